"""The orthophoto lookup of a turned camera from the rays kept once (no new z-buffer) agrees with the one computed
from the turned camera's own z-buffer; a turn beyond the margin is refused, not guessed."""

import numpy as np
import pytest

from monoplot_plugin.core import lookup
from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.synthetic import synthetic_terrain
from monoplot_plugin.core.xyz import compute_xyz


@pytest.fixture(scope="module")
def scene():
    dem = synthetic_terrain((150, 150), cell=50.0, seed=2)
    x, y = dem.cell_to_map(75, 149)
    cam = Camera((x, y, float(dem.elevation.max()) + 200.0), heading=0.0, pitch=-12.0, roll=0.0, fov=60.0,
                 image_size=(320, 200), k1=-0.05)
    return dem, cam, lookup.turnable_lookup(cam, dem, lambda c: compute_xyz(c, dem), max_degrees=3.0)


@pytest.mark.parametrize("turn", [(0.0, 0.0, 0.0), (1.0, 0.5, 0.3), (-2.5, 1.0, -1.0)])
def test_turned_lookup_agrees_with_the_turned_cameras_own(scene, turn):
    dem, cam, turnable = scene
    turned = cam.with_parameters(heading=cam.heading + turn[0], pitch=cam.pitch + turn[1], roll=cam.roll + turn[2])
    fast = turnable.turned(turned)
    direct = lookup.ortho_lookup(turned, dem, compute_xyz(turned, dem))
    a = dict(zip(fast.cells.tolist(), fast.pixels.tolist()))
    b = dict(zip(direct.cells.tolist(), direct.pixels.tolist()))
    common = set(a) & set(b)
    # a few % differ at this coarse size: cells on occlusion edges, which the two z-buffers sample at other pixels
    assert len(common) >= 0.95 * max(len(a), len(b))
    assert all(a[k] == b[k] for k in common)  # and a cell seen by both takes the same pixel
    photo = np.random.default_rng(0).integers(0, 255, (200, 320, 3), dtype=np.uint8)
    assert fast.apply(photo).shape == (150, 150, 4)


def test_a_turn_beyond_the_margin_is_refused(scene):
    _, cam, turnable = scene
    assert turnable.turned(cam.with_parameters(heading=cam.heading + 6.0)) is None


def test_the_lookup_in_chunks_is_the_lookup_in_one_go(scene):
    """Chunks only let a caller report progress and stop: the cells and pixels are the same, in the same order."""
    dem, cam, _ = scene
    xyz = compute_xyz(cam, dem)
    whole = lookup.ortho_lookup(cam, dem, xyz, chunk_cells=dem.elevation.size)
    done = []
    chunked = lookup.ortho_lookup(cam, dem, xyz, chunk_cells=1000, between_chunks=done.append)
    assert whole.seen > 1000
    assert np.array_equal(whole.cells, chunked.cells) and np.array_equal(whole.pixels, chunked.pixels)
    rows, cols = dem.shape  # whole rows, at most 1000 cells a chunk
    assert len(done) == -(-rows // (1000 // cols)) and done == sorted(done) and done[-1] == 1.0


def test_an_exception_between_chunks_stops_the_lookup(scene):
    dem, cam, _ = scene

    class Stop(Exception):
        pass

    def stop(fraction):
        raise Stop()

    with pytest.raises(Stop):
        lookup.ortho_lookup(cam, dem, compute_xyz(cam, dem), chunk_cells=1000, between_chunks=stop)
