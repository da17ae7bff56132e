"""A lens distortion the fit leaves out shows in its residuals, and the verdict says so (core.fit.lens)."""

import numpy as np
import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.fit import fit_camera
from monoplot_plugin.core.synthetic import synthetic_terrain
from monoplot_plugin.core.transforms import photo_points_to_map


@pytest.fixture(scope="module")
def terrain():
    return synthetic_terrain((200, 200), cell=30.0, seed=3)


def _scene(dem, k1: float, seed: int = 1):
    """(truth with ``k1``, (40, 2) photo points with 1 px noise, (40, 3) the terrain they see, a rough camera)."""
    rng = np.random.default_rng(seed)
    x0, y0, x1, _ = dem.bounds()
    x, y = (x0 + x1) / 2, y0 + 500
    truth = Camera((x, y, float(dem.sample(x, y)) + 300), 0.0, -8.0, 0.0, 70.0, (4000, 3000), crs_wkt=dem.crs_wkt,
                   k1=k1)
    uv = rng.uniform([0, 0], [4000, 3000], (400, 2))
    ground, seen = photo_points_to_map(uv, truth, dem)
    uv, ground = uv[seen][:40], ground[seen][:40]
    prior = truth.with_parameters(k1=0.0, x=x + 30, heading=2.0, fov=73.5)
    return truth, uv + rng.normal(0, 1.0, uv.shape), ground, prior


@pytest.mark.parametrize("paired", [True, False])
def test_a_barrel_lens_left_out_of_the_fit_is_not_ok_and_the_message_says_free_k1(terrain, paired):
    truth, uv, ground, prior = _scene(terrain, k1=-0.08)
    pairs = np.column_stack([np.arange(len(uv))] * 2) if paired else None
    result = fit_camera(uv, ground, prior, pairs=pairs)
    # the scene is what the test claims: the pinhole camera is well off, its residuals small for the verdict's limits
    assert np.linalg.norm(np.subtract(result.camera.position, truth.position)) > 30
    assert result.rmse_px < 0.01 * np.hypot(4000, 3000)
    assert result.status == "uncertain", result.message
    assert "barrel distortion" in result.message and "free k1" in result.message
    assert result.evidence["lens_k1"] < 0 and result.evidence["lens_rmse_px"] < 0.5 * result.rmse_px
    # freeing k1 as the message says gives the camera and an "ok"
    freed = fit_camera(uv, ground, prior, pairs=pairs, free=("x", "y", "z", "heading", "pitch", "roll", "fov", "k1"))
    assert freed.status == "ok", freed.message
    assert np.linalg.norm(np.subtract(freed.camera.position, truth.position)) < 10
    assert freed.camera.k1 == pytest.approx(-0.08, abs=0.01) and "lens_f" not in freed.evidence


def test_a_pinhole_photo_says_nothing_of_its_lens(terrain):
    _, uv, ground, prior = _scene(terrain, k1=0.0)
    result = fit_camera(uv, ground, prior, pairs=np.column_stack([np.arange(len(uv))] * 2))
    assert result.status == "ok", result.message
    assert "distortion" not in result.message and result.evidence["lens_f"] < 30
