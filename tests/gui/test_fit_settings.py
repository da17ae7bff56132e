"""What the user knows, in the real dock: lens -> field of view (EXIF where it can), fix / free toggles and the
prior's uncertainty passed to a real fit, a terrain-derived pitch for a drawn camera."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from osgeo import gdal
from qgis.core import Qgis, QgsProject
from qgis.PyQt.QtCore import Qt

from monoplot_plugin.adapters.exif import read_exif_prior
from monoplot_plugin.gui.fit_settings import fit_arguments, height_arguments
from monoplot_plugin.state import MAP, PHOTO, Point, replace_suggestions


def _jpeg_with_exif(path, size, **tags):
    """A real JPEG file of ``size`` = (W, H) with the given EXIF tags (GDAL's JPEG driver writes them)."""
    w, h = size
    mem = gdal.GetDriverByName("MEM").Create("", w, h, 3)
    for b in range(3):
        mem.GetRasterBand(b + 1).WriteArray(np.full((h, w), 40 * (b + 1), np.uint8))
    for key, value in tags.items():
        mem.SetMetadataItem("EXIF_" + key, value)
    gdal.GetDriverByName("JPEG").CreateCopy(str(path), mem, options=["WRITE_EXIF_METADATA=YES"])
    return str(path)


def _load(dock, photo_path):
    dock.photoFile.setFilePath(photo_path)
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    assert dock.controller.image is not None and dock.controller.dem is not None


def test_lens_entry_sets_the_field_of_view(dock, scene):
    _load(dock, scene.photo_path)
    c = dock.controller
    # a photo without EXIF (a scanned print): the panel says what to do when the lens is unknown (a trial asked)
    assert "Unknown? Leave it: the fit finds the field of view" in dock.lens_panel.note.text()
    c.set_prior(scene.prior)
    lens = dock.lens_panel
    lens.focal_spin.setValue(30.0)
    lens.sensor_spin.setValue(22.2)
    assert lens.apply() == pytest.approx(40.6, abs=0.05)  # the 30 mm lens on a 22.2 mm sensor
    assert dock.fovSpin.value() == pytest.approx(40.6, abs=0.05) and c.prior.fov == pytest.approx(40.6, abs=0.05)
    lens.equivalent_check.setChecked(True)
    lens.focal_spin.setValue(28.0)
    assert lens.apply() == pytest.approx(65.5, abs=0.05) and not lens.sensor_spin.isEnabled()
    assert c.state.settings["fit"]["focal_35mm"] == 28.0


def test_exif_focal_length_without_sensor_is_said_not_ignored(dock, tmp_path):
    path = _jpeg_with_exif(tmp_path / "lens_only.jpg", (480, 320), FocalLength="(30)")
    _load(dock, path)
    lens = dock.lens_panel
    assert lens.focal_spin.value() == 30.0
    assert "no sensor size" in lens.note.text()
    lens.sensor_spin.setValue(22.2)
    assert lens.apply() == pytest.approx(40.6, abs=0.05)


def test_exif_focal_plane_resolution_gives_the_field_of_view(dock, tmp_path):
    # 30 mm; 480 px over a 22.2 mm wide sensor: 21.62 px/mm (unit 4 = mm)
    path = _jpeg_with_exif(tmp_path / "lens_plane.jpg", (480, 320), FocalLength="(30)",
                           FocalPlaneXResolution=f"({480 / 22.2:.6f})", FocalPlaneResolutionUnit="4")
    exif = read_exif_prior(path, (480, 320))
    assert exif.sensor_width_mm == pytest.approx(22.2, abs=0.01) and exif.fov == pytest.approx(40.6, abs=0.05)
    _load(dock, path)
    assert "22.2 mm" in dock.lens_panel.note.text() and dock.fovSpin.value() == pytest.approx(40.6, abs=0.05)


def _scene_points(dock, scene):
    c = dock.controller
    c.stack.push(replace_suggestions(c.state, PHOTO, [Point.new(PHOTO, u, v) for u, v in scene.uv]))
    c.stack.push(replace_suggestions(c.state, MAP, [Point.new(MAP, x, y, z) for x, y, z in scene.xyz]))
    everywhere = (-1e12, -1e12, 1e12, 1e12)
    c.accept_all_in(PHOTO, everywhere)
    c.accept_all_in(MAP, everywhere)


def test_fixed_position_and_height_are_kept_by_the_fit(dock, scene, qtbot):
    _load(dock, scene.photo_path)
    c = dock.controller
    _scene_points(dock, scene)
    # the known position (the true one), heading and field of view wrong
    start = scene.camera.with_parameters(heading=4.0, fov=55.0)
    c.set_prior(start)
    panel = dock.fit_settings
    panel.free_checks["position"].setChecked(False)
    panel.free_checks["height"].setChecked(False)
    panel.sigma_spins["angle_sigma_deg"].setValue(6.0)
    free, options = fit_arguments(c.state.settings)
    assert set(free) == {"heading", "pitch", "roll", "fov"} and options.angle_sigma_deg == 6.0
    assert c.fit()
    with qtbot.waitSignal(c.taskFinished, timeout=120000) as blocker:
        pass
    assert blocker.args[0].ok, blocker.args[0].reason
    fitted = c.fitted
    assert fitted.position == pytest.approx(start.position, abs=1e-6)  # fixed: not moved at all
    assert set(c.state.fit_info["free"]) <= {"heading", "pitch", "roll", "fov"}
    assert abs(fitted.heading - scene.camera.heading) < 1.0 and abs(fitted.fov - scene.camera.fov) < 1.0
    # the fit tab says what was held (a flood trial's held guess read as a fitted position with no ±)
    text = dock.resultLabel.text()
    assert re.search(r"X&nbsp;</td><td>[\d.]+ m\u00a0\(held\)", text), text
    assert "Heading&nbsp;</td><td>" in text and not re.search(r"Heading&nbsp;</td><td>[^<]*\(held\)", text)


def test_settings_come_back_with_the_project(dock, scene, qtbot, tmp_path):
    _load(dock, scene.photo_path)
    panel = dock.fit_settings
    panel.free_checks["k1"].setChecked(True)
    panel.sigma_spins["position_sigma_m"].setValue(25.0)
    panel.height_combo.setCurrentIndex(2)  # in the air
    path = str(tmp_path / "settings.qgz")
    assert QgsProject.instance().write(path)
    QgsProject.instance().clear()
    assert not panel.free_checks["k1"].isChecked() and panel.sigma_spins["position_sigma_m"].value() == 0.0
    assert QgsProject.instance().read(path)
    qtbot.waitUntil(lambda: dock.controller.image is not None, timeout=5000)
    assert panel.free_checks["k1"].isChecked() and panel.sigma_spins["position_sigma_m"].value() == 25.0
    assert "k1" in fit_arguments(dock.controller.state.settings)[0]
    assert panel.height_combo.currentIndex() == 2 and not panel.eye_spin.isEnabled()
    assert height_arguments(dock.controller.state.settings)["on_ground"] is False


def test_on_the_ground_mode_holds_the_fit_at_the_eye_height(dock, scene, qtbot):
    _load(dock, scene.photo_path)
    c = dock.controller
    _scene_points(dock, scene)
    c.set_prior(scene.prior)
    panel = dock.fit_settings
    assert panel.height_combo.currentIndex() == 0  # automatic by default
    panel.height_combo.setCurrentIndex(1)
    panel.eye_spin.setValue(1.5)
    assert height_arguments(c.state.settings) == {"on_ground": True, "eye_height": 1.5}
    # the fit tab scrolled down to the settings, as a person leaves it after setting them
    bar = dock.fitScroll.verticalScrollBar()
    dock.splitter.setSizes([900, 200])  # a short tab: the settings below the fold
    qtbot.wait(20)
    bar.setValue(bar.maximum())
    scrolled = bar.value()
    assert c.fit()
    with qtbot.waitSignal(c.taskFinished, timeout=120000) as blocker:
        pass
    assert blocker.args[0].ok, blocker.args[0].reason
    x, y, z = c.fitted.position
    assert c.state.fit_info["on_ground"] and c.state.fit_info["eye_height_m"] == 1.5
    assert z - float(scene.dem.sample(x, y)) == pytest.approx(1.5, abs=0.5)
    # ... and back at the top once fitted: the verdict in sight (a re-check trial's stayed out of view)
    assert scrolled > 0 and bar.value() == 0
    # its height is the terrain's under it: as sure as X and Y, and said so (a summit trial's Z had no ±, 37 m low)
    sigma_z = c.state.fit_info["ground_sigma_m"]
    sx, sy = (c.state.fit_info["sigma"][k] for k in ("x", "y"))
    beside = [abs(float(scene.dem.sample(x + dx, y + dy)) - float(scene.dem.sample(x, y)))
              for dx, dy in ((sx, 0.0), (-sx, 0.0), (0.0, sy), (0.0, -sy))]
    # with the eye's own height over the terrain, which is not exact either (± 0.3 m)
    assert sigma_z == pytest.approx(math.hypot(max(beside[:2]), max(beside[2:]), 0.3), rel=1e-6)
    # the ± bound to its value and beside the height (a re-check trial's line wrapped as "... ±" / "18*")
    assert re.search(r"Z&nbsp;</td><td>\d+ m(<span[^>]*>)? ±\u00a0[\d.]+\*?(</span>)? \(ground\u00a0\+\u00a01.5\u00a0m\)",
                     dock.resultLabel.text()), dock.resultLabel.text()



def test_a_camera_held_on_the_ground_keeps_its_height_over_it_through_its_file(dock, scene, qtbot, tmp_path):
    """A time-lapse trial's camera, fitted 1.6 m above the ground and saved, read "ground + 0 m" once loaded in a
    new project: its file kept that it stood on the ground, not how high."""
    from monoplot_plugin.gui.camera_io import load_camera_file, save_camera_file

    _load(dock, scene.photo_path)
    c = dock.controller
    _scene_points(dock, scene)
    c.set_prior(scene.prior)
    dock.fit_settings.height_combo.setCurrentIndex(1)
    dock.fit_settings.eye_spin.setValue(1.5)
    assert c.fit()
    with qtbot.waitSignal(c.taskFinished, timeout=120000) as blocker:
        pass
    assert blocker.args[0].ok, blocker.args[0].reason
    path = str(tmp_path / "held.json")
    assert save_camera_file(c, path)
    saved = json.loads(open(path, encoding="utf-8").read())["fit"]
    assert saved["eye_height_m"] == 1.5
    # what the fit changed, so that the height it held reads as held, not as fitted with no σ
    assert {"x", "y", "heading", "pitch"} <= set(saved["fitted_parameters"]) and "z" not in saved["fitted_parameters"]
    c.set_fitted(None)
    assert "ground\u00a0+\u00a01.5\u00a0m" not in dock.resultLabel.text()
    with qtbot.waitSignal(c.productsReady, timeout=120000):
        assert load_camera_file(c, path, as_fitted=True) is not None
    assert c.state.fit_info["eye_height_m"] == 1.5
    assert "(ground\u00a0+\u00a01.5\u00a0m)" in dock.resultLabel.text()
    # with its ± (as sure as the terrain under its X, Y ±), as before it was saved (a re-check trial's had none)
    assert re.search(r"Z&nbsp;</td><td>\d+ m(<span[^>]*>)? ±\u00a0[\d.]+", dock.resultLabel.text())


def test_above_ground_box_shows_and_moves_the_prior(dock, scene, qtbot):
    _load(dock, scene.photo_path)
    c = dock.controller
    prior = scene.prior.with_parameters(z=float(scene.dem.sample(*scene.prior.position[:2])) + 114.0)
    c.set_prior(prior)  # as from a KML or a camera JSON: the box shows its height, not the last drawn one's
    assert dock.heightSpin.value() == pytest.approx(114.0, abs=0.5)
    dock.heightSpin.selectAll()
    qtbot.keyClicks(dock.heightSpin.lineEdit(), "50")
    assert c.prior.position == prior.position  # not yet: on Enter
    qtbot.keyClick(dock.heightSpin.lineEdit(), Qt.Key.Key_Return)
    x, y, z = c.prior.position
    assert z - float(scene.dem.sample(x, y)) == pytest.approx(50.0, abs=0.01)
    assert (x, y) == prior.position[:2] and c.prior.heading == prior.heading
    assert "50.0 m above the DEM" in dock.statusLabel.text()
    # a hand-held camera: decimetres count (a trial typed 1.6 and got 1 m: the box took whole metres)
    dock.heightSpin.selectAll()
    qtbot.keyClicks(dock.heightSpin.lineEdit(), "1.6")
    qtbot.keyClick(dock.heightSpin.lineEdit(), Qt.Key.Key_Return)
    x, y, z = c.prior.position
    assert z - float(scene.dem.sample(x, y)) == pytest.approx(1.6, abs=0.01)
    assert "1.6 m above the DEM" in dock.statusLabel.text()


def test_heading_box_turns_the_prior_where_it_stands(dock, scene, qtbot):
    """A drone's heading known from its flight log: the only way was "Draw on map", which also moved the camera off
    its GPS position (a trial)."""
    _load(dock, scene.photo_path)
    c = dock.controller
    prior = scene.prior.with_parameters(heading=-20.0)
    c.set_prior(prior)
    assert dock.headingSpin.value() == pytest.approx(340.0)  # as an azimuth
    dock.fovSpin.selectAll()
    qtbot.keyClicks(dock.fovSpin.lineEdit(), "50")
    qtbot.keyClick(dock.fovSpin.lineEdit(), Qt.Key.Key_Return)
    assert c.prior.fov == 50.0 and c.prior.heading == -20.0  # another box edited: the heading is not rounded
    dock.headingSpin.selectAll()
    qtbot.keyClicks(dock.headingSpin.lineEdit(), "12.5")
    qtbot.keyClick(dock.headingSpin.lineEdit(), Qt.Key.Key_Return)
    assert c.prior.heading == 12.5 and c.prior.position == prior.position and c.prior.pitch == prior.pitch
    assert "heading 12.5°" in dock.cameraSummary.text()


def test_drawn_camera_gets_a_pitch_from_the_terrain(dock, scene):
    _load(dock, scene.photo_path)
    c = dock.controller
    x, y = scene.camera.position[:2]
    assert dock.pitchSpin.value() == 0.0
    cam = c.prior_from_map(x, y, 0.0, 60.0, 0.0, 2.0)
    assert cam is not None and cam.pitch != 0.0 and -60.0 <= cam.pitch <= 30.0
    assert dock.pitchSpin.value() == pytest.approx(cam.pitch, abs=0.05)  # the box shows it, editable
    # the skyline lies in the upper part of the picture: terrain below it, sky above
    from monoplot_plugin.core.render import render_dem

    view = render_dem(cam.scaled(0.25), scene.dem)
    rows_with_sky = np.isnan(view.depth).any(axis=1)
    assert rows_with_sky[: view.depth.shape[0] // 3].any() and not rows_with_sky[-view.depth.shape[0] // 3:].all()
    assert c.prior_from_map(x, y, 0.0, 60.0, -3.0, 2.0).pitch == -3.0  # a given pitch is kept


def test_the_lenss_exact_field_of_view_survives_editing_another_box(dock, scene, qtbot):
    """A trial's 35 mm lens on a 36 mm sensor, 54.432°: "Set field of view" gave the camera the box's 54.4°, and so
    did typing the heading afterwards (the fit then held 54.4° fixed: 1.4 px RMS at 24 MP). The camera keeps the
    exact value; a box typed into changes what it shows."""
    from monoplot_plugin.adapters.exif import lens_fov

    _load(dock, scene.photo_path)
    c = dock.controller
    c.set_prior(scene.prior)
    lens = dock.lens_panel
    lens.focal_spin.setValue(35.0)
    lens.sensor_spin.setValue(36.0)
    exact = lens_fov(35.0, 36.0)
    assert lens.apply() == pytest.approx(exact) and c.prior.fov == pytest.approx(exact, abs=1e-9)
    assert abs(exact - round(exact, 1)) > 1e-3  # the box shows it rounded
    pitch = c.prior.pitch
    dock.headingSpin.setValue(dock.headingSpin.value() + 7.0)  # as typed (keyboard tracking off: one change)
    assert c.prior.fov == pytest.approx(exact, abs=1e-9) and c.prior.pitch == pitch
    dock.fovSpin.setValue(50.0)  # a box edited: its value
    assert c.prior.fov == pytest.approx(50.0)


def test_auto_camera_height_says_the_height_it_stands_for(dock, scene):
    """A flood trial read "Above ground 12.0 m" in the camera tab and "auto" in the fit settings, and could not tell
    which height the fit would hold: "auto" now says it, for this rough camera and mode."""
    _load(dock, scene.photo_path)
    c = dock.controller
    panel = dock.fit_settings
    ground = float(scene.dem.sample(*scene.prior.position[:2]))
    c.set_prior(scene.prior.with_parameters(z=ground + 12.0))  # an embankment: within 20 m, on the ground
    assert panel.eye_spin.value() == 0.0 and panel.eye_spin.text() == "auto (12.0 m)"
    panel.height_combo.setCurrentIndex(1)  # "On the ground" without a height: a hand-held camera's
    assert panel.eye_spin.text() == "auto (1.7 m)"
    panel.height_combo.setCurrentIndex(0)
    c.set_prior(scene.prior.with_parameters(z=ground + 300.0))  # a drone
    assert panel.eye_spin.text() == "auto (in the air)"


def test_position_box_places_and_moves_the_rough_camera_to_typed_coordinates(dock, scene, qtbot):
    """A surveyed position typed, not drawn: a time-lapse trial drew its GNSS position at 1.2 m a screen pixel and
    got the camera 0.6-1.3 m off its coordinates. Typed X, Y (Enter) place a camera with no rough camera yet, and
    move one that exists keeping its height above the DEM and its angles; a typo or a point off the DEM says so."""
    _load(dock, scene.photo_path)
    c = dock.controller
    assert c.prior is None and dock.positionEdit.text() == ""
    x, y = scene.camera.position[0] + 0.37, scene.camera.position[1] - 0.42
    dock.headingSpin.setValue(15.0)
    dock.positionEdit.setFocus()
    qtbot.keyClicks(dock.positionEdit, f"{x:.2f}, {y:.2f}")
    qtbot.keyClick(dock.positionEdit, Qt.Key.Key_Return)
    assert c.prior is not None and c.prior.position[:2] == pytest.approx((round(x, 2), round(y, 2)), abs=1e-6)
    assert c.prior.heading == pytest.approx(15.0)
    assert "looking along heading 15°" in dock.statusLabel.text()  # what it took, not "set its heading"
    # moved: the height above the DEM and the angles kept
    c.set_prior(c.prior.with_parameters(z=float(scene.dem.sample(x, y)) + 30.0, pitch=-3.0))
    assert dock.positionEdit.text() == f"{round(x, 2):.2f}, {round(y, 2):.2f}"
    dock.positionEdit.selectAll()
    qtbot.keyClicks(dock.positionEdit, f"{x + 200:.1f} {y + 100:.1f}")
    qtbot.keyClick(dock.positionEdit, Qt.Key.Key_Return)
    nx, ny, nz = c.prior.position
    assert (nx, ny) == pytest.approx((round(x + 200, 1), round(y + 100, 1)), abs=1e-6)
    assert nz - float(scene.dem.sample(nx, ny)) == pytest.approx(30.0, abs=0.01) and c.prior.pitch == -3.0
    assert "30.0 m above the DEM" in dock.statusLabel.text()
    for typed, said in (("2643210", "Type the camera's position as X, Y"), ("0, 0", "outside the DEM")):
        dock.positionEdit.selectAll()
        qtbot.keyClicks(dock.positionEdit, typed)
        qtbot.keyClick(dock.positionEdit, Qt.Key.Key_Return)
        assert said in dock.statusLabel.text() and c.prior.position == (nx, ny, nz)
        assert dock.positionEdit.text() == f"{nx:.2f}, {ny:.2f}"  # the camera's again, not the typo


def test_position_box_takes_a_surveyed_height_as_a_third_number(dock, scene, qtbot, qgis_iface):
    """A time-lapse trial typed her GNSS "X, Y, Z" and was told to type X, Y, the box cleared: a third number is
    the camera's height in the DEM's height system, as typed, for a new rough camera and for a moved one."""
    _load(dock, scene.photo_path)
    c = dock.controller
    x, y = scene.camera.position[0] + 0.37, scene.camera.position[1] - 0.42
    ground = float(scene.dem.sample(round(x, 2), round(y, 2)))
    dock.positionEdit.setFocus()
    qtbot.keyClicks(dock.positionEdit, f"{x:.2f}, {y:.2f}, {ground + 1.6:.2f}")
    qtbot.keyClick(dock.positionEdit, Qt.Key.Key_Return)
    assert c.prior is not None and c.prior.position == pytest.approx((round(x, 2), round(y, 2),
                                                                      round(ground + 1.6, 2)), abs=1e-6)
    assert "1.6 m above the DEM" in dock.statusLabel.text()
    assert dock.heightSpin.value() == pytest.approx(1.6, abs=0.05)  # the Above ground box follows
    # moved, with a decimal comma, to a height under the terrain: taken, and said
    dock.positionEdit.selectAll()
    qtbot.keyClicks(dock.positionEdit, f"{x + 50:.1f}; {y:.1f}; {ground - 30:.1f}".replace(".", ","))
    qtbot.keyClick(dock.positionEdit, Qt.Key.Key_Return)
    assert c.prior.position[0] == pytest.approx(round(x + 50, 1)) and c.prior.position[2] == pytest.approx(
        round(ground - 30, 1))
    said = dock.statusLabel.text() + dock.statusLabel.toolTip()
    assert "under the DEM" in said and "height system" in said
    # a warning, not an info a re-check trial read past
    assert any("under the DEM" in m for m in qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Warning))


def test_find_camera_keeps_near_the_field_of_view_of_the_photos_lens(dock, scene, tmp_path):
    """A drone trial's EXIF lens (24 mm equivalent, 71.6°) gave the rough camera its field of view, and Find
    camera, free to search 10 %, ended at 113.7°. The lens's field of view is searched within a few %, unless the
    person states a Field of view ± or types another field of view."""
    from monoplot_plugin.gui.auto_panel import LENS_FOV_SHARE

    path = _jpeg_with_exif(tmp_path / "drone.jpg", (480, 360), FocalLengthIn35mmFilm="24")
    _load(dock, path)
    c = dock.controller
    fov = read_exif_prior(path, (480, 360)).fov
    assert fov == pytest.approx(71.6, abs=0.1)  # the trial's (a 4:3 picture, crop factor on the diagonal)
    # the box the rough camera takes it from keeps it to 0.01° (a time-lapse trial's 37.115° became 37.1: 0.3 px
    # at the picture's edges for a field of view she then held)
    assert dock.fovSpin.value() == pytest.approx(fov, abs=0.006)
    c.set_prior(scene.prior.with_parameters(fov=fov))
    panel = dock.auto_panel
    assert panel.prior_sigmas(True)["fov_sigma_deg"] == pytest.approx(LENS_FOV_SHARE * fov)
    c.set_prior(scene.prior.with_parameters(fov=fov + 5.0))  # typed: not the lens's
    assert panel.prior_sigmas(True)["fov_sigma_deg"] is None
    c.state.settings["fit"] = {"fov_sigma_deg": 8.0}
    c.set_prior(scene.prior.with_parameters(fov=fov))
    assert panel.prior_sigmas(True)["fov_sigma_deg"] == 8.0


def test_a_doubtful_fit_that_moved_the_lens_field_of_view_says_to_hold_it(dock, scene, qtbot, tmp_path):
    """A flood trial's fits traded the field of view against the distance along the view (+3.5° off the EXIF lens,
    the camera 184 m forward); holding the lens's field of view put it 26 m off, and nothing had suggested it."""
    from monoplot_plugin.adapters.photo import qimage_to_array

    from qgis.PyQt.QtGui import QImage

    rgb = qimage_to_array(QImage(scene.photo_path))
    mem = gdal.GetDriverByName("MEM").Create("", rgb.shape[1], rgb.shape[0], 3)
    for b in range(3):
        mem.GetRasterBand(b + 1).WriteArray(rgb[..., b])
    mem.SetMetadataItem("EXIF_FocalLengthIn35mmFilm", "40")  # a lens narrower than the camera's 60°
    path = str(tmp_path / "lens.jpg")
    gdal.GetDriverByName("JPEG").CreateCopy(path, mem, options=["WRITE_EXIF_METADATA=YES", "QUALITY=95"])
    _load(dock, path)
    c = dock.controller
    lens_fov = read_exif_prior(path, scene.camera.image_size).fov
    assert abs(lens_fov - scene.camera.fov) > 5.0
    c.set_prior(scene.prior.with_parameters(fov=lens_fov))
    photo = [Point.new(PHOTO, u, v) for u, v in scene.uv[:8]]
    world = [Point.new(MAP, x + (400.0 if k == 3 else 0.0), y, z) for k, (x, y, z) in enumerate(scene.xyz[:8])]
    c.stack.push(replace_suggestions(c.state, PHOTO, photo))
    c.stack.push(replace_suggestions(c.state, MAP, world))
    everywhere = (-1e12, -1e12, 1e12, 1e12)
    c.accept_all_in(PHOTO, everywhere)
    c.accept_all_in(MAP, everywhere)
    for p, m in zip(photo, world):
        c.link(p.id, m.id)
    assert c.fit()
    with qtbot.waitSignal(c.taskFinished, timeout=120000) as blocker:
        pass
    assert blocker.args[0].ok, blocker.args[0].reason
    info = c.state.fit_info
    assert info["status"] != "ok" and abs(c.fitted.fov - lens_fov) > 3.0, (info["status"], c.fitted.fov)
    assert f"moved from the lens ({lens_fov:.1f}°" in info["message"] and "untick field of view" in info["message"]
