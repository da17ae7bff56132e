"""QGIS layers of the outputs: live photo -> map layers in the photo's group, XYZ layer identify, map -> photo."""

import numpy as np
import pytest
from osgeo import ogr
from qgis.core import (QgsFeature, QgsGeometry, QgsPointXY, QgsProject, QgsRaster, QgsVectorLayer,
                       QgsWkbTypes)

from monoplot_plugin.outputs import write_xyz_raster
from monoplot_plugin.gui.digitising import DigitisingSession
from monoplot_plugin.gui.map_layers import add_xyz_layer, map_layer_on_photo

from outputs_helpers import CRS, plane_height


@pytest.fixture
def project(qgis_app):
    project = QgsProject()
    yield project
    project.clear()


def test_features_drawn_after_the_last_save_survive_a_crash(plane_scene, tmp_path):
    """Drawn features are a project entry, on disk only when the project is saved: the entries autosave keeps the
    ones drawn since, for the next opening after a crash; a project QGIS closed discards it."""
    import os

    from monoplot_plugin.gui import persistence

    s = plane_scene
    w, h = s.camera.width, s.camera.height
    triangle = [[0.2 * w, 0.6 * h], [0.8 * w, 0.6 * h], [0.6 * w, 0.9 * h]]
    first = QgsProject()
    session = DigitisingSession(first, s.camera, s.dem, s.xyz, "/photos/a.jpg")
    session.add_feature("polygon", triangle)
    path = str(tmp_path / "drawn.qgz")
    assert first.write(path)
    os.utime(path, (os.path.getmtime(path) - 10,) * 2)  # saved a while ago
    session.add_feature("line", [[0.2 * w, 0.8 * h], [0.8 * w, 0.8 * h]])  # drawn after the save; then a crash

    def reopened() -> dict:
        project = QgsProject()
        assert project.read(path)
        again = DigitisingSession(project, s.camera, s.dem, s.xyz, "/photos/a.jpg")
        counts = {k: layer.featureCount() for k, layer in again.photo_layers.items()}
        project.clear()
        return counts

    try:
        assert reopened() == {"polygon": 1, "line": 1}
        persistence.discard_autosave(path)  # the project closed by QGIS (saved, or "Discard")
        assert reopened() == {"polygon": 1}
    finally:
        first.clear()


def test_live_map_layer_follows_photo_edits(project, plane_scene, tmp_path):
    s = plane_scene
    session = DigitisingSession(project, s.camera, s.dem, s.xyz, "/photos/Aletsch 1890.jpg",
                                fields=[("name", "string"), ("year", "integer")])
    w, h = s.camera.width, s.camera.height
    fid = session.add_feature("polygon", [[0.2 * w, 0.6 * h], [0.8 * w, 0.6 * h], [0.6 * w, 0.9 * h]],
                              {"name": "tongue", "year": 1890})
    live = session.map_layer("polygon")
    assert session.group.name() == "Aletsch 1890"
    assert session.group.findLayer(live.id()) is not None
    assert QgsWkbTypes.hasZ(live.wkbType()) and live.crs().authid() == CRS
    (feature,) = list(live.getFeatures())
    area_before = feature["area"]
    assert feature["name"] == "tongue" and feature["year"] == 1890 and area_before > 0
    vertex = next(iter(feature.geometry().vertices()))
    assert vertex.z() == pytest.approx(plane_height(vertex.x(), vertex.y()), abs=0.01)

    # Moving a vertex on the photo updates the map layer; so does QGIS's own editing of the photo layer.
    session.move_vertex("polygon", fid, 2, 0.5 * w, 0.98 * h)
    (feature,) = list(live.getFeatures())
    assert feature["area"] > area_before
    photo_layer = session.photo_layer("polygon")
    photo_layer.startEditing()
    extra = QgsFeature(photo_layer.fields())
    extra.setGeometry(QgsGeometry.fromPolygonXY([[QgsPointXY(10, -150), QgsPointXY(60, -150), QgsPointXY(40, -120),
                                                  QgsPointXY(10, -150)]]))
    photo_layer.addFeature(extra)
    assert live.featureCount() == 2
    photo_layer.rollBack()
    assert live.featureCount() == 1
    session.delete_feature("polygon", fid)
    assert live.featureCount() == 0

    # A line over sky: the sky piece is split off and reported.
    sky_row = np.flatnonzero(np.isnan(s.xyz[:, w // 2, 2]))[-1] - 5
    reports = []
    session.mapLayerUpdated.connect(lambda kind, sky, dropped: reports.append((kind, sky, dropped)))
    session.add_feature("line", [[0.2 * w, 0.8 * h], [0.5 * w, sky_row], [0.8 * w, 0.8 * h]], {"name": "crest"})
    assert reports[-1] == ("line", 1, 0)
    (line,) = list(session.map_layer("line").getFeatures())
    assert line.geometry().constGet().numGeometries() == 2 and line["sky_parts"] == 1
    # drawn on the map as on the photo, not in QGIS's random thin default (a trial could hardly see its flood line)
    for kind in ("line", "polygon"):
        on_map, on_photo = (layer.renderer().symbol() for layer in (session.map_layer(kind),
                                                                      session.photo_layer(kind)))
        assert on_map.color().name() == on_photo.color().name() == "#00c8ff"
    assert session.map_layer("line").renderer().symbol().symbolLayer(0).width() == pytest.approx(0.8)
    session.add_feature("point", [[0.5 * w, sky_row]])
    assert reports[-1] == ("point", 0, 1) and session.map_layer("point").featureCount() == 0

    # Export as a Shapefile, added to the same group.
    path = session.export("line", tmp_path / "crest.shp")
    ds = ogr.Open(str(path))
    assert ds.GetLayer(0).GetFeatureCount() == 1
    # One group for the photo: for each kind the photo layer (unchecked: photo pixel space) and its live map
    # layer, plus the written file.
    nodes = session.group.findLayers()
    assert len(nodes) == 7
    photo_nodes = [n for n in nodes if n.layer() in session.photo_layers.values()]
    assert len(photo_nodes) == 3 and not any(n.isVisible() for n in photo_nodes)


def test_xyz_layer_identify_gives_ground_coordinates(project, plane_scene, tmp_path):
    s = plane_scene
    path = write_xyz_raster(tmp_path / "xyz.tif", s.xyz, CRS, s.distance)
    layer = add_xyz_layer(path, project)
    assert layer.isValid() and layer.bandCount() == 4 and not layer.crs().isValid()
    assert layer.renderer().type() == "singlebandpseudocolor" and layer.renderer().band() == 3
    assert "X" in layer.bandName(1) and "Z" in layer.bandName(3)
    u, v = 130.5, 120.5  # a ground pixel, clicked on the photo canvas at (u, -v)
    result = layer.dataProvider().identify(QgsPointXY(u, -v), QgsRaster.IdentifyFormat.IdentifyFormatValue)
    values = result.results()
    assert np.allclose([values[1], values[2], values[3]], s.xyz[int(v), int(u)], atol=0.07)


def test_an_xyz_raster_added_by_hand_shows_z_as_the_dock_does(project, plane_scene, tmp_path):
    """A trial added the XYZ raster through the Browser: QGIS drew X, Y, Z as red, green and blue (grey noise). Its
    style file, written beside it, makes QGIS draw it as the dock does, with the file's Z range."""
    from qgis.core import QgsRasterLayer

    s = plane_scene
    path = write_xyz_raster(tmp_path / "photo_xyz.tif", s.xyz, CRS, s.distance)
    assert (tmp_path / "photo_xyz.qml").is_file()
    by_hand = QgsRasterLayer(str(path), "by hand")  # as Add Raster Layer or the Browser opens it
    ours = add_xyz_layer(path, project)
    assert by_hand.isValid() and by_hand.renderer().type() == "singlebandpseudocolor"
    assert by_hand.renderer().band() == ours.renderer().band() == 3
    z = s.xyz[..., 2][np.isfinite(s.xyz[..., 2])]
    shader = by_hand.renderer().shader().rasterShaderFunction()
    assert np.isclose(shader.minimumValue(), z.min(), rtol=1e-5) and np.isclose(shader.maximumValue(), z.max(),
                                                                              rtol=1e-5)
    assert by_hand.opacity() == ours.opacity() < 1.0
    colours = [i.color.name() for i in shader.colorRampItemList()]
    ours_colours = [i.color.name() for i in ours.renderer().shader().rasterShaderFunction().colorRampItemList()]
    assert colours[0] == ours_colours[0] and colours[-1] == ours_colours[-1] and colours[0] != colours[-1]


def test_map_layer_drawn_on_photo_with_hidden_parts(project, plane_scene):
    s = plane_scene
    cx, cy, _ = s.camera.position
    layer = QgsVectorLayer(f"LineString?crs={CRS}", "modern outline", "memory")
    f = QgsFeature()
    f.setGeometry(QgsGeometry.fromPolylineXY([QgsPointXY(cx - 200, cy - 800), QgsPointXY(cx, cy + 2500)]))
    layer.dataProvider().addFeatures([f])
    poly = QgsVectorLayer(f"Polygon?crs={CRS}", "outline", "memory")
    g = QgsFeature()
    g.setGeometry(QgsGeometry.fromPolygonXY([[QgsPointXY(601500, 202000), QgsPointXY(602600, 202100),
                                              QgsPointXY(602500, 203300), QgsPointXY(601500, 202000)]]))
    poly.dataProvider().addFeatures([g])
    on_photo = map_layer_on_photo(layer, s.camera, s.dem, project)
    flags = [feat["visible"] for feat in on_photo.getFeatures()]
    assert 1 in flags  # the part in front of the camera, solid
    assert on_photo.renderer().type() == "categorizedSymbol"
    outline = map_layer_on_photo(poly, s.camera, s.dem, project)
    (piece,) = list(outline.getFeatures())
    assert piece["visible"] == 1
    uv = np.array([(p.x(), -p.y()) for p in piece.geometry().vertices()])
    assert np.allclose(uv[0], s.camera.project([[601500, 202000, plane_height(601500, 0)]])[0], atol=1e-6)


def test_drawn_features_survive_saving_and_reopening_the_project(qgis_app, plane_scene, tmp_path):
    s = plane_scene
    project = QgsProject()
    session = DigitisingSession(project, s.camera, s.dem, None, "Aletsch 1890.jpg",
                                fields=[("name", "string"), ("seen", "date")])
    session.add_feature("polygon", [[50, 100], [190, 100], [150, 150]], {"name": "tongue", "seen": "1890-07-14"})
    session.add_feature("line", [[40, 120], [200, 130]], {"name": "moraine"})
    path = tmp_path / "glacier project.qgz"
    assert project.write(str(path))
    project.clear()

    reopened = QgsProject()
    assert reopened.read(str(path))
    # QGIS brings memory layers back empty; the session refills them from the project file.
    again = DigitisingSession(reopened, s.camera, s.dem, None, "Aletsch 1890.jpg")
    assert ("seen", "date") in again.fields
    assert again.photo_layer("polygon").featureCount() == 1 and again.photo_layer("line").featureCount() == 1
    (poly,) = list(again.map_layer("polygon").getFeatures())
    assert poly["name"] == "tongue" and poly["area"] > 0
    assert poly["seen"].toString("yyyy-MM-dd") == "1890-07-14"  # a date field must not make the feature vanish
    names = [n.name() for n in again.group.findLayers()]
    assert len(names) == len(set(names))  # the reopened layers are reused, not duplicated
    reopened.clear()


def _source_and_overlay(kind: str, name: str, n: int, pieces):
    """A source layer of ``n`` features and its overlay on the photo: one feature per (source fid, visible) piece."""
    from qgis.core import QgsFeature, QgsField, QgsVectorLayer
    from qgis.PyQt.QtCore import QVariant

    source = QgsVectorLayer(f"{kind}?crs=EPSG:2056", name, "memory")
    source.dataProvider().addFeatures([QgsFeature() for _ in range(n)])
    overlay = QgsVectorLayer(kind, f"{name} on photo", "memory")
    overlay.dataProvider().addAttributes([QgsField("source_fid", QVariant.Type.LongLong),
                                          QgsField("visible", QVariant.Type.Int)])
    overlay.updateFields()
    features = []
    for fid, visible in pieces:
        f = QgsFeature(overlay.fields())
        f["source_fid"], f["visible"] = fid, visible
        features.append(f)
    overlay.dataProvider().addFeatures(features)
    return source, overlay


def test_the_message_counts_the_features_hidden_in_part_not_the_pieces(qgis_app):
    """A trial's line along a valley floor came out in 9 hidden pieces of 1-10 px (DEM bumps at a grazing angle):
    "9 pieces hidden" read as more occlusion than there was. The message counts features partly hidden."""
    from monoplot_plugin.gui.map_layers import overlay_outcome

    # line 1 in 19 pieces, 9 hidden; line 2 seen
    source, overlay = _source_and_overlay("LineString", "valley lines", 3, [(1, 1)] + [(1, 0), (1, 1)] * 9 + [(2, 1)])
    text, doubtful = overlay_outcome(source, overlay)
    assert text == "Drawn on the photo: 2 of the 3 features of valley lines (1 of them partly hidden behind " \
                   "terrain, dashed)." and not doubtful
    # a point is hidden or not, not "partly" (a trial's 4 stakes "partly hidden behind terrain")
    text, _ = overlay_outcome(*_source_and_overlay("Point", "stakes", 3, [(1, 0), (2, 1), (3, 0)]))
    assert text == "Drawn on the photo: 3 of the 3 features of stakes (2 of them hidden behind terrain)."
