"""The entry point, :func:`fit_camera`: checks, then the paired or the unpaired mode, check points, verdict."""

from __future__ import annotations

import time
from typing import Callable, Iterable, Optional

import numpy as np

from ..camera import Camera
from .checks import check_inputs
from .lens import unmodelled_lens
from .near_ground import ground_seen, loosely_placed_ground
from .context import FitCanceled, FitContext
from .options import FitOptions
from .paired import fit_paired
from .result import FitResult, rmse, worst_check
from .unpaired import fit_unpaired
from .check_points import checks_beyond_residuals
from .verdict import judge

__all__ = ["fit_camera"]


def widen_by_checks(result: FitResult, diag: float) -> None:
    """σ from the residuals, scaled by how much worse the check points are (their RMSE over the residuals' RMSE, at
    least 1 px) when they are beyond them (:func:`~.check_points.checks_beyond_residuals`): the residuals' scale is then
    not the camera's error. A time-lapse trial's fit on 3.3 px residuals, its check points at 13.1 px: heading and
    pitch ± 0.03°, the pitch 0.075° off (2.8 σ)."""
    check, own = result.check_rmse_px, result.rmse_px
    if not result.std or not checks_beyond_residuals(check, own, diag, result.mode == "paired"):
        return
    factor = float(check / max(own, 1.0))
    free = set(result.free) if result.free else set(result.std)  # a held parameter keeps its stated σ
    result.std = {name: value * factor if name in free else value for name, value in result.std.items()}
    result.evidence["sigma_widened_by_checks"] = factor


def sees_no_terrain(result: FitResult) -> None:
    """A fitted camera that sees no cell of the terrain it was given is "poor", whatever its points say: a trial's GCP
    table in another CRS than the DEM's (metres beside degrees) fitted "ok" at 0.0 px, 4,575 km from the DEM. Its
    points agree with it; they cannot be the terrain's."""
    x, y = result.camera.position[:2]
    result.evidence["sees_no_terrain"] = True
    if result.status in ("ok", "uncertain"):
        result.status = "poor"
    result.message = (f"Probably wrong: the camera (at X {x:.0f}, Y {y:.0f}) sees no part of the DEM: are the map "
                      f"points' X, Y in the DEM's CRS? No product can be made from it. " + result.message)


def fit_camera(image_points, world_points, initial: Camera, pairs=None, free: Optional[Iterable[str]] = None, *,
               ground=None, eye_height: float = 1.7, terrain=None, check_image_points=None, check_world_points=None,
               options: Optional[FitOptions] = None, progress: Optional[Callable[[float, str], None]] = None,
               is_canceled: Optional[Callable[[], bool]] = None, **option_values) -> FitResult:
    """Fit a camera to photo points and DEM points.

    Args:
        image_points: (N, 2) pixels (u = column, v = row, see :mod:`~monoplot_plugin.core.camera`).
        world_points: (M, 3) map coordinates in the DEM's CRS (metres).
        initial: approximate camera (its image size is the photo's); parameters not in ``free`` keep its values.
        pairs: optional (K, 2) int array of (image index, world index): paired mode on those pairs only.
        free: parameter names to fit (default :data:`DEFAULT_FREE`: x y z heading pitch roll fov).
        ground: optional terrain for the "camera on the ground" constraint: a callable ``(x, y) -> z`` on numpy
            arrays, or an object with a ``sample(x, y)`` method (a :class:`~monoplot_plugin.core.dem.Dem`).
        eye_height: metres of the camera above the ground (with ``ground``).
        terrain: optional :class:`~monoplot_plugin.core.dem.Dem` the points come from: the verdict then also asks
            whether the camera is placed closely enough for all the ground it sees, the near ground too
            (:mod:`~.near_ground`), not only where the points are.
        check_image_points, check_world_points: optional (C, 2) and (C, 3) paired points NOT used by the fit;
            their RMSE is reported as ``check_rmse_px`` and judged by the verdict.
        options: a :class:`FitOptions`; or give its fields as keywords (``position_sigma_m=50``, ``n_starts=1``,
            ``robust=False``, ...), which override it.
        progress: optional ``callable(fraction in [0, 1], message)``.
        is_canceled: optional ``callable() -> bool``, polled during the optimisation (at least every few
            milliseconds); when it returns True the fit stops with status "canceled".
    Returns:
        :class:`FitResult`; its ``status`` says whether the evidence supports the camera.
    """
    unknown = set(option_values) - set(FitOptions.names())
    if unknown:
        raise TypeError(f"fit_camera() got unexpected keyword arguments {sorted(unknown)}")
    opts = FitOptions(**{**(vars(options) if options is not None else {}), **option_values})
    t0 = time.perf_counter()
    ctx = FitContext(image_points, world_points, initial, free, ground, eye_height, opts, progress, is_canceled)
    mode = "unpaired" if pairs is None else "paired"
    try:
        refusal = check_inputs(ctx, pairs)
        if refusal:
            result = FitResult(initial, "refused", refusal, mode, ctx.free)
        elif pairs is not None:
            result = fit_paired(ctx, np.asarray(pairs, dtype=np.int64).reshape(-1, 2))
        else:
            result = fit_unpaired(ctx)
    except FitCanceled:
        result = _canceled(ctx, mode)
    if result.status not in ("refused", "canceled") and check_image_points is not None \
            and check_world_points is not None:
        cq = np.asarray(check_image_points, dtype=np.float64).reshape(-1, 2)
        cuv = result.camera.project(np.asarray(check_world_points, dtype=np.float64).reshape(-1, 3))
        result.check_residuals_px = cuv - cq
        result.check_rmse_px = rmse(result.check_residuals_px)
        if result.evidence:
            cw = np.asarray(check_world_points, dtype=np.float64).reshape(-1, 3)
            nearest = float(np.min(np.linalg.norm(cw - np.asarray(result.camera.position), axis=1))) if len(cw) \
                else float("nan")  # how near the camera the check points measure it (verdict: loose near ground)
            result.evidence.update(check_rmse_px=result.check_rmse_px, has_check=len(cq) > 0, n_check=len(cq),
                                   check_nearest_m=nearest, **worst_check(result.check_residuals_px, cq, cw,
                                                                           result.camera.position))
    if result.evidence and result.status not in ("refused", "canceled"):
        try:  # its refit polls too: a cancel there is the fit's, not an exception out of it (a trial's traceback)
            result.evidence.update(unmodelled_lens(ctx, result))
        except FitCanceled:
            result = _canceled(ctx, mode, result.camera)
    if result.evidence and result.status not in ("refused", "canceled"):
        widen_by_checks(result, ctx.diag)
        seen = ground_seen(result.camera, terrain) if terrain is not None else None
        if seen is not None and result.std:  # without σ nothing can be said
            result.evidence.update(loosely_placed_ground(result.camera, result.std, seen, result.correlation,
                                                         ctx.ground))
        result.status, result.message = judge(result.evidence)
        factor = result.evidence.get("sigma_widened_by_checks")
        if factor:
            result.message += (f" Its σ are widened {factor:.1f} times: the check points measure the camera that much "
                               "less accurate than its residuals say.")
        if seen is not None and not len(seen):
            sees_no_terrain(result)
    result.elapsed_s = time.perf_counter() - t0
    ctx.report(1.0, "")  # not the status: a caller may still lower it (on-ground rule, automatic cap)
    return result


def _canceled(ctx: FitContext, mode: str, camera=None) -> FitResult:
    """The result of a canceled fit: ``camera`` (the best found so far by default)."""
    return FitResult(camera if camera is not None else ctx.best_camera(), "canceled",
                     "The fit was canceled; the camera is the best found so far.", mode, ctx.free,
                     loss_history=ctx.history, n_starts=ctx.starts_tried)
