"""Run Monoplot's algorithms with the ``qgis_process`` binary, from a source checkout, headless.

What QGIS 3.22's ``qgis_process`` needs to see a plugin's provider:

- the plugin folder, named ``monoplot``, in a directory listed in ``QGIS_PLUGINPATH`` (here a symbolic link to the
  checkout, in a scratch directory);
- the plugin enabled in the profile's settings (``[PythonPlugins] monoplot=true`` in ``QGIS3.ini``) and its
  metadata saying ``hasProcessingProvider=yes``; ``qgis_process`` then imports it and calls ``initProcessing()``.
  An isolated profile (``QGIS_CUSTOM_CONFIG_PATH``) keeps the user's own QGIS settings untouched;
- the Python packages of the venv (torch, OpenCV): ``qgis_process`` embeds the system Python, so the venv's
  site-packages go on ``PYTHONPATH``;
- ``QT_QPA_PLATFORM=offscreen`` without a display.

Debian's ``/usr/bin/qgis_process`` wrapper passes ``$QGIS_OPTS`` from ``/etc/default/qgis`` (``--noversioncheck``),
which ``qgis_process.bin`` 3.22 rejects ("Command --noversioncheck not known!"), so the binary is called directly.

Usage from a shell (prints the environment to export, then runs)::

    python -m monoplot_plugin.processing.cli run monoplot:fitcamera -- PHOTO=photo.jpg DEM=dem.tif ...

(or export the environment of :func:`prepare_environment` and call ``qgis_process.bin`` yourself).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path
from typing import Dict, List, Optional, Sequence

REPO_ROOT = Path(__file__).resolve().parents[2]
PLUGIN_NAME = "monoplot"


def qgis_process_binary() -> str:
    """Path of the qgis_process executable (the Debian ``.bin`` behind the wrapper when present)."""
    for name in ("qgis_process.bin", "qgis_process"):
        for folder in ("/usr/bin", "/usr/local/bin"):
            candidate = os.path.join(folder, name)
            if os.access(candidate, os.X_OK):
                return candidate
        found = shutil.which(name)
        if found:
            return found
    raise FileNotFoundError("qgis_process not found: install QGIS (Debian: apt install qgis)")


def prepare_environment(work_dir: Optional[str] = None, plugin_dir: Path = REPO_ROOT) -> Dict[str, str]:
    """Environment variables under which ``qgis_process`` loads the Monoplot provider from ``plugin_dir``.

    Creates ``<work_dir>/plugins/monoplot`` (a link to the checkout) and an isolated profile in
    ``<work_dir>/profile`` with the plugin enabled.
    """
    work = Path(work_dir or tempfile.mkdtemp(prefix="monoplot-qgis-"))
    plugins = work / "plugins"
    plugins.mkdir(parents=True, exist_ok=True)
    link = plugins / PLUGIN_NAME
    if link.is_symlink() and link.resolve() != Path(plugin_dir).resolve():
        link.unlink()
    if not link.exists():
        link.symlink_to(Path(plugin_dir).resolve(), target_is_directory=True)
    profile = work / "profile"
    ini = profile / "profiles" / "default" / "QGIS" / "QGIS3.ini"
    ini.parent.mkdir(parents=True, exist_ok=True)
    text = ini.read_text(encoding="utf-8") if ini.exists() else ""
    if f"{PLUGIN_NAME}=true" not in text:
        with open(ini, "a", encoding="utf-8") as fh:
            fh.write(f"\n[PythonPlugins]\n{PLUGIN_NAME}=true\n")
    env = dict(os.environ)
    site = sysconfig.get_paths()["purelib"]  # the venv's site-packages when run with .venv/bin/python
    env.update({
        "QGIS_PLUGINPATH": str(plugins),
        "QGIS_CUSTOM_CONFIG_PATH": str(profile),
        "QT_QPA_PLATFORM": env.get("QT_QPA_PLATFORM", "offscreen"),
        "PYTHONPATH": os.pathsep.join(p for p in (site, env.get("PYTHONPATH", "")) if p),
        "XDG_RUNTIME_DIR": env.get("XDG_RUNTIME_DIR", str(work / "runtime")),
        # numba's on-disk cache records the module name of each compiled function; inside QGIS the package is
        # "monoplot.monoplot_plugin", in a checkout "monoplot_plugin": they must not share a cache folder
        "NUMBA_CACHE_DIR": os.path.join(tempfile.gettempdir(), f"monoplot-numba-qgis-{os.getuid()}"),
    })
    Path(env["XDG_RUNTIME_DIR"]).mkdir(parents=True, exist_ok=True, mode=0o700)
    return env


def parameter_arguments(parameters: Dict[str, object]) -> List[str]:
    """``NAME=value`` arguments, to follow qgis_process's ``--`` separator (lists repeat the parameter; booleans
    as true/false).

    >>> parameter_arguments({"DEM": "dem.tif", "PAIRED": False, "LAYERS": ["a", "b"]})
    ['DEM=dem.tif', 'PAIRED=false', 'LAYERS=a', 'LAYERS=b']
    """
    args = []
    for name, value in parameters.items():
        values = value if isinstance(value, (list, tuple)) else [value]
        for v in values:
            if isinstance(v, bool):
                v = "true" if v else "false"
            args.append(f"{name}={v}")
    return args


class QgisProcessError(RuntimeError):
    """qgis_process failed; the message holds its output."""


def run(algorithm: str, parameters: Dict[str, object], env: Dict[str, str], timeout: float = 300) -> dict:
    """Run ``qgis_process --json run <algorithm> -- params``; returns the parsed JSON (``results`` etc.).

    Raises QgisProcessError with qgis_process's own messages when it fails.
    """
    command = [qgis_process_binary(), "--json", "run", algorithm, "--", *parameter_arguments(parameters)]
    proc = subprocess.run(command, env=env, capture_output=True, text=True, timeout=timeout)
    start = proc.stdout.find("{")
    if proc.returncode != 0 or start < 0:
        raise QgisProcessError(f"qgis_process run {algorithm} failed (exit {proc.returncode}):\n"
                               f"{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout[start:])


def main(argv: Sequence[str]) -> int:
    """``python -m monoplot_plugin.processing.cli <qgis_process arguments>``: same arguments as qgis_process."""
    env = prepare_environment(os.environ.get("MONOPLOT_QGIS_WORK"))
    return subprocess.call([qgis_process_binary(), *argv], env=env)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
