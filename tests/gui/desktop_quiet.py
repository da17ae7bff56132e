"""Screenshots of issue 12's last desktop findings in the REAL QGIS desktop (Aletsch): the camera tab's lens row at a
narrow dock, the product buttons before and after a fit, the message bar after background refits, the "Monoplot"
tab of the Log Messages panel.

Not a pytest module: run with
``xvfb-run -a -s "-screen 0 1600x1000x24" qgis --nologo --noversioncheck --code tests/gui/desktop_quiet.py``
(MONOPLOT_REPO = the checkout, the venv's site-packages on PYTHONPATH, as tests/gui/run_desktop_aletsch.sh does;
MONOPLOT_DOCK_WIDTH: the dock's width, 580 by default). Writes test-artifacts/quiet_*.png and quiet_session.json.
"""

import os
import sys
import time

import qgis.utils
from qgis.core import QgsApplication, QgsCoordinateReferenceSystem, QgsProject, QgsRasterLayer
from qgis.PyQt.QtCore import Qt, QTimer
from qgis.PyQt.QtWidgets import QDockWidget, QLabel, QTabWidget, QToolButton

sys.path.insert(0, os.path.join(os.environ["MONOPLOT_REPO"], "tests", "gui"))
from desktop_kit import DATA, DesktopSession  # noqa: E402

WIDTH = int(os.environ.get("MONOPLOT_DOCK_WIDTH", "580"))
iface = qgis.utils.iface
session = DesktopSession("quiet", dock_width=WIDTH)
report, shot, finish, guarded = session.report, session.shot, session.finish, session.guarded
state = {}


def bar_texts():
    """The texts of the message bar's items now (title and text)."""
    return [" ".join(w.text() for w in item.findChildren(QLabel) if w.text())
            for item in iface.messageBar().items()]


@guarded
def step1():
    from monoplot_plugin import logging_bridge
    from monoplot_plugin.gui import io_actions
    from monoplot_plugin.gui.dock import MonoplotDock

    logging_bridge.install()  # the plugin's initGui does this
    win = iface.mainWindow()
    win.resize(1600, 1000)
    dem = QgsRasterLayer(str(DATA / "dem.tif"), "Aletsch DEM (25 m)")
    QgsProject.instance().addMapLayer(dem)
    QgsProject.instance().setCrs(QgsCoordinateReferenceSystem("EPSG:21781"))
    iface.mapCanvas().setExtent(dem.extent())
    dock = MonoplotDock(iface, win)
    iface.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, dock)
    win.resizeDocks([dock], [WIDTH], Qt.Orientation.Horizontal)
    dock.show()
    state["dock"] = dock
    dock.photoFile.setFilePath(str(DATA / "photo.jpg"))
    dock.demCombo.setLayer(dem)
    c = dock.controller
    io_actions.load_camera_file(c, str(DATA / "prior_pose.kml"))
    dock.stepTabs.setCurrentWidget(dock.cameraTab)
    dock.lens_panel.focal_spin.setValue(30.0)
    dock.lens_panel.sensor_spin.setValue(22.2)
    QgsApplication.processEvents()
    lens = dock.lens_panel
    report["dock_contents_width"] = dock.dockContents.width()
    report["lens"] = {name: [w.geometry().x(), w.geometry().right()] for name, w in
                      (("equivalent", lens.equivalent_check), ("apply", lens.apply_button))}
    shot("quiet_1_camera_tab.png")
    shot("quiet_1b_lens_row.png", dock.cameraTab)
    dock.stepTabs.setCurrentWidget(dock.fitTab)
    tools = dock.output_tools
    buttons = {b.defaultAction(): b for b in dock.findChildren(QToolButton) if b.defaultAction() is not None}
    report["before_fit"] = {n: [buttons[tools.actions[n]].isEnabled(), buttons[tools.actions[n]].toolTip()]
                            for n in ("xyz", "ortho", "report")}
    shot("quiet_2_fit_tab_before_fit.png")
    io_actions.import_points_csv(c, str(DATA / "gcps.csv"))
    c.state.pairs = []  # the unpaired case: what the background refit and a new user see
    dock.stepTabs.setCurrentWidget(dock.pointsTab)
    panel = dock.curation_panel
    state["refits"] = 0
    panel.refitter.refitted.connect(lambda outcome: state.__setitem__("refits", state["refits"] + 1))
    panel.refitter.schedule(force=True)
    state["t0"] = time.time()
    QTimer.singleShot(1000, step2)


@guarded
def step2():
    if state["refits"] < 1 and time.time() - state["t0"] < 120:
        QTimer.singleShot(1000, step2)
        return
    dock = state["dock"]
    report["refits"] = state["refits"]
    report["bar_after_refit"] = bar_texts()
    shot("quiet_3_after_background_refit.png")
    c = dock.controller
    dock.stepTabs.setCurrentWidget(dock.fitTab)
    state["t_fit"] = time.perf_counter()
    c.taskFinished.connect(step3)
    dock.fitButton.click()


@guarded
def step3(result):
    dock = state["dock"]
    c = dock.controller
    c.taskFinished.disconnect(step3)
    report["fit"] = {"click_to_overlay_s": round(time.perf_counter() - state["t_fit"], 2),
                     **{k: c.state.fit_info.get(k) for k in ("status", "rmse_px", "mode", "elapsed_s")}}
    tools = dock.output_tools
    buttons = {b.defaultAction(): b for b in dock.findChildren(QToolButton) if b.defaultAction() is not None}
    report["after_fit"] = {n: [buttons[tools.actions[n]].isEnabled(), buttons[tools.actions[n]].toolTip()]
                           for n in ("xyz", "ortho", "report")}
    QTimer.singleShot(1500, step4)


@guarded
def step4():
    shot("quiet_4_fit_tab_after_fit.png")
    report["bar_after_fit"] = bar_texts()
    # the Log Messages panel, tab "Monoplot"
    log_dock = next((d for d in iface.mainWindow().findChildren(QDockWidget) if d.objectName() == "MessageLog"),
                    None)
    if log_dock is not None:
        log_dock.show()
        log_dock.raise_()
        tabs = log_dock.findChild(QTabWidget)
        if tabs is not None:
            names = [tabs.tabText(i) for i in range(tabs.count())]
            report["log_tabs"] = names
            if "Monoplot" in names:
                tabs.setCurrentIndex(names.index("Monoplot"))
                page = tabs.widget(names.index("Monoplot"))
                text = page.toPlainText() if hasattr(page, "toPlainText") else ""
                report["monoplot_log_lines"] = len([t for t in text.splitlines() if t.strip()])
    QTimer.singleShot(500, step5)


@guarded
def step5():
    shot("quiet_5_log_panel.png")
    finish()


QTimer.singleShot(1000, step1)
