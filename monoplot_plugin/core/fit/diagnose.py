"""Why an unpaired fit missed: was the true camera's basin never searched, or do the points prefer another camera?

:func:`basin_score` scores a given camera as the unpaired fit judges its candidates (consensus score within the
inlier radius, less the prior's penalty, :mod:`.consensus`), optionally after the fit's own local steps from it
(re-paired robust least squares with a shrinking gate, then convergence on the mutual-nearest pairs). Started from
a known reference camera (the paired fit on surveyed GCPs), it gives the best camera of the truth's basin *as the fit
sees the points*: if that scores above the fit's camera, the search missed it; if not, the points themselves
prefer a wrong camera and only more evidence can help (pairs, check points, appearance).

>>> import numpy as np
>>> from monoplot_plugin.core.camera import Camera
>>> cam = Camera((0.0, 0.0, 100.0), heading=0.0, pitch=-5.0, roll=0.0, fov=60.0, image_size=(1000, 750))
>>> rng = np.random.default_rng(0)
>>> world = np.column_stack([rng.uniform(-800, 800, 60), rng.uniform(1500, 4000, 60), rng.uniform(0, 300, 60)])
>>> uv = cam.project(world)
>>> b = basin_score(uv, world, cam.with_parameters(heading=1.0), cam, radius_px=10.0)
>>> b["n_inliers"], round(b["score"], 1), b["penalty"] > 0
(60, 60.0, True)
"""

from __future__ import annotations

from typing import Iterable, Optional

from ..camera import Camera
from .consensus import consensus_score, local_optimise, prior_penalty
from .context import FitContext
from .options import FitOptions
from .pairing import converge_on_pairs

__all__ = ["basin_score"]


def basin_score(image_points, world_points, initial: Camera, camera: Camera, radius_px: float,
                free: Optional[Iterable[str]] = None, options: Optional[FitOptions] = None,
                optimise: bool = False, ground=None, eye_height: float = 1.7) -> dict:
    """Score ``camera`` (or, with ``optimise``, the fit's local optimum started from it) as the unpaired fit does.

    Args:
        image_points: (N, 2) photo points (pixels); world_points: (M, 3) DEM points (map CRS, metres).
        initial: the fit's initial camera (the prior: its σ give the penalty, its free parameters the space).
        camera: the camera to score (e.g. a paired fit on surveyed GCPs).
        radius_px: inlier radius in pixels (the fit's, ``FitResult.evidence["radius_px"]``).
        free, options, ground, eye_height: as given to :func:`~monoplot_plugin.core.fit.fit_camera`.
        optimise: first apply the fit's local steps from ``camera`` (:func:`~.consensus.local_optimise` with a gate
            from 3 radii down to one, then :func:`~.pairing.converge_on_pairs`).
    Returns:
        dict: ``camera`` (the scored camera), ``score`` (soft inlier count), ``penalty`` (prior's, in the same
        units), ``net`` (score - penalty: what the fit maximises), ``n_inliers``.
    """
    opts = options if options is not None else FitOptions()
    ctx = FitContext(image_points, world_points, initial, free, ground, eye_height, opts)
    space = ctx.space(initial)
    u = space.from_camera(ctx.restrict_to_free(camera))
    if optimise:
        u = local_optimise(ctx, space, u, 3.0 * radius_px, radius_px)
        u_conv, pairs = converge_on_pairs(ctx, space, u, radius_px)
        if pairs is not None:
            u = u_conv
    uv, usable = ctx.project_usable(space, u)
    score, pairs = consensus_score(ctx.q, uv, usable, radius_px)
    scored = space.camera(u)
    penalty = prior_penalty(ctx, scored, opts.prior_sigmas(initial.fov, ctx.typical_range))
    return {"camera": scored, "score": float(score), "penalty": float(penalty), "net": float(score - penalty),
            "n_inliers": int(len(pairs))}
