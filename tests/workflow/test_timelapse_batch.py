"""The time-lapse batch of the workflow on real files: shared camera products computed once and equal to the
per-photo products, frames in threads, re-registration of turned frames, refusal of a frame that cannot be
registered, cancel with frames in flight."""

import csv
import json
import os

import numpy as np
import pytest
from osgeo import gdal

from monoplot_plugin.core import drift
from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.dem import Dem
from monoplot_plugin.workflow import batch, camera_files, products
from monoplot_plugin.workflow.files import read_photo


def band_arrays(path):
    ds = gdal.Open(str(path))
    return np.stack([ds.GetRasterBand(i + 1).ReadAsArray() for i in range(ds.RasterCount)], axis=-1)


def log_rows(path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def test_shared_camera_products_equal_the_per_photo_products(still_timelapse, tmp_path):
    scene = still_timelapse
    cam = Camera.load(scene["camera"])
    dem = Dem.open(scene["dem"])
    jobs = batch.folder_jobs(scene["folder"], cam)
    lines = []
    results = batch.run_batch(jobs, dem, dem.crs_wkt, str(tmp_path / "out"), workers=2,
                              log=lambda m, e: lines.append(m))
    assert [r.ok for r in results] == [True] * 6 and [r.index for r in results] == list(range(6))
    assert sorted(os.listdir(tmp_path / "out")) == sorted([f"frame_{i:03d}_ortho.tif" for i in range(6)]
                                                          + ["xyz.tif", "xyz.qml", "batch_journal.jsonl"])
    for i in (0, 5):  # what the dock and the single-photo algorithm write for the same photo
        single = products.orthophoto(tmp_path / f"single_{i}.tif", read_photo(scene["frames"][i]), cam, dem)
        assert np.array_equal(band_arrays(tmp_path / "out" / f"frame_{i:03d}_ortho.tif"), band_arrays(single))
    single_xyz = products.write_xyz(tmp_path / "single_xyz.tif", cam, dem)
    assert np.array_equal(band_arrays(tmp_path / "out" / "xyz.tif"), band_arrays(single_xyz), equal_nan=True)
    assert sum("/6] frame_" in line and ": ok" in line for line in lines) == 6
    assert all(np.isnan(r.drift_px) for r in results)  # not re-registered: no drift claimed


def test_turned_frames_are_registered_and_get_their_corrected_camera(drifting_timelapse, tmp_path):
    scene = drifting_timelapse
    cam = Camera.load(scene["camera"])
    dem = Dem.open(scene["dem"])
    out = tmp_path / "out"
    results = batch.run_batch(batch.folder_jobs(scene["folder"], cam), dem, dem.crs_wkt, str(out), workers=2,
                              register=True)
    assert all(r.ok for r in results), [r.message for r in results]
    batch.write_log(str(out / "batch_log.csv"), results)
    rows = log_rows(out / "batch_log.csv")
    for i, (result, row, true) in enumerate(zip(results, rows, scene["cameras"])):
        truth = true.rotation @ cam.rotation.T
        assert result.drift_deg == pytest.approx(drift.rotation_angle_deg(truth), abs=0.05)
        assert float(row["drift_px"]) == pytest.approx(result.drift_px, abs=1e-3) and row["drift_deg"]
        assert "drift" in result.message
        # how well it was registered, for a frame with no fit RMSE of its own (a trial could not tell)
        assert 0 <= float(row["match_px"]) < 1.0 and int(row["match_points"]) >= drift.MIN_INLIERS
        assert f"registered on {row['match_points']} points" in result.message
        own = out / f"frame_{i:03d}_camera.json"
        if i == 0:  # the reference itself: no turn, the shared camera's products, and its file for this frame
            assert result.drift_px < 0.1 and str(out / "xyz.tif") in result.outputs
            mine = Camera.load(own)
            assert np.allclose(mine.rotation, cam.rotation) and np.allclose(mine.position, cam.position)
            assert str(own) in result.outputs
            fit = json.loads(own.read_text())["fit"]
            assert "registered on this frame" in fit["message"]
            # for this very photo: Processing's phototomap with it keeps the shared camera's verdict (a trial's,
            # given the shared camera's own file, said "fitted on another photo: its ok does not carry over")
            assert camera_files.fitted_on_photo(fit, scene["frames"][0]) is True
            continue
        corrected = Camera.load(own)  # its own camera, XYZ raster and orthophoto
        assert drift.pixel_shift(cam, corrected.rotation @ cam.rotation.T, truth) <= 0.5
        assert (out / f"frame_{i:03d}_xyz.tif").is_file() and str(own) in result.outputs
        xyz = band_arrays(out / f"frame_{i:03d}_xyz.tif")
        # the file's camera: its heading an azimuth (358.8), the one computed -1.2: the same up to rounding
        again = products.xyz_result(corrected, dem).xyz.astype(xyz.dtype)
        assert np.array_equal(np.isnan(xyz), np.isnan(again))
        assert np.allclose(xyz, again, rtol=0.0, atol=1e-6, equal_nan=True), np.nanmax(np.abs(xyz - again))


def test_a_turned_frames_camera_file_carries_the_shared_cameras_figures(drifting_timelapse, tmp_path):
    """A time-lapse trial's turned frames carried only a status: loaded in the dock they said "ok" with no ±, and
    the fronts drawn on them had no xy_error_m. Their files carry the shared camera's σ and pixel figures, the
    registration's residual added, and name their photo."""
    import json
    import math

    from monoplot_plugin.workflow.camera_files import fitted_on_photo, written_fit
    from monoplot_plugin.workflow.features import pixel_error

    scene = drifting_timelapse
    cam = Camera.load(scene["camera"])
    dem = Dem.open(scene["dem"])
    shared = {"mode": "paired", "rmse_px": 1.5, "loo_rmse_px": 2.0, "sigma": {"heading": 0.01, "x": 0.8}}
    out = tmp_path / "out"
    results = batch.run_batch(batch.folder_jobs(scene["folder"], cam), dem, dem.crs_wkt, str(out), register=True,
                              camera_verdict=("ok", "", shared))
    turned = [(r, out / f"frame_{r.index:03d}_camera.json") for r in results if r.drift_px >= 0.1]
    assert turned and all(r.ok for r, _ in turned)
    for r, path in turned:
        fit = written_fit(str(path))
        assert fit["status"] == "ok" and fit["sigma"] == shared["sigma"] and fit["mode"] == "paired"
        assert fit["loo_rmse_px"] == pytest.approx(math.hypot(2.0, r.match_px))
        assert pixel_error(fit) == (pytest.approx(math.hypot(2.0, r.match_px)), "loo")
        assert fitted_on_photo(fit, r.photo) is True
    assert json.loads(turned[0][1].read_text())["fit"]["photo"] == os.path.basename(turned[0][0].photo)


def test_a_frame_that_cannot_be_registered_is_reported_not_given_the_reference_camera(drifting_timelapse,
                                                                                         tmp_path):
    import shutil

    import cv2

    scene = drifting_timelapse
    folder = tmp_path / "frames"
    shutil.copytree(scene["folder"], folder)
    cam = Camera.load(scene["camera"])
    # upside down: textured, but no small turn of the reference (a blank frame is skipped before registering)
    cv2.imwrite(str(folder / "frame_002.png"), cv2.imread(str(folder / "frame_002.png"))[::-1, ::-1])
    dem = Dem.open(scene["dem"])
    out = tmp_path / "out"
    lines = []
    results = batch.run_batch(batch.folder_jobs(str(folder), cam), dem, dem.crs_wkt, str(out), register=True,
                              log=lambda m, e: lines.append((m, e)))
    assert [r.ok for r in results] == [True, True, False, True, True]
    assert "not registered" in results[2].message and np.isnan(results[2].drift_px)
    assert not list(out.glob("frame_002_*"))  # no product made with the reference camera
    assert any(e and "frame_002.png: FAILED, skipped: not registered" in m for m, e in lines)


def test_cancel_with_frames_in_flight_marks_the_rest_canceled(still_timelapse, tmp_path):
    scene = still_timelapse
    cam = Camera.load(scene["camera"])
    dem = Dem.open(scene["dem"])
    seen, lines = [], []
    results = batch.run_batch(batch.folder_jobs(scene["folder"], cam), dem, dem.crs_wkt, str(tmp_path / "out"),
                              workers=2, progress=lambda f, m="": seen.append(f), is_canceled=lambda: len(seen) >= 1,
                              log=lambda m, e: lines.append(m))
    assert len(results) == 6 and [r.index for r in results] == list(range(6))
    assert not any("FAILED" in m for m in lines)  # a cancel is no failure, in flight or not
    done = [r for r in results if r.ok]
    canceled = [r for r in results if r.canceled]
    assert len(done) + len(canceled) == 6 and canceled and done
    for r in canceled:
        stem = os.path.splitext(os.path.basename(r.photo))[0]
        assert not (tmp_path / "out" / f"{stem}_ortho.tif").exists() and not r.outputs


def test_turned_frames_orthophotos_without_xyz_need_no_z_buffer_of_their_own(drifting_timelapse, tmp_path):
    from monoplot_plugin.workflow.frames import CameraProducts

    scene = drifting_timelapse
    cam = Camera.load(scene["camera"])
    dem = Dem.open(scene["dem"])
    out = tmp_path / "out"
    results = batch.run_batch(batch.folder_jobs(scene["folder"], cam), dem, dem.crs_wkt, str(out), register=True,
                              write_xyz=False)
    assert all(r.ok for r in results) and not list(out.glob("*_xyz.tif"))
    for i in (1, 3):
        corrected = Camera.load(out / f"frame_{i:03d}_camera.json")
        direct = CameraProducts(corrected, dem, cached=False).write_orthophoto(str(tmp_path / f"d{i}.tif"),
                                                                               read_photo(scene["frames"][i]))
        fast, slow = band_arrays(out / f"frame_{i:03d}_ortho.tif"), band_arrays(direct)
        both = (fast[..., 3] > 0) & (slow[..., 3] > 0)
        assert both.sum() >= 0.95 * max((fast[..., 3] > 0).sum(), (slow[..., 3] > 0).sum())
        assert np.array_equal(fast[both], slow[both])


def test_a_shared_xyz_that_cannot_be_written_is_said_once_and_left_off_the_frames(still_timelapse, tmp_path):
    scene = still_timelapse
    cam = Camera.load(scene["camera"])
    dem = Dem.open(scene["dem"])
    out = tmp_path / "out"
    (out / "xyz.tif").mkdir(parents=True)  # a folder in the way: the rename into place fails
    lines = []
    results = batch.run_batch(batch.folder_jobs(scene["folder"], cam), dem, dem.crs_wkt, str(out), workers=2,
                              log=lambda m, e: lines.append((m, e)))
    assert all(r.ok for r in results) and len(list(out.glob("*_ortho.tif"))) == 6
    assert all(str(out / "xyz.tif") not in r.outputs and "xyz.tif not written" in r.message for r in results)
    assert sum(e and m.startswith("xyz.tif FAILED") for m, e in lines) == 1


def test_a_reference_frame_of_another_size_fails_every_frame_with_the_reason(drifting_timelapse, tmp_path):
    import cv2

    scene = drifting_timelapse
    cam = Camera.load(scene["camera"])
    dem = Dem.open(scene["dem"])
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.random.default_rng(0).integers(0, 255, (50, 60, 3), dtype=np.uint8))
    results = batch.run_batch(batch.folder_jobs(scene["folder"], cam), dem, dem.crs_wkt, str(tmp_path / "out"),
                              register=True, reference=str(small))
    assert not any(r.ok for r in results) and all("small.png is 60x50 px" in r.message for r in results)


def test_a_scanned_prints_border_and_caption_are_not_draped_by_the_batch(tmp_path):
    """An archive of scans run as a batch: each frame's paper border and printed caption stay out of its
    orthophoto, as in the single-photo product (they were draped onto the terrain), and a frame without a border
    loses nothing."""
    import cv2

    from tests.workflow.conftest import timelapse_scene

    scene = timelapse_scene(tmp_path, [(0.0, 0.0, 0.0)] * 2, size=(480, 320), lighting=False)
    printed = read_photo(scene["frames"][1])
    h, w = printed.shape[:2]
    paper = (250, 246, 235)
    printed[:12], printed[-44:], printed[:, :12], printed[:, -12:] = paper, paper, paper, paper
    cv2.putText(printed, "Tal 1891 No 41", (30, h - 14), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (20, 20, 20), 2)
    cv2.imwrite(scene["frames"][1], printed[..., ::-1])
    cam, dem = Camera.load(scene["camera"]), Dem.open(scene["dem"])
    results = batch.run_batch(batch.folder_jobs(scene["folder"], cam), dem, dem.crs_wkt, str(tmp_path / "out"),
                              workers=1)
    assert all(r.ok for r in results), [r.message for r in results]
    plain, scan = (band_arrays(tmp_path / "out" / f"frame_{i:03d}_ortho.tif") for i in (0, 1))
    r, g, b, alpha = np.moveaxis(scan.astype(int), -1, 0)
    assert alpha.any() and not ((alpha > 0) & (r > 235) & (r - b > 8)).any()  # no paper
    assert not ((alpha > 0) & (r < 40) & (g < 40) & (b < 40)).any()  # no caption
    assert (plain[..., 3] > 0).sum() > (alpha > 0).sum()  # the frame without a border is draped whole
    single = products.orthophoto(tmp_path / "single.tif", read_photo(scene["frames"][1]), cam, dem)
    assert np.array_equal(scan, band_arrays(single))


def _foggy_first_frame(scene, folder):
    """A copy of ``scene``'s frames whose first frame is pure grey fog (a JPEG-like faint noise on it)."""
    import shutil

    import cv2

    shutil.copytree(scene["folder"], folder)
    cam = scene["cam"]
    fog = np.random.default_rng(0).normal(205, 1.5, (cam.height, cam.width, 3)).clip(0, 255).astype(np.uint8)
    cv2.imwrite(str(folder / "frame_000.png"), fog)
    return folder


def _registered_with_fog_first(scene, tmp_path, **options):
    """(results, log lines (message, is_error)) of a re-registered batch whose first frame is fog."""
    folder = _foggy_first_frame(scene, tmp_path / "frames")
    cam, dem = Camera.load(scene["camera"]), Dem.open(scene["dem"])
    lines = []
    options = {k: str(folder / v) if k == "reference" else v for k, v in options.items()}
    results = batch.run_batch(batch.folder_jobs(str(folder), cam), dem, dem.crs_wkt, str(tmp_path / "out"),
                              register=True, log=lambda m, e: lines.append((m, e)), **options)
    return results, lines


def test_a_foggy_first_frame_is_not_the_default_reference(drifting_timelapse, tmp_path):
    """The trial: the fog frame, first by name, was the reference: it came out "ok" and every good frame failed."""
    results, lines = _registered_with_fog_first(drifting_timelapse, tmp_path, write_xyz=False)
    assert all(r.ok for r in results[1:]), [r.message for r in results]
    assert not results[0].ok
    assert any(m.startswith("frame_000.png is not the reference frame: no structure") for m, _ in lines)
    assert any(m.startswith("Reference frame: frame_001.png") for m, _ in lines)
    assert results[1].drift_px < 0.1  # the reference itself


def test_a_blank_reference_frame_named_by_the_user_fails_with_its_name(drifting_timelapse, tmp_path):
    results, lines = _registered_with_fog_first(drifting_timelapse, tmp_path, reference="frame_000.png")
    assert not any(r.ok for r in results)
    assert all("reference frame frame_000.png is blank" in r.message and "REFERENCE" in r.message for r in results)
    assert any(e and m.startswith("every photo FAILED") for m, e in lines)


def test_an_unreadable_first_frame_is_passed_over_for_the_reference(drifting_timelapse, tmp_path):
    import shutil

    scene = drifting_timelapse
    folder = tmp_path / "frames"
    shutil.copytree(scene["folder"], folder)
    data = (folder / "frame_000.png").read_bytes()
    (folder / "frame_000.png").write_bytes(data[: len(data) // 3])
    cam, dem = Camera.load(scene["camera"]), Dem.open(scene["dem"])
    lines = []
    results = batch.run_batch(batch.folder_jobs(str(folder), cam), dem, dem.crs_wkt, str(tmp_path / "out"),
                              register=True, write_xyz=False, log=lambda m, e: lines.append(m))
    assert [r.ok for r in results] == [False, True, True, True, True], [r.message for r in results]
    assert any(m.startswith("Reference frame: frame_001.png") for m in lines)
    named = batch.run_batch(batch.folder_jobs(str(folder), cam), dem, dem.crs_wkt, str(tmp_path / "out2"),
                            register=True, reference=str(folder / "frame_000.png"))
    assert all("reference frame frame_000.png cannot be used" in r.message and "choose another frame with "
               "REFERENCE" in r.message for r in named)


def test_a_blank_frame_is_skipped_not_draped_with_the_shared_camera(still_timelapse, tmp_path):
    import shutil

    import cv2

    scene = still_timelapse
    folder = tmp_path / "frames"
    shutil.copytree(scene["folder"], folder)
    cam, dem = Camera.load(scene["camera"]), Dem.open(scene["dem"])
    cv2.imwrite(str(folder / "frame_002.png"), np.full((cam.height, cam.width, 3), 205, np.uint8))  # fog
    out, lines = tmp_path / "out", []
    results = batch.run_batch(batch.folder_jobs(str(folder), cam), dem, dem.crs_wkt, str(out), write_xyz=False,
                              log=lambda m, e: lines.append(m))
    assert [r.ok for r in results] == [True, True, False, True, True, True]
    assert results[2].verdict() == "skipped" and "blank frame" in results[2].message and not results[2].outputs
    assert not (out / "frame_002_ortho.tif").exists() and (out / "frame_003_ortho.tif").exists()
    assert any("frame_002.png: skipped: blank frame, no products written: no structure" in m for m in lines)
    batch.write_log(str(out / "batch_log.csv"), results)
    assert log_rows(out / "batch_log.csv")[2]["status"] == "skipped"


def test_a_rerun_removes_the_earlier_products_of_frames_it_does_not_make_again(drifting_timelapse, tmp_path):
    """The trial: a frame that failed on a rerun kept its orthophoto of the earlier run beside "failed" in the log."""
    import shutil

    import cv2

    scene = drifting_timelapse
    folder = tmp_path / "frames"
    shutil.copytree(scene["folder"], folder)
    cam, dem = Camera.load(scene["camera"]), Dem.open(scene["dem"])
    out = tmp_path / "out"
    first = batch.run_batch(batch.folder_jobs(str(folder), cam), dem, dem.crs_wkt, str(out), register=True)
    assert all(r.ok for r in first) and (out / "frame_001_camera.json").is_file()
    (out / "notes.txt").write_text("mine")  # not the batch's: never touched
    cv2.imwrite(str(folder / "frame_002.png"), np.full((cam.height, cam.width, 3), 205, np.uint8))  # fog now
    lines = []
    second = batch.run_batch(batch.folder_jobs(str(folder), cam), dem, dem.crs_wkt, str(out), write_xyz=False,
                             log=lambda m, e: lines.append(m))
    assert [r.ok for r in second] == [True, True, False, True, True]
    assert not list(out.glob("frame_002_*"))  # skipped now: its earlier products are gone
    # not re-registered now: the frames have the shared camera, their own cameras of the earlier run are gone
    assert not list(out.glob("frame_*_camera.json")) and not list(out.glob("frame_*_xyz.*"))  # and the style
    assert len(list(out.glob("frame_*_ortho.tif"))) == 4 and (out / "notes.txt").read_text() == "mine"
    assert any("of an earlier run removed" in m and "frame_002_ortho.tif" in m for m in lines)


def test_a_frame_canceled_while_written_leaves_no_half_of_its_products(tmp_path):
    """A trial canceled a batch as a turned frame's camera file had been written but not its rasters: the file
    stayed, and the log named it as an earlier run's. What this run wrote of a canceled frame goes; an earlier
    run's files of it stay and are named."""
    from monoplot_plugin.workflow.frames import FrameTask, PhotoResult

    half = tmp_path / "f3_camera.json"  # written by this run before the cancel
    half.write_text("{}")
    older = tmp_path / "f3_ortho.tif"  # an earlier run's
    older.write_bytes(b"x")
    task = FrameTask(3, str(tmp_path / "f3.jpg"), "f3", "f3.jpg")
    result = PhotoResult("f3.jpg", False, "canceled while processing (its outputs not written)", [str(half)],
                         canceled=True, status="canceled")
    said = []
    batch.remove_stale(str(tmp_path), [task], [result], False, lambda text, *a: said.append(text))
    assert not half.exists() and older.exists() and result.outputs == []
    assert result.message.endswith("files of an earlier run left as they were: f3_ortho.tif")
    assert any("canceled while they were written removed" in text and "f3_camera.json" in text for text in said)


def fitted_on_frame(scene, tmp_path, index):
    """A camera file as the dock writes it for frame ``index``: its true camera, "ok", naming that photo."""
    path = tmp_path / "camera_fitted.json"
    path.write_text(camera_files.camera_json(scene["cameras"][index], {"status": "ok", "message": "fitted"},
                                             scene["frames"][index]))
    return str(path)


def test_re_registration_is_relative_to_the_frame_the_camera_was_fitted_on(drifting_timelapse, tmp_path):
    """The first frame was every frame's reference: a camera fitted on another frame passed the turn between the
    two on to every frame. The frame the camera file names is the reference now."""
    scene = drifting_timelapse
    path = fitted_on_frame(scene, tmp_path, 2)
    cam, dem = Camera.load(path), Dem.open(scene["dem"])
    lines = []
    verdict = batch.shared_camera_verdict(path)
    results = batch.run_batch(batch.folder_jobs(scene["folder"], cam), dem, dem.crs_wkt, str(tmp_path / "out"),
                              register=True, camera_verdict=verdict, log=lambda m, e: lines.append(m))
    assert all(r.ok and r.status == "ok" for r in results), [r.message for r in results]
    assert any("Reference frame: frame_002.png, the frame the shared camera was fitted on" in m for m in lines)
    assert results[2].drift_px < 0.1 and results[0].drift_deg == pytest.approx(
        drift.rotation_angle_deg(scene["cameras"][0].rotation @ cam.rotation.T), abs=0.05)
    frame0 = Camera.load(tmp_path / "out" / "frame_000_camera.json")
    assert drift.pixel_shift(cam, frame0.rotation @ cam.rotation.T, scene["cameras"][0].rotation @ cam.rotation.T) \
        <= 0.5


def test_frames_not_re_registered_are_uncertain_unless_the_camera_was_fitted_on_them(drifting_timelapse, tmp_path):
    """A trial's two bumped frames were logged "ok, the shared camera", 32-37 m off on the glacier: without a
    re-registration nothing shows that a frame is not the one the "ok" camera was fitted on."""
    scene = drifting_timelapse
    path = fitted_on_frame(scene, tmp_path, 2)
    cam, dem = Camera.load(path), Dem.open(scene["dem"])
    results = batch.run_batch(batch.folder_jobs(scene["folder"], cam), dem, dem.crs_wkt, str(tmp_path / "out"),
                              camera_verdict=batch.shared_camera_verdict(path))
    assert [r.status for r in results] == ["uncertain", "uncertain", "ok", "uncertain", "uncertain"]
    assert all(r.ok for r in results)
    assert "fitted on frame_002.png and this frame was not re-registered" in results[0].message
    assert results[2].message == "ok, the shared camera"
    # each orthophoto says its row's verdict (an archivist's "uncertain" ones lay beside the good ones, only the
    # log told them apart), the shared XYZ raster the camera's
    import json

    from osgeo import gdal

    kept = [json.loads(gdal.Open(str(tmp_path / "out" / f"frame_{i:03d}_ortho.tif")).GetMetadataItem("MONOPLOT_FIT"))
            for i in range(5)]
    assert [k["status"] for k in kept] == [r.status for r in results]
    assert "this frame was not re-registered" in kept[0]["message"]
    shared = json.loads(gdal.Open(str(tmp_path / "out" / batch.SHARED_XYZ)).GetMetadataItem("MONOPLOT_FIT"))
    assert shared["status"] == "ok"
