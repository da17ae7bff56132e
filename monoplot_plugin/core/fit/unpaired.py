"""Unpaired mode: photo points and DEM points with no correspondence known.

Two searches propose cameras and one score judges them:

1. the paper's descent (:mod:`.descent`) from the initial camera and its other starts;
2. the consensus search (:mod:`.consensus`): minimal two-point hypotheses drawn from the prior's uncertainty,
   each locally optimised on its own mutual-nearest pairs.

The camera with the best consensus score (soft count of photo points explained within
:func:`~.consensus.inlier_radius`) is refined by automatic pairing (:mod:`.pairing`), converged on its
mutual-nearest pairs within that radius (:func:`~.pairing.converge_on_pairs`), then judged
(:mod:`.verdict`) on evidence that a small residual cannot fake: its inliers against the chance level of cameras
turned away, the best clearly different competing camera, the spread of the inliers, the Jacobian.
"""

from __future__ import annotations

import math
from typing import List, Tuple

import numpy as np

from .aperture import REACH_RADII, across_line_std, line_normals, slide_ratio, slide_sigma_px
from .consensus import (_gates, chance_inliers, consensus_score, hypotheses, inlier_radius, kernel_align,
                        local_optimise, position_hypotheses, prior_penalty, shift_hypotheses)
from .descent import descend_from_prior
from .local_search import local_hypotheses
from .losses import mutual_nearest_pairs, nearest_distances
from .lsq import bootstrap_std, jacobian, leave_one_out, parameter_uncertainty
from .pairing import converge_on_pairs, refine_by_pairs
from .params import ParameterSpace
from .result import FitResult, rms, rmse
from .stability import pixel_precision, weak_direction_probes
from .verdict import TRUNCATED_SHARE, flags_outliers, judge, photo_spread, weak_direction_matters, weakest_parameter

__all__ = ["fit_unpaired", "AUTOMATIC_PAIRS_WIDENING"]

#: Factor on the σ of an unpaired fit (see :func:`_judge_unpaired`).
AUTOMATIC_PAIRS_WIDENING = 1.4

#: How many of the best consensus candidates are searched again around themselves
#: (:func:`~.local_search.local_hypotheses`).
LOCAL_CANDIDATES = 4
#: Soft inliers by which a camera of the local search must beat the first search's best (see :func:`_fit_unpaired`).
LOCAL_MARGIN = 2.0
#: Share of the inlier radius within which the last step also converges (see :func:`_converge`).
TIGHT_SHARE = 0.5
#: Soft inliers (net of the prior's penalty) by which a stability probe must beat the camera to replace it (see
#: :func:`_stability`).
PROBE_MARGIN = 0.5
#: A camera that pairs this share of the smaller point set (photo points, DEM points in view) is not probed: a rival
#: explaining nearly as many points would have to place most of the same ones elsewhere, which the points' Jacobian
#: (its condition) already measures. Keeps the probes' cost where the evidence is thin (measured, 2026-12-02: the
#: 200 x 500 benchmark pairs 198 of 200 points; probing it took 0.6 s -> 1.6 s).
SETTLED_SHARE = 0.8


def fit_unpaired(ctx) -> FitResult:
    """The whole unpaired fit (see the module docstring); status and message from :func:`~.verdict.judge`."""
    import torch

    # The tensors are small (hundreds of points): intra-op threads only add overhead, and on a busy machine a
    # lot of it (ten times slower measured with 2 threads on 2 shared cores).
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        return _fit_unpaired(ctx)
    finally:
        torch.set_num_threads(threads)


def _fit_unpaired(ctx) -> FitResult:
    opts = ctx.options
    space = ctx.space(ctx.initial)
    uv0, in_view = ctx.project_usable(space, space.zero())
    w, h = ctx.initial.image_size
    radius = inlier_radius(ctx.diag, w * h, len(ctx.q), int(in_view.sum()))
    sigmas = opts.prior_sigmas(ctx.initial.fov, ctx.typical_range)
    descended = descend_from_prior(ctx)
    u_descent = space.from_camera(descended.camera)
    candidates: List[Tuple[float, np.ndarray, str]] = [(_score(ctx, space, u_descent, radius), u_descent,
                                                        "descent")]
    # The consensus search is skipped when the descent already explains half of the smaller point set: a clearly
    # different camera cannot then explain as many (it would need those points to fit two cameras).
    uv_d, usable_d = ctx.project_usable(space, u_descent)
    matched = len(consensus_score(ctx.q, uv_d, usable_d, radius)[1])
    convincing = matched >= max(12, 0.5 * min(len(ctx.q), int(usable_d.sum())))
    if opts.consensus and opts.refine and not convincing:
        ctx.report(0.9, "unpaired fit: consensus search")
        _, hyp_radius = _gates(ctx, sigmas)
        starts = []
        origins = [(ctx.initial, h) for h in shift_hypotheses(ctx, sigmas, 8) +
                   hypotheses(ctx, sigmas, opts.consensus_hypotheses)[:6]]
        for camera in position_hypotheses(ctx, sigmas):
            origins += [(camera, h) for h in shift_hypotheses(ctx, sigmas, 3, camera=camera)]
        for camera, h in origins:
            values = {k: h[k] for k in ("heading", "pitch", "roll", "fov") if k in ctx.free}
            u0 = space.from_camera(ctx.restrict_to_free(camera.with_parameters(**values)))
            if space.valid(u0):
                starts.append((_score(ctx, space, u0, hyp_radius), u0))
        # Only the stated camera and the most promising starts are aligned (the alignment is what costs). The stated
        # camera always: among hundreds of wrong points its window can score lower than chance clusters elsewhere,
        # though the truth lies nearest to it; its kernel starts at three inlier radii, too narrow to climb those
        # clusters (Aletsch, careless +5 %, 2026-12-03: 394 px from the ranked starts alone, 70.5 px with it).
        prior_start = space.from_camera(ctx.restrict_to_free(ctx.initial))
        aligned = [(prior_start, min(hyp_radius, 3.0 * radius))]
        aligned += [(u0, hyp_radius) for _, u0 in sorted(starts, key=lambda t: -t[0])[:opts.consensus_starts - 1]]
        for u0, scale in aligned:
            u = kernel_align(ctx, space, u0, scale, radius, sigmas=sigmas)
            u = local_optimise(ctx, space, u, 3.0 * radius, radius)
            candidates.append((_score(ctx, space, u, radius), u, "consensus"))
            ctx.starts_tried += 1
        # The best few candidates searched again around themselves (many wrong points hold a local optimisation
        # where it starts; see local_hypotheses). A camera of this narrower search joins only when it explains
        # LOCAL_MARGIN more points than every camera so far: a different explanation, not a neighbour of one that
        # fits the noise of the same pairs a little better (measured on Aletsch's 20 re-suggested starts, 2026-12-02:
        # without the margin such neighbours replaced the camera in 8 starts, 6 of them 0.4-5 px farther from the
        # GCPs, 12/20 within 12 px became 9/20; with it every start ends as before).
        nets = [c[0] - prior_penalty(ctx, space.camera(c[1]), sigmas) if np.isfinite(c[0]) else -math.inf
                for c in candidates]
        best_net = max(nets)
        ranked = sorted((c for c, n in zip(candidates[1:], nets[1:]) if np.isfinite(n)),
                        key=lambda c: -(c[0] - prior_penalty(ctx, space.camera(c[1]), sigmas)))
        for _, u_c, _ in ranked[:LOCAL_CANDIDATES]:
            for u in local_hypotheses(ctx, space, u_c, radius):
                s = _score(ctx, space, u, radius)
                if s - prior_penalty(ctx, space.camera(u), sigmas) >= best_net + LOCAL_MARGIN:
                    candidates.append((s, u, "consensus"))
    # Judged by the consensus score less the prior's penalty: a camera far from the stated one must explain
    # more points. The descent's camera is kept on a near tie: it is the paper's method, and its two-sided
    # refinement centres clouds of nearby different features better than a count does.
    candidates = [(s - prior_penalty(ctx, space.camera(u), sigmas) if np.isfinite(s) else s, u, o)
                  for s, u, o in candidates]
    best_score = max(c[0] for c in candidates)
    if candidates[0][0] >= best_score - 0.03 * abs(best_score):
        chosen = candidates[0]
    else:
        chosen = max(candidates, key=lambda c: c[0])
    u = chosen[1]
    result = None
    origin, rivals = chosen[2], []
    if opts.refine:
        ctx.report(0.95, "unpaired fit: automatic pairing and robust refinement")
        result = refine_by_pairs(ctx, space, u, opts.gate_px, with_loo=False)
        # Polish: least squares on the camera's own tight inliers (the gate shrinks with the residuals down to 2 px),
        # kept when it explains the points at least as well; the automatic pairing's gate can be wide.
        if result is not None:
            u_res = space.from_camera(result.camera)
            u_pol = local_optimise(ctx, space, u_res, radius, 2.0)
            if _score(ctx, space, u_pol, radius) >= _score(ctx, space, u_res, radius):
                result.camera = space.camera(u_pol)
                if len(result.pairs):  # the pairs' residuals and RMSE of the camera returned, not of the one before
                    p = result.pairs
                    result.residuals_px = space.project(u_pol, ctx.P[p[:, 1]])[0] - ctx.q[p[:, 0]]
                    kept = result.inliers if len(result.inliers) == len(p) else np.ones(len(p), dtype=bool)
                    result.rmse_px = rmse(result.residuals_px[kept])
            _converge(ctx, space, result, radius)
            adopted, rivals = _stability(ctx, space, result, radius, sigmas)
            if adopted:
                origin = "stability probe"
    if result is None:
        uv, usable = ctx.project_usable(space, u)
        nearest = nearest_distances(ctx.q, uv, usable)
        result = descended if chosen[2] == "descent" else FitResult(
            space.camera(u), "ok", "", "unpaired", ctx.free, rms(nearest), nearest_px=nearest)
    if not opts.refine:
        result.message = ("The paper's loss only (refine=False): no automatic pairing asked, so no "
                          "leave-one-out check.")
    result.n_starts = ctx.starts_tried
    result.loss_history = ctx.history
    _judge_unpaired(ctx, space, result, candidates, radius, origin, sigmas, rivals)
    return result


def _converge(ctx, space: ParameterSpace, result: FitResult, radius: float) -> None:
    """Last step (:func:`~.pairing.converge_on_pairs`), kept when its camera explains the points as well (consensus
    score within 1 %); the result's pairs, residuals and RMSE become the converged ones. The leave-one-out check is
    made here, on the final pairs, so that it judges the same pairs as the RMSE.

    From there it also converges on the pairs within :data:`TIGHT_SHARE` of the radius and keeps that camera when
    it scores higher at the full radius: with few true pairs, a wrong pair near the radius can hold the camera
    along a weakly determined direction (measured on the synthetic scene u170: 9.9 px from the truth converged
    within the radius, 1.7 px within half of it, which also scores 12.7 against 11.4)."""
    u_res = space.from_camera(result.camera)
    floor = 0.99 * _score(ctx, space, u_res, radius)
    best, u_from = None, u_res
    for share in (1.0, TIGHT_SHARE):
        u_conv, pairs = converge_on_pairs(ctx, space, u_from, share * radius)
        if pairs is None:
            continue
        s = _score(ctx, space, u_conv, radius)
        if s >= floor and (best is None or s > best[0]):
            best, u_from = (s, u_conv, pairs), u_conv
    if best is not None:
        _, u_conv, pairs = best
        result.camera = space.camera(u_conv)
        result.pairs, result.inliers = pairs, np.ones(len(pairs), dtype=bool)
        result.residuals_px = space.project(u_conv, ctx.P[pairs[:, 1]])[0] - ctx.q[pairs[:, 0]]
        result.rmse_px = rmse(result.residuals_px)
    if not len(result.pairs):
        return
    u = space.from_camera(result.camera)
    kept = result.inliers if len(result.inliers) == len(result.pairs) else np.ones(len(result.pairs), dtype=bool)
    p = result.pairs[kept]
    loo = leave_one_out(ctx, space, u, ctx.q[p[:, 0]], ctx.P[p[:, 1]])
    result.loo_residuals_px = np.full(len(result.pairs), np.nan)
    result.loo_residuals_px[kept] = loo
    result.loo_rmse_px = rms(loo)


def _stability(ctx, space: ParameterSpace, result: FitResult, radius: float, sigmas: dict):
    """Re-optimise the result's camera from starts along its weakest directions
    (:func:`~.stability.weak_direction_probes`). A probe that explains the points better by :data:`PROBE_MARGIN`
    (net of the prior's penalty) replaces the camera (then converged again, see :func:`_converge`).

    Not when the camera already pairs :data:`SETTLED_SHARE` of the smaller point set.

    Returns:
        (adopted, others): whether a probe replaced the camera, and the ``(net score, parameter vector)`` of the
        other cameras reached (the probes' ends and a replaced camera), for the verdict's rivals.
    """
    u = space.from_camera(result.camera)
    uv, usable = ctx.project_usable(space, u)
    pairs = consensus_score(ctx.q, uv, usable, radius)[1]
    if len(pairs) == 0 or len(pairs) >= SETTLED_SHARE * min(len(ctx.q), int(usable.sum())):
        return False, []
    own = _score(ctx, space, u, radius) - prior_penalty(ctx, result.camera, sigmas)
    ends = []
    # The camera mirrored through the prior (the parameter space is centred on it) is a start too.
    mirror = 2.0 * space.from_camera(ctx.restrict_to_free(ctx.initial)) - u
    for _, u_end in weak_direction_probes(ctx, space, u, ctx.q[pairs[:, 0]], ctx.P[pairs[:, 1]], radius,
                                          also=[mirror]):
        ends.append((_score(ctx, space, u_end, radius) - prior_penalty(ctx, space.camera(u_end), sigmas), u_end))
    if not ends:
        return False, []
    best = max(ends, key=lambda t: t[0])
    if best[0] > own + PROBE_MARGIN:
        result.camera = space.camera(best[1])
        _converge(ctx, space, result, radius)
        return True, ends + [(own, u)]
    return False, ends


def _moved(space: ParameterSpace, u, u_other, P: np.ndarray) -> float:
    """RMS pixel distance between where the cameras ``u`` and ``u_other`` project the centred points ``P``."""
    return float(np.sqrt(np.mean(np.sum((space.project(u_other, P)[0] - space.project(u, P)[0]) ** 2, axis=1))))


def _slide(space: ParameterSpace, J: np.ndarray, uv: np.ndarray, usable: np.ndarray, pairs: np.ndarray,
           radius: float, q_in: np.ndarray) -> Tuple[float, dict]:
    """(σ in pixels of the camera sliding along lines of DEM points, σ of each parameter from the across-line
    evidence alone), see :mod:`.aperture`; ``J`` the pairs' Jacobian."""
    kept = np.flatnonzero(usable)
    normals = line_normals(uv[kept], np.searchsorted(kept, pairs[:, 1]), REACH_RADII * radius)
    residual = float(np.sqrt(np.mean((uv[pairs[:, 1]] - q_in) ** 2)))
    return (slide_sigma_px(slide_ratio(J, normals), residual, len(pairs)),
            across_line_std(J, normals, residual, space.names, space.scales))


def _score(ctx, space: ParameterSpace, u, radius: float) -> float:
    if not space.valid(u):
        return -math.inf
    uv, usable = ctx.project_usable(space, u)
    return consensus_score(ctx.q, uv, usable, radius)[0]


def _judge_unpaired(ctx, space: ParameterSpace, result: FitResult, candidates, radius: float, origin: str,
                    sigmas: dict, rivals=()) -> None:
    """Fill ``result.evidence``, ``status``, ``message``, ``photo_outliers`` and the σ of an unpaired fit.
    ``rivals``: (net score, parameter vector) of other cameras the stability probes reached (:func:`_stability`).
    """
    u = space.from_camera(result.camera)
    uv, usable = ctx.project_usable(space, u)
    score, pairs = consensus_score(ctx.q, uv, usable, radius)
    # Outliers: photo points with no DEM point within three radii, or, when some pairs exist, farther than that.
    nearest = nearest_distances(ctx.q, uv, usable)
    outliers = ~(nearest <= 3.0 * radius)
    chance = chance_inliers(ctx, space, u, radius)
    # The best clearly different competitor: a candidate that moves this camera's inliers by 3 radii or more.
    competitor = 0.0
    if len(pairs):
        P_in = ctx.P[pairs[:, 1]]
        here = space.project(u, P_in)[0]
        for s, uc, _ in candidates:
            if not np.isfinite(s) or not space.valid(uc):
                continue
            there = space.project(uc, P_in)[0]
            if np.median(np.linalg.norm(there - here, axis=1)) >= 3.0 * radius:
                competitor = max(competitor, s)
    own = score - prior_penalty(ctx, result.camera, sigmas)
    q_in, P_in = (ctx.q[pairs[:, 0]], ctx.P[pairs[:, 1]]) if len(pairs) else (np.zeros((0, 2)), np.zeros((0, 3)))
    # A rival: a camera the stability probes reached that moves the inliers (RMS) by more than this camera's
    # precision (three times its pixel σ, at least 2 px): at most one of the two can be right. The verdict weighs
    # its net score against this camera's, as it weighs the search's competitors.
    precision = pixel_precision(space, u, q_in, P_in) if len(pairs) else math.nan
    rival_net, rival_px, rival_m = -math.inf, 0.0, 0.0
    for net, u_r in rivals if len(pairs) else ():
        moved = _moved(space, u, u_r, P_in)
        if moved > max(2.0, 3.0 * precision) and net > rival_net:
            rival_net, rival_px = net, moved
            rival_m = float(np.linalg.norm(np.subtract(space.camera(u_r).position, result.camera.position)))
    # Truncated residuals: many more pairs within twice the radius than chance adds there (three times the area of
    # the radius, about twice as many pairs as the soft chance score): the points or the DEM (a coarse one) err by
    # about the radius. It matters when the camera converged on the pairs within twice the radius moves the inliers
    # by more than this camera's precision, as a rival would (synthetic suite, 2026-12-02: u101 on a coarse DEM,
    # 10.4 px from the truth, moves; u4, 0.7 px, with as many pairs beyond, does not).
    wide = len(mutual_nearest_pairs(ctx.q, uv, usable, 2.0 * radius)) if len(pairs) else 0
    beyond = max(0.0, wide - len(pairs) - 6.0 * float(chance.mean()))
    truncation_px = 0.0
    if beyond > TRUNCATED_SHARE * len(pairs):
        u_wide, wide_pairs = converge_on_pairs(ctx, space, u, 2.0 * radius)
        if wide_pairs is not None:
            truncation_px = _moved(space, u, u_wide, P_in)
    J = jacobian(space, u, q_in, P_in) if 2 * len(pairs) > len(u) else None
    cond, weakest = weakest_parameter(J, space.names, space.scales) if J is not None else (math.inf, "")
    slide_px, slide_std = _slide(space, J, uv, usable, pairs, radius, q_in) if J is not None else (math.inf, {})
    if not weak_direction_matters(result.camera, weakest):
        cond = 1.0
    # σ: the covariance of the final pairs, widened by a bootstrap over them when that is larger (a few wrong
    # automatic pairs widen the bootstrap, not the covariance), and by the automatic pairing's covariance (its
    # gate follows the residuals: where the inlier radius is smaller than the noise, the pairs within the radius
    # have truncated residuals and too small a covariance).
    # (the correlations are the final pairs' covariance's: the widenings below scale the σ, not how they go together)
    held = ctx.options.held_sigmas(ctx.requested_free)
    std, result.correlation = parameter_uncertainty(space, u, q_in, P_in, held=held) if len(pairs) else ({}, {})
    for name, value in (result.std or {}).items():
        std[name] = max(std.get(name, 0.0), value)
    boot = bootstrap_std(ctx, space, u, q_in, P_in, ctx.options.bootstrap) if len(pairs) else {}
    for name, value in list(boot.items()) + list(slide_std.items()):  # a slide along lines widens σ too
        std[name] = max(std.get(name, 0.0), value)
    # The pairs were chosen by the fit itself (mutual nearest within a radius), which trims the residuals the
    # covariance is scaled by, and a coarse DEM's height errors are systematic, not noise: widen by
    # AUTOMATIC_PAIRS_WIDENING (measured on the synthetic suite, 2026-12-02, after the converging step: with 1.3 the
    # true camera lay within 2 sigma in every parameter at once in 0.899 of the successes, with 1.4 in 0.918).
    # (a held parameter's σ is the one stated for it, not the pairs')
    result.std = {name: value if name in held else AUTOMATIC_PAIRS_WIDENING * value for name, value in std.items()}
    used = result.inliers.sum() if len(result.inliers) else 0
    evidence = {"mode": "unpaired", "n_free": len(ctx.free), "position_free": bool({"x", "y"} & set(ctx.free)),
                "diag": ctx.diag, "n_photo": len(ctx.q),
                "n_dem": len(ctx.world), "n_dem_in_view": int(usable.sum()), "radius_px": radius,
                "n_inliers": int(len(pairs)),
                "score": score, "chance_max": float(chance.max()), "chance_mean": float(chance.mean()),
                "competitor_ratio": competitor / own if own > 0 else 0.0,
                "precision_px": precision, "rival_px": rival_px, "rival_m": rival_m,
                "rival_ratio": rival_net / own if own > 0 and np.isfinite(rival_net) else 0.0,
                "beyond_radius": beyond, "truncation_px": truncation_px,
                "spread": photo_spread(ctx.q[pairs[:, 0]], ctx.initial.image_size) if len(pairs) else 0.0,
                "photo_outliers": int(outliers.sum()), "condition": cond, "weakest": weakest, "slide_px": slide_px,
                "rmse_px": rmse(space.project(u, P_in)[0] - q_in) if len(pairs) else math.nan,
                "loo_rmse_px": result.loo_rmse_px, "n_pairs": int(used), "camera_from": origin,
                "note": result.message}
    result.evidence = evidence
    result.status, result.message = judge(evidence)
    result.photo_outliers = outliers if flags_outliers(result.status) else np.zeros_like(outliers)
    kept = result.inliers if len(result.inliers) == len(result.pairs) else np.ones(len(result.pairs), dtype=bool)
    if ctx.options.refine and len(pairs) and int(kept.sum()) != len(pairs):
        # The pairs, residuals and RMSE reported become those the message counts (the consensus pairs within the
        # inlier radius; the verdict is made): with few points the camera kept can be the descent's, with no
        # automatic pairs, or the automatic pairing's, with pairs beyond the radius; the dock's header said "0 of 6
        # matched, RMSE 30 px" under a message "4 of 6 photo points matched ..., RMSE 2.4 px". The leave-one-out
        # RMSE stays the one the verdict weighed (per pair: not computed for these pairs).
        result.pairs, result.inliers = pairs, np.ones(len(pairs), dtype=bool)
        result.residuals_px = space.project(u, P_in)[0] - q_in
        result.rmse_px = rmse(result.residuals_px)
        result.loo_residuals_px = np.full(len(pairs), np.nan)
