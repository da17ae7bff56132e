"""Re-registration of time-lapse frames on generated terrain: known turns recovered, outliers ignored, a frame with
nothing to match refused with a reason."""

import numpy as np
import pytest

from monoplot_plugin.core import drift
from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain
from monoplot_plugin.core.xyz import compute_xyz


@pytest.fixture(scope="module")
def scene():
    dem = synthetic_terrain((150, 150), cell=50.0, seed=2)
    x, y = dem.cell_to_map(75, 149)
    cam = Camera((x, y, float(dem.elevation.max()) + 200.0), heading=0.0, pitch=-12.0, roll=0.0, fov=60.0,
                 image_size=(400, 260))
    photo = render_photo(cam, dem, seed=1)
    reference = drift.Reference(photo, cam, drift.stable_mask(compute_xyz(cam, dem), cam))
    return dem, cam, reference


@pytest.mark.parametrize("turn", [(0.0, 0.0, 0.0), (1.5, 0.0, 0.0), (-0.7, 0.5, 0.2), (0.3, -0.4, -2.0)])
def test_known_turns_in_new_light_are_recovered_within_half_a_pixel(scene, turn):
    dem, cam, reference = scene
    true = cam.with_parameters(heading=cam.heading + turn[0], pitch=cam.pitch + turn[1], roll=cam.roll + turn[2])
    frame = render_photo(true, dem, seed=1, sun_azimuth=100.0, sun_altitude=30.0)  # other light
    frame = np.clip(frame * 0.8 + 10, 0, 255).astype(np.uint8)  # and exposure
    found = drift.register(reference, frame)
    assert found.ok, found.message
    truth = true.rotation @ cam.rotation.T
    assert drift.pixel_shift(cam, found.rotation, truth) <= 0.5
    assert found.degrees == pytest.approx(drift.rotation_angle_deg(truth), abs=0.05)
    assert found.inliers >= drift.MIN_INLIERS
    corrected = drift.corrected_camera(cam, found.rotation)
    probe = np.array([[50.0, 200.0], [350.0, 120.0]])
    world = np.asarray(true.position) + true.pixel_to_world_ray(probe)[1] * 1000.0
    assert np.abs(corrected.project(world) - probe).max() <= 0.75
    assert corrected.position == cam.position and corrected.fov == cam.fov


def test_a_frame_with_nothing_to_match_is_not_registered(scene):
    _, cam, reference = scene
    fog = np.full((cam.height, cam.width, 3), 200, np.uint8)
    found = drift.register(reference, fog)
    assert not found.ok and "key points" in found.message
    assert np.array_equal(found.rotation, np.eye(3))
    wrong = drift.register(reference, fog[:100])
    assert not wrong.ok and "px" in wrong.message


def test_rotation_fit_ignores_wrong_matches():
    cam = Camera((0, 0, 0), heading=0, pitch=0, roll=0, fov=50, image_size=(600, 400))
    rays = cam.pixel_to_camera_ray(np.random.default_rng(0).uniform([0, 0], [600, 400], (200, 2)))
    truth = cam.with_parameters(heading=1.0, pitch=-0.5).rotation @ cam.rotation.T
    moved = rays @ truth.T
    moved[:60] = np.roll(moved[:60], 7, axis=0)  # 30 % of the matches wrong
    rotation, inliers = drift.fit_rotation(rays, moved, threshold=1.0 / cam.focal_px)
    assert not inliers[:60].any() and inliers[60:].all()
    assert drift.pixel_shift(cam, rotation, truth) < 1e-6


def test_stable_mask_leaves_out_sky_foreground_and_border(scene):
    dem, cam, _ = scene
    xyz = compute_xyz(cam, dem)
    mask = drift.stable_mask(xyz, cam, near_m=2000.0, border_px=10)
    distance = np.linalg.norm(xyz - np.asarray(cam.position), axis=-1)
    assert mask.dtype == np.uint8 and set(np.unique(mask)) <= {0, 255}
    assert not mask[~np.isfinite(distance)].any()  # sky
    assert not mask[np.nan_to_num(distance, nan=1e9) < 2000.0].any()  # foreground
    assert not mask[:10].any() and not mask[:, -10:].any()
    assert mask.mean() > 20  # terrain is left
