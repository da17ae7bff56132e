"""`make eval`: the fully automatic registration (issue 13) measured; one JSON line per case.

Cases:

1. ``auto_aletsch``: the Aletsch photo, DEM and ``prior_pose.kml`` (46 px off on the 11 GCPs); target <= 12 px on the
   GCPs (the least-squares optimum on them is 7.7 px). The GCPs are only measured, never given.
2. ``auto_aletsch_perturbed``: 20 priors perturbed from the KML one (position +-300 m, heading +-10 deg, pitch
   +-5 deg, fov +-10 %, uniform, fixed seed); target >= 90 % within 15 px and every failure not "ok".
3. ``auto_synthetic``: ``--scenes`` (default 50) scenes rendered by :func:`~monoplot_plugin.core.synthetic.
   render_photo` (texture, haze, noise) over generated terrain (cells 30-80 m, fov 35-75 deg, camera 30-400 m above
   the ground, terrain seen at a median 0.1-7 km, sky over the top of the picture); priors off by up to 150 m, 5 deg
   heading, 2.5 deg pitch, 1 deg roll, 5 % fov; target >= 95 % within 1 % of the range in position and 0.2 deg in
   heading, pitch and roll. A wrong camera called "ok" is counted (``wrong_but_ok``).
4. ``auto_fog``: a synthetic scene whose photo is replaced by fog (uniform grey with noise): must not be "ok".
   ``auto_no_sky``: scenes whose terrain fills the whole picture (a slope seen from a few metres above the ground,
   no skyline): must not be "ok".
5. ``auto_synthetic_default_sigma``: the first ``--default-scenes`` (default 20) synthetic scenes registered with the
   registration's default σ (200 m, 5 deg, 10 % fov: what the dock uses) instead of the eval's tighter 150 m / 3 deg /
   5 %: a wider search finds more wrong cameras, and none may say "ok" (``wrong_but_ok``; also counted: an "ok"
   more than 1 % of the diagonal off on the terrain grid).

6. ``auto_heading_unknown``: the first ``--heading-scenes`` (default 8) synthetic scenes and the Aletsch case with
   the prior's heading turned 60-300 deg away (a photo with GPS but no direction tag), registered by
   :func:`~monoplot_plugin.core.register_any_heading` with the default angle σ; success as in 3 (Aletsch: <= 15 px);
   every failure must be reported not "ok".

Run: ``.venv/bin/python -m eval.auto [--data DIR] [--scenes 50] [--heading-scenes 8]
[--cases aletsch,synthetic,fog,no_sky,default_sigma,heading]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Optional

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from monoplot_plugin.core import register_any_heading, register_automatic  # noqa: E402
from monoplot_plugin.core.camera import Camera  # noqa: E402
from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain  # noqa: E402

from eval.aletsch import gcp_errors, load_case  # noqa: E402


def emit(line: dict) -> None:
    print(json.dumps(line), flush=True)


def perturb(cam: Camera, rng, pos_m, heading_deg, pitch_deg, fov_frac, roll_deg=0.0, z_m=None) -> Camera:
    x, y, z = cam.position
    z_m = pos_m / 3.0 if z_m is None else z_m
    return cam.with_parameters(x=x + rng.uniform(-pos_m, pos_m), y=y + rng.uniform(-pos_m, pos_m),
                               z=z + rng.uniform(-z_m, z_m),
                               heading=cam.heading + rng.uniform(-heading_deg, heading_deg),
                               pitch=cam.pitch + rng.uniform(-pitch_deg, pitch_deg),
                               roll=cam.roll + rng.uniform(-roll_deg, roll_deg),
                               fov=cam.fov * (1.0 + rng.uniform(-fov_frac, fov_frac)))


def case_aletsch(data: Path, n_perturbed: int, seed: int = 13):
    dem, gcps, image, prior = load_case(data)
    r = register_automatic(image, dem, prior, position_sigma_m=200.0, angle_sigma_deg=5.0)
    e = gcp_errors(r.camera, gcps, dem)
    emit({"case": "auto_aletsch", "status": r.status, **e, "prior_px": gcp_errors(prior, gcps, dem)["gcp_rmse_px"],
          "aligned_px": gcp_errors(r.aligned, gcps, dem)["gcp_rmse_px"] if r.aligned else None, "target_px": 12.0,
          "pass": bool(e["gcp_rmse_px"] <= 12.0), "seconds": round(r.elapsed_s, 1), "message": r.message})
    if not n_perturbed:
        return
    rng = np.random.default_rng(seed)
    rows = []
    for _ in range(n_perturbed):
        start = perturb(prior, rng, 300.0, 10.0, 5.0, 0.10)
        r = register_automatic(image, dem, start, position_sigma_m=200.0, angle_sigma_deg=5.0)
        px = gcp_errors(r.camera, gcps, dem)["gcp_rmse_px"]
        rows.append((px, r.status, r.elapsed_s, gcp_errors(start, gcps, dem)["gcp_rmse_px"],
                     gcp_errors(r.aligned, gcps, dem)["gcp_rmse_px"] if r.aligned else float("nan")))
    good = [p <= 15.0 for p, *_ in rows]
    honest = all(s != "ok" for (p, s, *_), g in zip(rows, good) if not g)
    emit({"case": "auto_aletsch_perturbed", "n": len(rows), "within_15px": int(sum(good)),
          "share_within_15px": round(float(np.mean(good)), 3), "failures_not_ok": honest,
          "statuses": [s for _, s, *_ in rows], "gcp_px": [round(p, 1) for p, *_ in rows],
          "start_px": [round(row[3], 1) for row in rows], "aligned_px": [round(row[4], 1) for row in rows],
          "median_s": round(float(np.median([row[2] for row in rows])), 1),
          "target": ">= 90 % within 15 px, every failure not ok",
          "pass": bool(np.mean(good) >= 0.9 and honest)})


def make_scene(k: int, seed: int = 0, sky: bool = True):
    """(dem, truth camera, photo, prior, median range of the terrain seen) of synthetic scene ``k``.

    ``sky``: the truth sees sky over most of the top of the picture and terrain over more than a third of it (a
    picture the skyline method is for); ``False``: terrain fills the whole picture (a slope in front of the camera,
    no skyline at all). A terrain where 30 cameras miss that is replaced by a new one: a scene is never one of the
    other kind.
    """
    from monoplot_plugin.core.xyz import compute_xyz_full

    rng = np.random.default_rng(1000 * seed + k + (0 if sky else 500_000))
    for _terrain in range(20):
        cell = float(rng.choice([30.0, 50.0, 80.0]))
        n = 260
        dem = synthetic_terrain((n, n), cell=cell, seed=int(rng.integers(1 << 30)))
        x0, y0, x1, y1 = dem.bounds()
        ext = x1 - x0
        width = 800
        height = int(rng.choice([533, 600]))
        fov = float(rng.uniform(35.0, 75.0))
        for _ in range(30):
            x = x0 + ext * rng.uniform(0.35, 0.65)
            y = y0 + ext * (rng.uniform(0.04, 0.12) if sky else rng.uniform(0.3, 0.7))
            heading = float(rng.uniform(-20, 20)) if sky else float(rng.uniform(-180, 180))
            z = float(dem.sample(x, y)) + float(rng.uniform(30.0, 400.0) if sky else rng.uniform(5.0, 40.0))
            pitch = float(rng.uniform(-6.0, 2.0)) if sky else float(rng.uniform(-20.0, -8.0))
            cam = Camera((x, y, z), heading, pitch, float(rng.uniform(-2, 2)), fov, (width, height),
                         crs_wkt=dem.crs_wkt)
            res = compute_xyz_full(cam.scaled(0.1), dem, visibility=False)
            hit = res.hit
            wanted = hit.mean() > 0.35 and (~hit[0]).mean() > 0.7 if sky else hit.all()
            if wanted:
                photo = render_photo(cam, dem, seed=k)
                rng_m = float(np.nanmedian(res.distance[hit]))
                prior = perturb(cam, rng, 150.0, 5.0, 2.5, 0.05, roll_deg=1.0, z_m=50.0)
                return dem, cam, photo, prior, rng_m
    raise RuntimeError(f"no {'sky' if sky else 'no-sky'} scene found for scene {k}")


def errors(cam: Camera, truth: Camera, rng_m: float) -> dict:
    pos = float(np.linalg.norm(np.subtract(cam.position, truth.position)))
    ang = max(abs((cam.heading - truth.heading + 180) % 360 - 180), abs(cam.pitch - truth.pitch),
              abs(cam.roll - truth.roll))
    return {"position_m": round(pos, 1), "position_share": round(pos / rng_m, 4), "angle_deg": round(ang, 3),
            "fov_deg": round(abs(cam.fov - truth.fov), 3)}


def within_two_sigma(cam: Camera, truth: Camera, std: dict) -> bool:
    """True when every parameter of ``cam`` with a σ in ``std`` lies within 2 σ of ``truth``'s (heading wrapped)."""
    a, b = cam.parameters(), truth.parameters()
    for name, s in std.items():
        if name not in a or not np.isfinite(s):
            continue
        d = a[name] - b[name]
        d = (d + 180.0) % 360.0 - 180.0 if name == "heading" else d
        if abs(d) > 2.0 * s:
            return False
    return True


def grid_error(cam: Camera, truth: Camera, dem) -> float:
    """RMS pixel distance between ``cam`` and ``truth`` over the terrain ``truth`` sees on a 24 x 16 pixel grid."""
    from monoplot_plugin.core.xyz import compute_xyz_full

    res = compute_xyz_full(truth.scaled(24.0 / truth.width), dem, visibility=False)
    xyz = res.xyz[res.hit]
    if not len(xyz):
        return float("nan")
    d = cam.project(xyz) - truth.project(xyz)
    return round(float(np.sqrt(np.nanmean(np.sum(d * d, axis=1)))), 2)


def case_synthetic(n: int, seed: int = 0, fog: bool = False, default_sigma: bool = False, no_sky: bool = False):
    rows = []
    name = "auto_synthetic_default_sigma" if default_sigma else "auto_synthetic"
    honest = "auto_fog" if fog else "auto_no_sky" if no_sky else None  # cases that must not end "ok"
    for k in range(n):
        dem, truth, photo, prior, rng_m = make_scene(k, seed, sky=not no_sky)
        if fog:
            photo = np.clip(np.random.default_rng(k).normal(200, 3, photo.shape), 0, 255).astype(np.uint8)
        given = {} if default_sigma else dict(position_sigma_m=150.0, angle_sigma_deg=3.0,
                                              fov_sigma_deg=0.05 * prior.fov)
        r = register_automatic(photo, dem, prior, **given)
        e = errors(r.camera, truth, rng_m)
        e["grid_px"] = grid_error(r.camera, truth, dem)
        e["within_2sigma"] = within_two_sigma(r.camera, truth, r.std or {})
        # the alignment's evidence, for calibrating the verdict (which of it separates right from wrong cameras)
        e["evidence"] = {k: round(v, 3) if isinstance(v, float) else v for k, v in r.evidence.items()
                         if k.startswith("auto_") and isinstance(v, (bool, int, float))}
        if getattr(r, "aligned", None) is not None:  # the edge alignment alone, before the suggestions' fit
            e["aligned"] = {**errors(r.aligned, truth, rng_m), "grid_px": grid_error(r.aligned, truth, dem)}
        ok = e["position_share"] <= 0.01 and e["angle_deg"] <= 0.2
        rows.append({"scene": k, "status": r.status, "success": bool(ok), **e, "range_m": round(rng_m),
                     "prior": errors(prior, truth, rng_m), "seconds": round(r.elapsed_s, 1)})
        emit({"case": (honest or name) + "_scene", **rows[-1]})
    if honest:
        emit({"case": honest, "n": n, "statuses": [x["status"] for x in rows],
              "pass": all(x["status"] != "ok" for x in rows)})
        return
    succ = [x["success"] for x in rows]
    emit({"case": name, "n": n, "successes": int(sum(succ)), "share": round(float(np.mean(succ)), 3),
          "ok": sum(x["status"] == "ok" for x in rows),
          "wrong_but_ok": sum(x["status"] == "ok" and not x["success"] for x in rows),
          "ok_but_grid_over_1pct_diag": sum(x["status"] == "ok" and x["grid_px"] > 0.01 * 1000 for x in rows),
          "median_grid_px": round(float(np.median([x["grid_px"] for x in rows])), 2),
          # honest σ: the true camera within 2 σ (every parameter), over the "ok" results and over all
          "sigma_coverage_ok": _share([x["within_2sigma"] for x in rows if x["status"] == "ok"]),
          "sigma_coverage_all": _share([x["within_2sigma"] for x in rows]),
          "median_position_share": round(float(np.median([x["position_share"] for x in rows])), 4),
          "median_angle_deg": round(float(np.median([x["angle_deg"] for x in rows])), 3),
          "median_s": round(float(np.median([x["seconds"] for x in rows])), 1),
          **({"target": "no wrong camera says ok",
              "pass": not any(x["status"] == "ok" and not x["success"] for x in rows)} if default_sigma else
             {"target": ">= 95 % within 1 % of range and 0.2 deg", "pass": bool(np.mean(succ) >= 0.95)})})


def case_heading_unknown(n: int, data: Path, seed: int = 29):
    """Priors whose heading is a guess: turned 60-300 deg from the truth (the search must find the direction)."""
    rng = np.random.default_rng(seed)
    rows = []
    for k in range(n + 1):
        turn = float(rng.uniform(60.0, 300.0))
        if k == n:  # the real case last
            dem, gcps, image, prior = load_case(data)
            start = prior.with_parameters(heading=prior.heading + turn)
            r = register_any_heading(image, dem, start, position_sigma_m=200.0)
            px = gcp_errors(r.camera, gcps, dem)["gcp_rmse_px"]
            row = {"scene": "aletsch", "turn_deg": round(turn), "status": r.status, "gcp_px": round(px, 2),
                   "success": bool(px <= 15.0), "seconds": round(r.elapsed_s, 1)}
        else:
            dem, truth, photo, prior, rng_m = make_scene(k)
            r = register_any_heading(photo, dem, prior.with_parameters(heading=prior.heading + turn),
                                     position_sigma_m=150.0)
            e = errors(r.camera, truth, rng_m)
            row = {"scene": k, "turn_deg": round(turn), "status": r.status,
                   "success": bool(e["position_share"] <= 0.01 and e["angle_deg"] <= 0.2), **e,
                   "grid_px": grid_error(r.camera, truth, dem), "seconds": round(r.elapsed_s, 1)}
        rows.append(row)
        emit({"case": "auto_heading_unknown_scene", **row})
    found = [x["success"] for x in rows]
    wrong_ok = sum(x["status"] == "ok" and not x["success"] for x in rows)
    emit({"case": "auto_heading_unknown", "n": len(rows), "successes": int(sum(found)),
          "share": round(float(np.mean(found)), 3), "ok": sum(x["status"] == "ok" for x in rows),
          "wrong_but_ok": wrong_ok, "statuses": [x["status"] for x in rows],
          "median_s": round(float(np.median([x["seconds"] for x in rows])), 1),
          "target": "every failure not ok", "pass": wrong_ok == 0})


def _share(flags) -> Optional[float]:
    return round(float(np.mean(flags)), 3) if len(flags) else None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(REPO.parent / "shared" / "data" / "aletsch"))
    ap.add_argument("--scenes", type=int, default=50)
    ap.add_argument("--perturbed", type=int, default=20)
    ap.add_argument("--fog", type=int, default=3, help="fogged synthetic scenes")
    ap.add_argument("--no-sky", type=int, default=3, help="scenes whose terrain fills the picture (no skyline)")
    ap.add_argument("--default-scenes", type=int, default=20, help="scenes registered with the default σ")
    ap.add_argument("--heading-scenes", type=int, default=8, help="synthetic scenes with an unknown heading")
    ap.add_argument("--cases", default="aletsch,synthetic,fog,no_sky,default_sigma,heading")
    args = ap.parse_args(argv)
    cases = set(args.cases.split(","))
    t0 = time.perf_counter()
    if "aletsch" in cases:
        case_aletsch(Path(args.data), args.perturbed)
    if "synthetic" in cases:
        case_synthetic(args.scenes)
    if "fog" in cases:
        case_synthetic(min(args.fog, args.scenes), fog=True)
    if "no_sky" in cases:
        case_synthetic(args.no_sky, no_sky=True)
    if "default_sigma" in cases:
        case_synthetic(args.default_scenes, default_sigma=True)
    if "heading" in cases:
        case_heading_unknown(args.heading_scenes, Path(args.data))
    emit({"case": "auto_runtime", "seconds": round(time.perf_counter() - t0, 1)})
    return 0


if __name__ == "__main__":
    sys.exit(main())
