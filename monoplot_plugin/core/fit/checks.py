"""Refusals: the inputs that cannot determine a camera, with the message that says what to add."""

from __future__ import annotations

import numpy as np

from ..camera import PARAMETER_NAMES
from .verdict import degenerate_points

__all__ = ["check_inputs"]


def check_inputs(ctx, pairs) -> str:
    """Empty string when the problem can be solved, else the message that says what is missing."""
    unknown = set(ctx.requested_free) - set(PARAMETER_NAMES)
    if unknown:
        return f"Unknown camera parameters {sorted(unknown)}; use names among {', '.join(PARAMETER_NAMES)}."
    n_free = len(ctx.free)
    if n_free == 0:
        return "No parameter is free: choose at least one parameter to fit."
    if not (np.isfinite(ctx.q).all() and np.isfinite(ctx.world).all()):
        return "Some points have non-finite coordinates (NaN): remove them, or give DEM points a height."
    names = ", ".join(ctx.free)
    if ctx.ground is not None:
        g = ctx.ground(np.array([ctx.origin[0]]), np.array([ctx.origin[1]]))
        if not np.isfinite(np.asarray(g, dtype=np.float64)).all():
            return ("The camera-on-the-ground constraint needs the terrain height under the initial camera, but "
                    "the DEM has none there (void or outside): move the initial camera onto the DEM.")
    if pairs is not None:
        pairs = np.asarray(pairs)
        if pairs.size and (pairs.ndim != 2 or pairs.shape[1] != 2):
            return "pairs must be a (K, 2) array of (photo point index, DEM point index)."
        pairs = pairs.reshape(-1, 2).astype(np.int64)
        if len(pairs) and (pairs[:, 0].min() < 0 or pairs[:, 0].max() >= len(ctx.q)
                           or pairs[:, 1].min() < 0 or pairs[:, 1].max() >= len(ctx.world)):
            return "A pair refers to a point that does not exist (index out of range)."
        k = len(np.unique(pairs, axis=0))
        needed = n_free // 2 + 1  # 2 equations per pair must exceed the unknowns
        if k < needed:
            # "pairs", not "linked pairs": Processing's GCP tables have no links (a trial read the dock's word)
            return (f"{k} pair{'s' if k != 1 else ''} give{'s' if k == 1 else ''} {2 * k} equations for {n_free} "
                    f"free parameters ({names}): add at least {needed - k} more pair{'s' if needed - k > 1 else ''}"
                    f" (at least {needed} in all), or fix parameters (e.g. a known field of view, or the camera "
                    f"on the ground).")
        pairs = np.unique(pairs, axis=0)
        return degenerate_points(ctx.q[pairs[:, 0]], ctx.world[pairs[:, 1]], needed)
    needed = n_free // 2 + 1
    short = []
    if len(ctx.q) < needed:
        short.append(f"{needed - len(ctx.q)} more photo point{'s' if needed - len(ctx.q) > 1 else ''}")
    if len(ctx.world) < needed:
        short.append(f"{needed - len(ctx.world)} more DEM point{'s' if needed - len(ctx.world) > 1 else ''}")
    if short:
        return (f"{len(ctx.q)} photo points and {len(ctx.world)} DEM points cannot determine {n_free} free "
                f"parameters ({names}): add {' and '.join(short)} (at least {needed} of each, and many more for "
                f"a reliable unpaired fit), link pairs, or fix parameters.")
    uv, depth = ctx.initial.project_with_depth(ctx.world)
    if not (depth > 0).any():
        return ("Every DEM point is behind the initial camera: check its heading and position (the fit needs a "
                "rough camera that looks towards the points).")
    if not ctx.initial.in_image(uv, margin=max(ctx.initial.image_size)).any():
        return (f"None of the {len(ctx.world)} DEM points falls in or near the initial camera's view: check its "
                f"heading, pitch and field of view (the fit needs a rough camera that sees the points).")
    return ""
