"""Synthetic terrain and photo: deterministic, plausible relief, a photo-like picture."""

import numpy as np
import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain


def test_terrain_is_deterministic_and_alpine():
    a = synthetic_terrain((120, 100), cell=50.0, seed=4)
    b = synthetic_terrain((120, 100), cell=50.0, seed=4)
    c = synthetic_terrain((120, 100), cell=50.0, seed=5)
    assert np.array_equal(a.elevation, b.elevation) and not np.array_equal(a.elevation, c.elevation)
    assert a.shape == (120, 100) and a.geotransform[1] == 50.0 and a.geotransform[5] == -50.0
    assert "2056" in a.crs_wkt
    z = a.elevation
    assert np.isfinite(z).all() and z.max() - z.min() > 1500.0
    gx, gy = a.gradient()
    slope = np.degrees(np.arctan(np.hypot(gx, gy)))
    assert 10.0 < np.median(slope) < 45.0  # steep but not a wall everywhere
    # rough at every scale: a smoothed copy differs noticeably (ridges, not a smooth bump)
    from scipy import ndimage

    assert np.abs(z - ndimage.uniform_filter(z, 5)).mean() > 5.0
    o = synthetic_terrain((10, 10), cell=25.0, origin=(600000.0, 5100000.0), crs_wkt="EPSG:32632")
    assert o.geotransform[0] == 600000.0 and o.geotransform[3] == 5100000.0


@pytest.mark.parametrize("shape, cell, wavelength", [((37, 53), 30.0, 6000.0), ((37, 53), 30.0, 375.0),
                                                     ((64, 48), 7.3, 750.0), ((40, 40), 20.0, 50.0)])
def test_noise_is_the_cubic_zoom_of_its_coarse_grid_cropped(shape, cell, wavelength):
    """Only the DEM's window is interpolated (zooming the whole coarse grid took 23 s for a 300 x 300 DEM of 2 m
    cells): the values are still those of the whole zoom, cropped, so every seed keeps its terrain."""
    import math

    from scipy import ndimage

    from monoplot_plugin.core.synthetic import _value_noise

    factor = wavelength / cell
    grid = np.random.default_rng(9).uniform(-1.0, 1.0, (math.ceil(shape[0] / factor) + 4,
                                                         math.ceil(shape[1] / factor) + 4))
    whole = ndimage.zoom(grid, factor, order=3, mode="mirror", prefilter=False, grid_mode=False)
    off = int(factor)
    expected = whole[off:off + shape[0], off:off + shape[1]]
    assert np.array_equal(_value_noise(shape, cell, wavelength, np.random.default_rng(9)), expected)


def test_render_photo_looks_like_a_photo():
    dem = synthetic_terrain((150, 150), cell=50.0, seed=2)
    x, y = dem.cell_to_map(75, 149)
    cam = Camera((x, y, float(dem.elevation.max()) + 200.0), heading=0.0, pitch=-12.0, roll=0.0, fov=60.0,
                 image_size=(160, 100))
    img = render_photo(cam, dem, seed=1)
    assert img.shape == (100, 160, 3) and img.dtype == np.uint8
    again = render_photo(cam, dem, seed=1)
    assert np.array_equal(img, again)
    # sky at the top is blue-ish and bright; terrain below is darker and textured
    top = img[:5].reshape(-1, 3).astype(float)
    assert (top[:, 2] > top[:, 0]).mean() > 0.9
    bottom = img[-30:].astype(float)
    assert bottom.mean() < top.mean()
    assert bottom.std() > 8.0
    clean = render_photo(cam, dem, seed=1, noise=False, haze=False)
    assert not np.array_equal(clean, img)
