"""The batch's threads: frames processed a few at a time, results in order, and one job in the background.

- :func:`threaded`: ``work`` on every task, ``workers`` at a time, results in task order; the waiting thread calls
  ``waiting()`` between short waits (the progress of the frames' threads is passed on there,
  :class:`~.progress.CallerThread`).
- :class:`Background`: one function in a thread (the shared XYZ raster written while the frames run).
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor, TimeoutError as FutureTimeout
from typing import Callable, Iterable, List, Optional

from .frames import FrameTask, PhotoResult
from .progress import IsCanceled

__all__ = ["threaded", "Background"]


def threaded(tasks: List[FrameTask], work: Callable[[FrameTask], PhotoResult], workers: Optional[int],
             is_canceled: IsCanceled, waiting: Callable[[], None] = lambda: None) -> Iterable[Optional[PhotoResult]]:
    """Results of ``work`` on every task, in task order, ``workers`` at a time (one: in this thread, strictly one
    after the other); a task that has not started when ``is_canceled()`` turns true comes back None (canceled).
    ``waiting()`` is called every quarter of a second while this thread waits for a result."""
    workers = max(1, workers or os.cpu_count() or 1)
    if workers == 1:
        for task in tasks:
            yield None if is_canceled() else work(task)
        return

    def guarded(task):
        return None if is_canceled() else work(task)

    window = 2 * workers  # frames in flight: the decoded photos and products held at once stay few
    with ThreadPoolExecutor(max_workers=workers, thread_name_prefix="monoplot-batch") as pool:
        pending = []
        for task in tasks:
            pending.append(pool.submit(guarded, task))
            if len(pending) > window:
                yield _result(pending.pop(0), waiting)
        for future in pending:
            yield _result(future, waiting)


def _result(future, waiting: Callable[[], None]):
    while True:
        try:
            return future.result(timeout=0.25)
        except FutureTimeout:
            waiting()


class Background:
    """``function(*args)`` in a thread; :meth:`wait` returns the exception it raised, or None."""

    def __init__(self, function, *args):
        self.error = None

        def run():
            try:
                function(*args)
            except Exception as exc:  # reported by the caller after the frames
                self.error = exc

        self.thread = threading.Thread(target=run, name="monoplot-shared-xyz", daemon=True)
        self.thread.start()

    def wait(self):
        self.thread.join()
        return self.error
