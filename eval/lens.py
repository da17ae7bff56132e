"""`make eval`: photos through a lens that bends them, fitted as a pinhole: does the verdict say so?

A phone's or an old camera's lens distorts the picture radially; the default fit has no ``k1``. Scenes
(deterministic from ``--seed``): generated terrain, a camera 300 m over it with a 4000 x 3000 picture, field of view
50 or 70 deg, ``k1`` of 0 (a pinhole: the control), -0.03, -0.08 or -0.15 (barrel); 40 photo points with 1 px noise
on the terrain they see; a rough camera 30 m, 2 deg and 5 % of the field of view off; fitted paired and unpaired
without ``k1`` (the default), and again with ``k1`` free as the verdict's message advises.

Per fit: status, RMSE, the camera's error on a 20 x 15 grid of the terrain the true camera sees (pixels, median and
maximum), its position error. Success: the grid's median error within 3 px (the pinhole fits of the control reach
0.3-0.4 px). Output: one JSON line per case and a summary line (``wrong_ok``: "ok" fits that fail; ``flagged``:
distorted scenes whose default fit's message says to free k1; ``freed_ok_success``: those fitted again with ``k1``
that are "ok" and succeed).

Run: ``.venv/bin/python -m eval.lens [--seeds 3] [--seed 0]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from monoplot_plugin.core.camera import Camera  # noqa: E402
from monoplot_plugin.core.fit import DEFAULT_FREE, fit_camera  # noqa: E402
from monoplot_plugin.core.synthetic import synthetic_terrain  # noqa: E402
from monoplot_plugin.core.transforms import photo_points_to_map  # noqa: E402

K1S = (0.0, -0.03, -0.08, -0.15)
FOVS = (50.0, 70.0)
SUCCESS_PX = 3.0


def run_case(dem, k1: float, fov: float, paired: bool, seed: int) -> dict:
    rng = np.random.default_rng([seed, int(-k1 * 1000), int(fov), int(paired)])
    x0, y0, x1, _ = dem.bounds()
    x, y = (x0 + x1) / 2 + rng.uniform(-500, 500), y0 + 500 + rng.uniform(0, 300)
    truth = Camera((x, y, float(dem.sample(x, y)) + 300), rng.uniform(-10, 10), -8.0, 0.0, fov, (4000, 3000),
                   crs_wkt=dem.crs_wkt, k1=k1)
    uv = rng.uniform([0, 0], [4000, 3000], (400, 2))
    ground, seen = photo_points_to_map(uv, truth, dem)
    uv, ground = uv[seen][:40], ground[seen][:40]
    observed = uv + rng.normal(0, 1.0, uv.shape)
    prior = truth.with_parameters(k1=0.0, x=x + 30, heading=truth.heading + 2.0, fov=fov * 1.05)
    grid = np.stack(np.meshgrid(np.linspace(50, 3950, 20), np.linspace(50, 2950, 15)), -1).reshape(-1, 2)
    grid_ground, grid_seen = photo_points_to_map(grid, truth, dem)
    pairs = np.column_stack([np.arange(len(uv))] * 2) if paired else None
    out = {"k1": k1, "fov": fov, "mode": "paired" if paired else "unpaired", "seed": seed}
    for name, free in (("default", None), ("k1_free", tuple(DEFAULT_FREE) + ("k1",))):
        t0 = time.perf_counter()
        r = fit_camera(observed, ground, prior, pairs=pairs, free=free)
        err = np.linalg.norm(r.camera.project(grid_ground[grid_seen]) - grid[grid_seen], axis=1)
        out[name] = {"status": r.status, "rmse_px": round(float(r.rmse_px), 2),
                     "grid_err_px_median": round(float(np.median(err)), 2),
                     "grid_err_px_max": round(float(np.max(err)), 1),
                     "position_error_m": round(float(np.linalg.norm(np.subtract(r.camera.position,
                                                                                 truth.position))), 1),
                     "success": bool(np.median(err) <= SUCCESS_PX), "flagged": "free k1" in r.message,
                     "lens_f": round(float(r.evidence.get("lens_f", np.nan)), 1), "fit_s": round(
                         time.perf_counter() - t0, 2)}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    dem = synthetic_terrain((200, 200), cell=30.0, seed=3)
    records = [run_case(dem, k1, fov, paired, args.seed + s) for s in range(args.seeds) for k1 in K1S
               for fov in FOVS for paired in (True, False)]
    for r in records:
        print(json.dumps(r))
    bent = [r for r in records if r["k1"] != 0.0]
    plain = [r for r in records if r["k1"] == 0.0]
    summary = {
        "suite": "lens", "n": len(records),
        "wrong_ok": sum(r["default"]["status"] == "ok" and not r["default"]["success"] for r in records),
        "distorted_default_success": sum(r["default"]["success"] for r in bent), "distorted": len(bent),
        "flagged": sum(r["default"]["flagged"] for r in bent),
        "pinhole_flagged": sum(r["default"]["flagged"] for r in plain), "pinhole_ok": sum(
            r["default"]["status"] == "ok" for r in plain), "pinhole": len(plain),
        "freed_ok_success": sum(r["k1_free"]["status"] == "ok" and r["k1_free"]["success"] for r in bent),
        "runtime_s": round(time.perf_counter() - t0, 1)}
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
