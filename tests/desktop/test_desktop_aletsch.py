"""The scripted Aletsch sessions in the real QGIS desktop under Xvfb (tests/gui/run_desktop_aletsch.sh and
tests/outputs/run_desktop_outputs.sh): they must finish without a Python error, and their figures must hold.

Screenshots land in test-artifacts/ (aletsch_*.png, outputs_desktop.png): look at them.
"""

import json
import os
import shutil
import subprocess

import pytest

from test_desktop_smoke import ARTIFACTS, ROOT


def run_script(script, report_name, aletsch_dir, tmp_path):
    if not (shutil.which("qgis") and shutil.which("xvfb-run")):
        if os.environ.get("CI"):
            pytest.fail("qgis or xvfb-run missing: run `make setup`")
        pytest.skip("qgis or xvfb-run missing: run `make setup`")
    report = ARTIFACTS / report_name
    report.unlink(missing_ok=True)
    env = dict(os.environ, MONOPLOT_ALETSCH=str(aletsch_dir), MONOPLOT_DESKTOP_HOME=str(tmp_path),
               QT_QPA_PLATFORM="xcb")
    process = subprocess.run(["bash", str(ROOT / script)], env=env, capture_output=True, text=True, timeout=300,
                             start_new_session=True)
    assert report.is_file(), f"{script}: exit {process.returncode}, no report:\n{process.stdout[-3000:]}"
    data = json.loads(report.read_text())
    assert data["errors"] == [], "\n".join(data["errors"])
    assert process.returncode == 0, process.stdout[-3000:]
    return data


def test_aletsch_session_in_the_desktop_fits_within_15_px_on_its_check_points(aletsch_dir, tmp_path):
    data = run_script("tests/gui/run_desktop_aletsch.sh", "aletsch_session.json", aletsch_dir, tmp_path)
    steps = {s["step"]: s for s in data["steps"]}
    check = steps["gcp_check"]
    assert check["n_check"] == 11 and check["rmse_px"] <= 15.0
    assert "Check points" in check["summary"]
    assert steps["cursor_map_to_photo"]["pixel"] is not None
    assert all((ARTIFACTS / f"aletsch_{n}").is_file() for n in
               ("1_suggestions.png", "2_fit.png", "3_floating.png", "4_residuals_closeup.png"))


def test_outputs_session_in_the_desktop_maps_what_was_drawn(aletsch_dir, tmp_path):
    data = run_script("tests/outputs/run_desktop_outputs.sh", "outputs_desktop.json", aletsch_dir, tmp_path)
    assert data["finished"]
    assert data["map_features"]["polygon"] == 1 and data["map_features"]["line"] == 1
    assert data["map_features"]["point"] >= 5
    assert 0.1 < data["area_km2"] < 20.0  # the lower glacier tongue traced on the photo: a few km²
    assert data["overlay_pieces"]["visible"] > 0
