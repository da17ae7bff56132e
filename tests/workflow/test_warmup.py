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
            warmup.yield_to_work()  # the dock's first Suggest, while the warm-up is in its render step

    with pytest.raises(Canceled):
        warmup.warm_up(progress)
    assert steps == ["sight", "render"]  # stopped before the suggest and fit steps


def test_warm_up_runs_in_a_thread():
    out = {}
    thread = threading.Thread(target=lambda: out.update(warmup.warm_up()))
    thread.start()
    thread.join(300)
    assert set(out) == {"sight", "render", "suggest", "fit"}


def test_a_cancel_stops_the_wait_for_the_torch_import_not_the_import():
    """The fit's torch import, in a fresh Python: a cancel gives up the wait at once (an import itself cannot be
    interrupted) while the import goes on; the next fit finds torch and torch._dynamo imported."""
    import subprocess
    import sys

    code = (
        "import sys, threading\n"
        "from monoplot_plugin.workflow import warmup\n"
        "from monoplot_plugin.workflow.progress import Canceled\n"
        "assert 'torch' not in sys.modules\n"
        "try:\n"
        "    warmup.import_torch(lambda: True)\n"
        "except Canceled:\n"
        "    print('canceled', warmup._TORCH_READY.is_set(), flush=True)\n"
        "warmup.import_torch()\n"
        "print('ready', 'torch._dynamo' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["canceled", "False", "ready", "True"]
