"""The miss diagnosis of an unpaired fit (core/fit/diagnose.py): the truth's basin scored as the fit scores its
candidates. Real fits' local steps on generated points (no mocks)."""

import math

import numpy as np
import pytest

from monoplot_plugin.core import Camera
from monoplot_plugin.core.fit.diagnose import basin_score

torch = pytest.importorskip("torch")
torch.set_num_threads(1)

TRUTH = Camera((2_600_000.0, 1_200_000.0, 1500.0), heading=30.0, pitch=-6.0, roll=1.5, fov=58.0,
               image_size=(1024, 768))


def scene(n_true=40, n_wrong=60, seed=0):
    """(photo (N, 2), DEM (M, 3), true world points (K, 3)): true points 1.5-8 km ahead with 0.5 px noise, plus
    wrong points on both sides (photo points anywhere, DEM points on terrain ahead)."""
    rng = np.random.default_rng(seed)
    h = math.radians(TRUTH.heading)
    fwd, right = np.array([math.sin(h), math.cos(h), 0.0]), np.array([math.cos(h), -math.sin(h), 0.0])

    def ahead(n):
        dist = rng.uniform(1500, 8000, n)
        pts = np.asarray(TRUTH.position) + dist[:, None] * fwd + (rng.uniform(-0.5, 0.5, n) * dist)[:, None] * right
        pts[:, 2] = rng.uniform(300, 1400, n)
        return pts

    world = ahead(n_true)
    uv = TRUTH.project(world)
    keep = TRUTH.in_image(uv, margin=-5)
    world, uv = world[keep], uv[keep]
    photo = rng.permutation(np.vstack([uv + rng.normal(0, 0.5, uv.shape),
                                       rng.uniform([0, 0], TRUTH.image_size, (n_wrong, 2))]))
    dem = rng.permutation(np.vstack([world, ahead(n_wrong)]))
    return photo, dem, world


def test_the_truths_basin_is_found_from_nearby_and_outscores_a_wrong_camera():
    photo, dem, world = scene()
    prior = TRUTH.with_parameters(x=TRUTH.position[0] + 60.0, heading=TRUTH.heading + 2.0, fov=55.0)
    near = TRUTH.with_parameters(heading=TRUTH.heading + 0.3, pitch=TRUTH.pitch - 0.2)
    basin = basin_score(photo, dem, prior, near, radius_px=10.0, optimise=True)
    off = np.sqrt(np.mean(np.sum((basin["camera"].project(world) - TRUTH.project(world)) ** 2, axis=1)))
    assert off < 1.0
    assert basin["n_inliers"] >= len(world)
    wrong = basin_score(photo, dem, prior, TRUTH.with_parameters(heading=TRUTH.heading + 6.0), radius_px=10.0)
    assert wrong["net"] < basin["net"] - 0.5 * len(world)
    # Scoring alone leaves the camera as given; the penalty grows with the distance from the prior.
    as_given = basin_score(photo, dem, prior, near, radius_px=10.0)
    assert as_given["camera"].heading == pytest.approx(near.heading)
    assert wrong["penalty"] > as_given["penalty"]
