"""Runs inside QGIS (``qgis --code``) for test_desktop_crash_recovery.py: once the Monoplot dock is open (at most
60 s), writes what it shows to $MONOPLOT_CRASH_REPORT and quits. QGIS runs this only after its start is over: a
question asked while it started (a "save the project?") keeps it from ever running, and the test fails."""

import json
import os
import time

from qgis.PyQt.QtCore import QTimer
from qgis.PyQt.QtWidgets import QApplication, QDockWidget
from qgis.utils import iface

started = time.time()


def report():
    dock = iface.mainWindow().findChild(QDockWidget, "MonoplotDock")
    if (dock is None or not dock.isVisible()) and time.time() - started < 60:
        QTimer.singleShot(500, report)
        return
    from qgis.core import QgsProject

    status = "" if dock is None else dock.statusLabel.text() + " " + dock.statusLabel.toolTip()
    opacity = None if dock is None else dock.controller.state.settings.get("overlay_opacity")
    with open(os.environ["MONOPLOT_CRASH_REPORT"], "w", encoding="utf-8") as fh:
        json.dump({"dock_open": dock is not None and dock.isVisible(), "status": status, "overlay_opacity": opacity,
                   "modal": QApplication.activeModalWidget() is not None,
                   "project_modified": QgsProject.instance().isDirty()}, fh)
    iface.mainWindow().grab().save(os.environ["MONOPLOT_CRASH_REPORT"][:-len(".json")] + ".png")
    os._exit(0)


QTimer.singleShot(500, report)
