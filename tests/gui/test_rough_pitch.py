"""The pitch of a rough camera (drawn on the map, or from EXIF, which has none): the DEM's skyline seen from it is
put where the photo shows its skyline. A trial's drone photo, truly pitched -6 deg, got +1.4 deg from the old rule
(the DEM's skyline a fifth of the picture under its top, whatever the photo showed)."""

from __future__ import annotations

import numpy as np

from monoplot_plugin.adapters.photo import qimage_to_array
from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain
from monoplot_plugin.gui.priors import photo_sky_rows, terrain_pitch
from test_dock import load_inputs


def test_the_photos_skyline_sets_the_pitch_of_a_rough_camera():
    dem = synthetic_terrain((200, 200), cell=50.0, seed=3)
    x0, y0, x1, _ = dem.bounds()
    x, y = x0 + 0.5 * (x1 - x0), y0 + 0.08 * (x1 - x0)
    truth = Camera((x, y, float(dem.sample(x, y)) + 200.0), 0.0, -3.0, 0.0, 60.0, (480, 320), crs_wkt=dem.crs_wkt)
    photo = render_photo(truth, dem)
    rough = truth.with_parameters(x=x + 15.0, y=y - 10.0, heading=3.0, pitch=0.0)  # a GPS position, no pitch
    rows = photo_sky_rows(photo)
    assert rows is not None and np.isfinite(rows).mean() > 0.5
    assert abs(terrain_pitch(rough, dem, sky_rows=rows) - truth.pitch) < 1.0
    assert abs(terrain_pitch(rough, dem) - truth.pitch) > 3.0  # the fixed rule, kept for photos without a skyline
    fog = np.full_like(photo, 170)
    assert photo_sky_rows(fog) is None


def test_a_prints_picture_centre_off_the_scans_centre_sets_the_pitch_from_there():
    """A re-check trial's scan: the picture's centre (the principal point) 75 px off the scan's, for a caption
    under the print; the pitch was measured from the scan's centre and came out 2.65 deg off."""
    dem = synthetic_terrain((200, 200), cell=50.0, seed=3)
    x0, y0, x1, _ = dem.bounds()
    x, y = x0 + 0.5 * (x1 - x0), y0 + 0.08 * (x1 - x0)
    truth = Camera((x, y, float(dem.sample(x, y)) + 200.0), 0.0, -3.0, 0.0, 60.0, (480, 320),
                   principal_point=(240.0, 220.0), crs_wkt=dem.crs_wkt)
    rows = photo_sky_rows(render_photo(truth, dem))
    rough = truth.with_parameters(x=x + 15.0, y=y - 10.0, heading=3.0, pitch=0.0)
    assert abs(terrain_pitch(rough, dem, sky_rows=rows) - truth.pitch) < 1.0


def test_the_dock_says_which_skyline_set_the_pitch(dock, scene, qtbot):
    load_inputs(dock, scene, qtbot)
    c = dock.controller
    said = []
    c.message.connect(lambda text, level: said.append(text))
    x, y, _ = scene.camera.position
    prior = c.prior_from_map(x, y, 0.0, 60.0)
    rows = photo_sky_rows(qimage_to_array(c.image), c._picture_area())  # the photo as the dock holds it
    assert prior.pitch == terrain_pitch(prior.with_parameters(pitch=0.0), scene.dem, sky_rows=rows)
    fixed = terrain_pitch(prior.with_parameters(pitch=0.0), scene.dem)  # the rule without the photo's skyline
    rule = "so that the DEM's skyline lies on the photo's" if prior.pitch != fixed else \
        "its skyline in the upper part of the picture"
    assert any(rule in text for text in said), said


def test_a_drone_photo_without_sky_pitches_the_rough_camera_down(dock, scene, qtbot, tmp_path):
    """A drone trial's photo looked down the slope (pitch -30 deg) and showed no sky; the rough camera got -13 deg
    from the fixed rule, which puts the DEM's skyline inside the picture. In the air, with no sky on the photo, the
    DEM's skyline goes just above the picture: the least downward pitch the photo allows."""
    import cv2

    load_inputs(dock, scene, qtbot)
    c = dock.controller
    x, y, _ = scene.camera.position
    height = 250.0
    truth = scene.camera.with_parameters(z=float(scene.dem.sample(x, y)) + height, pitch=-45.0)
    photo = render_photo(truth, scene.dem)
    assert photo_sky_rows(photo) is None
    path = str(tmp_path / "drone.png")
    cv2.imwrite(path, photo[:, :, ::-1])
    dock.photoFile.setFilePath(path)
    said = []
    c.message.connect(lambda text, level: said.append(text))
    prior = c.prior_from_map(x, y, truth.heading, truth.fov, 0.0, height)
    fixed = terrain_pitch(prior.with_parameters(pitch=0.0), scene.dem)
    assert truth.pitch - 1.0 <= prior.pitch < fixed - 5.0, (prior.pitch, fixed)  # down, never past the truth
    assert any("the photo shows no sky" in text and "type the gimbal pitch" in text for text in said), said
    # the pitch typed replaces how the bound was set on the status line (a trial read "Pitch set to -15.0°" after
    # typing -40)
    dock.pitchSpin.setValue(-45.0)
    assert c.prior.pitch == -45.0
    assert "Pitch set to" not in dock.statusLabel.text() and "pitch as typed" in dock.statusLabel.text(), \
        dock.statusLabel.text()
    on_ground = c.prior_from_map(x, y, truth.heading, truth.fov, 0.0, 2.0)  # fog, or a close-up: the fixed rule
    assert on_ground.pitch == terrain_pitch(on_ground.with_parameters(pitch=0.0), scene.dem)
