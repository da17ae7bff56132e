"""A few pairs and many points without a partner (:mod:`monoplot_plugin.workflow.mixed`): a trial paired 4 summits,
accepted hundreds of suggestions, and the paired fit left them all out, its camera 28 m off."""

import math

import numpy as np
import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.fit import FitOptions
from monoplot_plugin.core.synthetic import synthetic_terrain
from monoplot_plugin.core.xyz import segment_first_hit
from monoplot_plugin.workflow.fit import fit
from monoplot_plugin.workflow.mixed import fit_accepted

OPTIONS = FitOptions(position_sigma_m=60.0, angle_sigma_deg=3.0, fov_sigma_deg=3.0)


@pytest.fixture(scope="module")
def valley():
    """(dem, true camera 250 m over the terrain, (N, 2) noisy pixels, (N, 3) the terrain they see, rough camera)."""
    dem = synthetic_terrain((300, 300), cell=20.0, seed=7)
    x0, y0, x1, y1 = dem.bounds()
    x, y = 0.5 * (x0 + x1), y0 + 0.15 * (y1 - y0)
    truth = Camera((x, y, float(dem.sample(x, y)) + 250.0), 10.0, -12.0, 0.5, 55.0, (1200, 800),
                   crs_wkt=dem.crs_wkt)
    rng = np.random.default_rng(7)
    uv = rng.uniform([30, 30], [1170, 770], (400, 2))
    origin, dirs = truth.pixel_to_world_ray(uv)
    starts = np.broadcast_to(origin, dirs.shape)
    s = segment_first_hit(dem, starts, starts + dirs * 20000.0)
    xyz = starts + s[:, None] * dirs * 20000.0
    seen = np.isfinite(xyz).all(axis=1)
    xyz = xyz[seen][:120]
    observed = truth.project(xyz) + rng.normal(0.0, 1.0, (len(xyz), 2))
    rough = truth.with_parameters(x=x + 45.0, y=y - 30.0, heading=12.0, fov=57.0)
    return dem, truth, observed, xyz, rough


def _curated(valley, n_pairs, n_alone=60, wrong_pairs=False):
    """Photo points, map points (the unpaired ones shuffled apart), pairs (K, 2) by row, the map rows' truth."""
    dem, truth, uv, xyz, rough = valley
    photo = np.vstack([uv[:n_pairs], uv[n_pairs:n_pairs + n_alone]])
    order = np.random.default_rng(1).permutation(n_alone)
    world = np.vstack([xyz[:n_pairs], xyz[n_pairs:n_pairs + n_alone][order]])
    partner = np.arange(n_pairs)
    if wrong_pairs:  # each photo point linked to another pair's map point
        partner = np.roll(partner, 1)
    return photo, world, np.column_stack([np.arange(n_pairs), partner])


def _error_px(camera, valley):
    _, truth, _, xyz, _ = valley
    return float(np.sqrt(np.mean(np.sum((camera.project(xyz) - truth.project(xyz)) ** 2, axis=1))))


def test_four_pairs_check_a_fit_of_the_points_without_a_partner(valley):
    dem, truth, _, _, rough = valley
    photo, world, pairs = _curated(valley, 4)
    paired = fit(photo, world, rough, dem, pairs=pairs, options=OPTIONS, on_ground=False)
    assert paired.result.status != "ok"  # 4 pairs for 7 unknowns: nothing tests them
    done = fit_accepted(photo, world, rough, dem, pairs=pairs, options=OPTIONS, on_ground=False)
    assert done.result.status == "ok" and done.pairs_checked == 4, done.result.message
    assert done.result.message.startswith("Your 4 pairs alone left the camera uncertain")
    assert _error_px(done.camera, valley) < 2.0 < _error_px(paired.camera, valley)
    assert len(done.result.check_residuals_px) == 4  # the pairs, measured as check points
    # its matches in the rows of the points given: photo row 4 + i is the i-th point without a partner, whose map
    # point went to row 4 + order^-1(i)
    order = np.random.default_rng(1).permutation(60)
    truth_row = {4 + i: 4 + int(np.flatnonzero(order == i)[0]) for i in range(60)}
    matched = np.asarray(done.result.pairs).reshape(-1, 2)
    right = [truth_row.get(int(i)) == int(j) for i, j in matched]
    assert len(matched) >= 30 and np.mean(right) > 0.9 and matched[:, 0].min() >= 4
    assert len(done.result.photo_outliers) == len(photo) and not np.any(done.result.photo_outliers[:4])


def test_pairs_that_disagree_with_the_other_points_keep_the_paired_fit(valley):
    dem, _, _, _, rough = valley
    photo, world, pairs = _curated(valley, 5, wrong_pairs=True)
    done = fit_accepted(photo, world, rough, dem, pairs=pairs, options=OPTIONS, on_ground=False)
    assert done.pairs_checked == 0 and done.result.mode == "paired" and done.result.status != "ok"
    assert "so the paired fit is kept" in done.result.message


def test_enough_good_pairs_are_fitted_as_before(valley):
    dem, _, _, _, rough = valley
    photo, world, pairs = _curated(valley, 12)
    done = fit_accepted(photo, world, rough, dem, pairs=pairs, options=OPTIONS, on_ground=False)
    plain = fit(photo, world, rough, dem, pairs=pairs, options=OPTIONS, on_ground=False)
    assert done.result.status == "ok" and done.pairs_checked == 0 and done.result.mode == "paired"
    assert done.camera == plain.camera and done.result.message == plain.result.message
    assert math.isfinite(done.result.loo_rmse_px)
