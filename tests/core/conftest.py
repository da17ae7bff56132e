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
