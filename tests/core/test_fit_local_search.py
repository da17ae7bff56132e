"""The second consensus search around a candidate camera (core/fit/local_search.py), on generated points where
wrong points outnumber the right ones nine to one on the photo side (no mocks: the fit's own steps)."""

import math

import numpy as np
import pytest

from monoplot_plugin.core import Camera
from monoplot_plugin.core.fit import FitOptions
from monoplot_plugin.core.fit.consensus import inlier_radius, local_optimise
from monoplot_plugin.core.fit.context import FitContext
from monoplot_plugin.core.fit.local_search import local_hypotheses

torch = pytest.importorskip("torch")
torch.set_num_threads(1)

TRUTH = Camera((2_600_000.0, 1_200_000.0, 1500.0), heading=30.0, pitch=-6.0, roll=1.5, fov=58.0,
               image_size=(1024, 768))


def ahead(rng, n):
    """(n, 3) terrain points 1.5-8 km in front of TRUTH."""
    h = math.radians(TRUTH.heading)
    fwd, right = np.array([math.sin(h), math.cos(h), 0.0]), np.array([math.cos(h), -math.sin(h), 0.0])
    dist = rng.uniform(1500, 8000, n)
    pts = np.asarray(TRUTH.position) + dist[:, None] * fwd + (rng.uniform(-0.5, 0.5, n) * dist)[:, None] * right
    pts[:, 2] = rng.uniform(300, 1400, n)
    return pts


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_candidate_twenty_pixels_off_among_ninety_percent_wrong_points_is_corrected(seed):
    rng = np.random.default_rng(seed)
    world = ahead(rng, 25)
    uv = TRUTH.project(world)
    keep = TRUTH.in_image(uv, margin=-5)
    world, uv = world[keep], uv[keep]
    wrong_photo = TRUTH.project(ahead(rng, 9 * len(world)))  # real terrain features, not partners of any DEM point
    wrong_photo = wrong_photo[TRUTH.in_image(wrong_photo)]
    photo = rng.permutation(np.vstack([uv + rng.normal(0, 0.5, uv.shape), wrong_photo]))
    dem = rng.permutation(np.vstack([world, ahead(rng, 3 * len(world))]))
    candidate = TRUTH.with_parameters(heading=TRUTH.heading + 1.0, fov=TRUTH.fov * 1.03)  # about 20 px off
    ctx = FitContext(photo, dem, candidate, None, None, 1.7, FitOptions())
    space = ctx.space(candidate)
    radius = inlier_radius(ctx.diag, 1024 * 768, len(photo), len(dem))

    def error_px(u):
        return float(np.sqrt(np.mean(np.sum((space.camera(u).project(world) - uv) ** 2, axis=1))))

    u0 = space.zero()
    assert error_px(u0) > 15.0
    # The local optimisation alone pairs mostly wrong points and stays where it starts ...
    assert error_px(local_optimise(ctx, space, u0, 3.0 * radius, radius)) > 10.0
    # ... two-point hypotheses drawn a few radii around it find the camera.
    found = local_hypotheses(ctx, space, u0, radius)
    assert found and min(error_px(u) for u in found) < 3.0
