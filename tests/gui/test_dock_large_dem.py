"""A DEM too large to read whole, chosen in the real dock: its missing overviews are built in a task (progress bar,
Cancel), not on the main thread, and the dock takes the DEM when they are done."""

from __future__ import annotations

import os

from qgis.core import QgsProject, QgsRasterLayer

from monoplot_plugin.core.dem_large import LargeDem
from monoplot_plugin.core.synthetic import synthetic_terrain


def test_a_large_dem_without_overviews_opens_in_a_task(dock, qtbot, tmp_path, monkeypatch):
    monkeypatch.setenv("MONOPLOT_DEM_MAX_CELLS", "100000")  # this 360,000-cell DEM counts as larger than memory
    path = str(tmp_path / "national.tif")
    synthetic_terrain((600, 600), cell=10.0, seed=4).save(path)
    layer = QgsRasterLayer(path, "national DEM")
    assert layer.isValid()
    QgsProject.instance().addMapLayer(layer)
    c = dock.controller
    busy = []
    c.busyChanged.connect(busy.append)
    progress = []
    c.progressChanged.connect(progress.append)
    messages = []
    c.message.connect(lambda text, level: messages.append(text))
    with qtbot.waitSignal(c.demChanged, timeout=60000):
        dock.demCombo.setLayer(layer)
        assert c.task_kind == "dem" and c.dem_layer is not layer  # not read on the main thread
    assert isinstance(c.dem, LargeDem) and c.dem_layer is layer
    assert os.path.exists(path + ".ovr")
    assert any("Opening the large DEM" in b for b in busy) and busy[-1] == ""
    assert any("built overviews" in m for m in messages)
    qtbot.waitUntil(lambda: c.task is None, timeout=5000)
    # the next time the overviews are there: the DEM opens at once, on the main thread, as before
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    assert c.dem_layer is not layer
    assert c.set_dem_layer(layer) and isinstance(c.dem, LargeDem)
    # the dock going away closes the file while GDAL is still there (kept open, it crashed Python's exit)
    dock.unload()
    assert c.dem is None


def test_a_dem_of_many_cells_is_read_in_a_task_and_a_reopened_project_waits_for_it(dock, scene, qtbot, tmp_path,
                                                                                  monkeypatch):
    """A trial chose a 25 M-cell DEM (overviews present: readable whole): QGIS froze 3 s, 8-10 s at 100 M cells,
    and 2 s again when the project was reopened. A DEM of more than BACKGROUND_READ_CELLS is read in a task; a
    reopened project's overlay follows once it is in, and the project stays unmodified."""
    from monoplot_plugin.adapters import dem as dem_adapter

    monkeypatch.setattr(dem_adapter, "BACKGROUND_READ_CELLS", 100_000)  # this 400 x 400 DEM counts as many
    path = str(tmp_path / "lidar.tif")
    synthetic_terrain((400, 400), cell=10.0, seed=4).save(path)
    layer = QgsRasterLayer(path, "lidar DEM")
    QgsProject.instance().addMapLayer(layer)
    c = dock.controller
    dock.photoFile.setFilePath(scene.photo_path)
    with qtbot.waitSignal(c.demChanged, timeout=60000):
        dock.demCombo.setLayer(layer)
        assert c.task_kind == "dem" and c.dem_layer is not layer  # not read on the main thread
    assert c.dem_layer is layer and c.dem.shape == (400, 400)
    qtbot.waitUntil(lambda: c.task is None, timeout=5000)
    # a fitted camera saved with it; the project reopened
    x0, y0 = c.dem.bounds()[0] + 2000.0, c.dem.bounds()[1] + 200.0
    c.set_fitted(scene.camera.with_parameters(x=x0, y=y0, z=float(c.dem.sample(x0, y0)) + 100.0, heading=0.0,
                                              pitch=-10.0),
                 {"status": "ok", "message": "given"}, background=False)
    c.save()
    project = QgsProject.instance()
    saved = str(tmp_path / "lidar.qgz")
    assert project.write(saved)
    project.clear()
    assert project.read(saved)
    qtbot.waitUntil(lambda: c.dem_layer is not None and c.xyz is not None and c.task is None, timeout=60000)
    assert c.overlay is not None and not project.isDirty()
