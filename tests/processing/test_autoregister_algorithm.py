"""monoplot:autoregister through processing.run: a rendered scene from a JSON prior, and a clear refusal."""

import json

import cv2
import numpy as np
import pytest
from qgis.core import QgsProcessingException

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain


@pytest.fixture(scope="module")
def rendered_scene(tmp_path_factory):
    """A generated DEM (GeoTIFF), a photo rendered from a hidden camera (PNG) and a prior 2.5 deg / 50 m off."""
    folder = tmp_path_factory.mktemp("auto")
    dem = synthetic_terrain((120, 120), cell=80.0, seed=3)
    x0, y0, x1, y1 = dem.bounds()
    x, y = (x0 + x1) / 2, y0 + 0.03 * (y1 - y0)
    truth = Camera((x, y, float(dem.sample(x, y)) + 400.0), -5.0, -3.0, 0.0, 55.0, (360, 240), crs_wkt=dem.crs_wkt)
    dem.save(folder / "dem.tif")
    cv2.imwrite(str(folder / "photo.png"), render_photo(truth, dem, seed=2)[..., ::-1])
    prior = truth.with_parameters(heading=truth.heading + 2.5, pitch=truth.pitch + 1.0, x=x + 50.0)
    prior.save(folder / "prior.json")
    return {"dir": folder, "truth": truth}


def test_autoregister_writes_a_camera_and_its_status(run_alg, rendered_scene, tmp_path):
    d = rendered_scene["dir"]
    out = tmp_path / "camera.json"
    from qgis.core import QgsProcessingFeedback

    class Stages(QgsProcessingFeedback):  # what the algorithm dialog shows above its bar (and in its log)
        said = []

        def setProgressText(self, text):  # noqa: N802 (QGIS API)
            self.said.append(text)
            super().setProgressText(text)

    feedback = Stages()
    result = run_alg("autoregister", {"PHOTO": str(d / "photo.png"), "DEM": str(d / "dem.tif"),
                                      "PRIOR": str(d / "prior.json"), "POSITION_SIGMA": 100.0, "ANGLE_SIGMA": 3.0,
                                      "OUTPUT": str(out), "MATCHED": str(tmp_path / "matched.csv")}, feedback)
    assert result["STATUS"] in ("ok", "uncertain", "poor") and result["MESSAGE"]
    # the pairs the camera rests on, to check (an archivist was told to "check the matched points" and had none)
    from monoplot_plugin.workflow.points_csv import read_points_csv

    matched = read_points_csv(result["MATCHED"])
    assert len(matched["uv"]) == result["N_MATCHED"] > 0 and np.isfinite(matched["xyz"]).all()
    # each stage said once in the dialog (a trial's 24 s run said nothing of what it did)
    assert feedback.said.count("Automatic registration: coarse search of the view direction") == 1, feedback.said
    cam = Camera.load(out)
    truth = rendered_scene["truth"]
    # the file names the heading as an azimuth (354.7 for -5.3)
    assert abs((cam.heading - truth.heading + 180.0) % 360.0 - 180.0) < 1.0 and abs(cam.pitch - truth.pitch) < 1.0
    assert 0.0 <= cam.heading < 360.0
    assert json.loads(out.read_text())["crs_wkt"]
    assert result["N_MATCHED"] >= 0 and np.isfinite(result["RMSE_PX"]) or result["STATUS"] == "poor"


def test_autoregister_holds_a_camera_on_the_ground_when_asked(run_alg, rendered_scene, tmp_path):
    """A phone trial: an EXIF altitude 14 m too high, and autoregister had no way to hold the camera on the ground,
    as the dock's Find camera does: it ended 20.7 m too high. ON_GROUND and EYE_HEIGHT, as fitcamera's."""
    from monoplot_plugin.core.dem import Dem

    d = rendered_scene["dir"]
    out = tmp_path / "camera.json"
    run_alg("autoregister", {"PHOTO": str(d / "photo.png"), "DEM": str(d / "dem.tif"), "PRIOR": str(d / "prior.json"),
                             "POSITION_SIGMA": 20.0, "ON_GROUND": 1, "EYE_HEIGHT": 2.5, "OUTPUT": str(out)})
    cam = Camera.load(out)
    dem = Dem.open(str(d / "dem.tif"))
    ground = float(dem.sample(cam.position[0], cam.position[1], to_extent=True))
    assert cam.position[2] - ground == pytest.approx(2.5, abs=0.5)


def test_autoregister_without_prior_or_gps_says_what_to_give(run_alg, rendered_scene, tmp_path):
    d = rendered_scene["dir"]
    with pytest.raises(QgsProcessingException, match="GPS|prior"):
        run_alg("autoregister", {"PHOTO": str(d / "photo.png"), "DEM": str(d / "dem.tif"),
                                 "OUTPUT": str(tmp_path / "c.json")})


def test_a_doubtful_registrations_camera_carries_its_verdict_to_the_products(run_alg, rendered_scene, tmp_path):
    """A trial chained autoregister on a photo of fog into computexyz: the camera (the prior, "uncertain") was
    written as any other and the XYZ raster made from it without a word. The JSON now keeps the verdict, and a
    product made from a camera that is not "ok" warns."""
    from tests.processing.conftest import recording_feedback

    d = rendered_scene["dir"]
    rng = np.random.default_rng(5)
    fog = np.clip(200 + rng.normal(0, 3, (240, 360, 3)), 0, 255).astype(np.uint8)
    cv2.imwrite(str(tmp_path / "fog.png"), fog)
    out = tmp_path / "camera.json"
    result = run_alg("autoregister", {"PHOTO": str(tmp_path / "fog.png"), "DEM": str(d / "dem.tif"),
                                      "PRIOR": str(d / "prior.json"), "OUTPUT": str(out)})
    assert result["STATUS"] in ("uncertain", "poor")
    written = json.loads(out.read_text())["fit"]
    assert written["status"] == result["STATUS"] and written["message"] == result["MESSAGE"]
    log = recording_feedback()
    run_alg("computexyz", {"CAMERA": str(out), "DEM": str(d / "dem.tif"), "OUTPUT": str(tmp_path / "xyz.tif")},
            log)
    assert any(f'verdict was "{result["STATUS"]}"' in w for w in log.warnings)
    from osgeo import gdal  # the XYZ raster says it too, as the dock's does

    kept = json.loads(gdal.Open(str(tmp_path / "xyz.tif")).GetMetadataItem("MONOPLOT_FIT"))
    assert kept["status"] == result["STATUS"]
    # a camera its fit called ok, or one written without a verdict, warns of nothing
    Camera.load(out).save(tmp_path / "plain.json")
    quiet = recording_feedback()
    run_alg("computexyz", {"CAMERA": str(tmp_path / "plain.json"), "DEM": str(d / "dem.tif"),
                           "OUTPUT": str(tmp_path / "xyz2.tif")}, quiet)
    assert not quiet.warnings


def test_a_camera_fitted_on_one_photo_is_not_ok_for_another(run_alg, rendered_scene, tmp_path):
    """A time-lapse trial used frame 1's "ok" camera for frame 5 (the mount turned 4 degrees): its products were
    168 m off, said "ok". The camera file names the photo its verdict is about; products of another photo warn,
    and their XYZ raster says "uncertain"; products of the same photo do not."""
    from osgeo import gdal

    from tests.processing.conftest import recording_feedback
    from monoplot_plugin.workflow.camera_files import camera_json

    d = rendered_scene["dir"]
    camera = tmp_path / "frame1_camera.json"
    camera.write_text(camera_json(rendered_scene["truth"], {"status": "ok", "message": "fitted"},
                                  str(d / "photo.png")))
    other = tmp_path / "photo.png"  # the same name and size, other pixels
    cv2.imwrite(str(other), 255 - cv2.imread(str(d / "photo.png")))
    for photo, warned in ((d / "photo.png", False), (other, True)):
        log = recording_feedback()
        out = tmp_path / f"xyz_{warned}.tif"
        run_alg("computexyz", {"CAMERA": str(camera), "DEM": str(d / "dem.tif"), "PHOTO": str(photo),
                               "OUTPUT": str(out)}, log)
        assert any("fitted on another photo (photo.png)" in w for w in log.warnings) == warned, log.warnings
        kept = json.loads(gdal.Open(str(out)).GetMetadataItem("MONOPLOT_FIT"))
        assert kept["status"] == ("uncertain" if warned else "ok")


def test_any_heading_finds_a_view_the_prior_looks_away_from(run_alg, rendered_scene, tmp_path):
    """A viewpoint known, its direction not (a print's caption names the summit it was taken from): ANY_HEADING
    searches every direction of view."""
    d = rendered_scene["dir"]
    truth = rendered_scene["truth"]
    truth.with_parameters(heading=truth.heading + 100.0, x=truth.position[0] + 50.0).save(tmp_path / "away.json")
    result = run_alg("autoregister", {"PHOTO": str(d / "photo.png"), "DEM": str(d / "dem.tif"),
                                      "PRIOR": str(tmp_path / "away.json"), "ANY_HEADING": True,
                                      "POSITION_SIGMA": 100.0, "OUTPUT": str(tmp_path / "camera.json")})
    cam = Camera.load(tmp_path / "camera.json")
    assert abs((cam.heading - truth.heading + 180.0) % 360.0 - 180.0) < 1.0 and abs(cam.pitch - truth.pitch) < 1.0
    assert result["MESSAGE"].startswith("The direction of view was not known") and result["STATUS"] != "poor"


def test_the_position_uncertainty_defaults_to_a_gps_error_for_an_exif_prior(processing_provider):
    """A phone trial: the dialog filled 200 m for its EXIF GPS prior, the dock took 30 m, and the same photo came out
    "uncertain" in Processing and "ok" in the dock. Empty by default: 30 m for EXIF GPS, 200 m for a camera file."""
    from monoplot_plugin.workflow.auto import DEFAULT_POSITION_SIGMA_M, GPS_POSITION_SIGMA_M

    parameter = processing_provider.algorithm("autoregister").parameterDefinition("POSITION_SIGMA")
    assert parameter.defaultValue() is None and parameter.flags() & parameter.FlagOptional
    assert f"Empty: {GPS_POSITION_SIGMA_M:.0f} m for the photo's EXIF GPS position, " \
           f"{DEFAULT_POSITION_SIGMA_M:.0f} m for a prior camera file" in parameter.toolTip()
    # a surveyed camera position (GNSS, ± 0.5 m) is accepted, as the dock accepts it (a time-lapse trial's was
    # refused with "Incorrect parameter value"), in the batch too
    assert parameter.checkValueIsAcceptable(0.5) and not parameter.checkValueIsAcceptable(0.0)
    batch = processing_provider.algorithm("batch").parameterDefinition("POSITION_SIGMA")
    assert batch.checkValueIsAcceptable(0.5)
