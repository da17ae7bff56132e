"""Latency of the dock on the real Aletsch case: one JSON line per measurement on stdout (part of ``make bench``).

Each scenario runs in a fresh Python process with its own QGIS application (offscreen), as a user's fresh QGIS
session would; numba's on-disk kernel cache is the checkout's (warm once compiled), unless ``--cold`` points it at
an empty folder (a first run after installing).

- ``first_suggest``: photo, DEM and KML camera loaded, then *Suggest points* (300 + 300) from the click to the
  suggestions applied. ``warmup``: "none" (no warm-up), "concurrent" (the plugin's warm-up task started with the
  session, the click right after the inputs are in), "done" (the click after the warm-up finished, e.g. while the
  user chose the photo). Target: <= 3 s.
- ``reopen_project``: a saved project with a fitted Aletsch camera is opened in a session whose dock is open:
  ``block_s`` is the longest the main thread stalled (a 10 ms timer's largest gap) until the overlay arrived,
  ``read_s`` the ``QgsProject.read`` call. Target: block <= 2 s.
- ``dock_fit``: the 11 GCPs imported with their surveyed Z, *Fit camera* (paired, and the same points unpaired) from
  the click to the overlay applied, with the core fit's own seconds (``core_fit_s``); ``unpaired_after_refit``: the
  same unpaired click after the background refit of these points finished (the dock reuses its fit and only
  renders); ``unpaired_during_refit``: the click 0.5 s after such a refit started (the person clicked Fit right
  after the last accept: the Fit waits for that refit rather than fit again). Target: <= 2 s.
- ``cancel_first_fit``: the first unpaired fit of a fresh session without warm-up (torch not yet imported),
  *Cancel* clicked 1 s after *Fit camera*: ``cancel_s`` from the Cancel to the task's end (an import cannot be
  interrupted: the fit must not be stuck in it).

    .venv/bin/python bench/bench_dock.py [--only dock_fit] [--cold]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ALETSCH = os.path.join(os.path.dirname(ROOT), "shared", "data", "aletsch")
SCENARIOS = ("first_suggest", "reopen_project", "dock_fit", "cancel_first_fit")


# --- in the child process ---------------------------------------------------------------------------------------
def _session():
    """A QGIS application, an interface stub and a Monoplot dock on the Aletsch DEM layer (fresh process)."""
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    sys.path.insert(0, ROOT)
    from qgis.core import QgsApplication, QgsProject, QgsRasterLayer

    app = QgsApplication([], True)
    app.initQgis()
    iface = _Iface()
    layer = QgsRasterLayer(os.path.join(ALETSCH, "dem.tif"), "Aletsch DEM")
    QgsProject.instance().addMapLayer(layer)
    return app, iface, layer


class _Iface:
    """What the dock uses of QGIS's interface: a real map canvas, message bar and main window; the rest no-ops."""

    def __init__(self):
        from qgis.gui import QgsMapCanvas, QgsMessageBar
        from qgis.PyQt.QtWidgets import QMainWindow, QStatusBar

        self._window = QMainWindow()
        self._canvas = QgsMapCanvas(self._window)
        self._bar = QgsMessageBar(self._window)
        self._status = QStatusBar(self._window)

    def mainWindow(self):  # noqa: N802
        return self._window

    def mapCanvas(self):  # noqa: N802
        return self._canvas

    def messageBar(self):  # noqa: N802
        return self._bar

    def statusBarIface(self):  # noqa: N802
        return self._status

    def __getattr__(self, name):
        return lambda *args, **kwargs: None


def _dock(iface):
    from monoplot_plugin.gui.dock import MonoplotDock

    dock = MonoplotDock(iface)
    dock.resize(600, 900)
    dock.show()
    return dock


def _wait(signal, timeout_s: float = 300.0):
    """Run the event loop until ``signal`` fires; returns its arguments."""
    from qgis.PyQt.QtCore import QEventLoop, QTimer

    loop, got = QEventLoop(), []
    signal.connect(lambda *args: (got.append(args), loop.quit()))
    QTimer.singleShot(int(timeout_s * 1000), loop.quit)
    loop.exec()
    return got[0] if got else None


class StallMeter:
    """The longest gap between the ticks of a 10 ms timer: how long the main thread was blocked."""

    def __init__(self):
        from qgis.PyQt.QtCore import QTimer

        self.last, self.worst = time.perf_counter(), 0.0
        self.timer = QTimer()
        self.timer.setInterval(10)
        self.timer.timeout.connect(self._tick)
        self.timer.start()

    def _tick(self):
        now = time.perf_counter()
        self.worst = max(self.worst, now - self.last)
        self.last = now

    def stop(self) -> float:
        self._tick()
        self.timer.stop()
        return self.worst


def _inputs(dock, layer):
    from monoplot_plugin.gui import io_actions

    c = dock.controller
    c.load_photo(os.path.join(ALETSCH, "photo.jpg"))
    c.set_dem_layer(layer)
    io_actions.load_camera_file(c, os.path.join(ALETSCH, "prior_pose.kml"))
    return c


def child_first_suggest(warmup: str) -> dict:
    t_start = time.perf_counter()
    app, iface, layer = _session()
    task, warm_s = None, None
    if warmup != "none":
        from monoplot_plugin.plugin import start_warm_up

        task = start_warm_up()
        if warmup == "done":
            _wait(task.taskCompleted)
            warm_s = time.perf_counter() - t_start
    dock = _dock(iface)
    c = _inputs(dock, layer)
    dock.suggestCountSpin.setValue(2000)  # the default, whatever the profile's preference
    t0 = time.perf_counter()
    dock.suggestButton.click()
    result = _wait(c.taskFinished)
    seconds = time.perf_counter() - t0
    ok = result is not None and result[0].ok
    return {"suggest_s": round(seconds, 3), "warmup_s": None if warm_s is None else round(warm_s, 2), "ok": ok,
            "n_points": len(c.state.points)}


def child_make_project(path: str) -> dict:
    app, iface, layer = _session()
    from monoplot_plugin.gui import io_actions
    from qgis.core import QgsProject

    dock = _dock(iface)
    c = _inputs(dock, layer)
    io_actions.import_points_csv(c, os.path.join(ALETSCH, "gcps.csv"))
    c.fit()
    _wait(c.taskFinished)
    assert c.fitted is not None
    c.save()
    assert QgsProject.instance().write(path)
    dock.unload()
    return {}


def child_reopen_project(path: str) -> dict:
    app, iface, layer = _session()
    from qgis.core import QgsProject

    QgsProject.instance().clear()
    dock = _dock(iface)
    c = dock.controller
    meter = StallMeter()
    t0 = time.perf_counter()
    assert QgsProject.instance().read(path)
    read_s = time.perf_counter() - t0
    if c.products_pending or c.overlay is None:
        _wait(c.productsReady)
    ready_s = time.perf_counter() - t0
    return {"block_s": round(meter.stop(), 3), "read_s": round(read_s, 3), "overlay_ready_s": round(ready_s, 3),
            "ok": c.overlay is not None and c.fitted is not None}


def child_dock_fit(warmup: str) -> list:
    app, iface, layer = _session()
    if warmup == "done":
        from monoplot_plugin.plugin import start_warm_up

        _wait(start_warm_up().taskCompleted)
    from monoplot_plugin.gui import io_actions

    dock = _dock(iface)
    c = _inputs(dock, layer)
    io_actions.import_points_csv(c, os.path.join(ALETSCH, "gcps.csv"))
    out = []
    refitter = dock.curation_panel.refitter
    for mode in ("paired", "unpaired", "unpaired_during_refit", "unpaired_after_refit"):
        if mode == "unpaired":
            c.state.pairs = []
        if mode == "unpaired_during_refit":  # the person clicked Fit right after the last accept
            refitter.schedule(force=True)
            _wait(refitter.running)
            _pause(0.5)
        if mode == "unpaired_after_refit":  # the person paused after the last accept: the refit ran meanwhile
            refitter.schedule(force=True)
            _wait(refitter.refitted)
        meter = StallMeter()
        t0 = time.perf_counter()
        dock.fitButton.click()
        result = _wait(c.taskFinished)
        seconds = time.perf_counter() - t0
        info = c.state.fit_info
        out.append({"mode": mode, "click_to_overlay_s": round(seconds, 3), "block_s": round(meter.stop(), 3),
                    "core_fit_s": round(float(info.get("elapsed_s", float("nan"))), 3),
                    "rmse_px": info.get("rmse_px"), "ok": bool(result and result[0].ok and c.overlay is not None)})
    return out


def _pause(seconds: float) -> None:
    """Run the event loop for ``seconds``."""
    from qgis.PyQt.QtCore import QEventLoop, QTimer

    loop = QEventLoop()
    QTimer.singleShot(int(seconds * 1000), loop.quit)
    loop.exec()


def child_cancel_first_fit() -> dict:
    app, iface, layer = _session()
    from monoplot_plugin.gui import io_actions

    dock = _dock(iface)
    c = _inputs(dock, layer)
    dock.curation_panel.refitCheck.setChecked(False)  # only the Fit button's fit
    io_actions.import_points_csv(c, os.path.join(ALETSCH, "gcps.csv"))
    c.state.pairs = []
    torch_before = "torch" in sys.modules
    dock.fitButton.click()
    _pause(1.0)
    t0 = time.perf_counter()
    dock.cancelButton.click()
    result = _wait(c.taskFinished)
    return {"cancel_s": round(time.perf_counter() - t0, 3), "status": result[0].status if result else None,
            "torch_imported_before": torch_before}


# --- the parent: one fresh process per scenario -----------------------------------------------------------------
def _run_child(args, env) -> object:
    proc = subprocess.run([sys.executable, os.path.abspath(__file__), "--child"] + args, capture_output=True,
                          text=True, env=env, cwd=ROOT, timeout=1200)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("@@")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"bench child {args} failed ({proc.returncode}): {proc.stderr[-2000:]}")
    return json.loads(lines[-1][2:])


def _load() -> str:
    try:
        return " ".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        return ""


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", choices=SCENARIOS)
    parser.add_argument("--cold", action="store_true", help="an empty numba cache (a first run after installing)")
    parser.add_argument("--child", nargs="+", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        name, *rest = args.child
        value = {"first_suggest": lambda: child_first_suggest(*rest), "make_project": lambda: child_make_project(*rest),
                 "reopen_project": lambda: child_reopen_project(*rest), "dock_fit": lambda: child_dock_fit(*rest),
                 "cancel_first_fit": lambda: child_cancel_first_fit(*rest)}[name]()
        print("@@" + json.dumps(value), flush=True)
        os._exit(0)  # QGIS's exit handlers are slow and irrelevant here
    if not os.path.isdir(ALETSCH):
        print(f"Aletsch data not found at {ALETSCH}", file=sys.stderr)
        return 1
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen")
    if args.cold:
        env["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="monoplot-bench-numba-")
    cache = "cold" if args.cold else "warm"
    todo = [args.only] if args.only else list(SCENARIOS)
    if "first_suggest" in todo:
        for warmup in ("none", "concurrent", "done"):
            value = _run_child(["first_suggest", warmup], env)
            print(json.dumps({"bench": "dock_first_suggest", "warmup": warmup, "numba_cache": cache, **value,
                              "target_s": 3.0, "load": _load()}), flush=True)
    if "reopen_project" in todo:
        path = os.path.join(tempfile.mkdtemp(prefix="monoplot-bench-"), "aletsch.qgz")
        _run_child(["make_project", path], env)
        value = _run_child(["reopen_project", path], env)
        print(json.dumps({"bench": "dock_reopen_project", "numba_cache": cache, **value, "target_block_s": 2.0,
                          "load": _load()}), flush=True)
    if "dock_fit" in todo:
        for warmup in ("none", "done"):
            for value in _run_child(["dock_fit", warmup], env):
                print(json.dumps({"bench": "dock_fit_aletsch", "warmup": warmup, "numba_cache": cache, **value,
                                  "target_s": 2.0, "load": _load()}), flush=True)
    if "cancel_first_fit" in todo:
        value = _run_child(["cancel_first_fit"], env)
        print(json.dumps({"bench": "dock_cancel_first_fit", "numba_cache": cache, **value, "target_s": 1.0,
                          "load": _load()}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
