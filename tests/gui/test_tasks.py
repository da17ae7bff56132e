"""Monoplot's tasks in QGIS's real task manager: what a cancel leaves in the result."""

from __future__ import annotations

from monoplot_plugin.gui.tasks import CANCELED, SUCCESS, FunctionTask, start_task
from monoplot_plugin.workflow.progress import Canceled


def run(qtbot, work):
    results = []
    task = FunctionTask("Monoplot: test", lambda progress, is_canceled: work(task, is_canceled), results.append)
    start_task(task)
    qtbot.waitUntil(lambda: bool(results), timeout=20000)
    return results[0]


def test_a_cancel_after_the_work_finished_keeps_what_it_made(qtbot):
    """The person's cancel arrives as the work ends (a file already renamed into place): the result is canceled
    but still carries the value, so that the dock can say the file was written rather than "nothing was
    replaced"."""
    def finishes_then_canceled(task, is_canceled):
        task.cancel()
        return "written.tif"

    late = run(qtbot, finishes_then_canceled)
    assert late.status == CANCELED and late.value == "written.tif"

    def stops(task, is_canceled):
        task.cancel()
        if is_canceled():
            raise Canceled()
        return "never"

    stopped = run(qtbot, stops)
    assert stopped.status == CANCELED and stopped.value is None
    done = run(qtbot, lambda task, is_canceled: 42)
    assert done.status == SUCCESS and done.value == 42


def test_a_worded_error_is_said_without_a_traceback_and_a_bug_keeps_its_own(qtbot, tmp_path):
    """A read-only output folder is the person's matter: its sentence is the reason and nothing else goes to the
    log (a traceback in the Monoplot tab looked like a crash). A bug still logs its traceback."""
    from qgis.core import QgsApplication

    from monoplot_plugin.gui.tasks import FAILED
    from monoplot_plugin.outputs.safe_write import check_can_write

    logged = []
    log = QgsApplication.messageLog()
    log.messageReceived.connect(lambda message, tag, level: logged.append(message))
    missing = tmp_path / "no such folder" / "xyz.tif"

    def write(task, is_canceled):
        check_can_write(missing, overwrite=True)  # a real refusal in words
        return "never"

    refused = run(qtbot, write)
    assert refused.status == FAILED and "does not exist" in refused.reason
    assert not any("Traceback" in m for m in logged)
    bug = run(qtbot, lambda task, is_canceled: [][1])
    assert bug.status == FAILED and any("Traceback" in m and "IndexError" in m for m in logged)


def test_an_abandoned_task_stops_and_tells_nobody(qtbot):
    """The dock going away mid-task (plugin unload or reload): the task is canceled and cut loose; its ``on_done``
    and its signals never reach the dock's (deleted) objects. A hidden task stays referenced until its thread ends.
    Before, a fit that ended after the unload called the deleted controller (a Python error in the log)."""
    import threading

    from monoplot_plugin.gui import tasks
    from monoplot_plugin.gui.tasks import HiddenTask, abandon

    for kind in (FunctionTask, HiddenTask):
        started, ended, delivered, heard = threading.Event(), threading.Event(), [], []

        def work(progress, is_canceled):
            started.set()
            while not is_canceled():
                progress(0.5, "working")
                threading.Event().wait(0.01)
            ended.set()
            raise Canceled()

        task = kind("Monoplot: abandoned", work, delivered.append)
        signal = task.stageChanged if kind is FunctionTask else task.progressChanged
        signal.connect(heard.append)
        start_task(task)
        assert started.wait(10)
        qtbot.waitUntil(lambda: bool(heard), timeout=5000)  # connected and heard while it runs
        if kind is HiddenTask:
            assert task in tasks._LIVE
        abandon(task)
        assert ended.wait(10)
        heard.clear()
        qtbot.wait(300)  # the end reaches the main thread
        assert delivered == [] and heard == []
        assert task not in tasks._LIVE
    abandon(None)  # nothing to abandon


def test_a_fit_ending_after_the_dock_was_deleted_reaches_nothing(qgis_iface, dem_layer, scene, tmp_path, qtbot):
    """The plugin unloaded 50-400 ms after a Fit click: the fit's task ended later and called the deleted dock's
    controller (a traceback in the Monoplot log each time; QGIS crashed 2 times in 22 in a desktop loop). Now the
    unload cuts the task loose: it stops, and nothing is logged but its own line."""
    from qgis.core import Qgis, QgsApplication
    from qgis.PyQt import sip
    from qgis.PyQt.QtCore import QCoreApplication, QEvent

    from monoplot_plugin.gui.dock import MonoplotDock
    from monoplot_plugin.gui.io_actions import import_points_csv, load_camera_file
    from monoplot_plugin.workflow.camera_files import save_camera
    from monoplot_plugin.workflow.points_csv import write_points_csv

    dock = MonoplotDock(qgis_iface)  # deleted below, as the plugin's unload does: not a qtbot widget
    dock.photoFile.setFilePath(scene.photo_path)
    dock.demCombo.setLayer(dem_layer)
    c = dock.controller
    save_camera(str(tmp_path / "prior.json"), scene.prior)
    assert load_camera_file(c, str(tmp_path / "prior.json")) is not None
    write_points_csv(str(tmp_path / "gcps.csv"), uv=scene.uv[:30], xyz=scene.xyz[:30])
    import_points_csv(c, str(tmp_path / "gcps.csv"))
    logged = []
    QgsApplication.messageLog().messageReceived.connect(
        lambda text, tag, level: logged.append(text) if level >= Qgis.MessageLevel.Warning else None)
    dock.fitButton.click()
    task = c.task
    assert task is not None
    qtbot.wait(100)
    dock.unload()
    dock.deleteLater()
    QCoreApplication.sendPostedEvents(None, QEvent.Type.DeferredDelete)
    assert sip.isdeleted(dock)
    qtbot.waitUntil(lambda: task.result is not None, timeout=60000)
    qtbot.wait(500)  # the task's end reaches the main thread
    assert logged == []


def test_a_result_that_cannot_be_shown_leaves_the_dock_usable(dock, qtbot):
    """A trial: showing a poor fit raised (its cursor's σ), and the dock stayed busy at "Fit camera 100 %" with Fit
    greyed out and Cancel doing nothing. Now the failure is said and logged, and the next task runs."""
    c = dock.controller
    messages, shown = [], []
    c.message.connect(lambda text, level: messages.append(text))

    def show(value):
        raise ValueError(f"cannot show {value}")

    assert c.run_task("fit", "Fit camera", lambda progress, is_canceled: 42, show)
    qtbot.waitUntil(lambda: c.task is None, timeout=20000)
    assert c.task_kind == "" and dock.fitButton.isEnabled() and not dock.cancelButton.isEnabled()
    assert any("Fit camera finished, but showing its result failed: cannot show 42" in m for m in messages), messages
    assert c.run_task("fit", "Fit camera", lambda progress, is_canceled: 7, shown.append)
    qtbot.waitUntil(lambda: shown == [7], timeout=20000)
