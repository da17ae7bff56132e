"""Real QGIS desktop under Xvfb: the released plugin loads, its dock opens, a reload leaves nothing behind.

Starts ``qgis`` with an isolated profile and the unpacked release zip on QGIS_PLUGINPATH; the script
qgis_smoke_script.py runs inside QGIS and writes test-artifacts/desktop_smoke.{png,json}.
"""

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
SCRIPT = Path(__file__).with_name("qgis_smoke_script.py")


@pytest.fixture(scope="module")
def smoke_report(tmp_path_factory):
    if not (shutil.which("qgis") and shutil.which("xvfb-run")):
        if os.environ.get("CI"):
            pytest.fail("qgis or xvfb-run missing: run `make setup`")
        pytest.skip("qgis or xvfb-run missing: run `make setup`")
    tmp = tmp_path_factory.mktemp("desktop")
    subprocess.run([sys.executable, str(ROOT / "scripts" / "package.py"), "--output", str(tmp)], check=True,
                   capture_output=True, timeout=120)
    with zipfile.ZipFile(next(tmp.glob("monoplot-*.zip"))) as archive:
        archive.extractall(tmp / "plugins")  # -> plugins/monoplot/
    ARTIFACTS.mkdir(exist_ok=True)
    for old in ARTIFACTS.glob("desktop_smoke.*"):
        old.unlink()
    env = dict(os.environ, QGIS_PLUGINPATH=str(tmp / "plugins"), MONOPLOT_SMOKE_OUT=str(ARTIFACTS),
               # QGIS runs /usr/bin/python3: give it the venv's torch/cv2/scipy/numba, as a user's pip install would
               PYTHONPATH=sysconfig.get_paths()["purelib"], QT_QPA_PLATFORM="xcb", HOME=str(tmp / "home"))
    command = ["xvfb-run", "-a", "-s", "-screen 0 1600x1000x24", "qgis", "--nologo", "--noversioncheck",
               "--profiles-path", str(tmp / "profiles"), "--code", str(SCRIPT)]
    try:
        process = subprocess.run(command, env=env, capture_output=True, text=True, timeout=240,
                                 start_new_session=True)
    except subprocess.TimeoutExpired as expired:
        pytest.fail(f"QGIS did not quit within 240 s:\n{expired.stderr}")
    result_file = ARTIFACTS / "desktop_smoke.json"
    assert result_file.is_file(), f"QGIS exit {process.returncode}, no report:\n{process.stderr[-4000:]}"
    return json.loads(result_file.read_text())


def test_plugin_active_without_python_errors(smoke_report):
    assert smoke_report["script_error"] is None, smoke_report["script_error"]
    assert smoke_report["python_errors"] == [], json.dumps(smoke_report["python_errors"], indent=1)
    assert "monoplot" in smoke_report["active_plugins"]


def test_toolbar_menu_dock_and_reload_in_real_qgis(smoke_report):
    steps = {s["step"]: s for s in smoke_report["steps"]}
    assert steps["enable"]["loaded"] and steps["enable"]["started"]
    assert (steps["enable"]["actions"], steps["enable"]["raster_menu_entries"],
            steps["enable"]["toolbar_entries"]) == (1, 1, 1)
    assert steps["open_dock"]["dock_visible"] and steps["open_dock"]["docks"] == 1
    after_reload = steps["reload"]
    assert (after_reload["actions"], after_reload["docks"], after_reload["raster_menu_entries"],
            after_reload["toolbar_entries"]) == (1, 0, 1, 1)  # old ones gone, new plugin's added
    assert steps["open_dock_after_reload"]["dock_visible"] and steps["open_dock_after_reload"]["docks"] == 1
    assert (ARTIFACTS / "desktop_smoke.png").stat().st_size > 10_000


def test_processing_provider_registered_in_real_qgis(smoke_report):
    assert "monoplot" in [p.lower() for p in smoke_report["processing_providers"]]
