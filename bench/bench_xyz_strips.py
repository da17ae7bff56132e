"""Memory-bounded XYZ raster (``make bench``): a 300 MP photo (20,000 x 15,000 px) over the 24 MP benchmark's
terrain, computed strip by strip within a 3 GB budget and written to a GeoTIFF; one JSON line (seconds, peak MB
of the process while it runs, the DEM included, strips, file size). At once it would need 12 GB.

    .venv/bin/python bench/bench_xyz_strips.py [--width 20000 --height 15000 --budget-mb 3000]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from bench.run_bench import peak_mb, reset_peak, scene  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=int, default=20000)
    parser.add_argument("--height", type=int, default=15000)
    parser.add_argument("--budget-mb", type=float, default=3000.0)
    args = parser.parse_args()

    from monoplot_plugin.core.xyz_strips import plan_strips, xyz_memory, xyz_strips
    from monoplot_plugin.outputs.xyz_raster import storage_dtype_for_range, write_xyz_raster_strips

    cam, dem = scene(5000, 10.0, args.width, args.height)
    reset_peak()  # the peak of the strips, not of generating the terrain
    budget = int(args.budget_mb * (1 << 20))
    rows = plan_strips(cam, budget=budget, fixed=3 * dem.elevation.nbytes)
    xmin, ymin, xmax, ymax = dem.bounds()
    dtype = storage_dtype_for_range(min(xmin, ymin), max(xmax, ymax))
    with tempfile.TemporaryDirectory(dir=os.environ.get("MONOPLOT_BENCH_DIR")) as folder:
        path = os.path.join(folder, "xyz.tif")
        t0 = time.perf_counter()
        write_xyz_raster_strips(path, xyz_strips(cam, dem, rows_per_strip=rows), cam.width, cam.height,
                                dem.crs_wkt, dtype)
        seconds = time.perf_counter() - t0
        size = os.path.getsize(path)
    print(json.dumps({"name": f"xyz_strips_{cam.width * cam.height / 1e6:.0f}mp_dem5000", "image": list(cam.image_size),
                      "at_once_gb": round(xyz_memory(cam) / 1e9, 2), "budget_mb": args.budget_mb,
                      "rows_per_strip": rows, "strips": -(-cam.height // rows), "seconds": round(seconds, 1),
                      "peak_mb": round(peak_mb(), 1), "file_mb": round(size / 1e6, 1), "dtype": dtype,
                      "load_avg_1min": round(os.getloadavg()[0], 2)}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
