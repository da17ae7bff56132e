"""Automatic registration without a known direction of view (:mod:`monoplot_plugin.core.auto.heading`): real sweeps
and registrations on the generated valley."""

import time

import numpy as np
import pytest

from monoplot_plugin.core import register_any_heading
from monoplot_plugin.core.auto.dem_edges import dem_edges
from monoplot_plugin.core.auto.heading import sweep_headings
from monoplot_plugin.core.auto.register import _sigmas


@pytest.fixture(scope="module")
def turned(valley):
    """The valley's photo with a rough camera 60 m off whose heading is turned 110 deg away (a guess)."""
    dem, truth, photo = valley
    x, y, _ = truth.position
    return dem, truth, photo, truth.with_parameters(heading=truth.heading + 110.0, x=x + 60.0, y=y - 40.0)


def gap(a, b):
    return abs((a - b + 180.0) % 360.0 - 180.0)


def test_the_sweep_ranks_the_true_direction_first(turned):
    dem, truth, photo, prior = turned
    sectors = sweep_headings(photo, dem, prior, _sigmas(prior, 100.0, 5.0, None))
    assert len(sectors) >= 3  # the other directions that see the DEM were scored too
    assert gap(sectors[0][1], truth.heading) < 5.0, sectors[:3]
    assert [s[0] for s in sectors] == sorted(s[0] for s in sectors)


def test_register_any_heading_recovers_a_view_the_ordinary_search_cannot_reach(turned):
    dem, truth, photo, prior = turned
    # the lens known (its field of view held to 0.02°): it stays the rough camera's, not the sweep's (a re-check
    # trial's held 54.43° came back 54.57°)
    result = register_any_heading(photo, dem, prior, position_sigma_m=100.0, fov_sigma_deg=0.02)
    cam = result.camera
    assert abs(cam.fov - prior.fov) <= 0.07
    assert gap(cam.heading, truth.heading) < 0.6 and abs(cam.pitch - truth.pitch) < 0.6
    world = dem_edges(truth, dem, 0.0).sky[::10]
    assert np.nanmedian(np.linalg.norm(cam.project(world) - truth.project(world), axis=1)) < 6.0
    assert result.message.startswith("The direction of view was not known")
    assert result.evidence["auto_heading_searched"] and result.status in ("ok", "uncertain")


def test_a_cancel_during_the_sweep_stops_it(turned):
    dem, _, photo, prior = turned
    start = time.perf_counter()
    result = register_any_heading(photo, dem, prior, is_canceled=lambda: time.perf_counter() - start > 0.5)
    assert result.status == "canceled" and time.perf_counter() - start < 3.0


def test_when_no_direction_matches_the_message_does_not_call_one_the_best_fit():
    """A quarry trial's photo without sky: every direction scored 1.000 (no match), and the message said "this one
    fits the photo's edges best (edge score 1.000)"."""
    from monoplot_plugin.core.auto.heading import _best_of
    from monoplot_plugin.core.auto.register import AutoFitResult
    from monoplot_plugin.core.camera import Camera

    def result(heading, score):
        camera = Camera((0.0, 0.0, 100.0), heading, -10.0, 0.0, 60.0, (400, 300))
        return AutoFitResult(camera, "uncertain", "No match.", "unpaired", evidence={"auto_edge_score": score})

    sig = {"angle_deg": 5.0, "position_m": 100.0, "fov_deg": 6.0}
    none = _best_of([result(0.0, 1.0), result(120.0, 1.0)], sig, 12)
    assert "fits the photo's edges best" not in none.message and "in none do the DEM's edges match" in none.message
    some = _best_of([result(0.0, 0.2), result(120.0, 0.9)], sig, 12)
    assert "this one fits the photo's edges best (edge score 0.200)" in some.message
