"""The plugin shell in pytest-qgis's QGIS (offscreen): initGui builds the GUI, unload removes all of it."""

import importlib.util
import logging

import pytest
from qgis.core import QgsApplication
from qgis.PyQt import sip
from qgis.PyQt.QtCore import QCoreApplication, QEvent
from qgis.PyQt.QtWidgets import QAction, QDockWidget

import resources_rc  # noqa: F401  (compiled by `make resources`, as in the release zip)
from monoplot_plugin import plugin as plugin_module
from monoplot_plugin.gui import tasks as tasks_module
from monoplot_plugin.plugin import MonoplotPlugin


def flush_deletes():
    QCoreApplication.sendPostedEvents(None, QEvent.Type.DeferredDelete)
    QCoreApplication.processEvents()


def expect_dock(instance, qtbot, opens: bool) -> None:
    """The plugin ``instance`` opens its dock (its button checked), or after a moment still has none."""
    if opens:
        qtbot.waitUntil(lambda: instance.dock is not None, timeout=5000)
        assert instance.action.isChecked()
    else:
        qtbot.wait(300)
        assert instance.dock is None


def monoplot_widgets(window):
    return (window.findChildren(QAction, "MonoplotAction"), window.findChildren(QDockWidget, "MonoplotDock"))


_restored_providers = []


@pytest.fixture(autouse=True)
def no_foreign_monoplot_provider():
    """Tests of the Processing engine register a session-wide "monoplot" provider; the plugin must register its own.

    Taken out for each test here, then registered again by id, so that test order does not matter.
    """
    registry = QgsApplication.processingRegistry()
    had_one = registry.providerById("monoplot") is not None
    if had_one:
        registry.removeProvider("monoplot")
    yield
    if had_one and registry.providerById("monoplot") is None:
        from monoplot_plugin.processing.provider import MonoplotProvider

        _restored_providers.append(MonoplotProvider())  # keep the Python object alive: sip does not
        registry.addProvider(_restored_providers[-1])


@pytest.fixture()
def plugin(qgis_iface):
    instance = MonoplotPlugin(qgis_iface)
    instance.initGui()
    yield instance
    if instance.action is not None:
        instance.unload()
    flush_deletes()


def test_init_gui_adds_action_to_plugins_toolbar_and_raster_menu(plugin, qgis_iface):
    action = plugin.action
    assert action in qgis_iface.mainWindow().findChildren(QAction, "MonoplotAction")
    assert action.text() == "Monoplot" and action.isCheckable() and not action.icon().isNull()
    assert plugin_module.plugin_icon_path() == plugin_module.ICON_RESOURCE  # the compiled resources.qrc is used
    qgis_iface.addPluginToRasterMenu.assert_called_with(plugin.menu, action)


def test_init_gui_warms_the_kernels_in_a_background_task(plugin, qtbot):
    """The first Suggest of a session must not compile numba's kernels or import torch: initGui starts a task that
    does it (workflow/warmup.py), on a worker thread."""
    qtbot.waitUntil(lambda: plugin.warmup_task is not None, timeout=plugin_module.WARM_UP_DELAY_MS + 5000)
    task = plugin.warmup_task
    assert task in tasks_module._LIVE  # kept referenced while its thread runs
    qtbot.waitUntil(lambda: task not in tasks_module._LIVE, timeout=120000)
    assert task.result is not None and task.result.ok, task.result
    assert set(task.result.value) == {"sight", "render", "suggest", "fit"}


def test_unload_during_the_warm_up_cancels_it(qgis_iface, qtbot):
    """A reload while the warm-up runs: unload cancels it and waits for the kernel it is compiling, no longer (a
    reload re-imports the plugin's modules next: the warm-up must not import them at the same time). The task stays
    referenced until its result is delivered."""
    instance = MonoplotPlugin(qgis_iface)
    instance.initGui()
    qtbot.waitUntil(lambda: instance.warmup_task is not None, timeout=plugin_module.WARM_UP_DELAY_MS + 5000)
    task = instance.warmup_task
    instance.unload()
    assert instance.warmup_task is None and task in tasks_module._LIVE
    assert task.waitForFinished(0)  # its thread has ended: nothing of the old plugin runs on
    qtbot.waitUntil(lambda: task not in tasks_module._LIVE, timeout=120000)
    assert task.result is not None and task.result.status in ("canceled", "success")
    flush_deletes()


def test_action_opens_and_closes_the_dock(plugin, qgis_iface, qtbot):
    qgis_iface.mainWindow().show()  # visibility signals only flow in a shown window
    assert plugin.dock is None  # created lazily: nothing heavy at QGIS start-up
    plugin.action.trigger()
    dock = plugin.dock
    assert isinstance(dock, QDockWidget) and dock.parent() is qgis_iface.mainWindow()
    qtbot.waitUntil(dock.isVisible, timeout=2000)
    assert dock.windowTitle() == "Monoplot" and plugin.action.isChecked()
    dock.close()  # the dock's own close button unchecks the toolbar button
    qtbot.waitUntil(lambda: not plugin.action.isChecked(), timeout=2000)
    plugin.action.trigger()
    assert plugin.dock is dock and dock.isVisible()
    qgis_iface.mainWindow().hide()


def test_unload_removes_everything_and_reload_leaves_nothing(qgis_iface):
    window = qgis_iface.mainWindow()
    app = QgsApplication.instance()
    quit_hooks = app.receivers(app.aboutToQuit)
    for _ in range(3):  # a plugin reload is unload() + a fresh instance's initGui()
        instance = MonoplotPlugin(qgis_iface)
        instance.initGui()
        assert app.receivers(app.aboutToQuit) > quit_hooks  # a background import is waited for at quit
        instance.action.trigger()
        actions, docks = monoplot_widgets(window)
        assert len(actions) == 1 and len(docks) == 1
        action, dock = instance.action, instance.dock
        instance.unload()
        flush_deletes()
        assert sip.isdeleted(action) and sip.isdeleted(dock)
        assert monoplot_widgets(window) == ([], [])
        qgis_iface.removePluginRasterMenu.assert_called_with(instance.menu, action)
        assert app.receivers(app.aboutToQuit) <= quit_hooks + 1  # the tasks module's own hook, once at most


@pytest.mark.skipif(importlib.util.find_spec("monoplot_plugin.processing.provider") is None,
                    reason="no Processing provider in this checkout yet")
def test_processing_provider_registered_and_removed(qgis_iface):
    registry = QgsApplication.processingRegistry()
    log = []
    QgsApplication.messageLog().messageReceived.connect(lambda message, tag, level: log.append((tag, message)))
    assert registry.providerById("monoplot") is None, [p.id() for p in registry.providers()]
    instance = MonoplotPlugin(qgis_iface)
    instance.initGui()
    provider = instance.provider
    assert provider is not None, f"monoplot_plugin.processing.provider exists but could not be registered: {log}"
    provider_id = provider.id()
    assert registry.providerById(provider_id) is provider
    instance.unload()
    assert registry.providerById(provider_id) is None


def test_duplicate_provider_is_not_fatal(qgis_iface):
    first, second = MonoplotPlugin(qgis_iface), MonoplotPlugin(qgis_iface)
    first.initGui()
    second.initGui()  # e.g. a provider left registered by a crashed reload
    assert second.provider is None and first.provider is not None
    second.unload()
    assert QgsApplication.processingRegistry().providerById(first.provider.id()) is first.provider
    first.unload()


def test_python_logging_reaches_the_monoplot_log_tab(plugin):
    received = []

    def on_message(message, tag, level):
        received.append((message, tag))

    QgsApplication.messageLog().messageReceived.connect(on_message)
    try:
        logging.getLogger("monoplot_plugin.some_module").warning("fit diverged after %d steps", 12)
        QCoreApplication.processEvents()
        assert ("monoplot_plugin.some_module: fit diverged after 12 steps", "Monoplot") in received
        plugin.unload()
        received.clear()
        logging.getLogger("monoplot_plugin.some_module").warning("after unload")
        QCoreApplication.processEvents()
        assert not [m for m in received if m[1] == "Monoplot"]
    finally:
        QgsApplication.messageLog().messageReceived.disconnect(on_message)


def test_a_project_with_monoplot_work_opens_the_dock_and_its_layers(plugin, qgis_iface, qtbot, tmp_path):
    """A project saved with a fitted camera, reopened in a QGIS where the dock was never opened: the dock opens
    and the camera and footprint layers have their features (memory layers came back empty until then)."""
    from qgis.core import QgsProject

    from monoplot_plugin.core.camera import Camera
    from monoplot_plugin.gui import persistence
    from monoplot_plugin.state import ProjectState

    project = QgsProject.instance()
    project.clear()
    camera = Camera((2_600_000.0, 1_200_000.0, 1500.0), 30.0, -6.0, 0.0, 58.0, (1024, 768))
    state = ProjectState()
    state.fitted = camera.to_dict()
    persistence.store_in_project(project, state)
    path = tmp_path / "with_monoplot.qgz"
    assert project.write(str(path))
    project.clear()
    assert plugin.dock is None
    assert project.read(str(path))
    qtbot.waitUntil(lambda: plugin.dock is not None, timeout=5000)
    assert plugin.action.isChecked() and plugin.dock.controller.fitted is not None
    # an empty project opens nothing
    plugin.dock.close()
    project.clear()
    assert project.write(str(tmp_path / "plain.qgz"))
    docks = len(qgis_iface.mainWindow().findChildren(QDockWidget, "MonoplotDock"))
    assert project.read(str(tmp_path / "plain.qgz"))
    assert len(qgis_iface.mainWindow().findChildren(QDockWidget, "MonoplotDock")) == docks
    project.clear()


def test_a_reload_brings_the_dock_back_for_a_project_with_monoplot_work(qgis_iface, qtbot, tmp_path):
    """A trial: after a reload (the plugin manager's update does one) the dock stayed closed on a project with
    Monoplot work until the button was clicked. It comes back; on a project without Monoplot work nothing opens."""
    from qgis.core import QgsProject

    from monoplot_plugin.gui import persistence
    from monoplot_plugin.state import ProjectState

    project = QgsProject.instance()
    project.clear()
    state = ProjectState()
    state.settings["overlay_opacity"] = 0.4
    persistence.store_in_project(project, state)
    assert project.write(str(tmp_path / "work.qgz"))
    for path, opens in ((tmp_path / "work.qgz", True), (tmp_path / "plain.qgz", False)):
        if not opens:
            project.clear()
            assert project.write(str(path))
        instance = MonoplotPlugin(qgis_iface)
        instance.initGui()
        try:
            expect_dock(instance, qtbot, opens)
        finally:
            instance.unload()
            flush_deletes()
    project.clear()


def test_without_its_packages_the_dock_offers_the_install_instead_of_a_python_error(plugin, qgis_iface,
                                                                                    monkeypatch):
    """Opening a project with Monoplot work in a QGIS without OpenCV showed a Python error dialog ("No module named
    'cv2'"): now the dock stays closed and the missing-packages notice with its Install button comes back."""
    from monoplot_plugin import deps

    absent = deps.Requirement("surely_absent_module_x", "surely-absent-package")
    monkeypatch.setattr(deps, "REQUIRED", deps.REQUIRED + (absent,))
    plugin.action.setChecked(True)
    assert plugin.dock is None and not plugin.action.isChecked()
    notice = plugin.dependency_notice
    assert notice is not None and "surely-absent-package" in notice.text()
    monkeypatch.undo()
    plugin.action.setChecked(True)  # installed meanwhile: the dock opens
    assert plugin.dock is not None and plugin.action.isChecked()


def test_work_a_crash_left_in_a_never_saved_project_opens_the_dock_once_qgis_has_started(qgis_iface, qtbot):
    """A re-check trial: after a crash, nothing at QGIS's start said that a never-saved project's work was waiting;
    it came back only if the dock happened to be opened on an empty project. Once QGIS has started
    (``initializationCompleted``) the plugin opens the dock, which takes it back; not before (opened while QGIS
    started, the restored work made the start's new project "modified", and QGIS asked whether to save it before
    anything showed); with no such work, or work this session wrote, nothing opens."""
    import os

    from pytest_qgis.mock_qgis_classes import MockMessageBar
    from pytest_qgis.qgis_interface import QgisInterface
    from qgis.core import QgsProject
    from qgis.PyQt.QtCore import pyqtSignal

    from monoplot_plugin.gui import persistence
    from monoplot_plugin.state import ProjectState

    class StartingQgis(QgisInterface):  # the real interface's signal, which pytest-qgis's lacks
        initializationCompleted = pyqtSignal()

    iface = StartingQgis(qgis_iface.mapCanvas(), MockMessageBar(), qgis_iface.mainWindow())
    project = QgsProject.instance()
    project.clear()
    state = ProjectState()
    state.settings["overlay_opacity"] = 31
    path = persistence.autosave_path(project)
    try:
        for left_by_a_crash in (False, True):
            with open(path, "w", encoding="utf-8") as fh:
                fh.write(state.snapshot()())
            if left_by_a_crash:  # written before this session began; else it is this session's own
                before = persistence.SESSION_START - 60.0
                os.utime(path, (before, before))
            instance = MonoplotPlugin(iface)
            instance.initGui()
            try:
                qtbot.wait(300)
                assert instance.dock is None  # QGIS is still starting
                iface.initializationCompleted.emit()
                expect_dock(instance, qtbot, left_by_a_crash)
                if left_by_a_crash:
                    assert instance.dock.controller.state.settings.get("overlay_opacity") == 31
                    assert "ended without its project being saved" in instance.dock.statusLabel.text()
            finally:
                instance.unload()
                flush_deletes()
    finally:
        project.clear()
        persistence.discard_autosave("")
