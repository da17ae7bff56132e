"""Pairs and points without a partner accepted together: when the pairs alone do not fix the camera, the other
points are fitted unpaired and the pairs check that fit.

A person who pairs a few summits and accepts many suggestions without partners expects all of them to count. A
paired fit uses the pairs only: a trial's 4 summits left hundreds of accepted points out, the camera 28 m off. On
generated scenes (``eval``'s synthetic scenes, 4 of their true pairs given as pairs and the rest unpaired), the
paired fit on the 4 pairs was within 1.5 times the optimum in 8 of 33, the unpaired fit of the rest in 31 of 33,
30 of them "ok" with the 4 pairs as its check points. The pairs are kept out of that fit on purpose: as check points
they are independent evidence, which the verdict weighs (:func:`~..core.fit.verdict.judge`).

Only a paired fit that is not "ok" is tried again this way: a person's good pairs fix a camera better than automatic
matches, and an "ok" on them stays as it was (nor costs a second fit).
"""

from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from ..core.fit.params import DEFAULT_FREE
from . import fit as fit_step
from .progress import IsCanceled, Progress

__all__ = ["fit_accepted", "points_without_partner", "EXTRA_PER_FREE"]

#: Points without a partner, on each side, per free parameter, before they are fitted on their own: fewer cannot
#: give an unpaired fit its "ok" (the verdict wants twice as many matched points as unknowns).
EXTRA_PER_FREE = 2


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
    when it is "ok". Its result's indices (``pairs``, ``photo_outliers``, ``nearest_px``) are those of ``uv`` and
    ``xyz``; its check residuals are ``check_uv``'s, then the pairs'. ``FitDone.pairs_checked`` says how many pairs
    checked it. Raises as :func:`~.fit.fit`."""
    kw = dict(free=free, options=options, on_ground=on_ground, eye_height=eye_height, is_canceled=is_canceled)
    pairs = None if pairs is None or len(pairs) == 0 else np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    photo_rows, map_rows = points_without_partner(len(uv), len(xyz), pairs if pairs is not None else [])
    enough = EXTRA_PER_FREE * len(free or DEFAULT_FREE)
    if pairs is None or min(len(photo_rows), len(map_rows)) < enough:
        return fit_step.fit(uv, xyz, start, dem, pairs=pairs, check_uv=check_uv, check_xyz=check_xyz,
                            progress=progress, **kw)
    part = (lambda a, b: None) if progress is None else (
        lambda a, b: lambda f, m="": progress(a + (b - a) * f, m))
    paired = fit_step.fit(uv, xyz, start, dem, pairs=pairs, check_uv=check_uv, check_xyz=check_xyz,
                          progress=part(0.0, 0.4), **kw)
    if paired.result.status == "ok":
        return paired
    n_check = 0 if check_uv is None else len(check_uv)
    checks_uv = np.vstack([np.reshape(check_uv, (-1, 2)) if n_check else np.zeros((0, 2)), uv[pairs[:, 0]]])
    checks_xyz = np.vstack([np.reshape(check_xyz, (-1, 3)) if n_check else np.zeros((0, 3)), xyz[pairs[:, 1]]])
    report = part(0.4, 1.0)
    if report is not None:
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
    if alone.result.status != "ok":
        paired.result.message += (
            f" The {n_photo} photo and {n_map} map points without a partner were also fitted on their own, your "
            f"{n_pairs} pairs as check points: that fit is {alone.result.status} (the pairs {off:.1f} px off it), "
            f"so the paired fit is kept.")
        return paired
    result = alone.result
    matched = np.asarray(result.pairs, dtype=np.int64).reshape(-1, 2)
    result.pairs = np.column_stack([photo_rows[matched[:, 0]], map_rows[matched[:, 1]]]) if len(matched) else matched
    result.photo_outliers = _spread_rows(result.photo_outliers, photo_rows, len(uv), False)
    result.nearest_px = _spread_rows(result.nearest_px, photo_rows, len(uv), np.nan)
    result.message = (f"Your {n_pairs} pairs alone left the camera {paired.result.status}: the {n_photo} photo and "
                      f"{n_map} map points without a partner fixed it, and the pairs checked it ({off:.1f} px off "
                      f"it). {result.message}")
    alone.pairs_checked = n_pairs
    return alone


def _spread_rows(values, rows: np.ndarray, n: int, fill):
    """``values`` given for ``rows`` of ``n``, as an (n,) array (``fill`` elsewhere); as given when they are not one
    per row."""
    values = np.asarray(values).reshape(-1)
    if len(values) != len(rows):
        return values
    out = np.full(n, fill, dtype=bool if isinstance(fill, bool) else float)
    out[rows] = values
    return out
