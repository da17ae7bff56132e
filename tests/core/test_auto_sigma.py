"""σ of an automatic registration (:mod:`monoplot_plugin.core.auto.sigma`): a position widened to the prior's
σ carries the angles the fit found with it, checked against a real refit at the widened position."""

import numpy as np
import pytest

from monoplot_plugin.core.auto.sigma import carry_correlated, widen_std
from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.fit import fit_camera


@pytest.fixture(scope="module")
def paired_fit():
    """A paired fit on 12 far points (2-6 km) seen under a narrow angle, 1 px noise: position and heading
    are strongly correlated, as in a distant view."""
    rng = np.random.default_rng(4)
    truth = Camera((1000.0, 2000.0, 1500.0), 30.0, -3.0, 0.0, 35.0, (1200, 800))
    dist = rng.uniform(2000.0, 6000.0, 12)
    azimuth = np.radians(30.0 + rng.uniform(-14.0, 14.0, 12))
    world = np.stack([1000.0 + dist * np.sin(azimuth), 2000.0 + dist * np.cos(azimuth),
                      1500.0 - dist * np.tan(np.radians(3.0)) + rng.uniform(-150.0, 150.0, 12)], axis=1)
    image = truth.project(world) + rng.normal(0.0, 1.0, (12, 2))
    pairs = np.stack([np.arange(12), np.arange(12)], axis=1)
    start = truth.with_parameters(x=1030.0, heading=31.0)
    result = fit_camera(image, world, start, pairs=pairs)
    assert result.correlation and result.std["x"] > 0
    return result, image, world, pairs


def test_a_position_widened_to_the_priors_sigma_carries_the_heading_along(paired_fit):
    result, image, world, pairs = paired_fit
    std = result.std
    k = 10.0  # the position known only to the prior's σ, ten times the fit's
    widened = widen_std(std, {}, [], {"x": k * std["x"]})
    carried = carry_correlated(std, widened, result.correlation)
    assert carried["x"] == pytest.approx(k * std["x"])
    # the camera refitted with its X held where the widened σ puts it: its heading moves with it
    moved = result.camera.with_parameters(x=result.camera.position[0] + k * std["x"])
    refit = fit_camera(image, world, moved, pairs=pairs, free=("y", "z", "heading", "pitch", "roll", "fov"))
    turn = abs((refit.camera.heading - result.camera.heading + 180.0) % 360.0 - 180.0)
    assert turn > 2.0 * std["heading"]  # the fit's own σ does not cover it: widened alone, the heading stays put
    assert widened["heading"] == std["heading"]
    before, after = result.camera.parameters(), refit.camera.parameters()
    shifts = {"heading": turn, "y": abs(after["y"] - before["y"]), "fov": abs(after["fov"] - before["fov"])}
    for name, shift in shifts.items():  # carried along as far as the refit moved them
        assert 0.7 * shift <= carried[name] <= 1.5 * shift, (name, shift, carried[name])
    # a parameter barely correlated with X stays about as sure as it was
    for name in carried:
        r = abs(result.correlation.get("x", {}).get(name, 0.0))
        if name != "x" and r < 0.1:
            assert carried[name] <= 1.1 * std[name]


def test_nothing_widened_changes_nothing(paired_fit):
    result, *_ = paired_fit
    assert carry_correlated(result.std, dict(result.std), result.correlation) == result.std
    assert carry_correlated(result.std, dict(result.std), {}) == result.std
