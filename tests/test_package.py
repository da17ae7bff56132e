"""`make package`'s zip passes the checks plugins.qgis.org makes: layout, metadata fields, licence, no junk."""

import configparser
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
REQUIRED_METADATA = ("name", "qgisMinimumVersion", "description", "about", "version", "author", "email",
                     "tracker", "repository", "category", "icon")


@pytest.fixture(scope="module")
def unpacked(tmp_path_factory):
    out = tmp_path_factory.mktemp("dist")
    subprocess.run([sys.executable, str(ROOT / "scripts" / "package.py"), "--output", str(out)], check=True,
                   capture_output=True, text=True, timeout=120)
    zips = list(out.glob("*.zip"))
    assert [z.name for z in zips] == ["monoplot-0.1.0.zip"]
    with zipfile.ZipFile(zips[0]) as archive:
        assert archive.testzip() is None
        names = archive.namelist()
        archive.extractall(out / "unpacked")
    return names, out / "unpacked"


def test_one_lowercase_top_folder_with_the_plugin_parts(unpacked):
    names, folder = unpacked
    assert {name.split("/")[0] for name in names} == {"monoplot"}
    plugin = folder / "monoplot"
    for required in ("__init__.py", "metadata.txt", "LICENSE", "resources.qrc", "resources_rc.py",
                     "monoplot_plugin/plugin.py", "monoplot_plugin/core/camera.py", "ui/dock.ui", "icons/monoplot.svg"):
        assert (plugin / required).is_file(), required
    assert "GNU GENERAL PUBLIC LICENSE" in (plugin / "LICENSE").read_text() and "Version 2" in (plugin / "LICENSE").read_text()


def test_no_tests_caches_vcs_venv_or_data(unpacked):
    names, _ = unpacked
    forbidden = re.compile(r"(^|/)(tests|__pycache__|\.git|\.venv|venv|data|\.pytest_cache|dist|test-artifacts)(/|$)"
                           r"|\.pyc$|\.pyo$|\.(tif|jpg|csv|kml)$")
    assert [name for name in names if forbidden.search(name)] == []


def test_metadata_has_every_required_field(unpacked):
    _, folder = unpacked
    parser = configparser.ConfigParser(interpolation=None)
    parser.optionxform = str
    parser.read(folder / "monoplot" / "metadata.txt", encoding="utf-8")
    meta = parser["general"]
    assert [key for key in REQUIRED_METADATA if not meta.get(key, "").strip()] == []
    assert meta["name"] == "Monoplot" and meta["qgisMinimumVersion"] == "3.22" and meta["category"] == "Raster"
    assert re.fullmatch(r"\d+\.\d+\.\d+", meta["version"])
    assert (folder / "monoplot" / meta["icon"]).is_file()
    for package in ("torch", "opencv-python-headless", "scipy", "numba"):
        assert package in meta["about"]
    assert meta["tracker"].startswith("https://") and meta["repository"].startswith("https://")
    if (folder / "monoplot/monoplot_plugin/processing/provider.py").is_file():
        assert meta.get("hasProcessingProvider") == "yes"


def test_unpacked_plugin_imports_as_package_monoplot(unpacked):
    """The unzipped folder is importable under its installed name, with the compiled icon resources."""
    _, folder = unpacked
    code = ("import monoplot, monoplot.resources_rc; from qgis.PyQt.QtCore import QFile; "
            "from monoplot.monoplot_plugin.plugin import MonoplotPlugin, plugin_icon_path; "
            "print(plugin_icon_path(), callable(monoplot.classFactory))")
    result = subprocess.run([sys.executable, "-c", code], cwd=folder, capture_output=True, text=True, timeout=120,
                            env={"PYTHONPATH": str(folder), "QT_QPA_PLATFORM": "offscreen", "PATH": "/usr/bin:/bin"})
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == [":/plugins/monoplot/icons/monoplot.svg", "True"]
