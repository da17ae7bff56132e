"""Screenshots of the dock's default layout in the REAL desktop (Aletsch, 1600 x 1000 screen): photo, DEM, KML prior
and suggestions loaded, a photo suggestion selected (its chips on show). Reports how many table rows are visible and
the part of the photo canvas the chips cover.

Not a pytest module: run with
``xvfb-run -a -s "-screen 0 1600x1000x24" qgis --nologo --noversioncheck --code tests/gui/desktop_layout.py``
(MONOPLOT_REPO = the checkout, the venv's site-packages on PYTHONPATH, as tests/gui/run_desktop_aletsch.sh does;
MONOPLOT_DOCK_WIDTH: 560 by default). Writes test-artifacts/layout_*.png and layout_session.json.
"""

import os
import sys

import qgis.utils
from qgis.core import QgsCoordinateReferenceSystem, QgsProject, QgsRasterLayer
from qgis.PyQt.QtCore import Qt, QTimer

sys.path.insert(0, os.path.join(os.environ["MONOPLOT_REPO"], "tests", "gui"))
from desktop_kit import DATA, DesktopSession  # noqa: E402

WIDTH = int(os.environ.get("MONOPLOT_DOCK_WIDTH", "560"))
iface = qgis.utils.iface
session = DesktopSession("layout", dock_width=WIDTH)
report, shot, finish, guarded = session.report, session.shot, session.finish, session.guarded
state = {}


@guarded
def start():
    from monoplot_plugin.gui import io_actions
    from monoplot_plugin.gui.dock import MonoplotDock

    win = iface.mainWindow()
    win.resize(1600, 1000)
    dem = QgsRasterLayer(str(DATA / "dem.tif"), "Aletsch DEM (25 m)")
    QgsProject.instance().addMapLayer(dem)
    QgsProject.instance().setCrs(QgsCoordinateReferenceSystem("EPSG:21781"))
    dock = MonoplotDock(iface, win)
    iface.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, dock)
    win.resizeDocks([dock], [WIDTH], Qt.Orientation.Horizontal)
    dock.show()
    state["dock"] = dock
    dock.photoFile.setFilePath(str(DATA / "photo.jpg"))
    dock.demCombo.setLayer(dem)
    c = dock.controller
    io_actions.load_camera_file(c, str(DATA / "prior_pose.kml"))
    dock.stepTabs.setCurrentWidget(dock.pointsTab)
    c.taskFinished.connect(suggested)
    dock.suggestCountSpin.setValue(300)
    dock.suggestButton.click()


@guarded
def suggested(result):
    from monoplot_plugin.state import PHOTO

    if not result.ok:
        raise RuntimeError(f"suggest failed: {result.status} {result.reason}")
    dock = state["dock"]
    dock.controller.step(PHOTO, 1, only_suggested=True)  # what N does: a photo suggestion selected, chips shown
    QTimer.singleShot(2500, measure)


@guarded
def measure():
    dock = state["dock"]
    table = dock.pointTable
    rows = table.verticalHeader().defaultSectionSize()
    canvas = dock.photo_canvas
    chips = dock.chips
    report["screen"] = [iface.mainWindow().width(), iface.mainWindow().height()]
    report["dock"] = [dock.width(), dock.height()]
    report["splitter_sizes"] = dock.splitter.sizes()
    report["table_viewport_height"] = table.viewport().height()
    report["table_rows_visible"] = table.viewport().height() // rows
    page = dock.pointsScroll.widget()
    report["points_page_hint"] = [page.minimumSizeHint().height(), page.sizeHint().height()]
    lay = page.layout()
    report["page_items"] = [[(lay.itemAt(i).widget().objectName() if lay.itemAt(i).widget() else "layout"),
                             lay.itemAt(i).geometry().height()] for i in range(lay.count())]
    counts = dock.countsLabel
    report["counts_label"] = [counts.width(), counts.minimumHeight(), counts.heightForWidth(counts.width()),
                              getattr(counts, "monoplot_floor_width", None), dock.dockContents.minimumWidth()]
    report["tab_bar"] = dock.stepTabs.tabBar().sizeHint().height()
    report["points_scroll_viewport"] = dock.pointsScroll.viewport().height()
    report["photo_pane_min"] = dock.photoPane.minimumSizeHint().height()
    report["photo_canvas"] = [canvas.width(), canvas.height()]
    report["chips"] = [chips.width(), chips.height(), chips.x(), chips.y(), chips.isVisible()]
    if chips.isVisible():
        report["chips_cover"] = round(chips.width() * chips.height() / float(canvas.width() * canvas.height()), 3)
    shot("layout_1_window.png")
    shot("layout_2_dock.png", dock)
    print("MONOPLOT-LAYOUT", report, flush=True)
    finish()


QTimer.singleShot(240_000, lambda: (report["errors"].append("watchdog: stalled"), finish()))
QTimer.singleShot(1500, start)
