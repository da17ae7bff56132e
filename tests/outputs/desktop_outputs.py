"""Outputs in the REAL QGIS desktop on the Aletsch case (not a pytest module; run tests/outputs/run_desktop_outputs.sh).

Loads dem.tif and photo.jpg into the Monoplot dock, fits the camera on the 11 GCPs (paired), draws a polygon around
the lower glacier, a line and the GCP points on the photo, exports the XYZ raster and the orthophoto, draws a map
polygon onto the photo (hidden parts dashed), and saves test-artifacts/outputs_desktop.png and outputs_desktop.json.
"""

import json
import os
import sys
import traceback
from pathlib import Path

import qgis.utils
from qgis.core import (QgsApplication, QgsCoordinateReferenceSystem, QgsFeature, QgsGeometry, QgsHillshadeRenderer,
                       QgsPointXY, QgsProject, QgsRasterLayer, QgsVectorLayer)
from qgis.PyQt.QtCore import Qt, QTimer

ROOT = Path(os.environ["MONOPLOT_REPO"])  # qgis --code exec()s this file: no __file__
DATA = Path(os.environ.get("MONOPLOT_ALETSCH", ROOT.parent / "shared" / "data" / "aletsch"))
OUT = ROOT / "test-artifacts"
OUT.mkdir(exist_ok=True)
sys.path.insert(0, str(ROOT))
iface = qgis.utils.iface
report = {"errors": []}


def finish():
    if report.get("finished"):
        return
    report["finished"] = True
    (OUT / "outputs_desktop.json").write_text(json.dumps({k: v for k, v in report.items() if k != "_dock"},
                                                         indent=1))
    dock = report.pop("_dock", None)
    if dock is not None:
        dock.controller._autosave.stop()  # an autosave would make the project dirty again
    QTimer.singleShot(300, quit_qgis)  # after the screenshot was saved


def quit_qgis():
    # Hard exit once the artifacts are written: this script checks the outputs, not QGIS's shutdown (the plugin
    # smoke test does that), and a shutdown that waits on something must not hang the caller.
    os._exit(0)


def guarded(fn):
    def run(*args):
        try:
            fn(*args)
        except Exception:  # noqa: BLE001 — written to the JSON, then quit
            report["errors"].append(traceback.format_exc())
            finish()
    return run


@guarded
def start():
    import numpy as np

    from monoplot_plugin.core.fit import fit_camera
    from monoplot_plugin.gui.dock import MonoplotDock

    win = iface.mainWindow()
    win.resize(1600, 1000)
    project = QgsProject.instance()
    dem = QgsRasterLayer(str(DATA / "dem.tif"), "Aletsch DEM")
    dem.setRenderer(QgsHillshadeRenderer(dem.dataProvider(), 1, 315.0, 40.0))
    project.addMapLayer(dem)
    project.setCrs(QgsCoordinateReferenceSystem("EPSG:21781"))
    dock = MonoplotDock(iface, win)
    iface.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, dock)
    win.resizeDocks([dock], [760], Qt.Orientation.Horizontal)
    dock.show()
    report["_dock"] = dock
    dock.photoFile.setFilePath(str(DATA / "photo.jpg"))
    dock.demCombo.setLayer(dem)
    c = dock.controller
    assert c.import_kml(str(DATA / "prior_pose.kml"))
    table = np.loadtxt(DATA / "gcps.csv", delimiter=",", skiprows=1)
    fit = fit_camera(table[:, :2], table[:, 2:], c.prior, pairs=np.column_stack([np.arange(11)] * 2))
    c.state.fitted, c.state.fit_info = fit.camera.to_dict(), fit.summary()
    c.cameraChanged.emit()
    tools = dock.output_tools
    session = tools.current_session()
    session.add_feature("polygon", [(60, 450), (450, 445), (750, 395), (950, 355), (950, 430), (640, 470),
                                    (640, 600), (60, 640)], {"name": "lower glacier"})
    session.add_feature("line", [(100, 300), (480, 120), (700, 250)], {"name": "crest"})
    for u, v in table[:, :2]:
        session.add_feature("point", [(u, v)])
    tools.export_xyz(OUT / "outputs_desktop_xyz.tif", overwrite=True)
    tools.export_orthophoto(OUT / "outputs_desktop_ortho.tif", overwrite=True)
    box = QgsVectorLayer("Polygon?crs=EPSG:21781", "modern box", "memory")
    f = QgsFeature()
    f.setGeometry(QgsGeometry.fromPolygonXY([[QgsPointXY(643000, 143000), QgsPointXY(648500, 143000),
                                              QgsPointXY(648500, 147500), QgsPointXY(643000, 147500),
                                              QgsPointXY(643000, 143000)]]))
    box.dataProvider().addFeatures([f])
    project.addMapLayer(box)
    overlay = tools.draw_layer_on_photo(box)
    dock.stepTabs.setCurrentWidget(dock.fitTab)
    tools.actions["polygon"].setChecked(True)
    dock.photo_canvas.zoom_to_photo()
    project.layerTreeRoot().findGroup("photo").setExpanded(True)
    report["map_features"] = {k: session.map_layer(k).featureCount() for k in ("point", "line", "polygon")}
    report["overlay_pieces"] = {"visible": sum(1 for g in overlay.getFeatures() if g["visible"] == 1),
                                "hidden": sum(1 for g in overlay.getFeatures() if g["visible"] == 0)}
    report["area_km2"] = next(session.map_layer("polygon").getFeatures())["area"] / 1e6
    canvas = iface.mapCanvas()
    QTimer.singleShot(1500, lambda: (canvas.setExtent(session.map_layer("polygon").extent().buffered(4000)),
                                     canvas.refresh()))
    QTimer.singleShot(4000, screenshot)


@guarded
def screenshot():
    QgsApplication.processEvents()
    iface.mainWindow().grab().save(str(OUT / "outputs_desktop.png"))
    finish()


QTimer.singleShot(180_000, lambda: (report["errors"].append("watchdog: stalled"), finish()))
QTimer.singleShot(1500, start)
