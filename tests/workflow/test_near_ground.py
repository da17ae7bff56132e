"""A camera on the ground fitted on far points only: right where its points are, loose on the near ground.

A person standing on a hillside photographs a valley; the points anyone recognises are far (ridges, summits). The
fit (the dock's and Processing's, :func:`monoplot_plugin.workflow.fit.fit`, with the DEM) must not call such a
camera "ok" when its σ leaves the near ground, a large part of the picture, loose; with points on the near ground
too it may.
"""

import math

import numpy as np
import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.fit import FitOptions, fit_camera
from monoplot_plugin.core.fit.near_ground import NEAR_SHIFT, ground_seen
from monoplot_plugin.core.synthetic import synthetic_terrain
from monoplot_plugin.core.xyz import segment_first_hit
from monoplot_plugin.workflow.fit import fit


def _first_hits(dem, cam, uv):
    origin, dirs = cam.pixel_to_world_ray(uv)
    starts = np.broadcast_to(origin, dirs.shape)
    s = segment_first_hit(dem, starts, starts + dirs * 20000.0)
    return starts + s[:, None] * dirs * 20000.0


@pytest.fixture(scope="module")
def hillside():
    """(dem, true camera 1.7 m over the terrain, (N, 2) pixels, (N, 3) terrain they see, (N,) distances, rng)."""
    dem = synthetic_terrain((300, 300), cell=20.0, seed=4)
    x0, y0, _, _ = dem.bounds()
    rng = np.random.default_rng(4)
    for _ in range(300):
        x, y = x0 + rng.uniform(0.3, 0.7) * 6000, y0 + rng.uniform(0.1, 0.3) * 6000
        pos = np.array([x, y, float(dem.sample(x, y)) + 1.7])
        cam = Camera(pos, 0.0, 0.0, 0.0, 55.0, (1200, 800), crs_wkt=dem.crs_wkt)
        target = float(dem.sample(x, y + 3000))
        cam = cam.with_parameters(pitch=math.degrees(math.atan2(target - pos[2], 3000)) - 0.2 * cam.vertical_fov)
        uv = rng.uniform([0, 0], [1200, 800], (3000, 2))
        hits = _first_hits(dem, cam, uv)
        seen = np.isfinite(hits).all(axis=1)
        dist = np.linalg.norm(hits - pos, axis=1)
        if seen.mean() > 0.5 and (seen & (dist < 300)).mean() > 0.15 and (seen & (dist > 1000)).mean() > 0.2:
            return dem, cam, uv[seen], hits[seen], dist[seen], rng
    pytest.fail("no hillside view found")


def _off_share(camera, truth, dem):
    """Share of the ground the true camera sees that ``camera`` puts more than NEAR_SHIFT of the diagonal off."""
    ground = ground_seen(truth, dem)
    err = np.linalg.norm(camera.project(ground) - truth.project(ground), axis=1)
    return float(np.mean(~(err <= NEAR_SHIFT * math.hypot(*truth.image_size))))


def _points(hillside, near: int):
    dem, truth, uv, hits, dist, _ = hillside
    rng = np.random.default_rng(0)
    far, close = np.flatnonzero(dist > 1000)[:12], np.flatnonzero((dist > 20) & (dist < 300))[:near]
    pick = np.concatenate([far, close])
    return uv[pick] + rng.normal(0, 1.0, (len(pick), 2)), hits[pick]


def _prior(truth):
    x, y, z = truth.position
    return truth.with_parameters(x=x + 20, y=y - 15, heading=5.0, pitch=truth.pitch + 1, fov=58.0)


OPTIONS = FitOptions(position_sigma_m=30.0, angle_sigma_deg=6.0)


def test_far_points_only_leave_the_near_ground_loose_and_the_fit_says_so(hillside):
    dem, truth = hillside[0], hillside[1]
    uv, xyz = _points(hillside, near=0)
    done = fit(uv, xyz, _prior(truth), dem, options=OPTIONS)
    result = done.result
    assert done.on_ground
    # the scene is what the test claims: the fitted camera really misplaces much of the near ground
    assert _off_share(result.camera, truth, dem) > 0.1
    assert result.status == "uncertain", result.message
    assert result.evidence["ground_loose_share"] > 0.1
    assert "too loosely for the near ground" in result.message and "add points on the near ground" in result.message
    # the core fit says the same when given the terrain, and nothing about it without
    core = fit_camera(uv, xyz, _prior(truth), ground=dem, terrain=dem, options=OPTIONS)
    assert core.status != "ok" and core.evidence["ground_loose_share"] > 0.1
    assert "ground_loose_share" not in fit_camera(uv, xyz, _prior(truth), ground=dem, options=OPTIONS).evidence


def test_points_on_the_near_ground_too_place_it_and_the_fit_is_ok(hillside):
    dem, truth = hillside[0], hillside[1]
    uv, xyz = _points(hillside, near=10)
    result = fit(uv, xyz, _prior(truth), dem, options=OPTIONS).result
    assert _off_share(result.camera, truth, dem) < 0.02
    assert result.status == "ok", result.message
    assert result.evidence["ground_loose_share"] <= 0.02
    # the correlations are kept with the σ: symmetric, ones on the diagonal
    names = list(result.std)
    assert set(result.correlation) == set(names)
    for a in names:
        assert result.correlation[a][a] == pytest.approx(1.0)
        for b in names:
            assert result.correlation[a][b] == pytest.approx(result.correlation[b][a])


def test_a_feature_on_the_near_ground_says_how_far_off_the_camera_may_put_it(hillside):
    """The ± a drawn feature gets (``xy_error_m``, ``z_error_m``) counts the camera's σ where the feature is: a line on the near
    ground of a camera placed by far points said ± 6 m from the far points' pixel error and was 73 m off."""
    from monoplot_plugin.workflow.features import photo_to_map_feature
    from monoplot_plugin.workflow.fit import sigma_px
    from monoplot_plugin.workflow.spread import camera_spread

    dem, truth, uv, hits, dist, _ = hillside
    fit_uv, xyz = _points(hillside, near=0)
    done = fit(fit_uv, xyz, _prior(truth), dem, options=OPTIONS)
    result = done.result
    figure = sigma_px(result, xyz)
    assert np.isfinite(figure)
    spread = camera_spread({"sigma": result.std, "correlation": result.correlation, "on_ground": done.on_ground}, dem)
    # a line along the near ground, drawn where the true camera sees terrain 40-250 m away
    near = np.flatnonzero((dist > 40) & (dist < 250))[:40]
    line = uv[near][np.argsort(uv[near, 0])]
    said, said_z = {}, {}
    for name, with_spread in (("figure", None), ("spread", spread)):
        feature = photo_to_map_feature("line", line, camera=result.camera, dem=dem, pixel_rmse=figure,
                                       spread=with_spread, step_px=50.0)
        said[name], said_z[name] = feature.xy_error_m, feature.z_error_m
    # how far off the fitted camera really puts that ground (its error alone: both rays on the same DEM)
    moved = _first_hits(dem, result.camera, line) - _first_hits(dem, truth, line)
    real = np.linalg.norm(moved[:, :2], axis=1)
    real_rms = float(np.sqrt(np.nanmean(real ** 2)))
    # the heights too (``z_error_m``): a flood analyst's marks were 3-6 m too high and no ± said so
    real_z = float(np.sqrt(np.nanmean(moved[:, 2] ** 2)))
    assert said_z["spread"] * 2 >= real_z > 0 and said_z["spread"] >= said_z["figure"] > 0, (said_z, real_z)
    # the ± covers it, and is never below the fit's own figure (on QGIS 3.22's libraries that figure alone said
    # 2.8 m of this 22.6 m; on 3.40's, numpy 2, its σ came out larger and it said 58 m)
    assert said["spread"] * 2 >= real_rms and said["spread"] >= said["figure"], (said, real_rms)
    # and far ground, where the points are, keeps the figure's ± at the median (the spread adds little there)
    ratios = [photo_to_map_feature("point", [p], camera=result.camera, dem=dem, pixel_rmse=figure,
                                   spread=spread).xy_error_m /
              photo_to_map_feature("point", [p], camera=result.camera, dem=dem, pixel_rmse=figure).xy_error_m
              for p in uv[np.flatnonzero(dist > 1500)[:15]]]
    assert np.median(ratios) < 1.5, ratios


def test_far_check_points_do_not_verify_the_near_ground(hillside):
    """Check points on summits far away measure the camera where the points already fix it: they cannot say the
    near ground is placed (a flood trial's camera, "ok" with 4 summit check points, was 6 m off and the ground within
    300 m 1000 px off). A check point on the near ground can."""
    dem, truth, uv, hits, dist, _ = hillside
    fit_uv, xyz = _points(hillside, near=0)
    far_checks = np.flatnonzero(dist > 2000)[20:25]
    done = fit(fit_uv, xyz, _prior(truth), dem, options=OPTIONS, check_uv=uv[far_checks], check_xyz=hits[far_checks])
    result = done.result
    assert result.check_rmse_px < 0.015 * np.hypot(*truth.image_size)  # they agree with the camera
    assert result.status == "uncertain", result.message
    assert "do not reach that ground" in result.message and "Verified by the check points" not in result.message
    assert result.evidence["check_nearest_m"] > result.evidence["ground_loose_reach_m"]


def test_too_few_far_check_points_are_told_to_include_the_near_ground(hillside):
    """Too few check points, all far: the advice to add more says one must be on the near ground (a re-check
    trial added far ones as told, then read that they "do not reach that ground")."""
    dem, truth, uv, hits, dist, _ = hillside
    fit_uv, xyz = _points(hillside, near=0)
    far_checks = np.flatnonzero(dist > 2000)[20:23]
    result = fit(fit_uv, xyz, _prior(truth), dem, options=OPTIONS, check_uv=uv[far_checks],
                 check_xyz=hits[far_checks]).result
    assert result.status == "uncertain", result.message
    reach = result.evidence["ground_loose_reach_m"]
    assert f"spread over the picture, one of them within {reach:.0f} m of the camera, verify" in result.message


def test_a_position_held_at_a_rough_guess_leaves_the_near_ground_as_loose_as_its_stated_sigma(hillside):
    """A flood trial held the camera at her typed position (60 m off, Position ± 40 m) as the dock advised: the fit
    on far points was "ok", "about 1.0 m on the ground", the near ground 75 m off; the held position counted as
    exact. Its stated σ is the camera's: in its σ (correlated with the angles that follow it) and in the check of
    the near ground."""
    dem, truth = hillside[0], hillside[1]
    uv, xyz = _points(hillside, near=0)
    x, y, z = truth.position
    guess = truth.with_parameters(x=x + 45.0, y=y - 40.0, heading=5.0, pitch=truth.pitch + 1, fov=58.0)
    held = ("z", "heading", "pitch", "roll", "fov")
    stated = fit(uv, xyz, guess, dem, options=FitOptions(position_sigma_m=40.0, angle_sigma_deg=6.0),
                 free=held).result
    assert _off_share(stated.camera, truth, dem) > 0.1  # the near ground is really off
    assert stated.std["x"] == pytest.approx(40.0) and stated.std["y"] == pytest.approx(40.0)
    assert abs(stated.correlation["x"]["heading"]) > 0.1  # the view turns to keep the far points where they are
    assert stated.status != "ok", stated.message
    assert stated.evidence["ground_loose_share"] > 0.1 and "its position held as it is" in stated.message


def test_a_line_on_the_near_ground_keeps_the_terrain_not_every_millimetre(hillside):
    """A flood trial's 26 clicks became 2,109 vertices, 3.6 mm apart near the camera (a 147 KB GeoPackage): one
    ground point per pixel of the photo. Between the person's vertices, half a DEM cell is the spacing the terrain
    has; the vertices clicked stay where they are."""
    from monoplot_plugin.core.transforms import photo_points_to_map
    from monoplot_plugin.workflow.features import photo_to_map_feature

    dem, truth, uv, hits, dist, _ = hillside
    near = np.flatnonzero((dist > 20) & (dist < 250))[:12]
    clicks = uv[near][np.argsort(uv[near, 0])]
    feature = photo_to_map_feature("line", clicks, camera=truth, dem=dem)
    vertices = np.vstack(feature.parts)
    gaps = np.hypot(*np.diff(vertices[:, :2], axis=0).T)
    clicked = photo_points_to_map(clicks, truth, dem)[0]
    on_clicks = np.array([np.min(np.linalg.norm(vertices - c, axis=1)) for c in clicked if np.isfinite(c).all()])
    assert np.all(on_clicks < 1e-6)  # every clicked vertex kept
    # between them, no two vertices closer than half a cell (but where a clicked vertex falls in between)
    assert np.sum(gaps < 0.5 * dem.cell_size - 1e-9) <= len(clicks), np.sort(gaps)[:20]
    # ... and no more than the terrain needs: about one per half cell of the line's length
    length = float(gaps.sum())
    assert len(vertices) <= length / (0.5 * dem.cell_size) + 2 * len(clicks) + 2
