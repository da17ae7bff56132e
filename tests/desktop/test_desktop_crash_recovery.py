"""Real QGIS desktop under Xvfb: work a crash left in a never-saved project opens the dock once QGIS has started.

Opened while QGIS was still starting, the restored work made the start's new project "modified": QGIS asked
whether to save it before its window showed, and "Discard" there would have thrown the work away.
"""

import json
import os
import shutil
import subprocess
import sysconfig
import time

import pytest

from monoplot_plugin.state import ProjectState
from test_desktop_smoke import ARTIFACTS, ROOT

SCRIPT = ROOT / "tests" / "desktop" / "crash_recovery_script.py"


def test_work_left_by_a_crash_comes_back_once_qgis_has_started(tmp_path):
    if not (shutil.which("qgis") and shutil.which("xvfb-run")):
        if os.environ.get("CI"):
            pytest.fail("qgis or xvfb-run missing: run `make setup`")
        pytest.skip("qgis or xvfb-run missing: run `make setup`")
    profile = tmp_path / "profiles" / "default"
    (profile / "QGIS").mkdir(parents=True)
    (profile / "QGIS" / "QGIS3.ini").write_text("[PythonPlugins]\nmonoplot=true\n")  # loaded as QGIS starts
    (profile / "python" / "plugins").mkdir(parents=True)
    os.symlink(ROOT, profile / "python" / "plugins" / "monoplot")  # as a user's install: in the profile
    state = ProjectState()
    state.settings["overlay_opacity"] = 27
    left = profile / "monoplot" / "autosave-unsaved-project.json"  # what the crashed session's autosave wrote
    left.parent.mkdir()
    left.write_text(state.snapshot()())
    an_hour_ago = time.time() - 3600
    os.utime(left, (an_hour_ago, an_hour_ago))
    ARTIFACTS.mkdir(exist_ok=True)
    out = ARTIFACTS / "desktop_crash_recovery.json"
    out.unlink(missing_ok=True)
    env = dict(os.environ, MONOPLOT_CRASH_REPORT=str(out),
               QT_QPA_PLATFORM="xcb", HOME=str(tmp_path / "home"), PYTHONPATH=sysconfig.get_paths()["purelib"])
    command = ["xvfb-run", "-a", "-s", "-screen 0 1600x1000x24", "qgis", "--nologo", "--noversioncheck",
               "--profiles-path", str(tmp_path), "--code", str(SCRIPT)]  # its profiles/default
    try:
        process = subprocess.run(command, env=env, capture_output=True, text=True, timeout=150,
                                 start_new_session=True)
    except subprocess.TimeoutExpired as expired:
        pytest.fail(f"QGIS never ran the script (a question while it started?):\n{expired.stderr}")
    assert out.is_file(), f"QGIS exit {process.returncode}, no report:\n{process.stderr[-3000:]}"
    report = json.loads(out.read_text())
    assert report["dock_open"] and not report["modal"], report
    assert report["overlay_opacity"] == 27 and "ended without its project being saved" in report["status"], report
    assert report["project_modified"]  # closing QGIS asks to save it
