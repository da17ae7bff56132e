"""Resuming a batch (:mod:`monoplot_plugin.workflow.resume`) on real files: a canceled run is finished by a rerun
without touching what it had done; a changed photo, setting or missing product is made again; without ``resume``
every photo is processed."""

import os

import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.dem import Dem
from monoplot_plugin.workflow import batch
from monoplot_plugin.workflow.resume import JOURNAL, RESUMED


def canceled_after(frames):
    """An ``is_canceled`` that turns true once ``frames`` results have been reported through progress."""
    seen = []

    def progress(fraction, message=""):
        if fraction < 1.0:
            seen.append(message)

    # a frame ended: a step of progress that does not say a frame is under way ("processing ...")
    return progress, lambda: len([m for m in seen if not m.startswith("processing")]) >= frames


def stamps(folder):
    return {p.name: p.stat().st_mtime_ns for p in folder.iterdir() if p.name.endswith("_ortho.tif")}


@pytest.fixture()
def first_run(still_timelapse, tmp_path):
    """A run canceled after some frames (one at a time, so that the cut is clean)."""
    scene = still_timelapse
    cam = Camera.load(scene["camera"])
    dem = Dem.open(scene["dem"])
    out = tmp_path / "out"
    progress, is_canceled = canceled_after(2)
    fractions = []
    results = batch.run_batch(batch.folder_jobs(scene["folder"], cam), dem, dem.crs_wkt, str(out), workers=1,
                              progress=lambda f, m="": (fractions.append(f), progress(f, m)),
                              is_canceled=is_canceled)
    done = [r for r in results if r.ok]
    assert 2 <= len(done) < 6 and all(r.canceled for r in results if not r.ok)
    # the bar stops where the work stopped (a trial's jumped to 100 % on Cancel)
    assert max(fractions) < 1.0 and max(fractions) == pytest.approx(len(done) / 6, abs=0.2), fractions
    return scene, cam, dem, out, done


def test_a_canceled_run_is_finished_by_a_rerun_that_keeps_what_was_done(first_run):
    scene, cam, dem, out, done = first_run
    before = stamps(out)
    lines = []
    results = batch.run_batch(batch.folder_jobs(scene["folder"], cam), dem, dem.crs_wkt, str(out), workers=2,
                              resume=True, log=lambda m, e: lines.append(m))
    assert all(r.ok for r in results) and len(results) == 6
    resumed = [r for r in results if r.message.startswith(RESUMED)]
    assert [r.photo for r in resumed] == [r.photo for r in done]
    for r in resumed:  # untouched: the same file, not written again
        name = os.path.basename(r.outputs[-1])
        assert (out / name).stat().st_mtime_ns == before[name]
    assert any(f"{len(done)} of 6 photos were done by an earlier run" in line for line in lines)
    assert len(stamps(out)) == 6
    batch.write_log(str(out / "batch_log.csv"), results, scene["folder"])
    assert (out / "batch_log.csv").read_text().count(RESUMED) == len(done)


def test_a_changed_photo_or_setting_or_missing_product_is_made_again(first_run):
    scene, cam, dem, out, done = first_run
    jobs = batch.folder_jobs(scene["folder"], cam)
    batch.run_batch(jobs, dem, dem.crs_wkt, str(out), workers=2, resume=True)  # all six done now
    touched = done[0].photo
    os.utime(touched, ns=(os.stat(touched).st_atime_ns, os.stat(touched).st_mtime_ns + 10**9))
    os.remove(out / os.path.basename(done[1].outputs[-1]))
    results = batch.run_batch(jobs, dem, dem.crs_wkt, str(out), workers=2, resume=True)
    again = {r.photo for r in results if not r.message.startswith(RESUMED)}
    assert again == {touched, done[1].photo} and all(r.ok for r in results)
    # another orthophoto cell size: every product is another, every photo processed
    results = batch.run_batch(jobs, dem, dem.crs_wkt, str(out), workers=2, resume=True, resolution=7.0)
    assert not any(r.message.startswith(RESUMED) for r in results)
    # without resume, nothing is taken from the journal
    results = batch.run_batch(jobs, dem, dem.crs_wkt, str(out), workers=2, resolution=7.0)
    assert not any(r.message.startswith(RESUMED) for r in results) and all(r.ok for r in results)


def test_a_journal_line_cut_short_by_a_killed_run_is_passed_over(first_run):
    scene, cam, dem, out, done = first_run
    with open(out / JOURNAL, "a", encoding="utf-8") as journal:
        journal.write('{"stem": "frame_005", "key": "')  # the run died while writing this line
    results = batch.run_batch(batch.folder_jobs(scene["folder"], cam), dem, dem.crs_wkt, str(out), workers=2,
                              resume=True)
    assert sum(r.message.startswith(RESUMED) for r in results) == len(done) and all(r.ok for r in results)
    results = batch.run_batch(batch.folder_jobs(scene["folder"], cam), dem, dem.crs_wkt, str(out), workers=2,
                              resume=True)  # the lines written after the half line are whole
    assert all(r.message.startswith(RESUMED) for r in results)
