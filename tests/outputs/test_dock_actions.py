"""The outputs inside the real Monoplot dock: tools and actions installed, drawing on the photo canvas, exports
added to the photo's layer group, a refit moving the live map layer, unload."""

import numpy as np
import pytest
from osgeo import gdal
from qgis.core import QgsFeature, QgsGeometry, QgsPointXY, QgsProject, QgsRasterLayer, QgsVectorLayer

from monoplot_plugin.outputs import OutputExistsError

from outputs_helpers import CRS


@pytest.fixture
def dock_with_fit(qgis_iface, qtbot, plane_scene, tmp_path):
    from monoplot_plugin.gui.dock import MonoplotDock

    s = plane_scene
    dem_path = tmp_path / "plane_dem.tif"
    s.dem.save(str(dem_path))
    photo_path = tmp_path / "Gletscher 1890.png"
    mem = gdal.GetDriverByName("MEM").Create("", s.camera.width, s.camera.height, 3, gdal.GDT_Byte)
    for b in range(3):
        mem.GetRasterBand(b + 1).WriteArray(s.photo[..., b])
    gdal.GetDriverByName("PNG").CreateCopy(str(photo_path), mem)
    project = QgsProject.instance()
    project.clear()
    dem_layer = QgsRasterLayer(str(dem_path), "plane DEM")
    project.addMapLayer(dem_layer)
    dock = MonoplotDock(qgis_iface)
    qtbot.addWidget(dock)
    dock.resize(600, 900)
    dock.show()
    c = dock.controller
    assert c.load_photo(str(photo_path)) and c.set_dem_layer(dem_layer)
    dock.photo_canvas.resize(480, 320)
    dock.photo_canvas.zoom_to_photo()
    tools = dock.output_tools  # the dock installs them itself (gui.dock._install_outputs)
    assert tools is not None
    c.state.fitted = s.camera.to_dict()
    c.cameraChanged.emit()
    yield dock, tools
    dock.unload()  # also unloads the output tools
    c.cancel()
    project.clear()


def test_outputs_in_the_dock(dock_with_fit, plane_scene, tmp_path, qtbot):
    dock, tools = dock_with_fit
    s = plane_scene
    # Tools and actions are on the dock's bars.
    assert {"point", "line", "polygon", "edit", "xyz", "ortho", "report", "features", "overlay"} <= set(tools.actions)
    tools.actions["polygon"].setChecked(True)
    assert dock.photo_canvas.mapTool() is tools.capture_tools["polygon"]
    session = tools.current_session()
    session.add_feature("polygon", [[50, 100], [190, 100], [150, 150]], {"name": "tongue"})
    live = session.map_layer("polygon")
    assert live.featureCount() == 1
    # A field added later reaches both layers; a value typed into the photo layer reaches the map layer.
    session.add_field("year", "integer")
    photo_layer = session.photo_layer("polygon")
    photo_layer.startEditing()
    fid = next(photo_layer.getFeatures()).id()
    assert photo_layer.changeAttributeValue(fid, photo_layer.fields().indexFromName("year"), 1890)
    assert photo_layer.commitChanges()
    assert next(live.getFeatures())["year"] == 1890
    assert set(session.all_photo_layers()) <= set(dock.photo_canvas.layers())
    group = session.group
    assert group.name() == "Gletscher 1890"

    xyz_layer = tools.export_xyz(tmp_path / "xyz.tif")
    ortho_layer = tools.export_orthophoto(tmp_path / "ortho.tif")
    report = tools.export_report(tmp_path / "report.png")
    shp = tools.export_features("polygon", tmp_path / "tongue.shp")
    assert xyz_layer.bandCount() == 4 and ortho_layer.crs().authid() == CRS and report.exists() and shp.exists()
    names = {node.name() for node in group.findLayers()}
    assert {"xyz (X Y Z, photo pixels)", "ortho (orthophoto)", "tongue"} <= names
    assert not group.findLayer(xyz_layer.id()).isVisible()  # off by default: it lies in photo pixel space
    with pytest.raises(OutputExistsError):
        tools.export_xyz(tmp_path / "xyz.tif")

    # A modern outline drawn on the photo.
    outline = QgsVectorLayer(f"Polygon?crs={CRS}", "outline 2020", "memory")
    f = QgsFeature()
    f.setGeometry(QgsGeometry.fromPolygonXY([[QgsPointXY(601500, 202000), QgsPointXY(602600, 202100),
                                              QgsPointXY(602500, 203300), QgsPointXY(601500, 202000)]]))
    outline.dataProvider().addFeatures([f])
    overlay = tools.draw_layer_on_photo(outline)
    assert overlay in dock.photo_canvas.layers() and overlay.featureCount() >= 1

    # A refit: the live map layer is recomputed from what was drawn on the photo.
    before = next(live.getFeatures()).geometry().centroid().asPoint()
    dock.controller.state.fitted = s.camera.with_parameters(heading=s.camera.heading + 2.0).to_dict()
    dock.controller.cameraChanged.emit()
    after = next(live.getFeatures()).geometry().centroid().asPoint()
    assert before.distance(after) > 10.0


def test_drawn_features_come_back_with_the_project(dock_with_fit, tmp_path, qtbot):
    dock, tools = dock_with_fit
    project = QgsProject.instance()
    tools.current_session().add_feature("line", [[40, 120], [200, 130]], {"name": "moraine"})
    path = tmp_path / "session.qgz"
    dock.controller.save()
    assert project.write(str(path))
    project.clear()
    assert tools.session is None
    assert project.read(str(path))
    qtbot.waitUntil(lambda: tools.session is not None, timeout=5000)
    layer = tools.session.map_layer("line")
    assert layer.featureCount() == 1 and next(layer.getFeatures())["name"] == "moraine"
    assert tools.session.photo_layer("line") in dock.photo_canvas.layers()


def test_exports_run_in_background_tasks(dock_with_fit, tmp_path, qtbot):
    dock, tools = dock_with_fit
    done = []
    tools.exported.connect(lambda what, path: done.append((what, path)))
    for what, name in (("xyz", "bg_xyz.tif"), ("ortho", "bg_ortho.tif"), ("report", "bg_report.pdf")):
        assert tools.start_export(what, tmp_path / name) is not None
        qtbot.waitUntil(lambda: len(done) > 0 and done[-1][0] == what, timeout=30000)
    assert all((tmp_path / n).exists() for n in ("bg_xyz.tif", "bg_ortho.tif", "bg_report.pdf"))
    names = {node.name() for node in QgsProject.instance().layerTreeRoot().findGroup("Gletscher 1890").findLayers()}
    assert {"bg_xyz (X Y Z, photo pixels)", "bg_ortho (orthophoto)"} <= names
    # A refused overwrite is a message, not a traceback, and the file is untouched.
    before = (tmp_path / "bg_xyz.tif").read_bytes()
    tools.start_export("xyz", tmp_path / "bg_xyz.tif")
    qtbot.waitUntil(lambda: "Nothing was written" in dock.statusLabel.text(), timeout=30000)
    assert "already exists" in dock.statusLabel.text()
    assert (tmp_path / "bg_xyz.tif").read_bytes() == before
