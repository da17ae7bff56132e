"""Real QGIS desktop under Xvfb: the released plugin loads, its dock opens, a reload leaves nothing behind.

Starts ``qgis`` with an isolated profile and the unpacked release zip on QGIS_PLUGINPATH; the script
qgis_smoke_script.py runs inside QGIS and writes test-artifacts/desktop_smoke.{png,json}.
"""

import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

from monoplot_plugin.deps import REQUIRED

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
SCRIPT = Path(__file__).with_name("qgis_smoke_script.py")


def run_qgis(tmp_path_factory, name, with_dependencies):
    """Start QGIS on the unpacked release zip; return the JSON report written by qgis_smoke_script.py."""
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
    for old in ARTIFACTS.glob(f"{name}.*"):
        old.unlink()
    env = dict(os.environ, QGIS_PLUGINPATH=str(tmp / "plugins"), MONOPLOT_SMOKE_OUT=str(ARTIFACTS),
               MONOPLOT_SMOKE_NAME=name, QT_QPA_PLATFORM="xcb", HOME=str(tmp / "home"))
    env.pop("PYTHONPATH", None)
    if with_dependencies:  # QGIS runs /usr/bin/python3: give it the venv's torch/cv2/scipy/numba, like a pip install
        env["PYTHONPATH"] = sysconfig.get_paths()["purelib"]
    command = ["xvfb-run", "-a", "-s", "-screen 0 1600x1000x24", "qgis", "--nologo", "--noversioncheck",
               "--profiles-path", str(tmp / "profiles"), "--code", str(SCRIPT)]
    try:
        process = subprocess.run(command, env=env, capture_output=True, text=True, timeout=360,
                                 start_new_session=True)
    except subprocess.TimeoutExpired as expired:
        pytest.fail(f"QGIS did not quit within 360 s:\n{expired.stderr}")
    result_file = ARTIFACTS / f"{name}.json"
    assert result_file.is_file(), f"QGIS exit {process.returncode}, no report:\n{process.stderr[-4000:]}"
    # 3: the script's watchdog ended a QGIS that did not quit (a "Save project?" question kept it open)
    return {**json.loads(result_file.read_text()), "qgis_exit": process.returncode}


@pytest.fixture(scope="module")
def smoke_report(tmp_path_factory):
    return run_qgis(tmp_path_factory, "desktop_smoke", with_dependencies=True)


@pytest.fixture(scope="module")
def missing_deps_report(tmp_path_factory):
    return run_qgis(tmp_path_factory, "desktop_missing_deps", with_dependencies=False)


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


def test_warm_up_runs_to_its_end_in_the_desktop(smoke_report):
    """Every kernel compiled cold in QGIS's own process, in the warm-up's thread: compiling the photo's skyline
    kernel there crashed the QGIS 3.40 desktop (signal 11 in LLVM), which the quick smoke steps never waited for."""
    warm_up = smoke_report["warm_up"]
    assert warm_up["status"] == "success" and warm_up["steps"] == ["fit", "render", "sight", "suggest"], warm_up


def test_quitting_qgis_after_the_dock_and_a_reload_asks_nothing(smoke_report):
    """Opening the dock and reloading the plugin wrote a blank Monoplot entry into the empty project: quitting
    QGIS asked "Do you want to save the current project?" and only the watchdog ended it (exit 3)."""
    assert smoke_report["qgis_exit"] == 0


def test_processing_provider_registered_in_real_qgis(smoke_report):
    assert "monoplot" in [p.lower() for p in smoke_report["processing_providers"]]


def qgis_python_lacks():
    """Packages the plugin needs that QGIS's own Python (Debian's, no venv) cannot find: the warning names these."""
    modules = [r.module for r in REQUIRED]
    code = f"import importlib.util as u; print(' '.join(m for m in {modules!r} if u.find_spec(m) is None))"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    result = subprocess.run(["/usr/bin/python3", "-c", code], capture_output=True, text=True, check=True, env=env)
    return [r.package for r in REQUIRED if r.module in result.stdout.split()]


def test_plugin_loads_with_missing_dependencies_and_says_what_to_install(missing_deps_report):
    """Debian's /usr/bin/python3 lacks the plugin's packages (3.22: torch, cv2, numba; 3.40: cv2, scipy, numba):
    a warning, not a crash. The dock stays closed (it would raise "No module named 'cv2'" at the first photo) and
    its button brings the warning back, once."""
    report = missing_deps_report
    assert report["script_error"] is None, report["script_error"]
    assert report["qgis_exit"] == 0  # QGIS quit by itself
    assert [e for e in report["python_errors"] if e["tag"] == "Python error"] == []
    assert "monoplot" in report["active_plugins"]
    steps = {s["step"]: s for s in report["steps"]}
    assert not steps["open_dock"]["dock_visible"]
    warnings = [text for text in report["message_bar"] if "Missing Python packages" in text]
    assert len(warnings) == 1  # the reload replaced, not duplicated, the warning
    lacking = qgis_python_lacks()
    assert lacking and f"Missing Python packages: {', '.join(lacking)}." in warnings[0]
    # Debian's interpreter (python3 or python3.X), not a python found on PATH, with the user-site flags and numpy kept
    assert re.search(r"/usr/bin/python3(\.\d+)? -m pip install --user --break-system-packages ", warnings[0])
    assert re.search(r" numpy==\d", warnings[0])
