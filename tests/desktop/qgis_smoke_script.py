"""Run INSIDE real QGIS (``qgis --code``) by test_desktop_smoke.py; not a pytest module.

Enables the plugin, checks its toolbar/menu entries, opens the dock, lets the background warm-up run to its end
(every kernel compiled in the desktop's own process), reloads the plugin, opens the dock again, saves a screenshot and
a JSON report (``MONOPLOT_SMOKE_OUT``), then quits QGIS. A watchdog ends QGIS if anything stalls.
"""

import json
import os
import time
import traceback
from pathlib import Path

import qgis.utils
from qgis.core import Qgis, QgsApplication
from qgis.PyQt.QtCore import QEvent, QTimer
from qgis.PyQt.QtWidgets import QAction, QDockWidget

OUT = Path(os.environ["MONOPLOT_SMOKE_OUT"])
NAME = os.environ.get("MONOPLOT_SMOKE_NAME", "desktop_smoke")
PLUGIN = "monoplot"
iface = qgis.utils.iface
report = {"log": [], "python_errors": [], "steps": [], "script_error": None}


def on_message(message, tag, level):
    # a traceback's cause is its last line: keep the head and the tail of a long one
    entry = {"tag": tag, "level": int(level),
             "message": message if len(message) <= 4000 else message[:1000] + "\n[...]\n" + message[-3000:]}
    report["log"].append(entry)
    if tag == "Python error" or (tag == "Monoplot" and level == Qgis.MessageLevel.Critical):
        report["python_errors"].append(entry)


QgsApplication.messageLog().messageReceived.connect(on_message)


def counts():
    window = iface.mainWindow()
    raster_menu_actions = [a for a in iface.rasterMenu().actions() if a.menu() is not None
                           and a.menu().title() == "&Monoplot"]
    return {
        "actions": len(window.findChildren(QAction, "MonoplotAction")),
        "docks": len(window.findChildren(QDockWidget, "MonoplotDock")),
        "raster_menu_entries": sum(len(a.menu().actions()) for a in raster_menu_actions),
        "toolbar_entries": sum(a.objectName() == "MonoplotAction" and a.isVisible()
                               for a in iface.pluginToolBar().actions()),
    }


def step(name, function):
    def run():
        try:
            report["steps"].append({"step": name, **(function() or {})})
        except Exception:  # noqa: BLE001 — reported in the JSON, the test fails on it
            report["script_error"] = traceback.format_exc()
            finish()
    return run


def enable():
    loaded = qgis.utils.loadPlugin(PLUGIN)
    started = qgis.utils.startPlugin(PLUGIN)
    return {"loaded": bool(loaded), "started": bool(started), **counts()}


def open_dock():
    iface.mainWindow().findChild(QAction, "MonoplotAction").trigger()
    dock = iface.mainWindow().findChild(QDockWidget, "MonoplotDock")
    return {"dock_visible": bool(dock and dock.isVisible()), **counts()}


def reload_plugin():
    qgis.utils.reloadPlugin(PLUGIN)
    QgsApplication.sendPostedEvents(None, QEvent.Type.DeferredDelete)  # unload() used deleteLater()
    QgsApplication.processEvents()
    return counts()


def finish():
    try:
        QgsApplication.processEvents()
        report["active_plugins"] = list(qgis.utils.active_plugins)
        report["qgis_version"] = Qgis.QGIS_VERSION
        processing = QgsApplication.processingRegistry()
        report["processing_providers"] = [p.id() for p in processing.providers()]
        report["message_bar"] = [item.text() for item in iface.messageBar().items()]
        iface.mainWindow().grab().save(str(OUT / f"{NAME}.png"))
    except Exception:  # noqa: BLE001
        report["script_error"] = (report["script_error"] or "") + traceback.format_exc()
    (OUT / f"{NAME}.json").write_text(json.dumps(report, indent=1))
    QTimer.singleShot(500, iface.actionExit().trigger)


#: seconds the warm-up may take: it compiles every numba kernel cold (the plugin is unpacked afresh), 60-80 s here
WARM_UP_WAIT_S = 170.0
_warm_up = {"since": None}


def wait_for_warm_up():
    """The first plugin instance's warm-up, waited for without blocking the event loop: compiling one of its kernels
    (the photo's skyline) in the warm-up thread crashed the QGIS 3.40 desktop, which quit too soon to show it."""
    if _warm_up["since"] is None:
        _warm_up["since"] = time.monotonic()
    task = getattr(qgis.utils.plugins.get(PLUGIN), "warmup_task", None)
    result = getattr(task, "result", None)
    waited = time.monotonic() - _warm_up["since"]
    # none after 10 s: none is started (packages missing: the plugin only says what to install)
    if result is None and waited < (WARM_UP_WAIT_S if task is not None else 10.0) and report["script_error"] is None:
        QTimer.singleShot(500, wait_for_warm_up)
        return
    report["warm_up"] = {"started": task is not None, "waited_s": round(waited, 1),
                         "status": getattr(result, "status", None),
                         "steps": sorted(result.value) if result is not None and result.ok else []}
    run_steps()


QTimer.singleShot(int(WARM_UP_WAIT_S * 1000) + 60_000, lambda: os._exit(3))  # watchdog: never hang CI
iface.mainWindow().resize(1600, 1000)
# Each step starts a while after the one before has ended, not at a fixed time: the reload waits for the warm-up's
# kernel compile (plugin.unload), and its processEvents() would otherwise run the later steps inside it.
STEPS = [(1000, step("enable", enable)), (1500, step("open_dock", open_dock)), (500, wait_for_warm_up),
         (1500, step("reload", reload_plugin)), (1500, step("open_dock_after_reload", open_dock)), (2500, finish)]


def run_steps():
    if STEPS and report["script_error"] is None:
        delay, function = STEPS.pop(0)
        if function is wait_for_warm_up:  # it goes on with the next steps itself, once the warm-up has ended
            QTimer.singleShot(delay, function)
        else:
            QTimer.singleShot(delay, lambda: (function(), run_steps()))


run_steps()
