"""Does a lens distortion the fit left out show in its residuals?

A phone's or an old camera's lens bends the picture: straight lines bow, points towards the edges land farther out
(pincushion) or nearer in (barrel) than a pinhole puts them. A fit without ``k1`` absorbs part of it in the field of
view and the position and leaves the rest in the residuals; its RMSE stays well under the verdict's limits, so it
said "ok": on generated photos with k1 = -0.03 to -0.15 (4000 x 3000 px, 40 pairs) the camera was 18-83 m off and
the ground 12-294 px off at the picture's edges, against 1.3 px with ``k1`` fitted.

The test: the fit's own final pairs fitted again with ``k1`` free too. When that removes most of the residuals and
an F test for the one parameter added says it is far beyond noise (:data:`LENS_F_MIN`), the verdict says so
(:func:`lens_text`) and what to do. The camera is not replaced: a person who knows the lens is corrected may have
fixed ``k1`` on purpose, and ``k1`` from a handful of pairs near the centre extrapolates wildly to the corners.

>>> lens_text({"lens_f": 400.0, "lens_rmse_px": 1.4, "rmse_px": 7.2, "lens_k1": -0.031})[:30]
'the residuals grow towards the'
>>> lens_text({"lens_f": 3.0, "lens_rmse_px": 7.0, "rmse_px": 7.2, "lens_k1": -0.001})
''
"""

from __future__ import annotations

import numpy as np

from .lsq import PIXEL_FLOOR, least_squares
from .params import ParameterSpace
from .result import rmse

__all__ = ["LENS_F_MIN", "LENS_GAIN", "MIN_LENS_PAIRS", "unmodelled_lens", "lens_text"]

#: an F statistic for the one parameter added beyond which its gain is not noise (F(1, 30) > 30: p < 1e-5; wrong
#: pairs left among the inliers inflate the residuals of both fits alike)
LENS_F_MIN = 30.0
#: ... and the pairs' RMSE with ``k1`` at most this share of the fit's (a real gain, not a shaved pixel)
LENS_GAIN = 0.7
#: fewer pairs than this say too little of a radial trend
MIN_LENS_PAIRS = 12


def unmodelled_lens(ctx, result) -> dict:
    """Evidence for :func:`~.verdict.judge`: ``lens_rmse_px`` (the fit's inlier pairs fitted again with ``k1``
    free too), ``lens_k1`` (the ``k1`` found) and ``lens_f`` (the F statistic of that one parameter); {} when
    ``k1`` was fitted already, with fewer than :data:`MIN_LENS_PAIRS` pairs, or when the refit fails."""
    if "k1" in result.free:
        return {}
    pairs = np.asarray(result.pairs, dtype=int).reshape(-1, 2)
    kept = np.asarray(result.inliers, dtype=bool).reshape(-1)
    pairs = pairs[kept] if kept.shape == (len(pairs),) else pairs
    if len(pairs) < MIN_LENS_PAIRS:
        return {}
    q, P = ctx.q[pairs[:, 0]], ctx.P[pairs[:, 1]]
    before = rmse(result.camera.project(ctx.world[pairs[:, 1]]) - q)
    space = ParameterSpace(result.camera, tuple(result.free) + ("k1",), ctx.typical_range, origin=ctx.origin,
                           ground=ctx.ground, eye_height=ctx.eye_height)
    m, n = 2 * len(q), space.size
    if m <= n + 2 or not np.isfinite(before):
        return {}
    try:
        u, after = least_squares(ctx, space, space.zero(), q, P)
    except ValueError:
        return {}
    if not np.isfinite(after):
        return {}
    rss_before, rss_after = m * before ** 2, m * after ** 2
    f = (rss_before - rss_after) / max(rss_after / (m - n), PIXEL_FLOOR ** 2)
    return {"lens_rmse_px": float(after), "lens_k1": float(space.camera(u).k1), "lens_f": float(f)}


def lens_text(e: dict) -> str:
    """The verdict's words for evidence ``e`` from :func:`unmodelled_lens` ("" when no distortion shows)."""
    f = float(e.get("lens_f", 0.0))
    after, before = float(e.get("lens_rmse_px", np.nan)), float(e.get("rmse_px", np.nan))
    if not (f > LENS_F_MIN and np.isfinite(after) and np.isfinite(before) and after < LENS_GAIN * before
            and before - after > 1.0):
        return ""
    kind = "barrel" if float(e.get("lens_k1", 0.0)) < 0 else "pincushion"
    return (f"the residuals grow towards the picture's edges as a lens's {kind} distortion makes them: with k1 "
            f"fitted too, the same pairs leave {after:.1f} px instead of {before:.1f} px; free k1 (the dock's fit "
            f"settings: lens distortion k1; fitcamera's Lens distortion: Fit radial distortion k1) and fit again")
