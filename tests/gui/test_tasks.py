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
