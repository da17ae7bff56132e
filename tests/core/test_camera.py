"""Camera model: conventions, round trips, numpy/torch/OpenCV agreement, JSON and KML."""

import math

import numpy as np
import pytest

from monoplot_plugin.core.camera import (Camera, angles_from_rotation, project_points, rotation_matrix)


def random_camera(rng, distortion=True):
    """A plausible camera: aspect ratio 0.6-1.8, principal point near the centre, mild distortion."""
    width = int(rng.integers(300, 4000))
    height = int(width / rng.uniform(0.6, 1.8))
    principal = None
    if rng.random() < 0.5:
        principal = tuple(np.array([width, height]) * rng.uniform(0.45, 0.55, 2))
    return Camera(position=tuple(rng.uniform([-5e5, -5e5, 0], [5e5, 5e6, 4000])),
                  heading=rng.uniform(-180, 180), pitch=rng.uniform(-60, 40), roll=rng.uniform(-20, 20),
                  fov=rng.uniform(20, 90), image_size=(width, height), principal_point=principal,
                  k1=rng.uniform(-0.1, 0.1) if distortion else 0.0, k2=rng.uniform(-0.01, 0.01) if distortion else 0.0)


def test_axes_follow_documented_conventions():
    cam = Camera(position=(1000, 2000, 500), heading=90, pitch=0, roll=0, fov=90, image_size=(400, 300))
    east, north, up = np.eye(3) * 100
    centre, right, top = cam.project([cam.position + east * 10, cam.position + east * 10 - north,
                                      cam.position + east * 10 + up])
    assert np.allclose(centre, [200, 150])
    assert right[0] > 200 and math.isclose(right[1], 150)  # south is on the right when looking east
    assert top[1] < 150  # up is towards row 0
    looking_down = cam.with_parameters(pitch=-30)
    assert np.allclose(looking_down.forward, [math.cos(math.radians(30)), 0, -0.5])


def test_positive_roll_turns_camera_clockwise():
    cam = Camera(position=(0, 0, 0), heading=0, pitch=0, roll=10, fov=90, image_size=(400, 400))
    # A point to the right of the axis on the horizon appears above the centre row: the camera's right side went down.
    u, v = cam.project([[100.0, 1000.0, 0.0]])[0]
    assert u > 200 and v < 200


def test_points_behind_camera_are_nan():
    cam = Camera(position=(0, 0, 0), heading=0, pitch=0, roll=0, fov=60, image_size=(100, 100))
    uv = cam.project([[0, -10, 0], [0, 10, 0]])
    assert np.isnan(uv[0]).all() and np.isfinite(uv[1]).all()


@pytest.mark.parametrize("seed", range(20))
def test_pixel_ray_pixel_round_trip(seed):
    rng = np.random.default_rng(seed)
    cam = random_camera(rng)
    uv = rng.uniform([0, 0], cam.image_size, size=(50, 2))
    origin, directions = cam.pixel_to_world_ray(uv)
    points = origin + directions * rng.uniform(10, 20000, size=(50, 1))
    assert np.abs(cam.project(points) - uv).max() < 1e-6


@pytest.mark.parametrize("seed", range(5))
def test_angles_round_trip(seed):
    rng = np.random.default_rng(seed)
    h, p, r = rng.uniform(-179, 179), rng.uniform(-85, 85), rng.uniform(-170, 170)
    assert np.allclose(angles_from_rotation(rotation_matrix(h, p, r)), (h, p, r))
    R = rotation_matrix(h, p, r)
    assert np.allclose(R @ R.T, np.eye(3)) and math.isclose(np.linalg.det(R), 1.0)


def test_torch_projection_equals_numpy_and_has_gradients():
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(3)
    cam = random_camera(rng)
    pts = np.asarray(cam.position) + rng.normal(size=(30, 3)) * 300 + cam.forward * 2000
    expected = cam.project(pts)
    angles = torch.tensor([cam.heading, cam.pitch, cam.roll], dtype=torch.float64, requires_grad=True)
    R = rotation_matrix(angles[0], angles[1], angles[2])
    uv, depth = project_points(torch.tensor(pts - cam.position), torch.zeros(3, dtype=torch.float64), R,
                               cam.focal_px, cam.cx, cam.cy, cam.k1, cam.k2)
    assert (depth > 0).all()
    assert np.allclose(uv.detach().numpy(), expected, atol=1e-8)
    uv.sum().backward()
    assert torch.isfinite(angles.grad).all() and angles.grad.abs().sum() > 0


def test_rotation_of_scalars_and_of_tensors_equals_the_array_rotation():
    """The fit's fast paths (three floats; three 0-d tensors) give the matrix of the general one (arrays of
    angles), and the tensors' gradient is that of the array path's."""
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(5)
    h, p, r = rng.uniform(-400, 400, (3, 50))
    many = rotation_matrix(h, p, r)  # (3, 3, 50)
    for k in range(50):
        # numpy's vectorised sin/cos (SIMD on some CPUs) may differ from math's by an ulp
        assert np.allclose(rotation_matrix(h[k], p[k], r[k]), many[..., k], rtol=0, atol=1e-15)
        t = torch.tensor([h[k], p[k], r[k]], dtype=torch.float64, requires_grad=True)
        R = rotation_matrix(t[0], t[1], t[2])
        assert np.allclose(R.detach().numpy(), many[..., k], rtol=0, atol=1e-15)
        weights = torch.as_tensor(rng.normal(size=(3, 3)))
        (R * weights).sum().backward()
        t2 = torch.tensor([h[k], p[k], r[k]], dtype=torch.float64, requires_grad=True)
        (rotation_matrix(t2[0:1], t2[1:2], t2[2:3])[..., 0] * weights).sum().backward()
        assert np.allclose(t.grad.numpy(), t2.grad.numpy(), rtol=1e-12, atol=1e-15)


def test_opencv_round_trip_and_agreement():
    cv2 = pytest.importorskip("cv2")
    rng = np.random.default_rng(11)
    cam = random_camera(rng)
    local = Camera(**{**cam.__dict__, "position": (0.0, 0.0, 0.0)})  # OpenCV works in float64 but keep it small
    pts = rng.normal(size=(40, 3)) * 200 + local.forward * 1500
    rvec, tvec, K, dist = local.to_opencv()
    cv_uv, _ = cv2.projectPoints(pts, rvec, tvec, K, dist)
    assert np.allclose(cv_uv.reshape(-1, 2) + 0.5, local.project(pts), atol=1e-6)
    back = Camera.from_opencv(rvec, tvec, K, dist, local.image_size)
    assert np.allclose(back.project(pts), local.project(pts), atol=1e-6)


def test_json_round_trip_and_errors():
    cam = random_camera(np.random.default_rng(5))
    assert Camera.from_json(cam.to_json()) == cam
    with pytest.raises(ValueError, match="fov"):
        Camera.from_json('{"position": [0,0,0], "heading": 0, "pitch": 0, "roll": 0, "fov": 0, "image_size": [1,1]}')
    with pytest.raises(ValueError, match="lacks"):
        Camera.from_json('{"position": [0,0,0]}')


def test_kml_prior_of_aletsch(aletsch_dir):
    cam = Camera.from_kml(aletsch_dir / "prior_pose.kml", (1024, 763), "EPSG:21781")
    x, y, z = cam.position
    # The prior lies south-east of the Aletschhorn (LV03 ~ 643 000 / 146 000) and looks north-west towards it.
    assert 640_000 < x < 660_000 and 135_000 < y < 150_000 and math.isclose(z, 2929.03, abs_tol=0.01)
    assert -70 < cam.heading < -55 and math.isclose(cam.pitch, 78.7204365914 - 90, abs_tol=1e-6)
    assert math.isclose(cam.fov, 2 * 31.5386631717, abs_tol=1e-6)
    gcps = np.loadtxt(aletsch_dir / "gcps.csv", delimiter=",", skiprows=1)
    rmse = np.sqrt(np.mean(np.sum((cam.project(gcps[:, 2:5]) - gcps[:, :2]) ** 2, axis=1)))
    assert 10 < rmse < 100  # a rough prior: "off by tens of pixels"
