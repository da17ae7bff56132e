"""Background work in QGIS tasks: a pure function runs in ``run()``, its outcome is applied on the main thread.

The pattern every Monoplot task follows:

* the caller copies everything the work needs (numpy arrays, Camera objects: never a layer) *before* starting;
* ``run()`` never raises: exceptions become a :class:`TaskResult` with status ``failed`` and a readable reason;
* the work function receives the workflow's ``progress(fraction in [0, 1], message="")`` and ``is_canceled()``
  callbacks (:mod:`..workflow.progress`) and polls the latter often (the fit checks it every iteration, so Cancel
  acts within a second); it may stop by raising the workflow's ``Canceled``;
* ``finished()`` runs on the main thread and hands the :class:`TaskResult` to ``on_done``.

>>> TaskResult.success(42).ok, TaskResult.failed("no points").reason
(True, 'no points')
"""

from __future__ import annotations

import traceback
from dataclasses import dataclass
from typing import Any, Callable, Optional

from qgis.core import Qgis, QgsApplication, QgsMessageLog, QgsTask

from ..workflow.progress import Canceled  # raised by work that stops at once when is_canceled() turns true

__all__ = ["TaskResult", "FunctionTask", "start_task", "SUCCESS", "FAILED", "CANCELED"]

SUCCESS, FAILED, CANCELED = "success", "failed", "canceled"



@dataclass
class TaskResult:
    """Outcome of a task: ``status`` is success / failed / canceled; ``value`` the work's return value."""

    status: str
    value: Any = None
    reason: str = ""
    details: str = ""

    @property
    def ok(self) -> bool:
        return self.status == SUCCESS

    @classmethod
    def success(cls, value: Any) -> "TaskResult":
        return cls(SUCCESS, value)

    @classmethod
    def failed(cls, reason: str, details: str = "") -> "TaskResult":
        return cls(FAILED, None, reason, details)

    @classmethod
    def canceled(cls) -> "TaskResult":
        return cls(CANCELED, None, "canceled")


class FunctionTask(QgsTask):
    """Run ``work(progress, is_canceled)`` in the background and pass a :class:`TaskResult` to ``on_done``.

    ``work`` must only use the data captured in its closure (copied beforehand); it must not touch layers, widgets
    or the project. ``on_done(result)`` is called on the main thread.
    """

    def __init__(self, description: str, work: Callable[[Callable[..., None], Callable[[], bool]], Any],
                 on_done: Optional[Callable[[TaskResult], None]] = None):
        super().__init__(description, QgsTask.Flag.CanCancel)
        self._work = work
        self._on_done = on_done
        self.result: Optional[TaskResult] = None

    def run(self) -> bool:  # worker thread
        try:
            value = self._work(self._report_progress, self.isCanceled)
            self.result = TaskResult.canceled() if self.isCanceled() else TaskResult.success(value)
        except Canceled:
            self.result = TaskResult.canceled()
        except MemoryError:
            self.result = TaskResult.failed("not enough memory for this computation")
        except Exception as exc:  # never raise out of run(): QGIS would show a traceback dialog
            if self.isCanceled():  # work interrupted by the cancel itself
                self.result = TaskResult.canceled()
            else:
                self.result = TaskResult.failed(str(exc) or type(exc).__name__, traceback.format_exc())
        return self.result.ok

    def _report_progress(self, fraction: float, message: str = "") -> None:
        self.setProgress(max(0.0, min(100.0, 100.0 * float(fraction))))

    def finished(self, ok: bool) -> None:  # main thread
        if self.result is None:  # canceled before run() started
            self.result = TaskResult.canceled()
        if self.result.status == FAILED and self.result.details:
            QgsMessageLog.logMessage(self.result.details, "Monoplot", Qgis.MessageLevel.Warning)
        if self._on_done is not None:
            try:
                self._on_done(self.result)
            except Exception:  # a failing callback must not take QGIS down either
                QgsMessageLog.logMessage(traceback.format_exc(), "Monoplot", Qgis.MessageLevel.Critical)


def start_task(task: FunctionTask) -> FunctionTask:
    """Hand ``task`` to the QGIS task manager (progress appears in the status-bar task list). Keep a reference to
    the returned task until ``on_done`` ran: Python must not collect it while it runs."""
    QgsApplication.taskManager().addTask(task)
    return task
