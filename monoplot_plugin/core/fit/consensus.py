"""Consensus registration of unpaired points: camera hypotheses from minimal two-point solves, verified by the
number of photo points they explain, then locally optimised.

Why: the paper's nearest-point loss is an average, so wrongly accepted points pull it, and with many of them a
wrong camera reaches a lower loss than the right one. A *count* of photo points that have a projected DEM point
within a small radius is not pulled by points that fit nothing; the right camera makes many such coincidences,
a wrong one only a few by chance (measured by :func:`chance_inliers`).

Hypotheses (:func:`hypotheses`) keep the camera at the prior position and draw candidate correspondences from the
prior's uncertainty: a DEM point is a candidate for a photo point when the prior projects it within the gate that
the stated position / angle / field-of-view σ allow. Two correspondences fix the rotation and, when the field of
view is free, the focal length too (the angle between two rays must be the angle between their world directions,
:func:`focal_from_ray_angle`). Parallax from the position error is left to the local optimisation
(:func:`local_optimise`), which frees every parameter on the hypothesis's mutual-nearest pairs with a shrinking
gate.

Conventions: pixels, camera frame x right / y down / z forward, see :mod:`~monoplot_plugin.core.camera`.
"""

from __future__ import annotations

import math
from typing import List, Optional, Tuple

import numpy as np

from ..camera import angles_from_rotation, focal_from_fov, fov_from_focal
from .losses import mutual_nearest_pairs
from .minimal import camera_rays, focal_from_ray_angle, rotation_between, rotation_from_two_rays
from .lsq import least_squares
from .params import ParameterSpace

__all__ = ["consensus_score", "hypotheses", "local_optimise",
           "chance_inliers", "inlier_radius", "shift_hypotheses", "kernel_align", "prior_penalty"]


def inlier_radius(diag: float, image_area: float = 0.0, n_photo: int = 0, n_dem: int = 0) -> float:
    """Radius (pixels) within which a projected DEM point explains a photo point.

    1 % of the image diagonal (a clicked or detected point is about that accurate), but smaller for dense point
    sets: where ``n_photo`` photo points and ``n_dem`` DEM points in view fill ``image_area`` px^2 so densely
    that a camera placed anywhere would pair about one of them by chance at that radius, the radius shrinks to
    keep the expected coincidences near one (down to 0.3 % of the diagonal, at least 2 px).

    >>> inlier_radius(1000.0), inlier_radius(100.0)
    (10.0, 3.0)
    >>> round(inlier_radius(2000.0, 600 * 800, 400, 100), 2)   # 400 x 100 points fill 600 x 800 px densely
    6.0
    >>> round(inlier_radius(2000.0, 1600 * 1200, 40, 10), 2)   # sparse: 1 % of the diagonal
    20.0
    """
    radius = max(3.0, 0.01 * float(diag))
    if image_area > 0 and n_photo > 0 and n_dem > 0:
        one_coincidence = math.sqrt(image_area / (math.pi * n_photo * n_dem))
        radius = min(radius, max(one_coincidence, 0.003 * float(diag), 2.0))
    return radius


def consensus_score(q: np.ndarray, uv: np.ndarray, usable: np.ndarray, radius: float) -> Tuple[float, np.ndarray]:
    """Soft count of the photo points explained by a camera: mutual-nearest pairs within ``radius`` pixels, each
    weighted ``1 - (d / radius)^2`` (an MSAC score: more inliers win, then tighter ones).

    Returns:
        (score, pairs): the score and the (K, 2) int (photo index, DEM index) inlier pairs.

    >>> q = np.array([[0.0, 0], [100, 0], [200, 0]])
    >>> s, pairs = consensus_score(q, np.array([[1.0, 0], [100, 0], [900, 0]]), np.ones(3, bool), 5.0)
    >>> round(s, 2), pairs.tolist()
    (1.96, [[0, 0], [1, 1]])
    """
    pairs = mutual_nearest_pairs(q, uv, usable, radius)
    if len(pairs) == 0:
        return 0.0, pairs
    d = np.linalg.norm(uv[pairs[:, 1]] - q[pairs[:, 0]], axis=1)
    return float(np.sum(1.0 - (d / radius) ** 2)), pairs


def chance_inliers(ctx, space: ParameterSpace, u, radius: float, trials: int = 24) -> np.ndarray:
    """(trials,) consensus scores of cameras turned away from ``space.camera(u)`` by 4 radii to 15 % of the image
    diagonal (random directions, a little roll and zoom): what the same points give a wrongly placed camera, so a
    fit can say whether its inliers are more than coincidences among dense point sets."""
    cam = space.camera(u)
    rng = np.random.default_rng(12345)
    f = cam.focal_px
    scores = np.zeros(trials)
    for k in range(trials):
        shift = rng.uniform(4.0 * radius, max(5.0 * radius, 0.15 * ctx.diag))
        theta = rng.uniform(0, 2 * math.pi)
        d_heading = math.degrees(math.atan2(shift * math.cos(theta), f))
        d_pitch = math.degrees(math.atan2(shift * math.sin(theta), f))
        other = cam.with_parameters(heading=cam.heading + d_heading, pitch=cam.pitch + d_pitch,
                                    roll=cam.roll + rng.uniform(-2, 2), fov=cam.fov * rng.uniform(0.95, 1.05))
        uv, depth = other.project_with_depth(ctx.world)
        usable = ctx.usable(np.nan_to_num(uv, nan=-1e9), depth, ctx.view_margin)
        scores[k] = consensus_score(ctx.q, np.nan_to_num(uv, nan=-1e9), usable, radius)[0]
    return scores


#: Which of the prior's σ (:meth:`~.options.FitOptions.prior_sigmas`) each camera parameter is measured in.
PRIOR_SIGMA_OF = {"x": "position_m", "y": "position_m", "z": "position_m", "heading": "angle_deg",
                  "pitch": "angle_deg", "roll": "angle_deg", "fov": "fov_deg"}


def prior_penalty(ctx, camera, sigmas: dict) -> float:
    """Half the squared Mahalanobis distance of ``camera`` from the initial camera under the prior's σ (position,
    heading, pitch, roll, field of view; fixed parameters do not count): the log-prior that a camera explaining
    the same number of points must pay for being farther from what the user stated."""
    cam0 = ctx.initial
    m2 = 0.0
    if {"x", "y", "z"} & set(ctx.free):
        d = np.subtract(camera.position, cam0.position)
        m2 += float(d @ d) / sigmas["position_m"] ** 2
    for name in ("heading", "pitch", "roll", "fov"):
        if name in ctx.free:
            delta = getattr(camera, name) - getattr(cam0, name)
            if name == "heading":
                delta = (delta + 180.0) % 360.0 - 180.0
            m2 += (delta / sigmas[PRIOR_SIGMA_OF[name]]) ** 2
    return 0.5 * m2


def candidate_count(n_photo: int, n_dem: int, at_least: int, budget: int = 2_000_000) -> int:
    """Candidate DEM points per photo point: every DEM point in the gate when ``n_photo x n_dem`` fits the budget.

    A fixed few nearest would silently shrink the gate: the true partner of a photo point lies a whole rotation
    error away from where the prior projects it, behind dozens of nearer DEM points when the sets are dense.

    >>> candidate_count(149, 300, 60), candidate_count(20_000, 5_000, 60), candidate_count(10, 3, 60)
    (300, 100, 3)
    """
    return int(min(n_dem, max(at_least, budget // max(1, n_photo))))


def _gates(ctx, sigmas: dict) -> Tuple[float, float]:
    """(candidate gate, hypothesis inlier radius) in pixels from the prior's σ."""
    cam = ctx.initial
    f = cam.focal_px
    deg = math.pi / 180.0
    parallax = f * math.atan2(sigmas["position_m"], ctx.typical_range)
    angle = f * sigmas["angle_deg"] * deg
    zoom = 0.5 * ctx.diag * abs(1.0 - focal_from_fov(cam.fov + sigmas["fov_deg"], cam.width) / f)
    gate = float(np.clip(2.5 * math.sqrt(angle ** 2 + parallax ** 2 + zoom ** 2), 0.03 * ctx.diag,
                         0.6 * ctx.diag))
    radius = float(np.clip(inlier_radius(ctx.diag) + 0.3 * parallax, inlier_radius(ctx.diag), 0.04 * ctx.diag))
    return gate, radius


def hypotheses(ctx, sigmas: dict, n_max: int, camera=None) -> List[dict]:
    """Camera hypotheses at the prior position from pairs of candidate correspondences, best first.

    ``camera``: draw around this camera instead of the prior (its position, rotation and field of view; the gate
    still follows ``sigmas``).

    Returns:
        list of dicts ``{"heading", "pitch", "roll", "fov", "score"}`` (distinct rotations only).
    """
    from scipy.spatial import cKDTree

    cam = ctx.initial if camera is None else camera
    q = ctx.q
    P = ctx.P if camera is None else ctx.world - np.asarray(cam.position, dtype=np.float64)
    if len(q) < 2 or len(P) < 2:
        return []
    gate, radius = _gates(ctx, sigmas)
    uv0, depth0 = cam.project_with_depth(ctx.world)
    front = np.isfinite(uv0).all(axis=1) & (depth0 > 1e-3 * ctx.typical_range)
    in_reach = front & cam.in_image(np.nan_to_num(uv0, nan=-1e9), margin=gate)
    dem_idx = np.flatnonzero(in_reach)
    if len(dem_idx) < 2:
        return []
    rng = np.random.default_rng(ctx.options.seed + 7)
    # Candidate correspondences: each photo point with the DEM points the prior puts within the gate.
    tree = cKDTree(uv0[dem_idx])
    k = candidate_count(len(q), len(dem_idx), 40)
    dist, nn = tree.query(q, k=k, distance_upper_bound=gate)
    dist, nn = np.atleast_2d(dist), np.atleast_2d(nn)
    ok = np.isfinite(dist)
    cand_i = np.repeat(np.arange(len(q)), k).reshape(len(q), k)[ok]
    cand_j = dem_idx[nn[ok]]
    spread = gate / 2.5
    weight = np.exp(-0.5 * (dist[ok] / spread) ** 2) + 1e-3
    if len(cand_i) < 2:
        return []
    # Cost of one hypothesis is one projection of the scored DEM points: keep hypotheses x points bounded.
    score_idx = dem_idx if len(dem_idx) <= 600 else np.sort(rng.choice(dem_idx, 600, replace=False))
    n_hyp = int(min(n_max, max(200, 600_000 // max(1, len(score_idx)))))
    draws = 4 * n_hyp
    p = weight / weight.sum()
    a = rng.choice(len(cand_i), draws, p=p)
    b = rng.choice(len(cand_i), draws, p=p)
    i1, i2, j1, j2 = cand_i[a], cand_i[b], cand_j[a], cand_j[b]
    sep = np.linalg.norm(q[i1] - q[i2], axis=1)
    keep = (i1 != i2) & (j1 != j2) & (sep >= 0.08 * ctx.diag)
    i1, i2, j1, j2 = i1[keep][:n_hyp * 2], i2[keep][:n_hyp * 2], j1[keep][:n_hyp * 2], j2[keep][:n_hyp * 2]
    if len(i1) == 0:
        return []
    c = np.array([cam.cx, cam.cy])
    w1 = P[j1] / np.linalg.norm(P[j1], axis=1, keepdims=True)
    w2 = P[j2] / np.linalg.norm(P[j2], axis=1, keepdims=True)
    cos_w = np.clip(np.sum(w1 * w2, axis=1), -1.0, 1.0)
    o1, o2 = q[i1] - c, q[i2] - c
    f0 = cam.focal_px
    if "fov" in ctx.free:
        focal = focal_from_ray_angle(o1, o2, cos_w)
        lo = focal_from_fov(min(175.0, cam.fov + 3.0 * sigmas["fov_deg"]), cam.width)
        hi = focal_from_fov(max(0.5, cam.fov - 3.0 * sigmas["fov_deg"]), cam.width)
        good = np.isfinite(focal) & (focal >= lo) & (focal <= hi)
    else:
        focal = np.full(len(i1), f0)
        b1, b2 = camera_rays(o1, focal), camera_rays(o2, focal)
        tolerance = 2.0 * radius / f0
        good = np.abs(np.arccos(np.clip(np.sum(b1 * b2, axis=1), -1, 1)) - np.arccos(cos_w)) <= tolerance
    if not good.any():
        return []
    i1, i2, j1, j2, w1, w2, focal = i1[good], i2[good], j1[good], j2[good], w1[good], w2[good], focal[good]
    o1, o2 = q[i1] - c, q[i2] - c
    R = rotation_from_two_rays(camera_rays(o1, focal), camera_rays(o2, focal), w1, w2)
    R = R[:n_hyp]
    focal = focal[:n_hyp]
    # Score every hypothesis: project the scored DEM points, count photo points with one within the radius.
    photo_tree = cKDTree(q)
    Ps = P[score_idx]
    w, h = cam.image_size
    scores = np.zeros(len(R))
    chunk = max(1, 200_000 // max(1, len(score_idx)))
    for s0 in range(0, len(R), chunk):
        ctx.poll()
        cam_pts = np.einsum("hij,mj->hmi", R[s0:s0 + chunk], Ps)
        z = cam_pts[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = focal[s0:s0 + chunk, None, None] * cam_pts[..., :2] / z[..., None] + c
        inside = (z > 1e-3 * ctx.typical_range) & (uv[..., 0] >= 0) & (uv[..., 0] <= w) & (uv[..., 1] >= 0) & (
            uv[..., 1] <= h)
        hh, mm = np.nonzero(inside)
        if len(hh) == 0:
            continue
        d, i = photo_tree.query(uv[hh, mm], distance_upper_bound=radius)
        hit = np.isfinite(d)
        if not hit.any():
            continue
        # One photo point counts once per hypothesis, with its closest DEM point.
        key = hh[hit] * len(q) + i[hit]
        weight_hit = 1.0 - (d[hit] / radius) ** 2
        order = np.lexsort((-weight_hit, key))
        key, weight_hit = key[order], weight_hit[order]
        first = np.ones(len(key), dtype=bool)
        first[1:] = key[1:] != key[:-1]
        np.add.at(scores, s0 + key[first] // len(q), weight_hit[first])
    order = np.argsort(-scores)
    out: List[dict] = []
    seen: List[np.ndarray] = []
    for idx in order:
        if len(out) >= 8 or scores[idx] <= 0:
            break
        # Distinct only: a rotation within twice the radius of a kept one is the same hypothesis.
        axis = R[idx][2]
        if any(math.degrees(math.acos(min(1.0, float(axis @ s)))) * f0 * math.pi / 180 < 2 * radius for s in seen):
            continue
        seen.append(axis)
        heading, pitch, roll = angles_from_rotation(R[idx])
        out.append({"heading": heading, "pitch": pitch, "roll": roll,
                    "fov": fov_from_focal(float(focal[idx]), cam.width), "score": float(scores[idx])})
    return out


def shift_hypotheses(ctx, sigmas: dict, n_keep: int = 6, camera=None) -> List[dict]:
    """Hypotheses from a vote: every candidate correspondence votes for the image shift that would bring the
    prior's projection of its DEM point onto its photo point; true correspondences agree on one shift (the prior's
    rotation error), wrong ones spread over the gate. The strongest peaks become rotations of the prior camera.

    Cheaper and far less sensitive to the share of wrong points than drawing pairs at random, because one true
    correspondence is enough for a vote.

    ``camera``: vote from this camera (default the prior; :func:`position_hypotheses` gives others).
    """
    from scipy import ndimage
    from scipy.spatial import cKDTree

    cam = ctx.initial if camera is None else camera
    if len(ctx.q) < 2 or len(ctx.P) < 2:
        return []
    gate, _ = _gates(ctx, sigmas)
    uv0, depth0 = cam.project_with_depth(ctx.world)
    front = np.isfinite(uv0).all(axis=1) & (depth0 > 1e-3 * ctx.typical_range)
    dem_idx = np.flatnonzero(front & cam.in_image(np.nan_to_num(uv0, nan=-1e9), margin=gate))
    if len(dem_idx) < 2:
        return []
    k = candidate_count(len(ctx.q), len(dem_idx), 60)
    dist, nn = cKDTree(uv0[dem_idx]).query(ctx.q, k=k, distance_upper_bound=gate)
    dist, nn = np.atleast_2d(dist), np.atleast_2d(nn)
    ok = np.isfinite(dist)
    rows = np.repeat(np.arange(len(ctx.q)), k).reshape(len(ctx.q), k)[ok]
    shifts = ctx.q[rows] - uv0[dem_idx[nn[ok]]]
    if len(shifts) == 0:
        return []
    bin_px = max(2.0, 0.012 * ctx.diag)
    n_bins = max(3, int(math.ceil(2 * gate / bin_px)))
    votes, ex, ey = np.histogram2d(shifts[:, 0], shifts[:, 1], bins=n_bins, range=[[-gate, gate], [-gate, gate]])
    smooth = ndimage.gaussian_filter(votes, 1.0)
    peaks = (smooth == ndimage.maximum_filter(smooth, size=5)) & (smooth > 0)
    order = np.argsort(-smooth[peaks])
    ix, iy = np.nonzero(peaks)
    f = cam.focal_px
    R0 = cam.rotation
    out = []
    for n in order[:n_keep]:
        dx = 0.5 * (ex[ix[n]] + ex[ix[n] + 1])
        dy = 0.5 * (ey[iy[n]] + ey[iy[n] + 1])
        # A point seen dx to the right of where the prior puts it: the camera turns so that (0, 0, 1) in the new
        # frame is the old frame's ray through the centre minus the shift.
        a = np.array([0.0, 0.0, 1.0])
        b = np.array([-dx / f, -dy / f, 1.0])
        R = rotation_between(b / np.linalg.norm(b), a) @ R0
        heading, pitch, roll = angles_from_rotation(R)
        out.append({"heading": heading, "pitch": pitch, "roll": roll, "fov": cam.fov, "score": float(smooth[ix[n],
                                                                                                        iy[n]])})
    return out


def position_hypotheses(ctx, sigmas: dict) -> list:
    """Cameras at other positions the prior allows, for the shift vote, when its position error could turn the
    view by more than its angle error: a rotation at the prior's position cannot explain the parallax of a camera
    moved by a large fraction of the range (close-range scenes).

    Returns:
        list of :class:`~monoplot_plugin.core.camera.Camera` (empty when the parallax is small or the position is
        fixed): eight at one σ around the prior horizontally, one σ above and one below.
    """
    if not {"x", "y"} <= set(ctx.free):
        return []
    parallax_deg = math.degrees(math.atan2(sigmas["position_m"], ctx.typical_range))
    if parallax_deg <= sigmas["angle_deg"]:
        return []
    s = sigmas["position_m"]
    x, y, z = ctx.initial.position
    offsets = [(s * math.cos(a), s * math.sin(a), 0.0) for a in np.arange(8) * math.pi / 4]
    if "z" in ctx.free and ctx.ground is None:
        offsets += [(0.0, 0.0, s), (0.0, 0.0, -s)]
    return [ctx.initial.with_parameters(x=x + dx, y=y + dy, z=z + dz) for dx, dy, dz in offsets]


def kernel_align(ctx, space: ParameterSpace, u0, start_scale: float, final_scale: float, max_points: int = 400,
                 sigmas: Optional[dict] = None):
    """Align by a soft mutual count, annealed: maximise ``sum_i max_j k_ij + sum_j max_i k_ij`` with
    ``k_ij = exp(-|q_i - p_j|^2 / (2 s^2))`` over the free parameters (L-BFGS, torch), ``s`` halving from
    ``start_scale`` to ``final_scale`` pixels.

    A wrongly accepted point adds a term that is flat almost everywhere, so it neither pulls nor pushes: unlike a
    mean distance, the maximum stays where the true correspondences coincide, however many wrong points there are.
    At most ``max_points`` points of each set take part (evenly drawn), which bounds the time.

    With ``sigmas`` (:meth:`~.options.FitOptions.prior_sigmas`) half the soft count less :func:`prior_penalty` is
    maximised, the net score the candidates are judged by: among hundreds of wrong points a wide kernel also
    finds chance clusters far from the stated camera, and the penalty keeps the alignment from climbing them.
    """
    import torch

    rng = np.random.default_rng(ctx.options.seed + 3)
    q = ctx.q if len(ctx.q) <= max_points else ctx.q[rng.choice(len(ctx.q), max_points, replace=False)]
    uv, usable = ctx.project_usable(space, u0)
    idx = np.flatnonzero(usable)
    if len(idx) < 2:
        return np.asarray(u0, dtype=np.float64)
    if len(idx) > max_points:
        idx = rng.choice(idx, max_points, replace=False)
    q_t = torch.as_tensor(q, dtype=torch.float64)
    P_t = torch.as_tensor(ctx.P[idx], dtype=torch.float64)
    u = torch.tensor(np.asarray(u0, dtype=np.float64), requires_grad=True)
    penalty = _torch_prior_penalty(ctx, space, sigmas) if sigmas is not None else None
    scale = float(start_scale)
    while True:
        ctx.poll()
        optimiser = torch.optim.LBFGS([u], lr=1.0, max_iter=20, history_size=10, line_search_fn="strong_wolfe",
                                      tolerance_grad=1e-9, tolerance_change=1e-9)
        before = u.detach().clone()

        def closure(s=scale):
            ctx.poll()
            optimiser.zero_grad()
            proj, depth = space.project(u, P_t)
            front = (depth > 1e-3 * ctx.typical_range).to(torch.float64)
            # Nearest only, both ways: a photo point (or a DEM point) counts once, so stacking many points of one
            # set onto a cluster of the other gains nothing.
            d2 = torch.cdist(q_t, proj).square() + (1.0 - front[None, :]) * 1e12
            k = torch.exp(-d2 / (2.0 * s * s))
            loss = -(k.max(dim=1).values.sum() + k.max(dim=0).values.sum()) / len(q)
            if penalty is not None:  # in the count's units (the soft count is about twice the inliers), per point
                loss = loss + 2.0 * penalty(u) / len(ctx.q)
            loss.backward()
            return loss

        optimiser.step(closure)
        if not torch.isfinite(u).all() or not space.valid(u.detach().numpy()):
            with torch.no_grad():
                u.copy_(before)
            break
        if scale <= final_scale:
            break
        scale = max(final_scale, 0.5 * scale)
    return u.detach().numpy().copy()


def _torch_prior_penalty(ctx, space: ParameterSpace, sigmas: dict):
    """``u -> prior_penalty(ctx, space.camera(u), sigmas)`` as a differentiable torch function of the free
    parameters (the position by its free coordinates; a height set by the ground does not count)."""
    initial = ctx.initial.parameters()
    centre = {"x": initial["x"] - space.origin[0], "y": initial["y"] - space.origin[1],
              "z": initial["z"] - space.origin[2]}
    terms = [(i, space.base[n], float(space.scales[i]), centre.get(n, initial[n]), sigmas[PRIOR_SIGMA_OF[n]])
             for i, n in enumerate(space.names) if n in PRIOR_SIGMA_OF and n in ctx.free]

    def penalty(u):
        total = u.new_zeros(())
        for i, base, scale, centre_value, s in terms:
            total = total + ((base + scale * u[i] - centre_value) / s) ** 2
        return 0.5 * total

    return penalty


def local_optimise(ctx, space: ParameterSpace, u, start_gate: float, final_radius: float, rounds: int = 6):
    """Re-pair and re-solve: mutual-nearest pairs within a gate that shrinks from ``start_gate`` towards
    ``final_radius`` (pixels) as the residuals allow, robust least squares on every free parameter each round.
    Returns the improved parameter vector (``u`` itself when too few pairs ever form)."""
    u = np.asarray(u, dtype=np.float64)
    min_pairs = len(space.names) // 2 + 2
    gate = float(start_gate)
    for _ in range(rounds):
        ctx.poll()
        uv, usable = ctx.project_usable(space, u)
        pairs = mutual_nearest_pairs(ctx.q, uv, usable, gate)
        if len(pairs) < min_pairs:
            break
        q, P = ctx.q[pairs[:, 0]], ctx.P[pairs[:, 1]]
        try:
            u_new, _ = least_squares(ctx, space, u, q, P, loss="soft_l1", f_scale=max(1.0, gate / 3.0),
                                     max_nfev=30 * (len(u) + 1))
        except (ValueError, np.linalg.LinAlgError):
            break
        r = np.linalg.norm(space.project(u_new, P)[0] - q, axis=1)
        u = u_new
        new_gate = float(np.clip(3.0 * 1.4826 * np.median(r), final_radius, gate))
        if new_gate >= gate * 0.98 and _ > 1:
            break
        gate = new_gate
    return u
