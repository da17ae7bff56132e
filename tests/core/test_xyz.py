"""Per-pixel XYZ: exact against a brute-force float64 reference, analytic planes, boxes, round trips."""

import math
import os

import numpy as np
import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.dem import Dem
from monoplot_plugin.core.synthetic import synthetic_terrain
from monoplot_plugin.core.xyz import compute_xyz, compute_xyz_full, segment_first_hit


def mesh_triangles(dem: Dem, origin=np.zeros(3)):
    """(first vertex, edge 1, edge 2), each (T, 3), of the mesh's triangles without a void corner, relative to
    ``origin`` (the two triangles of each quad, split as core's mesh)."""
    verts = dem.vertices() - origin
    rows, cols = dem.shape
    r, c = np.meshgrid(np.arange(rows - 1), np.arange(cols - 1), indexing="ij")
    r, c = r.ravel(), c.ravel()
    a = np.concatenate([verts[r, c], verts[r, c]])
    b = np.concatenate([verts[r, c + 1], verts[r + 1, c + 1]])
    q = np.concatenate([verts[r + 1, c + 1], verts[r + 1, c]])
    keep = np.isfinite(a[:, 2]) & np.isfinite(b[:, 2]) & np.isfinite(q[:, 2])
    a, b, q = a[keep], b[keep], q[keep]
    return a, b - a, q - a


def brute_force_xyz(cam: Camera, dem: Dem) -> np.ndarray:
    """Reference: every pixel ray against every mesh triangle (Moller-Trumbore, float64, camera-centred)."""
    a, e1, e2 = mesh_triangles(dem, np.asarray(cam.position))
    _, dirs = cam.pixel_to_world_ray(cam.pixel_centres().reshape(-1, 2))
    best = np.full(len(dirs), np.inf)
    for start in range(0, len(dirs), 256):
        d = dirs[start:start + 256, None, :]
        p = np.cross(d, e2[None])
        det = np.einsum("ntk,tk->nt", p, e1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            tvec = -a[None]
            u = np.einsum("ntk,ntk->nt", np.broadcast_to(tvec, p.shape), p) * inv
            qv = np.cross(np.broadcast_to(tvec, p.shape), e1[None])
            v = np.einsum("ntk,ntk->nt", np.broadcast_to(d, p.shape), qv) * inv
            t = np.einsum("tk,ntk->nt", e2, qv) * inv
        ok = (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0) & np.isfinite(t)
        best[start:start + 256] = np.where(ok, t, np.inf).min(axis=1)
    xyz = np.where(np.isfinite(best)[:, None], dirs * best[:, None] + np.asarray(cam.position), np.nan)
    return xyz.reshape(cam.height, cam.width, 3)


def silhouette_mask(ref: np.ndarray) -> np.ndarray:
    """Pixels next to a hit/sky change or a range jump (> 3 %) among their 8 neighbours."""
    d = np.linalg.norm(ref - np.nanmean(ref, axis=(0, 1)), axis=-1)
    hit = np.isfinite(d)
    pad_d = np.pad(np.where(hit, d, np.nan), 1, mode="edge")
    pad_h = np.pad(hit, 1, mode="edge")
    H, W = hit.shape
    out = np.zeros_like(hit)
    rng = np.linalg.norm(np.nan_to_num(ref), axis=-1)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            nh = pad_h[1 + di:1 + di + H, 1 + dj:1 + dj + W]
            nd = pad_d[1 + di:1 + di + H, 1 + dj:1 + dj + W]
            out |= nh != hit
            with np.errstate(invalid="ignore"):
                out |= hit & nh & (np.abs(nd - d) > 0.03 * np.maximum(rng, 1.0))
    return out


@pytest.fixture(scope="module")
def small_scene():
    dem = synthetic_terrain((48, 56), cell=60.0, seed=3)
    x, y = dem.cell_to_map(28, 47)
    cam = Camera(position=(x, y, dem.sample(x, y + 30.0) + 400.0), heading=5.0, pitch=-12.0, roll=3.0,
                 fov=65.0, image_size=(72, 54), k1=-0.03, k2=0.005)
    return cam, dem


def test_exact_against_brute_force_reference(small_scene):
    cam, dem = small_scene
    ours = compute_xyz(cam, dem)
    ref = brute_force_xyz(cam, dem)
    ref_hit = np.isfinite(ref[..., 0])
    our_hit = np.isfinite(ours[..., 0])
    assert ref_hit.mean() > 0.25 and (~ref_hit).sum() > 10  # terrain and sky both in view
    edge = silhouette_mask(ref)
    assert np.array_equal(our_hit[~edge], ref_hit[~edge])  # sky is NaN exactly where the reference sees none
    both = ref_hit & our_hit & ~edge
    err = np.linalg.norm(ours[both] - ref[both], axis=-1)
    assert np.median(err) < 0.05
    assert np.mean(err < 0.5) >= 0.999


@pytest.mark.parametrize("k1", [0.0, -0.06])
def test_the_ground_at_the_feet_of_a_camera_at_eye_height_is_seen(k1):
    """A phone photo (k1 -0.06) from 1.7 m above a 10 m DEM: its bottom third had no ground in the XYZ raster (a
    desktop trial: 36 % ground where the truth has 73 %), the triangles at the camera's feet having corners beyond
    the distortion's valid radius. Every pixel below the horizon sees the ground, where the exact ray test says."""
    from monoplot_plugin.core.transforms import photo_points_to_map

    dem = synthetic_terrain((120, 120), cell=10.0, seed=7)
    x, y = dem.cell_to_map(60, 60)
    x, y = x + 3.7, y - 2.2  # not on a vertex
    cam = Camera((x, y, float(dem.sample(x, y)) + 1.7), heading=50.0, pitch=-8.0, roll=1.5, fov=53.0,
                 image_size=(90, 120), k1=k1)
    res = compute_xyz_full(cam, dem)
    jj, ii = np.meshgrid(np.arange(90), np.arange(60, 120))  # the lower half: 8 to 41 degrees down
    uv = np.column_stack([jj.ravel() + 0.5, ii.ravel() + 0.5])
    exact, ok = photo_points_to_map(uv, cam, dem)
    ours, hit = res.xyz[ii.ravel(), jj.ravel()], res.hit[ii.ravel(), jj.ravel()]
    assert ok.mean() > 0.8 and hit.mean() > 0.8, (ok.mean(), hit.mean())
    assert np.mean(hit == ok) > 0.99, np.mean(hit == ok)  # ground where the exact ray test finds it
    assert res.hit[-1].all()  # the bottom row: the ground a few metres ahead
    both = hit & ok
    far = np.linalg.norm(exact[both] - np.asarray(cam.position), axis=1)
    assert np.median(np.linalg.norm(ours[both] - exact[both], axis=1) / far) < 0.002


def test_rotated_geotransform_gives_same_terrain():
    """The same heights on a grid rotated by 30 degrees, camera rotated with it: identical picture."""
    z = synthetic_terrain((30, 34), cell=50.0, seed=5).elevation
    north_up = Dem.from_array(z, (1000.0, 50.0, 0.0, 5000.0, 0.0, -50.0))
    ang = math.radians(30.0)
    ca, sa = math.cos(ang), math.sin(ang)
    # rotate the whole grid by +30 degrees clockwise about (1000, 5000)
    rot = Dem.from_array(z, (1000.0, 50.0 * ca, -50.0 * sa, 5000.0, -50.0 * sa, -50.0 * ca))
    x, y = north_up.cell_to_map(17, 18)
    cam = Camera((x, y, float(z.max()) + 300.0), heading=0.0, pitch=-70.0, roll=0.0, fov=60.0, image_size=(40, 30))
    dx, dy = x - 1000.0, y - 5000.0
    xr, yr = 1000.0 + dx * ca + dy * sa, 5000.0 - dx * sa + dy * ca
    cam_r = cam.with_parameters(x=xr, y=yr, heading=30.0)
    a = compute_xyz_full(cam, north_up)
    b = compute_xyz_full(cam_r, rot)
    assert np.array_equal(a.hit, b.hit) and a.hit.mean() > 0.2
    assert np.allclose(a.distance[a.hit], b.distance[b.hit], rtol=1e-5)
    assert np.allclose(a.xyz[a.hit][:, 2], b.xyz[b.hit][:, 2], atol=1e-3)


def test_plane_analytic_and_round_trip():
    """A tilted plane z = 0.3 x - 0.1 y: every hit lies on it, and re-projects to its own pixel centre."""
    cols, rows, cell = 60, 50, 20.0
    gt = (500000.0, cell, 0.0, 5200000.0, 0.0, -cell)
    base = Dem.from_array(np.zeros((rows, cols)), gt)
    X, Y = base.cell_centres()
    z = 0.3 * (X - 500000.0) - 0.1 * (Y - 5200000.0) + 1000.0
    dem = Dem.from_array(z, gt, "EPSG:32632")
    cam = Camera((500600.0, 5199200.0, 1600.0), heading=20.0, pitch=-25.0, roll=-4.0, fov=50.0,
                 image_size=(80, 60), k1=0.02)
    res = compute_xyz_full(cam, dem)
    hit = res.hit
    assert hit.mean() > 0.5
    pts = res.xyz[hit]
    plane = 0.3 * (pts[:, 0] - 500000.0) - 0.1 * (pts[:, 1] - 5200000.0) + 1000.0
    assert np.abs(pts[:, 2] - plane).max() < 1e-6
    uv = cam.project(pts)
    centres = cam.pixel_centres()[hit]
    assert np.abs(uv - centres).max() < 1e-6
    assert np.allclose(np.linalg.norm(pts - np.asarray(cam.position), axis=1), res.distance[hit], rtol=1e-6)


def test_three_boxes_on_flat_ground():
    """The paper's first experiment: three boxes of known size on flat ground, known camera; every pixel that
    sees a box face gets XYZ on that face."""
    cell = 1.0
    rows, cols = 120, 120
    z = np.zeros((rows, cols))
    boxes = [(20, 30, 40, 45, 10.0), (60, 70, 50, 62, 6.0), (85, 100, 30, 40, 15.0)]  # r0, r1, c0, c1, height
    for r0, r1, c0, c1, h in boxes:
        z[r0:r1, c0:c1] = h
    dem = Dem.from_array(z, (0.0, cell, 0.0, float(rows), 0.0, -cell))
    cam = Camera((60.0, -30.0, 90.0), heading=0.0, pitch=-40.0, roll=0.0, fov=70.0, image_size=(320, 240))
    res = compute_xyz_full(cam, dem)
    tops = 0
    for r0, r1, c0, c1, h in boxes:
        # the top face spans cell centres r0 .. r1-1, c0 .. c1-1 (a flat quad of the mesh at height h)
        xa, ya = dem.cell_to_map(c0 + 0.5, r1 - 0.5)
        xb, yb = dem.cell_to_map(c1 - 0.5, r0 + 0.5)
        on_top = (np.abs(res.xyz[..., 2] - h) < 1e-9)
        pts = res.xyz[on_top]
        assert len(pts) > 20
        inside = (pts[:, 0] >= xa - 1e-9) & (pts[:, 0] <= xb + 1e-9) & (pts[:, 1] >= ya - 1e-9) & (pts[:, 1] <= yb + 1e-9)
        assert inside.all()
        tops += len(pts)
        # every pixel whose ray meets the top face first (analytic) must report that point
        _, dirs = cam.pixel_to_world_ray(cam.pixel_centres().reshape(-1, 2))
        t = (h - cam.position[2]) / dirs[:, 2]
        p = np.asarray(cam.position) + dirs * t[:, None]
        in_face = (t > 0) & (p[:, 0] > xa + 0.01) & (p[:, 0] < xb - 0.01) & (p[:, 1] > ya + 0.01) & (p[:, 1] < yb - 0.01)
        got = res.xyz.reshape(-1, 3)[in_face]
        assert np.allclose(got, p[in_face], atol=1e-6)
    ground = np.abs(res.xyz[..., 2]) < 1e-9
    assert ground.sum() > 0.3 * ground.size and tops > 100


def test_voids_are_holes_and_sky_is_nan():
    z = np.full((40, 40), 100.0)
    z[10:20, 10:30] = np.nan
    dem = Dem.from_array(z, (0.0, 10.0, 0.0, 400.0, 0.0, -10.0))
    cam = Camera((200.0, 200.0, 1000.0), heading=0.0, pitch=-89.0, roll=0.0, fov=60.0, image_size=(64, 64))
    xyz = compute_xyz(cam, dem)
    hit = np.isfinite(xyz[..., 2])
    pts = xyz[hit]
    assert np.allclose(pts[:, 2], 100.0)
    col, row = dem.map_to_cell(pts[:, 0], pts[:, 1])
    # no hit strictly inside the void (triangles touching a void vertex are holes)
    assert not ((row > 9.5) & (row < 19.5) & (col > 9.5) & (col < 29.5)).any()
    assert (~hit).sum() > 50


def test_visibility_mask_and_line_of_sight():
    """A wall hides the ground behind it: cells behind it are not visible; segment_first_hit agrees."""
    z = np.zeros((60, 40))
    z[30, :] = 50.0  # an east-west wall of height 50 m in row 30
    dem = Dem.from_array(z, (0.0, 10.0, 0.0, 600.0, 0.0, -10.0))
    cam = Camera((200.0, -100.0, 20.0), heading=0.0, pitch=-5.0, roll=0.0, fov=80.0, image_size=(320, 240))
    res = compute_xyz_full(cam, dem, rel_tol=0.0, abs_tol=0.5)
    vis = res.visible
    # north of the wall (behind it, seen from the south): hidden; the few rows that project within a pixel of
    # the wall's foot are decided at pixel resolution (documented), so they are left out here
    assert vis[:25, :].sum() == 0
    assert vis[40:55, 15:25].all()  # in front of the wall, near the image centre
    assert vis[30, 15:25].all()  # the wall's crest
    X, Y = dem.cell_centres()
    targets = np.stack([X[[22, 50], [20, 20]], Y[[22, 50], [20, 20]], z[[22, 50], [20, 20]]], 1)
    s = segment_first_hit(dem, np.asarray(cam.position), targets)
    assert s[0] < 0.9 and s[1] > 0.999


def test_max_range_cuts_far_terrain():
    dem = Dem.from_array(np.zeros((100, 100)), (0.0, 10.0, 0.0, 1000.0, 0.0, -10.0))
    cam = Camera((500.0, 0.0, 50.0), heading=0.0, pitch=-5.0, roll=0.0, fov=60.0, image_size=(40, 30))
    res = compute_xyz_full(cam, dem, max_range=400.0)
    d = res.distance[res.hit]
    assert d.max() <= 400.0 and res.hit.sum() > 20
    full = compute_xyz_full(cam, dem)
    assert full.distance[full.hit].max() > 600.0


def test_camera_inside_grid_close_to_ground_clips_near_plane():
    """Terrain crossing the camera plane (camera 1 m above ground, looking down) is clipped, not lost."""
    dem = Dem.from_array(np.zeros((20, 20)), (0.0, 10.0, 0.0, 200.0, 0.0, -10.0))
    cam = Camera((100.0, 100.0, 1.0), heading=0.0, pitch=-60.0, roll=0.0, fov=150.0, image_size=(48, 32))
    xyz = compute_xyz(cam, dem)
    assert np.isfinite(xyz[..., 2]).mean() > 0.4
    assert np.allclose(xyz[np.isfinite(xyz[..., 2])][:, 2], 0.0, atol=1e-9)
    # bottom rows look steeply down: ground right next to the camera
    assert np.isfinite(xyz[-1, 24, 2])


def test_numba_cache_folder_is_per_import_name(monkeypatch, tmp_path):
    from monoplot_plugin.core import xyz

    folder = os.path.basename(xyz._numba_cache_dir())
    assert folder.startswith("monoplot_plugin.core.xyz-") and len(folder) == len("monoplot_plugin.core.xyz-") + 12
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert xyz._numba_cache_dir() == str(tmp_path / folder)


_THREADS_SCRIPT = """
import sys, numpy as np
from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.synthetic import synthetic_terrain
from monoplot_plugin.core.xyz import compute_xyz_full
dem = synthetic_terrain((120, 120), cell=25.0, seed=3)
x, y = dem.cell_to_map(12, 108)
cam = Camera((x, y, float(np.nanmax(dem.elevation)) + 150.0), heading=45.0, pitch=-8.0, roll=0.0, fov=70.0,
             image_size=(320, 200))
res = compute_xyz_full(cam, dem)
np.save(sys.argv[1], res.xyz)
"""


@pytest.mark.parametrize("threads", [1, 3, 5])
def test_same_xyz_whatever_the_thread_count(tmp_path, threads):
    """The depth buffers of up to three threads live inside the output array, more get arrays of their own: every
    layout gives the same terrain hits as two threads (this machine's default count is irrelevant)."""
    import os
    import subprocess
    import sys

    repo = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    outs = {}
    for n in (2, threads):
        out = tmp_path / f"xyz_{n}.npy"
        env = dict(os.environ, NUMBA_NUM_THREADS=str(n), PYTHONPATH=repo)
        subprocess.run([sys.executable, "-c", _THREADS_SCRIPT, str(out)], check=True, env=env, cwd=repo)
        outs[n] = np.load(out)
    a, b = outs[2], outs[threads]
    hit_a, hit_b = np.isfinite(a[..., 0]), np.isfinite(b[..., 0])
    assert hit_a.mean() > 0.3
    # ties between triangles meeting at a shared edge may go either way: the hit point is the same
    assert (hit_a != hit_b).mean() < 1e-4
    both = hit_a & hit_b
    assert np.percentile(np.linalg.norm(a[both] - b[both], axis=1), 99.9) < 1e-3


def _hill_and_ridge():
    """A round hill with its top at (1000, 1000) and, 800 m north of it, a 300 m high east-west ridge."""
    rows = cols = 200
    x = (np.arange(cols) + 0.5) * 10.0
    y = 2000.0 - (np.arange(rows) + 0.5) * 10.0
    X, Y = np.meshgrid(x, y)
    z = 100.0 * np.exp(-((X - 1000) ** 2 + (Y - 1000) ** 2) / (2 * 300.0 ** 2))
    z += 300.0 * np.exp(-((Y - 1800) ** 2) / (2 * 60.0 ** 2))
    return Dem.from_array(z, (0.0, 10.0, 0.0, 2000.0, 0.0, -10.0))


@pytest.mark.parametrize("offset_m", [-3.0, 1.5])
def test_camera_a_few_metres_under_the_dem_sees_the_terrain_beyond(offset_m, caplog):
    """A fit on a coarse DEM can end a few metres below the surface at the camera (a summit the DEM rounds off).
    The rays must leave the ground and see the ridge, as from a camera on the ground; not the hill's underside
    (drawn both ways, it filled the whole picture a few metres from the camera)."""
    dem = _hill_and_ridge()
    ground = float(dem.sample(1000.0, 1000.0, method="mesh"))
    cam = Camera((1000.0, 1000.0, ground + offset_m), heading=0.0, pitch=-2.0, roll=0.0, fov=60.0,
                 image_size=(160, 100))
    on_ground = cam.with_parameters(z=ground + 1.5)
    res = compute_xyz_full(cam, dem)
    ref = compute_xyz_full(on_ground, dem)
    # rays leave the ground; only rays that head down from under the surface (near the bottom edge) never do
    assert (res.hit & ~ref.hit).mean() < 0.03  # (parallax at the skyline)
    assert res.hit.mean() > 0.5 * ref.hit.mean()
    far = ref.hit & (ref.distance > 500.0)  # the ridge, seen over the valley
    assert far.mean() > 0.2
    assert np.mean(res.distance[far] > 500.0) > 0.99  # not the hill's underside, a few metres away
    # the same terrain as from the camera on the ground, but for a few metres of parallax
    both = res.hit & ref.hit
    assert np.median(np.abs(res.distance[both] - ref.distance[both])) < 5.0
    assert ("below the DEM surface" in caplog.text) == (offset_m < 0)
    # exact lines of sight agree: a point 1 m above the ridge's south face is in the open from the buried camera
    face = np.array([[1000.0, 1700.0, float(dem.sample(1000.0, 1700.0, method="mesh")) + 1.0]])
    assert np.isnan(segment_first_hit(dem, np.asarray(cam.position)[None], face)[0])


def test_a_search_rendering_cameras_it_only_tries_does_not_warn_for_each(caplog):
    """The automatic registration renders dozens of trial cameras; one under the DEM is a debug line, not a
    warning (the dock's log filled with them), while a real render still warns."""
    import logging

    from monoplot_plugin.core.xyz.zbuffer import trial_cameras

    dem = _hill_and_ridge()
    ground = float(dem.sample(1000.0, 1000.0, method="mesh"))
    cam = Camera((1000.0, 1000.0, ground - 3.0), heading=0.0, pitch=-2.0, roll=0.0, fov=60.0, image_size=(80, 50))
    caplog.set_level(logging.DEBUG, logger="monoplot")
    with trial_cameras():
        compute_xyz_full(cam, dem)
    tried = [r for r in caplog.records if "below the DEM surface" in r.getMessage()]
    assert tried and all(r.levelno == logging.DEBUG for r in tried)
    caplog.clear()
    compute_xyz_full(cam, dem)
    assert any(r.levelno == logging.WARNING and "below the DEM surface" in r.getMessage() for r in caplog.records)


def brute_force_first_entry(dem: Dem, origins: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Reference for segment_first_hit: every segment against every mesh triangle, the smallest s in (0, 1] where
    it crosses a triangle from its upper side (float64, numpy)."""
    a, e1, e2 = mesh_triangles(dem)
    up = np.cross(e1, e2)
    up[up[:, 2] < 0] *= -1
    out = np.full(len(origins), np.nan)
    for k, (o, t) in enumerate(zip(origins, targets)):
        d = t - o
        p = np.cross(d, e2)
        det = np.einsum("tk,tk->t", p, e1)
        with np.errstate(divide="ignore", invalid="ignore"):
            tvec = o - a
            u = np.einsum("tk,tk->t", tvec, p) / det
            qv = np.cross(tvec, e1)
            v = qv @ d / det
            s = np.einsum("tk,tk->t", e2, qv) / det
        ok = (u >= -1e-12) & (v >= -1e-12) & (u + v <= 1 + 1e-12) & (s > 1e-9) & (s <= 1) & (up @ d < 0)
        if ok.any():
            out[k] = s[ok].min()
    return out


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_segment_first_hit_agrees_with_every_triangle_tried(dtype):
    """The walk passes quads the segment stays above without testing their triangles: it must find the same
    first entries as testing every triangle, grazing segments, rotated grids and holes included."""
    rng = np.random.default_rng(3)
    base = synthetic_terrain((24, 22), cell=25.0, seed=4)
    z = base.elevation.astype(dtype)
    z[8:11, 5:9] = np.nan  # a hole the segments pass through
    g = base.geotransform
    dem = Dem(z, (g[0], g[1] * 0.9, 4.0, g[3], 3.0, g[5]), base.crs_wkt)  # rotated, not square
    centre = np.nanmean(dem.vertices(), axis=(0, 1))
    lo, hi = float(np.nanmin(z)), float(np.nanmax(z))
    n = 300
    origins = centre + np.c_[rng.uniform(-300, 300, (n, 2)), rng.uniform(lo - centre[2], hi - centre[2] + 200, n)]
    targets = centre + np.c_[rng.uniform(-300, 300, (n, 2)), rng.uniform(lo - centre[2] - 200, hi - centre[2], n)]
    # segments ending exactly on the surface, and ones skimming a peak by 1 cm
    top = np.unravel_index(np.nanargmax(z), z.shape)
    peak = dem.vertices()[top]
    skim = np.array([peak + [-300, -200, 150.01], peak + [300, 200, -149.99]])
    # low shots at points of the surface: they graze the slopes in front, where a quad is entered only just
    # (aimed inside a triangle, and on past it: a shot ending exactly on the surface is a tie either way)
    x, y = dem.cell_to_map(rng.uniform(2, 20, 100), rng.uniform(2, 20, 100))
    ground = np.c_[x, y, dem.sample(x, y, method="mesh")]
    ground = ground[np.isfinite(ground[:, 2])]
    shots = ground + np.c_[rng.uniform(-300, 300, (len(ground), 2)), rng.uniform(1, 30, len(ground))]
    # flat shots that just clip a vertex (1 to 30 cm deep): a quad they are entered in is hardly under them
    tips = dem.vertices()[rng.integers(2, 20, 200), rng.integers(2, 20, 200)]
    tips = tips[np.isfinite(tips[:, 2])]
    tips[:, 2] -= rng.uniform(0.01, 0.3, len(tips))
    flat = tips + np.c_[rng.uniform(-300, 300, (len(tips), 2)), rng.uniform(0.5, 3, len(tips))]
    origins = np.vstack([origins, skim[:1], shots, flat])
    targets = np.vstack([targets, skim[1:], shots + 1.2 * (ground - shots), flat + 1.05 * (tips - flat)])
    got = segment_first_hit(dem, origins, targets)
    want = brute_force_first_entry(dem, origins, targets)
    assert np.isfinite(want).sum() > 60 and np.isnan(want).sum() > 60  # both kinds are tried
    np.testing.assert_array_equal(np.isfinite(got), np.isfinite(want))
    np.testing.assert_allclose(got[np.isfinite(got)], want[np.isfinite(want)], atol=1e-9)
