"""Batch algorithm on the awkward frames of a real time-lapse: truncated JPEGs, two frames with the same name, a
re-run into the same folder, a camera in another CRS or one that sees no terrain, a KML camera, a table saved with
';' by a spreadsheet, missing mode parameters."""

import csv

import numpy as np
import pytest
from osgeo import osr
from qgis.core import QgsProcessingException, QgsProcessingFeedback

from tests.processing.conftest import HEIGHT, WIDTH, write_photo


def smooth_jpeg(path, seed=0):
    """A real JPEG of the scene's size with enough entropy-coded data to be cut in half."""
    import cv2

    rng = np.random.default_rng(seed)
    image = cv2.GaussianBlur(rng.integers(0, 255, (HEIGHT, WIDTH, 3), dtype=np.uint8), (5, 5), 0)
    cv2.imwrite(str(path), image, [cv2.IMWRITE_JPEG_QUALITY, 95])
    return path


def log_rows(path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def test_truncated_jpeg_frame_is_skipped_not_draped_grey(run_alg, small_scene, tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    for i in range(3):
        smooth_jpeg(folder / f"f{i}.jpg", seed=i)
    data = (folder / "f1.jpg").read_bytes()
    (folder / "f1.jpg").write_bytes(data[: len(data) // 2])  # a cut-off copy: libjpeg would fill it with grey
    feedback = QgsProcessingFeedback()
    out = tmp_path / "out"
    result = run_alg("batch", {"MODE": 0, "REGISTER": False, "DEM": small_scene["dem"], "FOLDER": str(folder),
                               "CAMERA": small_scene["camera"], "XYZ": False, "OUTPUT": str(out)}, feedback)
    assert result["SUCCEEDED"] == 2 and result["FAILED"] == 1
    assert sorted(p.name for p in out.glob("*_ortho.tif")) == ["f0_ortho.tif", "f2_ortho.tif"]
    failed = [r for r in log_rows(result["LOG"]) if r["status"] == "failed"]
    assert len(failed) == 1 and failed[0]["photo"].endswith("f1.jpg") and "truncated" in failed[0]["message"]
    assert "f1.jpg: FAILED, skipped" in feedback.textLog() and "truncated" in feedback.textLog()


def test_read_photo_keeps_complete_jpegs_with_thumbnail_and_trailing_bytes(tmp_path):
    """The truncation check must not refuse good files: an EXIF thumbnail (its own scan and end marker before the
    main image) and bytes appended after the end of the image."""
    from PIL import Image

    from monoplot_plugin.processing.inputs import InputError, read_photo

    path = smooth_jpeg(tmp_path / "a.jpg")
    thumb = tmp_path / "t.jpg"
    Image.open(path).resize((40, 30)).save(thumb)
    data = path.read_bytes()
    # an APP1 segment carrying a whole JPEG (as an EXIF thumbnail does), then junk after the end of the image
    payload = b"Exif\x00\x00" + thumb.read_bytes()
    segment = b"\xff\xe1" + (len(payload) + 2).to_bytes(2, "big") + payload
    (tmp_path / "b.jpg").write_bytes(data[:2] + segment + data[2:] + b"\x00" * 100)
    assert read_photo(str(tmp_path / "b.jpg")).shape == (HEIGHT, WIDTH, 3)
    (tmp_path / "c.jpg").write_bytes((tmp_path / "b.jpg").read_bytes()[: len(segment) + len(data) // 2])
    with pytest.raises(InputError, match="truncated"):
        read_photo(str(tmp_path / "c.jpg"))


def test_frames_with_the_same_name_get_distinct_outputs(run_alg, small_scene, tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    write_photo(folder / "frame_09.jpg", seed=1)
    write_photo(folder / "frame_09.png", seed=2)
    write_photo(folder / "frame_10.jpg", seed=3)
    feedback = QgsProcessingFeedback()
    out = tmp_path / "out"
    result = run_alg("batch", {"MODE": 0, "REGISTER": False, "DEM": small_scene["dem"], "FOLDER": str(folder),
                               "CAMERA": small_scene["camera"], "XYZ": False, "OUTPUT": str(out)}, feedback)
    assert result["SUCCEEDED"] == 3
    assert sorted(p.name for p in out.glob("*_ortho.tif")) == ["frame_09_2_ortho.tif", "frame_09_ortho.tif",
                                                               "frame_10_ortho.tif"]
    outputs = [r["outputs"] for r in log_rows(result["LOG"])]
    assert len(set(outputs)) == 3  # no two photos claim the same file
    assert "frame_09_2_*" in feedback.textLog()


def test_table_photos_of_the_same_name_in_two_folders_keep_both_cameras(run_alg, small_scene, tmp_path):
    from monoplot_plugin.core.camera import Camera

    cam = small_scene["cam"]
    for sub in ("day1", "day2"):
        (tmp_path / sub).mkdir()
        write_photo(tmp_path / sub / "frame.png")
    cam.with_parameters(heading=cam.heading - 1.0).save(tmp_path / "prior1.json")
    cam.with_parameters(heading=cam.heading + 1.0).save(tmp_path / "prior2.json")
    # a spreadsheet in a European locale saves CSV with ';'
    (tmp_path / "photos.csv").write_text("photo;prior;points\n"
                                         "day1/frame.png;prior1.json;gcps.csv\n"
                                         "day2/frame.png;prior2.json;gcps.csv\n"
                                         ";prior1.json;gcps.csv\n", encoding="utf-8")
    _write_gcps(small_scene, tmp_path / "gcps.csv")
    feedback = QgsProcessingFeedback()
    result = run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(tmp_path / "photos.csv"),
                               "XYZ": False, "ORTHO": False, "OUTPUT": str(tmp_path / "out")}, feedback)
    assert result["SUCCEEDED"] == 2 and result["FAILED"] == 1
    names = sorted(p.name for p in (tmp_path / "out").glob("*_camera.json"))
    assert names == ["frame_2_camera.json", "frame_camera.json"]
    for name in names:
        assert abs(Camera.load(tmp_path / "out" / name).heading - cam.heading) < 0.05
    assert "photos.csv line 4: FAILED, skipped: no photo given" in feedback.textLog()


def _write_gcps(small_scene, path):
    from monoplot_plugin.core.dem import Dem
    from monoplot_plugin.core.xyz import compute_xyz
    from monoplot_plugin.processing.inputs import write_points_csv

    cam = small_scene["cam"]
    xyz = compute_xyz(cam, Dem.open(small_scene["dem"]))
    rows, cols = np.nonzero(np.isfinite(xyz[..., 2]))
    pick = np.random.default_rng(3).choice(len(rows), 12, replace=False)
    world = xyz[rows[pick], cols[pick]]
    write_points_csv(str(path), uv=cam.project(world), xyz=world)


def test_table_with_wrong_columns_says_what_it_found(run_alg, small_scene, tmp_path):
    (tmp_path / "t.csv").write_text("image;camera;gcp\na.jpg;b.json;c.csv\n")
    with pytest.raises(QgsProcessingException, match="found image, camera, gcp"):
        run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(tmp_path / "t.csv"),
                          "OUTPUT": str(tmp_path / "out")})


def test_each_mode_names_its_missing_input(run_alg, small_scene, tmp_path):
    with pytest.raises(QgsProcessingException, match="needs the photo FOLDER"):
        run_alg("batch", {"MODE": 0, "DEM": small_scene["dem"], "CAMERA": small_scene["camera"],
                          "OUTPUT": str(tmp_path / "out")})
    with pytest.raises(QgsProcessingException, match="needs the photo TABLE"):
        run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "OUTPUT": str(tmp_path / "out")})


def test_rerun_into_the_same_folder_says_files_are_replaced(run_alg, small_scene, tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    write_photo(folder / "a.png")
    params = {"MODE": 0, "DEM": small_scene["dem"], "FOLDER": str(folder), "CAMERA": small_scene["camera"],
              "OUTPUT": str(tmp_path / "out")}
    first = QgsProcessingFeedback()
    run_alg("batch", params, first)
    assert "replaced" not in first.textLog()
    second = QgsProcessingFeedback()
    run_alg("batch", dict(params, RESUME=False), second)
    assert "2 file(s) of an earlier run" in second.textLog() and "replaced" in second.textLog()
    third = QgsProcessingFeedback()  # resumed (the default): nothing is made again, nothing replaced
    run_alg("batch", params, third)
    assert "1 of 1 photos were done by an earlier run" in third.textLog() and "replaced" not in third.textLog()


def test_camera_mislabelled_in_another_crs_is_refused_not_run_empty(run_alg, small_scene, tmp_path):
    """UTM numbers labelled LV03: transformed from LV03 they land far from the DEM; refused before any photo, with
    the transformation and the likely wrong label said (another projected CRS, correctly labelled, is transformed:
    tests/badinput)."""
    folder = tmp_path / "frames"
    folder.mkdir()
    write_photo(folder / "a.png")
    lv03 = osr.SpatialReference()
    lv03.ImportFromEPSG(21781)
    cam = small_scene["cam"].with_parameters()
    cam.crs_wkt = lv03.ExportToWkt()
    cam.save(tmp_path / "lv03.json")
    with pytest.raises(QgsProcessingException, match=r"sees no part of the DEM.*transformed from .*EPSG:21781.*"
                                                      r"into the DEM's .*EPSG:32632.*CRS label is wrong"):
        run_alg("batch", {"MODE": 0, "DEM": small_scene["dem"], "FOLDER": str(folder),
                          "CAMERA": str(tmp_path / "lv03.json"), "OUTPUT": str(tmp_path / "out")})
    with pytest.raises(QgsProcessingException, match="EPSG:21781"):  # the single-photo algorithms too
        run_alg("computexyz", {"CAMERA": str(tmp_path / "lv03.json"), "DEM": small_scene["dem"],
                               "OUTPUT": str(tmp_path / "x.tif")})
    utm = osr.SpatialReference()
    utm.ImportFromEPSG(32632)
    cam.crs_wkt = utm.ExportToWkt()  # the same CRS written differently is accepted
    cam.save(tmp_path / "utm.json")
    result = run_alg("batch", {"MODE": 0, "DEM": small_scene["dem"], "FOLDER": str(folder),
                               "CAMERA": str(tmp_path / "utm.json"), "OUTPUT": str(tmp_path / "out")})
    assert result["SUCCEEDED"] == 1


def test_camera_that_sees_no_terrain_fails_its_photos(run_alg, small_scene, tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    write_photo(folder / "a.png")
    small_scene["cam"].with_parameters(pitch=60.0).save(tmp_path / "sky.json")
    with pytest.raises(QgsProcessingException, match="No photo could be processed"):
        run_alg("batch", {"MODE": 0, "DEM": small_scene["dem"], "FOLDER": str(folder),
                          "CAMERA": str(tmp_path / "sky.json"), "OUTPUT": str(tmp_path / "out")})
    rows = log_rows(tmp_path / "out" / "batch_log.csv")
    assert rows[0]["status"] == "failed" and "sees no cell of the DEM" in rows[0]["message"]


def test_kml_shared_camera_takes_the_frames_size(run_alg, small_scene, tmp_path):
    cam = small_scene["cam"]
    utm, wgs = osr.SpatialReference(), osr.SpatialReference()
    utm.ImportFromEPSG(32632)
    wgs.ImportFromEPSG(4326)
    wgs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    utm.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    lon, lat, _ = osr.CoordinateTransformation(utm, wgs).TransformPoint(cam.position[0], cam.position[1])
    half = cam.fov / 2
    (tmp_path / "prior.kml").write_text(
        f"<kml><PhotoOverlay><Camera><longitude>{lon}</longitude><latitude>{lat}</latitude>"
        f"<altitude>{cam.position[2]}</altitude><heading>{cam.heading}</heading><tilt>{90 + cam.pitch}</tilt>"
        f"<roll>0</roll></Camera><ViewVolume><leftFov>{-half}</leftFov><rightFov>{half}</rightFov></ViewVolume>"
        f"</PhotoOverlay></kml>")
    folder = tmp_path / "frames"
    folder.mkdir()
    (folder / "0_broken.png").write_bytes(b"not a png")
    write_photo(folder / "a.png")
    write_photo(folder / "b.png", seed=4)
    feedback = QgsProcessingFeedback()
    result = run_alg("batch", {"MODE": 0, "REGISTER": False, "DEM": small_scene["dem"], "FOLDER": str(folder),
                               "CAMERA": str(tmp_path / "prior.kml"), "OUTPUT": str(tmp_path / "out")}, feedback)
    assert result["SUCCEEDED"] == 2 and result["FAILED"] == 1
    assert f"image size {WIDTH}x{HEIGHT} px taken from a.png" in feedback.textLog()
    assert (tmp_path / "out" / "xyz.tif").is_file() and (tmp_path / "out" / "b_ortho.tif").is_file()


def test_cancel_marks_the_rest_canceled_not_failed(run_alg, small_scene, tmp_path):
    """A canceled run writes its log and ends as an error (``qgis_process`` said success after Ctrl+C, a trial);
    the canceled frames' files of an earlier run are named in the log, not taken for this run's."""
    folder = tmp_path / "frames"
    folder.mkdir()
    for i in range(6):
        write_photo(folder / f"f{i}.png", seed=i)
    parameters = {"MODE": 0, "REGISTER": False, "DEM": small_scene["dem"], "FOLDER": str(folder), "WORKERS": 1,
                  "CAMERA": small_scene["fitted"], "OUTPUT": str(tmp_path / "out"), "RESUME": False}
    run_alg("batch", parameters)  # an earlier, complete run (made again: not resumed)
    feedback = QgsProcessingFeedback()
    feedback.progressChanged.connect(lambda value: feedback.cancel() if value >= 40 else None)
    with pytest.raises(QgsProcessingException, match="Canceled: 3 photos processed, 3 not processed"):
        run_alg("batch", parameters, feedback)
    rows = log_rows(str(tmp_path / "out" / "batch_log.csv"))
    assert [r["status"] for r in rows] == ["ok", "ok", "ok", "canceled", "canceled", "canceled"]
    assert "files of an earlier run left as they were: f3_ortho.tif" in rows[3]["message"]
    assert "3 photos processed, 0 skipped, 3 not processed (canceled)" in feedback.textLog()


def test_read_photo_turns_the_photo_by_its_exif_orientation(tmp_path):
    """Processing reads photos as bytes (imdecode) and must still honour EXIF orientation, as the dock does: a
    phone picture stored landscape with 'rotate 90' must come out portrait, or its camera would not match."""
    from PIL import Image

    from monoplot_plugin.processing.inputs import read_photo

    exif = Image.Exif()
    exif[0x0112] = 6  # rotate 90 degrees clockwise to display
    path = tmp_path / "phone.jpg"
    Image.fromarray(np.zeros((40, 80, 3), np.uint8)).save(path, exif=exif.tobytes())
    assert read_photo(str(path)).shape == (80, 40, 3)


def test_table_row_of_a_blank_photo_is_skipped_without_products(run_alg, small_scene, tmp_path):
    """The trial: a photo of fog registered automatically came out "fit uncertain, RMSE nan px" with an XYZ raster
    and an orthophoto of grey fog."""
    import cv2

    write_photo(tmp_path / "a.png")
    cv2.imwrite(str(tmp_path / "fog.png"), np.full((HEIGHT, WIDTH, 3), 205, np.uint8))
    small_scene["cam"].save(tmp_path / "prior.json")
    _write_gcps(small_scene, tmp_path / "gcps.csv")
    (tmp_path / "photos.csv").write_text("photo,prior,points\na.png,prior.json,gcps.csv\nfog.png,prior.json,\n")
    feedback = QgsProcessingFeedback()
    out = tmp_path / "out"
    result = run_alg("batch", {"MODE": 1, "DEM": small_scene["dem"], "TABLE": str(tmp_path / "photos.csv"),
                               "OUTPUT": str(out)}, feedback)
    assert result["SUCCEEDED"] == 1 and result["FAILED"] == 1
    assert not list(out.glob("fog_*"))
    row = log_rows(result["LOG"])[1]
    assert row["status"] == "skipped" and "blank frame, no products written" in row["message"]
    assert "fog.png: skipped: blank frame" in feedback.textLog()


def test_a_shared_camera_without_fit_verdict_is_not_ok(run_alg, small_scene, tmp_path):
    """The trial: a rough prior given as CAMERA made every frame "ok, the shared camera", products 225 m off."""
    from tests.processing.conftest import recording_feedback

    folder = tmp_path / "frames"
    folder.mkdir()
    for i in range(2):
        write_photo(folder / f"f{i}.png", seed=i)
    feedback = recording_feedback()
    result = run_alg("batch", {"MODE": 0, "REGISTER": False, "DEM": small_scene["dem"], "FOLDER": str(folder), "XYZ": False,
                               "CAMERA": small_scene["camera"], "OUTPUT": str(tmp_path / "out")}, feedback)
    assert result["SUCCEEDED"] == 2 and len(list((tmp_path / "out").glob("*_ortho.tif"))) == 2  # still works
    assert result["NOT_OK"] == 2  # processed, but no camera it can vouch for
    rows = log_rows(result["LOG"])
    assert [r["status"] for r in rows] == ["uncertain", "uncertain"]
    assert rows[0]["message"] == "uncertain: camera not fitted (the shared camera)"
    assert sum("carries no fit verdict: it is not a fitted camera" in w for w in feedback.warnings) == 1
    assert any(w.startswith("2 of the photos processed have a camera whose verdict is not") for w in feedback.warnings)


def test_dem_kept_beside_the_frames_is_not_taken_for_a_frame(run_alg, small_scene, tmp_path):
    """A trial kept dem.tif in the photo folder; the default patterns (which include *.tif) made it a frame that
    failed. The DEM given is left out of the frames."""
    import shutil

    folder = tmp_path / "frames"
    folder.mkdir()
    for i in range(2):
        smooth_jpeg(folder / f"f{i}.jpg", seed=i)
    dem_here = folder / "dem.tif"
    shutil.copy(small_scene["dem"], dem_here)
    out = tmp_path / "out"
    result = run_alg("batch", {"MODE": 0, "REGISTER": False, "DEM": str(dem_here), "FOLDER": str(folder),
                               "CAMERA": small_scene["camera"], "XYZ": False, "OUTPUT": str(out)},
                     QgsProcessingFeedback())
    assert result["SUCCEEDED"] == 2 and result["FAILED"] == 0
    assert [r["photo"].rsplit("/", 1)[-1] for r in log_rows(result["LOG"])] == ["f0.jpg", "f1.jpg"]
