"""Fit camera algorithm through processing.run: paired CSV, unpaired layers, KML prior, clear refusals."""

import json
import re

import cv2
import numpy as np
import pytest
from qgis.core import QgsFeature, QgsGeometry, QgsPoint, QgsProcessingException, QgsVectorLayer

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.dem import Dem
from monoplot_plugin.core.xyz import compute_xyz
from monoplot_plugin.processing.inputs import write_points_csv


@pytest.fixture(scope="module")
def ground_truth(small_scene):
    """20 ground points seen by the scene camera, their exact pixels, and a prior off by 60 m and 2 degrees."""
    cam = small_scene["cam"]
    xyz = compute_xyz(cam, Dem.open(small_scene["dem"]))
    rng = np.random.default_rng(3)
    rows, cols = np.nonzero(np.isfinite(xyz[..., 2]))
    pick = rng.choice(len(rows), 20, replace=False)
    world = xyz[rows[pick], cols[pick]]
    pixels = cam.project(world)
    prior = cam.with_parameters(x=cam.position[0] + 50, y=cam.position[1] - 30, heading=cam.heading + 1.5,
                                pitch=cam.pitch - 1.0, fov=cam.fov + 2.0)
    prior_path = small_scene["dir"] / "prior.json"
    prior.save(prior_path)
    return {"world": world, "pixels": pixels, "prior": str(prior_path), "prior_cam": prior}


def test_fit_from_paired_csv_recovers_the_camera(run_alg, small_scene, ground_truth, tmp_path):
    gcps = tmp_path / "gcps.csv"
    write_points_csv(str(gcps), uv=ground_truth["pixels"], xyz=ground_truth["world"])
    out = tmp_path / "camera.json"
    result = run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                                   "PRIOR": ground_truth["prior"], "PHOTO_CSV": str(gcps), "OUTPUT": str(out)})
    fitted = Camera.load(out)
    truth = small_scene["cam"]
    assert result["RMSE_PX"] < 0.5 and result["N_PHOTO"] == 20
    assert np.linalg.norm(np.subtract(fitted.position, truth.position)) < 5.0
    assert abs(fitted.heading - truth.heading) < 0.1 and abs(fitted.fov - truth.fov) < 0.2
    assert json.loads(out.read_text())["crs_wkt"]  # the DEM's CRS travels with the camera
    # ... and the photo it was fitted on: products of another photo warn (a trial's camera of photo 2 made photo 3's
    # XYZ raster 60 m off, silently)
    from monoplot_plugin.workflow.camera_files import fitted_on_photo, photo_fingerprint

    fit = json.loads(out.read_text())["fit"]
    assert fit["photo_sha256"] == photo_fingerprint(small_scene["photo"])
    assert fitted_on_photo(fit, small_scene["photo"]) is True
    other = tmp_path / "other.png"
    cv2.imwrite(str(other), 255 - cv2.imread(small_scene["photo"]))
    assert fitted_on_photo(fit, str(other)) is False


def test_the_tables_check_column_keeps_check_points_out_of_the_fit(run_alg, small_scene, ground_truth, tmp_path):
    """A desktop trial: the dock fitted a GCP table's 6 control pairs and measured its 2 check points; fitcamera
    fitted all 8 and said nothing of checks. Check points are measured, not fitted, here too: one of them 40 px off
    shows in CHECK_RMSE_PX and leaves the fit's own residuals clean."""
    pixels = ground_truth["pixels"].copy()
    check = np.zeros(len(pixels), dtype=bool)
    check[[3, 11, 17]] = True
    pixels[3] += (40.0, 0.0)  # a check point placed 40 px off: it must not pull the camera
    gcps = tmp_path / "gcps.csv"
    write_points_csv(str(gcps), uv=pixels, xyz=ground_truth["world"], check=check)
    out = tmp_path / "camera.json"
    result = run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                                   "PRIOR": ground_truth["prior"], "PHOTO_CSV": str(gcps), "OUTPUT": str(out)})
    assert result["N_PHOTO"] == 17 and result["N_CHECK"] == 3
    assert result["RMSE_PX"] < 0.5  # the 40 px point is not among the fitted ones
    assert 40.0 / np.sqrt(3) - 1.0 < result["CHECK_RMSE_PX"] < 40.0 / np.sqrt(3) + 1.0
    fitted = Camera.load(out)
    assert np.linalg.norm(np.subtract(fitted.position, small_scene["cam"].position)) < 5.0


def test_a_pair_the_fit_doubts_is_named_by_the_tables_id(run_alg, small_scene, ground_truth, tmp_path):
    """A trial's message said "check the pair at photo pixel (1100, 650)" where her table called it GCP4: the
    MESSAGE (and the camera file) name it by the table's id."""
    world = ground_truth["world"][:12].copy()
    world[3, 2] += 60.0  # one surveyed height typed wrong
    gcps = tmp_path / "gcps.csv"
    write_points_csv(str(gcps), uv=ground_truth["pixels"][:12], xyz=world, ids=[f"GCP{i + 1}" for i in range(12)])
    out = tmp_path / "camera.json"
    result = run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                                   "PRIOR": ground_truth["prior"], "PHOTO_CSV": str(gcps), "OUTPUT": str(out)})
    named = re.search(r"photo pixel \((\d+), (\d+)\), GCP4", result["MESSAGE"])
    assert result["STATUS"] != "ok" and named, result["MESSAGE"]
    assert np.allclose([float(named.group(1)), float(named.group(2))], ground_truth["pixels"][3], atol=1.0)
    assert "GCP4" in json.loads(out.read_text())["fit"]["message"]


def test_a_prior_made_for_a_crop_is_a_rough_start_and_said_so(run_alg, small_scene, ground_truth, tmp_path):
    """A prior camera of a photo of another shape (the full print, for a cropped scan): kept as a start, with a
    note; the fit recovers this photo's camera."""
    from tests.processing.conftest import recording_feedback

    prior = ground_truth["prior_cam"]
    other = tmp_path / "prior_other_shape.json"
    other.write_text(Camera.from_dict(
        {**prior.to_dict(), "image_size": [prior.width, int(prior.height * 1.4)]}).to_json())
    gcps = tmp_path / "gcps.csv"
    write_points_csv(str(gcps), uv=ground_truth["pixels"], xyz=ground_truth["world"])
    out = tmp_path / "camera.json"
    feedback = recording_feedback()
    result = run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"], "PRIOR": str(other),
                                   "PHOTO_CSV": str(gcps), "OUTPUT": str(out)}, feedback)
    assert any("another shape" in line and "rough start" in line for line in feedback.infos)
    fitted = Camera.load(out)
    assert result["RMSE_PX"] < 0.5 and fitted.image_size == small_scene["cam"].image_size
    assert np.linalg.norm(np.subtract(fitted.position, small_scene["cam"].position)) < 5.0


def point_layer(points, crs=""):
    kind = "PointZ" if points.shape[1] == 3 else "Point"
    layer = QgsVectorLayer(f"{kind}?crs={crs}" if crs else kind, "pts", "memory")
    features = []
    for p in points:
        f = QgsFeature()
        f.setGeometry(QgsGeometry(QgsPoint(*p) if len(p) == 3 else QgsPoint(p[0], -p[1])))
        features.append(f)
    layer.dataProvider().addFeatures(features)
    return layer


def test_fit_from_unpaired_layers_with_different_counts(run_alg, small_scene, ground_truth, tmp_path):
    photo_layer = point_layer(ground_truth["pixels"][:16])          # 16 photo points (x = u, y = -v)
    dem_layer = point_layer(ground_truth["world"][2:], "EPSG:32632")  # 18 DEM points, not in the same order
    out = tmp_path / "camera.json"
    result = run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                                   "PRIOR": ground_truth["prior"], "PHOTO_POINTS": photo_layer,
                                   "DEM_POINTS": dem_layer, "PAIRED": False, "OUTPUT": str(out)})
    fitted = Camera.load(out)
    check = fitted.project(ground_truth["world"]) - ground_truth["pixels"]
    assert result["N_PHOTO"] == 16 and result["N_DEM"] == 18
    assert np.sqrt(np.mean(check ** 2)) < 1.0  # every point, including the ones only one side had


def test_paired_counts_must_match(run_alg, small_scene, ground_truth, tmp_path):
    with pytest.raises(QgsProcessingException, match="as many photo points as DEM points"):
        run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                              "PRIOR": ground_truth["prior"], "PAIRED": True,
                              "PHOTO_POINTS": point_layer(ground_truth["pixels"][:10]),
                              "DEM_POINTS": point_layer(ground_truth["world"][:12], "EPSG:32632"),
                              "OUTPUT": str(tmp_path / "c.json")})


def test_no_points_is_a_clear_error(run_alg, small_scene, ground_truth, tmp_path):
    with pytest.raises(QgsProcessingException, match="needs photo points and DEM points"):
        run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                              "PRIOR": ground_truth["prior"], "OUTPUT": str(tmp_path / "c.json")})


def test_a_table_in_another_crs_than_the_dem_says_where_its_points_went(run_alg, small_scene, ground_truth,
                                                                          tmp_path):
    """GCPs in another CRS than the DEM file's (here 500 km off, no Z): every DEM point is dropped; the refusal says
    they were left out and in which CRS tables are read, not just "0 DEM points"."""
    gcps = tmp_path / "gcps_elsewhere.csv"
    elsewhere = np.column_stack([ground_truth["world"][:, :2] + 5e5, np.full(20, np.nan)])
    write_points_csv(str(gcps), uv=ground_truth["pixels"], xyz=elsewhere)
    with pytest.raises(QgsProcessingException, match=r"20 DEM points were left out: outside the DEM, or not in "
                                                     r"the DEM file's CRS \(EPSG:32632\)"):
        run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                              "PRIOR": ground_truth["prior"], "PHOTO_CSV": str(gcps),
                              "OUTPUT": str(tmp_path / "c.json")})


def test_heights_in_feet_against_a_dem_in_metres_are_said(run_alg, small_scene, ground_truth, tmp_path):
    """A trial's DEM in feet without its unit tag: the fit ended "poor", 800 px, advising to check the pairs, and
    nothing hinted at feet. Heights 3.28 times (or 0.305 times) the DEM's are a warning that names the unit."""
    from tests.processing.conftest import recording_feedback

    gcps = tmp_path / "gcps_feet.csv"
    write_points_csv(str(gcps), uv=ground_truth["pixels"], xyz=ground_truth["world"] * [1.0, 1.0, 1.0 / 0.3048])
    log = recording_feedback()
    try:
        result = run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                                       "PRIOR": ground_truth["prior"], "PHOTO_CSV": str(gcps),
                                       "OUTPUT": str(tmp_path / "c.json")}, log)
    except QgsProcessingException:
        result = None  # refused or not: what matters is that the log names the unit
    assert any("have heights about 3.28 times the DEM's there" in w and "feet" in w for w in log.warnings), log.warnings
    if result is not None:  # and a failed fit says so in words ("RMSE nan px (too few pairs ...)" with 12 pairs)
        assert "nan" not in result["MESSAGE"] and "too few pairs" not in result["MESSAGE"], result["MESSAGE"]
    quiet = recording_feedback()  # heights in metres: no such warning
    write_points_csv(str(gcps), uv=ground_truth["pixels"], xyz=ground_truth["world"])
    run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"], "PRIOR": ground_truth["prior"],
                          "PHOTO_CSV": str(gcps), "OUTPUT": str(tmp_path / "c.json")}, quiet)
    assert not any("times the DEM's" in w for w in quiet.warnings)


def test_a_wide_lens_distortion_is_fitted_when_asked(run_alg, small_scene, ground_truth, tmp_path):
    """A phone trial's 26 mm lens (k1 -0.06): the dock fits k1, fitcamera could not. LENS frees k1."""
    cam = small_scene["cam"].with_parameters(k1=-0.06)
    gcps = tmp_path / "gcps.csv"
    write_points_csv(str(gcps), uv=cam.project(ground_truth["world"]), xyz=ground_truth["world"])
    rmse = {}
    for lens in (0, 1):
        out = tmp_path / f"camera_{lens}.json"
        result = run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                                       "PRIOR": ground_truth["prior"], "PHOTO_CSV": str(gcps), "LENS": lens,
                                       "OUTPUT": str(out)})
        rmse[lens] = result["RMSE_PX"]
        if lens:
            assert Camera.load(out).k1 == pytest.approx(-0.06, abs=0.01)
        else:
            assert Camera.load(out).k1 == 0.0  # the prior's, not fitted
    assert rmse[1] < 0.1 * rmse[0], rmse


def test_photo_points_outside_the_image_are_refused(run_alg, small_scene, ground_truth, tmp_path):
    gcps = tmp_path / "gcps.csv"
    write_points_csv(str(gcps), uv=ground_truth["pixels"] * 10, xyz=ground_truth["world"])
    with pytest.raises(QgsProcessingException, match="outside the 160x120 photo"):
        run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                              "PRIOR": ground_truth["prior"], "PHOTO_CSV": str(gcps),
                              "OUTPUT": str(tmp_path / "c.json")})


def test_a_table_with_u_and_v_the_other_way_round_is_swapped(run_alg, small_scene, ground_truth, tmp_path):
    """A trial's GCP table with v first: refused as "outside the photo" here, and in the dock its rows off the photo
    were rejected and the rest fitted wrong. Several points off the photo as given, all on it swapped: swapped."""
    from tests.processing.conftest import recording_feedback

    uv = ground_truth["pixels"]
    assert (uv[:, 0] > 120).sum() >= 2  # as given (v, u), those rows lie below the 160 x 120 photo
    gcps = tmp_path / "gcps.csv"
    write_points_csv(str(gcps), uv=uv[:, ::-1], xyz=ground_truth["world"])
    feedback = recording_feedback()
    result = run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                                   "PRIOR": ground_truth["prior"], "PHOTO_CSV": str(gcps),
                                   "OUTPUT": str(tmp_path / "c.json")}, feedback)
    assert result["RMSE_PX"] < 0.5
    assert any("u and v the other way round" in line for line in feedback.warnings), feedback.warnings


def test_aletsch_paired_fit_from_kml_prior(run_alg, aletsch_dir, tmp_path):
    """The real case: 11 hand GCPs, the rough KML PhotoOverlay prior, the Int16 DEM with 0 voids."""
    out = tmp_path / "aletsch.json"
    result = run_alg("fitcamera", {"PHOTO": str(aletsch_dir / "photo.jpg"), "DEM": str(aletsch_dir / "dem.tif"),
                                   "VOID_VALUE": 0, "PRIOR": str(aletsch_dir / "prior_pose.kml"),
                                   "PHOTO_CSV": str(aletsch_dir / "gcps.csv"), "OUTPUT": str(out)})
    fitted = Camera.load(out)
    assert fitted.image_size == (1024, 763)
    assert result["N_PHOTO"] == 11 and result["RMSE_PX"] < 12.0  # published least squares: about 7.7 px


def test_a_prints_principal_point_is_its_pictures_centre(run_alg, aletsch_dir, tmp_path):
    """The Aletsch photo as a scanned print: uneven paper border and a caption under it. The optical axis goes
    through the picture's centre, not the scan's: the paired fit on the 11 GCPs gets the photo's own optimum
    (7.7 px), where the scan's centre costs accuracy (a generated print: 13.5 px against 12.4 px)."""
    import cv2

    from monoplot_plugin.core.fit import fit_camera
    from tests.processing.conftest import recording_feedback

    photo = cv2.imread(str(aletsch_dir / "photo.jpg"))
    left, top, right, bottom = 40, 30, 160, 150
    h, w = photo.shape[:2]
    scan = np.full((h + top + bottom, w + left + right, 3), (228, 232, 235), np.uint8)  # paper
    scan[top:top + h, left:left + w] = photo
    cv2.putText(scan, "Aletschgletscher vom Eggishorn 1891", (left + 40, top + h + 90), cv2.FONT_HERSHEY_SIMPLEX,
                1.2, (40, 40, 40), 3)
    cv2.imwrite(str(tmp_path / "print.png"), scan)
    gcps = np.loadtxt(aletsch_dir / "gcps.csv", delimiter=",", skiprows=1)
    gcps[:, :2] += (left, top)
    write_points_csv(str(tmp_path / "gcps.csv"), uv=gcps[:, :2], xyz=gcps[:, 2:])
    out, log = tmp_path / "camera.json", recording_feedback()
    result = run_alg("fitcamera", {"PHOTO": str(tmp_path / "print.png"), "DEM": str(aletsch_dir / "dem.tif"),
                                   "VOID_VALUE": 0, "PRIOR": str(aletsch_dir / "prior_pose.kml"),
                                   "PHOTO_CSV": str(tmp_path / "gcps.csv"), "PAIRED": True, "OUTPUT": str(out)}, log)
    fitted = Camera.load(out)
    assert any("Principal point at the picture's centre" in line for line in log.infos)
    assert abs(fitted.cx - (left + w / 2)) < 8 and abs(fitted.cy - (top + h / 2)) < 8
    # the scan's centre, for comparison: the same pairs, the same prior
    prior = Camera.from_kml(str(aletsch_dir / "prior_pose.kml"), (scan.shape[1], scan.shape[0]), fitted.crs_wkt)
    pairs = np.column_stack([np.arange(len(gcps))] * 2)
    at_scan_centre = fit_camera(gcps[:, :2], gcps[:, 2:], prior, pairs=pairs).rmse_px
    assert result["RMSE_PX"] < 8.0 < at_scan_centre


def test_canceled_feedback_stops_the_fit(run_alg, small_scene, ground_truth, tmp_path):
    from qgis.core import QgsProcessingFeedback

    gcps = tmp_path / "gcps.csv"
    write_points_csv(str(gcps), uv=ground_truth["pixels"], xyz=ground_truth["world"])
    feedback = QgsProcessingFeedback()
    feedback.cancel()
    out = tmp_path / "camera.json"
    with pytest.raises(QgsProcessingException, match="canceled"):
        run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                              "PRIOR": ground_truth["prior"], "PHOTO_CSV": str(gcps), "OUTPUT": str(out)}, feedback)
    assert not out.exists()


def test_camera_height_is_automatic_by_default_as_in_the_dock(run_alg, small_scene, tmp_path):
    """A prior 15 m above the terrain is held on the ground at that height by default (the dock's rule), until 20
    exact pairs that say 40 m free it (the workflow's F test); "in the air" frees the height; "on the ground" (index 1,
    the former boolean's true) holds it at the eye height given, whatever the pairs say."""
    dem = Dem.open(small_scene["dem"])
    high = small_scene["cam"]
    x, y = high.position[0], high.position[1] + 1500.0  # over the DEM (the scene camera stands south of it)
    truth = high.with_parameters(y=y, z=float(dem.sample(x, y)) + 40.0, pitch=-5.0)
    xyz = compute_xyz(truth, dem)
    rows, cols = np.nonzero(np.isfinite(xyz[..., 2]))
    pick = np.random.default_rng(5).choice(len(rows), 20, replace=False)
    world = xyz[rows[pick], cols[pick]]
    gcps = tmp_path / "gcps.csv"
    write_points_csv(str(gcps), uv=truth.project(world), xyz=world)
    px, py = x + 20.0, y - 15.0
    prior = truth.with_parameters(x=px, y=py, z=float(dem.sample(px, py)) + 15.0, heading=truth.heading + 1.0)
    prior_path = tmp_path / "low_prior.json"
    prior.save(prior_path)

    def clearance(params):
        out = tmp_path / "camera.json"
        run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"], "PRIOR": str(prior_path),
                              "PHOTO_CSV": str(gcps), "OUTPUT": str(out), **params})
        fitted = Camera.load(out)
        return fitted.position[2] - float(dem.sample(fitted.position[0], fitted.position[1]))

    assert clearance({}) == pytest.approx(40.0, abs=1.0)
    assert clearance({"ON_GROUND": 2}) == pytest.approx(40.0, abs=1.0)
    assert clearance({"ON_GROUND": 1, "EYE_HEIGHT": 2.0}) == pytest.approx(2.0, abs=0.05)


def test_a_verdict_is_logged_at_its_own_level():
    """"ok" is information, "uncertain" a warning (it was a block of red, as an error), "poor" an error; the status
    leads the line."""
    from qgis.core import QgsProcessingFeedback

    from monoplot_plugin.processing.base import report_status

    class Recording(QgsProcessingFeedback):
        def __init__(self):
            super().__init__()
            self.seen = []

        def pushInfo(self, info):  # noqa: N802 (QGIS API)
            self.seen.append(("info", info))

        def pushWarning(self, warning):  # noqa: N802
            self.seen.append(("warning", warning))

        def reportError(self, error, fatalError=False):  # noqa: N802, N803
            self.seen.append(("error", error))

    feedback = Recording()
    for status in ("ok", "uncertain", "poor"):
        report_status(feedback, "Fit", status, "what it found.")
    assert feedback.seen == [("info", "Fit ok: what it found."), ("warning", "Fit uncertain: what it found."),
                             ("error", "Fit poor: what it found.")]


def test_dem_points_without_z_are_said_to_take_the_dems_height(run_alg, small_scene, ground_truth, tmp_path):
    from qgis.core import QgsProcessingFeedback

    gcps = tmp_path / "gcps_no_z.csv"
    write_points_csv(str(gcps), uv=ground_truth["pixels"],
                     xyz=np.column_stack([ground_truth["world"][:, :2], np.full(20, np.nan)]))
    feedback = QgsProcessingFeedback()
    run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"], "PRIOR": ground_truth["prior"],
                          "PHOTO_CSV": str(gcps), "OUTPUT": str(tmp_path / "c.json")}, feedback)
    assert "20 of the 20 DEM points have no Z: the DEM's height there is used" in feedback.textLog()


def test_paired_gcps_need_no_prior(run_alg, small_scene, ground_truth, tmp_path):
    """Six or more paired GCPs: PRIOR may be left out, the camera comes from the pairs alone; fewer, or unpaired
    points, still need it, and the refusal says so."""
    gcps = tmp_path / "gcps.csv"
    write_points_csv(str(gcps), uv=ground_truth["pixels"], xyz=ground_truth["world"])
    out = tmp_path / "camera.json"
    result = run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                                   "PHOTO_CSV": str(gcps), "OUTPUT": str(out)})
    fitted, truth = Camera.load(out), small_scene["cam"]
    assert result["STATUS"] == "ok" and result["RMSE_PX"] < 0.5
    assert np.linalg.norm(np.subtract(fitted.position, truth.position)) < 5.0
    assert abs((fitted.heading - truth.heading + 180) % 360 - 180) < 0.1
    few = tmp_path / "few.csv"
    write_points_csv(str(few), uv=ground_truth["pixels"][:5], xyz=ground_truth["world"][:5])
    with pytest.raises(QgsProcessingException, match="A prior camera is needed"):
        run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"], "PHOTO_CSV": str(few),
                              "OUTPUT": str(tmp_path / "c.json")})


def test_a_number_with_a_decimal_comma_is_refused_not_read_as_another(run_alg, small_scene, ground_truth, tmp_path):
    """A German-locale trial: qgis_process ... EYE_HEIGHT=1,7 fitted as if the height were 0, with no word (QGIS lets
    an optional number that is no number through). It is refused, saying what to write."""
    gcps = tmp_path / "gcps.csv"
    write_points_csv(str(gcps), uv=ground_truth["pixels"], xyz=ground_truth["world"])
    given = {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"], "PRIOR": ground_truth["prior"],
             "PHOTO_CSV": str(gcps), "OUTPUT": str(tmp_path / "camera.json")}
    with pytest.raises(QgsProcessingException, match=r'EYE_HEIGHT "1,7" is not a number \(write 1.7 with a decimal'):
        run_alg("fitcamera", {**given, "EYE_HEIGHT": "1,7"})
    with pytest.raises(QgsProcessingException, match=r'EYE_HEIGHT "1.700,5" is not a number$'):
        run_alg("fitcamera", {**given, "EYE_HEIGHT": "1.700,5"})
    assert run_alg("fitcamera", {**given, "EYE_HEIGHT": "1.7"})["STATUS"]  # a decimal point: read as given


def test_known_parameters_are_kept_at_the_priors_values(run_alg, small_scene, ground_truth, tmp_path):
    """A drone trial had 3 GCPs and the lens from EXIF: refused, with no way to fix the field of view here as the
    dock's fit settings can. FIXED keeps it (or the position, height, angles) at the prior camera's values: with the
    lens and the drone's height known, 3 GCPs leave one equation to spare."""
    truth = small_scene["cam"]
    prior = ground_truth["prior_cam"].with_parameters(fov=truth.fov)  # the lens and the height known
    prior_path = tmp_path / "prior_lens.json"
    prior.save(prior_path)
    gcps = tmp_path / "three.csv"
    pick = [0, 7, 13]
    write_points_csv(str(gcps), uv=ground_truth["pixels"][pick], xyz=ground_truth["world"][pick])
    params = {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"], "PRIOR": str(prior_path),
              "PHOTO_CSV": str(gcps), "OUTPUT": str(tmp_path / "camera.json")}
    with pytest.raises(QgsProcessingException, match="3"):  # seven unknowns, six equations
        run_alg("fitcamera", params)
    result = run_alg("fitcamera", {**params, "FIXED": [1, 5]})  # the height and the field of view
    fitted = Camera.load(tmp_path / "camera.json")
    assert fitted.fov == pytest.approx(truth.fov, abs=1e-9) and fitted.position[2] == pytest.approx(prior.position[2])
    assert np.linalg.norm(np.subtract(fitted.position, truth.position)) < 5.0 and result["RMSE_PX"] < 0.5
    # fixing without a prior to take the values from is refused, saying why
    with pytest.raises(QgsProcessingException, match="PRIOR"):
        run_alg("fitcamera", {**{k: v for k, v in params.items() if k != "PRIOR"}, "FIXED": [5]})
