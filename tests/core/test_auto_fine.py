"""The registration's fine stage helpers (:mod:`monoplot_plugin.core.auto.fine`): terrain shift between cameras,
re-aiming a moved camera, and position probes on a generated scene."""

import math

import numpy as np
import pytest

from monoplot_plugin.core.auto.fine import (PROBE_RATIO, PROBE_SHIFT, Probe, aimed_from, edge_score,
                                             position_probes, refine_fine, terrain_shift_px)
from monoplot_plugin.core.auto.photo_edges import detect_photo_edges

SIGMAS = {"angle_deg": 3.0, "fov_deg": 2.5, "position_m": 100.0}


@pytest.fixture(scope="module")
def scene(valley):
    """The valley (``conftest.valley``) with the photo's edges at full size."""
    dem, truth, photo = valley
    edges = detect_photo_edges(photo, width=480)
    edges.scale = 1.0
    return dem, truth, edges, photo


def test_terrain_shift_is_zero_for_the_same_camera_and_follows_a_turn(scene):
    dem, truth, *_ = scene
    assert terrain_shift_px(truth, truth, dem) == pytest.approx(0.0, abs=1e-6)
    turned = truth.with_parameters(heading=truth.heading + 1.0)
    # a turn of 1 degree moves every point by about focal * tan(1 deg) pixels
    assert terrain_shift_px(turned, truth, dem) == pytest.approx(truth.focal_px * math.tan(math.radians(1.0)),
                                                                 rel=0.15)


def test_a_moved_camera_is_aimed_at_the_same_terrain(scene):
    dem, truth, *_ = scene
    moved = aimed_from(truth, np.add(truth.position, (150.0, -80.0, 20.0)), dem)
    assert np.allclose(moved.position, np.add(truth.position, (150.0, -80.0, 20.0)))
    # turned towards the terrain: it moves (parallax), but less than the same move without the turn
    unturned = truth.with_parameters(x=moved.position[0], y=moved.position[1], z=moved.position[2])
    assert abs(moved.heading - truth.heading) > 0.1
    assert 0.0 < terrain_shift_px(moved, truth, dem) < 0.8 * terrain_shift_px(unturned, truth, dem)


def test_a_rival_fits_nearly_as_well_and_moves_the_terrain(scene):
    _, truth, *_ = scene
    far = PROBE_SHIFT * math.hypot(*truth.image_size) + 1.0
    assert Probe(truth, PROBE_RATIO - 0.01, far).rival
    assert not Probe(truth, PROBE_RATIO + 0.01, far).rival  # clearly worse on the edges
    assert not Probe(truth, 1.0, far - 2.0).rival  # the same camera, for the picture


def test_probes_from_the_true_camera_find_their_way_back(scene):
    dem, truth, edges, photo = scene
    base = edge_score(truth, edges, dem, SIGMAS)
    done = []
    probes = position_probes(truth, truth, edges, dem, SIGMAS, done=done.append)
    assert len(probes) == 4 and done == [0.25, 0.5, 0.75, 1.0]  # a progress bar moves with the probes
    # moved by 100 m and re-aimed, each ends within a few pixels of the truth on the terrain: no rival
    assert all(p.shift_px < 5.0 for p in probes), [(p.score_ratio, p.shift_px) for p in probes]
    assert not any(p.rival for p in probes)
    assert base < 0.3


def test_a_probe_far_off_counts_as_a_rival_only_when_it_scores_as_well(scene):
    dem, truth, edges, photo = scene
    wrong = aimed_from(truth, np.add(truth.position, (0.0, 300.0, 0.0)), dem)
    shift = terrain_shift_px(wrong, truth, dem)
    ratio = edge_score(wrong, edges, dem, SIGMAS) / edge_score(truth, edges, dem, SIGMAS)
    assert shift > PROBE_SHIFT * math.hypot(*truth.image_size)
    assert Probe(wrong, ratio, shift).rival == (ratio <= PROBE_RATIO)


def test_a_basin_the_search_missed_is_taken_when_a_probe_finds_it(scene):
    """The registration's last stages started from a camera 250 m east of the truth, aimed at the same terrain and
    refined there (a local basin, about 70 px off): a probe finds a camera that fits the edges clearly better, the
    registration goes on from it and ends near the truth."""
    from monoplot_plugin.core.auto import register

    dem, truth, edges, photo = scene
    wrong = aimed_from(truth, np.add(truth.position, (250.0, 0.0, 0.0)), dem)
    wrong, al, off = refine_fine(wrong, wrong, edges, dem, SIGMAS)
    assert terrain_shift_px(wrong, truth, dem) > 30.0
    finals = [(edge_score(wrong, edges, dem, SIGMAS), wrong, al, off, float(al.score(off[None])[0]))]
    bar = []
    report = register.never_back(lambda f, m="": bar.append(f))  # as register_automatic reports
    search = register._Search(photo, dem, wrong, SIGMAS, report, None, edges, dem, [(0.0, np.zeros(7))],
                              edge_score(wrong.with_parameters(heading=wrong.heading + 20.0), edges, dem, SIGMAS),
                              {})
    first, probes = register._finish(finals, 0.7, search)
    assert min(p.score_ratio for p in probes) < register.ESCAPE_RATIO
    found = register._escape(first, probes, finals, search, {})
    assert found.evidence.get("auto_escapes", 0) >= 1 and "a position probe found" in found.message
    # the bar never goes back as the search goes on (a trial's went from 89 % to 85 %)
    assert all(b >= a for a, b in zip(bar, bar[1:])) and max(bar) < 1.0, bar
    assert found.evidence["auto_edge_score"] < first.evidence["auto_edge_score"]
    assert terrain_shift_px(found.camera, truth, dem) < 0.5 * terrain_shift_px(first.camera, truth, dem)


def test_too_few_probes_back_make_an_ok_uncertain(scene):
    """A camera in a basin narrower than the prior's uncertainty (fewer than two of the four probes came back) is not
    "ok", whatever else the evidence says; two probes back are enough."""
    from monoplot_plugin.core.auto import register, verdict

    _, truth, *_ = scene
    good = {"auto_skyline_usable": True, "auto_sky_fraction": 0.98, "auto_sky_agreement": 0.97, "auto_edge_score": 0.15,
            "auto_range_m": 5000.0, "auto_position_sigma_m": 100.0, "auto_rival_ratio": 0.5, "auto_probe_rivals": 0}
    verdicts, stds = {}, {}
    for returned in (0, 1, 2):
        result = register.AutoFitResult(truth, "ok", "unpaired fit.", "unpaired", std={"heading": 0.05, "x": 3.0})
        verdict.combine_evidence(result, dict(good, auto_probe_returned=returned))
        verdicts[returned], stds[returned] = (result.status, result.message), result.std
    assert verdicts[2][0] == "ok" and stds[2]["x"] == 3.0
    # a camera the probes could not confirm is placed only as well as the prior placed it (a desktop trial: "± 8 m",
    # 37 m off); so is one whose terrain is too near for the edges to place it
    assert all(stds[n][k] == 100.0 for n in (0, 1) for k in "xyz")
    near = register.AutoFitResult(truth, "ok", "unpaired fit.", "unpaired", std={"heading": 0.05, "x": 3.0})
    verdict.combine_evidence(near, dict(good, auto_probe_returned=4, auto_range_m=500.0))
    assert near.status == "uncertain" and near.std["y"] == 100.0
    assert verdicts[1][0] == "uncertain" and "only 1 of four cameras moved" in verdicts[1][1]
    assert verdicts[0][0] == "uncertain" and "none of four cameras moved" in verdicts[0][1]
    assert Probe(truth, 1.0, 1.0).returned and not Probe(truth, 1.0, 50.0).returned
    # a rival view is named by where it looks (a phone trial's "a clearly different view direction" named none)
    rivalled = register.AutoFitResult(truth, "ok", "unpaired fit.", "unpaired", std={"heading": 0.05, "x": 3.0})
    verdict.combine_evidence(rivalled, dict(good, auto_probe_returned=4, auto_rival_ratio=0.95,
                                            auto_rival_heading_deg=-12.0, auto_rival_pitch_deg=0.1))
    assert rivalled.status == "uncertain" and "almost as well (12.0° to the left)" in rivalled.message


def test_an_ok_camera_needs_its_sigma_to_place_its_near_ground(scene):
    """A trial's "ok" camera, placed along the view only to ± 142 m by ridges 5.6 km away, had its near slope
    (6 % of the ground) 367 px off. With ground near the camera that the σ moves by more than 3 % of the diagonal
    the camera is "uncertain", and the message says how much and how near; far ground alone keeps it "ok"."""
    import numpy as np

    from monoplot_plugin.core.auto import register, verdict

    _, truth, *_ = scene
    good = {"auto_skyline_usable": True, "auto_sky_fraction": 0.98, "auto_sky_agreement": 0.97, "auto_edge_score": 0.15,
            "auto_range_m": 5000.0, "auto_position_sigma_m": 100.0, "auto_rival_ratio": 0.5, "auto_probe_rivals": 0,
            "auto_probe_returned": 4}
    ahead = np.array([np.sin(np.radians(truth.heading)), np.cos(np.radians(truth.heading)), 0.0])
    below = np.asarray(truth.position) - [0.0, 0.0, 50.0]

    def judged(distances):
        result = register.AutoFitResult(truth, "ok", "unpaired fit.", "unpaired", std={"heading": 0.05, "x": 40.0,
                                                                                      "y": 40.0})
        result.ground = below + np.outer(distances, ahead)
        verdict.combine_evidence(result, dict(good))
        return result

    far = judged(np.linspace(4000.0, 6000.0, 100))
    assert far.status == "ok" and far.evidence["auto_ground_uncertain_share"] == 0.0
    near = judged(np.concatenate([np.linspace(80.0, 200.0, 10), np.linspace(4000.0, 6000.0, 90)]))
    assert near.status == "uncertain" and near.evidence["auto_ground_uncertain_share"] >= 0.1
    assert "10 % of the ground seen (the nearest, within" in near.message


@pytest.mark.parametrize("moved", [(40.0, -30.0, -15.0), (50.0, 0.0, 10.0)])
def test_more_passes_walk_a_near_camera_back_where_one_stops(near_slopes, moved):
    """Terrain about 100 m ahead: each round scores against silhouettes rendered where it starts, and one pass of
    the rounds stops tens of pixels off; passes that render again and start wide again end near the truth, with a
    lower edge score."""
    dem, truth, photo = near_slopes
    edges = detect_photo_edges(photo, width=photo.shape[1])
    edges.scale = 1.0
    start = truth.with_parameters(x=truth.position[0] + moved[0], y=truth.position[1] + moved[1],
                                  z=truth.position[2] + moved[2])
    ended = {passes: refine_fine(start, start, edges, dem, SIGMAS, passes=passes)[0] for passes in (1, 3)}
    shift = {n: terrain_shift_px(cam, truth, dem) for n, cam in ended.items()}
    score = {n: edge_score(cam, edges, dem, SIGMAS) for n, cam in ended.items()}
    assert shift[1] > 30.0, shift  # the scene is one where a single pass stops short
    assert shift[3] < 15.0 and shift[3] < 0.5 * shift[1], shift
    assert score[3] < score[1], score


def test_sigma_covers_every_probe_that_fits_the_edges_nearly_as_well(scene):
    """Where a probe ends fitting the edges nearly as well, the edges do not tell it from the camera: the σ covers
    it even when it moves the terrain too little to be a rival (a 24 MP trial: 22 m off with σ ± 4.5 m)."""
    from monoplot_plugin.core.auto import register

    dem, truth, edges, photo = scene
    tiny = dict.fromkeys(("x", "y", "z", "heading", "pitch", "roll", "fov"), 1e-3)
    result = register.AutoFitResult(truth, "ok", "", "unpaired", std=dict(tiny))
    evidence = {"auto_edge_score": edge_score(truth, edges, dem, SIGMAS)}
    probes = register._probe_position(result, truth, edges, dem, SIGMAS, evidence, None)
    alike = [p for p in probes if p.score_ratio <= PROBE_RATIO]
    assert alike, [p.score_ratio for p in probes]
    found = truth.parameters()
    for p in alike:
        ended = p.camera.parameters()
        for name, s in result.std.items():
            assert abs(ended[name] - found[name]) <= s + 1e-9, (name, ended[name] - found[name], s)
    moved = max(np.linalg.norm(np.subtract(p.camera.position, truth.position)) for p in alike)
    assert max(result.std["x"], result.std["y"], result.std["z"]) == pytest.approx(
        max(np.max(np.abs(np.subtract(p.camera.position, truth.position))) for p in alike))
    assert moved > 0.01  # the probes did not all end exactly on the camera: the σ was widened



def test_edges_filling_a_patch_of_the_picture_count_less_than_edges_across_it(scene, monkeypatch):
    """A trial's rough camera 84° off: the registration returned a camera 800 m up whose 138 contour points, in a
    tenth of the picture's width and height, sat on the photo's edges (edge score 0.016; the true camera's 0.62).
    The match of edges that span less than EDGE_SPREAD_FULL of the picture counts in proportion."""
    from monoplot_plugin.core.auto import fine
    from monoplot_plugin.core.auto.align import Aligner
    from monoplot_plugin.core.auto.dem_edges import dem_edges

    dem, truth, edges, _ = scene

    def spread(camera):
        found = dem_edges(camera, dem, 1.0, camera.focal_px * edges.scale)
        return Aligner(camera, edges, found, SIGMAS, tau=4.0).edge_spread(np.zeros(7))

    x0, y0, x1, y1 = dem.bounds()
    # the whole DEM from 40 km south: a fifth of the picture's width
    far = truth.with_parameters(y=y0 - 40000.0, z=truth.position[2] + 2000.0, heading=0.0, pitch=-2.0)
    assert spread(truth) > 0.8 and 0.0 < spread(far) < fine.EDGE_SPREAD_FULL
    share = spread(far) / fine.EDGE_SPREAD_FULL
    scores = {}
    for full in (fine.EDGE_SPREAD_FULL, 1e-9):  # the second: every match counted in full
        monkeypatch.setattr(fine, "EDGE_SPREAD_FULL", full)
        scores[full] = [edge_score(camera, edges, dem, SIGMAS) for camera in (truth, far)]
    (truth_score, far_score), (truth_raw, far_raw) = scores.values()
    assert truth_score == truth_raw < 0.3  # edges across the picture: unchanged
    assert far_score == pytest.approx(far_raw + (1.0 - far_raw) * (1.0 - share)) and far_score > far_raw
