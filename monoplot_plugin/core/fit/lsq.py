"""Least squares on pixel residuals of pairs, the parameters' σ and leave-one-out; shared by every mode."""

from __future__ import annotations

import math
from typing import Dict, Optional, Tuple

import numpy as np

from .params import ParameterSpace
from .result import rmse

__all__ = ["least_squares", "jacobian", "parameter_std", "parameter_uncertainty", "bootstrap_std", "leave_one_out",
           "PIXEL_FLOOR", "few_equations_factor"]


def least_squares(ctx, space: ParameterSpace, u0, q, P, loss="linear", f_scale=1.0, max_nfev=None):
    """Least squares on pixel residuals of pairs; returns (u, cost = RMSE px)."""
    from scipy.optimize import least_squares

    def residuals(u):
        ctx.poll()
        uv, depth = space.project(u, P)
        r = (uv - q).ravel()
        # A point behind the camera would be a meaningless projection: push it away with a large residual.
        behind = np.repeat(depth <= 0, 2)
        if behind.any():
            r = np.where(behind, 10.0 * ctx.diag, r)
        return r

    method = "lm" if loss == "linear" and 2 * len(q) >= len(u0) else "trf"
    res = least_squares(residuals, u0, method=method, loss=loss, f_scale=f_scale, x_scale=1.0,
                        max_nfev=max_nfev or 200 * (len(u0) + 1))
    u = res.x
    if not space.valid(u):
        raise ValueError("invalid camera")
    r = residuals(u).reshape(-1, 2)
    return u, rmse(r)


def jacobian(space: ParameterSpace, u, q, P) -> np.ndarray:
    """(2K, n) forward-difference Jacobian of the K pairs' pixel residuals in the parameter vector's units."""
    m, n = 2 * len(q), len(u)
    J = np.zeros((m, n))
    r0 = (space.project(u, P)[0] - q).ravel()
    for k in range(n):
        h = 1e-6 * max(1.0, abs(u[k]))
        du = np.zeros(n)
        du[k] = h
        J[:, k] = ((space.project(u + du, P)[0] - q).ravel() - r0) / h
    return J


#: Pixel accuracy below which no point is trusted (a detected or clicked point is never better than this).
PIXEL_FLOOR = 0.5


def parameter_std(ctx, space: ParameterSpace, u, q, P) -> Dict[str, float]:
    """Standard deviations of the free parameters (their units: metres, degrees, pixels) from the covariance
    ``s^2 (J^T J)^-1``, ``s`` the residuals' standard error (at least :data:`PIXEL_FLOOR`)."""
    return parameter_uncertainty(space, u, q, P)[0]


def parameter_uncertainty(space: ParameterSpace, u, q, P, held: Optional[Dict[str, float]] = None
                          ) -> Tuple[Dict[str, float], Dict[str, Dict[str, float]]]:
    """(σ of each free parameter as :func:`parameter_std`, and of each ``held`` one, their correlations
    ``{name: {other: r}}``); both empty when the covariance cannot be computed.

    The correlations say which errors go together: a camera slid back along its view and turned to keep far points
    where they are moves them little and the near ground a lot, which σ taken as independent cannot tell
    (:func:`~.result.sigma_shifts`).

    ``held``: σ (their units) of parameters held at a value known to that accuracy (not free: a surveyed position
    fixed at ± 1 m). The free parameters take up their error as well: ``G Σ Gᵀ`` is added to the covariance, ``G``
    how the fit's solution moves with each held value (:func:`held_sensitivity`). A time-lapse trial's camera fixed
    at its surveyed position (1.3 m off, ± 1 m) had its pitch 3.5 σ off with the residuals' σ alone."""
    m, n = 2 * len(q), len(u)
    if m <= n:
        return {}, {}
    J = jacobian(space, u, q, P)
    r0 = (space.project(u, P)[0] - q).ravel()
    sigma2 = max(float(r0 @ r0) / (m - n), PIXEL_FLOOR ** 2) * few_equations_factor(m - n) ** 2
    try:
        normal_inv = np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        return {}, {}
    cov = normal_inv * sigma2
    G, sigma_held, held_names, held_scales = np.zeros((n, 0)), np.zeros(0), [], []
    if held:
        G, sigma_held, held_names, held_scales = held_sensitivity(space, u, q, P, J, normal_inv, held)
        cov = cov + (G * sigma_held ** 2) @ G.T
    if space.ground is not None and GROUND_HEIGHT_SIGMA_M > 0:  # the held height is not exact either
        Gh = ground_height_sensitivity(space, u, q, P, J, normal_inv, r0)
        cov = cov + (Gh * GROUND_HEIGHT_SIGMA_M ** 2) @ Gh.T
    # the held parameters with their stated σ, and how the free ones follow them: a position held at a rough guess
    # (± 40 m) had no σ, and the near ground's check took it as exact (a flood trial: "ok", "about 1.0 m on the
    # ground", the near ground 75 m off)
    S = np.diag(sigma_held ** 2)
    cov = np.block([[cov, G @ S], [(G @ S).T, S]])
    names = list(space.names) + list(held_names)
    scales = list(space.scales) + list(held_scales)
    diag = np.clip(np.diag(cov), 0.0, None)
    std = {name: float(scales[i] * math.sqrt(diag[i])) for i, name in enumerate(names)}
    root = np.sqrt(diag)
    if not np.all(np.isfinite(cov)) or np.any(root <= 0):
        return std, {}
    corr = np.clip(cov / np.outer(root, root), -1.0, 1.0)
    return std, {a: {b: float(corr[i, j]) for j, b in enumerate(names)} for i, a in enumerate(names)}


#: σ (m) of the height of a camera held on the ground (its eye height over the DEM): a person's eye stands about
#: 1.4-2.0 m up, and the DEM under the spot errs too. Taken as exact, it left the near ground out of the σ: an
#: eye-level scene's "ok" camera stood 1.8 m under the truth with σ x 0.03 m, its near ground 221 px off
#: (eval/eye_level.py, e27); with 0.3 m its σ cover that ground and it is "uncertain".
GROUND_HEIGHT_SIGMA_M = 0.3


def ground_height_sensitivity(space: ParameterSpace, u, q, P, J: np.ndarray, normal_inv: np.ndarray,
                              r0: np.ndarray, step_m: float = 0.5) -> np.ndarray:
    """(n, 1): how the free parameters' solution ``u`` moves per metre of a camera's held height over the ground
    (``space.ground``), in the space's units: ``-(JᵀJ)⁻¹ Jᵀ b``, ``b`` the residuals' change per metre of eye
    height (a step of ``step_m``); ``r0`` the residuals at ``u``."""
    higher = ParameterSpace(space.camera(u), space.names, space.typical_range, origin=space.origin,
                            ground=space.ground, eye_height=space.eye_height + step_m)
    b = ((higher.project(higher.zero(), P)[0] - q).ravel() - r0) / step_m
    return -normal_inv @ J.T @ b[:, None]


def held_sensitivity(space: ParameterSpace, u, q, P, J: np.ndarray, normal_inv: np.ndarray,
                     held: Dict[str, float]) -> Tuple[np.ndarray, np.ndarray, list, list]:
    """(G (n, k), σ (k,), names, scales): how the free parameters' solution ``u`` (n,) moves per unit of each held
    parameter, both in the units of a space that frees them too (:func:`~.params.parameter_scales`), the held σ in
    those units, the held parameters' names and their scales.
    ``G = -(JᵀJ)⁻¹ Jᵀ B``, ``B`` the residuals' Jacobian in the held parameters; ``normal_inv`` is ``(JᵀJ)⁻¹``."""
    names = [n for n in held if n not in space.names and not (space.ground is not None and n == "z")]
    if not names:
        return np.zeros((len(u), 0)), np.zeros(0), [], []
    camera = space.camera(u)
    wider = ParameterSpace(camera, tuple(space.names) + tuple(names), space.typical_range, origin=space.origin,
                           ground=space.ground, eye_height=space.eye_height)
    columns = [wider.names.index(n) for n in names]
    B = jacobian(wider, wider.zero(), q, P)[:, columns]
    scales = np.array([wider.scales[i] for i in columns])
    return -normal_inv @ J.T @ B, np.array([held[n] for n in names]) / scales, names, list(scales)


#: fewer equations to spare than this and the residuals' scale is a guess (:func:`few_equations_factor`)
FEW_SPARE = 4


def few_equations_factor(spare: int) -> float:
    """How much wider σ must be when the residuals' scale is estimated from ``spare`` (fewer than
    :data:`FEW_SPARE`) equations beyond the unknowns (2 x pairs - free parameters): the Student t quantile of a 2σ
    interval over the normal's, so that "within 2σ" means what it says; 1 from :data:`FEW_SPARE` on (where it is
    1.4 and falls to 1.09 at 15: there the σ are judged as they always were, Aletsch's 11 GCPs among them). 4
    pairs for 7 parameters leave one: a drone trial's "ok" camera was 3-5 σ off on 4 of its parameters, its σ taken
    from an RMSE of 0.11 px.

    >>> [round(few_equations_factor(k), 2) for k in (1, 2, 3, 4, 15)]
    [6.98, 2.26, 1.65, 1.0, 1.0]
    """
    from scipy.stats import norm, t

    if spare <= 0:
        return float("inf")
    if spare >= FEW_SPARE:
        return 1.0
    return float(t.ppf(float(norm.cdf(2.0)), spare) / 2.0)


#: at most this many patches of the picture are drawn by :func:`bootstrap_std`
BOOTSTRAP_BLOCKS = 16


def photo_blocks(q: np.ndarray, blocks: int) -> np.ndarray:
    """(K,) block index in ``0 .. ~blocks-1`` of each photo point ``q`` (K, 2) px: the picture cut into a grid of
    patches holding about as many points each (quantiles of u, then of v within each column).

    >>> q = np.array([[u, v] for u in range(4) for v in range(4)], float)
    >>> np.bincount(photo_blocks(q, 4)).tolist()
    [4, 4, 4, 4]
    """
    k = len(q)
    columns = max(1, int(round(math.sqrt(blocks))))
    rows = max(1, blocks // columns)
    out = np.zeros(k, dtype=int)
    column_of = np.minimum((np.argsort(np.argsort(q[:, 0], kind="stable")) * columns) // max(k, 1), columns - 1)
    for c in range(columns):
        inside = np.flatnonzero(column_of == c)
        order = np.argsort(np.argsort(q[inside, 1], kind="stable"))
        out[inside] = c * rows + np.minimum((order * rows) // max(len(inside), 1), rows - 1)
    return out


def bootstrap_std(ctx, space: ParameterSpace, u, q, P, rounds: int) -> Dict[str, float]:
    """σ of each free parameter over ``rounds`` least-squares fits to patches of the picture drawn with replacement
    (:func:`photo_blocks`, at most :data:`BOOTSTRAP_BLOCKS`; single pairs when there are fewer pairs). It captures
    what the covariance misses when a few automatic pairs are wrong, and errors that neighbouring points share (a
    coarse DEM's heights, a wrong stretch of ridge), which a draw of single pairs averages away. Empty when too few
    pairs."""
    k, n = len(q), len(u)
    if rounds <= 0 or 2 * k <= n + 2:
        return {}
    rng = np.random.default_rng(ctx.options.seed + 99)
    block = photo_blocks(q, min(k, BOOTSTRAP_BLOCKS))
    members = [np.flatnonzero(block == b) for b in np.unique(block)]
    samples = []
    for _ in range(rounds):
        pick = np.concatenate([members[b] for b in rng.integers(0, len(members), len(members))])
        if len(np.unique(pick)) * 2 <= n + 1:
            continue
        try:
            ub, _ = least_squares(ctx, space, u, q[pick], P[pick], max_nfev=10 * (n + 1))
        except (ValueError, np.linalg.LinAlgError):
            continue
        samples.append(ub)
    if len(samples) < 5:
        return {}
    # half the range of the middle 68 % (σ for a normal spread), not the standard deviation: one draw of few
    # distinct pairs can land a camera kilometres away, and made Aletsch's semi-automatic σ 1.2 km (45 m without
    # it). (Leaving such draws out instead narrowed the σ of eye-level cameras until two wrong ones said "ok".)
    low, high = np.percentile(np.asarray(samples), [15.87, 84.13], axis=0)
    spread = 0.5 * (high - low)
    return {name: float(space.scales[i] * spread[i]) for i, name in enumerate(space.names)}


def leave_one_out(ctx, space: ParameterSpace, u, q, P, limit: int = 40) -> np.ndarray:
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
            ui, _ = least_squares(ctx, space, u, q[keep], P[keep], max_nfev=50 * (len(u) + 1))
        except (ValueError, np.linalg.LinAlgError):
            continue
        uv, depth = space.project(ui, P[i:i + 1])
        if depth[0] > 0:
            out[i] = float(np.linalg.norm(uv[0] - q[i]))
    return out
