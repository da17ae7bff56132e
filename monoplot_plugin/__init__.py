"""Monoplot: georeference a single oblique photograph against a DEM.

Layout: ``core/`` is pure (numpy, torch, OpenCV, SciPy, GDAL; no Qt, no qgis); the rest adapts it to QGIS.
``plugin.py`` is what QGIS loads (via the repository root's ``classFactory``).
"""

from pathlib import Path

#: Repository / installed plugin folder: holds metadata.txt, icons/, ui/.
PLUGIN_DIR = Path(__file__).resolve().parent.parent


def plugin_version(metadata=PLUGIN_DIR / "metadata.txt"):
    """Version string from metadata.txt's [general] section, e.g. ``'0.1.0'``; ``'unknown'`` if unreadable."""
    try:
        for line in Path(metadata).read_text(encoding="utf-8").splitlines():
            key, _, value = line.partition("=")
            if key.strip() == "version":
                return value.strip()
    except OSError:
        pass
    return "unknown"
