"""Photo <-> map geometry and orthorectification."""

import numpy as np
import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.dem import Dem
from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain
from monoplot_plugin.core.lookup import orthorectify
from monoplot_plugin.core.transforms import (densify, ground_error_m, map_to_photo, photo_line_to_map,
                                             photo_points_to_map, photo_polygon_to_map)
from monoplot_plugin.core.xyz import compute_xyz, compute_xyz_full, segment_first_hit


@pytest.fixture(scope="module")
def scene():
    dem = synthetic_terrain((60, 60), cell=50.0, seed=11, relief=800.0)
    x, y = dem.cell_to_map(30, 59)
    cam = Camera((x, y, float(dem.sample(x, y + 40.0)) + 300.0), heading=0.0, pitch=-15.0, roll=2.0, fov=60.0,
                 image_size=(120, 90), k1=-0.02)
    return cam, dem


def test_pixel_ray_terrain_pixel_round_trip(scene):
    cam, dem = scene
    rng = np.random.default_rng(0)
    uv = rng.uniform([0, 0], [cam.width, cam.height], size=(400, 2))
    xyz, ok = photo_points_to_map(uv, cam, dem)
    assert ok.sum() > 100 and (~ok).sum() > 5
    assert np.abs(cam.project(xyz[ok]) - uv[ok]).max() < 1e-6
    # the points lie on the mesh surface
    assert np.allclose(dem.sample(xyz[ok, 0], xyz[ok, 1], method="mesh"), xyz[ok, 2], atol=1e-6)
    # and agree with the z-buffer at pixel centres
    res = compute_xyz_full(cam, dem)
    centres = cam.pixel_centres()[::7, ::7].reshape(-1, 2)
    p, hit = photo_points_to_map(centres, cam, dem)
    zb = res.xyz[::7, ::7].reshape(-1, 3)
    same = hit & np.isfinite(zb[:, 0])
    assert same.mean() > 0.3
    assert np.median(np.linalg.norm(p[same] - zb[same], axis=1)) < 1e-6


def test_line_follows_terrain_and_splits_at_sky(scene):
    cam, dem = scene
    res = compute_xyz_full(cam, dem)
    col = 60
    hits = res.hit[:, col]
    top = int(np.argmax(hits))  # first terrain row in this column (sky above)
    assert 3 < top < cam.height - 10
    # a vertical line from sky down into terrain, and back up to the sky in a second segment
    line = np.array([[col + 0.5, 0.5], [col + 0.5, cam.height - 1.0], [col + 20.5, 0.5]])
    out = photo_line_to_map(line, cam, dem, step_px=1.0)
    assert out.report.dropped > 0 and not out.report.complete
    assert len(out.parts) >= 1
    for part in out.parts:
        assert part.shape[1] == 3 and len(part) >= 2
        assert np.allclose(dem.sample(part[:, 0], part[:, 1], method="mesh"), part[:, 2], atol=1e-6)
        uv = cam.project(part)
        assert cam.in_image(uv).all()
    assert any("dropped" in m for m in out.report.messages)
    # a line entirely on terrain stays one piece and is densified (about one sample per pixel)
    low = np.array([[20.5, cam.height - 5.5], [100.5, cam.height - 5.5]])
    whole = photo_line_to_map(low, cam, dem)
    assert whole.report.complete and len(whole.parts) == 1 and len(whole.parts[0]) == 81


def test_polygon_on_terrain_and_across_sky(scene):
    cam, dem = scene
    ring = np.array([[30.0, 80.0], [90.0, 80.0], [90.0, 88.0], [30.0, 88.0]])
    ok = photo_polygon_to_map([ring], cam, dem)
    assert ok.closed and len(ok.parts) == 1 and ok.report.complete
    assert np.isfinite(ok.parts[0]).all()
    high = np.array([[30.0, 1.0], [90.0, 1.0], [90.0, 88.0], [30.0, 88.0]])
    cut = photo_polygon_to_map(high, cam, dem)
    assert not cut.closed and cut.report.dropped > 0
    assert all(len(p) >= 2 for p in cut.parts)
    assert any("open outline" in m for m in cut.report.messages)


def test_map_to_photo_flags_occlusion():
    z = np.zeros((60, 40))
    z[30, :] = 60.0  # wall
    dem = Dem.from_array(z, (0.0, 10.0, 0.0, 600.0, 0.0, -10.0))
    cam = Camera((200.0, -100.0, 20.0), heading=0.0, pitch=-3.0, roll=0.0, fov=80.0, image_size=(200, 150))
    # a north-south line on the ground crossing behind the wall
    line = np.array([[205.0, 100.0], [205.0, 500.0]])
    (part,) = map_to_photo([line], cam, dem, densify_m=10.0)
    y = part.xyz[:, 1]
    assert np.allclose(part.xyz[y < 280, 2], 0.0)
    assert part.visible[y < 280].all()
    assert part.occluded[y > 300].all() and not part.visible[y > 300].any()
    assert len(part.visible_runs()) == 1 and len(part.hidden_runs()) >= 1
    # visible projected vertices round-trip to the same map points
    back, hit = photo_points_to_map(part.uv[part.visible], cam, dem)
    assert np.allclose(back[:, :2], part.xyz[part.visible, :2], atol=1e-4)


def seen_exactly(cam, dem) -> np.ndarray:
    """(rows, cols) bool: the cell centres in the picture that an exact line of sight from the camera reaches."""
    xs, ys = dem.cell_centres()
    pts = np.stack([xs.ravel(), ys.ravel(), dem.elevation.ravel()], axis=1)
    origin = np.asarray(cam.position)
    s = segment_first_hit(dem, origin, pts)
    length = np.linalg.norm(pts - origin, axis=1)
    uv, depth = cam.project_with_depth(pts)
    with np.errstate(invalid="ignore"):
        exact = ~(np.isfinite(s) & (s * length < length - (1.0 + 1e-4 * length))) & cam.in_image(uv) & (depth > 0)
    return exact.reshape(dem.shape)


def test_orthorectify_fills_only_visible_cells(scene):
    cam, dem = scene
    photo = render_photo(cam, dem, noise=False)
    ortho = orthorectify(photo, cam, dem, compute_xyz(cam, dem))
    assert ortho.shape == dem.shape + (4,) and ortho.dtype == np.uint8
    mask = ortho[..., 3] == 255
    assert 0.05 < mask.mean() < 0.95
    assert (ortho[~mask] == 0).all()
    # a visible cell's value is the photo's colour at its projection
    r, c = np.argwhere(mask)[len(np.argwhere(mask)) // 2]
    x, y = dem.cell_to_map(c + 0.5, r + 0.5)
    u, v = cam.project([[x, y, dem.elevation[r, c]]])[0]
    assert np.array_equal(ortho[r, c, :3], photo[int(v), int(u)])
    # seen cells agree with an exact line of sight to each cell centre
    assert (seen_exactly(cam, dem) == mask).mean() > 0.95  # the depth test is decided at pixel resolution


def test_densify_keeps_vertices():
    line = np.array([[0.0, 0.0, 5.0], [10.0, 0.0, 15.0]])
    d = densify(line, 2.5)
    assert len(d) == 5 and np.allclose(d[:, 2], [5, 7.5, 10, 12.5, 15])
    ring = densify(np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]]), 2.0, closed=True)
    assert len(ring) == 2 + 2 + 3  # last edge (length 5.66) gets 3 steps, closing vertex not repeated


def test_map_ring_closing_edge_is_densified_and_points_are_not():
    dem = Dem.from_array(np.zeros((40, 40)), (0.0, 10.0, 0.0, 400.0, 0.0, -10.0))
    cam = Camera((200.0, -100.0, 150.0), heading=0.0, pitch=-25.0, roll=0.0, fov=60.0, image_size=(80, 60))
    ring = np.array([[100.0, 100.0], [300.0, 100.0], [300.0, 300.0], [100.0, 300.0]])
    (part,) = map_to_photo([ring], cam, dem, densify_m=50.0, closed=True)
    assert len(part.xyz) == 16  # 4 edges of 200 m in 50 m steps, ring left unclosed
    assert np.allclose(part.xyz[-1], [100.0, 150.0, 0.0])
    assert part.visible.all()
    from monoplot_plugin.core.transforms import map_points_to_photo

    pts = map_points_to_photo(ring, cam, dem)
    assert len(pts.uv) == 4 and pts.visible.all()
    assert np.allclose(cam.project(pts.xyz), pts.uv)


def test_ground_error_matches_the_spread_of_noisy_pixels(scene):
    """The footprint estimate against a Monte-Carlo: pixels moved by 2-D Gaussian noise of the stated RMS, their rays
    intersected with the terrain; the horizontal RMS of the ground displacement agrees (on a rough terrain, where
    the footprint varies from pixel to pixel)."""
    cam, dem = scene
    rng = np.random.default_rng(3)
    uv = rng.uniform([10, 10], [cam.width - 10, cam.height - 10], size=(150, 2))
    base, ok = photo_points_to_map(uv, cam, dem)
    uv = uv[ok]
    rmse_px = 0.5
    predicted = ground_error_m(uv, cam, dem, rmse_px)
    noise = rng.normal(0.0, rmse_px / np.sqrt(2.0), size=(400, len(uv), 2))  # per axis: RMS / sqrt(2)
    moved, hit = photo_points_to_map((uv[None] + noise).reshape(-1, 2), cam, dem)
    d2 = np.sum((moved[:, :2] - np.repeat(base[ok][None, :, :2], 400, axis=0).reshape(-1, 2)) ** 2, axis=1).reshape(400, -1)
    hit = hit.reshape(400, -1)
    smooth = hit.all(axis=0)  # leave out pixels whose noise reaches the sky
    trimmed = np.sort(d2, axis=0)[:396]  # the 1 % largest left out: a sample jumping behind a ridge
    measured = np.sqrt(trimmed.mean(axis=0))[smooth]
    ratio = predicted[smooth] / measured
    assert smooth.sum() > 30
    assert 0.85 < np.median(ratio) < 1.2
    # twice the pixel error, about twice the ground error where the terrain is smooth at that scale
    doubled = ground_error_m(uv, cam, dem, 2 * rmse_px)[smooth] / predicted[smooth]
    assert 1.8 < np.median(doubled) < 2.2


def test_orthorectify_keeps_terrain_seen_at_a_grazing_angle():
    """A low camera over a rippled plain, the top of the photo half a degree under the horizon: one pixel row
    spans many DEM rows far away. The plain depth test left stripes of seen cells out (a trial's flood
    orthophoto); every cell an exact line of sight sees is kept."""
    rows, cols, cell = 300, 120, 5.0
    ground = np.ones((rows, 1)) * 0.3 * np.sin(np.arange(cols) / 7.0)[None, :]
    dem = Dem.from_array(ground, (0.0, cell, 0.0, rows * cell, 0.0, -cell))
    x0, y0 = dem.cell_to_map(cols / 2, rows - 1)
    cam = Camera((x0, y0, 6.0), heading=0.0, pitch=-6.2, roll=0.0, fov=20.0, image_size=(160, 90))
    photo = render_photo(cam, dem, noise=False)
    seen = orthorectify(photo, cam, dem, compute_xyz(cam, dem))[..., 3] == 255
    exact = seen_exactly(cam, dem)
    assert exact.sum() > 2000
    assert (seen & exact).sum() > 0.99 * exact.sum()
    assert (seen & ~exact).sum() < 0.02 * exact.sum()
