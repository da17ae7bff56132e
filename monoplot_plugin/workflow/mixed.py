"""Pairs and points without a partner accepted together: when the pairs alone do not fix the camera, the other
points are fitted unpaired and the pairs check that fit.

A person who pairs a few summits and accepts many suggestions without partners expects all of them to count. A
paired fit uses the pairs only: a trial's 4 summits left hundreds of accepted points out, the camera 28 m off. On
generated scenes (50 of ``eval``'s synthetic scenes, 4 of their true pairs given as pairs and the rest unpaired),
the paired fit on the 4 pairs was within 1.5 times the error of the scene's best camera in 11, this fit in 45, 43
of them "ok" with the 4 pairs as its check points. The pairs are kept out of that fit on purpose: as check points
they are independent evidence, which the verdict weighs (:func:`~..core.fit.verdict.judge`).

Only a paired fit that is not "ok" is tried again this way: a person's good pairs fix a camera better than automatic
matches, and an "ok" on them stays as it was (nor costs a second fit). The fit of the other points is taken when it
is "ok", or "uncertain" too with the pairs agreeing with it at least as well as they agree with each other
(:func:`better_than_pairs`).
"""

from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from ..core.fit.params import DEFAULT_FREE
from ..core.fit.verdict import WEAK_SHARE
from . import fit as fit_step
from .progress import IsCanceled, Progress, part

__all__ = ["fit_accepted", "points_without_partner", "better_than_pairs", "EXTRA_PER_FREE", "PAIRS_AGREE_SHARE"]

#: Points without a partner, on each side, per free parameter, before they are fitted on their own: fewer cannot
#: give an unpaired fit its "ok" (the verdict wants twice as many matched points as unknowns).
EXTRA_PER_FREE = 2
#: The pairs agree with the fit of the other points when they are at most this share of the picture's diagonal off
#: it (RMS): the verdict's limit for check points that verify a camera (:data:`~..core.fit.verdict.WEAK_SHARE`).
PAIRS_AGREE_SHARE = WEAK_SHARE


def points_without_partner(n_photo: int, n_map: int, pairs: np.ndarray):
    """(photo rows, map rows) that no pair uses, in order.

    >>> points_without_partner(4, 3, np.array([[0, 2], [3, 0]]))
    (array([1, 2]), array([1]))
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    return np.setdiff1d(np.arange(n_photo), pairs[:, 0]), np.setdiff1d(np.arange(n_map), pairs[:, 1])


def fit_accepted(uv: np.ndarray, xyz: np.ndarray, start, dem, pairs=None, check_uv: Optional[np.ndarray] = None,
                 check_xyz: Optional[np.ndarray] = None, progress: Optional[Progress] = None,
                 is_canceled: Optional[IsCanceled] = None, free: Optional[Sequence[str]] = None, options=None,
                 on_ground: Optional[bool] = None, eye_height: Optional[float] = None) -> fit_step.FitDone:
    """:func:`~.fit.fit` of the accepted points; with pairs whose paired fit is not "ok" and enough points without
    a partner (:data:`EXTRA_PER_FREE`), those points fitted unpaired with the pairs as check points, that fit taken
    when :func:`better_than_pairs` says so (else ``FitDone.alone_status`` is its status). Its result's indices
    (``pairs``, ``photo_outliers``, ``nearest_px``) are those of ``uv`` and ``xyz``; its check residuals are
    ``check_uv``'s, then the pairs'. ``FitDone.pairs_checked`` says how many pairs checked it. Raises as
    :func:`~.fit.fit`."""
    kw = dict(free=free, options=options, on_ground=on_ground, eye_height=eye_height, is_canceled=is_canceled)
    pairs = None if pairs is None or len(pairs) == 0 else np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    if pairs is None:
        return fit_step.fit(uv, xyz, start, dem, check_uv=check_uv, check_xyz=check_xyz, progress=progress, **kw)
    photo_rows, map_rows = points_without_partner(len(uv), len(xyz), pairs)
    paired = fit_step.fit(uv, xyz, start, dem, pairs=pairs, check_uv=check_uv, check_xyz=check_xyz,
                          progress=part(progress, 0.0, 0.4), **kw)
    # the unknowns the paired fit had (a camera held on the ground has no height of its own: 6)
    enough = EXTRA_PER_FREE * len(paired.result.free or free or DEFAULT_FREE)
    if paired.result.status == "ok" or min(len(photo_rows), len(map_rows)) < enough:
        return paired
    n_check = 0 if check_uv is None else len(check_uv)
    checks_uv = np.vstack([np.reshape(check_uv, (-1, 2)) if n_check else np.zeros((0, 2)), uv[pairs[:, 0]]])
    checks_xyz = np.vstack([np.reshape(check_xyz, (-1, 3)) if n_check else np.zeros((0, 3)), xyz[pairs[:, 1]]])
    report = part(progress, 0.4, 1.0)
    report(0.0, "fitting the points without a partner, the pairs as check points")
    try:
        alone = fit_step.fit(uv[photo_rows], xyz[map_rows], start, dem, check_uv=checks_uv, check_xyz=checks_xyz,
                             progress=report, **kw)
    except fit_step.FitRefused as refusal:
        paired.result.message += f" The points without a partner could not be fitted on their own: {refusal}"
        return paired
    on_pairs = np.asarray(alone.result.check_residuals_px, dtype=float).reshape(-1, 2)[n_check:]
    off = float(np.sqrt(np.mean(np.sum(on_pairs ** 2, axis=1)))) if len(on_pairs) else float("nan")
    n_pairs, n_photo, n_map = len(pairs), len(photo_rows), len(map_rows)
    own = float(paired.result.loo_rmse_px)
    if not better_than_pairs(alone.result.status, off, own, float(np.hypot(*start.image_size))):
        own_text = f"{own:.1f} px left out of their own fit" if np.isfinite(own) else "too few to leave one out"
        paired.result.message += (
            f" The {n_photo} photo and {n_map} map points without a partner were also fitted on their own, your "
            f"{n_pairs} pairs as check points: that fit is {alone.result.status}, your pairs {off:.1f} px off it "
            f"({own_text}), so the paired fit is kept.")
        paired.alone_status = alone.result.status
        return paired
    result = alone.result
    matched = np.asarray(result.pairs, dtype=np.int64).reshape(-1, 2)
    result.pairs = np.column_stack([photo_rows[matched[:, 0]], map_rows[matched[:, 1]]]) if len(matched) else matched
    result.photo_outliers = _spread_rows(result.photo_outliers, photo_rows, len(uv), False)
    result.nearest_px = _spread_rows(result.nearest_px, photo_rows, len(uv), np.nan)
    result.message = (f"Your {n_pairs} pairs alone left the camera {paired.result.status}: the {n_photo} photo and "
                      f"{n_map} map points without a partner place it, and your pairs are {off:.1f} px off it"
                      + (f" (each {own:.1f} px off a fit of the other pairs)" if np.isfinite(own) else "")
                      + f". {result.message}")
    alone.pairs_checked = n_pairs
    return alone


def better_than_pairs(status: str, off_px: float, own_loo_px: float, diag: float) -> bool:
    """Whether the fit of the points without a partner (its ``status``; the user's pairs ``off_px`` RMS off it)
    is taken over a paired fit that is not "ok" (its leave-one-out RMSE ``own_loo_px``, NaN when the pairs are too
    few to leave one out): when it is "ok", or "uncertain" with the pairs within :data:`PAIRS_AGREE_SHARE` of the
    picture's diagonal (``diag``) and predicted at least as well as the pairs predict each other. Both are
    predictions of the pairs by cameras not fitted to them: a trial's 4 summits agreed to 1.9 px with the unpaired
    fit of 413 points, both fits "uncertain" (the near ground of a camera 6 m over a floodplain), and the paired
    camera, 31 m off, was kept over the unpaired one, 6 m off.

    >>> better_than_pairs("ok", 30.0, 1.0, 1000.0), better_than_pairs("uncertain", 1.9, float("nan"), 5000.0)
    (True, True)
    >>> better_than_pairs("uncertain", 9.0, 4.0, 5000.0), better_than_pairs("uncertain", 90.0, 400.0, 5000.0)
    (False, False)
    >>> better_than_pairs("poor", 1.0, float("nan"), 5000.0)
    False
    """
    if status == "ok":
        return True
    if status != "uncertain" or not np.isfinite(off_px) or off_px > PAIRS_AGREE_SHARE * diag:
        return False
    return not np.isfinite(own_loo_px) or off_px <= own_loo_px


def _spread_rows(values, rows: np.ndarray, n: int, fill):
    """``values`` given for ``rows`` of ``n``, as an (n,) array (``fill`` elsewhere); as given when they are not one
    per row."""
    values = np.asarray(values).reshape(-1)
    if len(values) != len(rows):
        return values
    out = np.full(n, fill, dtype=bool if isinstance(fill, bool) else float)
    out[rows] = values
    return out
