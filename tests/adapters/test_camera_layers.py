"""The fitted camera's layers on the map: a new camera refills them in place, so that the layer tree does not change
(layers removed and added again marked a reopened project modified in the desktop: "save?" on every quit)."""

from osgeo import osr
from qgis.core import QgsProject

from monoplot_plugin.adapters.layers import remove_camera_layers, show_camera_layers
from monoplot_plugin.core.camera import Camera


def _camera(x: float, heading: float) -> Camera:
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(21781)
    return Camera((x, 150000.0, 2000.0), heading, -5.0, 0.0, 50.0, (800, 600), crs_wkt=srs.ExportToWkt())


def test_a_new_camera_refills_the_layers_it_finds_and_replaces_others(qgis_app):
    project = QgsProject.instance()
    square = "POLYGON((640000 150000, 641000 150000, 641000 151000, 640000 150000))"
    cam, foot = show_camera_layers(project, _camera(640000.0, 10.0), square)
    ids = {cam.id(), foot.id()}
    cam.renderer().symbol().setSize(11.0)  # the person's own styling of the layer
    again, again_foot = show_camera_layers(project, _camera(640500.0, 20.0), "")
    assert {again.id(), again_foot.id()} == ids and again.renderer().symbol().size() == 11.0
    (point,) = list(again.getFeatures())
    assert (point["x"], point["heading"]) == (640500.0, 20.0) and again_foot.featureCount() == 0
    # a camera beside it (a set-aside automatic one) gets layers of its own; the fitted camera's stay
    other, _ = show_camera_layers(project, _camera(641000.0, 30.0), square, other="automatic, uncertain")
    assert other.id() not in ids and ids <= set(project.mapLayers())
    # layers that are not as Monoplot made them (another CRS) are replaced
    remove_camera_layers(project, other=True)
    cam.setCrs(cam.crs().__class__("EPSG:2056"))
    replaced, _ = show_camera_layers(project, _camera(640000.0, 10.0), square)
    assert replaced.id() not in ids and len([lyr for lyr in project.mapLayers().values()
                                              if lyr.customProperty("monoplot/role") == "camera"]) == 1
    project.clear()
