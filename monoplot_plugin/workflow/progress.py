"""The one progress protocol and the one cancel exception of the workflow (the core fit uses the same protocol).

- ``progress(fraction, message="")``: ``fraction`` in [0, 1] of the current step, ``message`` a short text or "".
- ``is_canceled() -> bool``: polled by long loops; a step that sees it true raises :class:`Canceled`.

The dock's task turns ``progress`` into its progress bar, a Processing algorithm into ``feedback.setProgress``; both
catch :class:`Canceled` (a clean stop, nothing written).

>>> seen = []
>>> half = part(lambda f, m="": seen.append(round(f, 2)), 0.5, 1.0)
>>> half(0.0); half(0.5); half(1.0)
>>> seen
[0.5, 0.75, 1.0]
>>> check_canceled(lambda: True)
Traceback (most recent call last):
...
monoplot_plugin.workflow.progress.Canceled: canceled
"""

from __future__ import annotations

import threading
from typing import Callable, Dict, Hashable, Optional

__all__ = ["Progress", "IsCanceled", "Canceled", "no_progress", "never_canceled", "part", "check_canceled",
           "SharedBar", "CallerThread"]

Progress = Callable[..., None]  # progress(fraction in [0, 1], message: str = "")
IsCanceled = Callable[[], bool]


class Canceled(Exception):
    """The user canceled: the step stopped and wrote nothing."""

    def __init__(self, message: str = "canceled"):
        super().__init__(message)


def no_progress(fraction: float, message: str = "") -> None:
    """A ``progress`` that shows nothing."""


def never_canceled() -> bool:
    return False


def part(progress: Optional[Progress], start: float, end: float) -> Progress:
    """A ``progress`` for a sub-step that fills ``[start, end]`` of ``progress`` (fractions, clipped to [0, 1])."""
    progress = progress or no_progress

    def sub(fraction: float, message: str = "") -> None:
        progress(start + (end - start) * max(0.0, min(1.0, float(fraction))), message)

    return sub


def check_canceled(is_canceled: Optional[IsCanceled]) -> None:
    """Raise :class:`Canceled` when ``is_canceled()`` says so."""
    if is_canceled is not None and is_canceled():
        raise Canceled()


class SharedBar:
    """One ``progress`` over ``total`` items worked on in parallel threads, ``done`` of them done before: an item
    under way counts with its own fraction, and the bar never goes back (items end out of order).

    >>> seen = []
    >>> bar = SharedBar(lambda f, m="": seen.append(round(f, 2)), 4)
    >>> bar.item("a", 0.5); bar.item("b", 0.5); bar.finished("a"); bar.forward(0.25); bar.item("b", 1.0)
    >>> seen
    [0.12, 0.25, 0.25, 0.5]
    """

    def __init__(self, progress: Optional[Progress], total: int, done: int = 0):
        self._progress = progress or no_progress
        self._total, self._done, self._shown = max(1, int(total)), int(done), 0.0
        self._under_way: Dict[Hashable, float] = {}
        self._lock = threading.Lock()

    def item(self, key: Hashable, fraction: float, message: str = "") -> None:
        """Item ``key`` is ``fraction`` done."""
        with self._lock:
            self._under_way[key] = max(0.0, min(1.0, float(fraction)))
            fraction = (self._done + sum(self._under_way.values())) / self._total
        self.forward(fraction, message)

    def finished(self, key: Hashable, counted: bool = True) -> None:
        """Item ``key`` ended; ``counted``: as work done (not an item canceled under way: a trial's bar went from
        3 % to 50 % on Cancel, the two rows under way counted as done)."""
        with self._lock:
            self._done += int(bool(counted))
            self._under_way.pop(key, None)

    def forward(self, fraction: float, message: str = "") -> None:
        """Show ``fraction`` of the whole, unless more was shown already."""
        with self._lock:
            self._shown = fraction = max(self._shown, float(fraction))
        self._progress(fraction, message)


class CallerThread:
    """A ``progress`` that calls ``progress`` only on the thread that made it: calls from other threads wait for
    :meth:`flush`, which that thread calls while it waits for them (the last fraction, and every message in order).

    Qt hands a signal emitted on another thread to the receiver's event loop; qgis_process runs an algorithm on its
    main thread with no event loop running, so a batch whose frames ran in worker threads showed no progress until
    it ended (a time-lapse trial in a terminal: nothing for 50-90 s a frame).

    >>> import threading
    >>> seen = []
    >>> relay = CallerThread(lambda f, m="": seen.append((f, m)))
    >>> worker = threading.Thread(target=lambda: (relay(0.2, "a"), relay(0.3), relay(0.4)))
    >>> worker.start(); worker.join()
    >>> seen
    []
    >>> relay.flush(); seen
    [(0.2, 'a'), (0.4, '')]
    >>> relay(0.5); seen[-1]
    (0.5, '')
    """

    def __init__(self, progress: Optional[Progress]):
        self._progress = progress or no_progress
        self._owner = threading.get_ident()
        self._waiting: list = []
        self._lock = threading.Lock()

    def __call__(self, fraction: float, message: str = "") -> None:
        if threading.get_ident() != self._owner:
            with self._lock:
                self._waiting.append((fraction, message))
            return
        self.flush()
        self._progress(fraction, message)

    def flush(self) -> None:
        """Pass on what other threads reported: each message, and the last fraction (on the owner's thread)."""
        with self._lock:
            waiting, self._waiting = self._waiting, []
        for i, (fraction, message) in enumerate(waiting):
            if message or i == len(waiting) - 1:
                self._progress(fraction, message)
