"""The warm-up step by step: it runs every kernel once, and real work makes it stop after its step."""

import threading

import pytest

from monoplot_plugin.workflow import warmup
from monoplot_plugin.workflow.progress import Canceled


def test_real_work_stops_a_running_warm_up():
    steps = []

    def progress(fraction, message=""):
        steps.append(message)
        if message == "render":
            warmup.yield_to_work()  # the dock's first Suggest, while the warm-up is in its first step

    with pytest.raises(Canceled):
        warmup.warm_up(progress)
    assert steps == ["render"]  # stopped before the suggest and fit steps


def test_warm_up_runs_in_a_thread():
    out = {}
    thread = threading.Thread(target=lambda: out.update(warmup.warm_up()))
    thread.start()
    thread.join(300)
    assert set(out) == {"render", "suggest", "fit"}
