"""Suggest photo points / DEM points through processing.run on a rendered synthetic scene."""

import numpy as np
import pytest
from qgis.core import QgsProcessingException, QgsVectorLayer

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.dem import Dem


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """A synthetic alpine DEM and a photo rendered from a known camera (core/synthetic.py)."""
    import cv2

    from monoplot_plugin.core.synthetic import render_photo, synthetic_terrain

    folder = tmp_path_factory.mktemp("rendered")
    dem = synthetic_terrain((120, 120), cell=50.0, seed=2)
    dem.save(str(folder / "dem.tif"))
    dem = Dem.open(str(folder / "dem.tif"))
    x, y = dem.cell_to_map(60, 112)
    z = float(dem.sample(np.array([x]), np.array([y]))[0]) + 400
    cam = Camera((float(x), float(y), z), heading=0.0, pitch=-8.0, roll=0.0, fov=55.0, image_size=(320, 240))
    cv2.imwrite(str(folder / "photo.png"), render_photo(cam, dem, seed=2)[:, :, ::-1])
    cam.save(folder / "camera.json")
    return {"dem": str(folder / "dem.tif"), "photo": str(folder / "photo.png"), "camera": str(folder / "camera.json"),
            "cam": cam, "demobj": dem}


def test_suggest_photo_points_in_pixel_space(run_alg, rendered, tmp_path):
    out = tmp_path / "photo_points.gpkg"
    result = run_alg("suggestphotopoints", {"PHOTO": rendered["photo"], "MAX_POINTS": 40, "OUTPUT": str(out)})
    layer = QgsVectorLayer(result["OUTPUT"], "p", "ogr")
    features = list(layer.getFeatures())
    assert 5 <= len(features) <= 40 and result["COUNT"] == len(features)
    for f in features:
        point = f.geometry().asPoint()
        assert point.x() == pytest.approx(f["u_px"]) and point.y() == pytest.approx(-f["v_px"])
        assert 0 <= f["u_px"] <= 320 and 0 <= f["v_px"] <= 240
    # photo space has no CRS: none at all (newer GDAL) or an undefined Cartesian one, never GeoPackage's older
    # default undefined geographic one (QGIS would reproject the pixels as degrees)
    crs = layer.crs()
    assert crs.authid() == "" and not crs.isGeographic()
    assert not crs.isValid() or "Cartesian" in crs.description(), crs.description()


def test_a_photo_of_noise_is_warned_about(run_alg, rendered, tmp_path):
    """Key points on a grey frame of noise mean nothing: the log says so; the rendered scene gets no warning."""
    import cv2
    from qgis.core import QgsProcessingFeedback

    noise = np.random.default_rng(1).normal(128, 9, (240, 320, 3)).clip(0, 255).astype(np.uint8)
    cv2.imwrite(str(tmp_path / "fog.png"), noise)
    for photo, warned in ((str(tmp_path / "fog.png"), True), (rendered["photo"], False)):
        feedback = QgsProcessingFeedback()
        result = run_alg("suggestphotopoints", {"PHOTO": photo, "MAX_POINTS": 40, "OUTPUT": str(tmp_path / "p.gpkg")},
                         feedback)
        assert ("almost no structure" in feedback.textLog()) == warned, feedback.textLog()
        assert result["COUNT"] > 0


def test_suggest_dem_points_seen_by_the_prior(run_alg, rendered, tmp_path):
    out = tmp_path / "dem_points.gpkg"
    result = run_alg("suggestdempoints", {"DEM": rendered["dem"], "CAMERA": rendered["camera"], "MAX_POINTS": 30,
                                          "OUTPUT": str(out)})
    layer = QgsVectorLayer(result["OUTPUT"], "d", "ogr")
    xyz = np.array([(f["X"], f["Y"], f["Z"]) for f in layer.getFeatures()])
    assert 3 <= len(xyz) <= 30
    assert layer.crs().authid() == "EPSG:2056"
    assert np.allclose(xyz[:, 2], rendered["demobj"].sample(xyz[:, 0], xyz[:, 1]), atol=30.0)
    uv = rendered["cam"].project(xyz)
    assert rendered["cam"].in_image(uv, margin=32).all()  # restricted to what the prior camera sees


def test_unreadable_photo_is_a_clear_error(run_alg, tmp_path):
    bad = tmp_path / "bad.jpg"
    bad.write_bytes(b"not an image")
    with pytest.raises(QgsProcessingException, match="cannot read the photo bad.jpg"):
        run_alg("suggestphotopoints", {"PHOTO": str(bad), "OUTPUT": str(tmp_path / "p.gpkg")})


def test_a_camera_facing_a_near_slope_is_warned_that_it_is_left_out(run_alg, rendered, tmp_path):
    """A prior camera 5 m above the ground, looking level into rising terrain: the suggestions come from beyond
    100 m and the log says why."""
    from qgis.core import QgsProcessingFeedback

    from monoplot_plugin.core.suggest import blocked_view
    from monoplot_plugin.core.xyz import compute_xyz_full

    dem, cam = rendered["demobj"], rendered["cam"]
    x, y, _ = cam.position
    blocked = None
    for step in range(1, 60):  # walk north, into the terrain the photo looks at, until a slope fills the view
        yy = y + 50.0 * step
        moved = cam.with_parameters(y=yy, z=float(dem.sample(x, yy)) + 5.0, pitch=0.0)
        if blocked_view(compute_xyz_full(moved, dem, visibility=False), moved, dem):
            blocked = moved
            break
    assert blocked is not None
    blocked.save(tmp_path / "blocked.json")
    feedback = QgsProcessingFeedback()
    result = run_alg("suggestdempoints", {"DEM": rendered["dem"], "CAMERA": str(tmp_path / "blocked.json"),
                                          "MAX_POINTS": 30, "OUTPUT": str(tmp_path / "d.gpkg")}, feedback)
    assert "Terrain within 100 m of the prior camera fills its view" in feedback.textLog()
    layer = QgsVectorLayer(result["OUTPUT"], "d", "ogr")
    xyz = np.array([(f["X"], f["Y"], f["Z"]) for f in layer.getFeatures()]).reshape(-1, 3)
    assert len(xyz) and (blocked.project_with_depth(xyz)[1] > 100.0).all()
    # with the position known to 2 m the slope is what the camera sees: no warning, the near terrain suggested
    feedback = QgsProcessingFeedback()
    result = run_alg("suggestdempoints", {"DEM": rendered["dem"], "CAMERA": str(tmp_path / "blocked.json"),
                                          "MAX_POINTS": 30, "POSITION_SIGMA": 2.0,
                                          "OUTPUT": str(tmp_path / "d2.gpkg")}, feedback)
    assert "fills its view" not in feedback.textLog()
    layer = QgsVectorLayer(result["OUTPUT"], "d", "ogr")
    xyz = np.array([(f["X"], f["Y"], f["Z"]) for f in layer.getFeatures()]).reshape(-1, 3)
    assert (blocked.project_with_depth(xyz)[1] < 100.0).sum() >= 3


def test_temporary_and_file_outputs_load_without_error_and_photo_pixels_keep_no_crs(processing_provider, small_scene,
                                                                                    tmp_path):
    """A desktop trial: Suggest photo points, Map -> photo and Photo -> map with the default temporary output said
    "The following layers were not correctly generated • memory:...", and photo-pixel layers came in as EPSG:4326.
    Run as the toolbox runs them (results loaded into the project): no error, photo pixels without a CRS and
    unchecked, map features in the DEM's CRS."""
    import processing
    from qgis.core import (QgsFeature, QgsGeometry, QgsProcessingFeedback, QgsProject, QgsVectorLayer)

    class Errors(QgsProcessingFeedback):
        said: list = []

        def reportError(self, error, fatalError=False):  # noqa: N802 (QGIS API)
            self.said.append(error)

    polygon = QgsVectorLayer("Polygon", "on the photo", "memory")
    feature = QgsFeature()
    feature.setGeometry(QgsGeometry.fromWkt("Polygon ((40 -70, 120 -70, 120 -100, 40 -100, 40 -70))"))
    polygon.dataProvider().addFeatures([feature])
    scene = {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"]}
    runs = [("suggestphotopoints", {"PHOTO": small_scene["photo"], "MAX_POINTS": 20}, False),
            ("phototomap", {**scene, "INPUT": polygon}, True)]
    project = QgsProject.instance()
    # as QGIS adds it, before any post-processing: a GeoPackage's "Undefined Cartesian SRS" made the map ask for a
    # transform and say "No transform available ..." in red (a trial)
    crs_when_added = {}
    watch = lambda layers: crs_when_added.update({lyr.id(): lyr.crs().isValid() for lyr in layers})  # noqa: E731
    from monoplot_plugin.processing import safe_sink

    safe_sink._watch_added_layers()  # as after a first run: Monoplot's slot before this one
    project.layersAdded.connect(watch)
    for output in ("TEMPORARY_OUTPUT", str(tmp_path / "{0}.gpkg")):
        for name, parameters, in_map in runs:
            feedback = Errors()
            before = set(project.mapLayers())
            processing.runAndLoadResults(f"monoplot:{name}", {**parameters, "OUTPUT": output.format(name)},
                                         feedback=feedback)
            loaded = [project.mapLayer(i) for i in set(project.mapLayers()) - before]
            assert feedback.said == [] and len(loaded) == 1, (name, output, feedback.said)
            assert loaded[0].featureCount() > 0
            checked = project.layerTreeRoot().findLayer(loaded[0].id()).itemVisibilityChecked()
            if in_map:
                assert loaded[0].crs().authid() == "EPSG:32632" and checked, (name, output)
            else:  # and off on the map, where photo pixels would stretch the full extent (a desktop trial)
                assert not loaded[0].crs().isValid() and not checked, (name, output, loaded[0].crs().authid())
                assert crs_when_added[loaded[0].id()] is False, (name, output)
            project.removeMapLayer(loaded[0].id())
    project.layersAdded.disconnect(watch)
