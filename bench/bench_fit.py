"""Fit and suggestion benchmarks: one JSON line each on stdout (part of ``make bench``).

- ``fit_unpaired_200x500``: the paper's unpaired fit (refine=False) of 200 photo points to 500 DEM points (150 of
  them without a counterpart in the photo) from a start off by 4 deg in heading, 2 deg in pitch, 8 % in fov and
  100 m; target <= 0.3 s. ``fit_unpaired_200x500_refined``: the same plus automatic pairing, robust refinement and
  leave-one-out (the default). ``fit_paired_11``: paired mode on 11 points.
- ``suggest_photo_24mp``: :func:`suggest_photo_points` on a 6000 x 4000 picture; ``suggest_dem_5000``:
  :func:`suggest_dem_points` on a 5000 x 5000 DEM with an approximate camera; target <= 2 s each.

Seconds are the median of ``--repeat`` runs after one warm-up run (``first_s``: the warm-up, with imports and
numba's cache). Inputs are generated in code (core.synthetic), nothing is downloaded.

    .venv/bin/python bench/bench_fit.py [--repeat 5] [--only fit_unpaired_200x500]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import numpy as np  # noqa: E402

from monoplot_plugin.core.camera import Camera  # noqa: E402


def timed(fn, repeat: int):
    t0 = time.perf_counter()
    out = fn()
    first = time.perf_counter() - t0
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), first, out


def fit_problem(seed: int = 0, n_photo: int = 200, n_world: int = 500):
    """200 photo points (1 px noise) and 500 world points, 150 of them outside the view or without counterpart
    (or other counts in the same proportions)."""
    rng = np.random.default_rng(seed)
    truth = Camera((2_600_000.0, 1_200_000.0, 1500.0), heading=30.0, pitch=-6.0, roll=1.0, fov=60.0,
                   image_size=(1024, 768))
    fwd = truth.forward
    right = np.cross(fwd, [0, 0, 1.0])
    right /= np.linalg.norm(right)
    dist = rng.uniform(2000, 9000, n_world)
    lateral = rng.uniform(-0.9, 0.9, n_world) * dist * 0.6
    world = (np.asarray(truth.position) + dist[:, None] * fwd * np.array([1, 1, 0]) / np.linalg.norm(fwd[:2])
             + lateral[:, None] * right)
    world[:, 2] = rng.uniform(500, 1400, n_world)
    uv = truth.project(world)
    inside = np.flatnonzero(truth.in_image(uv))
    photo = uv[inside[:n_photo]] + rng.normal(0, 1.0, (min(n_photo, len(inside)), 2))
    start = truth.with_parameters(heading=truth.heading + 4, pitch=truth.pitch - 2, fov=truth.fov * 1.08,
                                  x=truth.position[0] + 100)
    return photo, world, start, truth


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--only", default="")
    args = parser.parse_args()
    only = set(filter(None, args.only.split(",")))
    import torch

    torch.set_num_threads(2)
    from monoplot_plugin.core.fit import fit_camera
    from monoplot_plugin.core.suggest import suggest_dem_points, suggest_photo_points

    def emit(name, seconds, first, target=None, **extra):
        line = {"name": name, "seconds": round(seconds, 4), "first_s": round(first, 3), "threads": 2}
        if target is not None:
            line.update(target_s=target, pass_=bool(seconds <= target))
            line["pass"] = line.pop("pass_")
        line.update(extra)
        print(json.dumps(line), flush=True)

    photo, world, start, truth = fit_problem()
    if not only or "fit_unpaired_200x500" in only:
        s, f, r = timed(lambda: fit_camera(photo, world, start, refine=False), args.repeat)
        err = float(np.linalg.norm(np.asarray(r.camera.position) - truth.position))
        emit("fit_unpaired_200x500", s, f, 0.3, sizes="200 photo x 500 DEM points", status=r.status,
             position_error_m=round(err, 2))
    if not only or "fit_unpaired_200x500_refined" in only:
        s, f, r = timed(lambda: fit_camera(photo, world, start), args.repeat)
        err = float(np.linalg.norm(np.asarray(r.camera.position) - truth.position))
        emit("fit_unpaired_200x500_refined", s, f, 1.0, sizes="200 photo x 500 DEM points", status=r.status,
             position_error_m=round(err, 2), pairs=int(r.inliers.sum()))
    if not only or "fit_unpaired_2000x2000" in only:
        big_photo, big_world, big_start, big_truth = fit_problem(1, n_photo=2000, n_world=3000)
        s, f, r = timed(lambda: fit_camera(big_photo, big_world, big_start), max(1, args.repeat // 2))
        err = float(np.linalg.norm(np.asarray(r.camera.position) - big_truth.position))
        emit("fit_unpaired_2000x2000", s, f, 3.0, sizes=f"{len(big_photo)} photo x {len(big_world)} DEM points",
             status=r.status, position_error_m=round(err, 2), pairs=int(r.inliers.sum()))
    if not only or "fit_paired_11" in only:
        pairs = np.stack([np.arange(11)] * 2, axis=1)
        uvw = truth.project(world)
        inside = np.flatnonzero(truth.in_image(uvw))[:11]
        s, f, r = timed(lambda: fit_camera(uvw[inside], world[inside], start, pairs=pairs), args.repeat)
        emit("fit_paired_11", s, f, sizes="11 pairs", status=r.status)

    if not only or only & {"suggest_photo_24mp", "suggest_dem_5000"}:
        from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain

        if not only or "suggest_photo_24mp" in only:
            dem_small = synthetic_terrain((400, 400), cell=25.0, seed=1)
            x, y = dem_small.cell_to_map(200, 395)
            cam = Camera((x, y, float(np.nanmax(dem_small.elevation)) + 200), heading=0, pitch=-8, roll=0, fov=60,
                         image_size=(1500, 1000))
            small = render_photo(cam, dem_small, seed=1)
            import cv2

            image = cv2.resize(small, (6000, 4000), interpolation=cv2.INTER_CUBIC)
            image[:200] = 255  # a paper border
            s, f, r = timed(lambda: suggest_photo_points(image), max(1, args.repeat // 2))
            emit("suggest_photo_24mp", s, f, 2.0, sizes="6000 x 4000 px", points=len(r))
        if not only or "suggest_dem_5000" in only:
            dem = synthetic_terrain((5000, 5000), cell=10.0, seed=2)
            x, y = dem.cell_to_map(2500, 4800)
            cam = Camera((x, y, float(np.nanmax(dem.elevation)) + 300), heading=0, pitch=-8, roll=0, fov=60,
                         image_size=(6000, 4000), crs_wkt=dem.crs_wkt)
            s, f, r = timed(lambda: suggest_dem_points(dem, cam), max(1, args.repeat // 2))
            emit("suggest_dem_5000", s, f, 2.0, sizes="DEM 5000 x 5000, camera 6000 x 4000 px", points=len(r))
            s, f, r = timed(lambda: suggest_dem_points(dem), 1)
            emit("suggest_dem_5000_no_camera", s, f, sizes="DEM 5000 x 5000, map hillshade", points=len(r))
    return 0


if __name__ == "__main__":
    sys.exit(main())
