"""Background work in QGIS tasks: a pure function runs in ``run()``, its outcome is applied on the main thread.

The pattern every Monoplot task follows:

* the caller copies everything the work needs (numpy arrays, Camera objects: never a layer) *before* starting;
* ``run()`` never raises: exceptions become a :class:`TaskResult` with status ``failed`` and a readable reason;
* the work function receives the workflow's ``progress(fraction in [0, 1], message="")`` and ``is_canceled()``
  callbacks (:mod:`..workflow.progress`) and polls the latter often (the fit checks it every iteration, so Cancel
  acts within a second); it may stop by raising the workflow's ``Canceled``;
* ``finished()`` runs on the main thread and hands the :class:`TaskResult` to ``on_done``.

Work the person started (Suggest, Fit, a product) runs as a :class:`FunctionTask` in QGIS's task manager: it shows
in the status bar and QGIS announces it when it took long. Work the dock starts on its own (the background refit,
the chips' DEM view, the warm-up) runs as a :class:`HiddenTask`, same protocol, in a plain worker thread: no
status-bar entry and no "Task complete" message on every refit (QGIS 3.22 has no ``QgsTask.Flag.Silent``).

When the dock goes away (plugin unloaded or reloaded, QGIS quitting) its tasks may still run: :func:`abandon` cancels
each and cuts it loose (no ``on_done``, no signal to the dock's objects), so that a task ending afterwards touches
nothing deleted. A :class:`HiddenTask` is kept referenced here until its thread ends, and QGIS quitting waits for the
step it is in (Python must not be finalised under a running worker thread: QGIS 3.40 crashed in LLVM that way).

>>> TaskResult.success(42).ok, TaskResult.failed("no points").reason
(True, 'no points')
"""

from __future__ import annotations

import threading
import traceback
from dataclasses import dataclass
from typing import Any, Callable, Optional

from qgis.core import Qgis, QgsApplication, QgsMessageLog, QgsTask
from qgis.PyQt.QtCore import QObject, pyqtSignal

from ..adapters.dem import DemError
from ..adapters.photo import PhotoError
from ..core.photo_file import PhotoFileError
from ..outputs.safe_write import OutputError
from ..workflow.fit import FitRefused
from ..workflow.inputs import InputError
from ..workflow.products import ProductError
from ..workflow.progress import Canceled  # raised by work that stops at once when is_canceled() turns true

#: errors of the person's input or file system, raised with a sentence that says it all: the reason is shown, and
#: no traceback goes to the log (a read-only folder put a Python traceback in the Monoplot tab, desktop trial)
#: (a fit's refusal too: a background refit from a rough camera turned away wrote "Every DEM point is behind the
#: initial camera" as a traceback, a phone-photo trial)
WORDED_ERRORS = (OutputError, InputError, ProductError, PhotoError, PhotoFileError, DemError, FitRefused)

__all__ = ["TaskResult", "FunctionTask", "HiddenTask", "start_task", "abandon", "SUCCESS", "FAILED", "CANCELED"]

SUCCESS, FAILED, CANCELED = "success", "failed", "canceled"
#: how long QGIS quitting waits for a hidden task's step (an import of torch or a numba compile cannot be cut short)
QUIT_WAIT_MS = 60000
#: hidden tasks whose worker thread runs (Python keeps them and their closures until it ends, also after an unload)
_LIVE: list = []
_QUIT_HOOK: list = []


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

    #: the work's progress message when it changes ("automatic registration: coarse search ..."), main thread
    stageChanged = pyqtSignal(str)

    def __init__(self, description: str, work: Callable[[Callable[..., None], Callable[[], bool]], Any],
                 on_done: Optional[Callable[[TaskResult], None]] = None):
        super().__init__(description, QgsTask.Flag.CanCancel)
        self._work = work
        self._on_done = on_done
        self._stage = ""
        self.result: Optional[TaskResult] = None

    def run(self) -> bool:  # worker thread
        self.result = _run_work(self._work, self._report_progress, self.isCanceled)
        return self.result.ok

    def _report_progress(self, fraction: float, message: str = "") -> None:
        self.setProgress(max(0.0, min(100.0, 100.0 * float(fraction))))
        if message and message != self._stage:  # queued to the main thread: the task object lives there
            self._stage = message
            self.stageChanged.emit(message)

    def finished(self, ok: bool) -> None:  # main thread
        if self.result is None:  # canceled before run() started
            self.result = TaskResult.canceled()
        _deliver(self.result, self._on_done)

    def abandon(self) -> None:
        """Cancel, and deliver to nobody: see :func:`abandon`."""
        self.cancel()
        self._on_done = None
        _disconnect_all(self.stageChanged)


def _run_work(work, progress, is_canceled) -> TaskResult:
    """``work(progress, is_canceled)`` as a :class:`TaskResult`; never raises (QGIS would show a traceback)."""
    try:
        value = work(progress, is_canceled)
        if is_canceled():  # the work may have stopped early and returned what it had: that value is kept
            return TaskResult(CANCELED, value, "canceled")
        return TaskResult.success(value)
    except Canceled:
        return TaskResult.canceled()
    except MemoryError as exc:  # a MemoryBudgetError says how much it needed
        return TaskResult.failed(str(exc) or "not enough memory for this computation")
    except WORDED_ERRORS as exc:
        return TaskResult.canceled() if is_canceled() else TaskResult.failed(str(exc) or type(exc).__name__)
    except Exception as exc:  # noqa: BLE001 — never raise out of a worker thread
        if is_canceled():  # work interrupted by the cancel itself
            return TaskResult.canceled()
        return TaskResult.failed(str(exc) or type(exc).__name__, traceback.format_exc())


def _deliver(result: TaskResult, on_done) -> None:
    """Main thread: log a failure's traceback, hand the result to ``on_done`` (whose errors are logged too)."""
    if result.status == FAILED and result.details:
        QgsMessageLog.logMessage(result.details, "Monoplot", Qgis.MessageLevel.Warning)
    if on_done is not None:
        try:
            on_done(result)
        except Exception:  # noqa: BLE001 — a failing callback must not take QGIS down either
            QgsMessageLog.logMessage(traceback.format_exc(), "Monoplot", Qgis.MessageLevel.Critical)


class HiddenTask(QObject):
    """A :class:`FunctionTask` the person does not see: the same ``work`` / ``on_done`` protocol in a worker thread
    of its own, outside QGIS's task manager (no status-bar entry, no "Task complete" message).

    The methods the callers use of a QgsTask: ``cancel``, ``isCanceled``, ``waitForFinished``, ``description``,
    the signals ``progressChanged(float)`` (percent), ``taskCompleted`` and ``taskTerminated``. ``on_done`` runs on
    the main thread (a queued signal), after the worker has ended.
    """

    progressChanged = pyqtSignal(float)
    taskCompleted = pyqtSignal()
    taskTerminated = pyqtSignal()
    _ended = pyqtSignal()

    def __init__(self, description: str, work: Callable[[Callable[..., None], Callable[[], bool]], Any],
                 on_done: Optional[Callable[[TaskResult], None]] = None):
        super().__init__()
        self._description = description
        self._work = work
        self._on_done = on_done
        self._canceled = threading.Event()
        self._thread: Optional[threading.Thread] = None
        self.result: Optional[TaskResult] = None
        self._ended.connect(self._finished)  # emitted by the worker: queued to this object's (the main) thread

    def description(self) -> str:
        return self._description

    def isCanceled(self) -> bool:  # noqa: N802 (QgsTask's name)
        return self._canceled.is_set()

    def cancel(self) -> None:
        self._canceled.set()

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name=self._description, daemon=True)
        self._thread.start()

    def waitForFinished(self, timeout_ms: int = 30000) -> bool:  # noqa: N802 (QgsTask's name)
        """Block until the worker has ended (its ``on_done`` follows from the event loop); False on timeout."""
        if self._thread is None:
            return True
        self._thread.join(max(0, timeout_ms) / 1000.0)
        return not self._thread.is_alive()

    def _run(self) -> None:  # worker thread
        self.result = _run_work(self._work, self._report_progress, self.isCanceled)
        self._ended.emit()

    def _report_progress(self, fraction: float, message: str = "") -> None:
        self.progressChanged.emit(max(0.0, min(100.0, 100.0 * float(fraction))))

    def _finished(self) -> None:  # main thread
        if self in _LIVE:
            _LIVE.remove(self)
        result = self.result or TaskResult.canceled()
        _deliver(result, self._on_done)
        (self.taskCompleted if result.ok else self.taskTerminated).emit()

    def abandon(self) -> None:
        """Cancel, and deliver to nobody: see :func:`abandon`."""
        self.cancel()
        self._on_done = None
        for signal in (self.progressChanged, self.taskCompleted, self.taskTerminated):
            _disconnect_all(signal)


def _disconnect_all(signal) -> None:
    try:
        signal.disconnect()
    except (TypeError, RuntimeError):  # nothing connected; or the object is already deleted
        pass


def abandon(task) -> None:
    """The dock that started ``task`` (a :class:`FunctionTask` or :class:`HiddenTask`, or None) is going away: cancel
    it without waiting, drop its ``on_done`` and disconnect the signals it would send to the dock's objects. The work
    stops at its next ``is_canceled()`` check; nothing of it reaches a deleted widget. (Before, a fit ending after
    the plugin's unload called the deleted controller: a Python error in the log, and QGIS crashed 2 times in 22.)
    A task the QGIS task manager already deleted is skipped."""
    if task is None:
        return
    try:
        task.abandon()
    except RuntimeError:  # wrapped C++ object deleted: the task is over
        pass


def _wait_for_live_tasks() -> None:
    """QGIS is quitting: stop every hidden task and wait for the step it is in."""
    for task in list(_LIVE):
        task.cancel()
        task.waitForFinished(QUIT_WAIT_MS)


def start_task(task):
    """Start ``task``: a :class:`FunctionTask` goes to the QGIS task manager (progress appears in the status-bar
    task list), a :class:`HiddenTask` into its own thread. Keep a reference to the returned task until ``on_done``
    ran: Python must not collect it while it runs."""
    if isinstance(task, HiddenTask):
        _LIVE.append(task)
        if not _QUIT_HOOK:  # once per module (a plugin reload makes a new module, with its own list and hook)
            QgsApplication.instance().aboutToQuit.connect(_wait_for_live_tasks)
            _QUIT_HOOK.append(True)
        task.start()
    else:
        QgsApplication.taskManager().addTask(task)
    return task
