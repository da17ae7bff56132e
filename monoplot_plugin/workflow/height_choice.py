"""Which height a fit holds the camera at when nobody said: the rough camera's, eye height, or free. The fit step
(:mod:`.fit`) tries the others and weighs them here; pairs or points that cannot tell them apart leave the fit
"uncertain", its σ covering both.
"""

from __future__ import annotations

import math
from typing import Tuple

import numpy as np

from ..core.camera import Camera
from ..core.fit import FitResult

__all__ = ["ground_clearance", "weigh_eye_height", "weigh_free_height", "height_explained", "DEFAULT_EYE_HEIGHT_M",
           "UNDERGROUND_TOLERANCE_M", "FREE_HEIGHT_F", "FREE_HEIGHT_MIN_PAIRS", "UNSURE_HEIGHT_M",
           "EYE_HEIGHT_MARGIN", "HEIGHT_RIVAL_M"]

#: a free fit whose camera ends more than this far under the terrain is refitted on the ground (DEM error margin)
UNDERGROUND_TOLERANCE_M = 2.0
#: eye height of a photographer standing on the ground, when nothing else says it
DEFAULT_EYE_HEIGHT_M = 1.7
#: an automatic paired fit held on the ground is also fitted with its height free, and the free height is taken when
#: freeing it explains the pairs this much better: the F statistic of one more unknown, (SSE_held - SSE_free) /
#: (SSE_free / (2 x pairs - 8)), over 20: stricter than the 99.9 % point of F(1, d) for d >= 12 degrees of freedom
#: (10 or more pairs); with fewer pairs the test is laxer (F(1, 6) at 99.9 % is 35.5), which only costs the held
#: unknown back. A desktop trial: a rough camera 29 m under the terrain (the truth 30 m above it) held on the ground
#: gave 36.8 px and 37 m off with 9 exact pairs; its height free, 0.8 px and 0.8 m.
FREE_HEIGHT_F = 20.0
#: fewest pairs for that test (2 x 5 - 8 = 2 degrees of freedom left, one fewer than the free fit's 7 unknowns leave)
FREE_HEIGHT_MIN_PAIRS = 5
#: An unpaired fit held on the ground higher than this (metres) is also fitted at eye height (:func:`weigh_eye_height`).
UNSURE_HEIGHT_M = 3.0
#: Consensus score (about one more matched point) by which one of the two heights must win to be taken.
EYE_HEIGHT_MARGIN = 1.0
#: Two cameras further apart than this (metres) that the points cannot tell apart leave the fit "uncertain".
HEIGHT_RIVAL_M = 5.0


def ground_clearance(camera: Camera, dem) -> float:
    """Height of the camera above the terrain under it (metres; NaN outside the DEM)."""
    return float(camera.position[2]) - float(dem.sample(camera.position[0], camera.position[1]))


def weigh_eye_height(held: FitResult, at_eye: FitResult, height: float) -> Tuple[FitResult, float]:
    """(result, its height above the terrain) of an unpaired fit held ``height`` m above the terrain (the rough
    camera's own clearance) against the same fit at eye height: the one whose points agree clearly better
    (:data:`EYE_HEIGHT_MARGIN` more of the consensus score), else the held one, "uncertain" when the two cameras
    stand more than :data:`HEIGHT_RIVAL_M` apart (the points cannot tell the height). A trial's phone photo, its
    GPS altitude 15 m high, was held 16.6 m above the valley floor: "ok" at 6.2 px with the camera 34 m off."""
    own, eye_score = (float((r.evidence or {}).get("score", -math.inf)) for r in (held, at_eye))
    apart = float(np.linalg.norm(np.subtract(held.camera.position, at_eye.camera.position)))
    if at_eye.status in ("ok", "uncertain") and eye_score > own + EYE_HEIGHT_MARGIN:
        at_eye.message = (f"{at_eye.message} Held at eye height ({DEFAULT_EYE_HEIGHT_M:.1f} m above the terrain): "
                          f"the points agree with it better than at the rough camera's {height:.0f} m (a GPS "
                          f"altitude is often tens of metres off); set Above ground if it stood higher.")
        return at_eye, DEFAULT_EYE_HEIGHT_M
    if apart > HEIGHT_RIVAL_M and own <= eye_score + EYE_HEIGHT_MARGIN:
        held.message = (f"{held.message} Its height is not known: held {height:.0f} m above the terrain (the rough "
                        f"camera's), the points agree about as well with a camera at eye height {apart:.0f} m away. "
                        f"Set Above ground to where the photographer stood (a GPS altitude is often tens of metres "
                        f"off), or pair a few points.")
        if held.status == "ok":
            held.status = "uncertain"
    return held, height


def weigh_free_height(held: FitResult, freed: FitResult, height: float, dem) -> None:
    """A paired fit the automatic rule held ``height`` m above the terrain, whose pairs do not demand the height
    free (:func:`height_explained`), against the same pairs with it free: when the free camera stands more than
    :data:`HEIGHT_RIVAL_M` away, above the terrain, the pairs do not tell the two apart, and the hold is the rule's
    guess, not theirs. Its σ then cover the free camera, and an "ok" is "uncertain", as :func:`weigh_eye_height`
    does for unpaired fits. A trial's print, taken 25 m above a valley floor, typed position and no height: held at
    2 m, 88-106 m off with X, Y ± 5.5 / 16 m (4-7 σ); free, 21 m off.

    >>> from types import SimpleNamespace as R
    >>> from monoplot_plugin.core.synthetic import synthetic_terrain
    >>> dem = synthetic_terrain((40, 40), cell=50.0, seed=1)
    >>> x, y = dem.cell_to_map(20, 20)
    >>> at = Camera((x, y, float(dem.sample(x, y)) + 2.0), 0.0, -5.0, 0.0, 50.0, (400, 300))
    >>> held = R(camera=at, std={"x": 5.0, "y": 16.0, "heading": 0.1}, status="ok", message="Fit.", rmse_px=4.9)
    >>> freed = R(camera=at.with_parameters(y=y - 90.0, z=at.position[2] + 23.0, heading=359.5), status="ok",
    ...           rmse_px=4.2)
    >>> weigh_free_height(held, freed, 2.0, dem)
    >>> held.status, held.std
    ('uncertain', {'x': 5.0, 'y': 90.0, 'heading': 0.5})
    """
    if freed.status not in ("ok", "uncertain") or ground_clearance(freed.camera, dem) < -UNDERGROUND_TOLERANCE_M:
        return
    apart = float(np.linalg.norm(np.subtract(held.camera.position, freed.camera.position)))
    if apart <= HEIGHT_RIVAL_M:
        return
    own, other = held.camera.parameters(), freed.camera.parameters()
    std = dict(held.std or {})
    for name in std:
        if name in own:
            gap = abs(other[name] - own[name])
            if name == "heading":
                gap = min(gap % 360.0, 360.0 - gap % 360.0)
            std[name] = max(float(std[name]), gap)
    held.std = std
    held.message = (f"{held.message} Its height is not known: held {height:.1f} m above the terrain, while with its "
                    f"height free the pairs place the camera {ground_clearance(freed.camera, dem):.0f} m above it "
                    f"and {apart:.0f} m away, at {freed.rmse_px:.1f} px against {held.rmse_px:.1f} px: the pairs "
                    f"cannot tell the two apart, and the σ cover both. If you know the camera height, set it (Camera "
                    f"height in the dock's Fit settings, tab 4; ON_GROUND in Processing: on the ground, or in the "
                    f"air), or add pairs.")
    if held.status == "ok":
        held.status = "uncertain"


def height_explained(held: FitResult, freed: FitResult, n_pairs: int) -> bool:
    """True when the fit with the height free explains ``n_pairs`` pairs significantly better than the one held on
    the ground (:data:`FREE_HEIGHT_F`): one more unknown that removes far more residual than chance would.

    >>> from types import SimpleNamespace as R
    >>> height_explained(R(rmse_px=36.8, status="ok"), R(rmse_px=0.8, status="ok"), 9)
    True
    >>> height_explained(R(rmse_px=8.0, status="ok"), R(rmse_px=7.5, status="ok"), 11)
    False

    A freed fit judged worse than the held one is not taken; one judged "poor" as the held one is, by the same check
    points, is: a desktop trial's single wrong check point (114 px off under the true camera) made its freed camera,
    1.6 m from the truth at 2.3 px on the pairs, "poor", and the camera held at the GPS height, 42 m off at 65 px and
    "poor" too, was kept.

    >>> height_explained(R(rmse_px=65.0, status="poor"), R(rmse_px=2.3, status="poor"), 7)
    True
    >>> height_explained(R(rmse_px=65.0, status="uncertain"), R(rmse_px=2.3, status="poor"), 7)
    False
    """
    rank = {"ok": 2, "uncertain": 1, "poor": 0}
    if rank.get(freed.status, -1) < min(rank.get(held.status, -1), 1) or \
            not (np.isfinite(held.rmse_px) and np.isfinite(freed.rmse_px)):
        return False
    dof = max(2 * n_pairs - 8, 1)
    sse_held, sse_free = held.rmse_px ** 2, max(freed.rmse_px ** 2, 1e-6)
    return (sse_held - sse_free) / (sse_free / dof) > FREE_HEIGHT_F
