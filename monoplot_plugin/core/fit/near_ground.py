"""Is the camera placed closely enough for all the ground it sees, not only where its points are?

Points a person recognises are mostly far (the skyline, summits). A camera fixed by far points alone can slide
along its view and turn to keep them in place: where they are it is right, and the near ground, which fills the
lower half of a photo taken from eye height, moves by hundreds of pixels. A desktop trial's phone photo was "ok"
at 5.6 px with the camera 10 m off and the ground within 300 m 225 px off.

The check: the terrain the camera sees, one point per pixel of a small z-buffer (:func:`ground_seen`), moved by
the camera's covariance (its σ and their correlations, :func:`~.result.sigma_shifts`). When more than
:data:`NEAR_SHIFT_SHARE` of it may be more than :data:`NEAR_SHIFT` of the picture's diagonal off, the fit is not
"ok" (:func:`~.verdict.judge`, evidence ``ground_loose_share``).

>>> from monoplot_plugin.core.camera import Camera
>>> cam = Camera((0.0, 0.0, 0.0), 0.0, 0.0, 0.0, 60.0, (1000, 700))
>>> ground = np.array([[0.0, 30.0, -1.7], [0.0, 3000.0, 0.0], [0.0, 4000.0, 0.0]])
>>> e = loosely_placed_ground(cam, {"x": 10.0}, ground)   # 10 m across the view: 289 px at 30 m, 3 px at 3 km
>>> round(e["ground_loose_share"], 2), round(e["ground_loose_reach_m"]), round(e["ground_loose_limit_px"])
(0.33, 30, 37)
"""

from __future__ import annotations

from typing import Callable, Dict, Optional

import numpy as np

from ..camera import Camera
from .result import sigma_shifts

__all__ = ["NEAR_SHIFT", "NEAR_SHIFT_SHARE", "ground_seen", "loosely_placed_ground", "loose_ground_text",
           "FIT_CONSEQUENCE", "HELD_CONSEQUENCE"]

#: a point of the ground seen is loosely placed when the camera's σ may move it by more than this share of the
#: picture's diagonal (3 %: the share beyond which the verdict calls residuals poor)
NEAR_SHIFT = 0.03
#: ... and the camera is not "ok" when more than this share of the ground seen is (2 %: a sliver at the picture's
#: foot is tolerated; a desktop trial's near ground was 30-40 % of its picture)
NEAR_SHIFT_SHARE = 0.02


def ground_seen(camera: Camera, dem, width: float = 128.0) -> np.ndarray:
    """(N, 3) the terrain ``camera`` sees, one point per pixel of a ``width`` px wide z-buffer: the whole picture,
    near slopes as much as the far ridges."""
    from ..xyz import compute_xyz_full

    res = compute_xyz_full(camera.scaled(min(1.0, width / camera.width)), dem, visibility=False)
    return res.xyz[res.hit]


def loosely_placed_ground(camera: Camera, std: Dict[str, float], ground: np.ndarray,
                          correlation: Optional[Dict[str, Dict[str, float]]] = None,
                          height_of: Optional[Callable] = None) -> dict:
    """Evidence for :func:`~.verdict.judge`: ``ground_loose_share``, the share of ``ground`` ((N, 3), e.g.
    :func:`ground_seen`) that the camera's σ (``std``, with ``correlation`` when known) may move by more than
    :data:`NEAR_SHIFT` of the diagonal; ``ground_loose_reach_m``, the distance of the farthest such point;
    ``ground_loose_limit_px``, that shift in pixels. Empty when nothing can be said (no ground, no σ, a σ
    undetermined). A point that a move by σ puts behind the camera counts as loose.
    ``height_of``: the terrain ``(x, y) -> z`` of a camera held on the ground, whose height follows x and y."""
    if ground is None or not len(ground) or not std:
        return {}
    shifts = sigma_shifts(camera, std, ground, correlation, height_of)
    if not np.isfinite(shifts).any():
        return {}
    limit = NEAR_SHIFT * float(np.hypot(*camera.image_size))
    # a point that a move by σ puts behind the camera (no projection) is off by more than any limit: a camera
    # slid 48 m along its view, "ok" with 1 % of its ground counted loose, had most of it behind
    moved = ~(shifts <= limit)
    reach = float(np.max(np.linalg.norm(ground[moved] - np.asarray(camera.position), axis=1))) if moved.any() \
        else 0.0
    return {"ground_loose_share": float(moved.mean()), "ground_loose_reach_m": reach, "ground_loose_limit_px": limit}


#: what a fit's verdict says follows from loose ground, and what to do
FIT_CONSEQUENCE = ("the points place the camera too loosely for the near ground; add points on the near ground, or "
                   "fix the position if you know it")
#: the same with the position held: fixing it is no advice then (a quarry trial, position and height held, was told
#: to fix the position)
HELD_CONSEQUENCE = ("the points place the camera too loosely for the near ground, its position held as it is; add "
                    "points on the near ground, or check the position and height held in the fit settings")


def loose_ground_text(e: dict, consequence: str = FIT_CONSEQUENCE) -> str:
    """The verdict's words for evidence ``e`` from :func:`loosely_placed_ground` ("" when the ground is placed
    closely enough), ending with ``consequence`` (the automatic registration says its own).

    >>> print(loose_ground_text({"ground_loose_share": 0.3, "ground_loose_reach_m": 240.0,
    ...                          "ground_loose_limit_px": 150.0}))
    with the camera's σ, 30 % of the ground seen (the nearest, within 240 m) may be more than 150 px off: the points \
place the camera too loosely for the near ground; add points on the near ground, or fix the position if you know it
    """
    share = float(e.get("ground_loose_share", 0.0))
    if not share > NEAR_SHIFT_SHARE:
        return ""
    return (f"with the camera's σ, {100 * share:.0f} % of the ground seen (the nearest, within "
            f"{float(e.get('ground_loose_reach_m', 0.0)):.0f} m) may be more than "
            f"{float(e.get('ground_loose_limit_px', 0.0)):.0f} px off: {consequence}")
