"""Screenshots of the dock at the width QGIS gives it when opened from the toolbar (~390 px) in the REAL desktop
(Aletsch): each tab, the "Above ground" box after a KML, the fit settings with the camera height mode, a summary.

Not a pytest module: run with
``xvfb-run -a -s "-screen 0 1600x1000x24" qgis --nologo --noversioncheck --code tests/gui/desktop_narrow.py``
(MONOPLOT_REPO = the checkout, the venv's site-packages on PYTHONPATH, as tests/gui/run_desktop_aletsch.sh does;
MONOPLOT_DOCK_WIDTH: 390 by default). Writes test-artifacts/narrow_*.png and narrow_session.json.
"""

import os
import sys
import traceback

import qgis.utils
from qgis.core import QgsApplication, QgsCoordinateReferenceSystem, QgsProject, QgsRasterLayer
from qgis.PyQt.QtCore import Qt, QTimer

sys.path.insert(0, os.path.join(os.environ["MONOPLOT_REPO"], "tests", "gui"))
from desktop_kit import DATA, DesktopSession  # noqa: E402

WIDTH = int(os.environ.get("MONOPLOT_DOCK_WIDTH", "390"))
iface = qgis.utils.iface
session = DesktopSession("narrow", dock_width=WIDTH)
report, shot, finish, guarded = session.report, session.shot, session.finish, session.guarded


def widths(layout):
    """Minimum width of each item of a layout (what makes a tab wider than the dock)."""
    out = []
    for i in range(layout.count()):
        item = layout.itemAt(i)
        w = item.widget()
        name = (w.objectName() or type(w).__name__) if w is not None else "layout " + (item.layout().objectName()
                                                                                       if item.layout() else "")
        out.append([name, item.minimumSize().width()])
    return out


def run():
    try:
        from monoplot_plugin.core.camera import Camera  # noqa: F401
        from monoplot_plugin.gui import io_actions
        from monoplot_plugin.gui.dock import MonoplotDock
        from monoplot_plugin.gui.summary import fit_summary_html

        win = iface.mainWindow()
        win.resize(1600, 1000)
        dem = QgsRasterLayer(str(DATA / "dem.tif"), "Aletsch DEM (25 m)")
        QgsProject.instance().addMapLayer(dem)
        QgsProject.instance().setCrs(QgsCoordinateReferenceSystem("EPSG:21781"))
        dock = MonoplotDock(iface, win)
        iface.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, dock)
        win.resizeDocks([dock], [WIDTH], Qt.Orientation.Horizontal)
        dock.show()
        dock.photoFile.setFilePath(str(DATA / "photo.jpg"))
        dock.demCombo.setLayer(dem)
        c = dock.controller
        io_actions.load_camera_file(c, str(DATA / "prior_pose.kml"))
        QgsApplication.processEvents()
        report["dock_actual_width"] = dock.width()
        report["above_ground_after_kml"] = dock.heightSpin.value()
        dock.stepTabs.setCurrentWidget(dock.cameraTab)
        shot("narrow_1_camera.png")
        dock.stepTabs.setCurrentWidget(dock.pointsTab)
        shot("narrow_2_points.png")
        dock.stepTabs.setCurrentWidget(dock.fitTab)
        dock.fit_settings.setCollapsed(False)
        c.state.fitted = c.prior.to_dict()  # a summary to look at (the prior as if fitted, an uncertain verdict)
        c.state.fit_info = {"status": "uncertain", "mode": "unpaired", "rmse_px": 6.4, "n_photo": 70, "n_map": 66,
                            "message": "Uncertain: the automatic pairs agree, but few of them cover the left "
                                       "half of the photo; add points there or mark check points.",
                            "sigma": {"x": 7.2, "y": 0.31, "z": 2.0, "heading": 0.04, "pitch": 0.2, "roll": 0.1,
                                      "fov": 0.3}}
        dock.resultLabel.setText(fit_summary_html(c.fitted, c.state.fit_info, dock.tr))
        shot("narrow_3_fit.png")
        dock.fitScroll.verticalScrollBar().setValue(dock.fitScroll.verticalScrollBar().maximum()) \
            if hasattr(dock, "fitScroll") else None
        shot("narrow_4_fit_scrolled.png")
        report["hscroll"] = {name: [s.horizontalScrollBar().isVisible(), s.horizontalScrollBar().maximum()]
                             for name, s in (("fit", getattr(dock, "fitScroll", None)),
                                             ("points", getattr(dock, "pointsScroll", None))) if s is not None}
        report["min_widths"] = {tab: widths(getattr(dock, tab)) for tab in ("cameraTabLayout", "fitTabLayout")}
        report["min_widths"]["contents"] = dock.dockContents.minimumSizeHint().width()
        report["min_widths"]["fit_page"] = dock.fitScrollContents.minimumSizeHint().width()
    except Exception:  # noqa: BLE001
        report["errors"].append(traceback.format_exc())
        print(traceback.format_exc(), flush=True)
    finish()


QTimer.singleShot(1500, run)
