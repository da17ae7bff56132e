"""Core benchmarks: one JSON line per benchmark on stdout (``make bench``).

Each line: name, sizes (image W x H, DEM rows x cols), seconds (median of ``--repeat`` timed runs after one warm-up
run), first_s (the warm-up run, which includes loading numba's compiled cache or compiling), peak_mb (the process's
peak resident memory during the timed runs, inputs included), threads, and the machine's 1-minute load average
(other people's work on shared cores slows the timings). Terrain is generated in code
(core.synthetic), nothing is downloaded.

    .venv/bin/python bench/run_bench.py [--repeat 5] [--only xyz_1.5mp] [--threads N]
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
from monoplot_plugin.core.synthetic import synthetic_terrain  # noqa: E402


def reset_peak() -> None:
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
    except OSError:
        pass


def peak_mb() -> float:
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def scene(rows: int, cell: float, width: int, height: int, seed: int = 0):
    """A DEM and a camera 1 km above a point near the south-west corner, looking north-east over the terrain."""
    dem = synthetic_terrain((rows, rows), cell=cell, seed=seed)
    x, y = dem.cell_to_map(rows * 0.1, rows * 0.9)
    z = float(np.nanmax(dem.elevation)) + 300.0
    cam = Camera((x, y, z), heading=45.0, pitch=-6.0, roll=0.0, fov=60.0, image_size=(width, height))
    return cam, dem


def timed(fn, repeat: int):
    t0 = time.perf_counter()
    out = fn()
    first = time.perf_counter() - t0
    del out
    reset_peak()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
        del out
    return statistics.median(times), first, times


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--only", default="", help="comma-separated benchmark names")
    parser.add_argument("--threads", type=int, default=0, help="numba threads (0 = all cores)")
    args = parser.parse_args()

    from monoplot_plugin.core import xyz as xyz_mod
    from monoplot_plugin.core.render import render_dem
    from monoplot_plugin.core.lookup import orthorectify  # the orthophoto product's own (outputs.orthophoto)
    from monoplot_plugin.core.xyz import compute_xyz, compute_xyz_full

    if args.threads and xyz_mod.HAVE_NUMBA:
        import numba

        numba.set_num_threads(args.threads)
    threads = xyz_mod.numba.get_num_threads() if xyz_mod.HAVE_NUMBA else 1
    only = {s for s in args.only.split(",") if s}

    cases = [
        ("xyz_1.5mp_dem2000", 2000, 25.0, 1500, 1000, "xyz"),
        ("xyz_1.5mp_dem2000_1thread", 2000, 25.0, 1500, 1000, "xyz1"),
        ("xyz_full_1.5mp_dem2000", 2000, 25.0, 1500, 1000, "xyz_full"),
        ("render_1.5mp_dem2000", 2000, 25.0, 1500, 1000, "render"),
        ("ortho_1.5mp_dem2000", 2000, 25.0, 1500, 1000, "ortho"),
        ("xyz_24mp_dem5000", 5000, 10.0, 6000, 4000, "xyz"),
    ]
    cache = {}
    for name, rows, cell, width, height, kind in cases:
        if only and name not in only:
            continue
        key = (rows, cell, width, height)
        if key not in cache:
            cache.clear()
            cache[key] = scene(rows, cell, width, height)
        cam, dem = cache[key]
        run_threads = threads
        if kind in ("xyz", "xyz1"):
            fn = lambda: compute_xyz(cam, dem)  # noqa: E731
            if kind == "xyz1" and xyz_mod.HAVE_NUMBA:
                run_threads = 1
        elif kind == "xyz_full":
            fn = lambda: compute_xyz_full(cam, dem)  # noqa: E731
        elif kind == "render":
            fn = lambda: render_dem(cam, dem)  # noqa: E731
        else:
            photo = np.random.default_rng(0).integers(0, 255, size=(height, width, 3), dtype=np.uint8)
            # what the orthophoto product runs (workflow.products.orthophoto, before writing): z-buffer, then drape
            fn = lambda: orthorectify(photo, cam, dem, compute_xyz(cam, dem))  # noqa: E731
        if xyz_mod.HAVE_NUMBA:
            xyz_mod.numba.set_num_threads(run_threads)
        median, first, times = timed(fn, args.repeat)
        if xyz_mod.HAVE_NUMBA:
            xyz_mod.numba.set_num_threads(threads)
        hit = float(np.isfinite(compute_xyz(cam, dem)[..., 2]).mean()) if kind.startswith("xyz") else None
        line = {"name": name, "image": [width, height], "megapixels": round(width * height / 1e6, 2),
                "dem": [rows, rows], "cell_m": cell, "seconds": round(median, 4), "first_s": round(first, 3),
                "min_s": round(min(times), 4), "peak_mb": round(peak_mb(), 1), "threads": run_threads,
                "repeat": args.repeat, "load_avg_1min": round(os.getloadavg()[0], 2)}
        if hit is not None:
            line["hit_fraction"] = round(hit, 3)
        print(json.dumps(line), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
