"""The batch on a Dask LocalCluster of 2 worker processes, one of them killed while it processes frames: every
frame comes back once in the table, with its outputs, and no temporary file is left, whether a task carries one
frame or several."""

import csv
import os
import signal

import distributed
import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.workflow import batch



@pytest.fixture()
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    client = distributed.Client(cluster)
    yield client
    client.close()
    cluster.close()


@pytest.mark.parametrize("per_task", [1, 3])
def test_a_killed_worker_has_its_frames_retried_none_lost_or_written_twice(still_timelapse, client, tmp_path,
                                                                            per_task):
    from monoplot_plugin.workflow.cluster import run_batch_dask

    scene = still_timelapse
    cam = Camera.load(scene["camera"])
    jobs = batch.folder_jobs(scene["folder"], cam) * 2  # 12 frames; the same names get numbered outputs
    killed = []

    def progress(fraction, message=""):
        if killed or fraction >= 1.0:
            return
        busy = {address: keys for address, keys in client.processing().items() if keys}
        if not busy:  # between two frames: at the next result
            return
        victim = next(iter(busy))  # a worker with frames in hand
        pid = client.run(os.getpid, workers=[victim])[victim]
        os.kill(pid, signal.SIGKILL)
        killed.append((victim, len(busy[victim])))

    out = tmp_path / "out"
    results = run_batch_dask(jobs, scene["dem"], cam.crs_wkt, str(out), client=client, progress=progress,
                             per_task=per_task)
    assert killed and killed[0][1] >= 1  # it died holding frames
    assert [r.index for r in results] == list(range(12)) and all(r.ok for r in results), [r.message for r in results]
    batch.write_log(str(out / "batch_log.csv"), results)
    with open(out / "batch_log.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert sorted(r["photo"] for r in rows) == sorted(j.photo for j in jobs)  # each frame once
    orthos = sorted(p.name for p in out.glob("*_ortho.tif"))
    assert len(orthos) == 12 and len({r.outputs[-1] for r in results}) == 12
    assert (out / "xyz.tif").is_file()
    assert not [p.name for p in out.iterdir() if "monoplot-tmp" in p.name]  # no half file left behind


def test_a_cluster_that_cannot_import_the_plugin_is_told_what_to_do(client):
    """The frames' functions travel by module name: a scheduler or worker without the plugin on its path gets a
    message naming the module and the PYTHONPATH to give, before any frame is sent."""
    from monoplot_plugin.workflow.cluster import check_importable
    from monoplot_plugin.workflow.files import InputError

    check_importable(client, "monoplot_plugin.workflow.cluster")  # the test's own cluster can
    with pytest.raises(InputError) as err:
        check_importable(client, "monoplot_plugin.no_such_module")
    text = str(err.value)
    assert "cannot import monoplot_plugin.no_such_module" in text and "3 process(es)" in text, text
    assert "PYTHONPATH=" in text and text.endswith("the same Python packages.")


def test_a_rerun_on_the_cluster_keeps_the_frames_an_earlier_run_finished(still_timelapse, client, tmp_path):
    """RESUME with Dask: the frames whose journal line matches are not sent to the workers again; one whose
    orthophoto was deleted is."""
    from monoplot_plugin.workflow.cluster import run_batch_dask
    from monoplot_plugin.workflow.resume import RESUMED

    scene = still_timelapse
    cam = Camera.load(scene["camera"])
    jobs = batch.folder_jobs(scene["folder"], cam)
    out = tmp_path / "out"
    first = run_batch_dask(jobs, scene["dem"], cam.crs_wkt, str(out), client=client)
    assert all(r.ok for r in first)
    os.remove(first[2].outputs[-1])
    lines = []
    again = run_batch_dask(jobs, scene["dem"], cam.crs_wkt, str(out), client=client, resume=True,
                           log=lambda m, e: lines.append(m))
    assert [r.index for r in again] == list(range(6)) and all(r.ok for r in again)
    assert [r.message.startswith(RESUMED) for r in again] == [True, True, False, True, True, True]
    assert os.path.isfile(first[2].outputs[-1]) and any(line.startswith("Dask: 1 frames") for line in lines)
    again = run_batch_dask(jobs, scene["dem"], cam.crs_wkt, str(out), client=client, resume=True)
    assert all(r.message.startswith(RESUMED) for r in again)  # nothing left to do: no task sent
