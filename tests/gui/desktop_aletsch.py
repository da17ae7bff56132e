"""Scripted session in the REAL QGIS desktop on the Aletsch case (steps 1-6 of the analyst's path).

Run it (not a pytest module) with ``tests/gui/run_desktop_aletsch.sh``, i.e.
``xvfb-run -a -s "-screen 0 1600x1000x24" qgis --nologo --noversioncheck --code tests/gui/desktop_aletsch.py``.
It loads dem.tif and photo.jpg, imports prior_pose.kml, suggests points, accepts those in view, fits the camera,
shows residuals and the DEM overlay at 50 %, moves the linked cursor, and saves screenshots and a JSON summary to
test-artifacts/ (gitignored): aletsch_1_suggestions.png, aletsch_2_fit.png, aletsch_3_floating.png,
aletsch_session.json. The fitted camera is checked against the 11 independent GCPs (never used as input).
"""

import csv
import json
import os
import sys
import time
import traceback
from pathlib import Path

import qgis.utils
from qgis.core import (QgsApplication, QgsCoordinateReferenceSystem, QgsHillshadeRenderer, QgsProject,
                       QgsRasterLayer)
from qgis.PyQt.QtCore import Qt, QTimer

ROOT = Path(os.environ["MONOPLOT_REPO"])  # qgis --code exec()s this file: no __file__
DATA = Path(os.environ.get("MONOPLOT_ALETSCH", ROOT.parent / "shared" / "data" / "aletsch"))
OUT = ROOT / "test-artifacts"
OUT.mkdir(exist_ok=True)
sys.path.insert(0, str(ROOT))

iface = qgis.utils.iface
report = {"steps": [], "errors": []}
state = {}


def log(step, **info):
    info["step"] = step
    info["t"] = round(time.time() - T0, 1)
    report["steps"].append(info)
    print("MONOPLOT-DESKTOP", json.dumps(info), flush=True)


def shot(name):
    QgsApplication.processEvents()
    path = OUT / name
    iface.mainWindow().grab().save(str(path))
    log("screenshot", path=str(path))


def finish():
    (OUT / "aletsch_session.json").write_text(json.dumps(report, indent=1))
    QTimer.singleShot(200, lambda: iface.actionExit().trigger())


def guarded(fn):
    def run(*args):
        try:
            fn(*args)
        except Exception:  # noqa: BLE001 — written to the JSON, then quit
            report["errors"].append(traceback.format_exc())
            print(traceback.format_exc(), flush=True)
            finish()
    return run


@guarded
def step1_inputs():
    from monoplot_plugin.gui.dock import MonoplotDock

    win = iface.mainWindow()
    win.resize(1600, 1000)
    project = QgsProject.instance()
    dem = QgsRasterLayer(str(DATA / "dem.tif"), "Aletsch DEM (25 m)")
    renderer = QgsHillshadeRenderer(dem.dataProvider(), 1, 315.0, 40.0)
    renderer.setZFactor(1.5)
    renderer.setMultiDirectional(True)
    dem.setRenderer(renderer)
    project.addMapLayer(dem)
    project.setCrs(QgsCoordinateReferenceSystem("EPSG:21781"))
    canvas = iface.mapCanvas()
    canvas.setExtent(dem.extent())
    dock = MonoplotDock(iface, win)
    iface.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, dock)
    win.resizeDocks([dock], [760], Qt.Orientation.Horizontal)
    dock.show()
    state["dock"] = dock
    dock.photoFile.setFilePath(str(DATA / "photo.jpg"))
    dock.demCombo.setLayer(dem)
    c = dock.controller
    log("inputs", photo=c.photo_size, dem=list(c.dem.elevation.shape), messages=dock.statusLabel.text())
    # step 2: rough camera from the KML PhotoOverlay
    assert c.import_kml(str(DATA / "prior_pose.kml"))
    dock.stepTabs.setCurrentWidget(dock.pointsTab)
    log("prior", camera=c.prior.parameters())
    # step 3: suggestions (background task)
    c.taskFinished.connect(on_task_finished)
    dock.suggestButton.click()


@guarded
def on_task_finished(result):
    dock = state["dock"]
    c = dock.controller
    if not result.ok:
        raise RuntimeError(f"task failed: {result.status} {result.reason}")
    if "suggested" not in state:
        state["suggested"] = True
        counts = c.state.counts()
        log("suggestions", counts=counts)
        canvas = iface.mapCanvas()
        canvas.setExtent(dock.map_view.prior_band.band.asGeometry().boundingBox().buffered(1500))
        canvas.refresh()
        QTimer.singleShot(1500, step3_screenshot)
        return
    log("fit", info=c.state.fit_info, camera=c.fitted.parameters())
    QTimer.singleShot(500, step5_result)


@guarded
def step3_screenshot():
    shot("aletsch_1_suggestions.png")
    dock = state["dock"]
    c = dock.controller
    # curation: select a few with the keyboard path, then "accept all in view" for the rest
    n = dock.accept_all_in_view()
    log("accepted", n=n, counts=c.state.counts())
    dock.stepTabs.setCurrentWidget(dock.fitTab)
    dock.fitButton.click()  # step 4: fit in a QgsTask


@guarded
def step5_result():
    dock = state["dock"]
    c = dock.controller
    dock.overlaySlider.setValue(50)
    dock.residualsCheck.setChecked(True)
    cam = c.fitted
    # independent check: the 11 hand GCPs
    import numpy as np

    rows = list(csv.DictReader(open(DATA / "gcps.csv")))
    uv = np.array([[float(r["u_px"]), float(r["v_px"])] for r in rows])
    xyz = np.array([[float(r["X_lv03"]), float(r["Y_lv03"]), float(r["Z_m"])] for r in rows])
    err = np.linalg.norm(cam.project(xyz) - uv, axis=1)
    log("gcp_check", rmse_px=float(np.sqrt(np.mean(err ** 2))), median_px=float(np.median(err)))
    # step 6: linked cursors, photo -> map (status bar shows X, Y, Z) and map -> photo
    dock._photo_cursor(520.0, 420.0)
    ground = c.ground_at_pixel(520.0, 420.0)
    log("cursor_photo_to_map", pixel=[520, 420], ground=ground)
    if ground is not None:
        uvp, where = c.pixel_of_ground(ground[0], ground[1])
        log("cursor_map_to_photo", pixel=uvp, where=where)
    canvas = iface.mapCanvas()
    foot = dock.map_view.fitted_band.band.asGeometry().boundingBox()
    if not foot.isEmpty():
        foot.combineExtentWith(cam.position[0], cam.position[1])
        canvas.setExtent(foot.buffered(1000))
        canvas.refresh()
    QTimer.singleShot(2000, step6_screenshots)


@guarded
def step6_screenshots():
    shot("aletsch_2_fit.png")
    dock = state["dock"]
    dock.floatButton.setChecked(True)
    dock.move(60, 40)
    dock.resize(1400, 920)
    QTimer.singleShot(1200, lambda: (shot("aletsch_3_floating.png"), finish()))


T0 = time.time()
QTimer.singleShot(240_000, lambda: (report["errors"].append("watchdog: stalled"), finish()))
QTimer.singleShot(1500, step1_inputs)
