"""Build the release zip for plugins.qgis.org: ``dist/monoplot-<version>.zip`` with one top folder ``monoplot/``.

Included: root ``__init__.py``, ``metadata.txt``, ``LICENSE``, ``resources.qrc`` and its compiled
``resources_rc.py``, ``monoplot_plugin/``, ``ui/``, ``icons/``. Never: tests, caches, ``.pyc``, git, venv, data.

Usage: ``python scripts/package.py [--output dist]`` (``make package``).
"""

import argparse
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TOP_FOLDER = "monoplot"
FILES = ("__init__.py", "metadata.txt", "LICENSE", "resources.qrc", "resources_rc.py")
FOLDERS = ("monoplot_plugin", "ui", "icons")
EXCLUDED_PARTS = {"__pycache__", "tests", ".git", ".venv", "data", ".pytest_cache"}
EXCLUDED_SUFFIXES = {".pyc", ".pyo", ".orig", ".rej", ".swp"}


def plugin_version(root=ROOT):
    for line in (root / "metadata.txt").read_text(encoding="utf-8").splitlines():
        if line.startswith("version="):
            return line.partition("=")[2].strip()
    raise SystemExit("metadata.txt has no version=")


def packaged_files(root=ROOT):
    """Relative paths (sorted) of every file that goes into the zip."""
    missing = [name for name in FILES if not (root / name).is_file()]
    if missing:
        raise SystemExit(f"missing {missing}: run `make setup` first (resources_rc.py comes from `make resources`)")
    paths = [Path(name) for name in FILES]
    for folder in FOLDERS:
        for path in sorted((root / folder).rglob("*")):
            relative = path.relative_to(root)
            if path.is_file() and not EXCLUDED_PARTS & set(relative.parts) and path.suffix not in EXCLUDED_SUFFIXES:
                paths.append(relative)
    return sorted(paths)


def build(output_dir, root=ROOT):
    """Write the zip and return its path."""
    output_dir = Path(output_dir)
    output_dir.mkdir(parents=True, exist_ok=True)
    archive_path = output_dir / f"{TOP_FOLDER}-{plugin_version(root)}.zip"
    with zipfile.ZipFile(archive_path, "w", zipfile.ZIP_DEFLATED) as archive:
        for relative in packaged_files(root):
            archive.write(root / relative, f"{TOP_FOLDER}/{relative.as_posix()}")
    return archive_path


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", default=str(ROOT / "dist"), help="folder for the zip (default: dist)")
    args = parser.parse_args(argv)
    path = build(args.output)
    with zipfile.ZipFile(path) as archive:
        count = len(archive.namelist())
    print(f"{path} ({count} files, {path.stat().st_size / 1024:.0f} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
