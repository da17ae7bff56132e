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
