"""render_dem: shading, depth, silhouettes and the RGBA overlay."""

import numpy as np

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.dem import Dem
from monoplot_plugin.core.render import render_dem
from monoplot_plugin.core.xyz import compute_xyz_full


def test_flat_ground_shade_and_depth():
    dem = Dem.from_array(np.full((80, 80), 500.0), (0.0, 10.0, 0.0, 800.0, 0.0, -10.0))
    cam = Camera((400.0, -20.0, 600.0), heading=0.0, pitch=-20.0, roll=0.0, fov=60.0, image_size=(64, 48))
    view = render_dem(cam, dem, azimuth=0.0, altitude=30.0)
    hit = np.isfinite(view.depth)
    assert hit.any() and (~hit).any()
    assert np.array_equal(hit, np.isfinite(view.shade))
    assert np.allclose(view.shade[hit], 0.5)  # flat ground: sin(30 degrees)
    # depth is the distance from the camera to the ground point seen
    _, dirs = cam.pixel_to_world_ray(cam.pixel_centres().reshape(-1, 2))
    t = (500.0 - 600.0) / dirs[:, 2]
    expected = t.reshape(48, 64)
    assert np.allclose(view.depth[hit], expected[hit], rtol=1e-5)
    # depth grows towards the horizon (up the picture)
    column = view.depth[:, 32]
    ok = np.isfinite(column)
    assert (np.diff(column[ok]) < 0).all()


def test_edges_and_rgba_mark_the_ridge():
    z = np.zeros((60, 40))
    z[25:28, :] = 80.0  # a ridge hiding the ground behind it
    dem = Dem.from_array(z, (0.0, 10.0, 0.0, 600.0, 0.0, -10.0))
    cam = Camera((200.0, -50.0, 40.0), heading=0.0, pitch=-4.0, roll=0.0, fov=70.0, image_size=(90, 60))
    res = compute_xyz_full(cam, dem)
    view = render_dem(cam, dem, result=res)
    assert view.result is res
    edges = view.edges()
    assert edges.any()
    # the ridge crest (the near side of the depth jump) is outlined across the picture
    crest = edges & (res.xyz[..., 2] > 40.0)
    ridge_columns = (res.xyz[..., 2] > 40.0).any(axis=0)
    assert ridge_columns.sum() > 30 and crest.any(axis=0)[ridge_columns].all()
    # and nothing in the middle of the flat ground in front of it is an edge
    inner = (res.xyz[..., 0] > 50.0) & (res.xyz[..., 0] < 350.0)
    front = np.isfinite(view.depth) & inner & (res.xyz[..., 1] < 300.0) & (res.xyz[..., 1] > 100.0)
    assert not (edges & front).any()
    rgba = view.rgba(edge_colour=(255, 0, 0))
    assert rgba.shape == (60, 90, 4) and rgba.dtype == np.uint8
    assert (rgba[~np.isfinite(view.depth), 3] == 0).all()
    assert (rgba[edges] == [255, 0, 0, 255]).all()
