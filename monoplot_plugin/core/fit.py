"""Camera fit: find the camera that projects DEM points onto photo points, with or without known pairs.

Two modes, one entry point, :func:`fit_camera`:

Unpaired (the paper's method, the default when ``pairs`` is None). Photo points ``q_i`` (N of them) and DEM points
``P_j`` (M of them, N and M may differ, no correspondence known). With ``p_j`` the projection of ``P_j``, the loss is::

    L = mean_i min_j |q_i - p_j|  +  lambda * |mean_i q_i - mean_j p_j|^2

minimised with PyTorch autograd (L-BFGS). ``lambda`` is adaptive: ``lambda = rho / diag`` with ``diag`` the image
diagonal in pixels and ``rho = D / (D + 0.02 diag)`` where ``D`` is the current mean nearest distance, so the
centroid term dominates while the projection is far from the points and vanishes near convergence (where the
centroids of two unequal point sets need not coincide). DEM points behind the camera or projecting outside the
image (plus a margin) take part in neither term: out-of-view points must not attract the fit.

With ``robust=False, coarse=False, n_starts=1, n_escapes=0, refine=False`` :func:`fit_camera` is exactly that.
The defaults differ where measurements said so (eval/aletsch.py): each distance saturates (``robust``,
:func:`unpaired_loss`), and when the first descent leaves many photo points unmatched, the initial camera is tried
again *without* the centroid term (with a few wrongly accepted points the centroids of the two sets differ and the
term pulls the camera away: 1 % of the rejected Aletsch suggestions added moved the fit 200 px off with it, 12 px
without), then the other starts.

Then, beyond the paper:

1. multi-start and basin escape: when the first descent leaves many photo points without a close DEM point, other
   starts around the initial camera (heading, pitch, field of view, position) are tried and the best kept (judged by
   a truncated nearest-distance score, robust to unmatched points);
2. automatic pairing: mutual nearest neighbours within a gate, refined by robust least squares (``soft_l1`` loss)
   with outlier rejection, re-paired until the pairs stop changing;
3. paired mode (``pairs`` given): PnP / DLT starts, then Levenberg-Marquardt;
4. any subset of parameters free (``free``), others kept from ``initial``;
5. camera on the ground (``ground`` callable or :class:`~monoplot_plugin.core.dem.Dem`): ``z`` is the terrain
   height under the camera plus ``eye_height``, one unknown less;
6. under-determined problems are refused with a message saying what to add.

Accuracy is reported on points not used by the fit when given (``check_image_points``/``check_world_points``)
and always as leave-one-out over the pairs (a fit to few points can look perfect and be far off elsewhere).

Coordinates: everything is computed centred on the initial camera's position (float64), see
:mod:`monoplot_plugin.core.fit_params`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable, Dict, Iterable, List, Optional, Tuple

import numpy as np

from .camera import PARAMETER_NAMES, Camera
from .fit_params import DEFAULT_FREE, ParameterSpace

__all__ = ["FitResult", "fit_camera", "unpaired_loss", "soft_nearest_loss", "mutual_nearest_pairs", "DEFAULT_FREE"]


class FitCanceled(Exception):
    """Raised inside the optimisers when ``is_canceled()`` turns true."""


@dataclass
class FitResult:
    """What :func:`fit_camera` found.

    Attributes:
        camera: the fitted camera (``initial`` unchanged when refused; the best so far when canceled).
        status: "ok", "refused" (under-determined or invalid input: nothing fitted), "canceled", or "poor" (fitted,
            but the pairs' RMSE is large or few points matched: see ``message``).
        message: one human-readable sentence or two (what happened, what to add).
        mode: "paired" or "unpaired".
        free: names of the parameters that were fitted.
        rmse_px: RMSE (pixels) of the pairs used by the final fit (the user's pairs, or the automatic pairs of the
            unpaired mode); for an unpaired fit without enough pairs, the RMS nearest distance. NaN when refused.
        pairs: (K, 2) int array of (image index, world index) used by the final fit.
        residuals_px: (K, 2) projected minus observed pixel of each pair.
        inliers: (K,) bool, False for automatic pairs rejected as outliers (always True in paired mode).
        nearest_px: (N,) distance from each photo point to the nearest projected in-view DEM point (unpaired mode;
            in paired mode, the pair residual norm of each photo point, NaN for unpaired ones).
        std: standard deviation of each fitted parameter (its units: metres, degrees, pixels), from the Jacobian
            of the final least-squares fit; empty when it could not be computed.
        loo_rmse_px: leave-one-out RMSE over the pairs (each pair predicted by a fit without it), NaN if too few.
        loo_residuals_px: (K,) leave-one-out error of each pair (pixels).
        check_rmse_px / check_residuals_px: RMSE and (C, 2) residuals on the independent check points, if given.
        loss_history: the unpaired loss (pixels) after every L-BFGS round of every start, then the pairs' RMSE
            after every robust refinement; for plotting convergence.
        n_starts: how many starts the multi-start tried.
        elapsed_s: wall time of the fit.
    """

    camera: Camera
    status: str
    message: str
    mode: str
    free: Tuple[str, ...] = ()
    rmse_px: float = float("nan")
    pairs: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    residuals_px: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    inliers: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    nearest_px: np.ndarray = field(default_factory=lambda: np.zeros(0))
    std: Dict[str, float] = field(default_factory=dict)
    loo_rmse_px: float = float("nan")
    loo_residuals_px: np.ndarray = field(default_factory=lambda: np.zeros(0))
    check_rmse_px: float = float("nan")
    check_residuals_px: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    loss_history: List[float] = field(default_factory=list)
    n_starts: int = 0
    elapsed_s: float = 0.0

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def summary(self) -> dict:
        """JSON-friendly digest (numbers rounded) for logs and reports."""
        def r(x, n=3):
            return None if x is None or not np.isfinite(x) else round(float(x), n)

        return {"status": self.status, "mode": self.mode, "message": self.message, "rmse_px": r(self.rmse_px),
                "loo_rmse_px": r(self.loo_rmse_px), "check_rmse_px": r(self.check_rmse_px),
                "pairs": int(len(self.pairs)), "inliers": int(self.inliers.sum()), "free": list(self.free),
                "std": {k: r(v, 4) for k, v in self.std.items()}, "n_starts": self.n_starts,
                "elapsed_s": r(self.elapsed_s), "camera": self.camera.to_dict()}


# ----------------------------------------------------------------------------------------------------------------
# The paper's loss
# ----------------------------------------------------------------------------------------------------------------
def unpaired_loss(image_points, projected, usable, lam: float, eps: float = 1e-3, robust_px: Optional[float] = None):
    """Mean nearest distance from each photo point to the usable projected points + ``lam`` * squared centroid gap.

    Args:
        image_points: (N, 2) torch tensor, pixels.
        projected: (M, 2) torch tensor, projected world points (pixels).
        usable: (M,) bool tensor: points in front of the camera and inside the image (+ margin).
        lam: centroid weight (1 / pixel).
        eps: pixels; smooths the distance at zero so gradients stay finite.
        robust_px: None = the paper's loss. Else each distance ``d`` becomes ``c tanh(d / c)`` with ``c =
            robust_px``: unchanged for close points, saturating for far ones, so photo points without a DEM
            counterpart (a wrongly accepted suggestion) stop pulling once they are a few ``c`` away.
    Returns:
        (loss, nearest): 0-d tensor (pixels) and (N,) nearest distances (detached).
    """
    import torch

    candidates = projected[usable]
    if candidates.shape[0] == 0:
        raise ValueError("no DEM point projects into the picture")
    # The gradient of a minimum is that of its arg-minimum: find it without autograd (cheap), then differentiate
    # only the N chosen distances instead of the whole N x M matrix.
    with torch.no_grad():
        index = torch.cdist(image_points, candidates).argmin(dim=1)
    delta = image_points - candidates[index]
    nearest = torch.sqrt(delta.square().sum(dim=1) + eps * eps)
    if robust_px is not None and math.isfinite(robust_px):
        per_point = robust_px * torch.tanh(nearest / robust_px)
    else:
        per_point = nearest
    centroid_gap = image_points.mean(dim=0) - candidates.mean(dim=0)
    loss = per_point.mean() + lam * centroid_gap.square().sum()
    return loss, nearest.detach()


def soft_nearest_loss(image_points, candidates, sigma: float):
    """Smoothed mean nearest distance (pixels): ``-sigma * log(sum_j exp(-d_ij^2 / (2 sigma^2)))`` per photo point,
    a soft minimum of the squared distances at scale ``sigma`` (pixels), expressed as a distance, averaged.

    It tends to the paper's nearest distance as ``sigma -> 0`` and is smooth at larger scales (coarse-to-fine).
    """
    import torch

    d2 = torch.cdist(image_points, candidates).square()
    soft_d2 = -2.0 * sigma * sigma * torch.logsumexp(-d2 / (2.0 * sigma * sigma), dim=1)
    return torch.sqrt(soft_d2.clamp(min=0.0) + 1e-6).mean()


def mutual_nearest_pairs(image_points: np.ndarray, projected: np.ndarray, usable: np.ndarray,
                         gate_px: float) -> np.ndarray:
    """(K, 2) int pairs (image index, world index) that are each other's nearest neighbour within ``gate_px``.

    >>> mutual_nearest_pairs(np.array([[0.0, 0], [10, 0]]), np.array([[1.0, 0], [50, 0], [10, 1]]),
    ...                      np.array([True, True, True]), 3.0).tolist()
    [[0, 0], [1, 2]]
    """
    idx = np.flatnonzero(usable)
    if len(idx) == 0 or len(image_points) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    from scipy.spatial import cKDTree

    proj = projected[idx]
    d_iw, j = cKDTree(proj).query(image_points)
    _, i_back = cKDTree(image_points).query(proj)
    rows = np.arange(len(image_points))
    mutual = (i_back[j] == rows) & (d_iw <= gate_px)
    return np.stack([rows[mutual], idx[j[mutual]]], axis=1).astype(np.int64)


# ----------------------------------------------------------------------------------------------------------------
# Entry point
# ----------------------------------------------------------------------------------------------------------------
def fit_camera(image_points, world_points, initial: Camera, pairs=None, free: Optional[Iterable[str]] = None, *,
               ground=None, eye_height: float = 1.7, check_image_points=None, check_world_points=None,
               n_starts: int = 12, n_escapes: int = 6, view_margin: float = 0.1, gate_px: Optional[float] = None,
               refine: bool = True, coarse: bool = True, robust=True, centroid_weight: float = 1.0,
               time_budget_s: float = 8.0, switch_ratio: float = 0.8, seed: int = 0,
               progress: Optional[Callable[[float, str], None]] = None,
               is_canceled: Optional[Callable[[], bool]] = None) -> FitResult:
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
        check_image_points, check_world_points: optional (C, 2) and (C, 3) paired points NOT used by the fit;
            their RMSE is reported as ``check_rmse_px``.
        n_starts: most starts of the unpaired multi-start (1 = the paper's single descent).
        n_escapes: most random "basin escape" perturbations tried from the best start.
        view_margin: fraction of the image size around it within which projected DEM points still count.
        gate_px: pairing gate in pixels (default: adaptive, 2.5 x the median nearest distance, 4 to 5 % of the
            image diagonal).
        refine: unpaired mode only: two-sided refinement, then automatic pairing and robust least squares
            (False = stop after the paper's loss).
        robust: unpaired mode only: True = each nearest distance of the paper's loss passes through
            ``c tanh(d / c)`` with ``c`` = 6 % of the image diagonal (a wrongly accepted point stops pulling once far
            from every DEM point); a number = that ``c`` in pixels; False or None = the paper's loss exactly.
        centroid_weight: unpaired mode only: factor on the paper's adaptive lambda in the first descent (0 = no
            centroid term); the later starts always go without it.
        coarse: unpaired mode only: a coarse-to-fine pass on a smoothed nearest distance before the paper's loss
            at every start (False = the paper's descent alone).
        time_budget_s: no new start or basin escape begins after this many seconds (the best so far is kept).
        switch_ratio: another start replaces the initial camera's result only when its truncated nearest-distance
            score is below ``switch_ratio`` x the initial one (with uninformative points, stay near the prior).
        seed: random seed of the basin-escape perturbations (results are deterministic).
        progress: optional ``callable(fraction in [0, 1], message)``.
        is_canceled: optional ``callable() -> bool``, polled during the optimisation (at least every few
            milliseconds); when it returns True the fit stops with status "canceled".
    Returns:
        :class:`FitResult`.
    """
    t0 = time.perf_counter()
    fitter = _Fitter(image_points, world_points, initial, free, ground, eye_height, view_margin, seed, progress,
                     is_canceled)
    fitter.coarse = bool(coarse)
    fitter.centroid_weight = float(centroid_weight)
    fitter.robust_px = (None if robust is None or robust is False else
                        (0.06 * fitter.diag if robust is True else float(robust)))
    fitter.time_budget_s = float(time_budget_s)
    fitter.switch_ratio = float(switch_ratio)
    try:
        refusal = fitter.check_inputs(pairs)
        if refusal:
            result = FitResult(initial, "refused", refusal, fitter.mode(pairs), fitter.free)
        elif pairs is not None:
            result = fitter.fit_paired(np.asarray(pairs, dtype=np.int64).reshape(-1, 2))
        else:
            result = fitter.fit_unpaired(n_starts, n_escapes, gate_px, refine)
    except FitCanceled:
        result = FitResult(fitter.best_camera(), "canceled", "The fit was canceled; the camera is the best found "
                           "so far.", fitter.mode(pairs), fitter.free, loss_history=fitter.history,
                           n_starts=fitter.starts_tried)
    if result.status not in ("refused",) and check_image_points is not None and check_world_points is not None:
        cq = np.asarray(check_image_points, dtype=np.float64).reshape(-1, 2)
        cuv = result.camera.project(np.asarray(check_world_points, dtype=np.float64).reshape(-1, 3))
        result.check_residuals_px = cuv - cq
        result.check_rmse_px = _rmse(result.check_residuals_px)
    result.elapsed_s = time.perf_counter() - t0
    fitter.report(1.0, result.status)
    return result


def _rmse(residuals: np.ndarray) -> float:
    residuals = np.asarray(residuals, dtype=np.float64).reshape(-1, 2)
    if len(residuals) == 0:
        return float("nan")
    return float(np.sqrt(np.mean(np.sum(residuals ** 2, axis=1))))


def _ground_callable(ground):
    if ground is None or callable(ground) and not hasattr(ground, "sample"):
        return ground
    if hasattr(ground, "sample"):
        return lambda x, y: ground.sample(x, y)
    raise TypeError("ground must be a callable (x, y) -> z or an object with a sample(x, y) method (Dem)")


class _Fitter:
    """State shared by the stages of one fit (points centred on the initial camera, callbacks, best so far)."""

    def __init__(self, image_points, world_points, initial: Camera, free, ground, eye_height, view_margin, seed,
                 progress, is_canceled):
        self.q = np.asarray(image_points, dtype=np.float64).reshape(-1, 2)
        self.world = np.asarray(world_points, dtype=np.float64).reshape(-1, 3)
        self.initial = initial
        self.origin = np.asarray(initial.position, dtype=np.float64)
        self.P = self.world - self.origin
        requested = tuple(DEFAULT_FREE if free is None else free)
        self.ground = _ground_callable(ground)
        self.eye_height = eye_height
        self.requested_free = requested
        self.free = tuple(n for n in PARAMETER_NAMES if n in set(requested)
                          and not (self.ground is not None and n == "z"))
        self.view_margin = float(view_margin)
        # Options of fit_camera (set again there); defaults here keep the class usable on its own.
        self.coarse, self.robust_px, self.centroid_weight = True, None, 1.0
        self.time_budget_s, self.switch_ratio = 8.0, 0.8
        self.two_sided_cap = 0.025
        self.rng = np.random.default_rng(seed)
        self.progress = progress
        self.is_canceled = is_canceled
        self.history: List[float] = []
        self.starts_tried = 0
        self._best: Optional[Tuple[float, Camera]] = None
        self._last_poll = 0.0
        width, height = initial.image_size
        self.diag = math.hypot(width, height)
        depth = self.P @ initial.rotation[2] if len(self.P) else np.zeros(0)
        front = depth > 0
        dist = np.linalg.norm(self.P[front] if front.any() else self.P, axis=1)
        self.typical_range = float(np.median(dist)) if len(dist) else 1000.0
        self.typical_range = max(self.typical_range, 1.0)

    # --- bookkeeping -----------------------------------------------------------------------------------------
    def mode(self, pairs) -> str:
        return "unpaired" if pairs is None else "paired"

    def report(self, fraction: float, message: str) -> None:
        if self.progress is not None:
            self.progress(float(min(1.0, max(0.0, fraction))), message)

    def poll(self) -> None:
        """Raise :class:`FitCanceled` when the caller asked to stop (polled at most every millisecond)."""
        if self.is_canceled is None:
            return
        now = time.perf_counter()
        if now - self._last_poll < 1e-3:
            return
        self._last_poll = now
        if self.is_canceled():
            raise FitCanceled()

    def remember(self, score: float, camera: Camera) -> None:
        if np.isfinite(score) and (self._best is None or score < self._best[0]):
            self._best = (score, camera)

    def best_camera(self) -> Camera:
        return self.initial if self._best is None else self._best[1]

    def space(self, start: Camera) -> ParameterSpace:
        return ParameterSpace(start, self.free, self.typical_range, origin=self.origin, ground=self.ground,
                              eye_height=self.eye_height)

    # --- refusal ---------------------------------------------------------------------------------------------
    def check_inputs(self, pairs) -> str:
        """Empty string when the problem can be solved, else the message that says what is missing."""
        unknown = set(self.requested_free) - set(PARAMETER_NAMES)
        if unknown:
            return f"Unknown camera parameters {sorted(unknown)}; use names among {', '.join(PARAMETER_NAMES)}."
        n_free = len(self.free)
        if n_free == 0:
            return "No parameter is free: choose at least one parameter to fit."
        if not (np.isfinite(self.q).all() and np.isfinite(self.world).all()):
            return "Some points have non-finite coordinates (NaN): remove them, or give DEM points a height."
        names = ", ".join(self.free)
        if self.ground is not None:
            g = self.ground(np.array([self.origin[0]]), np.array([self.origin[1]]))
            if not np.isfinite(np.asarray(g, dtype=np.float64)).all():
                return ("The camera-on-the-ground constraint needs the terrain height under the initial camera, but "
                        "the DEM has none there (void or outside): move the initial camera onto the DEM.")
        if pairs is not None:
            pairs = np.asarray(pairs)
            if pairs.size and (pairs.ndim != 2 or pairs.shape[1] != 2):
                return "pairs must be a (K, 2) array of (photo point index, DEM point index)."
            pairs = pairs.reshape(-1, 2).astype(np.int64)
            if len(pairs) and (pairs[:, 0].min() < 0 or pairs[:, 0].max() >= len(self.q)
                               or pairs[:, 1].min() < 0 or pairs[:, 1].max() >= len(self.world)):
                return "A pair refers to a point that does not exist (index out of range)."
            k = len(np.unique(pairs, axis=0))
            needed = n_free // 2 + 1  # 2 equations per pair must exceed the unknowns
            if k < needed:
                return (f"{k} linked pair{'s' if k != 1 else ''} give {2 * k} equations for {n_free} free "
                        f"parameters ({names}): link at least {needed - k} more pair{'s' if needed - k > 1 else ''}"
                        f" (at least {needed} in all), or fix parameters (e.g. a known field of view, or the camera "
                        f"on the ground).")
            return ""
        needed = n_free // 2 + 1
        short = []
        if len(self.q) < needed:
            short.append(f"{needed - len(self.q)} more photo point{'s' if needed - len(self.q) > 1 else ''}")
        if len(self.world) < needed:
            short.append(f"{needed - len(self.world)} more DEM point{'s' if needed - len(self.world) > 1 else ''}")
        if short:
            return (f"{len(self.q)} photo points and {len(self.world)} DEM points cannot determine {n_free} free "
                    f"parameters ({names}): add {' and '.join(short)} (at least {needed} of each, and many more for "
                    f"a reliable unpaired fit), link pairs, or fix parameters.")
        uv, depth = self.initial.project_with_depth(self.world)
        if not (depth > 0).any():
            return ("Every DEM point is behind the initial camera: check its heading and position (the fit needs a "
                    "rough camera that looks towards the points).")
        if not self.initial.in_image(uv, margin=max(self.initial.image_size)).any():
            return (f"None of the {len(self.world)} DEM points falls in or near the initial camera's view: check its "
                    f"heading, pitch and field of view (the fit needs a rough camera that sees the points).")
        return ""

    # --- paired mode -----------------------------------------------------------------------------------------
    def fit_paired(self, pairs: np.ndarray) -> FitResult:
        pairs = np.unique(pairs, axis=0)
        q = self.q[pairs[:, 0]]
        P = self.P[pairs[:, 1]]
        self.report(0.05, "paired fit: starts")
        starts = [self.initial] + _pnp_starts(q, P, self.origin, self.initial) + _dlt_start(q, P, self.origin,
                                                                                          self.initial)
        best = None
        for i, start in enumerate(starts):
            self.poll()
            start = self._restrict_to_free(start)
            if not np.isfinite(start.position).all():
                continue
            space = self.space(self.initial)
            u0 = space.from_camera(start)
            if not space.valid(u0):
                continue
            try:
                u, cost = self._least_squares(space, u0, q, P, loss="linear")
            except (ValueError, np.linalg.LinAlgError):
                continue
            self.starts_tried += 1
            self.remember(cost, space.camera(u))
            if best is None or cost < best[0]:
                best = (cost, space, u)
            self.report(0.05 + 0.6 * (i + 1) / len(starts), f"paired fit: start {i + 1}/{len(starts)}")
        if best is None:
            return FitResult(self.initial, "poor", "No start led to a valid camera: check the pairs.", "paired",
                             self.free, n_starts=self.starts_tried)
        _, space, u = best
        camera = space.camera(u)
        residuals = camera.project(self.world[pairs[:, 1]]) - q
        self.history.append(_rmse(residuals))
        self.report(0.7, "paired fit: leave-one-out")
        std = self._std(space, u, q, P)
        loo = self._leave_one_out(space, u, q, P)
        nearest = np.full(len(self.q), np.nan)
        nearest[pairs[:, 0]] = np.linalg.norm(residuals, axis=1)
        rmse = _rmse(residuals)
        status, message = self._judge(rmse, loo, len(pairs), "paired")
        return FitResult(camera, status, message, "paired", self.free, rmse, pairs, residuals,
                         np.ones(len(pairs), dtype=bool), nearest, std, _rms(loo), loo, loss_history=self.history,
                         n_starts=self.starts_tried)

    def _restrict_to_free(self, camera: Camera) -> Camera:
        """``camera`` with every parameter that is not free put back to the initial value."""
        fixed = {n: v for n, v in self.initial.parameters().items() if n not in self.free}
        if self.ground is not None:
            fixed.pop("z", None)
        if "cx" not in self.free and "cy" not in self.free:
            fixed.pop("cx")
            fixed.pop("cy")
        return camera.with_parameters(**fixed)

    def _least_squares(self, space: ParameterSpace, u0, q, P, loss="linear", f_scale=1.0, max_nfev=None):
        """Least squares on pixel residuals of pairs; returns (u, cost = RMSE px)."""
        from scipy.optimize import least_squares

        def residuals(u):
            self.poll()
            uv, depth = space.project(u, P)
            r = (uv - q).ravel()
            # A point behind the camera would be a meaningless projection: push it away with a large residual.
            behind = np.repeat(depth <= 0, 2)
            if behind.any():
                r = np.where(behind, 10.0 * self.diag, r)
            return r

        method = "lm" if loss == "linear" and 2 * len(q) >= len(u0) else "trf"
        res = least_squares(residuals, u0, method=method, loss=loss, f_scale=f_scale, x_scale=1.0,
                            max_nfev=max_nfev or 200 * (len(u0) + 1))
        u = res.x
        if not space.valid(u):
            raise ValueError("invalid camera")
        r = residuals(u).reshape(-1, 2)
        return u, _rmse(r)

    def _std(self, space: ParameterSpace, u, q, P) -> Dict[str, float]:
        """Standard deviations of the free parameters from the Jacobian at the solution (units of the parameter)."""
        m, n = 2 * len(q), len(u)
        if m <= n:
            return {}
        J = np.zeros((m, n))
        r0 = (space.project(u, P)[0] - q).ravel()
        for k in range(n):
            h = 1e-6 * max(1.0, abs(u[k]))
            du = np.zeros(n)
            du[k] = h
            J[:, k] = ((space.project(u + du, P)[0] - q).ravel() - r0) / h
        sigma2 = float(r0 @ r0) / (m - n)
        try:
            cov = np.linalg.inv(J.T @ J) * sigma2
        except np.linalg.LinAlgError:
            return {}
        diag = np.clip(np.diag(cov), 0.0, None)
        return {name: float(space.scales[i] * math.sqrt(diag[i])) for i, name in enumerate(space.names)}

    def _leave_one_out(self, space: ParameterSpace, u, q, P, limit: int = 40) -> np.ndarray:
        """(K,) pixel error of each pair predicted by a fit without it (NaN when the rest is too few).

        With more than ``limit`` pairs only ``limit`` evenly spread pairs are left out in turn (the others stay
        NaN): enough for the RMSE, and the time stays bounded.
        """
        k = len(q)
        out = np.full(k, np.nan)
        if 2 * (k - 1) <= len(u):
            return out
        chosen = np.unique(np.linspace(0, k - 1, min(k, limit)).round().astype(int))
        for i in chosen:
            keep = np.arange(k) != i
            try:
                ui, _ = self._least_squares(space, u, q[keep], P[keep], max_nfev=50 * (len(u) + 1))
            except (ValueError, np.linalg.LinAlgError):
                continue
            uv, depth = space.project(ui, P[i:i + 1])
            if depth[0] > 0:
                out[i] = float(np.linalg.norm(uv[0] - q[i]))
        return out

    def _judge(self, rmse, loo, n_pairs, mode) -> Tuple[str, str]:
        loo_rms = _rms(loo)
        text = f"{mode} fit on {n_pairs} pairs: RMSE {rmse:.1f} px"
        if np.isfinite(loo_rms):
            text += f", leave-one-out {loo_rms:.1f} px"
        else:
            text += " (too few pairs for a leave-one-out check: add points)"
        if rmse > 0.03 * self.diag:
            return "poor", text + ". The residuals are large: check the pairs (a wrong link?) or the free parameters."
        return "ok", text + "."

    # --- unpaired mode ---------------------------------------------------------------------------------------
    def fit_unpaired(self, n_starts: int, n_escapes: int, gate_px: Optional[float], refine: bool) -> FitResult:
        import torch

        # The tensors are small (hundreds of points): intra-op threads only add overhead, and on a busy machine a
        # lot of it (ten times slower measured with 2 threads on 2 shared cores).
        threads = torch.get_num_threads()
        torch.set_num_threads(1)
        try:
            return self._fit_unpaired(n_starts, n_escapes, gate_px, refine)
        finally:
            torch.set_num_threads(threads)

    def _fit_unpaired(self, n_starts: int, n_escapes: int, gate_px: Optional[float], refine: bool) -> FitResult:
        import torch

        q_t = torch.as_tensor(self.q, dtype=torch.float64)
        P_t = torch.as_tensor(self.P, dtype=torch.float64)
        space = self.space(self.initial)
        cap = 0.04 * self.diag
        starts = self._start_vectors(space, max(1, n_starts))
        best = None
        total = len(starts) + max(0, n_escapes) + 2
        t0 = time.perf_counter()
        # Another start must beat the initial camera's descent clearly: with few or outlier-ridden points every
        # camera scores alike, and moving far from the user's rough camera on a tiny difference does harm.
        first_score = math.inf

        def better(score, best_score):
            return score < best_score and score < self.switch_ratio * first_score

        # The initial camera is tried first with the paper's descent alone (fast when it is good enough), then
        # with the coarse-to-fine pass, then the other starts (coarse-to-fine when enabled).
        # The first descent is the paper's (with its centroid term); the initial camera is then tried again
        # without it (robust to wrongly accepted points, which shift the centroids), with the coarse-to-fine pass.
        plan = [(starts[0], False, self.centroid_weight)]
        if self.coarse or self.centroid_weight:
            plan.append((starts[0], self.coarse, 0.0))
        plan += [(u0, self.coarse, 0.0) for u0 in starts[1:]]
        total = len(plan) + max(0, n_escapes) + 2
        for i, (u0, coarse, centroid) in enumerate(plan):
            if i > 0 and time.perf_counter() - t0 > self.time_budget_s:
                break
            self.report(0.8 * i / total, f"unpaired fit: start {i + 1}")
            u = self._descend(space, u0, q_t, P_t, coarse=coarse, centroid_weight=centroid)
            score = self._score(space, u, cap)
            self.starts_tried += 1
            self.remember(score, space.camera(u))
            if best is None:
                best, first_score = (score, u), score
            elif u0 is starts[0]:  # the initial camera again, coarse-to-fine: a plain comparison
                if score < best[0]:
                    best = (score, u)
                first_score = min(first_score, score)
            elif better(score, best[0]):
                best = (score, u)
            if self._good_enough(space, best[1], cap):
                break
        # Basin escape: random jumps around the best camera, kept when they lower the truncated score.
        if not self._good_enough(space, best[1], cap):
            for j in range(max(0, n_escapes)):
                if time.perf_counter() - t0 > self.time_budget_s:
                    break
                self.report(0.8 * (len(plan) + j) / total, f"unpaired fit: basin escape {j + 1}")
                u0 = best[1] + self._jump(space, 0.5)
                if not space.valid(u0):
                    continue
                u = self._descend(space, u0, q_t, P_t, coarse=self.coarse, centroid_weight=0.0)
                score = self._score(space, u, cap)
                self.starts_tried += 1
                self.remember(score, space.camera(u))
                if better(score, best[0]):
                    best = (score, u)
                if self._good_enough(space, best[1], cap):
                    break
        u = best[1]
        camera = space.camera(u)
        uv, usable = self._project_usable(space, u)
        nearest = _nearest(self.q, uv, usable)
        empty = np.zeros((0, 2), dtype=np.int64)
        result = FitResult(camera, "ok", "", "unpaired", self.free, _rms(nearest), empty, np.zeros((0, 2)),
                           np.zeros(0, dtype=bool), nearest, loss_history=self.history, n_starts=self.starts_tried)
        if refine:
            self.report(0.82, "unpaired fit: two-sided refinement")
            u = self._two_sided(space, q_t, P_t, u)
            camera = space.camera(u)
            uv, usable = self._project_usable(space, u)
            nearest = _nearest(self.q, uv, usable)
            result.camera, result.nearest_px, result.rmse_px = camera, nearest, _rms(nearest)
            self.report(0.88, "unpaired fit: automatic pairing and robust refinement")
            refined = self._refine_by_pairs(space, u, gate_px)
            if refined is not None:
                result = refined
        if len(result.pairs) == 0:
            reason = ("too few automatic pairs for a refinement or a leave-one-out check" if refine else
                      "no automatic pairing asked (refine=False), so no leave-one-out check")
            matched = int((nearest <= cap).sum())
            result.message = (f"unpaired fit (the paper's loss): {matched} of {len(self.q)} photo points lie within "
                              f"{cap:.0f} px of a DEM point; {reason}.")
            result.status = "ok" if matched >= max(len(self.free), 0.5 * len(self.q)) else "poor"
        return result

    def _project_usable(self, space: ParameterSpace, u) -> Tuple[np.ndarray, np.ndarray]:
        uv, depth = space.project(np.asarray(u, dtype=np.float64), self.P)
        return uv, self._usable(uv, depth, self.view_margin)

    def _usable(self, uv, depth, margin):
        w, h = self.initial.image_size
        mw, mh = margin * w, margin * h
        lib = np if isinstance(uv, np.ndarray) else __import__("torch")
        near = 1e-3 * self.typical_range
        ok = (depth > near) & (uv[:, 0] >= -mw) & (uv[:, 0] <= w + mw) & (uv[:, 1] >= -mh) & (uv[:, 1] <= h + mh)
        if lib is np:
            ok &= np.isfinite(uv).all(axis=1)
        return ok

    def _descend(self, space: ParameterSpace, u0: np.ndarray, q_t, P_t, rounds: int = 6,
                 iterations: int = 20, coarse: bool = True, centroid_weight: float = 1.0) -> np.ndarray:
        """The paper's descent: L-BFGS on :func:`unpaired_loss`, ``lambda`` updated between rounds; preceded
        (``coarse=True``) by a coarse-to-fine pass on a smoothed version of the same nearest distance
        (:func:`soft_nearest_loss`, scale 8 %, 4 %, 2 % then 1 % of the image diagonal), which widens the basin of
        attraction: with dense random-looking point sets the hard minimum has a local minimum every point spacing."""
        import torch

        u = torch.tensor(np.asarray(u0, dtype=np.float64), requires_grad=True)
        diag = self.diag
        if coarse:
            for sigma in (0.08 * diag, 0.04 * diag, 0.02 * diag, 0.01 * diag):
                self.poll()
                optimiser = torch.optim.LBFGS([u], lr=1.0, max_iter=15, history_size=10,
                                              line_search_fn="strong_wolfe", tolerance_grad=1e-9,
                                              tolerance_change=1e-10)
                before = u.detach().clone()

                def soft_closure():
                    self.poll()
                    optimiser.zero_grad()
                    uv_, depth_ = space.project(u, P_t)
                    usable_ = self._usable(uv_, depth_, 0.25)
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
        margins = np.linspace(max(self.view_margin, 0.25), self.view_margin, rounds)
        for r in range(rounds):
            self.poll()
            with torch.no_grad():
                uv, depth = space.project(u, P_t)
                usable = self._usable(uv, depth, margins[r])
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
                self.poll()
                optimiser.zero_grad()
                uv_, depth_ = space.project(u, P_t)
                usable_ = self._usable(uv_, depth_, margin)
                if not bool(usable_.any()):
                    loss_ = (u * 0.0).sum() + 10.0 * diag
                else:
                    loss_, _ = unpaired_loss(q_t, uv_, usable_, lam, robust_px=self.robust_px)
                loss_.backward()
                return loss_

            before = u.detach().clone()
            optimiser.step(closure)
            with torch.no_grad():
                uv, depth = space.project(u, P_t)
                usable = self._usable(uv, depth, margin)
                loss = (float(unpaired_loss(q_t, uv, usable, lam, robust_px=self.robust_px)[0])
                        if bool(usable.any()) else math.inf)
            if not space.valid(u.detach().numpy()) or not np.isfinite(loss):
                with torch.no_grad():
                    u.copy_(before)
                break
            self.history.append(loss)
            if abs(previous - loss) < 1e-3 * max(1.0, loss) and r >= 2:
                break
            previous = loss
        return u.detach().numpy()

    def _score(self, space: ParameterSpace, u, cap: float) -> float:
        """Truncated mean nearest distance (pixels): unmatched photo points cost ``cap`` each, no more."""
        if not space.valid(u):
            return math.inf
        uv, usable = self._project_usable(space, u)
        if not usable.any():
            return math.inf
        nearest = _nearest(self.q, uv, usable)
        return float(np.mean(np.minimum(nearest, cap)))

    def _good_enough(self, space, u, cap) -> bool:
        """Most photo points have a close DEM point: no need to try other starts."""
        uv, usable = self._project_usable(space, u)
        if not usable.any():
            return False
        nearest = _nearest(self.q, uv, usable)
        return bool(np.mean(nearest <= 0.25 * cap) >= 0.8)

    def _start_vectors(self, space: ParameterSpace, n: int) -> List[np.ndarray]:
        """The initial camera first, then a deterministic pattern of rotated / zoomed / moved starts."""
        cam = self.initial
        offsets = []
        h, v = cam.fov, cam.vertical_fov
        for dh, dp, zoom in [(0.25, 0, 1), (-0.25, 0, 1), (0, 0, 0.8), (0, 0, 1.25), (0, 0.25, 1), (0, -0.25, 1),
                             (0.5, 0, 1), (-0.5, 0, 1), (0.25, 0.2, 0.9), (-0.25, -0.2, 1.1), (0.25, -0.2, 1.1),
                             (-0.25, 0.2, 0.9)]:
            offsets.append(dict(heading=cam.heading + dh * h, pitch=cam.pitch + dp * v,
                                fov=min(170.0, cam.fov * zoom)))
        vectors = [space.zero()]
        for o in offsets:
            if len(vectors) >= n:
                break
            values = {k: val for k, val in o.items() if k in space.names}
            if not values:
                continue
            vectors.append(space.from_camera(cam.with_parameters(**values)))
        while len(vectors) < n:
            vectors.append(self._jump(space, 1.0))
        return vectors

    def _jump(self, space: ParameterSpace, size: float) -> np.ndarray:
        """Random perturbation: about ``size`` x (a quarter of the field of view, 10 % zoom, 3 % of the range)."""
        u = np.zeros(space.size)
        cam = self.initial
        for i, name in enumerate(space.names):
            if name in ("heading", "pitch", "roll"):
                span = {"heading": 0.25 * cam.fov, "pitch": 0.25 * cam.vertical_fov, "roll": 3.0}[name]
            elif name == "fov":
                span = 0.1 * cam.fov
            elif name in ("x", "y", "z"):
                span = 0.03 * self.typical_range
            else:
                span = 0.0
            u[i] = size * span * self.rng.uniform(-1, 1) / space.scales[i]
        return u

    def _chamfer_weight(self) -> float:
        """Weight of the DEM-to-photo term: 1 for sets of similar size, less when DEM points far outnumber photo
        points (most of them then have no counterpart and must not pull)."""
        return float(min(1.0, len(self.q) / max(1, len(self.P))))

    def _two_sided_loss(self, space, u, q_t, P_t, cap: float):
        """Truncated two-sided Chamfer distance (pixels): photo -> nearest DEM point and, weighted, in-view DEM
        point -> nearest photo point; each distance capped at ``cap`` so unmatched points cost a constant."""
        import torch

        uv, depth = space.project(u, P_t)
        usable = self._usable(uv, depth, 0.0)
        if not bool(usable.any()):
            return (u * 0.0).sum() + cap
        cand = uv[usable]
        with torch.no_grad():
            D = torch.cdist(q_t, cand)
            i_w = D.argmin(dim=1)
            i_q = D.argmin(dim=0)
        a = torch.sqrt((q_t - cand[i_w]).square().sum(dim=1) + 1e-6).clamp(max=cap).mean()
        b = torch.sqrt((cand - q_t[i_q]).square().sum(dim=1) + 1e-6).clamp(max=cap).mean()
        return a + self._chamfer_weight() * b

    def _two_sided(self, space: ParameterSpace, q_t, P_t, u0) -> np.ndarray:
        """Refine by the truncated two-sided Chamfer distance (:meth:`_two_sided_loss`). The paper's one-sided
        loss lets a photo point sit anywhere inside a cloud of DEM points; asking the DEM points near photo points to
        have a photo point near them too centres the two clouds (measured on Aletsch: about 0.5 px better)."""
        import torch

        cap = self.two_sided_cap * self.diag
        u = torch.tensor(np.asarray(u0, dtype=np.float64), requires_grad=True)
        optimiser = torch.optim.LBFGS([u], lr=1.0, max_iter=60, history_size=10, line_search_fn="strong_wolfe",
                                      tolerance_grad=1e-9, tolerance_change=1e-10)

        def closure():
            self.poll()
            optimiser.zero_grad()
            loss = self._two_sided_loss(space, u, q_t, P_t, cap)
            loss.backward()
            return loss

        optimiser.step(closure)
        out = u.detach().numpy()
        if not space.valid(out):
            return np.asarray(u0, dtype=np.float64)
        with torch.no_grad():
            before = float(self._two_sided_loss(space, torch.tensor(np.asarray(u0, dtype=np.float64)), q_t, P_t, cap))
            after = float(self._two_sided_loss(space, torch.tensor(out), q_t, P_t, cap))
        self.history.append(after)
        return out if after <= before else np.asarray(u0, dtype=np.float64)

    def _refine_by_pairs(self, space: ParameterSpace, u, gate_px: Optional[float]) -> Optional[FitResult]:
        """Mutual-nearest-neighbour pairs within a gate, robust least squares, outlier rejection, re-pairing.

        The refined camera is kept only if it fits the whole point sets (truncated two-sided Chamfer distance) at
        least as well as the camera it started from: with exact correspondences it is sharper, but pairs formed
        between clouds of nearby yet different features would only fit noise.
        """
        import torch

        u_start = np.asarray(u, dtype=np.float64).copy()
        min_pairs = len(space.names) // 2 + 2
        pairs = np.zeros((0, 2), dtype=np.int64)
        inliers = np.zeros(0, dtype=bool)
        for it in range(6):
            self.poll()
            uv, usable = self._project_usable(space, u)
            nearest = _nearest(self.q, uv, usable)
            finite = nearest[np.isfinite(nearest)]
            if len(finite) == 0:
                return None
            gate = gate_px if gate_px is not None else float(np.clip(2.5 * np.median(finite), 0.004 * self.diag,
                                                                     0.05 * self.diag))
            new_pairs = mutual_nearest_pairs(self.q, uv, usable, gate)
            if len(new_pairs) < min_pairs:
                break
            if it > 0 and len(new_pairs) == len(pairs) and (new_pairs == pairs).all():
                break
            pairs = new_pairs
            q, P = self.q[pairs[:, 0]], self.P[pairs[:, 1]]
            r = np.linalg.norm(space.project(u, P)[0] - q, axis=1)
            scale = max(1.0, 1.4826 * float(np.median(r)))
            try:
                u_robust, _ = self._least_squares(space, u, q, P, loss="soft_l1", f_scale=scale)
            except (ValueError, np.linalg.LinAlgError):
                break
            r = np.linalg.norm(space.project(u_robust, P)[0] - q, axis=1)
            sigma = max(0.5, 1.4826 * float(np.median(r)))
            inliers = r <= 3.0 * sigma
            if inliers.sum() < min_pairs:
                break
            try:
                u_new, cost = self._least_squares(space, u_robust, q[inliers], P[inliers])
            except (ValueError, np.linalg.LinAlgError):
                break
            u = u_new
            self.history.append(cost)
            self.remember(-1.0, space.camera(u))
        if len(pairs) < min_pairs or inliers.sum() < min_pairs:
            return None
        q_t = torch.as_tensor(self.q, dtype=torch.float64)
        P_t = torch.as_tensor(self.P, dtype=torch.float64)
        cap = self.two_sided_cap * self.diag
        with torch.no_grad():
            before = float(self._two_sided_loss(space, torch.tensor(u_start), q_t, P_t, cap))
            after = float(self._two_sided_loss(space, torch.tensor(np.asarray(u, dtype=np.float64)), q_t, P_t, cap))
        kept_refinement = after <= before * 1.01
        if not kept_refinement:
            u = u_start
        camera = space.camera(u)
        q, P = self.q[pairs[:, 0]], self.P[pairs[:, 1]]
        residuals = space.project(u, P)[0] - q
        r = np.linalg.norm(residuals, axis=1)
        sigma = max(0.5, 1.4826 * float(np.median(r)))
        inliers = r <= 3.0 * sigma
        qi, Pi = q[inliers], P[inliers]
        std = self._std(space, u, qi, Pi)
        loo = self._leave_one_out(space, u, qi, Pi)
        loo_all = np.full(len(pairs), np.nan)
        loo_all[inliers] = loo
        rmse = _rmse(residuals[inliers])
        uv, usable = self._project_usable(space, u)
        nearest = _nearest(self.q, uv, usable)
        status, message = self._judge(rmse, loo, int(inliers.sum()), "unpaired")
        message = message.replace("unpaired fit on", "unpaired fit, automatic pairing:").replace(
            " pairs:", f" inlier pairs of {len(pairs)}:")
        message += (" These figures measure how well the automatic pairs agree, not the accuracy: give independent "
                    "check points for that.")
        if not kept_refinement:
            message += (" The least-squares refinement on these pairs fitted the point sets worse than the two-sided "
                        "fit, which was kept (the automatic pairs are probably not exact correspondences).")
        return FitResult(camera, status, message, "unpaired", self.free, rmse, pairs, residuals, inliers, nearest,
                         std, _rms(loo), loo_all, loss_history=self.history, n_starts=self.starts_tried)


def _rms(values) -> float:
    values = np.asarray(values, dtype=np.float64)
    values = values[np.isfinite(values)]
    return float(np.sqrt(np.mean(values ** 2))) if len(values) else float("nan")


def _nearest(q: np.ndarray, uv: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """(N,) distance from each photo point to the nearest usable projected point (inf when none)."""
    if not usable.any():
        return np.full(len(q), np.inf)
    from scipy.spatial import cKDTree

    d, _ = cKDTree(uv[usable]).query(q)
    return d


# ----------------------------------------------------------------------------------------------------------------
# Paired-mode starts
# ----------------------------------------------------------------------------------------------------------------
def _pnp_starts(q: np.ndarray, P: np.ndarray, origin: np.ndarray, initial: Camera) -> List[Camera]:
    """Cameras from OpenCV PnP on centred points, for the initial field of view and a sweep around it."""
    if len(q) < 4:
        return []
    import cv2

    out = []
    for zoom in (1.0, 0.6, 0.8, 1.25, 1.6):
        fov = min(150.0, initial.fov * zoom)
        cam = initial.with_parameters(fov=fov)
        K = cam.K.copy()
        K[0, 2] -= 0.5
        K[1, 2] -= 0.5
        dist = np.array([cam.k1, cam.k2, 0.0, 0.0, 0.0])
        for flag in (cv2.SOLVEPNP_SQPNP, cv2.SOLVEPNP_ITERATIVE):
            try:
                ok, rvec, tvec = cv2.solvePnP(P.astype(np.float64), q.astype(np.float64), K, dist, flags=flag)
            except cv2.error:
                continue
            if not ok or not np.isfinite(rvec).all() or not np.isfinite(tvec).all():
                continue
            found = Camera.from_opencv(rvec, tvec, K, dist[:2], cam.image_size)
            found = found.with_parameters(x=found.position[0] + origin[0], y=found.position[1] + origin[1],
                                          z=found.position[2] + origin[2], cx=cam.cx, cy=cam.cy)
            out.append(found)
            break
    return out


def _dlt_start(q: np.ndarray, P: np.ndarray, origin: np.ndarray, initial: Camera) -> List[Camera]:
    """Camera from the direct linear transform (6+ non-coplanar points), decomposed into K, R, C."""
    if len(q) < 6:
        return []
    import cv2

    scale = max(1.0, float(np.abs(P).max()))
    Pn = P / scale
    rows = []
    for (u, v), (x, y, z) in zip(q - 0.5, Pn):  # OpenCV pixel centres on integers
        rows.append([x, y, z, 1, 0, 0, 0, 0, -u * x, -u * y, -u * z, -u])
        rows.append([0, 0, 0, 0, x, y, z, 1, -v * x, -v * y, -v * z, -v])
    A = np.asarray(rows)
    try:
        _, s, vt = np.linalg.svd(A)
    except np.linalg.LinAlgError:
        return []
    if s[-2] < 1e-12 * s[0]:
        return []
    M = vt[-1].reshape(3, 4)
    try:
        K, R, C, *_ = cv2.decomposeProjectionMatrix(M)
    except cv2.error:
        return []
    C = (C[:3] / C[3]).ravel() * scale
    K = K / K[2, 2]
    if K[0, 0] < 0 or K[1, 1] < 0:
        return []
    if np.linalg.det(R) < 0:
        return []
    # The camera must look at the points (a DLT can return the solution mirrored through the camera centre).
    if np.mean((P - C) @ R[2]) < 0:
        return []
    from .camera import angles_from_rotation, fov_from_focal

    heading, pitch, roll = angles_from_rotation(R)
    focal = 0.5 * (abs(K[0, 0]) + abs(K[1, 1]))
    fov = fov_from_focal(focal, initial.width)
    if not 0.5 < fov < 175:
        return []
    return [initial.with_parameters(x=C[0] + origin[0], y=C[1] + origin[1], z=C[2] + origin[2], heading=heading,
                                    pitch=pitch, roll=roll, fov=fov)]
