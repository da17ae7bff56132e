"""The background refit while the person clicks: debounced, cancelable, one silent task at a time.

Every change of the accepted points restarts a short timer; when it fires, the accepted points, the start camera
and the suggestions are copied on the main thread, and a :class:`~monoplot_plugin.gui.tasks.HiddenTask` runs the
one fit step (:func:`workflow.fit.fit`) and the camera's :func:`~monoplot_plugin.gui.shortlist.recommendation`
(agreement, likely pairs) in the background. A newer change cancels the running refit and starts again after it.
The result (:class:`RefitOutcome`) re-ranks the suggestions and flags the outliers; it never replaces the camera
of the Fit button.
"""

from __future__ import annotations

import logging
import math
import threading
from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np
from qgis.PyQt.QtCore import QObject, QTimer, pyqtSignal

from ..workflow.mixed import fit_accepted
from ..workflow.auto import cap_by_automatic
from ..workflow.progress import check_canceled
from .fit_settings import fit_arguments, height_arguments
from .shortlist import Recommendation, recommendation
from .tasks import HiddenTask, abandon, start_task

__all__ = ["Refitter", "RefitOutcome", "RunningFit", "sigma_of"]

LOG = logging.getLogger(__name__)

#: statuses of a refit good enough to re-rank by
USABLE = ("ok", "uncertain")


@dataclass
class RefitOutcome:
    camera: object
    status: str
    rmse_px: float
    sigma: float
    outlier_ids: List[str] = field(default_factory=list)
    rec: Optional[Recommendation] = None
    seconds: float = 0.0
    n_photo: int = 0  # accepted photo points the refit used
    key: tuple = ()  # :func:`inputs_key` of the fit
    done: object = None  # the workflow's FitDone (the Fit button reuses it for the same inputs)
    judged_with: tuple = ()  # (DEM points, fit options, check points): what the Fit button's verdict also weighs


class RunningFit:
    """A background refit under way, of inputs ``key`` (:func:`inputs_key`): the Fit button, clicked for the same
    inputs, waits for it (:meth:`wait`) instead of cancelling it and fitting them again from the start."""

    def __init__(self, key: tuple):
        self.key = key
        self.done = None
        self._ended = threading.Event()

    @property
    def ended(self) -> bool:
        return self._ended.is_set()

    def end(self, done=None) -> None:
        """The refit ended: ``done`` its workflow ``FitDone``, None when it was canceled or failed (the first call
        counts)."""
        if not self._ended.is_set():
            self.done = done
            self._ended.set()

    def wait(self, is_canceled=None, poll_s: float = 0.05):
        """The refit's ``FitDone`` once it has ended (None: canceled or failed); ``Canceled`` when
        ``is_canceled()`` turns true first."""
        while not self._ended.wait(poll_s):
            check_canceled(is_canceled)
        return self.done


def inputs_key(uv, xyz, pairs, start, free, options, check_uv, check_xyz) -> tuple:
    """What a fit depends on, comparable: two fits of equal keys give the same camera (``options``: anything with
    a stable repr, e.g. the FitOptions and the height mode).

    >>> a = inputs_key(np.zeros((4, 2)), np.ones((4, 3)), [], None, None, None, np.zeros((0, 2)), np.zeros((0, 3)))
    >>> a == inputs_key(np.zeros((4, 2)), np.ones((4, 3)), (), None, None, None, np.zeros((0, 2)), np.zeros((0, 3)))
    True
    """
    def arr(a):
        a = np.ascontiguousarray(a, dtype=np.float64)
        return a.shape, a.tobytes()

    cam = None if start is None else repr(sorted(start.to_dict().items()))
    return (arr(uv), arr(xyz), tuple(map(tuple, pairs or ())), cam, None if free is None else tuple(free),
            repr(options), arr(check_uv), arr(check_xyz))


def sigma_of(rmse_px: float, loo_px: float = math.nan, check_px: float = math.nan, n_check: int = 0) -> float:
    """How far (px) a partner may be under a fitted camera: twice the worst of its RMSE, its leave-one-out error
    and its check points' RMSE (at least 4 px; 25 px when none is known); with
    :data:`~..workflow.features.CHECKS_OVER_SIGMA` check points or more, twice what they vouch for alone
    (:func:`~..workflow.features.pixel_error`: a flood trial's leave-one-out of 27.7 px, from near pairs that each
    steer the camera alone, kept "Accept likely" off at ± 55 px where its 4 check points said 4.2 px). A new
    suggestion's partner is off by the camera's error at a point it was not fitted to, which its own RMSE
    understates (synthetic scenes, 5 points: RMSE 0.3 px, leave-one-out 5.1 px, the camera 3 px off; with sigma from
    the RMSE alone, 34 of 242 linked pairs were over 10 px wrong).

    >>> sigma_of(3.0), sigma_of(float("nan")), sigma_of(1.0, loo_px=5.0), sigma_of(1.0, check_px=9.0, n_check=1)
    (6.0, 25.0, 10.0, 18.0)
    >>> round(sigma_of(2.3, loo_px=27.7, check_px=4.2, n_check=4), 1)
    14.4
    """
    from ..workflow.features import checks_measure

    measured = checks_measure(check_px, n_check)
    if measured is not None:
        return max(4.0, 2.0 * measured)
    known = [float(x) for x in (rmse_px, loo_px, check_px) if x is not None and math.isfinite(float(x))]
    return max(4.0, 2.0 * max(known)) if known else 25.0


class Refitter(QObject):
    """Signals: ``refitted(RefitOutcome)`` on the main thread; ``running(bool)``; ``unavailable()``: the accepted
    points can no longer be refitted (too few, e.g. after an Undo), so an earlier refit's camera is stale."""

    refitted = pyqtSignal(object)
    running = pyqtSignal(bool)
    unavailable = pyqtSignal()

    def __init__(self, controller, delay_ms: int = 600, parent=None):
        super().__init__(parent)
        self.c = controller
        self.enabled = True
        self.task: Optional[HiddenTask] = None
        self._again = False
        self._key = None
        self.current: Optional[RunningFit] = None  # the refit under way, or the last one
        self._timer = QTimer(self)
        self._timer.setSingleShot(True)
        self._timer.setInterval(delay_ms)
        self._timer.timeout.connect(self._run)

    def accepted_key(self):
        sl = self.c.shortlist
        return frozenset(pid for space in sl.decided.values() for pid, st in space.items() if st == "accepted")

    def schedule(self, force: bool = False) -> None:
        """Refit soon if the accepted points changed since the last refit (or ``force``)."""
        if not self.enabled:
            return
        key = self.accepted_key()
        if force or key != self._key:
            self._timer.start()

    def adopt_fit(self, accepted_key) -> None:
        """The Fit button has just fitted the accepted points of ``accepted_key``: no refit of the same points
        (it would repeat the fit, with a second progress bar); a later change refits as usual. A change made
        while the fit ran (a pending or running refit) is left to refit."""
        if self._timer.isActive() or self.task is not None:
            return
        self._key = accepted_key

    def running_fit(self, key: tuple) -> Optional[RunningFit]:
        """The refit of inputs ``key`` (:func:`inputs_key`) under way, or just ended with a fit whose result has not
        reached the main thread yet, for the Fit button to wait for; else None."""
        r = self.current
        if r is None or r.key != key:
            return None
        return r if (r.done is not None if r.ended else self.task is not None) else None

    def cancel(self) -> None:
        """Stop the pending and the running refit."""
        self._timer.stop()
        self._again = False
        if self.task is not None:
            self.task.cancel()

    def abandon(self) -> None:
        """The dock is going away: stop the pending refit and cut the running one loose (:func:`.tasks.abandon`); a
        Fit waiting for it goes on by itself."""
        self.cancel()
        if self.current is not None and not self.current.ended:
            self.current.end(None)
        abandon(self.task)
        self.task = None

    def _run(self) -> None:
        if self.task is not None:  # a newer change: stop the running refit, start again when it ends
            self._again = True
            self.task.cancel()
            return
        c = self.c
        start = c.fit_start()
        if start is None or c.dem is None or c.image is None or c.task_kind == "fit":
            return  # (the Fit button's fit is running: its result re-ranks, and it must not share the cores)
        inputs = c.fit_inputs()
        if isinstance(inputs, str):
            self._key = self.accepted_key()
            self.unavailable.emit()
            return
        self._key = self.accepted_key()
        uv, xyz, pairs = inputs
        photo_ids = list(c._fit_ids[0])
        snapshot = c.shortlist.snapshot()
        threshold = c.shortlist.threshold
        dem = c.dem
        free, options = fit_arguments(c.state.settings)  # what the user fixed, how sure the prior is
        height = height_arguments(c.state.settings)  # on the ground / in the air / automatic
        _, check_uv, check_xyz = c.check_points()  # measured as the Fit button does: its fit can reuse this one
        # the automatic registration's verdict caps a refit on its own points alone (as it caps the Fit button's)
        labels = [c.state.points[i].label for i in photo_ids + list(c._fit_ids[1]) if i in c.state.points]
        automatic = str(c.state.settings.get("automatic_status") or "")
        key = inputs_key(uv, xyz, pairs, start, free, (options, height), check_uv, check_xyz)

        running = RunningFit(key)

        def work(progress, is_canceled):
            done = None
            try:
                done = fit_accepted(uv, xyz, start, dem, pairs=pairs or None, progress=progress, check_uv=check_uv,
                                    check_xyz=check_xyz, is_canceled=is_canceled, free=free, options=options,
                                    **height)
            finally:
                running.end(done)  # a Fit button waiting for this refit goes on at once (None: fit itself)
            r = done.result
            status, _ = cap_by_automatic(r.status, "", labels, len(pairs), len(check_uv), automatic)
            rmse = float(r.rmse_px) if r.rmse_px is not None else float("nan")
            sigma = sigma_of(rmse, r.loo_rmse_px, r.check_rmse_px, len(check_uv))
            rec = recommendation(done.camera, *snapshot, sigma, threshold) if status in USABLE else None
            flags = np.asarray(r.photo_outliers, dtype=bool).reshape(-1)
            outliers = [pid for pid, f in zip(photo_ids, flags) if f] if len(flags) == len(photo_ids) else []
            return RefitOutcome(done.camera, status, rmse, sigma, outliers, rec, float(r.elapsed_s), len(uv),
                                key, done, (xyz, options, len(check_uv)))

        self.task = HiddenTask("Monoplot refit", work, self._done)  # silent: no status-bar entry, no "Task complete"
        self.current = running
        self.running.emit(True)
        start_task(self.task)

    def _done(self, result) -> None:
        self.task = None
        if self.current is not None:
            self.current.end(None)  # (ended already when the fit ran; this covers a refit stopped before it)
        self.running.emit(False)
        if result.ok:
            o = result.value
            if o.status == "ok" and o.judged_with:
                # the Fit button's own doubt too: an "ok" refit beside an "uncertain" Fit of the same points read
                # as a contradiction (a re-check trial: "refit, 5.8 px (ok)", then Fit "uncertain" at 5.9 px)
                xyz, options, n_check = o.judged_with
                info = {"status": "ok", "n_check": n_check, **self.c.moved_from_prior(o.camera, xyz, options)}
                self.c.doubt_a_moved_camera(info)
                o.status = info["status"]
            LOG.info("Background refit on %d photo points: status %s, RMSE %.2f px, %d outlier(s), %.2f s",
                     o.n_photo, o.status, o.rmse_px, len(o.outlier_ids), o.seconds)
            self.c.remember_fit(o.key, o.done)
            self.refitted.emit(result.value)
        else:
            self._key = None  # canceled or refused: the same points may be tried again
        if self._again:
            self._again = False
            self._timer.start()
