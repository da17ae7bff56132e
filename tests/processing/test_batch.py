"""Batch algorithm: a time-lapse folder of 20 photos, one of them corrupted -> 19 outputs and one clear error."""

import csv
import json
import os

import numpy as np
import pytest
from osgeo import gdal
from qgis.core import QgsProcessingException, QgsProcessingFeedback

from tests.processing.conftest import write_photo


def recording_feedback():
    """A real feedback whose progress values are recorded (messages are read back from its text log)."""
    feedback = QgsProcessingFeedback()
    feedback.progress_values = []
    feedback.progressChanged.connect(lambda value: feedback.progress_values.append(value))
    return feedback


@pytest.fixture()
def timelapse(tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    for i in range(20):
        write_photo(folder / f"frame_{i:02d}.jpg", seed=i)
    (folder / "frame_07.jpg").write_bytes(b"\xff\xd8\xff\xe0 this is not a JPEG any more")
    return folder


def test_timelapse_batch_skips_the_corrupted_photo(run_alg, small_scene, timelapse, tmp_path):
    feedback = recording_feedback()
    out = tmp_path / "out"
    result = run_alg("batch", {"MODE": 0, "REGISTER": False, "DEM": small_scene["dem"], "FOLDER": str(timelapse),
                               "CAMERA": small_scene["fitted"], "XYZ": True, "ORTHO": True, "OUTPUT": str(out)},
                     feedback)
    assert result["SUCCEEDED"] == 19 and result["FAILED"] == 1
    orthos = sorted(p.name for p in out.glob("*_ortho.tif"))
    assert len(orthos) == 19 and "frame_07_ortho.tif" not in orthos
    assert (out / "xyz.tif").is_file()  # one XYZ raster for the shared camera
    log = feedback.textLog().splitlines()
    failures = [line for line in log if "FAILED, skipped" in line]
    assert len(failures) == 1
    assert "frame_07.jpg" in failures[0] and "cannot read the photo" in failures[0]
    # orthophotos differ per frame (each drapes its own photo)
    first, second = (gdal.Open(str(out / f"frame_0{i}_ortho.tif")) for i in (0, 1))
    assert not np.array_equal(first.GetRasterBand(1).ReadAsArray(), second.GetRasterBand(1).ReadAsArray())
    # cell size 0 means what it means in Orthophoto: the photo's own detail over the part seen (an archivist's batch
    # gave the DEM's 20 m cells over the whole DEM, 0.5 % of it covered, where Orthophoto gave 1.06 m)
    single = tmp_path / "single_ortho.tif"
    run_alg("orthophoto", {"CAMERA": small_scene["fitted"], "DEM": small_scene["dem"],
                           "PHOTO": str(timelapse / "frame_00.jpg"), "RESOLUTION": 0, "OUTPUT": str(single)})
    alone = gdal.Open(str(single))
    assert first.GetGeoTransform() == pytest.approx(alone.GetGeoTransform())
    assert (first.RasterXSize, first.RasterYSize) == (alone.RasterXSize, alone.RasterYSize)
    dem = gdal.Open(small_scene["dem"])
    assert first.GetGeoTransform()[1] != pytest.approx(dem.GetGeoTransform()[1])
    with open(result["LOG"], newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["status"] for r in rows].count("failed") == 1
    assert rows[0]["photo"] == "frame_00.jpg"  # relative to FOLDER, as in table mode
    assert max(feedback.progress_values) == pytest.approx(100.0)
    assert len(feedback.progress_values) >= 20  # progress per photo
    assert sum("/20] frame_" in line and ": ok" in line for line in log) == 19  # one line per good photo


def test_batch_table_mode_reports_missing_columns(run_alg, small_scene, tmp_path):
    table = tmp_path / "photos.csv"
    table.write_text("image,camera\nphoto.jpg,prior.json\n")
    with pytest.raises(QgsProcessingException, match="missing column"):
        run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(table), "OUTPUT": str(tmp_path)})


def test_timelapse_without_camera_is_refused(run_alg, small_scene, timelapse, tmp_path):
    with pytest.raises(QgsProcessingException, match="shared CAMERA"):
        run_alg("batch", {"MODE": 0, "DEM": small_scene["dem"], "FOLDER": str(timelapse), "OUTPUT": str(tmp_path)})


def test_table_batch_fits_each_photo_and_skips_a_bad_row(run_alg, small_scene, tmp_path):
    from monoplot_plugin.core.dem import Dem
    from monoplot_plugin.core.xyz import compute_xyz
    from monoplot_plugin.processing.inputs import write_points_csv

    cam = small_scene["cam"]
    xyz = compute_xyz(cam, Dem.open(small_scene["dem"]))
    rows, cols = np.nonzero(np.isfinite(xyz[..., 2]))
    pick = np.random.default_rng(5).choice(len(rows), 12, replace=False)
    world = xyz[rows[pick], cols[pick]]
    write_points_csv(str(tmp_path / "gcps.csv"), uv=cam.project(world), xyz=world)
    cam.with_parameters(heading=cam.heading - 1.0, y=cam.position[1] + 50).save(tmp_path / "prior.json")
    for name in ("a.png", "b.png", "c.png"):
        write_photo(tmp_path / name)
    write_photo(tmp_path / "d.png")
    (tmp_path / "photos.csv").write_text("photo,prior,points\n"
                                         "a.png,prior.json,gcps.csv\n"
                                         "b.png,no_such_prior.json,gcps.csv\n"
                                         "c.png,prior.json,gcps.csv\n"
                                         "d.png,prior.json,\n")
    out = tmp_path / "out"
    from qgis.core import QgsProcessingFeedback

    feedback, shown = QgsProcessingFeedback(), []
    feedback.progressChanged.connect(shown.append)
    result = run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(tmp_path / "photos.csv"),
                               "XYZ": True, "ORTHO": False, "OUTPUT": str(out)}, feedback)
    # progress within the rows reached the feedback while the batch ran, on this thread, as qgis_process needs it
    # (no event loop runs there: signals from the frames' threads came after the end, a trial saw no % in 90 s)
    assert any(abs(4 * p / 100.0 - round(4 * p / 100.0)) > 0.01 for p in shown), shown
    assert sorted(p.name for p in out.glob("*_camera.json")) == ["a_camera.json", "c_camera.json", "d_camera.json"]
    with open(result["LOG"], newline="") as fh:
        rows = {os.path.basename(r["photo"]): r for r in csv.DictReader(fh)}
    assert [name for name, r in rows.items() if r["status"] == "failed"] == ["b.png"]
    assert "camera file not found" in rows["b.png"]["message"]
    # a row without points is registered automatically from its prior (an archive with rough cameras only); on
    # this picture of noise not "ok", its log line and its camera JSON say so
    verdict = json.loads((out / "d_camera.json").read_text())["fit"]
    assert verdict["status"] in ("uncertain", "poor") and "automatic registration" in verdict["message"]
    assert rows["d.png"]["message"].startswith(f"fit {verdict['status']}")
    kept = "keeps the rough camera" in rows["d.png"]["message"]  # no camera found: the rough one is no product's
    if verdict["status"] == "poor" or kept:  # probably wrong: no products of it (a trial's batch wrote a camera 93
        # m off's)
        assert rows["d.png"]["status"] == "skipped" and "No products written" in rows["d.png"]["message"]
        assert not (out / "d_xyz.tif").exists() and result["SUCCEEDED"] == 2 and result["FAILED"] == 2
    else:
        assert rows["d.png"]["status"] == verdict["status"]  # the verdict, not "ok" (a trial)
        assert (out / "d_xyz.tif").exists() and result["SUCCEEDED"] == 3 and result["FAILED"] == 1
    assert rows["a.png"]["status"] == "ok" and rows["a.png"]["photo"] == "a.png"  # relative to the table's folder
    # a fitted row's camera file keeps the fit's σ, as the dock's and fitcamera's do (the dock reads it back)
    fitted = json.loads((out / "a_camera.json").read_text())["fit"]
    assert fitted["status"] == "ok" and fitted["mode"] == "paired" and fitted["rmse_px"] < 0.5
    assert set(fitted["sigma"]) >= {"x", "y", "z", "heading"} and 0.0 < fitted["sigma"]["x"] < 50.0
    # a rerun (RESUME by default) keeps what the first run made, tries the failed row again, and makes again the
    # rows whose points file changed
    before = {name: (out / name).stat().st_mtime_ns for name in ("a_camera.json", "d_camera.json")}
    feedback = recording_feedback()
    (tmp_path / "gcps.csv").write_text((tmp_path / "gcps.csv").read_text() + "\n")
    again = run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(tmp_path / "photos.csv"),
                              "XYZ": True, "ORTHO": False, "OUTPUT": str(out)}, feedback)
    assert (out / "a_camera.json").stat().st_mtime_ns != before["a_camera.json"]
    with open(again["LOG"], newline="") as fh:
        rows = {os.path.basename(r["photo"]): r for r in csv.DictReader(fh)}
    assert rows["b.png"]["status"] == "failed"
    if verdict["status"] == "poor" or kept:  # nothing was made of d: it is tried again, as the failed row is
        assert again["SUCCEEDED"] == 2 and rows["d.png"]["status"] == "skipped"
        return
    assert again["SUCCEEDED"] == 3 and "1 of 4 photos were done by an earlier run" in feedback.textLog()
    assert (out / "d_camera.json").stat().st_mtime_ns == before["d_camera.json"]
    assert rows["d.png"]["message"].startswith("done by an earlier run (resumed): fit")
    assert rows["d.png"]["status"] == verdict["status"]


def test_timelapse_fits_the_shared_camera_once_from_a_prior(run_alg, small_scene, timelapse, tmp_path):
    from monoplot_plugin.core.camera import Camera
    from monoplot_plugin.core.dem import Dem
    from monoplot_plugin.core.xyz import compute_xyz
    from monoplot_plugin.processing.inputs import write_points_csv

    cam = small_scene["cam"]
    xyz = compute_xyz(cam, Dem.open(small_scene["dem"]))
    rows, cols = np.nonzero(np.isfinite(xyz[..., 2]))
    pick = np.random.default_rng(8).choice(len(rows), 12, replace=False)
    world = xyz[rows[pick], cols[pick]]
    write_points_csv(str(tmp_path / "gcps.csv"), uv=cam.project(world), xyz=world)
    cam.with_parameters(heading=cam.heading + 1.5, x=cam.position[0] - 60).save(tmp_path / "prior.json")
    (timelapse / "frame_00.jpg").write_bytes(b"truncated")  # the first frame is bad too: the fit uses the next
    out = tmp_path / "out"
    result = run_alg("batch", {"MODE": 0, "REGISTER": False, "DEM": small_scene["dem"], "FOLDER": str(timelapse),
                               "CAMERA": str(tmp_path / "prior.json"), "POINTS": str(tmp_path / "gcps.csv"),
                               "XYZ": False, "ORTHO": True, "OUTPUT": str(out)})
    assert result["SUCCEEDED"] == 18 and result["FAILED"] == 2
    fitted = Camera.load(out / "camera.json")
    shared = json.loads((out / "camera.json").read_text())["fit"]
    assert shared["status"] and shared["sigma"]["heading"] > 0.0  # a rerun with it knows it was fitted, and how well
    assert np.linalg.norm(np.subtract(fitted.position, cam.position)) < 5.0
    assert abs(fitted.heading - cam.heading) < 0.1


def test_table_rows_registered_automatically_take_the_priors_uncertainty(run_alg, small_scene, tmp_path):
    """POSITION_SIGMA / ANGLE_SIGMA as monoplot:autoregister has them (the batch used 200 m / 5° for every row),
    and a row's own position_sigma / angle_sigma columns first."""
    cam = small_scene["cam"]
    cam.with_parameters(heading=cam.heading - 1.0).save(tmp_path / "prior.json")
    for name in ("a.png", "b.png"):
        write_photo(tmp_path / name, seed=3)
    (tmp_path / "photos.csv").write_text("photo,prior,points,position_sigma,angle_sigma\n"
                                         "a.png,prior.json,,,\n"
                                         "b.png,prior.json,,30,1.5\n")
    out = tmp_path / "out"

    class Recording(QgsProcessingFeedback):
        seen: list = []

        def setProgress(self, progress):  # noqa: N802 (QGIS API)
            self.seen.append(progress)
            super().setProgress(progress)

    feedback = Recording()
    run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(tmp_path / "photos.csv"), "XYZ": False,
                      "ORTHO": False, "POSITION_SIGMA": 80.0, "ANGLE_SIGMA": 2.0, "WORKERS": 1, "OUTPUT": str(out)},
            feedback)
    messages = [json.loads((out / f"{n}_camera.json").read_text())["fit"]["message"] for n in ("a", "b")]
    assert "prior σ 80 m, 2°" in messages[0] and "prior σ 30 m, 1.5°" in messages[1]
    # the bar moves while a row is registered, not only when it ends (a trial's sat at 0 % for 216 s), forward
    assert any(0.0 < p < 50.0 for p in feedback.seen) and any(50.0 < p < 100.0 for p in feedback.seen)
    assert all(b >= a - 1e-6 for a, b in zip(feedback.seen, feedback.seen[1:])), feedback.seen
    (tmp_path / "bad.csv").write_text("photo,prior,points,position_sigma\na.png,prior.json,,far\n")
    with pytest.raises(QgsProcessingException, match="bad.csv line 2: position_sigma 'far' is not a positive"):
        run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(tmp_path / "bad.csv"),
                          "OUTPUT": str(out)})


def test_a_cancel_stops_a_row_being_registered(run_alg, small_scene, tmp_path):
    """A trial's Ctrl+C let the frames under way be registered and written (12 s to stop): the registration of a
    row now checks the cancel too; the row is "canceled", its camera not written."""
    import threading

    from qgis.core import QgsProcessingFeedback

    cam = small_scene["cam"]
    cam.with_parameters(heading=cam.heading - 1.0).save(tmp_path / "prior.json")
    write_photo(tmp_path / "a.png", seed=3)
    (tmp_path / "photos.csv").write_text("photo,prior,points\na.png,prior.json,\n")
    out = tmp_path / "out"
    feedback = QgsProcessingFeedback()
    threading.Timer(0.3, feedback.cancel).start()  # while the row is being registered
    with pytest.raises(QgsProcessingException, match="Canceled: 0 photos processed, 1 not processed"):
        run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(tmp_path / "photos.csv"), "XYZ": False,
                          "ORTHO": False, "WORKERS": 1, "OUTPUT": str(out)}, feedback)
    with open(out / "batch_log.csv", newline="") as fh:
        row = next(csv.DictReader(fh))
    assert row["status"] == "canceled" and "canceled while processing" in row["message"], row
    assert not (out / "a_camera.json").exists()
    # the registration itself stops at the cancel (it ran to its end, 6 s here, before the camera was refused)
    from monoplot_plugin.core.dem import Dem
    from monoplot_plugin.workflow.batch import table_jobs
    from monoplot_plugin.workflow.files import read_photo
    from monoplot_plugin.workflow.frames import fit_job
    from monoplot_plugin.workflow.progress import Canceled

    job = table_jobs(str(tmp_path / "photos.csv"))[0]
    photo = read_photo(str(tmp_path / "a.png"))
    dem = Dem.open(small_scene["dem"])
    with pytest.raises(Canceled):
        fit_job(job, (photo.shape[1], photo.shape[0]), dem, dem.crs_wkt, photo, is_canceled=lambda: True)


def test_a_table_batch_canceled_while_rows_register_stops_its_bar_where_the_work_stopped(run_alg, small_scene,
                                                                                        tmp_path):
    """A trial canceled a table batch at 3 %: the bar jumped to 50 % (the two rows under way counted as done, their
    registrations reporting 100 % as they stopped)."""
    cam = small_scene["cam"]
    cam.with_parameters(heading=cam.heading - 1.0).save(tmp_path / "prior.json")
    names = ("a.png", "b.png", "c.png", "d.png")
    for name in names:
        write_photo(tmp_path / name, seed=3)
    (tmp_path / "photos.csv").write_text("photo,prior,points\n" + "".join(f"{n},prior.json,\n" for n in names))

    class CancelingInARow(QgsProcessingFeedback):
        seen: list = []
        at = None

        def setProgress(self, progress):  # noqa: N802 (QGIS API)
            self.seen.append(progress)
            if self.at is None and 0.0 < progress < 25.0:  # a row is registering
                self.at = len(self.seen)
                self.cancel()
            super().setProgress(progress)

    feedback = CancelingInARow()
    with pytest.raises(QgsProcessingException, match="Canceled: 0 photos processed, 4 not processed"):
        run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(tmp_path / "photos.csv"),
                          "XYZ": False, "ORTHO": False, "WORKERS": 2, "OUTPUT": str(tmp_path / "out")}, feedback)
    assert feedback.at is not None, feedback.seen
    assert max(feedback.seen) < 25.0, feedback.seen  # no row ended: not even a quarter done


def test_a_table_row_without_a_prior_starts_from_the_photos_exif_gps(run_alg, small_scene, tmp_path):
    """As autoregister: an empty prior cell is the photo's EXIF GPS (a trial made its four priors by hand in the
    dock: "FAILED, skipped: no camera file given"), with a GPS's 30 m of uncertainty; a photo without GPS fails with
    the reason."""
    from osgeo import gdal, osr

    cam = small_scene["cam"]
    src, dst = osr.SpatialReference(), osr.SpatialReference()
    src.ImportFromEPSG(32632)
    dst.ImportFromEPSG(4326)
    for srs in (src, dst):
        srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    # the scene's camera stands south of the DEM: its GPS fix here is inside it, at its south edge
    lon, lat, _ = osr.CoordinateTransformation(src, dst).TransformPoint(cam.position[0], 5097700.0)

    def dms(value):
        d, m = int(value), int((value - int(value)) * 60)
        return f"({d}) ({m}) ({(value - d - m / 60) * 3600:.4f})"

    write_photo(tmp_path / "plain.png", seed=3)
    mem = gdal.GetDriverByName("MEM").CreateCopy("", gdal.Open(str(tmp_path / "plain.png")))
    mem.SetMetadata({"EXIF_GPSLatitude": dms(lat), "EXIF_GPSLatitudeRef": "N", "EXIF_GPSLongitude": dms(lon),
                     "EXIF_GPSLongitudeRef": "E", "EXIF_GPSAltitude": f"({cam.position[2]:.1f})",
                     "EXIF_GPSImgDirection": f"({cam.heading % 360:.1f})", "EXIF_GPSImgDirectionRef": "T"})
    gdal.GetDriverByName("JPEG").CreateCopy(str(tmp_path / "gps.jpg"), mem)
    (tmp_path / "photos.csv").write_text("photo,prior,points\ngps.jpg,,\nplain.png,,\n")
    out = tmp_path / "out"

    class Texts(QgsProcessingFeedback):
        texts = []

        def setProgressText(self, text):  # noqa: N802 (QGIS API)
            self.texts.append(text)

    feedback = Texts()
    run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(tmp_path / "photos.csv"), "XYZ": False,
                      "ORTHO": False, "OUTPUT": str(out)}, feedback)
    # the row under way is named (a trial's bar sat at 0 % for 17-75 s with no word)
    assert "processing gps.jpg" in feedback.texts and "processing plain.png" in feedback.texts, feedback.texts
    # and only that: the dialog logs every progress text, and a frame's bare name repeated its log line (a trial)
    assert not {"gps.jpg", "plain.png"} & set(feedback.texts), feedback.texts
    rows = {r["photo"]: r for r in csv.DictReader(open(out / "batch_log.csv", encoding="utf-8"))}
    assert "prior from EXIF GPS, σ 30 m" in rows["gps.jpg"]["message"], rows["gps.jpg"]
    assert rows["gps.jpg"]["status"] in ("ok", "uncertain", "poor") and float(rows["gps.jpg"]["seconds"]) > 0
    assert rows["plain.png"]["status"] == "failed"
    assert "no prior camera in this row, and the photo has no GPS position" in rows["plain.png"]["message"]


def test_a_row_whose_registration_keeps_the_rough_camera_gets_no_products(run_alg, tmp_path):
    """A trial's indoor photo: the registration kept the rough camera (no camera found), and the batch wrote its
    XYZ raster and orthophoto and counted it processed. Its camera file is written with the reasons; no products,
    the row "skipped", logged as such."""
    import cv2

    from monoplot_plugin.core.camera import Camera
    from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain

    dem = synthetic_terrain((160, 160), cell=60.0, seed=1)  # a ridge-lined valley seen from its south end
    x0, y0, x1, y1 = dem.bounds()
    x, y = (x0 + x1) / 2, y0 + 0.03 * (y1 - y0)
    truth = Camera((x, y, float(dem.sample(x, y)) + 400.0), -5.0, -3.0, 0.5, 55.0, (480, 320), crs_wkt=dem.crs_wkt)
    dem.save(tmp_path / "dem.tif")
    clear = render_photo(truth, dem, seed=1).astype(float)  # in a thick fog: faint edges, no camera better
    faint = clear * 0.07 + 225.0 * 0.93 + np.random.default_rng(0).normal(0.0, 2.0, clear.shape)
    cv2.imwrite(str(tmp_path / "fog.png"), np.clip(faint, 0, 255).astype(np.uint8)[..., ::-1])
    truth.with_parameters(heading=truth.heading + 3.0, x=x + 60.0).save(tmp_path / "prior.json")
    (tmp_path / "photos.csv").write_text("photo,prior,points\nfog.png,prior.json,\n")
    out = tmp_path / "out"

    class Feedback(QgsProcessingFeedback):
        errors = []

        def reportError(self, text, fatal=False):  # noqa: N802
            self.errors.append(text)

    feedback = Feedback()
    with pytest.raises(QgsProcessingException):  # no photo processed
        run_alg("batch", {"MODE": 1, "DEM": str(tmp_path / "dem.tif"), "TABLE": str(tmp_path / "photos.csv"),
                          "XYZ": True, "ORTHO": True, "WORKERS": 1, "OUTPUT": str(out)}, feedback)
    with open(out / "batch_log.csv", newline="") as fh:
        row = next(csv.DictReader(fh))
    camera = json.loads((out / "fog_camera.json").read_text())
    assert camera["fit"]["status"] in ("uncertain", "poor") and "prior is kept" in camera["fit"]["message"]
    assert row["status"] == "skipped" and "No products written" in row["message"], row
    assert not (out / "fog_xyz.tif").exists() and not (out / "fog_ortho.tif").exists()
    assert any("fog.png: skipped" in m for m in feedback.errors), feedback.errors


def test_a_doubtful_rows_log_line_is_a_warning(run_alg, small_scene, tmp_path):
    """"uncertain" is logged as a warning (the README says so; a trial's were plain information lines)."""
    cam = small_scene["cam"]
    cam.with_parameters(heading=cam.heading - 1.0).save(tmp_path / "prior.json")
    write_photo(tmp_path / "noise.png", seed=5)  # no skyline: registered on chance matches, "uncertain"

    class Feedback(QgsProcessingFeedback):
        warnings = []

        def pushWarning(self, text):  # noqa: N802
            self.warnings.append(text)

    feedback = Feedback()
    (tmp_path / "photos.csv").write_text("photo,prior,points\nnoise.png,prior.json,\n")
    run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(tmp_path / "photos.csv"), "XYZ": False,
                      "ORTHO": False, "WORKERS": 1, "OUTPUT": str(tmp_path / "out")}, feedback)
    assert any(m.startswith("[1/1] noise.png: fit uncertain") for m in feedback.warnings), feedback.warnings
    # cut to a readable line (an archivist's rows ran to 700-1,800 characters), all of it in the log file
    line = next(m for m in feedback.warnings if m.startswith("[1/1] noise.png"))
    with open(tmp_path / "out" / "batch_log.csv", newline="") as fh:
        whole = next(csv.DictReader(fh))["message"]
    assert len(whole) > 600 and len(line) < 480 and line.endswith("(all of it in batch_log.csv)"), line


def test_a_row_whose_fit_is_poor_gets_its_camera_file_and_no_products(run_alg, small_scene, tmp_path):
    """A trial's batch wrote the XYZ raster and orthophoto of a registration 93 m off, "poor", and counted the row
    processed. A probably wrong camera makes no products: its camera file is written with the reasons, the row is
    "skipped" and says so; the good row beside it is made as before."""
    from monoplot_plugin.core.dem import Dem
    from monoplot_plugin.core.xyz import compute_xyz
    from monoplot_plugin.processing.inputs import write_points_csv

    cam = small_scene["cam"]
    xyz = compute_xyz(cam, Dem.open(small_scene["dem"]))
    rows, cols = np.nonzero(np.isfinite(xyz[..., 2]))
    world = xyz[rows, cols][np.random.default_rng(7).choice(len(rows), 10, replace=False)]
    uv = cam.project(world)
    write_points_csv(str(tmp_path / "good.csv"), uv=uv, xyz=world)
    write_points_csv(str(tmp_path / "scrambled.csv"), uv=uv, xyz=world[::-1])  # every pair linked wrongly
    cam.save(tmp_path / "prior.json")
    for name in ("good.png", "bad.png"):
        write_photo(tmp_path / name)
    (tmp_path / "photos.csv").write_text("photo,prior,points\ngood.png,prior.json,good.csv\n"
                                         "bad.png,prior.json,scrambled.csv\n")
    out = tmp_path / "out"
    result = run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(tmp_path / "photos.csv"),
                               "XYZ": True, "ORTHO": True, "WORKERS": 1, "OUTPUT": str(out)})
    with open(result["LOG"], newline="") as fh:
        logged = {os.path.basename(r["photo"]): r for r in csv.DictReader(fh)}
    assert json.loads((out / "bad_camera.json").read_text())["fit"]["status"] == "poor"
    assert logged["bad.png"]["status"] == "skipped" and "No products written" in logged["bad.png"]["message"]
    assert not (out / "bad_xyz.tif").exists() and not (out / "bad_ortho.tif").exists()
    assert logged["good.png"]["status"] == "ok" and (out / "good_xyz.tif").exists() and (out / "good_ortho.tif").exists()
    assert result["SUCCEEDED"] == 1


def test_table_rows_say_how_sure_an_ok_fit_is_and_name_a_doubted_gcp(run_alg, small_scene, tmp_path):
    """An archivist's batch: an "ok" row read only "ok, fit RMSE 0.99 px" (its 3 check points' RMSE in no column or
    file), a check-point column named "type" (CP / GCP) was ignored and its check points fitted, and a wrong GCP
    was "the pair at photo pixel (662, 262)" where fitcamera names it "G6"."""
    from monoplot_plugin.core.dem import Dem
    from monoplot_plugin.core.xyz import compute_xyz

    cam = small_scene["cam"]
    xyz = compute_xyz(cam, Dem.open(small_scene["dem"]))
    rows, cols = np.nonzero(np.isfinite(xyz[..., 2]))
    pick = np.random.default_rng(11).choice(len(rows), 12, replace=False)
    world = xyz[rows[pick], cols[pick]]
    uv = cam.project(world)

    def table(path, shift_g6=0.0):
        lines = ["id,u,v,X,Y,Z,type"]
        for k, ((u, v), (x, y, z)) in enumerate(zip(uv, world)):
            x += shift_g6 if k == 5 else 0.0
            lines.append(f"G{k + 1},{u:.2f},{v:.2f},{x:.2f},{y:.2f},{z:.2f},{'CP' if k >= 9 else 'GCP'}")
        path.write_text("\n".join(lines) + "\n")

    table(tmp_path / "good.csv")
    table(tmp_path / "bad.csv", shift_g6=400.0)
    cam.with_parameters(heading=cam.heading - 1.0, y=cam.position[1] + 50).save(tmp_path / "prior.json")
    write_photo(tmp_path / "a.png")
    write_photo(tmp_path / "b.png")
    (tmp_path / "photos.csv").write_text("photo,prior,points\na.png,prior.json,good.csv\nb.png,prior.json,bad.csv\n")
    out = tmp_path / "out"
    result = run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(tmp_path / "photos.csv"),
                               "XYZ": False, "ORTHO": False, "WORKERS": 1, "OUTPUT": str(out)})
    with open(result["LOG"], newline="") as fh:
        logged = {os.path.basename(r["photo"]): r for r in csv.DictReader(fh)}
    good = json.loads((out / "a_camera.json").read_text())["fit"]
    assert logged["a.png"]["status"] == "ok" and good["n_check"] == 3 and good["check_rmse_px"] < 1.0
    assert "3 check points" in logged["a.png"]["message"] and "leave-one-out" in logged["a.png"]["message"]
    assert logged["b.png"]["status"] != "ok"
    assert "G6" in logged["b.png"]["message"], logged["b.png"]["message"]


def test_a_time_lapse_batch_of_photos_from_other_viewpoints_points_to_the_table_mode(run_alg, small_scene, tmp_path):
    """An archivist kept the dialog's default mode (time-lapse) for a folder of photos from different places and read
    only "photo is 1200x800 px but the shared camera is for 1200x900 px" per photo."""
    from tests.processing.conftest import HEIGHT, WIDTH

    folder = tmp_path / "archive"
    folder.mkdir()
    write_photo(folder / "a.jpg")
    for i, size in enumerate([(WIDTH + 40, HEIGHT), (WIDTH, HEIGHT + 30), (WIDTH - 20, HEIGHT - 10)]):
        write_photo(folder / f"other_{i}.jpg", size=size, seed=i)

    class Feedback(QgsProcessingFeedback):
        warnings = []

        def pushWarning(self, text):  # noqa: N802
            self.warnings.append(text)

    feedback = Feedback()
    result = run_alg("batch", {"MODE": 0, "REGISTER": False, "DEM": small_scene["dem"], "FOLDER": str(folder),
                               "CAMERA": small_scene["fitted"], "XYZ": False, "ORTHO": True,
                               "OUTPUT": str(tmp_path / "out")}, feedback)
    assert result["SUCCEEDED"] == 1 and result["FAILED"] == 3
    assert any(w.startswith("3 of 4 photos differ in size") and "CSV table mode" in w for w in feedback.warnings), \
        feedback.warnings
