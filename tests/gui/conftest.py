"""Fixtures for the dock tests: a synthetic scene written to real files and a dock on a real QGIS project."""

from __future__ import annotations

import numpy as np
import pytest
from qgis.core import QgsProject, QgsRasterLayer

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain
from monoplot_plugin.core.xyz import compute_xyz


class Scene:
    """A DEM GeoTIFF, a photo PNG of it from a hidden camera, and exact correspondences."""

    def __init__(self, folder):
        self.dem = synthetic_terrain((160, 160), cell=50.0, seed=3)
        x, y = self.dem.cell_to_map(80, 150)
        z = float(self.dem.sample(x, y))
        self.camera = Camera((x, y, z + 300.0), 0.0, -4.0, 0.0, 60.0, (480, 320), crs_wkt=self.dem.crs_wkt)
        self.dem_path = str(folder / "dem.tif")
        self.dem.save(self.dem_path)
        self.photo_path = str(folder / "photo.png")
        from monoplot_plugin.adapters.photo import array_to_qimage

        assert array_to_qimage(render_photo(self.camera, self.dem)).save(self.photo_path)
        xyz = compute_xyz(self.camera, self.dem)
        # irregular positions: a regular grid would let an unpaired fit match every point to its neighbour
        rng = np.random.default_rng(7)
        uu, vv = rng.integers(10, 470, 80), rng.integers(40, 310, 80)
        pts = xyz[vv, uu]
        ok = np.isfinite(pts).all(axis=1)
        self.uv = np.column_stack([uu + 0.5, vv + 0.5])[ok]  # (N, 2) pixel centres
        self.xyz = pts[ok]  # (N, 3) the ground each of them sees
        self.prior = self.camera.with_parameters(x=x + 120.0, y=y - 80.0, heading=3.0, fov=56.0)


@pytest.fixture(scope="session")
def scene(tmp_path_factory):
    return Scene(tmp_path_factory.mktemp("scene"))


@pytest.fixture
def dem_layer(scene):
    project = QgsProject.instance()
    project.clear()
    layer = QgsRasterLayer(scene.dem_path, "synthetic DEM")
    assert layer.isValid()
    project.addMapLayer(layer)
    return layer


@pytest.fixture
def dock(qgis_iface, qtbot, dem_layer):
    from monoplot_plugin.gui.dock import MonoplotDock

    qgis_iface.messageBar().clear_messages()
    canvas = qgis_iface.mapCanvas()
    canvas.setDestinationCrs(dem_layer.crs())
    canvas.setLayers([dem_layer])
    canvas.setExtent(dem_layer.extent())
    canvas.resize(600, 600)
    d = MonoplotDock(qgis_iface)
    qtbot.addWidget(d)
    d.resize(600, 900)
    d.show()
    d.controller._autosave.setInterval(10)
    yield d
    d.controller.cancel()
    if d.controller.task is not None:
        qtbot.waitUntil(lambda: d.controller.task is None, timeout=10000)
    d.unload()
    QgsProject.instance().clear()
