"""Fixtures of the core tests."""

import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain


@pytest.fixture(scope="module")
def valley():
    """(dem, truth camera, rendered photo): a ridge-lined valley seen from its south end, a skyline across the
    picture (480 x 320 px, 60 m cells)."""
    dem = synthetic_terrain((160, 160), cell=60.0, seed=1)
    x0, y0, x1, y1 = dem.bounds()
    x, y = (x0 + x1) / 2, y0 + 0.03 * (y1 - y0)
    truth = Camera((x, y, float(dem.sample(x, y)) + 400.0), -5.0, -3.0, 0.5, 55.0, (480, 320), crs_wkt=dem.crs_wkt)
    return dem, truth, render_photo(truth, dem, seed=1)



@pytest.fixture(scope="module")
def near_slopes():
    """(dem, truth camera, rendered photo): terrain a few hundred metres ahead of a camera up to 150 m above the
    ground, under a skyline (640 x 400 px, 30 m cells), where a few tens of metres of position move the
    silhouettes. The first of a fixed series of positions that sees such a view."""
    import numpy as np

    from monoplot_plugin.core.xyz import compute_xyz_full

    dem = synthetic_terrain((200, 200), cell=30.0, seed=5)
    x0, y0, x1, y1 = dem.bounds()
    rng = np.random.default_rng(5)
    for _ in range(60):
        x, y = x0 + (x1 - x0) * rng.uniform(0.3, 0.7), y0 + (y1 - y0) * rng.uniform(0.05, 0.6)
        truth = Camera((x, y, float(dem.sample(x, y)) + rng.uniform(30.0, 150.0)), float(rng.uniform(-30, 30)), -2.0,
                       0.0, 50.0, (640, 400), crs_wkt=dem.crs_wkt)
        res = compute_xyz_full(truth.scaled(0.1), dem, visibility=False)
        if res.hit.mean() > 0.35 and (~res.hit[0]).mean() > 0.7 and np.median(res.distance[res.hit]) < 700.0:
            return dem, truth, render_photo(truth, dem, seed=5)
    raise AssertionError("no near view found on the generated terrain")
