"""monoplot:batch with REGISTER (drift per frame in the log, a frame that cannot be registered reported) and with
SCHEDULER (the frames run on the workers of a Dask scheduler given by its address)."""

import csv
import json

import cv2
import pytest
from qgis.core import QgsProcessingException, QgsProcessingFeedback

from tests.workflow.conftest import timelapse_scene


def log_rows(path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def frames(tmp_path_factory):
    scene = timelapse_scene(tmp_path_factory.mktemp("register"), [(0.0, 0.0, 0.0), (1.0, -0.3, 0.0),
                                                                   (0.0, 0.0, 0.0), (-0.5, 0.2, 0.4)])
    # upside down: textured, but no small turn of the reference (a blank frame of fog is skipped before)
    cv2.imwrite(scene["frames"][2], cv2.imread(scene["frames"][2])[::-1, ::-1])
    return scene


def test_register_reports_the_drift_of_every_frame_and_the_one_it_cannot_register(run_alg, frames, tmp_path):
    feedback = QgsProcessingFeedback()
    result = run_alg("batch", {"MODE": 0, "DEM": frames["dem"], "FOLDER": frames["folder"], "REGISTER": True,
                               "CAMERA": frames["camera"], "XYZ": False, "OUTPUT": str(tmp_path / "out")}, feedback)
    assert result["SUCCEEDED"] == 3 and result["FAILED"] == 1
    rows = log_rows(result["LOG"])
    assert [r["status"] for r in rows] == ["ok", "ok", "failed", "ok"]
    assert "not registered" in rows[2]["message"] and rows[2]["drift_px"] == ""
    assert float(rows[0]["drift_px"]) < 0.1 and float(rows[1]["drift_deg"]) == pytest.approx(1.04, abs=0.05)
    # the turned frame's own camera, with the shared camera's verdict ("ok": a fitted camera): without one it
    # loaded "uncertain" in the dock while the shared camera, wrong on that frame, loaded "ok"
    turned = json.loads((tmp_path / "out" / "frame_001_camera.json").read_text())["fit"]
    assert turned["status"] == "ok" and "turned onto this frame" in turned["message"]
    assert "frame_002.png: FAILED, skipped: not registered" in feedback.textLog()


def test_register_is_on_by_default_and_left_aside_in_table_mode(run_alg, processing_provider, frames, tmp_path):
    """A time-lapse run with the defaults logged two bumped frames "ok, the shared camera" (a trial): every frame
    is re-registered unless asked not to. A table's photos are each fitted: REGISTER does not stop that mode."""
    assert processing_provider.algorithm("batch").parameterDefinition("REGISTER").defaultValue() is True
    result = run_alg("batch", {"MODE": 0, "DEM": frames["dem"], "FOLDER": frames["folder"],
                               "CAMERA": frames["camera"], "XYZ": False, "OUTPUT": str(tmp_path / "out")})
    rows = log_rows(result["LOG"])
    assert float(rows[1]["drift_deg"]) == pytest.approx(1.04, abs=0.05) and rows[2]["status"] == "failed"
    (tmp_path / "t.csv").write_text("photo,prior,points\na.png,b.json,c.csv\n")
    with pytest.raises(QgsProcessingException, match="No photo could be processed"):
        run_alg("batch", {"MODE": 1, "DEM": frames["dem"], "TABLE": str(tmp_path / "t.csv"), "REGISTER": True,
                          "OUTPUT": str(tmp_path / "out2")})


def test_scheduler_address_runs_the_frames_on_its_workers(run_alg, frames, tmp_path):
    import distributed

    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as c:
        feedback = QgsProcessingFeedback()
        result = run_alg("batch", {"MODE": 0, "REGISTER": False, "DEM": frames["dem"], "FOLDER": frames["folder"],
                                   "CAMERA": frames["camera"], "SCHEDULER": c.scheduler_address,
                                   "OUTPUT": str(tmp_path / "out")}, feedback)
    assert result["SUCCEEDED"] == 4
    assert f"on 1 worker(s) of {c.scheduler_address}" in feedback.textLog()
    assert len(list((tmp_path / "out").glob("*_ortho.tif"))) == 4 and (tmp_path / "out" / "xyz.tif").is_file()
