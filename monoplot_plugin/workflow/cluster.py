"""The batch on a Dask ``distributed`` cluster: the frames as tasks (a few to a task), the results and failures in one
table.

:func:`run_batch_dask` takes a ``Client`` (or a scheduler ``address``; neither: a ``LocalCluster`` of processes on
this machine, one per core). The workers rebuild what the frames share from a picklable
:class:`~.frames.Timelapse` (they open the DEM and the reference frame by path: on a cluster, every worker must see
the photos, the DEM and the output folder at the same paths) and keep it for the next frames
(:func:`~.frames.shared_for`).

A worker that dies (killed, out of memory, its machine gone) loses its running frames; the scheduler runs them again
on another worker, up to ``distributed.scheduler.allowed-failures`` times (then the frame is reported failed). No
frame is lost or written twice: a frame's result is taken once, by its index, and every file is written to a
temporary name and renamed into place (:mod:`..outputs.safe_write`), so a worker killed while writing leaves an
orphan temporary file, which is removed at the end, never a half file under the output's name.

Start a cluster (README, "Batches on a Dask cluster")::

    dask scheduler                                   # on one machine: prints tcp://host:8786
    MALLOC_MMAP_THRESHOLD_=67108864 dask worker tcp://host:8786 --nthreads 1 --nworkers N   # on each machine
"""

from __future__ import annotations

import os
import queue
import sys
from pathlib import Path
from typing import Dict, List, Optional

from .batch import (Log, PhotoJob, batch_setup, frame_tasks, log_result, output_stems, planned_outputs,
                    say_replaced, shared_xyz_failed)
from .files import InputError
from .frames import SHARED_XYZ, FrameTask, PhotoResult, Timelapse, process_frame, shared_for
from .progress import IsCanceled, Progress, never_canceled, no_progress
from .resume import dem_identity, in_task_order, remove_stale, resumable

__all__ = ["run_batch_dask", "local_client", "check_importable", "frames_per_task"]

#: seconds between two looks at ``is_canceled`` while waiting for results
POLL_S = 0.5
#: environment of the worker processes :func:`local_client` starts. Dask sets ``MALLOC_TRIM_THRESHOLD_``, which
#: turns off glibc's adaptive mmap threshold: every photo-sized array would be a fresh mmap, zeroed page by page
#: (frames took 1.5-2 times longer on a worker than in this process); arrays up to 64 MB come from the heap again.
#: A worker is one process of one thread per core: numba's and OpenCV's thread pools get one thread too (Dask
#: already does so for OpenMP and BLAS), instead of one per core in every worker.
WORKER_ENVIRON = {"MALLOC_MMAP_THRESHOLD_": 64 << 20, "NUMBA_NUM_THREADS": 1, "OPENCV_FOR_THREADS_NUM": 1}
#: Dask settings of :func:`local_client`'s cluster. Workers: no statistical profiler (a thread that samples the
#: frames' stacks 100 times a second, for the dashboard) and fewer looks at memory (every 100 ms by default): a worker
#: idling between frames cost 30-37 ms of CPU per second, 17-25 ms with these. Scheduler: no work stealing (a
#: worker holds at most two frames at a time anyway, Dask's task queuing): its CPU, taken from the workers' cores on
#: this machine, fell from about 9 to 7 ms per frame.
CLUSTER_CONFIG = {"distributed.worker.profile.enabled": False, "distributed.worker.memory.monitor-interval": "1s",
                  "distributed.admin.system-monitor.interval": "2s", "distributed.scheduler.work-stealing": False}


#: frames of a shared camera take 10-50 ms each on a worker, while every task costs a few ms besides (measured,
#: 1.5 MP frames: 4 ms of the scheduler's CPU, and a fifth of the worker's wall time spent outside the frame); a task
#: carries up to MAX_FRAMES_PER_TASK frames, yet every worker gets about TASKS_PER_WORKER tasks so that they end
#: together and progress moves. Photos fitted one by one (seconds each) stay one per task.
MAX_FRAMES_PER_TASK = 8
TASKS_PER_WORKER = 8


def frames_per_task(frames: int, workers: int, shared_camera: bool) -> int:
    """How many frames one Dask task processes.

    >>> frames_per_task(200, 2, True), frames_per_task(12, 2, True), frames_per_task(200, 2, False)
    (8, 1, 1)
    """
    if not shared_camera:
        return 1
    return max(1, min(MAX_FRAMES_PER_TASK, frames // max(1, workers * TASKS_PER_WORKER)))


def local_client(workers: Optional[int] = None):
    """A ``Client`` of a ``LocalCluster``: ``workers`` processes (default: one per core) of one thread each."""
    import dask
    from distributed import Client, LocalCluster

    settings = {f"distributed.nanny.pre-spawn-environ.{k}": v for k, v in WORKER_ENVIRON.items()}
    with dask.config.set({**settings, **CLUSTER_CONFIG}):
        cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                               dashboard_address=None)
    return Client(cluster)


def check_importable(client, module: str) -> None:
    """Raise an :class:`~.files.InputError` that says what to do when the scheduler or a worker of ``client``
    cannot import ``module`` (the frames' functions travel by name: "monoplot.monoplot_plugin.workflow.cluster" in
    QGIS, where the plugin's folder is the package "monoplot"; without this, every frame failed with "Error during
    deserialization of the task graph" and only the scheduler's log said which module was missing)."""

    def probe(name=module):  # a nested function travels by value: it needs nothing of the plugin
        import importlib

        try:
            importlib.import_module(name)
            return ""
        except Exception as exc:  # noqa: BLE001 (any failure to import is the answer)
            return f"{type(exc).__name__}: {exc}"

    failures = {f"worker {w}": e for w, e in client.run(probe).items() if e}
    scheduler = client.run_on_scheduler(probe)
    if scheduler:
        failures["the scheduler"] = scheduler
    if not failures:
        return
    top = module.split(".")[0]
    here = os.path.dirname(os.path.dirname(os.path.abspath(sys.modules[top].__file__)))
    where, error = next(iter(failures.items()))
    raise InputError(f"{where} cannot import {module} ({error}; {len(failures)} process(es) in all). Start the "
                       f"scheduler and every worker with the folder that holds the package '{top}' on their "
                       f"PYTHONPATH (here: PYTHONPATH={here}) and the same Python packages.")


def _frames_task(tasks: List[FrameTask], setup: Timelapse) -> List[PhotoResult]:
    """What a worker runs for a few frames, one after the other."""
    shared = shared_for(setup)
    return [process_frame(task, shared) for task in tasks]


def _shared_xyz_task(setup: Timelapse) -> str:
    """What a worker runs once before the frames of a shared camera: the one ``xyz.tif``."""
    shared = shared_for(setup)
    if not shared.products.sees_ground:
        return ""
    return shared.products.write_xyz(os.path.join(setup.out_dir, SHARED_XYZ), setup.crs_wkt)


def run_batch_dask(jobs: List[PhotoJob], dem_path: str, crs_wkt: str, out_dir: str, write_xyz: bool = True,
                   write_ortho: bool = True, resolution: Optional[float] = None,
                   log: Log = lambda message, error: None, progress: Progress = no_progress,
                   is_canceled: IsCanceled = never_canceled, register: bool = False, reference: str = "",
                   client=None, address: str = "", void_value: Optional[float] = None,
                   per_task: Optional[int] = None, camera_verdict: tuple = ("ok", ""),
                   resume: bool = False) -> List[PhotoResult]:
    """:func:`~.batch.run_batch` with the frames as Dask tasks (arguments as there; the DEM as a file path).

    ``client``: a ``distributed.Client``; else ``address`` of a scheduler ("tcp://host:8786"); else a local
    cluster of processes (:func:`local_client`), closed at the end. ``per_task``: frames per task (default
    :func:`frames_per_task`). Results come back in job order.
    """
    from distributed import Client

    own = None
    if client is None:
        own = client = Client(address) if address else local_client()
    try:
        os.makedirs(out_dir, exist_ok=True)
        stems = output_stems(jobs)
        tasks = frame_tasks(jobs, stems, log)
        setup = batch_setup(jobs, crs_wkt, os.path.abspath(out_dir), write_xyz, write_ortho, resolution, register,
                            os.path.abspath(reference) if reference else "", dem_path=os.path.abspath(dem_path),
                            void_value=void_value, log=log, camera_verdict=camera_verdict)
        journal, keys, earlier = resumable(tasks, setup, dem_identity(dem_path=setup.dem_path,
                                                                      void_value=void_value), resume, log)
        todo = [t for t in tasks if t.index not in earlier]
        say_replaced(out_dir, jobs, todo, write_xyz, write_ortho, log)
        check_importable(client, _frames_task.__module__)
        workers = len(client.scheduler_info().get("workers", {}))
        per_task = per_task or frames_per_task(len(todo), workers, bool(setup.camera_json))
        log(f"Dask: {len(todo)} frames on {workers} worker(s) of {client.scheduler.address}"
            + (f", {per_task} frames per task" if per_task > 1 else ""), False)
        shared_xyz = None
        if setup.camera_json and write_xyz:  # one task, beside the frames
            shared_xyz = client.submit(_shared_xyz_task, setup, pure=False)
        fresh = _gather(client, todo, per_task, setup, log, progress, is_canceled,
                        lambda t, result: journal.append(t, keys[t.index], result), len(tasks))
        results = list(in_task_order(tasks, earlier, fresh))
        if shared_xyz is not None:
            try:
                shared_xyz.result()
            except Exception as exc:  # the frames' products are there; the shared raster is not
                shared_xyz_failed(results, os.path.join(setup.out_dir, SHARED_XYZ), exc, log)
        _remove_orphans(out_dir, planned_outputs(jobs, stems, write_xyz, write_ortho))
        remove_stale(out_dir, tasks, results, bool(setup.camera_json), log)
        return results
    finally:
        if own is not None:
            cluster = getattr(own, "cluster", None)
            own.close()
            if cluster is not None and not address:
                cluster.close()


def _gather(client, tasks: List[FrameTask], per_task: int, setup: Timelapse, log: Log, progress: Progress,
            is_canceled: IsCanceled, ended_frame=lambda task, result: None, total: int = 0) -> List[PhotoResult]:
    """Submit the frames, ``per_task`` to a task; take each frame's result once (by index) as its task ends, and
    give it to ``ended_frame(task, result)``; cancel the rest on a cancel. ``total``: the batch's photos (the log
    counts them), when ``tasks`` are only those to process.

    Each future reports its end into a queue (Dask calls the callback once, on a thread of its own), so that waiting
    costs nothing per task still pending (waiting on all pending futures after each result cost this process, which
    runs the scheduler too, several milliseconds of CPU per task, taken from the workers on a busy machine)."""
    chunks = [tasks[i: i + per_task] for i in range(0, len(tasks), per_task)]
    futures = dict(zip(client.map(_frames_task, chunks, setup=setup, pure=False), chunks))
    finished: "queue.SimpleQueue" = queue.SimpleQueue()
    for future in futures:
        future.add_done_callback(finished.put)
    done: Dict[int, PhotoResult] = {}
    total = total or len(tasks)
    before = total - len(tasks)  # done by an earlier run
    while len(done) < len(tasks):
        if is_canceled():
            pending = [f for f, chunk in futures.items() if chunk[0].index not in done]
            client.cancel(pending)
            for future in pending:
                for t in futures[future]:
                    done[t.index] = PhotoResult(t.photo, False, "canceled before processing", canceled=True,
                                                index=t.index)
            log(f"canceled: {sum(len(futures[f]) for f in pending)} photos not processed", True)
            break
        try:
            ended = [finished.get(timeout=POLL_S)]
        except queue.Empty:  # nothing finished yet: look at is_canceled again
            continue
        while True:  # every other task that has ended meanwhile: one gather for all of them
            try:
                ended.append(finished.get_nowait())
            except queue.Empty:
                break
        for t, result in _results(client, [f for f in ended if futures[f][0].index not in done], futures):
            done[t.index] = result
            ended_frame(t, result)
            log_result(log, t, total, result)
            progress((before + len(done)) / max(1, total), "")  # its log line named it
    progress(1.0, "")
    return [done[t.index] for t in tasks]


def _results(client, ended: list, futures: dict):
    """(frame task, result) of every frame of the tasks that have ended, fetched in one gather (one trip per worker
    rather than one per task: each trip also takes the worker's event loop, and with it the GIL, from the frame it is
    running). A task that raised, or whose result went with its worker before the gather, is taken on its own."""
    finished = [f for f in ended if f.status == "finished"]
    values = client.gather(finished, errors="skip") if finished else []
    gathered = dict(zip(finished, values)) if len(values) == len(finished) else {}
    for future in ended:
        chunk = futures[future]
        if future in gathered:
            yield from zip(chunk, gathered[future])
            continue
        try:
            yield from zip(chunk, future.result())
        except Exception as exc:  # KilledWorker: the task killed its workers again and again
            for t in chunk:
                yield t, PhotoResult(t.photo, False, f"{type(exc).__name__}: {exc}", index=t.index)


def _remove_orphans(out_dir: str, names: List[str]) -> None:
    """Temporary files of outputs a killed worker was writing (the retry wrote the output itself)."""
    folder = Path(out_dir)
    for name in names:
        stem = name[: len(name) - len(Path(name).suffix)]
        for orphan in folder.glob(f".{stem}.monoplot-tmp-*"):
            try:
                orphan.unlink()
            except OSError:
                pass
