"""Another photo in the dock when the current one carries work (a desktop trial lost 16 points, 6 pairs, 5 check
points and the fit to a grey copy of the same print, silently, Undo greyed out): the dock asks; the same picture
keeps its points; a rough camera of another picture size follows the photo. Real dialog, real clicks."""

from __future__ import annotations

import time

import cv2
import numpy as np
import pytest
from qgis.PyQt.QtCore import Qt, QTimer
from qgis.PyQt.QtWidgets import QApplication, QMessageBox

from monoplot_plugin.gui.photo_change import work_on_photo
from monoplot_plugin.state import ACCEPTED, CHECK, PHOTO, set_status
from test_dock import accept_everything, add_scene_points, load_inputs


def answer_with(qtbot, label: str, seen: list, give_up_s: float = 60.0) -> None:
    """Click the button ``label`` of the question box once it shows (its text kept in ``seen``); stop looking
    after ``give_up_s``."""
    deadline = time.monotonic() + give_up_s

    def click():
        box = QApplication.activeModalWidget()
        if not isinstance(box, QMessageBox):
            if time.monotonic() < deadline:
                QTimer.singleShot(20, click)
            return
        seen.append(box.text())
        button = next(b for b in box.buttons() if b.text().replace("&", "") == label)
        qtbot.mouseClick(button, Qt.MouseButton.LeftButton)

    QTimer.singleShot(20, click)


def test_choosing_another_photo_asks_before_its_points_go(dock, scene, qtbot, tmp_path):
    load_inputs(dock, scene, qtbot)
    c = dock.controller
    add_scene_points(dock, scene, n=8)
    accept_everything(c)
    c.set_prior(scene.prior)
    photo_ids = [p.id for p in c.state.in_space(PHOTO)]
    c.stack.push(set_status(c.state, photo_ids[:2], CHECK))
    assert work_on_photo(c) == "6 accepted photo points, 2 check points"  # said apart (a trial read "27 accepted")
    c.stack.undo()
    grey = str(tmp_path / "grey.png")
    image = cv2.imread(scene.photo_path)
    cv2.imwrite(grey, cv2.cvtColor(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), cv2.COLOR_GRAY2BGR))
    seen = []
    # Cancel: the photo, its points and the path in the box stay
    answer_with(qtbot, "Cancel", seen)
    dock.photoFile.setFilePath(grey)
    assert "8 accepted photo points" in seen[-1] and "same picture" in seen[-1]
    assert c.state.photo_path == scene.photo_path and dock.photoFile.filePath() == scene.photo_path
    assert c.state.counts()[PHOTO][ACCEPTED] == 8
    # the same picture in another file: the points stay with it
    answer_with(qtbot, "Keep the points", seen)
    dock.photoFile.setFilePath(grey)
    assert c.state.photo_path == grey and c.state.counts()[PHOTO][ACCEPTED] == 8
    # another picture, twice the size: no offer to keep; afresh removes the photo points, the map ones stay, and
    # the rough camera is scaled to it (it stayed at the old size: Find camera refused it with a traceback)
    bigger = str(tmp_path / "bigger.png")
    cv2.imwrite(bigger, cv2.resize(image, (image.shape[1] * 2, image.shape[0] * 2)))
    answer_with(qtbot, "Start afresh", seen)
    dock.photoFile.setFilePath(bigger)
    assert "same picture" not in seen[-1] and "put aside" in seen[-1]
    assert c.state.photo_path == bigger and c.state.counts()[PHOTO][ACCEPTED] == 0
    assert c.state.counts()["map"][ACCEPTED] == 8
    assert c.prior.image_size == c.photo_size == (image.shape[1] * 2, image.shape[0] * 2)
    assert abs(c.prior.project(scene.xyz[:3]) - 2 * scene.prior.project(scene.xyz[:3])).max() < 1.0
    # nothing to lose: no question
    n_questions = len(seen)
    dock.photoFile.setFilePath(scene.photo_path)
    qtbot.wait(100)
    assert len(seen) == n_questions and c.state.photo_path == scene.photo_path


def test_a_time_lapse_frame_keeps_the_camera_and_shows_its_overlay(dock, scene, qtbot, tmp_path):
    """A time-lapse user loaded the next frame and chose "Keep the points": the camera stayed, but the overlay was
    gone (the slider at 50 %), so nothing showed whether it still fitted the frame; and the question spoke only of
    copies of the same picture."""
    load_inputs(dock, scene, qtbot)
    c = dock.controller
    add_scene_points(dock, scene, n=8)
    accept_everything(c)
    c.set_fitted(scene.camera, {"status": "ok", "message": "the true camera"})
    assert c.overlay is not None
    frame = str(tmp_path / "frame_2.png")
    image = cv2.imread(scene.photo_path)
    cv2.imwrite(frame, cv2.convertScaleAbs(image, alpha=0.7, beta=10))  # a darker frame of the same camera
    seen, messages = [], []
    c.message.connect(lambda text, *_: messages.append(text))
    answer_with(qtbot, "Keep the points", seen)
    dock.photoFile.setFilePath(frame)
    assert "time-lapse" in seen[-1] and "follow the turn" in seen[-1]  # said before, not only after
    assert c.state.photo_path == frame and c.fitted == scene.camera
    # registered on the previous frame, and said (a re-check trial heard nothing of a frame that had not turned)
    assert any("This frame was matched to the previous one" in m and "it has not turned" in m for m in messages)
    qtbot.waitUntil(lambda: c.overlay is not None and not c.products_pending, timeout=30000)
    assert c.xyz is not None and np.isfinite(c.xyz[..., 2]).any()


def test_the_next_frame_of_a_turned_camera_turns_the_kept_points_and_cameras(dock, scene, qtbot, tmp_path):
    """A time-lapse trial kept the first frame's points on frames the mount had turned by up to 0.5°: the points sat
    7-28 px off their features and correct frame cameras were judged "uncertain" against them. The frame is
    registered on the previous one: the points follow the turn (Undo puts them back), and so do the cameras."""
    from monoplot_plugin.adapters.photo import array_to_qimage
    from monoplot_plugin.core.synthetic import render_photo

    load_inputs(dock, scene, qtbot)
    c = dock.controller
    add_scene_points(dock, scene, n=8)
    accept_everything(c)
    c.set_fitted(scene.camera, {"status": "ok", "message": "the true camera"})
    rough = scene.camera.with_parameters(heading=scene.camera.heading + 2.0)
    c.set_prior(rough)
    turned = scene.camera.with_parameters(heading=scene.camera.heading + 0.4, pitch=scene.camera.pitch - 0.2)
    frame = str(tmp_path / "frame_turned.png")
    # another frame: its own sensor noise (none), not the first frame's pattern in the same pixels
    assert array_to_qimage(render_photo(turned, scene.dem, noise=False)).save(frame)
    photo = {p.id: (p.x, p.y) for p in c.state.points.values() if p.space == PHOTO}
    pairs = list(c.state.pairs)
    messages, seen = [], []
    c.message.connect(lambda text, *_: messages.append(text))
    answer_with(qtbot, "Keep the points", seen)
    dock.photoFile.setFilePath(frame)
    assert c.state.photo_path == frame
    # within half a pixel (0.07° on this 480 px picture)
    assert abs(c.fitted.heading - turned.heading) < 0.07 and abs(c.fitted.pitch - turned.pitch) < 0.07
    assert abs(c.prior.heading - rough.heading - 0.4) < 0.07
    # each kept photo point is where the turned camera sees its map partner
    by_id = c.state.points
    for pid, mid in pairs:
        p, m = by_id[pid], by_id[mid]
        expected = turned.project(np.array([[m.x, m.y, m.z if m.z is not None else scene.dem.sample(m.x, m.y)]]))[0]
        assert np.hypot(p.x - expected[0], p.y - expected[1]) < 1.5, (pid, (p.x, p.y), expected)
    assert any("This frame turned 0.4" in m and "photo points and the camera were turned" in m for m in messages)
    assert not c.fit_points_changed()  # the fit's points moved with its camera: no "Fit again"
    turned_fit = c.fitted
    c.stack.undo()  # the points go back where they were on the first frame, and the cameras with them
    assert {p.id: (p.x, p.y) for p in c.state.points.values() if p.space == PHOTO} == photo
    assert c.fitted == scene.camera and c.prior == rough
    c.stack.redo()
    assert c.fitted == turned_fit and abs(c.prior.heading - rough.heading - 0.4) < 0.07


def test_a_frame_that_matches_no_previous_one_leaves_its_kept_camera_not_ok(dock, scene, qtbot, tmp_path):
    """A time-lapse trial kept the points on a frame of another view (the same size, 300 m away and 20° turned): the
    frame could not be matched, but its "ok" camera stayed a green "ok", and a line drawn there was given ± 5 m
    while 900 m off. The camera is now "uncertain" there, and its message says why first."""
    from monoplot_plugin.adapters.photo import array_to_qimage
    from monoplot_plugin.core.fit.result import verdict_first
    from monoplot_plugin.core.synthetic import render_photo

    load_inputs(dock, scene, qtbot)
    c = dock.controller
    add_scene_points(dock, scene, n=8)
    accept_everything(c)
    c.set_fitted(scene.camera, {"status": "ok", "message": "the true camera"})
    x, y, z = scene.camera.position
    other = scene.camera.with_parameters(x=x + 300.0, heading=scene.camera.heading + 20.0)
    frame = str(tmp_path / "another_view.png")
    assert array_to_qimage(render_photo(other, scene.dem, seed=7)).save(frame)
    messages, seen = [], []
    c.message.connect(lambda text, *_: messages.append(text))
    answer_with(qtbot, "Keep the points", seen)
    dock.photoFile.setFilePath(frame)
    assert c.state.photo_path == frame and c.fitted == scene.camera
    assert any("could not be matched" in m for m in messages), messages
    info = c.state.fit_info
    assert info["status"] == "uncertain", info
    assert verdict_first(info["message"])[0].startswith("Uncertain: this frame could not be matched")
    assert "the true camera" in info["message"]  # what the fit said is kept, after the reason
    # back to the first frame, which does not match the other view either: still one note, not one per switch
    answer_with(qtbot, "Keep the points", seen)
    dock.photoFile.setFilePath(scene.photo_path)
    message = c.state.fit_info["message"]
    assert message.count("could not be matched") == 1 and message.count("the true camera") == 1, message


def test_check_points_kept_on_a_turned_frame_are_measured_with_the_turned_camera(dock, scene, qtbot, tmp_path):
    """A time-lapse trial's 6 check points, 13.1 px on the first frame, read "18.2 px, 5 times the camera's
    residuals" after Keep the points on a frame turned 0.5°: they were measured when the points had moved and the
    camera not yet. Measured with the turned camera, they say what they said."""
    from monoplot_plugin.adapters.photo import array_to_qimage
    from monoplot_plugin.core.synthetic import render_photo

    load_inputs(dock, scene, qtbot)
    c = dock.controller
    photo, world = add_scene_points(dock, scene, n=10)
    accept_everything(c)
    for k in range(4):
        c.link(photo[k].id, world[k].id)
    c.stack.push(set_status(c.state, [p.id for p in photo[:4] + world[:4]], CHECK))
    c.set_fitted(scene.camera, {"status": "ok", "message": "the true camera", "rmse_px": 0.5})
    c.remeasure_checks()
    first = c.state.fit_info["check_rmse_px"]
    assert first < 1.0 and c.state.fit_info["status"] == "ok"
    turned = scene.camera.with_parameters(heading=scene.camera.heading + 0.5, pitch=scene.camera.pitch - 0.2)
    frame = str(tmp_path / "frame_turned.png")
    assert array_to_qimage(render_photo(turned, scene.dem, noise=False)).save(frame)
    said = []
    c.message.connect(lambda text, *_: said.append(text))
    answer_with(qtbot, "Keep the points", [])
    dock.photoFile.setFilePath(frame)
    qtbot.wait(50)  # the check points' message is queued
    assert c.state.photo_path == frame and abs(c.fitted.heading - turned.heading) < 0.07
    info = c.state.fit_info
    assert info["check_rmse_px"] < first + 0.5, info["check_rmse_px"]
    measured = [float(t.split("Check points: ")[1].split(" px")[0]) for t in said if t.startswith("Check points: ")]
    assert all(m < first + 0.5 for m in measured), said  # never a figure of the camera not yet turned
    assert info["status"] == "ok" and "Turned onto this frame" in info["message"]
    after_first = c.fitted
    # a third frame, turned back: one sentence, this frame's, from the previous one (a trial's third frame said
    # "Turned … by 1.773° … Turned … by 3.512°", the second from the second frame)
    third = str(tmp_path / "frame_back.png")
    assert array_to_qimage(render_photo(scene.camera, scene.dem, noise=False)).save(third)
    answer_with(qtbot, "Keep the points", [])
    dock.photoFile.setFilePath(third)
    qtbot.wait(50)
    message = c.state.fit_info["message"]
    assert message.count("Turned onto this frame") == 1 and "° (" in message, message
    assert message.startswith("the true camera") and message.endswith("px) from the previous one."), message
    assert abs(c.fitted.heading - scene.camera.heading) < 0.07
    c.stack.undo()  # the points and the cameras turn back together: measured with the camera turned back
    assert c.fitted == after_first
    assert c.state.fit_info["check_rmse_px"] < first + 0.5


def test_a_damaged_photo_is_refused_before_any_question(dock, scene, qtbot, tmp_path):
    """A trial chose a truncated JPEG while the photo carried points: the dock asked "Keep the points?" and only
    then refused the file. It is now refused at once, with its reason, and the points and the box stay."""
    load_inputs(dock, scene, qtbot)
    c = dock.controller
    add_scene_points(dock, scene, n=6)
    accept_everything(c)
    image = cv2.imread(scene.photo_path)
    whole = str(tmp_path / "whole.jpg")
    cv2.imwrite(whole, image)
    cut = tmp_path / "cut.jpg"
    data = open(whole, "rb").read()
    cut.write_bytes(data[: len(data) // 3])
    said, seen = [], []
    c.message.connect(lambda text, level: said.append(text))
    answer_with(qtbot, "Cancel", seen, give_up_s=0.5)  # would answer a question: there must be none
    dock.photoFile.setFilePath(str(cut))
    qtbot.wait(700)
    assert seen == [] and any("truncated" in text for text in said), said
    assert c.state.photo_path == scene.photo_path and dock.photoFile.filePath() == scene.photo_path
    assert c.state.counts()[PHOTO][ACCEPTED] == 6


def test_a_newer_camera_cancels_the_overlay_still_rendered_for_an_older_one(dock, scene, qtbot):
    """Cameras loaded one after the other each started an overlay task; the older ones ran to the end on the
    two cores only for their results to be dropped."""
    from monoplot_plugin.gui import engine

    load_inputs(dock, scene, qtbot)
    c = dock.controller
    info = {"status": "ok", "message": "loaded"}
    c.set_fitted(scene.camera.with_parameters(heading=scene.camera.heading + 2.0), info, background=True)
    older = list(c._products_tasks)
    c.set_fitted(scene.camera, info, background=True)
    assert len(older) == 1 and older[0].isCanceled()
    qtbot.waitUntil(lambda: not c.products_pending, timeout=30000)
    assert c.overlay is not None
    expected = c.in_picture(*engine.render_products(scene.camera, c.dem)[:2])[1]
    assert np.allclose(c.xyz, expected, equal_nan=True)  # the newer camera's, not the older's


def test_the_work_on_a_photo_comes_back_when_it_is_chosen_again(dock, scene, qtbot, tmp_path):
    """Repeat photography: an 1890 print and a modern photo in one project. A trial switched to the modern photo
    and back: the print's 11 pairs and its fitted camera were gone ("Not fitted yet", Undo greyed out)."""
    load_inputs(dock, scene, qtbot)
    c = dock.controller
    add_scene_points(dock, scene, n=8)
    accept_everything(c)
    c.set_fitted(scene.camera, {"status": "ok", "message": "the true camera"})
    print_points = {p.id: (p.x, p.y) for p in c.state.in_space(PHOTO)}
    modern = str(tmp_path / "modern.png")
    image = cv2.imread(scene.photo_path)
    cv2.imwrite(modern, cv2.resize(image, (image.shape[1] * 2, image.shape[0] * 2)))
    seen = []
    answer_with(qtbot, "Start afresh", seen)
    dock.photoFile.setFilePath(modern)
    assert "put aside" in seen[-1]
    assert c.state.photo_path == modern and c.state.counts()[PHOTO][ACCEPTED] == 0 and c.fitted is None
    c.add_manual(PHOTO, 40.0, 50.0)  # some work on the modern photo too
    messages = []
    c.message.connect(lambda text, *_: messages.append(text))
    answer_with(qtbot, "Start afresh", seen)
    dock.photoFile.setFilePath(scene.photo_path)  # back to the print: its points and camera come back
    assert "put aside earlier comes back with it" in seen[-1]
    assert c.state.photo_path == scene.photo_path
    assert {p.id: (p.x, p.y) for p in c.state.in_space(PHOTO)} == print_points
    assert c.fitted == scene.camera and c.state.fit_info["status"] == "ok"
    assert any("put aside earlier is back" in m and "8 accepted photo points" in m for m in messages)
    qtbot.waitUntil(lambda: c.overlay is not None and not c.products_pending, timeout=30000)
    answer_with(qtbot, "Start afresh", seen)
    dock.photoFile.setFilePath(modern)  # and the modern photo's one point is back as well
    assert [(p.x, p.y) for p in c.state.in_space(PHOTO)] == [(40.0, 50.0)]


def test_work_put_aside_before_the_first_save_comes_back_after_reopening(tmp_path):
    """A trial switched photos before saving the project for the first time: the work put aside then was keyed by
    the photo's absolute path, the project reopened looked for it by the relative one, and it was lost."""
    from qgis.core import QgsProject

    from monoplot_plugin.gui import photo_shelf
    from monoplot_plugin.state import ProjectState, Point

    photo = tmp_path / "photos" / "print.jpg"
    photo.parent.mkdir()
    photo.write_bytes(b"")
    project = QgsProject()  # not the application's: no dock listens to it
    state = ProjectState(photo_path=str(photo), fitted={"heading": 12.0})
    point = Point.new(PHOTO, 10.0, 20.0, status=ACCEPTED)
    state.points[point.id] = point
    assert project.fileName() == "" and photo_shelf.put_aside(project, state)
    assert project.write(str(tmp_path / "repeat.qgz"))
    reopened = QgsProject()
    assert reopened.read(str(tmp_path / "repeat.qgz"))
    assert photo_shelf.waiting(reopened, str(photo))
    back = photo_shelf.take_back(reopened, str(photo))
    assert back is not None and back.fitted == {"heading": 12.0} and list(back.points) == [point.id]
    assert not photo_shelf.waiting(reopened, str(photo))  # taken out: not brought back twice


def test_what_was_drawn_on_another_photo_is_on_the_map_after_reopening(dock, scene, qtbot, tmp_path):
    """Repeat photography: a glacier front drawn on each photo. After reopening, the front of the photo that was
    not current was an empty layer on the map until that photo was chosen again (desktop trial)."""
    from qgis.core import QgsProject

    project = QgsProject.instance()
    load_inputs(dock, scene, qtbot)
    c = dock.controller
    add_scene_points(dock, scene, n=8)
    accept_everything(c)
    c.set_fitted(scene.camera, {"status": "ok", "message": "the true camera"})
    session = dock.output_tools.current_session()
    session.add_field("seen", "date")
    session.add_feature("line", [[40, 200], [300, 210], [440, 190]], {"name": "front", "seen": "1890-08-01"})
    layer = session.map_layer("line")
    drawn = next(layer.getFeatures())
    wkt, layer_name = drawn.geometry().asWkt(3), layer.name()
    assert drawn.geometry().constGet().is3D() and drawn["m_per_px"] > 0
    modern = str(tmp_path / "modern.png")
    cv2.imwrite(modern, cv2.imread(scene.photo_path)[:, ::-1])
    draw_lines = dock.output_tools.actions["line"]
    draw_lines.trigger()  # still drawing lines when another photo is chosen
    assert draw_lines.isChecked() and dock.photo_canvas.mapTool() is not dock.photo_tool
    answer_with(qtbot, "Start afresh", [])
    dock.photoFile.setFilePath(modern)
    assert c.state.photo_path == modern and dock.output_tools.session is None
    # the new photo starts with point curation: no drawing tool left pressed over a photo without a camera (a trial's
    # "Draw polygons" stayed pressed after the photo changed)
    assert not draw_lines.isChecked() and dock.photo_canvas.mapTool() is dock.photo_tool
    path = str(tmp_path / "repeat.qgz")
    c.save()
    assert project.write(path)
    project.clear()
    assert project.read(path)
    qtbot.waitUntil(lambda: c.image is not None, timeout=5000)
    assert c.state.photo_path == modern and c.fitted is None  # the print is not the current photo
    (reopened,) = project.mapLayersByName(layer_name)
    assert reopened.featureCount() == 1
    back = next(reopened.getFeatures())
    assert back.geometry().asWkt(3) == wkt and back["name"] == "front"
    assert back["seen"].toString("yyyy-MM-dd") == "1890-08-01" and back["m_per_px"] == pytest.approx(drawn["m_per_px"])
    (pixels,) = project.mapLayersByName(layer_name.replace("(map)", "(photo pixels)"))
    assert not pixels.crs().isValid() and pixels.featureCount() == 1  # photo pixel space: no CRS (QGIS gave one)
    assert not project.isDirty()  # nothing changed by reading it back
    # the plugin opens the dock when the read is over (a trial: QGIS started afresh, the other frames' lines empty)
    from monoplot_plugin.gui.dock import MonoplotDock

    for emptied in (reopened, pixels):
        emptied.dataProvider().truncate()
    second = MonoplotDock(dock.iface)
    qtbot.addWidget(second)
    try:
        assert reopened.featureCount() == 1 and pixels.featureCount() == 1
    finally:
        second.controller.cancel()
        second.unload()
    answer_with(qtbot, "Start afresh", [])
    dock.photoFile.setFilePath(scene.photo_path)  # the print again: its session rebuilds the layer, once
    qtbot.waitUntil(lambda: dock.output_tools.session is not None, timeout=10000)
    assert reopened.featureCount() == 1 and next(reopened.getFeatures()).geometry().asWkt(3) == wkt
