"""Time-lapse benchmarks (issue 15): one JSON line each on stdout (``make bench``).

- ``timelapse_batch``: one camera, 1.5 MP, 200 JPEG frames, XYZ (one shared raster) + an orthophoto per frame,
  through :func:`monoplot_plugin.workflow.batch.run_batch` on all cores, and on one (frames/s, wall time including
  the once-per-camera XYZ and orthophoto lookup). Target >= 20 frames/s on 2 cores.
- ``reregistration``: frames rendered with known turns (up to 2 degrees) in changed light and exposure, registered
  on the reference (:func:`monoplot_plugin.core.drift.register`): largest and median error in pixels, frames/s.
  Targets <= 0.5 px, >= 5 frames/s. ``reregistered_batch``: the same frames through the batch with ``register``,
  orthophotos only (a turned frame's lookup from the rays kept once), then with an XYZ raster per turned frame.
- ``dask_batch``: the batch as Dask tasks (several frames to a task) on a LocalCluster of 1 then 2 worker
  processes (after a warm-up run that builds each worker's shared products): frames/s and the ratio to twice the
  one-worker rate (target >= 0.8). The timed run is a whole batch (submission, the frames, the shared ``xyz.tif``
  written once, the last result back); the CPU seconds per frame of this process (client and scheduler) and of the
  workers (all their threads) say how much of the two cores Dask itself takes, whatever the load.

Every line carries the 1-minute load average (shared cores: other people's work slows the timings).

    .venv/bin/python bench/bench_timelapse.py [--frames 200] [--only timelapse_batch,reregistration,dask_batch]
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402

from bench.run_bench import scene  # noqa: E402
from monoplot_plugin.core import drift  # noqa: E402
from monoplot_plugin.core.synthetic import render_photo  # noqa: E402
from monoplot_plugin.workflow import batch  # noqa: E402

WIDTH, HEIGHT = 1500, 1000  # 1.5 MP


def load() -> float:
    return round(os.getloadavg()[0], 2)


def emit(**fields) -> None:
    fields.setdefault("load_1min", load())
    fields.setdefault("cores", os.cpu_count())
    print(json.dumps(fields), flush=True)


def write_frames(folder: Path, photo: np.ndarray, count: int) -> None:
    """``count`` JPEG frames of one view, each with its own exposure and sensor noise."""
    import cv2

    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    for i in range(count):
        frame = np.clip(photo * rng.uniform(0.85, 1.1) + rng.normal(0, 3, photo.shape), 0, 255).astype(np.uint8)
        cv2.imwrite(str(folder / f"frame_{i:04d}.jpg"), frame[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, 90])


def bench_timelapse(work: Path, frames: int) -> None:
    cam, dem = scene(400, 25.0, WIDTH, HEIGHT)
    write_frames(work / "frames", render_photo(cam, dem, seed=1), frames)
    jobs = batch.folder_jobs(str(work / "frames"), cam)
    for workers in (os.cpu_count() or 1, 1):
        from monoplot_plugin.workflow.xyz import clear_cache

        clear_cache()
        start = time.perf_counter()
        results = batch.run_batch(jobs, dem, dem.crs_wkt, str(work / f"out{workers}"), workers=workers)
        seconds = time.perf_counter() - start
        emit(name="timelapse_batch", image=f"{WIDTH}x{HEIGHT}", dem=f"{dem.rows}x{dem.cols}", frames=frames,
             workers=workers, ok=sum(r.ok for r in results), seconds=round(seconds, 2),
             frames_per_s=round(frames / seconds, 2), target_frames_per_s=20.0)


def turned_frames(count: int):
    """(camera, dem, reference photo, [(photo, true camera)]) with turns up to 2 degrees and other light."""
    cam, dem = scene(400, 25.0, WIDTH, HEIGHT)
    reference = render_photo(cam, dem, seed=1)
    rng = np.random.default_rng(5)
    frames = []
    for _ in range(count):
        dh, dp, dr = rng.uniform(-2.0, 2.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)
        scale = 2.0 / max(2.0, np.degrees(np.hypot(np.hypot(np.radians(dh), np.radians(dp)), np.radians(dr))))
        true = cam.with_parameters(heading=cam.heading + dh * scale, pitch=cam.pitch + dp * scale,
                                   roll=cam.roll + dr * scale)
        photo = render_photo(true, dem, seed=1, sun_azimuth=135.0 + rng.uniform(-40, 40),
                             sun_altitude=40.0 + rng.uniform(-15, 10))
        photo = np.clip(photo * rng.uniform(0.7, 1.2) + rng.uniform(-20, 20), 0, 255).astype(np.uint8)
        frames.append((photo, true))
    return cam, dem, reference, frames


def bench_registration(work: Path, count: int) -> None:
    import cv2

    from monoplot_plugin.core.xyz import compute_xyz

    cam, dem, reference_photo, frames = turned_frames(count)
    start = time.perf_counter()
    reference = drift.Reference(reference_photo, cam, drift.stable_mask(compute_xyz(cam, dem), cam))
    reference_s = time.perf_counter() - start
    errors, times, failed = [], [], 0
    for photo, true in frames:
        start = time.perf_counter()
        found = drift.register(reference, photo)
        times.append(time.perf_counter() - start)
        if not found.ok:
            failed += 1
            continue
        errors.append(drift.pixel_shift(cam, found.rotation, true.rotation @ cam.rotation.T))
    from concurrent.futures import ThreadPoolExecutor

    cores = os.cpu_count() or 1
    start = time.perf_counter()
    with ThreadPoolExecutor(cores) as pool:  # as the batch runs it: a frame per core (OpenCV releases the GIL)
        list(pool.map(lambda frame: drift.register(reference, frame[0]), frames))
    parallel_s = time.perf_counter() - start
    emit(name="reregistration", image=f"{WIDTH}x{HEIGHT}", frames=count, registered=count - failed,
         max_error_px=round(max(errors), 3) if errors else None,
         median_error_px=round(float(np.median(errors)), 3) if errors else None,
         frames_per_s=round(count / sum(times), 2), frames_per_s_all_cores=round(count / parallel_s, 2),
         reference_s=round(reference_s, 2), target_error_px=0.5, target_frames_per_s=5.0)
    folder = work / "turned"
    folder.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(folder / "frame_0000.png"), reference_photo[..., ::-1])
    for i, (photo, _) in enumerate(frames, start=1):
        cv2.imwrite(str(folder / f"frame_{i:04d}.png"), photo[..., ::-1])
    jobs = batch.folder_jobs(str(folder), cam)
    for write_xyz in (False, True):
        start = time.perf_counter()
        results = batch.run_batch(jobs, dem, dem.crs_wkt, str(work / f"turned_out{write_xyz}"), register=True,
                                  write_xyz=write_xyz)
        seconds = time.perf_counter() - start
        emit(name="reregistered_batch", image=f"{WIDTH}x{HEIGHT}", frames=len(jobs), xyz=write_xyz,
             ok=sum(r.ok for r in results), seconds=round(seconds, 2), frames_per_s=round(len(jobs) / seconds, 2),
             note=("every turned frame gets its own XYZ raster (a z-buffer and a 36 MB write), lookup and camera"
                   if write_xyz else "orthophotos: a turned frame's lookup from the rays kept once"))


def bench_dask(work: Path, frames: int) -> None:
    from monoplot_plugin.workflow.cluster import local_client, run_batch_dask

    cam, dem = scene(400, 25.0, WIDTH, HEIGHT)
    folder = work / "dask_frames"
    write_frames(folder, render_photo(cam, dem, seed=1), frames)
    dem_path = str(work / "dem.tif")
    dem.save(dem_path)
    jobs = batch.folder_jobs(str(folder), cam)
    rates, per_frame = {}, {}
    for workers in (1, 2):
        client = local_client(workers)
        try:
            out = str(work / f"dask_out{workers}")
            run_batch_dask(jobs[: 2 * workers], dem_path, dem.crs_wkt, out, client=client)  # warm-up
            cpu0 = _cpu_seconds()
            own0, workers0 = time.process_time(), client.run(time.process_time)
            start = time.perf_counter()
            results = run_batch_dask(jobs, dem_path, dem.crs_wkt, out, client=client)
            seconds = time.perf_counter() - start
            machine = (_cpu_seconds() - cpu0) / seconds  # cores busy, every process of the machine
            workers1 = client.run(time.process_time)
            # CPU per frame, which the load of other jobs changes little: this process (client and scheduler) and
            # the workers (every thread: the frames, Dask's own work, the shared XYZ raster's write)
            own_ms = 1000.0 * (time.process_time() - own0) / frames
            workers_ms = 1000.0 * sum(workers1[w] - workers0[w] for w in workers1 if w in workers0) / frames
            roundtrip = _roundtrip_ms(client)
        finally:
            client.close()
            client.cluster.close()
        rates[workers] = frames / seconds
        busy = float(np.nansum([r.seconds for r in results]))
        per_frame[workers] = busy / max(1, len(results))
        # busy: the share of the workers' wall time spent inside the frames (the rest: scheduling, transfers);
        # frame_s: a frame's own time on its worker (grows with two workers when they compete for the cores)
        emit(name="dask_batch", image=f"{WIDTH}x{HEIGHT}", frames=frames, workers=workers,
             ok=sum(r.ok for r in results), seconds=round(seconds, 2), frames_per_s=round(rates[workers], 2),
             frame_s=round(per_frame[workers], 4), workers_busy=round(busy / (workers * seconds), 3),
             machine_cores_busy=round(machine, 2), noop_task_roundtrip_ms=round(roundtrip, 2),
             task_bytes=_pickled(jobs, dem_path, dem.crs_wkt, out), result_bytes=len(pickle.dumps(results[0])),
             cpu_ms_per_frame_scheduler_client=round(own_ms, 2), cpu_ms_per_frame_workers=round(workers_ms, 2))
    emit(name="dask_scaling", ratio_to_twice_one_worker=round(rates[2] / (2.0 * rates[1]), 3), target=0.8,
         frame_time_growth=round(per_frame[2] / per_frame[1], 3))


def _cpu_seconds() -> float:
    """CPU seconds the whole machine has spent (user + system, every core), from /proc/stat."""
    with open("/proc/stat") as fh:
        fields = [float(v) for v in fh.readline().split()[1:]]
    return (fields[0] + fields[1] + fields[2]) / os.sysconf("SC_CLK_TCK")


def _roundtrip_ms(client, count: int = 50) -> float:
    """Milliseconds from submitting a task that does nothing to having its result, the median of ``count``."""
    times = []
    for i in range(count):
        t0 = time.perf_counter()
        client.submit(abs, -i, pure=False).result()
        times.append(time.perf_counter() - t0)
    return 1000.0 * float(np.median(times))


def _pickled(jobs, dem_path: str, crs_wkt: str, out: str) -> int:
    """Bytes of one frame's task as sent: the task and the shared set-up (which carries paths, not arrays)."""
    from monoplot_plugin.workflow.batch import batch_setup, frame_tasks, output_stems

    task = frame_tasks(jobs[:1], output_stems(jobs[:1]), lambda message, error: None)[0]
    return len(pickle.dumps((task, batch_setup(jobs, crs_wkt, out, dem_path=dem_path))))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=200)
    parser.add_argument("--turned", type=int, default=12, help="frames of the re-registration benchmark")
    # 200 as the time-lapse target: runs of 60 frames last about 1 s, much of it start-up noise
    parser.add_argument("--dask-frames", type=int, default=200)
    parser.add_argument("--only", default="timelapse_batch,reregistration,dask_batch")
    args = parser.parse_args()
    only = set(args.only.split(","))
    work = Path(tempfile.mkdtemp(prefix="monoplot-bench-timelapse-"))
    try:
        if "timelapse_batch" in only:
            bench_timelapse(work, args.frames)
        if "reregistration" in only:
            bench_registration(work, args.turned)
        if "dask_batch" in only:
            bench_dask(work, args.dask_frames)
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
