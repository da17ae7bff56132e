"""An unpaired fit whose DEM points lie along lines cannot say where along them the camera is (core/fit/aperture)."""

import dataclasses

import numpy as np
import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.fit import fit_camera
from monoplot_plugin.core.synthetic import synthetic_terrain


def _drone_scene(seed: int):
    """A drone 100 m above gentle terrain looking down at 45 degrees; ground points on two parallel lines."""
    dem = synthetic_terrain((300, 300), cell=2.0, seed=seed, base=500.0, relief=40.0)
    x0, y0 = dem.cell_to_map(150, 250)
    z0 = float(dem.sample(np.array([x0]), np.array([y0]))[0])
    cam = Camera((x0, y0, z0 + 100.0), 0.0, -45.0, 0.0, 70.0, (1600, 1200))

    def on_lines(step: float, offset: float) -> np.ndarray:
        y = np.arange(y0 + 60.0 + offset, y0 + 300.0, step)
        xy = np.vstack([np.column_stack([np.full_like(y, x), y]) for x in (x0 - 20.0, x0 + 20.0)])
        return np.column_stack([xy, dem.sample(xy[:, 0], xy[:, 1])])

    return dem, cam, on_lines


def _grid_error_px(dem, cam: Camera, fitted: Camera) -> float:
    """RMS pixel distance between where the true and the fitted camera put the terrain in front of the camera."""
    x0, y0 = cam.position[0], cam.position[1]
    gx, gy = np.meshgrid(np.linspace(x0 - 100, x0 + 100, 15), np.linspace(y0 + 70, y0 + 290, 15))
    G = np.column_stack([gx.ravel(), gy.ravel(), dem.sample(gx.ravel(), gy.ravel())])
    true_uv = cam.project(G)
    inside = (true_uv[:, 0] >= 0) & (true_uv[:, 0] < 1600) & (true_uv[:, 1] >= 0) & (true_uv[:, 1] < 1200)
    return float(np.sqrt(np.mean(np.sum((fitted.project(G[inside]) - true_uv[inside]) ** 2, axis=1))))


@pytest.mark.parametrize("seed", [0, 1])
def test_dem_points_along_two_lines_are_not_ok(seed):
    dem, cam, on_lines = _drone_scene(seed)
    rng = np.random.default_rng(seed)
    world = on_lines(4.0, 0.0)
    photo = cam.project(on_lines(8.0, 4.0 / 3.0)) + rng.normal(0.0, 0.5, (len(on_lines(8.0, 4.0 / 3.0)), 2))
    prior = dataclasses.replace(cam, position=(cam.position[0], cam.position[1] + 30.0, cam.position[2]))
    result = fit_camera(photo, world, prior)
    assert result.status != "ok", (result.message, _grid_error_px(dem, cam, result.camera))
    assert "lie along lines" in result.message
    assert result.evidence["slide_px"] > 0.005 * result.evidence["diag"]
    # the σ says how far along the lines the camera may be
    assert abs(result.camera.position[1] - cam.position[1]) <= 3.0 * result.std["y"], result.std


def test_isolated_points_beside_the_lines_settle_the_slide():
    dem, cam, on_lines = _drone_scene(0)
    rng = np.random.default_rng(5)
    xy = np.column_stack([rng.uniform(cam.position[0] - 90, cam.position[0] + 90, 30),
                          rng.uniform(cam.position[1] + 70, cam.position[1] + 280, 30)])
    isolated = np.column_stack([xy, dem.sample(xy[:, 0], xy[:, 1])])
    world = np.vstack([on_lines(4.0, 0.0), isolated])
    photo = cam.project(np.vstack([on_lines(8.0, 4.0 / 3.0), isolated]))
    prior = dataclasses.replace(cam, position=(cam.position[0], cam.position[1] + 10.0, cam.position[2]))
    result = fit_camera(photo + rng.normal(0.0, 0.5, photo.shape), world, prior)
    assert result.evidence["slide_px"] < 0.005 * result.evidence["diag"]
    assert result.status == "ok", result.message
    assert _grid_error_px(dem, cam, result.camera) < 10.0
