"""The paper's descent, a stage of the unpaired search: multi-start L-BFGS on the nearest-point loss with basin
escapes, then the two-sided refinement. See the package docstring for the method."""

from __future__ import annotations

import math
import time

import numpy as np

from .losses import nearest_distances, nearest_index, soft_nearest_loss, unpaired_loss
from .params import ParameterSpace
from .result import FitResult, rms
from .starts import jump, start_vectors

__all__ = ["descend_from_prior", "descend", "two_sided", "two_sided_loss"]


def descend_from_prior(ctx) -> FitResult:
    """The paper's descent from the initial camera and the other starts, then (``refine``) the two-sided
    refinement and the automatic pairing; the status is set later by the verdict."""
    import torch

    opts = ctx.options
    n_starts, n_escapes, refine = opts.n_starts, opts.n_escapes, opts.refine

    q_t = torch.as_tensor(ctx.q, dtype=torch.float64)
    P_t = torch.as_tensor(ctx.P, dtype=torch.float64)
    space = ctx.space(ctx.initial)
    cap = 0.04 * ctx.diag
    starts = start_vectors(ctx, space, max(1, n_starts))
    best = None
    total = len(starts) + max(0, n_escapes) + 2
    # The budget is CPU time of this process, not wall time: the same points give the same camera on a quiet
    # machine and on a loaded one (wall time made the fit's result depend on what else was running).
    t0 = time.process_time()
    # Another start must beat the initial camera's descent clearly: with few or outlier-ridden points every
    # camera scores alike, and moving far from the user's rough camera on a tiny difference does harm.
    first_score = math.inf

    def better(score, best_score):
        return score < best_score and score < ctx.options.switch_ratio * first_score

    # The initial camera is tried first with the paper's descent alone (fast when it is good enough), then
    # with the coarse-to-fine pass, then the other starts (coarse-to-fine when enabled).
    # The first descent is the paper's (with its centroid term); the initial camera is then tried again
    # without it (robust to wrongly accepted points, which shift the centroids), with the coarse-to-fine pass.
    plan = [(starts[0], False, ctx.options.centroid_weight)]
    if ctx.options.coarse or ctx.options.centroid_weight:
        plan.append((starts[0], ctx.options.coarse, 0.0))
    plan += [(u0, ctx.options.coarse, 0.0) for u0 in starts[1:]]
    total = len(plan) + max(0, n_escapes) + 2
    for i, (u0, coarse, centroid) in enumerate(plan):
        if i > 0 and time.process_time() - t0 > ctx.options.time_budget_s:
            break
        ctx.report(0.8 * i / total, f"unpaired fit: start {i + 1}")
        u = descend(ctx, space, u0, q_t, P_t, coarse=coarse, centroid_weight=centroid)
        score = truncated_score(ctx, space, u, cap)
        ctx.starts_tried += 1
        ctx.remember(score, space.camera(u))
        if best is None:
            best, first_score = (score, u), score
        elif u0 is starts[0]:  # the initial camera again, coarse-to-fine: a plain comparison
            if score < best[0]:
                best = (score, u)
            first_score = min(first_score, score)
        elif better(score, best[0]):
            best = (score, u)
        if good_enough(ctx, space, best[1], cap):
            break
    # Basin escape: random jumps around the best camera, kept when they lower the truncated score.
    if not good_enough(ctx, space, best[1], cap):
        for j in range(max(0, n_escapes)):
            if time.process_time() - t0 > ctx.options.time_budget_s:
                break
            ctx.report(0.8 * (len(plan) + j) / total, f"unpaired fit: basin escape {j + 1}")
            u0 = best[1] + jump(ctx, space, 0.5)
            if not space.valid(u0):
                continue
            u = descend(ctx, space, u0, q_t, P_t, coarse=ctx.options.coarse, centroid_weight=0.0)
            score = truncated_score(ctx, space, u, cap)
            ctx.starts_tried += 1
            ctx.remember(score, space.camera(u))
            if better(score, best[0]):
                best = (score, u)
            if good_enough(ctx, space, best[1], cap):
                break
    u = best[1]
    camera = space.camera(u)
    uv, usable = ctx.project_usable(space, u)
    nearest = nearest_distances(ctx.q, uv, usable)
    empty = np.zeros((0, 2), dtype=np.int64)
    result = FitResult(camera, "ok", "", "unpaired", ctx.free, rms(nearest), empty, np.zeros((0, 2)),
                       np.zeros(0, dtype=bool), nearest, loss_history=ctx.history, n_starts=ctx.starts_tried)
    if refine:
        ctx.report(0.82, "unpaired fit: two-sided refinement")
        u = two_sided(ctx, space, q_t, P_t, u)
        uv, usable = ctx.project_usable(space, u)
        nearest = nearest_distances(ctx.q, uv, usable)
        result.camera, result.nearest_px, result.rmse_px = space.camera(u), nearest, rms(nearest)
    return result


def descend(ctx, space: ParameterSpace, u0: np.ndarray, q_t, P_t, rounds: int = 6,
             iterations: int = 20, coarse: bool = True, centroid_weight: float = 1.0) -> np.ndarray:
    """The paper's descent: L-BFGS on :func:`unpaired_loss`, ``lambda`` updated between rounds; preceded
    (``coarse=True``) by a coarse-to-fine pass on a smoothed version of the same nearest distance
    (:func:`soft_nearest_loss`, scale 8 %, 4 %, 2 % then 1 % of the image diagonal), which widens the basin of
    attraction: with dense random-looking point sets the hard minimum has a local minimum every point spacing."""
    import torch

    u = torch.tensor(np.asarray(u0, dtype=np.float64), requires_grad=True)
    diag = ctx.diag
    if coarse:
        for sigma in (0.08 * diag, 0.04 * diag, 0.02 * diag, 0.01 * diag):
            ctx.poll()
            optimiser = torch.optim.LBFGS([u], lr=1.0, max_iter=15, history_size=10,
                                          line_search_fn="strong_wolfe", tolerance_grad=1e-9,
                                          tolerance_change=1e-10)
            before = u.detach().clone()

            def soft_closure():
                ctx.poll()
                optimiser.zero_grad()
                uv_, depth_ = space.project(u, P_t)
                usable_ = ctx.usable(uv_, depth_, 0.25)
                if not bool(usable_.any()):
                    loss_ = (u * 0.0).sum() + diag
                else:
                    loss_ = soft_nearest_loss(q_t, uv_[usable_], sigma)
                loss_.backward()
                return loss_

            optimiser.step(soft_closure)
            if not space.valid(u.detach().numpy()) or not torch.isfinite(u).all():
                with torch.no_grad():
                    u.copy_(before)
                break
    previous = math.inf
    margins = np.linspace(max(ctx.view_margin, 0.25), ctx.view_margin, rounds)
    for r in range(rounds):
        ctx.poll()
        with torch.no_grad():
            uv, depth = space.project(u, P_t)
            usable = ctx.usable(uv, depth, margins[r])
            if not bool(usable.any()):
                return u.detach().numpy()
            _, nearest = unpaired_loss(q_t, uv, usable, 0.0)
        mean_nearest = float(nearest.mean())
        lam = centroid_weight * (mean_nearest / (mean_nearest + 0.02 * diag)) / diag
        optimiser = torch.optim.LBFGS([u], lr=1.0, max_iter=iterations, history_size=10,
                                      line_search_fn="strong_wolfe", tolerance_grad=1e-9,
                                      tolerance_change=1e-10)
        margin = float(margins[r])

        def closure():
            ctx.poll()
            optimiser.zero_grad()
            uv_, depth_ = space.project(u, P_t)
            usable_ = ctx.usable(uv_, depth_, margin)
            if not bool(usable_.any()):
                loss_ = (u * 0.0).sum() + 10.0 * diag
            else:
                loss_, _ = unpaired_loss(q_t, uv_, usable_, lam, robust_px=ctx.robust_px)
            loss_.backward()
            return loss_

        before = u.detach().clone()
        optimiser.step(closure)
        with torch.no_grad():
            uv, depth = space.project(u, P_t)
            usable = ctx.usable(uv, depth, margin)
            loss = (float(unpaired_loss(q_t, uv, usable, lam, robust_px=ctx.robust_px)[0])
                    if bool(usable.any()) else math.inf)
        if not space.valid(u.detach().numpy()) or not np.isfinite(loss):
            with torch.no_grad():
                u.copy_(before)
            break
        ctx.history.append(loss)
        if abs(previous - loss) < 1e-3 * max(1.0, loss) and r >= 2:
            break
        previous = loss
    return u.detach().numpy()


def truncated_score(ctx, space: ParameterSpace, u, cap: float) -> float:
    """Truncated mean nearest distance (pixels): unmatched photo points cost ``cap`` each, no more."""
    if not space.valid(u):
        return math.inf
    uv, usable = ctx.project_usable(space, u)
    if not usable.any():
        return math.inf
    nearest = nearest_distances(ctx.q, uv, usable)
    return float(np.mean(np.minimum(nearest, cap)))


def good_enough(ctx, space, u, cap) -> bool:
    """Most photo points have a close DEM point: no need to try other starts."""
    uv, usable = ctx.project_usable(space, u)
    if not usable.any():
        return False
    nearest = nearest_distances(ctx.q, uv, usable)
    return bool(np.mean(nearest <= 0.25 * cap) >= 0.8)


def chamfer_weight(ctx) -> float:
    """Weight of the DEM-to-photo term: 1 for sets of similar size, less when DEM points far outnumber photo
    points (most of them then have no counterpart and must not pull)."""
    return float(min(1.0, len(ctx.q) / max(1, len(ctx.P))))


def two_sided_loss(ctx, space, u, q_t, P_t, cap: float):
    """Truncated two-sided Chamfer distance (pixels): photo -> nearest DEM point and, weighted, in-view DEM
    point -> nearest photo point; each distance capped at ``cap`` so unmatched points cost a constant."""
    import torch

    uv, depth = space.project(u, P_t)
    usable = ctx.usable(uv, depth, 0.0)
    if not bool(usable.any()):
        return (u * 0.0).sum() + cap
    cand = uv[usable]
    i_w = nearest_index(q_t, cand)
    i_q = nearest_index(cand, q_t)
    a = torch.sqrt((q_t - cand[i_w]).square().sum(dim=1) + 1e-6).clamp(max=cap).mean()
    b = torch.sqrt((cand - q_t[i_q]).square().sum(dim=1) + 1e-6).clamp(max=cap).mean()
    return a + chamfer_weight(ctx) * b


def two_sided(ctx, space: ParameterSpace, q_t, P_t, u0) -> np.ndarray:
    """Refine by the truncated two-sided Chamfer distance (:meth:`_two_sided_loss`). The paper's one-sided
    loss lets a photo point sit anywhere inside a cloud of DEM points; asking the DEM points near photo points to
    have a photo point near them too centres the two clouds (measured on Aletsch: about 0.5 px better)."""
    import torch

    cap = ctx.two_sided_cap * ctx.diag
    u = torch.tensor(np.asarray(u0, dtype=np.float64), requires_grad=True)
    optimiser = torch.optim.LBFGS([u], lr=1.0, max_iter=60, history_size=10, line_search_fn="strong_wolfe",
                                  tolerance_grad=1e-9, tolerance_change=1e-10)

    def closure():
        ctx.poll()
        optimiser.zero_grad()
        loss = two_sided_loss(ctx, space, u, q_t, P_t, cap)
        loss.backward()
        return loss

    optimiser.step(closure)
    out = u.detach().numpy()
    if not space.valid(out):
        return np.asarray(u0, dtype=np.float64)
    with torch.no_grad():
        before = float(two_sided_loss(ctx, space, torch.tensor(np.asarray(u0, dtype=np.float64)), q_t, P_t, cap))
        after = float(two_sided_loss(ctx, space, torch.tensor(out), q_t, P_t, cap))
    ctx.history.append(after)
    return out if after <= before else np.asarray(u0, dtype=np.float64)
