"""Paired mode: the user's (photo point, DEM point) pairs; PnP / DLT starts, then Levenberg-Marquardt."""

from __future__ import annotations

import numpy as np

from .lsq import jacobian, leave_one_out, least_squares, parameter_uncertainty
from .result import FitResult, rmse, rms
from .starts import dlt_start, pnp_starts
from .verdict import WEAK_SHARE, photo_spread, weak_direction_matters, weakest_parameter

__all__ = ["fit_paired"]

#: Most pairs for which a paired fit whose residuals are large (over the verdict's ``WEAK_SHARE`` of the
#: diagonal) is solved again without each pair in turn, to find one wrong pair.
MAX_FRESH_LEAVE_OUT = 40


def fit_paired(ctx, pairs: np.ndarray) -> FitResult:
    pairs = np.unique(pairs, axis=0)
    q = ctx.q[pairs[:, 0]]
    P = ctx.P[pairs[:, 1]]
    ctx.report(0.05, "paired fit: starts")
    best = _best_start(ctx, q, P, whole=True)
    if best is None:
        return FitResult(ctx.initial, "poor", "No start led to a valid camera: check the pairs.", "paired",
                         ctx.free, n_starts=ctx.starts_tried)
    _, space, u = best
    camera = space.camera(u)
    residuals = camera.project(ctx.world[pairs[:, 1]]) - q
    ctx.history.append(rmse(residuals))
    ctx.report(0.7, "paired fit: leave-one-out")
    std, correlation = parameter_uncertainty(space, u, q, P, held=ctx.options.held_sigmas(ctx.requested_free))
    loo = leave_one_out(ctx, space, u, q, P)
    nearest = np.full(len(ctx.q), np.nan)
    nearest[pairs[:, 0]] = np.linalg.norm(residuals, axis=1)
    rmse_px = rmse(residuals)
    cond, weakest = weakest_parameter(jacobian(space, u, q, P), space.names, space.scales)
    if not weak_direction_matters(camera, weakest):
        cond = 1.0
    evidence = {"mode": "paired", "n_free": len(ctx.free), "position_free": bool({"x", "y"} & set(ctx.free)),
                "diag": ctx.diag, "n_pairs": len(pairs),
                "rmse_px": rmse_px, "loo_rmse_px": rms(loo), "condition": cond, "weakest": weakest,
                "spread": photo_spread(q, ctx.initial.image_size)}
    finite = np.isfinite(loo)
    own = np.linalg.norm(residuals, axis=1)
    if finite.sum() >= 4:  # the pair that stands out when left out (:func:`~.verdict.suspect_pair_text`)
        worst = int(np.nanargmax(np.where(finite, loo, -np.inf)))
        evidence.update(worst_pair_uv=(float(q[worst, 0]), float(q[worst, 1])), worst_loo_px=float(loo[worst]),
                        median_loo_px=float(np.median(np.delete(loo[finite], np.argmax(loo[finite])))),
                        worst_residual_px=float(own[worst]), median_residual_px=float(np.median(np.delete(own, worst))))
    if rmse_px > WEAK_SHARE * ctx.diag:
        evidence.update(_wrong_pair(ctx, q, P))
    return FitResult(camera, "ok", "", "paired", ctx.free, rmse_px, pairs, residuals,
                     np.ones(len(pairs), dtype=bool), nearest, std, rms(loo), loo, loss_history=ctx.history,
                     n_starts=ctx.starts_tried, evidence=evidence, correlation=correlation)


def _wrong_pair(ctx, q: np.ndarray, P: np.ndarray) -> dict:
    """The pair the others agree without, solved afresh: {} or the evidence of :func:`~.verdict.suspect_pair_text`.

    One wrong pair (a typed coordinate) can drag the whole fit kilometres off: every pair's residual is then large
    and a leave-one-out refit from that camera stays there, so nothing stands out (a desktop trial: u typed 3350
    for 2350 on one of 6 GCPs, "RMSE 582 px", no pair named). Each pair left out in turn, the others are solved
    from new starts; the one whose absence lets the rest agree is named with where they put it.
    """
    if len(q) < 5 or len(q) > MAX_FRESH_LEAVE_OUT:
        return {}
    found = []
    for i in range(len(q)):
        ctx.poll()
        keep = np.arange(len(q)) != i
        best = _best_start(ctx, q[keep], P[keep])
        if best is None:
            continue
        _, space, u = best
        uv, depth = space.project(u, P)
        errors = np.where(depth > 0, np.linalg.norm(uv - q, axis=1), np.inf)
        found.append((rmse(uv[keep] - q[keep]), i, errors))
    if not found:
        return {}
    rest, i, errors = min(found, key=lambda t: t[0])
    others = float(np.median(np.delete(errors, i)))
    if not np.isfinite(rest) or rest > WEAK_SHARE * ctx.diag:
        return {}  # no single pair explains it
    left_out = float(errors[i]) if np.isfinite(errors[i]) else 10.0 * ctx.diag
    return {"worst_pair_uv": (float(q[i, 0]), float(q[i, 1])), "worst_loo_px": left_out, "median_loo_px": others,
            "worst_residual_px": left_out, "median_residual_px": others, "rest_rmse_px": float(rest)}


def _best_start(ctx, q: np.ndarray, P: np.ndarray, whole: bool = False):
    """(cost, space, parameters) of the best least-squares fit of the pairs ``q`` (K, 2) / ``P`` (K, 3) from the
    initial camera, PnP and DLT starts; None when no start leads to a valid camera. ``whole``: these are all the
    pairs (not a leave-one-out subset)."""
    starts = [ctx.initial] + pnp_starts(q, P, ctx.origin, ctx.initial) + dlt_start(q, P, ctx.origin,
                                                                                      ctx.initial)
    best = None
    for i, start in enumerate(starts):
        ctx.poll()
        start = ctx.restrict_to_free(start)
        if not np.isfinite(start.position).all():
            continue
        space = ctx.space(ctx.initial)
        u0 = space.from_camera(start)
        if not space.valid(u0):
            continue
        try:
            u, cost = least_squares(ctx, space, u0, q, P, loss="linear")
        except (ValueError, np.linalg.LinAlgError):
            continue
        if best is None or cost < best[0]:
            best = (cost, space, u)
        if whole:  # the fit of every pair: counted, kept as the best so far (a cancel returns it), reported
            ctx.starts_tried += 1
            ctx.remember(cost, space.camera(u))
            ctx.report(0.05 + 0.6 * (i + 1) / len(starts), f"paired fit: start {i + 1}/{len(starts)}")
    return best
