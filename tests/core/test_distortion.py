"""One distortion model for the camera and the z-buffer: pixel -> ray -> terrain -> pixel round trips."""

import numpy as np
import pytest

from monoplot_plugin.core import distortion
from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.synthetic import synthetic_terrain
from monoplot_plugin.core.xyz import compute_xyz, compute_xyz_full


def test_kernels_compile_the_camera_model_itself():
    from monoplot_plugin.core.xyz import mesh

    for kernel, model in ((mesh._distort, distortion.distort), (mesh._undistort, distortion.undistort)):
        assert getattr(kernel, "py_func", kernel) is model


@pytest.mark.parametrize("k1,k2", [(-0.3, 0.0), (-0.25, 0.04), (0.2, -0.05), (0.15, 0.02)])
def test_undistort_inverts_distort_up_to_the_valid_radius(k1, k2):
    r2max = min(distortion.valid_radius2(k1, k2), 2.0)
    r = np.sqrt(np.linspace(0.0, r2max * 0.98, 200))
    angle = np.linspace(0.0, 6.0, r.size)
    x, y = r * np.cos(angle), r * np.sin(angle)
    xd, yd = distortion.distort(x, y, k1, k2)
    xu, yu = distortion.undistort(xd, yd, k1, k2)
    assert np.abs(xu - x).max() < 1e-12 and np.abs(yu - y).max() < 1e-12
    # the compiled copy of the same function gives the same numbers, point by point
    from monoplot_plugin.core.xyz import mesh

    for i in range(0, r.size, 17):
        u, v = mesh._undistort(float(xd[i]), float(yd[i]), k1, k2)
        assert abs(u - x[i]) < 1e-12 and abs(v - y[i]) < 1e-12


def test_valid_radius_is_where_the_polynomial_stops_growing():
    k1, k2 = -0.35, 0.05
    r2 = distortion.valid_radius2(k1, k2)
    slope = lambda q: 1 + 3 * k1 * q + 5 * k2 * q * q  # noqa: E731
    assert slope(r2) > 0 and slope(r2 / 0.999 * 1.0001) < 0


@pytest.mark.parametrize("k1,k2", [(0.0, 0.0), (-0.3, 0.03), (0.12, -0.01)])
def test_pixel_ray_terrain_pixel_round_trip(k1, k2):
    """Each pixel's terrain point, projected by the camera, falls back on the pixel's centre; and the camera's own ray
    through that pixel goes through the point (the z-buffer and the camera undistort alike)."""
    dem = synthetic_terrain((160, 160), cell=20.0, seed=5)
    x, y = dem.cell_to_map(20, 140)
    cam = Camera((x, y, float(np.nanmax(dem.elevation)) + 200.0), heading=45.0, pitch=-30.0, roll=3.0, fov=70.0,
                 image_size=(161, 121), principal_point=(82.3, 59.1), k1=k1, k2=k2)
    xyz = compute_xyz(cam, dem)
    hit = np.isfinite(xyz[..., 0])
    assert hit.mean() > 0.4
    centres = cam.pixel_centres()[hit]
    back = cam.project(xyz[hit])
    assert np.abs(back - centres).max() < 1e-6
    origin, rays = cam.pixel_to_world_ray(centres)
    rel = xyz[hit] - origin
    t = np.einsum("ij,ij->i", rel, rays)
    assert np.abs(rel - t[:, None] * rays).max() < 1e-6 * np.abs(t).max()


def test_distance_is_along_the_undistorted_ray():
    dem = synthetic_terrain((100, 100), cell=25.0, seed=2)
    x, y = dem.cell_to_map(10, 90)
    cam = Camera((x, y, float(np.nanmax(dem.elevation)) + 100.0), heading=40.0, pitch=-10.0, roll=0.0, fov=60.0,
                 image_size=(120, 90), k1=-0.2, k2=0.02)
    res = compute_xyz_full(cam, dem, visibility=False)
    d = np.linalg.norm(res.xyz - np.asarray(cam.position), axis=-1)
    assert np.allclose(d[res.hit], res.distance[res.hit], rtol=1e-6)
