"""Automatic registration benchmark (issue 13): one JSON line on stdout (part of ``make bench``).

``auto_24mp_25mcells``: :func:`~monoplot_plugin.core.register_automatic` on a 6000 x 4000 photo rendered from a
5000 x 5000-cell generated DEM (4 m cells), from a prior 3 deg / 100 m off; target <= 20 s on 2 cores. The photo is
rendered at 1500 x 1000 and enlarged (rendering 24 MP would dominate the set-up, not the measure); the registration
reduces it internally. ``cancel_s``: time from a cancel request 2 s into a second run until it returns; target <= 1 s.

    .venv/bin/python bench/bench_auto.py [--size 6000x4000] [--cells 5000]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


from monoplot_plugin.core import register_automatic  # noqa: E402
from monoplot_plugin.core.camera import Camera  # noqa: E402
from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="6000x4000")
    ap.add_argument("--cells", type=int, default=5000)
    args = ap.parse_args(argv)
    import cv2

    w, h = (int(v) for v in args.size.split("x"))
    n = args.cells
    cell = 20000.0 / n
    dem = synthetic_terrain((n, n), cell=cell, seed=11)
    x0, y0, x1, y1 = dem.bounds()
    x, y = (x0 + x1) / 2, y0 + 0.03 * (y1 - y0)
    truth = Camera((x, y, float(dem.sample(x, y)) + 400.0), -5.0, -3.0, 0.0, 55.0, (w, h), crs_wkt=dem.crs_wkt)
    small = truth.scaled(1500.0 / w)
    photo = cv2.resize(render_photo(small, dem, seed=3), (w, h), interpolation=cv2.INTER_LINEAR)
    prior = truth.with_parameters(heading=truth.heading + 3.0, pitch=truth.pitch + 1.0, x=x + 100.0)
    t0 = time.perf_counter()
    r = register_automatic(photo, dem, prior, position_sigma_m=150.0, angle_sigma_deg=3.0)
    seconds = time.perf_counter() - t0
    asked = threading.Event()
    threading.Timer(2.0, asked.set).start()
    t1 = time.perf_counter()
    rc = register_automatic(photo, dem, prior, is_canceled=asked.is_set)
    cancel_s = time.perf_counter() - t1 - 2.0
    print(json.dumps({"bench": "auto_24mp_25mcells", "photo": f"{w}x{h}", "dem_cells": n * n,
                      "seconds": round(seconds, 2), "target_s": 20.0, "pass": bool(seconds <= 20.0),
                      "status": r.status, "heading_error_deg": round(abs(r.camera.heading - truth.heading), 3),
                      "cancel_s": round(cancel_s, 2), "cancel_status": rc.status,
                      "cancel_pass": bool(rc.status == "canceled" and cancel_s <= 1.0),
                      "load": os.getloadavg()[0]}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
