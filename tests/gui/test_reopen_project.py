"""Reopening a saved project in the real dock: what a user finds (camera layers filled, no false "autosave
restored" notice)."""

from __future__ import annotations

import os

import pytest
from qgis.core import Qgis, QgsProject

from monoplot_plugin.adapters.layers import GROUP_NAME
from monoplot_plugin.gui import persistence


def _fitted_session(dock, scene, qtbot):
    dock.photoFile.setFilePath(scene.photo_path)
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    c = dock.controller
    assert c.image is not None and c.dem is not None
    c.state.fitted = scene.camera.to_dict()
    c.state.fit_info = {"status": "ok", "rmse_px": 1.0, "mode": "paired"}
    c.save()
    return c


def _camera_layers(project):
    group = project.layerTreeRoot().findGroup(GROUP_NAME)
    return {node.layer().name(): node.layer().featureCount() for node in (group.findLayers() if group else [])}


def test_dock_opened_after_the_project_shows_the_camera_on_the_map(dock, scene, qtbot, qgis_iface, tmp_path):
    """QGIS started with a project, Monoplot opened afterwards: the camera and footprint layers of the group came
    back from the file as empty memory layers and stayed empty (nothing to identify, nothing to zoom to)."""
    from monoplot_plugin.gui.dock import MonoplotDock

    _fitted_session(dock, scene, qtbot)
    dock._update_camera_layers()
    project = QgsProject.instance()
    path = str(tmp_path / "reopen.qgz")
    assert project.write(path)
    dock.unload()  # Monoplot not open while the project is read
    project.clear()
    assert project.read(path)
    assert _camera_layers(project) == {"Monoplot camera": 0, "Monoplot view footprint": 0}  # memory: empty
    later = MonoplotDock(qgis_iface)
    qtbot.addWidget(later)
    try:
        assert later.controller.fitted is not None
        # the footprint is rendered in a task (a reopened project must not freeze QGIS), then the layers fill
        qtbot.waitUntil(lambda: _camera_layers(project) == {"Monoplot camera": 1, "Monoplot view footprint": 1},
                        timeout=30000)
    finally:
        later.unload()


def test_an_autosave_identical_to_the_saved_project_is_not_announced(dock, scene, qtbot, tmp_path):
    """A pending autosave that fires just after Save is newer than the file but holds the same work: reopening
    must not say "Monoplot restored work done after the project was last saved"."""
    c = _fitted_session(dock, scene, qtbot)
    project = QgsProject.instance()
    path = str(tmp_path / "saved.qgz")
    assert project.write(path)
    c.save()  # the autosave, after the save
    old = os.path.getmtime(path)
    os.utime(path, (old - 10, old - 10))
    messages = []
    c.message.connect(lambda text, level: messages.append(text))
    project.clear()
    assert project.read(path)
    qtbot.waitUntil(lambda: c.image is not None, timeout=5000)
    assert persistence.load_with_source(project)[1] == "project"
    assert not any("autosave" in m for m in messages), messages


def test_a_reopened_project_can_be_saved_again(dock, scene, qtbot, tmp_path):
    """Reopening a project with a fitted camera and saving it crashed QGIS (a desktop trial, five times out of five):
    the dock replaced the camera layers while QGIS was still reading the project, which left a deleted layer in the
    project's snapping settings (QgsSnappingConfig::writeProject). The layers are now rebuilt once the read is over:
    filled, and the project saves."""
    _fitted_session(dock, scene, qtbot)
    dock._update_camera_layers()
    project = QgsProject.instance()
    path = str(tmp_path / "first.qgz")
    assert project.write(path)
    project.clear()
    assert project.read(path)
    qtbot.waitUntil(lambda: _camera_layers(project) == {"Monoplot camera": 1, "Monoplot view footprint": 1},
                    timeout=30000)
    assert project.write(str(tmp_path / "again.qgz"))
    project.clear()
    assert project.read(str(tmp_path / "again.qgz"))
    assert set(_camera_layers(project)) == {"Monoplot camera", "Monoplot view footprint"}


def test_a_project_closed_without_saving_does_not_come_back_from_the_autosave(dock, scene, qtbot, tmp_path):
    """QGIS asked whether to save and the person said no: the next opening shows the saved project, not the
    autosave of the discarded work (a desktop trial got discarded check points back)."""
    c = _fitted_session(dock, scene, qtbot)
    project = QgsProject.instance()
    path = str(tmp_path / "kept.qgz")
    assert project.write(path)
    old = os.path.getmtime(path)
    os.utime(path, (old - 10, old - 10))
    c.set_setting("overlay_opacity", 17)  # work after the save...
    c.save()
    assert '"overlay_opacity":17' in open(persistence.autosave_path(project), encoding="utf-8").read()
    project.clear()  # ...not saved: QGIS closes the project
    assert not os.path.exists(str(tmp_path / "kept.monoplot-autosave.json"))
    messages = []
    c.message.connect(lambda text, level: messages.append(text))
    assert project.read(path)
    qtbot.waitUntil(lambda: c.image is not None, timeout=5000)
    assert c.state.settings.get("overlay_opacity") != 17
    assert not any("autosave" in m for m in messages), messages


def test_a_dock_opened_and_closed_on_an_empty_project_leaves_it_unmodified(qgis_iface, qtbot, scene):
    """Opening the dock and unloading the plugin (a reload, QGIS quitting) wrote a blank Monoplot entry into an
    empty project: QGIS then asked "Do you want to save the current project?" on quit. Work in the dock is still
    written."""
    from monoplot_plugin.gui.dock import MonoplotDock

    project = QgsProject.instance()
    project.clear()
    assert not project.isDirty()
    blank = MonoplotDock(qgis_iface)
    qtbot.addWidget(blank)
    blank.unload()
    assert not project.isDirty()
    assert project.readEntry(persistence.SCOPE, persistence.KEY, "") == ("", False)

    worked = MonoplotDock(qgis_iface)
    qtbot.addWidget(worked)
    worked.photoFile.setFilePath(scene.photo_path)
    assert worked.controller.image is not None
    worked.unload()
    text, found = project.readEntry(persistence.SCOPE, persistence.KEY, "")
    assert found and os.path.basename(scene.photo_path) in text and project.isDirty()
    project.clear()


def test_saved_as_a_new_file_the_old_file_reopens_as_it_was_saved(dock, scene, qtbot, tmp_path):
    """Work done after opening day1.qgz and saved as day2.qgz is in day2.qgz: day1.qgz reopens as it was saved,
    not with day 2's work "restored from the autosave" (a desktop trial, which QGIS then offered to save over day 1)."""
    c = _fitted_session(dock, scene, qtbot)
    project = QgsProject.instance()
    day1, day2 = str(tmp_path / "day1.qgz"), str(tmp_path / "day2.qgz")
    assert project.write(day1)
    old = os.path.getmtime(day1)
    os.utime(day1, (old - 10, old - 10))
    c.set_setting("overlay_opacity", 17)  # day 2's work, autosaved beside day1.qgz...
    c.save()
    assert os.path.exists(str(tmp_path / "day1.monoplot-autosave.json"))
    assert project.write(day2)  # ...then saved as day2.qgz
    assert not os.path.exists(str(tmp_path / "day1.monoplot-autosave.json"))
    messages = []
    c.message.connect(lambda text, level: messages.append(text))
    project.clear()
    assert project.read(day1)
    qtbot.waitUntil(lambda: c.image is not None, timeout=5000)
    assert c.state.settings.get("overlay_opacity") != 17 and not project.isDirty()
    assert not any("autosave" in m for m in messages), messages
    project.clear()
    assert project.read(day2)
    qtbot.waitUntil(lambda: c.image is not None, timeout=5000)
    assert c.state.settings.get("overlay_opacity") == 17


def test_work_discarded_after_the_plugin_unloaded_does_not_come_back(dock, scene, qtbot, qgis_iface, tmp_path):
    """A trial: edit a saved project, reload (or unload) the plugin, New project, "Discard": reopened, the edit was
    back ("Monoplot restored work done after the project was last saved"), since the unload wrote an autosave that
    nothing listened to remove. The unload hands the state to the project (QGIS asks to save it) and removes the
    autosave; a reload of an untouched project leaves it unmodified."""
    from monoplot_plugin.gui.dock import MonoplotDock
    from monoplot_plugin.state import PHOTO, Point

    c = _fitted_session(dock, scene, qtbot)
    project = QgsProject.instance()
    path = str(tmp_path / "day.qgz")
    assert project.write(path)
    project.clear()
    assert project.read(path)
    qtbot.waitUntil(lambda: c.image is not None, timeout=5000)
    qtbot.wait(200)
    assert not project.isDirty()
    dock.unload()  # a reload of the untouched project: not "modified"
    assert not project.isDirty()
    again = MonoplotDock(qgis_iface)
    qtbot.addWidget(again)
    try:
        qtbot.waitUntil(lambda: again.controller.image is not None, timeout=5000)
        again.controller.state.points["p-new"] = Point("p-new", PHOTO, 10.0, 20.0)  # an edit after the save
        again.controller._changed()
        again.controller.save()  # as the debounced autosave would
        assert os.path.exists(persistence.autosave_path(project))
        again.unload()
        assert project.isDirty() and not os.path.exists(persistence.autosave_path(project))
        project.clear()  # New project, "Discard"
        assert project.read(path)
        state, source = persistence.load_with_source(project)
        assert source == "project" and "p-new" not in state.points
    finally:
        again.unload()


@pytest.mark.parametrize("drawn_before_save", [0, 1])
def test_features_drawn_after_the_last_save_and_restored_from_the_autosave_are_announced(dock, scene, qtbot,
                                                                                            qgis_iface, tmp_path,
                                                                                            drawn_before_save):
    """A trial drew two points, QGIS crashed before Save; reopening (the plugin opens its dock as the project is
    read) brought them back, but the status line said only "session restored from the project": the notice of the
    restored drawing came first and was written over."""
    from monoplot_plugin.gui.dock import MonoplotDock

    _fitted_session(dock, scene, qtbot)
    project = QgsProject.instance()
    path = str(tmp_path / "crashed.qgz")
    session = dock.output_tools.current_session()
    for _ in range(drawn_before_save):
        session.add_feature("point", [[20, 30]])
    assert project.write(path)
    old = os.path.getmtime(path)
    os.utime(path, (old - 10, old - 10))
    session.add_feature("point", [[40, 60]])  # drawn after the save: only in the autosave
    qtbot.waitUntil(lambda: persistence.autosaved_entry(project, session._entry()) is not None, timeout=5000)
    autosaves = {}
    for name in (persistence.autosave_path(project), persistence._entries_path(persistence.autosave_path(project))):
        if os.path.exists(name):
            with open(name, encoding="utf-8") as fh:
                autosaves[name] = fh.read()
    dock.unload()
    project.clear()  # a crash: QGIS never closes the project, its autosave stays (a clear would discard it)
    for name, text in autosaves.items():
        with open(name, "w", encoding="utf-8") as fh:
            fh.write(text)
    assert project.read(path)
    later = MonoplotDock(qgis_iface)
    qtbot.addWidget(later)
    try:
        # shown at once, not when the person next draws, and said on the status line, after what else came back
        restored = later.output_tools.session
        assert restored is not None and restored.photo_layer("point").featureCount() == 1 + drawn_before_save
        status = later.statusLabel.text() + later.statusLabel.toolTip()
        assert "after the project was last saved" in status, status
    finally:
        later.unload()


def test_work_in_a_never_saved_project_comes_back_after_a_crash(dock, scene, qtbot, qgis_iface, tmp_path):
    """A flood trial's 8 pairs and fit, in a project never saved, sat in the profile's autosave after QGIS was
    killed: the next dock opened empty, and choosing the photo again overwrote the file. Now the dock takes it
    back, and says so; a project QGIS closes (it asked whether to save) leaves no such file behind."""
    from monoplot_plugin.gui.dock import MonoplotDock

    c = _fitted_session(dock, scene, qtbot)
    project = QgsProject.instance()
    assert not project.fileName()
    c.set_setting("overlay_opacity", 23)
    c.save()
    path = persistence.autosave_path(project)
    left = open(path, encoding="utf-8").read()
    assert '"overlay_opacity":23' in left
    # ...and a glacier front drawn on the photo (a re-check trial: the points came back, the drawing did not)
    dock.output_tools.current_session().add_feature("line", [[20, 30], [60, 35], [90, 50]])
    entries = persistence._entries_path(path)
    qtbot.waitUntil(lambda: any('"line": [{' in text for text in persistence._read_entries(entries).values()),
                    timeout=5000)
    drawn = open(entries, encoding="utf-8").read()
    dock.unload()  # the plugin handed its state over to the project...
    project.clear()  # ...which QGIS closed: nothing is left to restore
    assert not os.path.exists(path)
    assert not persistence.unsaved_work_left(project)

    for name, text in ((path, left), (entries, drawn)):  # a crash instead: the autosave stays, the project is gone
        with open(name, "w", encoding="utf-8") as fh:
            fh.write(text)
    assert not persistence.unsaved_work_left(project)  # written in this session: its own, not a crash's
    before = persistence.SESSION_START - 60.0  # ...written by a session before this one
    for name in (path, entries):
        os.utime(name, (before, before))
    assert persistence.unsaved_work_left(project)
    qgis_iface.messageBar().clear_messages()
    later = MonoplotDock(qgis_iface)
    qtbot.addWidget(later)
    try:
        said = " ".join(qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Info))
        assert "drawn on the photo were restored" in said and "last saved" not in said, said  # it never was
        assert later.controller.state.settings.get("overlay_opacity") == 23
        assert later.controller.fitted is not None and later.controller.image is not None
        assert "ended without its project being saved" in later.statusLabel.text()
        session = later.output_tools.session
        assert session is not None and session.photo_layer("line").featureCount() == 1
        assert "drawn on the photo came back" in later.statusLabel.text() + later.statusLabel.toolTip()
        qtbot.waitUntil(project.isDirty, timeout=3000)  # closing QGIS asks to save it
        assert project.write(str(tmp_path / "rescued.qgz"))  # saved: the status line stops asking for it
        status = later.statusLabel.text() + later.statusLabel.toolTip()
        assert "saved in rescued.qgz" in status and "save the project" not in status, status
    finally:
        later.unload()
        project.clear()
    assert not os.path.exists(path) and not os.path.exists(entries)
