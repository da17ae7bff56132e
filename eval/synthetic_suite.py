"""`make eval`: the camera fit measured on a few hundred generated scenes; one JSON line per stratum, then an overall
line with the targets of issue 11 as pass flags.

Scenes (all deterministic from ``--seed``; terrain from :func:`~monoplot_plugin.core.synthetic.synthetic_terrain`):

- **unpaired** (``--scenes``, default 200): a hidden camera looks over generated terrain. Each scene draws, stratified
  (every bin gets the same number of scenes, in a shuffled order): nominal range 200 m-30 km (4 bins; the DEM spans
  3 x the range, 200-600 cells a side, cells about 1-150 m), horizontal fov 20-90 deg, image width 1000-6000 px
  (3:2, 4:3, 16:9, sometimes portrait), the number of true correspondences 6-500, the share of wrong accepted
  points (0, 10, 20, 30, 45, 60 %), the prior error bound (4 bins up to 300 m / 10 deg), pixel noise 0.05-3 px
  (Gaussian sigma per coordinate) and the DEM resolution: the hidden camera sees a 600-cell "world", the user's
  DEM has every 1st, 2nd or 3rd of its vertices (coarser DEMs miss fine relief). True points are where rays
  through random pixels of the hidden camera first hit the world (visible, in the picture); their photo points are
  the hidden camera's projection plus noise, their DEM points the same x, y at the DEM's height. Wrong points: on
  the photo side either "plausible" (a visible terrain pixel whose DEM point was not accepted) or anywhere in the
  picture; on the DEM side either plausible (visible terrain not accepted in the photo) or terrain hidden behind
  ridges or just outside the picture.
  The photo set and the DEM set have their own wrong shares (mean = the drawn share), hence different sizes; both
  are shuffled and no pairing is given: ``fit_camera(photo_uv, dem_xyz, prior, terrain=dem)`` (the DEM, as the dock
  and Processing give it, for the verdict's near-ground check).
  The prior: x and y each off by up to the bound (uniform; the bound capped at 0.3 x the range: a user knows where
  he stood better than that), z by up to half of it, heading by up to the angle bound, pitch half of it, roll a
  third (<= 2 deg), fov up to 10 % x (angle bound / 10 deg).
- **paired** (``--scenes`` / 10): the same generator, no wrong points, the true pairs given, half with 6-11 points.
- **degenerate** (paired, must be refused): one point duplicated 8-11 times (exact, or with noisy photo copies),
  three points repeated to 9, 8-11 collinear points (a straight 3-D segment between two terrain points).
- **careless** (``--careless N``, default none; tag ``careless``): a careless user's sets, beyond the issue's 60 %:
  6-30 true correspondences, 90 % of the photo points and 75 % of the DEM points wrong (:data:`CARELESS_WRONG`, as
  Aletsch's careless +5 % user), every wrong point on a real feature (visible terrain; on the DEM side also hidden or
  just outside). Own random stream: the other scenes do not change. Own line, not part of the targets.
  For every unpaired or careless miss the record says why (``miss``): "search" when the truth's basin, scored as the
  fit scores its candidates (``core/fit/diagnose.py``), beats the fit's camera, "points" when it does not.

When ``fit_camera`` takes ``position_sigma_m``, ``angle_sigma_deg``, ``fov_sigma_deg`` (the prior's stated
uncertainty; in its signature or as ``FitOptions`` fields), they are set to 1.5 x the scene's drawn error bounds
(floors 1 m, 0.1 deg); the overall line lists them as ``prior_sigmas_passed``.

**Success.** With ``T`` the hidden camera and ``W_i`` the n true world points of the scene (their DEM points are
``W_i`` on the full-resolution DEM, ``W_i`` at the coarser DEM's height otherwise), the error of a camera ``C`` is
``e(C) = sqrt(mean_i |C.project(W_i) - T.project(W_i)|^2)`` in pixels (noiseless truth pixels; infinite when a
point falls behind ``C``): the camera's error where the true correspondences are, not the DEM's own error. The
paired optimum ``e_opt = e(paired fit on the n true (noisy) correspondences, started from T)``. A fit succeeds
when ``e(fit) <= max(2 px, 1.5 e_opt)``; a degenerate set succeeds only when refused.
``grid_err_px`` (in the records, not judged) is ``|C.project(W) - T.project(W)|`` (RMS) over a regular grid of
visible world points (the whole picture, not only where the points are).
**Sigma coverage**: share of successes with sigmas whose true camera lies within 2 sigma of the fitted one for every
parameter with a finite sigma (x, y, z in m; heading (wrapped), pitch, roll, fov in deg); a success without any
sigma counts as not covered.
**Check-point bound**: per scene, 5 of the true points clicked with the scene's noise as check points; what they
vouch for (``core.fit.check_bound_px``, the figure the products are said to be worth with 3 or more check points)
against the camera's error over the grid; ``ok_grid_within_check_bound`` = share of "ok" fits it covers.

Output: one JSON line per stratum (n, success rate, the verdict's confusion matrix status x success/failure,
``ok_precision`` = share of "ok" fits that are successes, sigma coverage, median fit seconds) and an overall line with
the targets. Per-scene records (parameters, status, message, the fit's evidence, success, errors) go to
``test-artifacts/synthetic_suite.jsonl`` (``--records``).

Run: ``.venv/bin/python -m eval.synthetic_suite [--scenes 200] [--seed 0] [--jobs 2] [--only wrong60,range3]
[--scene u17,u42]``. ``--only`` keeps the scenes having all the given tags (``unpaired paired degenerate``, ``range0-3
fov0-2 count0-3 wrong0 wrong10 ... wrong60 prior0-3 noise0-2 cell0-2``); ``--scene`` runs scenes by id (same
``--scenes`` and ``--seed``) and prints their records.
"""

from __future__ import annotations

import argparse
import inspect
import json
import math
import os
import sys
import time
import zlib
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from monoplot_plugin.core.camera import Camera  # noqa: E402
from monoplot_plugin.core.dem import Dem  # noqa: E402
from monoplot_plugin.core.fit import FitOptions, check_bound_px, fit_camera, sigma_pixels  # noqa: E402
from monoplot_plugin.core.fit.diagnose import basin_score  # noqa: E402
from monoplot_plugin.core.synthetic import DEFAULT_ORIGIN, synthetic_terrain  # noqa: E402
from monoplot_plugin.core.xyz import segment_first_hit  # noqa: E402

RANGE_BINS = [(200.0, 1000.0), (1000.0, 4000.0), (4000.0, 12000.0), (12000.0, 30000.0)]
FOV_BINS = [(20.0, 40.0), (40.0, 65.0), (65.0, 90.0)]
COUNT_BINS = [(6, 11), (12, 30), (31, 100), (101, 500)]
WRONG_LEVELS = [0.0, 0.1, 0.2, 0.3, 0.45, 0.6]
#: wrong shares (photo, DEM) of the careless scenes: Aletsch's careless user who also accepts 5 % of the rejected
#: suggestions has 376 wrong of 413 photo points and 88 wrong of 117 DEM points
CARELESS_WRONG = (0.9, 0.75)
PRIOR_BINS = [((0.0, 10.0), (0.0, 1.0)), ((10.0, 50.0), (1.0, 3.0)), ((50.0, 150.0), (3.0, 6.0)),
              ((150.0, 300.0), (6.0, 10.0))]
NOISE_BINS = [(0.05, 0.5), (0.5, 1.5), (1.5, 3.0)]
CELL_STEPS = [1, 2, 3]  # the 600-cell base terrain, every 2nd, every 3rd cell
BASE_CELLS = 600
TERRAIN_SEEDS = 3
DEGENERATE_KINDS = ["duplicate1", "duplicate1_noisy", "three_distinct", "collinear"]
STATUSES = ["ok", "uncertain", "poor", "refused", "canceled", "error"]
SIGMA_KW = ("position_sigma_m", "angle_sigma_deg", "fov_sigma_deg")
FREE = ("x", "y", "z", "heading", "pitch", "roll", "fov")

_TERRAIN: dict = {}


# ----------------------------------------------------------------------------------------------------------------
# Scene specifications (stratified draws)
# ----------------------------------------------------------------------------------------------------------------
def _stratified(rng, n: int, bins: int) -> np.ndarray:
    """(n,) bin indices, each bin used n / bins times (+-1), in a random order."""
    return rng.permutation(np.arange(n) * bins // max(n, 1))


def make_specs(n_unpaired: int, seed: int, n_careless: int = 0) -> list:
    """Scene specifications; the ``n_careless`` careless scenes come from their own random stream, after the
    others, so that asking for them leaves every other scene as it was."""
    rng = np.random.default_rng([seed, 1])
    n_paired = max(8, n_unpaired // 10)
    n_degen = len(DEGENERATE_KINDS) * max(1, n_unpaired // 60)
    specs = []
    for kind, n in (("unpaired", n_unpaired), ("paired", n_paired), ("degenerate", n_degen)):
        draws = {"range": _stratified(rng, n, len(RANGE_BINS)), "fov": _stratified(rng, n, len(FOV_BINS)),
                 "count": _stratified(rng, n, len(COUNT_BINS)), "wrong": _stratified(rng, n, len(WRONG_LEVELS)),
                 "prior": _stratified(rng, n, len(PRIOR_BINS)), "noise": _stratified(rng, n, len(NOISE_BINS)),
                 "cell": _stratified(rng, n, len(CELL_STEPS)),
                 "degenerate": _stratified(rng, n, len(DEGENERATE_KINDS))}
        for i in range(n):
            b = {k: int(v[i]) for k, v in draws.items()}
            if kind != "unpaired":
                b["wrong"] = 0
                b["count"] = 0 if i % 2 == 0 else 1 + b["count"] % 2  # half of them 6-11 points
            spec = {"id": f"{kind[0]}{i}", "kind": kind, "index": len(specs), "seed": seed, "bins": b}
            if kind == "degenerate":
                spec["degenerate"] = DEGENERATE_KINDS[b["degenerate"]]
            spec["tags"] = [kind] + [f"{k}{v}" for k, v in b.items() if k not in ("wrong", "degenerate")] + \
                [f"wrong{round(100 * WRONG_LEVELS[b['wrong']])}"]
            specs.append(spec)
    crng = np.random.default_rng([seed, 3])
    draws = {"range": _stratified(crng, n_careless, len(RANGE_BINS)),
             "fov": _stratified(crng, n_careless, len(FOV_BINS)),
             "count": _stratified(crng, n_careless, 2),  # 6-30 true points, as a hand-curated few
             "prior": _stratified(crng, n_careless, len(PRIOR_BINS)),
             "noise": _stratified(crng, n_careless, len(NOISE_BINS)),
             "cell": _stratified(crng, n_careless, len(CELL_STEPS))}
    for i in range(n_careless):
        b = {k: int(v[i]) for k, v in draws.items()}
        b["wrong"] = 0
        specs.append({"id": f"c{i}", "kind": "careless", "index": len(specs), "seed": seed, "bins": b,
                      "tags": ["careless"] + [f"{k}{v}" for k, v in b.items() if k != "wrong"]})
    return specs


# ----------------------------------------------------------------------------------------------------------------
# Terrain and scene generation
# ----------------------------------------------------------------------------------------------------------------
def _base_key(range_bin: int, terrain_seed: int):
    return range_bin, terrain_seed


def base_terrain(key):
    """Elevation (600 x 600) for a range bin (DEM extent = 3 x the bin's geometric mid range) and its cell size.

    Extents under 12 km are generated at 20 m cells and shrunk in x, y and z alike (a smaller copy of the relief):
    synthetic_terrain sizes its features in metres and is slow on fine grids."""
    if key not in _TERRAIN:
        range_bin, terrain_seed = key
        lo, hi = RANGE_BINS[range_bin]
        cell = 3.0 * math.sqrt(lo * hi) / BASE_CELLS
        gen = max(cell, 20.0)
        dem = synthetic_terrain((BASE_CELLS, BASE_CELLS), cell=gen, seed=1000 * range_bin + terrain_seed)
        _TERRAIN[key] = (dem.elevation * np.float32(cell / gen), cell)
    return _TERRAIN[key]


def scene_dem(spec, rng, nominal_range: float):
    """(world, dem): the 600-cell terrain the hidden camera sees, and the DEM the user has (every 1st, 2nd or 3rd
    vertex of it, same grid alignment): a coarser DEM misses the world's fine relief."""
    b = spec["bins"]
    elevation, cell = base_terrain(_base_key(b["range"], int(rng.integers(TERRAIN_SEEDS))))
    lo, hi = RANGE_BINS[b["range"]]
    f = nominal_range / math.sqrt(lo * hi)
    z = elevation * np.float32(min(f, 3000.0 / max(float(elevation.max()), 1.0)))
    c = cell * f
    x0, y0 = DEFAULT_ORIGIN
    world = Dem.from_array(z, (x0, c, 0.0, y0, 0.0, -c))
    step = CELL_STEPS[b["cell"]]
    if step == 1:
        return world, world
    shift = (step - 1) * c / 2  # coarse vertex j on fine vertex j * step
    return world, Dem.from_array(np.ascontiguousarray(z[::step, ::step]),
                                 (x0 - shift, c * step, 0.0, y0 + shift, 0.0, -c * step))


def on_dem(dem: Dem, xyz: np.ndarray, world: Dem) -> np.ndarray:
    """World points as the user's DEM has them: its height at their x, y (the world's where it has none)."""
    if dem is world or len(xyz) == 0:
        return xyz
    z = np.asarray(dem.sample(xyz[:, 0], xyz[:, 1]), dtype=np.float64)
    return np.column_stack([xyz[:, :2], np.where(np.isfinite(z), z, xyz[:, 2])])


def cast(dem: Dem, cam: Camera, uv: np.ndarray, far: float):
    """World points where rays through ``uv`` first hit the terrain; NaN rows for sky."""
    origin, dirs = cam.pixel_to_world_ray(uv)
    starts = np.broadcast_to(origin, dirs.shape)
    s = segment_first_hit(dem, starts, starts + dirs * far)
    return starts + s[:, None] * dirs * far


def place_camera(spec, rng, dem: Dem, nominal_range: float):
    """The hidden camera near the DEM's south edge looking north-ish at terrain about ``nominal_range`` away;
    redrawn until at least 30 % of the picture is terrain with a median distance within 1/3-3 x the range."""
    b = spec["bins"]
    x0, y0, x1, y1 = dem.bounds()
    ext = x1 - x0
    width = int(round(math.exp(rng.uniform(math.log(1000), math.log(6000)))))
    aspect = [1.5, 4 / 3, 16 / 9][int(rng.integers(3))]
    height = int(round(width / aspect))
    if rng.random() < 0.15:
        width, height = height, width
    fov = rng.uniform(*FOV_BINS[b["fov"]])
    gu, gv = np.meshgrid(np.linspace(0.5, width - 0.5, 16), np.linspace(0.5, height - 0.5, 12))
    grid = np.stack([gu.ravel(), gv.ravel()], axis=1)
    for attempt in range(40):
        x = x0 + ext * rng.uniform(0.3, 0.7)
        y = y0 + ext * rng.uniform(0.05, 0.15)
        heading = rng.uniform(-25, 25)
        tx = x + nominal_range * math.sin(math.radians(heading))
        ty = y + nominal_range * math.cos(math.radians(heading))
        target = np.array([tx, ty, float(dem.sample(tx, ty))])
        ground = float(dem.sample(x, y))
        # Raised until the target is in sight (a viewpoint), at most 30 % of the range above the ground.
        for h in 1.7 + nominal_range * np.array([0.0, 0.005, 0.01, 0.02, 0.04, 0.08, 0.15, 0.3]):
            pos = np.array([x, y, ground + h])
            s = segment_first_hit(dem, pos[None], target[None])[0]
            if not np.isfinite(s) or (1 - s) * nominal_range < 3 * dem.cell_size:
                break
        pitch = math.degrees(math.atan2(target[2] - pos[2], nominal_range))
        cam = Camera(pos, heading, pitch, rng.uniform(-3, 3), fov, (width, height), crs_wkt=dem.crs_wkt)
        cam = cam.with_parameters(pitch=pitch + rng.uniform(-0.2, 0.2) * cam.vertical_fov)
        hits = cast(dem, cam, grid, 3 * ext)
        ok = np.isfinite(hits).all(axis=1)
        if ok.mean() >= 0.3:
            dist = np.median(np.linalg.norm(hits[ok] - np.asarray(cam.position), axis=1))
            if nominal_range / 3 <= dist <= 3 * nominal_range:
                return cam, hits[ok], attempt
    return cam, hits[ok], attempt


def visible_points(dem, cam, rng, n, far):
    """(n, 3) terrain points seen by ``cam`` through random pixels (fewer if the picture is mostly sky)."""
    out = []
    for _ in range(20):
        uv = rng.uniform([0, 0], cam.image_size, (2 * n + 32, 2))
        hits = cast(dem, cam, uv, far)
        out.append(hits[np.isfinite(hits).all(axis=1)])
        if sum(len(o) for o in out) >= n:
            break
    return np.vstack(out)[:n]


def hidden_or_outside(dem, cam, rng, n, nominal_range):
    """Terrain points in front of ``cam`` that it cannot see: behind terrain in the picture or just outside it."""
    out = [np.zeros((0, 3))]
    if n <= 0:
        return out[0]
    pos = np.asarray(cam.position)
    cell = dem.cell_size
    for _ in range(20):
        ang = math.radians(cam.heading) + rng.uniform(-1.2, 1.2, 4 * n + 32)
        dist = nominal_range * np.exp(rng.uniform(math.log(0.2), math.log(2.5), len(ang)))
        x, y = pos[0] + dist * np.sin(ang), pos[1] + dist * np.cos(ang)
        z = dem.sample(x, y)
        P = np.stack([x, y, z], axis=1)
        P = P[np.isfinite(P).all(axis=1)]
        uv, depth = cam.project_with_depth(P)
        inside = cam.in_image(uv)
        near = cam.in_image(uv, margin=0.5 * cam.width) & ~inside & (depth > 0)
        s = segment_first_hit(dem, np.broadcast_to(pos, P.shape), P)
        hidden = inside & np.isfinite(s) & ((1 - s) * np.linalg.norm(P - pos, axis=1) > 3 * cell)
        out.append(P[hidden | near])
        if sum(len(o) for o in out) >= n:
            break
    return np.vstack(out)[:n]


def perturb_prior(truth: Camera, rng, bins, nominal_range):
    (plo, phi), (alo, ahi) = PRIOR_BINS[bins["prior"]]
    pos_bound = min(rng.uniform(plo, phi), 0.3 * nominal_range)
    ang_bound = rng.uniform(alo, ahi)
    fov_frac = 0.1 * ang_bound / 10.0
    x, y, z = truth.position
    prior = truth.with_parameters(
        x=x + rng.uniform(-1, 1) * pos_bound, y=y + rng.uniform(-1, 1) * pos_bound,
        z=z + rng.uniform(-0.5, 0.5) * pos_bound, heading=truth.heading + rng.uniform(-1, 1) * ang_bound,
        pitch=truth.pitch + rng.uniform(-0.5, 0.5) * ang_bound,
        roll=truth.roll + rng.uniform(-1, 1) * min(ang_bound / 3, 2.0),
        fov=truth.fov * (1 + rng.uniform(-1, 1) * fov_frac))
    sigmas = {"position_sigma_m": max(1.0, 1.5 * pos_bound), "angle_sigma_deg": max(0.1, 1.5 * ang_bound),
              "fov_sigma_deg": max(0.1, 1.5 * fov_frac * truth.fov)}
    return prior, {"position_bound_m": pos_bound, "angle_bound_deg": ang_bound, "fov_bound_frac": fov_frac}, sigmas


def build_scene(spec):
    """Everything a fit needs, plus the truth: a dict (see :func:`run_scene`)."""
    rng = np.random.default_rng([spec["seed"], 2, spec["index"]])
    b = spec["bins"]
    lo, hi = RANGE_BINS[b["range"]]
    nominal_range = math.exp(rng.uniform(math.log(lo), math.log(hi)))
    world, dem = scene_dem(spec, rng, nominal_range)
    far = 3 * (world.bounds()[2] - world.bounds()[0])
    truth, grid_points, attempts = place_camera(spec, rng, world, nominal_range)
    clo, chi = COUNT_BINS[b["count"]]
    n_true = int(round(math.exp(rng.uniform(math.log(clo), math.log(chi + 0.999)) - 1e-9)))
    n_true = int(min(max(n_true, clo), chi))
    w = WRONG_LEVELS[b["wrong"]]
    d = rng.uniform(-1, 1) * min(0.1, w)
    w_photo, w_dem = w + d, w - d
    if spec["kind"] == "careless":
        w_photo, w_dem = CARELESS_WRONG
        w = 0.5 * (w_photo + w_dem)
    n_wp = int(round(n_true * w_photo / (1 - w_photo)))
    n_wd = int(round(n_true * w_dem / (1 - w_dem)))
    plausible = rng.uniform(0.3, 1.0) if w > 0 else 0.0
    if spec["kind"] == "careless":
        plausible = 1.0  # rejected suggestions: real features of the picture and of the terrain, not noise
    n_pp, n_pd = int(round(plausible * n_wp)), int(round(plausible * n_wd))
    pts = visible_points(world, truth, rng, n_true + n_pp + n_pd, far)
    true_xyz, pp_xyz, pd_xyz = pts[:n_true], pts[n_true:n_true + n_pp], pts[n_true + n_pp:]
    noise = rng.uniform(*NOISE_BINS[b["noise"]])
    uv_truth = truth.project(true_xyz)
    photo_true = uv_truth + rng.normal(0, noise, uv_truth.shape)
    real_xyz, true_xyz = true_xyz, on_dem(dem, true_xyz, world)  # truth and the DEM's version of it
    dem_z_error = float(np.median(np.abs(real_xyz[:, 2] - true_xyz[:, 2]))) if len(real_xyz) else 0.0
    photo_wrong = np.vstack([truth.project(pp_xyz) + rng.normal(0, noise, (len(pp_xyz), 2)),
                             rng.uniform([0, 0], truth.image_size, (n_wp - n_pp, 2))])
    dem_wrong = on_dem(dem, np.vstack([pd_xyz, hidden_or_outside(world, truth, rng, n_wd - n_pd, nominal_range)]),
                       world)
    prior, prior_err, sigmas = perturb_prior(truth, rng, b, nominal_range)
    pairs = None
    kind = spec.get("degenerate")
    if kind in ("duplicate1", "duplicate1_noisy", "three_distinct"):
        k = int(rng.integers(8, 12)) if kind != "three_distinct" else 9
        idx = np.zeros(k, dtype=int) if kind != "three_distinct" else np.arange(k) % 3
        true_xyz = true_xyz[idx]
        uv_truth = uv_truth[idx]
        photo_true = photo_true[idx] if kind != "duplicate1_noisy" else \
            uv_truth + rng.normal(0, max(noise, 0.5), uv_truth.shape)
    elif kind == "collinear":
        k = int(rng.integers(8, 12))
        t = np.linspace(0, 1, k)[:, None]
        true_xyz = true_xyz[0] + t * (true_xyz[1] - true_xyz[0])
        uv_truth = truth.project(true_xyz)
        photo_true = uv_truth + rng.normal(0, noise, uv_truth.shape)
    n = len(true_xyz)
    photo = np.vstack([photo_true, photo_wrong])
    dem_set = np.vstack([true_xyz, dem_wrong])
    perm_p, perm_d = rng.permutation(len(photo)), rng.permutation(len(dem_set))
    inv_p, inv_d = np.argsort(perm_p), np.argsort(perm_d)
    truth_pairs = np.stack([inv_p[:n], inv_d[:n]], axis=1)
    if spec["kind"] not in ("unpaired", "careless"):
        pairs = truth_pairs
    dist = np.linalg.norm(true_xyz - np.asarray(truth.position), axis=1)
    params = {"nominal_range_m": nominal_range, "median_range_m": float(np.median(dist)), "cell_m": dem.cell_size,
              "dem_shape": list(dem.shape), "fov": truth.fov, "image_size": list(truth.image_size),
              "n_true": n, "n_photo": len(photo), "n_dem": len(dem_set), "wrong_share": w,
              "wrong_photo": (len(photo) - n) / len(photo), "wrong_dem": (len(dem_set) - n) / len(dem_set),
              "dem_z_error_m": dem_z_error,
              "plausible_share": plausible, "noise_px": noise, **prior_err, "camera_attempts": attempts,
              "truth": truth.parameters(), "prior": prior.parameters()}
    return {"photo": photo[perm_p], "world": dem_set[perm_d], "prior": prior, "truth": truth, "pairs": pairs,
            "truth_pairs": truth_pairs, "world_xyz": real_xyz, "uv_truth": uv_truth, "sigmas": sigmas,
            "grid_xyz": grid_points, "params": params, "dem": dem}


# ----------------------------------------------------------------------------------------------------------------
# Running and judging
# ----------------------------------------------------------------------------------------------------------------
def reprojection_error(cam: Camera, xyz: np.ndarray, uv_truth: np.ndarray) -> float:
    uv = cam.project(xyz)
    if not np.isfinite(uv).all():
        return float("inf")
    return float(np.sqrt(np.mean(np.sum((uv - uv_truth) ** 2, axis=1))))


def accepted_options() -> set:
    """Keyword names ``fit_camera`` takes: its signature's, plus the fields of ``FitOptions`` when it has one
    (the rewritten fit takes them through ``**option_values``)."""
    names = set(inspect.signature(fit_camera).parameters)
    try:
        from monoplot_plugin.core.fit import FitOptions

        names |= set(FitOptions.names())
    except ImportError:
        pass
    return names


def _sigma_kwargs(sigmas):
    names = accepted_options()
    return {k: v for k, v in sigmas.items() if k in names}


def parameter_errors(cam: Camera, truth: Camera) -> dict:
    c, t = cam.parameters(), truth.parameters()
    err = {k: c[k] - t[k] for k in FREE}
    err["heading"] = (err["heading"] + 180.0) % 360.0 - 180.0
    return err


def run_scene(spec) -> dict:
    t0 = time.perf_counter()
    s = build_scene(spec)
    gen_s = time.perf_counter() - t0
    kw = _sigma_kwargs(s["sigmas"])
    try:
        if s["pairs"] is None:
            r = fit_camera(s["photo"], s["world"], s["prior"], terrain=s["dem"], **kw)
        else:
            r = fit_camera(s["photo"], s["world"], s["prior"], pairs=s["pairs"], terrain=s["dem"], **kw)
        status, message, cam, std, fit_s = r.status, r.message, r.camera, dict(r.std), r.elapsed_s
        rmse_px = float(r.rmse_px)
        radius = (r.evidence or {}).get("radius_px") if s["pairs"] is None else None
        evidence = {k: v if isinstance(v, (str, bool)) else _round(float(v), 4)
                    for k, v in (r.evidence or {}).items() if k != "note" and isinstance(v, (int, float, str))}
    except Exception as exc:  # a crash is a failure of the fit, recorded, not the end of the suite
        status, message, cam, std, fit_s, rmse_px = "error", f"{type(exc).__name__}: {exc}", s["prior"], {}, 0.0, \
            float("nan")
        radius, evidence = None, {}
    rec = {"id": spec["id"], "kind": spec["kind"], "tags": spec["tags"], "degenerate": spec.get("degenerate"),
           "params": s["params"], "status": status, "message": message, "fit_s": round(fit_s, 3),
           "fit_rmse_px": None if not np.isfinite(rmse_px) else round(rmse_px, 3), "sigma_kwargs": sorted(kw),
           "evidence": evidence}
    if spec["kind"] == "degenerate":
        rec.update(success=status == "refused", err_px=None, threshold_px=None, opt_px=None)
    else:
        opt = fit_camera(s["photo"], s["world"], s["truth"], pairs=s["truth_pairs"])
        e_opt = reprojection_error(opt.camera, s["world_xyz"], s["uv_truth"])
        e = reprojection_error(cam, s["world_xyz"], s["uv_truth"])
        threshold = max(2.0, 1.5 * e_opt)
        rec.update(success=bool(status not in ("refused", "canceled", "error") and e <= threshold),
                   err_px=round(e, 3) if np.isfinite(e) else None, threshold_px=round(threshold, 3),
                   opt_px=round(e_opt, 3), prior_err_px=_round(reprojection_error(s["prior"], s["world_xyz"],
                                                                                  s["uv_truth"])),
                   grid_err_px=_round(reprojection_error(cam, s["grid_xyz"], s["truth"].project(s["grid_xyz"]))))
        if radius and not rec["success"]:
            # Why it missed: the truth's basin scored as the fit scores its candidates (core/fit/diagnose.py).
            opts = FitOptions(**kw)
            fit = basin_score(s["photo"], s["world"], s["prior"], cam, radius, options=opts)
            basin = basin_score(s["photo"], s["world"], s["prior"], s["truth"], radius, options=opts, optimise=True)
            e_basin = reprojection_error(basin["camera"], s["world_xyz"], s["uv_truth"])
            rec.update(miss="search" if basin["net"] > fit["net"] else "points", fit_net=round(fit["net"], 2),
                       truth_basin_net=round(basin["net"], 2), truth_basin_err_px=_round(e_basin),
                       truth_basin_success=bool(e_basin <= threshold))
    err = parameter_errors(cam, s["truth"])
    sig = {k: float(v) for k, v in std.items() if k in FREE and v is not None and np.isfinite(v)}
    rec["errors"] = {k: round(v, 4) for k, v in err.items()}
    rec["position_error_m"] = round(float(math.sqrt(err["x"] ** 2 + err["y"] ** 2 + err["z"] ** 2)), 3)
    rec["std"] = {k: round(v, 5) for k, v in sig.items()}
    rec["covered_2sigma"] = bool(sig) and all(abs(err[k]) <= 2 * v for k, v in sig.items())
    # the σ as a pixel error (what an unpaired fit's products are said to be worth): does it cover the camera's
    # real error on the terrain, err_px?
    sp = sigma_pixels(cam, sig, s["world_xyz"]) if sig else float("nan")
    rec["sigma_px"] = _round(sp)
    rec["err_within_sigma_px"] = bool(np.isfinite(sp) and rec.get("err_px") is not None and rec["err_px"] <= sp)
    rec["err_within_2sigma_px"] = bool(np.isfinite(sp) and rec.get("err_px") is not None and rec["err_px"] <= 2 * sp)
    # what CHECK_POINTS check points (true points clicked with the scene's noise) vouch for, as the products say
    # it (workflow.features.pixel_error): does it cover the camera's real error on the terrain, grid_err_px?
    if rec.get("grid_err_px") is not None and len(s["world_xyz"]) >= CHECK_POINTS:
        rng = np.random.default_rng(zlib.crc32(str(spec["id"]).encode()))
        pick = rng.choice(len(s["world_xyz"]), CHECK_POINTS, replace=False)
        clicked = s["uv_truth"][pick] + rng.normal(0.0, s["params"]["noise_px"], (CHECK_POINTS, 2))
        bound = check_bound_px(reprojection_error(cam, s["world_xyz"][pick], clicked), CHECK_POINTS)
        rec["check_bound_px"] = _round(bound)
        rec["grid_within_check_bound"] = bool(np.isfinite(bound) and rec["grid_err_px"] <= bound)
    rec["gen_s"] = round(gen_s, 3)
    for key in ("params",):
        rec[key] = {k: (round(v, 4) if isinstance(v, float) else v) for k, v in rec[key].items()}
    return rec


#: Check points drawn per scene for the calibration of what they vouch for (core.fit.check_bound_px).
CHECK_POINTS = 5


def _round(x, n=3):
    return round(x, n) if x is not None and np.isfinite(x) else None


# ----------------------------------------------------------------------------------------------------------------
# Summaries
# ----------------------------------------------------------------------------------------------------------------
def _sigma_px_coverage(oks) -> dict:
    if not oks:
        return {}
    checked = [r for r in oks if "grid_within_check_bound" in r]
    bound = {"ok_grid_within_check_bound": round(sum(r["grid_within_check_bound"] for r in checked) / len(checked),
                                                 3)} if checked else {}
    ratio = [r["err_px"] / r["sigma_px"] for r in oks if r.get("err_px") is not None]
    return {"ok_err_within_sigma_px": round(sum(r["err_within_sigma_px"] for r in oks) / len(oks), 3),
            "ok_err_within_2sigma_px": round(sum(r["err_within_2sigma_px"] for r in oks) / len(oks), 3),
            "ok_err_over_sigma_px_median": round(float(np.median(ratio)), 3) if ratio else None, **bound}


def summarise(records, stratum: str, label: str) -> dict:
    n = len(records)
    conf = {st: {"success": 0, "failure": 0} for st in STATUSES}
    for r in records:
        conf.setdefault(r["status"], {"success": 0, "failure": 0})
        conf[r["status"]]["success" if r["success"] else "failure"] += 1
    conf = {k: v for k, v in conf.items() if k in STATUSES[:4] or v["success"] + v["failure"]}
    ok_n = conf["ok"]["success"] + conf["ok"]["failure"]
    succ = [r for r in records if r["success"] and r["kind"] != "degenerate"]
    with_sigma = [r for r in succ if r["std"]]
    times = [r["fit_s"] for r in records]
    return {"suite": "synthetic", "stratum": stratum, "bin": label, "n": n,
            "success_rate": round(sum(r["success"] for r in records) / n, 3) if n else None,
            "confusion": conf, "ok_precision": round(conf["ok"]["success"] / ok_n, 3) if ok_n else None,
            "sigma_coverage": round(sum(r["covered_2sigma"] for r in succ) / len(succ), 3) if succ else None,
            "successes_with_sigma": len(with_sigma), "successes": len(succ),
            # over the "ok" fits: their camera's error on the terrain within its σ as a pixel error (1 and 2 times)
            **_sigma_px_coverage([r for r in records if r["status"] == "ok" and r.get("sigma_px")]),
            "median_fit_s": round(float(np.median(times)), 3) if times else None}


def strata(records):
    un = [r for r in records if r["kind"] == "unpaired"]
    groups = []
    labels = {"range": [f"{lo / 1000:g}-{hi / 1000:g}km" for lo, hi in RANGE_BINS],
              "fov": [f"{lo:g}-{hi:g}deg" for lo, hi in FOV_BINS],
              "count": [f"{lo}-{hi}" for lo, hi in COUNT_BINS],
              "wrong": [f"{round(100 * w)}%" for w in WRONG_LEVELS],
              "prior": [f"<={p[1]:g}m/{a[1]:g}deg" for p, a in PRIOR_BINS],
              "noise": [f"{lo:g}-{hi:g}px" for lo, hi in NOISE_BINS],
              "cell": [f"{BASE_CELLS // s} cells" for s in CELL_STEPS]}
    for dim, names in labels.items():
        for i, name in enumerate(names):
            tag = f"wrong{round(100 * WRONG_LEVELS[i])}" if dim == "wrong" else f"{dim}{i}"
            sel = [r for r in un if tag in r["tags"]]
            if sel:
                groups.append((dim, name, sel))
    for kind in ("unpaired", "paired", "degenerate", "careless"):
        sel = [r for r in records if r["kind"] == kind]
        if sel:
            groups.append(("kind", kind, sel))
    for kind in DEGENERATE_KINDS:
        sel = [r for r in records if r["degenerate"] == kind]
        if sel:
            groups.append(("degenerate", kind, sel))
    for name, sel in target_groups(records).items():
        if sel:
            groups.append(("target", name, sel))
    return groups


def target_groups(records):
    un = [r for r in records if r["kind"] == "unpaired"]
    return {"wrong<=30% & prior<=300m/10deg": [r for r in un if r["params"]["wrong_share"] <= 0.3
                                               and r["params"]["position_bound_m"] <= 300
                                               and r["params"]["angle_bound_deg"] <= 10],
            "wrong=60%": [r for r in un if r["params"]["wrong_share"] >= 0.6]}


def overall(records, runtime_s) -> dict:
    # The careless scenes (beyond the 60 %) have their own line, not a share of the targets.
    records = [r for r in records if r["kind"] != "careless"]
    line = summarise(records, "overall", "all")
    tg = target_groups(records)
    deg = [r for r in records if r["kind"] == "degenerate"]

    def rate(sel):
        return round(sum(r["success"] for r in sel) / len(sel), 3) if sel else None

    def target(value, goal):
        return {"value": value, "target": goal, "pass": None if value is None else bool(value >= goal)}

    line["targets"] = {
        "success_wrong_le_30pct": target(rate(tg["wrong<=30% & prior<=300m/10deg"]), 0.95),
        "success_wrong_60pct": target(rate(tg["wrong=60%"]), 0.80),
        "ok_precision": target(line["ok_precision"], 0.99),
        "sigma_coverage_2sigma": target(line["sigma_coverage"], 0.90),
        "degenerate_refused": target(rate(deg), 1.0)}
    line["all_pass"] = all(t["pass"] for t in line["targets"].values() if t["pass"] is not None)
    line["runtime_s"] = round(runtime_s, 1)
    line["prior_sigmas_passed"] = [k for k in SIGMA_KW if k in accepted_options()]
    return line


# ----------------------------------------------------------------------------------------------------------------
def _init_worker():
    try:
        import torch

        torch.set_num_threads(1)
    except ImportError:
        pass


def _progress(results, n, t0) -> list:
    """The records, with a progress line on stderr every 10 %."""
    out = []
    for r in results:
        out.append(r)
        if len(out) % max(1, n // 10) == 0 or len(out) == n:
            print(f"synthetic_suite: {len(out)}/{n} scenes, {time.perf_counter() - t0:.0f} s", file=sys.stderr,
                  flush=True)
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=200, help="unpaired scenes (paired: /10, degenerate: /15)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--careless", type=int, default=0, help="also this many careless scenes (90 %% wrong "
                        "photo points, 75 %% wrong DEM points, all on real features; tag careless)")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--only", default="", help="comma-separated tags, all required (e.g. wrong60,range3)")
    parser.add_argument("--scene", default="", help="scene ids, comma-separated (e.g. u17,p3,d2): print their "
                        "records")
    parser.add_argument("--records", default=str(REPO / "test-artifacts" / "synthetic_suite.jsonl"))
    args = parser.parse_args(argv)
    _init_worker()
    specs = make_specs(args.scenes, args.seed, args.careless)
    if args.scene:
        wanted = set(args.scene.split(","))
        specs = [s for s in specs if s["id"] in wanted]
    only = set(filter(None, args.only.split(",")))
    specs = [s for s in specs if only <= set(s["tags"])]
    if not specs:
        print(json.dumps({"suite": "synthetic", "error": "no scene matches --scene/--only"}))
        return 1
    t0 = time.perf_counter()
    if args.jobs > 1 and len(specs) > 1:
        import multiprocessing as mp

        ctx = mp.get_context("fork")
        keys = sorted({_base_key(r, t) for r in {s["bins"]["range"] for s in specs} for t in range(TERRAIN_SEEDS)})
        with ctx.Pool(args.jobs, initializer=_init_worker) as pool:
            _TERRAIN.update(zip(keys, pool.map(base_terrain, keys)))
        with ctx.Pool(args.jobs, initializer=_init_worker) as pool:
            # Slow scenes (many points) first so that the two workers finish together.
            order = sorted(specs, key=lambda s: -s["bins"]["count"])
            records = _progress(pool.imap_unordered(run_scene, order), len(order), t0)
    else:
        records = _progress(map(run_scene, specs), len(specs), t0)
    records.sort(key=lambda r: [s["id"] for s in specs].index(r["id"]))
    runtime = time.perf_counter() - t0
    if args.scene:
        for r in records:
            print(json.dumps(r))
        return 0
    path = Path(args.records)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w") as fh:
        for r in records:
            fh.write(json.dumps(r) + "\n")
    for dim, name, sel in strata(records):
        print(json.dumps(summarise(sel, dim, name)), flush=True)
    line = overall(records, runtime)
    line["records"] = os.path.relpath(path, REPO) if path.is_relative_to(REPO) else str(path)
    print(json.dumps(line), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
