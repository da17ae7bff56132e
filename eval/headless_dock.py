"""A real Monoplot dock in a real (offscreen) QgsApplication, for ``bench/bench_curation.py`` and
``eval/user_trial.py``: real QGIS, real canvases, real clicks (QTest), real fits in QgsTasks.

The QGIS interface is pytest-qgis's (a real QgsMapCanvas as the main map, a message bar that records messages),
as in the GUI tests.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))


def start_qgis():
    """(QgsApplication, iface) with the offscreen platform unless a display is asked for."""
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from qgis.core import QgsApplication
    from qgis.gui import QgsMapCanvas
    from qgis.PyQt.QtWidgets import QMainWindow
    from pytest_qgis.mock_qgis_classes import MockMessageBar
    from pytest_qgis.qgis_interface import QgisInterface

    app = QgsApplication([], True)
    app.initQgis()
    main = QMainWindow()
    canvas = QgsMapCanvas(main)
    main.setCentralWidget(canvas)
    main.resize(900, 700)
    main.show()
    iface = QgisInterface(canvas, MockMessageBar(), main)
    iface._keep = (main, canvas)
    # an earlier run ends with os._exit (its project never closed): its never-saved project's autosave stays in the
    # profile, and this run's dock would take it back as a crash's work (a user trial counted 28 accepted photo
    # points where it had accepted 14)
    from monoplot_plugin.gui import persistence

    persistence.discard_autosave("")
    return app, iface


def open_dock(iface, photo_path: str, dem_path: str, name: str = "DEM"):
    """A dock on a fresh project with ``dem_path`` as a layer and ``photo_path`` loaded (photo canvas 600 x 420)."""
    from qgis.core import QgsProject, QgsRasterLayer

    from monoplot_plugin.gui.dock import MonoplotDock

    project = QgsProject.instance()
    project.clear()
    layer = QgsRasterLayer(str(dem_path), name)
    assert layer.isValid(), dem_path
    project.addMapLayer(layer)
    canvas = iface.mapCanvas()
    canvas.setDestinationCrs(layer.crs())
    canvas.setLayers([layer])
    canvas.resize(800, 600)
    canvas.setExtent(layer.extent())
    dock = MonoplotDock(iface)
    dock.resize(620, 1000)
    dock.show()
    dock.photoFile.setFilePath(str(photo_path))
    dock.demCombo.setLayer(layer)
    wait(50)
    dock.photo_canvas.zoom_to_photo()
    wait(50)
    return dock


def wait(ms: float) -> None:
    """Process events for ``ms`` milliseconds."""
    from qgis.PyQt.QtWidgets import QApplication

    end = time.perf_counter() + ms / 1000.0
    while True:
        QApplication.processEvents()
        if time.perf_counter() >= end:
            break
        time.sleep(0.002)


def wait_until(predicate, timeout_s: float = 120.0) -> bool:
    end = time.perf_counter() + timeout_s
    while time.perf_counter() < end:
        if predicate():
            return True
        wait(20)
    return predicate()


def photo_pos(dock, u: float, v: float):
    """Viewport position (QPoint) of photo pixel (u, v)."""
    from qgis.PyQt.QtCore import QPoint

    from monoplot_plugin.gui.photo_canvas import uv_to_map

    p = dock.photo_canvas.getCoordinateTransform().transform(uv_to_map(u, v))
    return QPoint(round(p.x()), round(p.y()))


def map_pos(dock, x: float, y: float):
    """Viewport position (QPoint) on the main map of DEM-CRS point (x, y)."""
    from qgis.PyQt.QtCore import QPoint

    p = dock.map_canvas.getCoordinateTransform().transform(dock.map_mapping.to_canvas(x, y))
    return QPoint(round(p.x()), round(p.y()))


def click(widget, pos, button=None, modifiers=None) -> None:
    from qgis.PyQt.QtCore import Qt
    from qgis.PyQt.QtTest import QTest

    QTest.mouseClick(widget, button or Qt.MouseButton.LeftButton, modifiers or Qt.KeyboardModifier.NoModifier, pos)


def key(widget, k, modifiers=None) -> None:
    from qgis.PyQt.QtCore import Qt
    from qgis.PyQt.QtTest import QTest

    QTest.keyClick(widget, k, modifiers or Qt.KeyboardModifier.NoModifier)
