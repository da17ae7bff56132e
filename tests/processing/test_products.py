"""XYZ raster, photo -> map, map -> photo and orthophoto algorithms through processing.run on real files."""

from pathlib import Path

import numpy as np
import pytest
from osgeo import gdal
from qgis.core import (NULL, QgsFeature, QgsGeometry, QgsPointXY, QgsProcessingException, QgsProcessingFeedback,
                       QgsVectorLayer)

from monoplot_plugin.core.dem import Dem
from monoplot_plugin.core.xyz import compute_xyz, compute_xyz_full
from monoplot_plugin.workflow.camera_files import camera_json


def test_compute_xyz_writes_photo_sized_raster_matching_core(run_alg, small_scene, tmp_path):
    out = tmp_path / "xyz.tif"
    result = run_alg("computexyz", {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"],
                                    "OUTPUT": str(out)})
    ds = gdal.Open(str(out))
    assert (ds.RasterXSize, ds.RasterYSize, ds.RasterCount) == (160, 120, 3)
    written = np.dstack([ds.GetRasterBand(b).ReadAsArray() for b in (1, 2, 3)])
    expected = compute_xyz(small_scene["cam"], Dem.open(small_scene["dem"]))
    ground = np.isfinite(expected[..., 2])
    assert 0.2 < ground.mean() < 0.98  # terrain and sky both in view
    assert result["GROUND_FRACTION"] == pytest.approx(ground.mean())
    assert np.allclose(written[ground], expected[ground], atol=1.0)
    assert np.isnan(written[~ground]).all()


def test_xyz_raster_loads_as_the_dock_adds_it(processing_provider, small_scene, tmp_path):
    """A desktop trial: computexyz's result loaded visible and grey, in photo pixels, and "zoom full" went to
    1:180,000,000. Loaded as the dock adds it: no CRS, unchecked, Z as a colour ramp."""
    import processing
    from qgis.core import QgsProject

    from qgis.core import QgsProcessingFeedback

    class Errors(QgsProcessingFeedback):
        said: list = []

        def reportError(self, error, fatalError=False):  # noqa: N802 (QGIS API)
            self.said.append(error)

    project = QgsProject.instance()
    # a file, and the default temporary output (a re-check trial: "The following layers were not correctly
    # generated" after every temporary one)
    for output in (str(tmp_path / "xyz.tif"), "TEMPORARY_OUTPUT"):
        before, feedback = set(project.mapLayers()), Errors()
        processing.runAndLoadResults("monoplot:computexyz", {"CAMERA": small_scene["camera"],
                                                              "DEM": small_scene["dem"], "OUTPUT": output},
                                     feedback=feedback)
        (layer,) = [project.mapLayer(i) for i in set(project.mapLayers()) - before]
        assert feedback.said == []
        assert not layer.crs().isValid() and layer.renderer().type() == "singlebandpseudocolor"
        assert layer.renderer().band() == 3
        assert not project.layerTreeRoot().findLayer(layer.id()).itemVisibilityChecked()
        project.removeMapLayer(layer.id())


def test_camera_for_another_image_shape_is_refused_and_for_another_resolution_scaled(run_alg, small_scene,
                                                                                     tmp_path):
    from tests.processing.conftest import write_photo

    other = write_photo(tmp_path / "wide.png", size=(200, 120))  # the camera's is 160x120: a crop, another camera
    with pytest.raises(QgsProcessingException, match="200x120, another shape"):
        run_alg("orthophoto", {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"], "PHOTO": str(other),
                               "OUTPUT": str(tmp_path / "o.tif")})
    bigger = write_photo(tmp_path / "big.png", size=(320, 240))  # the same picture at twice the resolution
    out = tmp_path / "xyz.tif"
    run_alg("computexyz", {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"], "PHOTO": str(bigger),
                           "OUTPUT": str(out)})
    assert (gdal.Open(str(out)).RasterXSize, gdal.Open(str(out)).RasterYSize) == (320, 240)


def test_missing_camera_file_is_a_clear_error(run_alg, small_scene, tmp_path):
    with pytest.raises(QgsProcessingException, match="camera file not found"):
        run_alg("computexyz", {"CAMERA": str(tmp_path / "nope.json"), "DEM": small_scene["dem"],
                               "OUTPUT": str(tmp_path / "x.tif")})


def photo_polygon_layer(vertices_uv):
    layer = QgsVectorLayer("Polygon", "drawn", "memory")
    feature = QgsFeature()
    feature.setGeometry(QgsGeometry.fromPolygonXY([[QgsPointXY(u, -v) for u, v in vertices_uv]]))
    layer.dataProvider().addFeatures([feature])
    return layer


def test_photo_polygon_becomes_3d_map_polygon_on_the_terrain(run_alg, small_scene, tmp_path):
    cam = small_scene["cam"]
    dem = Dem.open(small_scene["dem"])
    xyz = compute_xyz(cam, dem)
    rows, cols = np.nonzero(np.isfinite(xyz[..., 2]))
    v0, v1 = np.percentile(rows, [60, 90])
    u0, u1 = 40, 120
    drawn = photo_polygon_layer([(u0, v0), (u1, v0), (u1, v1), (u0, v1)])
    out = tmp_path / "outline.gpkg"
    result = run_alg("phototomap", {"INPUT": drawn, "CAMERA": small_scene["camera"], "DEM": small_scene["dem"],
                                    "STEP": 5, "OUTPUT": str(out)})
    layer = QgsVectorLayer(result["OUTPUT"], "out", "ogr")
    assert layer.isValid() and layer.featureCount() == 1
    assert layer.crs().authid() == "EPSG:32632"
    geometry = next(layer.getFeatures()).geometry()
    vertices = np.array([(p.x(), p.y(), p.z()) for p in geometry.vertices()])
    assert len(vertices) > 4 * 10  # densified along the edges
    assert np.allclose(vertices[:, 2], dem.sample(vertices[:, 0], vertices[:, 1]), atol=15.0)  # on the terrain
    back = cam.project(vertices)
    assert back[:, 0].min() == pytest.approx(u0, abs=1.5) and back[:, 0].max() == pytest.approx(u1, abs=1.5)
    # the measures the dock's drawings carry (a desktop trial: Processing kept only the input's fields)
    feature = next(layer.getFeatures())
    assert geometry.area() > 0 and feature["area"] == pytest.approx(geometry.area(), rel=1e-6)
    # and its area along the terrain: larger, by the DEM's slopes inside (the dock's surface_factor)
    from monoplot_plugin.workflow.features import surface_factor

    ring = vertices[:, :2]
    assert feature["area3d"] == pytest.approx(feature["area"] * surface_factor(ring, dem), rel=1e-3)
    assert feature["area3d"] > feature["area"]
    assert feature["length"] == pytest.approx(geometry.length(), rel=1e-6) and feature["sky_parts"] == 0
    assert feature["xy_error_m"] in (None, NULL)  # no pixel error given: no claim
    # With the fit's pixel error: the median footprint of the outline's ground points, twice as large for twice
    # the error, and of the size a pixel covers there (a few metres at this range, not millimetres or kilometres)
    errors = []
    for pixel_error in (1.0, 2.0):
        result = run_alg("phototomap", {"INPUT": drawn, "CAMERA": small_scene["camera"], "DEM": small_scene["dem"],
                                        "STEP": 5, "PIXEL_ERROR": pixel_error, "OUTPUT": "memory:"})
        errors.append(next(result["OUTPUT"].getFeatures())["xy_error_m"])
    footprint = float(np.median(np.linalg.norm(vertices - cam.position, axis=1))) / cam.focal_px
    assert 0.3 * footprint < errors[0] < 10 * footprint and errors[1] == pytest.approx(2 * errors[0], rel=0.2)


def test_photo_features_carry_the_verdict_of_their_camera_file(run_alg, small_scene):
    """As the dock's drawings: fit_status says how sure the camera was (a trial's outline from an "uncertain" camera
    read in its file as any other); empty for a camera file without a verdict."""
    cam = small_scene["cam"]
    rows = np.nonzero(np.isfinite(compute_xyz(cam, Dem.open(small_scene["dem"]))[..., 2]))[0]
    v0, v1 = np.percentile(rows, [60, 90])
    drawn = photo_polygon_layer([(40, v0), (120, v0), (120, v1), (40, v1)])
    statuses = []
    for camera in (small_scene["camera"], small_scene["fitted"]):
        result = run_alg("phototomap", {"INPUT": drawn, "CAMERA": camera, "DEM": small_scene["dem"], "STEP": 5,
                                        "OUTPUT": "memory:"})
        statuses.append(next(result["OUTPUT"].getFeatures())["fit_status"])
    assert statuses[0] in (None, NULL) and statuses[1] == "ok"
    # an "uncertain" camera: its verdict, and no xy_error_m even with a pixel error given (as the dock)
    doubtful = Path(small_scene["dir"]) / "doubtful.json"
    doubtful.write_text(camera_json(cam, {"status": "uncertain", "message": "generated"}))
    errors = {}
    for camera in (small_scene["fitted"], str(doubtful)):
        feedback = QgsProcessingFeedback()
        result = run_alg("phototomap", {"INPUT": drawn, "CAMERA": camera, "DEM": small_scene["dem"], "STEP": 5,
                                        "PIXEL_ERROR": 2.0, "OUTPUT": "memory:"}, feedback)
        feature = next(result["OUTPUT"].getFeatures())
        errors[feature["fit_status"]] = (feature["xy_error_m"], feedback.textLog(), feature["z_error_m"])
    assert errors["ok"][0] > 0 and errors["ok"][2] > 0 and "left empty" not in errors["ok"][1]
    assert errors["uncertain"][0] in (None, NULL) and errors["uncertain"][2] in (None, NULL)
    assert "xy_error_m and z_error_m are left empty" in errors["uncertain"][1]


def test_map_line_projects_onto_photo_and_back(run_alg, small_scene, tmp_path):
    cam = small_scene["cam"]
    dem = Dem.open(small_scene["dem"])
    xyz = compute_xyz(cam, dem)
    ground = xyz[np.isfinite(xyz[..., 2])]
    a, b = ground[len(ground) // 3], ground[2 * len(ground) // 3]
    line = QgsVectorLayer("LineString?crs=EPSG:32632", "line", "memory")
    feature = QgsFeature()
    feature.setGeometry(QgsGeometry.fromPolylineXY([QgsPointXY(a[0], a[1]), QgsPointXY(b[0], b[1])]))
    line.dataProvider().addFeatures([feature])
    result = run_alg("maptophoto", {"INPUT": line, "CAMERA": small_scene["camera"], "DEM": small_scene["dem"],
                                    "STEP": 10, "HIDDEN": False, "OUTPUT": "memory:"})
    out = result["OUTPUT"]
    photo_vertices = np.array([(p.x(), -p.y()) for f in out.getFeatures() for p in f.geometry().vertices()])
    expected = cam.project(np.array([a, b]))
    assert np.allclose(photo_vertices[0], expected[0], atol=1.0)
    assert np.allclose(photo_vertices[-1], expected[1], atol=1.0)


def test_orthophoto_colours_come_from_the_photo(run_alg, small_scene, tmp_path):
    import cv2

    out = tmp_path / "ortho.tif"
    run_alg("orthophoto", {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"],
                           "PHOTO": small_scene["photo"], "OUTPUT": str(out)})
    ds = gdal.Open(str(out))
    dem = Dem.open(small_scene["dem"])
    # by default at the photo's own detail over what the camera sees, as the dock's (a drone trial's 5 cm pixels were
    # written on the DEM's 1 m cells over all of it): no coarser than the DEM's cells, within the DEM
    x0, dx, _, y0, _, dy = ds.GetGeoTransform()
    assert ds.RasterCount == 4 and dx <= dem.cell_size and dx == -dy
    assert x0 >= dem.bounds()[0] - dx and y0 <= dem.bounds()[3] + dx
    alpha = ds.GetRasterBand(4).ReadAsArray()
    assert 0.05 < (alpha == 255).mean() <= 1.0
    # a seen cell has the colour of the pixel its centre projects to
    grid = Dem.from_array(np.zeros((ds.RasterYSize, ds.RasterXSize)), ds.GetGeoTransform())
    r, c = np.argwhere(alpha == 255)[len(np.argwhere(alpha == 255)) // 2]
    x, y = grid.cell_to_map(c + 0.5, r + 0.5)
    u, v = small_scene["cam"].project([[float(x), float(y), float(dem.sample(float(x), float(y)))]])[0]
    photo = cv2.imread(small_scene["photo"])[:, :, ::-1]
    rgb = [ds.GetRasterBand(b).ReadAsArray()[r, c] for b in (1, 2, 3)]
    assert list(rgb) == photo[int(v), int(u)].tolist()


def test_report_png_is_written(run_alg, small_scene, tmp_path):
    import cv2

    from monoplot_plugin.processing.inputs import write_points_csv

    cam = small_scene["cam"]
    xyz = compute_xyz(cam, Dem.open(small_scene["dem"]))
    ground = xyz[np.isfinite(xyz[..., 2])][::500][:10]
    points = tmp_path / "check.csv"
    write_points_csv(str(points), uv=cam.project(ground) + 0.5, xyz=ground)
    out = tmp_path / "report.png"
    run_alg("report", {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"], "PHOTO": small_scene["photo"],
                       "POINTS_CSV": str(points), "OUTPUT": str(out)})
    image = cv2.imread(str(out))
    assert image is not None and image.shape[0] > 400 and image.shape[1] > 400
    assert image.std() > 10  # a drawn page, not a blank one


def test_map_to_photo_drops_points_hidden_behind_terrain(run_alg, small_scene):
    cam = small_scene["cam"]
    dem = Dem.open(small_scene["dem"])
    xyz = compute_xyz(cam, dem)
    seen = xyz[90, 80]  # a ground point in the lower middle of the photo
    assert np.isfinite(seen).all()
    direction = (seen - np.asarray(cam.position)) / np.linalg.norm(seen - np.asarray(cam.position))
    behind_xy = seen[:2] + 400.0 * direction[:2]  # further along the same line of sight, on the ground
    behind = np.array([*behind_xy, float(dem.sample(behind_xy[:1], behind_xy[1:])[0])])
    layer = QgsVectorLayer("PointZ?crs=EPSG:32632", "pts", "memory")
    features = []
    for p in (seen, behind):
        f = QgsFeature()
        f.setGeometry(QgsGeometry.fromWkt(f"PointZ ({p[0]} {p[1]} {p[2]})"))
        features.append(f)
    layer.dataProvider().addFeatures(features)
    common = {"INPUT": layer, "CAMERA": small_scene["camera"], "DEM": small_scene["dem"], "OUTPUT": "memory:"}
    both = list(run_alg("maptophoto", {**common, "HIDDEN": False})["OUTPUT"].getFeatures())
    assert [f["visible_share"] for f in both] == [1.0, 0.0]  # kept, but said to be hidden (a desktop trial)
    kept = list(run_alg("maptophoto", {**common, "HIDDEN": True})["OUTPUT"].getFeatures())
    assert len(kept) == 1 and kept[0]["visible_share"] == 1.0
    u, v = kept[0].geometry().vertices().next().x(), -kept[0].geometry().vertices().next().y()
    assert np.allclose([u, v], cam.project([seen])[0], atol=0.5)


def test_map_line_into_hidden_ground_keeps_only_its_visible_part(run_alg, small_scene):
    """A line from a seen point to a hidden one (with 'drop hidden parts') keeps the seen end and loses the other."""
    cam = small_scene["cam"]
    dem = Dem.open(small_scene["dem"])
    seen = compute_xyz(cam, dem)[90, 80]
    direction = (seen - np.asarray(cam.position)) / np.linalg.norm(seen - np.asarray(cam.position))
    behind = seen[:2] + 400.0 * direction[:2]
    line = QgsVectorLayer("LineString?crs=EPSG:32632", "line", "memory")
    feature = QgsFeature()
    feature.setGeometry(QgsGeometry.fromPolylineXY([QgsPointXY(seen[0], seen[1]), QgsPointXY(*behind)]))
    line.dataProvider().addFeatures([feature])
    common = {"INPUT": line, "CAMERA": small_scene["camera"], "DEM": small_scene["dem"], "STEP": 10,
              "OUTPUT": "memory:"}

    def vertices(hidden):
        out = run_alg("maptophoto", {**common, "HIDDEN": hidden})["OUTPUT"]
        return np.array([(p.x(), -p.y()) for f in out.getFeatures() for p in f.geometry().vertices()])

    whole, visible = vertices(False), vertices(True)
    assert len(whole) >= 30  # 400 m densified every 10 m
    assert 2 <= len(visible) < len(whole)  # the far end, behind the near slope, is gone
    assert np.allclose(visible[0], cam.project([seen])[0], atol=1.0)
    share = next(run_alg("maptophoto", {**common, "HIDDEN": False})["OUTPUT"].getFeatures())["visible_share"]
    assert share == pytest.approx(len(visible) / len(whole), abs=0.05)

    # A polygon around the same stretch of ground is drawn whole, and says how much of its outline is seen.
    polygon = QgsVectorLayer("Polygon?crs=EPSG:32632", "area", "memory")
    side = np.array([-direction[1], direction[0]]) * 60.0
    ring = [seen[:2] - side, seen[:2] + side, behind + side, behind - side, seen[:2] - side]
    feature = QgsFeature()
    feature.setGeometry(QgsGeometry.fromPolygonXY([[QgsPointXY(*p) for p in ring]]))
    polygon.dataProvider().addFeatures([feature])
    drawn = [next(run_alg("maptophoto", {**common, "INPUT": polygon, "HIDDEN": hidden})["OUTPUT"].getFeatures())
             for hidden in (False, True)]
    assert drawn[0].geometry().equals(drawn[1].geometry())
    assert 0.05 < drawn[0]["visible_share"] < 0.95 and drawn[0]["visible_share"] == drawn[1]["visible_share"]


def test_geographic_dem_is_used_in_its_utm_zone(run_alg, small_scene, tmp_path):
    geographic = tmp_path / "dem_wgs84.tif"
    gdal.Warp(str(geographic), small_scene["dem"], dstSRS="EPSG:4326", resampleAlg="bilinear")
    out = tmp_path / "xyz.tif"
    result = run_alg("computexyz", {"CAMERA": small_scene["camera"], "DEM": str(geographic), "OUTPUT": str(out)})
    ds = gdal.Open(str(out))
    z = ds.GetRasterBand(3).ReadAsArray()
    expected = compute_xyz(small_scene["cam"], Dem.open(small_scene["dem"]))[..., 2]
    both = np.isfinite(z) & np.isfinite(expected)
    assert both.mean() > 0.3 and result["GROUND_FRACTION"] > 0.3
    assert np.median(np.abs(z[both] - expected[both])) < 10.0  # same terrain, resampled twice
    assert "32632" in ds.GetMetadataItem("MONOPLOT_VALUE_CRS_AUTHID") or "UTM zone 32N" in \
        ds.GetMetadataItem("MONOPLOT_VALUE_CRS")


def test_orthophoto_at_another_resolution(run_alg, small_scene, tmp_path):
    """At a cell size of the person's choosing, over the part of the DEM the camera sees (a desktop trial: 10 m
    cells over the whole DEM, 3.5 % of them with data): within the DEM's 40 x 40 cells of 60 m, every seen
    ground point inside the grid."""
    out = tmp_path / "ortho60.tif"
    run_alg("orthophoto", {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"],
                           "PHOTO": small_scene["photo"], "RESOLUTION": 60, "OUTPUT": str(out)})
    ds = gdal.Open(str(out))
    x0, dx, _, y0, _, dy = ds.GetGeoTransform()
    assert ds.RasterXSize <= 40 and ds.RasterYSize <= 40 and dx == 60.0
    assert 0.05 < (ds.GetRasterBand(4).ReadAsArray() == 255).mean() < 0.95
    seen = compute_xyz(small_scene["cam"], Dem.open(small_scene["dem"]))
    seen = seen[np.isfinite(seen[..., 2])]
    assert x0 <= seen[:, 0].min() and seen[:, 0].max() <= x0 + dx * ds.RasterXSize
    assert y0 + dy * ds.RasterYSize <= seen[:, 1].min() and seen[:, 1].max() <= y0
    assert ds.GetMetadataItem("MONOPLOT_FIT") is None  # a camera file with no verdict: nothing to say


def test_an_orthophoto_says_the_verdict_of_its_camera(run_alg, small_scene, tmp_path):
    """An orthophoto lies in a folder beside others: its file says how sure its camera is, as the XYZ raster's."""
    import json

    out = tmp_path / "ortho.tif"
    run_alg("orthophoto", {"CAMERA": small_scene["fitted"], "DEM": small_scene["dem"],
                           "PHOTO": small_scene["photo"], "RESOLUTION": 60, "OUTPUT": str(out)})
    kept = json.loads(gdal.Open(str(out)).GetMetadataItem("MONOPLOT_FIT"))
    assert kept["status"] == "ok" and kept["message"] == "the scene's true camera"


def test_photo_line_into_the_sky_is_cut_where_it_leaves_the_ground(run_alg, small_scene):
    cam = small_scene["cam"]
    xyz = compute_xyz(cam, Dem.open(small_scene["dem"]))
    column = xyz[:, 80, 2]
    sky_rows = np.flatnonzero(~np.isfinite(column))
    ground_rows = np.flatnonzero(np.isfinite(column))
    assert len(sky_rows) and len(ground_rows)
    line = QgsVectorLayer("LineString", "drawn", "memory")
    feature = QgsFeature()
    feature.setGeometry(QgsGeometry.fromPolylineXY([QgsPointXY(80.5, -(ground_rows.max() + 0.5)),
                                                    QgsPointXY(80.5, -(sky_rows.min() + 0.5))]))
    line.dataProvider().addFeatures([feature])
    result = run_alg("phototomap", {"INPUT": line, "CAMERA": small_scene["camera"], "DEM": small_scene["dem"],
                                    "STEP": 1, "OUTPUT": "memory:"})
    assert result["DROPPED"] > 0
    vertices = np.array([(p.x(), p.y(), p.z()) for f in result["OUTPUT"].getFeatures()
                         for p in f.geometry().vertices()])
    assert len(vertices) >= 2 and np.isfinite(vertices).all()
    rows = cam.project(vertices)[:, 1]
    assert rows.min() > sky_rows.min() - 1  # nothing mapped from the sky part


def test_kml_camera_without_photo_says_what_is_missing(run_alg, small_scene, tmp_path):
    kml = tmp_path / "prior.kml"
    kml.write_text("<kml><PhotoOverlay><Camera><longitude>9</longitude><latitude>46</latitude></Camera>"
                   "<ViewVolume><leftFov>-20</leftFov><rightFov>20</rightFov></ViewVolume></PhotoOverlay></kml>")
    with pytest.raises(QgsProcessingException, match="needs the photo"):
        run_alg("computexyz", {"CAMERA": str(kml), "DEM": small_scene["dem"], "OUTPUT": str(tmp_path / "x.tif")})


def test_cancel_during_feature_loop_is_a_clean_error_and_frees_the_cache(run_alg, small_scene):
    from qgis.core import QgsProcessingFeedback

    from monoplot_plugin.workflow import xyz

    feedback = QgsProcessingFeedback()
    feedback.cancel()
    drawn = photo_polygon_layer([(40, 80), (120, 80), (120, 110), (40, 110)])
    with pytest.raises(QgsProcessingException, match="Canceled"):
        run_alg("phototomap", {"INPUT": drawn, "CAMERA": small_scene["camera"], "DEM": small_scene["dem"],
                               "OUTPUT": "memory:"}, feedback)
    assert not xyz._cache


def test_photo_line_across_a_silhouette_is_cut_there(run_alg, small_scene):
    """A line drawn down the photo from a far slope onto the ridge in front of it: the map line must not join the
    two (it would cross ground hidden behind the ridge); it is cut where the range jumps."""
    cam = small_scene["cam"]
    distance = compute_xyz_full(cam, Dem.open(small_scene["dem"]), visibility=False).distance
    jumps = np.abs(np.diff(distance, axis=0)) > 0.2 * np.fmin(distance[:-1], distance[1:])
    col = int(np.flatnonzero(np.nan_to_num(jumps).any(axis=0))[-1])
    row = int(np.flatnonzero(jumps[:, col])[0])  # far slope in pixel row `row`, the ridge from row + 1
    assert np.isfinite(distance[row - 1:row + 12, col]).all()
    line = QgsVectorLayer("LineString", "drawn", "memory")
    feature = QgsFeature()
    feature.setGeometry(QgsGeometry.fromPolylineXY([QgsPointXY(col + 0.5, -(row - 0.8)),
                                                    QgsPointXY(col + 0.5, -(row + 10.5))]))
    line.dataProvider().addFeatures([feature])
    result = run_alg("phototomap", {"INPUT": line, "CAMERA": small_scene["camera"], "DEM": small_scene["dem"],
                                    "STEP": 0.25, "OUTPUT": "memory:"})
    parts = [np.array([(p.x(), p.y(), p.z()) for p in part.vertices()])
             for f in result["OUTPUT"].getFeatures() for part in f.geometry().constParts()]
    assert len(parts) == 2
    far, near = sorted(parts, key=lambda a: -np.linalg.norm(a[0] - np.asarray(cam.position)))
    gap = np.linalg.norm(far[-1, :2] - near[0, :2])
    steps = max(np.linalg.norm(np.diff(p[:, :2], axis=0), axis=1).max() for p in parts)
    assert gap > 10 * steps  # the hidden ground between the pieces is not bridged


class _RecordingFeedback:
    """A QgsProcessingFeedback that keeps what the algorithm reported."""

    def __new__(cls):
        from qgis.core import QgsProcessingFeedback

        class Recording(QgsProcessingFeedback):
            def __init__(self):
                super().__init__()
                self.errors, self.warnings = [], []

            def reportError(self, error, fatalError=False):  # noqa: N802, N803 (QGIS API)
                self.errors.append(error)
                super().reportError(error, fatalError)

            def pushWarning(self, warning):  # noqa: N802 (QGIS API)
                self.warnings.append(warning)
                super().pushWarning(warning)

        return Recording()


def test_map_polygon_whose_corners_are_outside_the_photo_is_still_drawn(run_alg, small_scene):
    """A strip across the view with its four corners far outside the image: corners alone (the old default, no
    densifying) found no visible vertex and the output was silently empty. A box behind the camera is skipped and
    said so."""
    layer = QgsVectorLayer("Polygon?crs=EPSG:32632", "strip", "memory")
    features = []
    for ring in ([(497000, 5098900), (506000, 5098900), (506000, 5099100), (497000, 5099100)],
                 [(501000, 5090000), (501400, 5090000), (501400, 5090400), (501000, 5090400)]):
        f = QgsFeature()
        f.setGeometry(QgsGeometry.fromPolygonXY([[QgsPointXY(x, y) for x, y in ring]]))
        features.append(f)
    layer.dataProvider().addFeatures(features)
    feedback = _RecordingFeedback()
    out = run_alg("maptophoto", {"INPUT": layer, "CAMERA": small_scene["camera"], "DEM": small_scene["dem"],
                                 "HIDDEN": True, "OUTPUT": "memory:"}, feedback=feedback)["OUTPUT"]
    kept = list(out.getFeatures())
    assert len(kept) == 1
    u = [p.x() for p in kept[0].geometry().vertices()]
    assert min(u) < 80 < max(u)  # across the middle of the 160 px wide photo
    # a warning, not an error: the algorithm did its work
    assert any("1 of 2 feature(s) are not visible" in w for w in feedback.warnings), feedback.warnings
    assert not feedback.errors


def test_a_dem_layer_of_the_project_is_taken_by_its_id_or_as_a_layer(run_alg, small_scene, tmp_path):
    """The Processing dialog passes a DEM that is a layer of the project by its layer id (even when a path was
    typed): that must read the layer's file, not look for a file named like the id."""
    from qgis.core import QgsProject, QgsRasterLayer

    layer = QgsRasterLayer(small_scene["dem"], "the DEM")
    assert layer.isValid()
    QgsProject.instance().addMapLayer(layer)
    try:
        for value in (layer.id(), layer, small_scene["dem"]):
            out = tmp_path / f"xyz_{type(value).__name__}.tif"
            result = run_alg("computexyz", {"CAMERA": small_scene["camera"], "DEM": value, "OUTPUT": str(out)})
            assert 0.2 < result["GROUND_FRACTION"] < 0.98 and out.is_file()
        with pytest.raises(QgsProcessingException, match="not found"):  # neither a layer nor a file
            run_alg("computexyz", {"CAMERA": small_scene["camera"], "DEM": "no_such_dem.tif",
                                   "OUTPUT": str(tmp_path / "x.tif")})
    finally:
        QgsProject.instance().removeMapLayer(layer.id())


def test_ground_fraction_is_the_written_files_when_a_prints_border_is_left_out(run_alg, aletsch_dir, tmp_path):
    """A trial: GROUND_FRACTION and the log said 83.8 % on Aletsch while the file had 71.9 % (the print's border
    and caption are nodata, left out after the share was counted)."""
    from monoplot_plugin.core.camera import Camera
    from monoplot_plugin.core.fit import fit_camera

    dem = Dem.open(aletsch_dir / "dem.tif", void_value=0)
    gcps = np.loadtxt(aletsch_dir / "gcps.csv", delimiter=",", skiprows=1)
    ds = gdal.Open(str(aletsch_dir / "photo.jpg"))
    size = (ds.RasterXSize, ds.RasterYSize)
    prior = Camera.from_kml(str(aletsch_dir / "prior_pose.kml"), size, dem.crs_wkt)
    pairs = np.column_stack([np.arange(len(gcps))] * 2)
    camera = tmp_path / "camera.json"
    fit_camera(gcps[:, :2], gcps[:, 2:], prior, pairs=pairs).camera.save(camera)
    out = tmp_path / "xyz.tif"
    result = run_alg("computexyz", {"CAMERA": str(camera), "DEM": str(aletsch_dir / "dem.tif"), "VOID_VALUE": 0,
                                    "PHOTO": str(aletsch_dir / "photo.jpg"), "OUTPUT": str(out)})
    written = gdal.Open(str(out))
    z = written.GetRasterBand(3).ReadAsArray().astype(float)
    nodata = written.GetRasterBand(3).GetNoDataValue()
    valid = np.isfinite(z) & (z != nodata) if nodata is not None else np.isfinite(z)
    everything = np.isfinite(compute_xyz(Camera.load(camera), dem)[..., 2]).mean()
    assert valid.mean() < everything - 0.05  # the border is left out ...
    assert result["GROUND_FRACTION"] == pytest.approx(valid.mean(), abs=1e-6)  # ... and the share said is the file's


def test_lines_drawn_on_a_prints_border_get_no_ground_when_the_photo_is_given(run_alg, aletsch_dir, tmp_path):
    """A re-check trial: a line drawn on a print's caption became a 27 m map line in phototomap too. With PHOTO,
    the paper border of the Aletsch photo (its bottom rows under the picture) gives no ground."""
    from monoplot_plugin.core.camera import Camera
    from monoplot_plugin.core.fit import fit_camera

    dem = Dem.open(aletsch_dir / "dem.tif", void_value=0)
    gcps = np.loadtxt(aletsch_dir / "gcps.csv", delimiter=",", skiprows=1)
    prior = Camera.from_kml(str(aletsch_dir / "prior_pose.kml"), (1024, 763), dem.crs_wkt)
    camera = tmp_path / "camera.json"
    fit_camera(gcps[:, :2], gcps[:, 2:], prior, pairs=np.column_stack([np.arange(11)] * 2)).camera.save(camera)
    layer = QgsVectorLayer("LineString", "drawn", "memory")
    features = []
    for v in (752.0, 600.0):  # on the white border under the picture; in the picture
        f = QgsFeature()
        f.setGeometry(QgsGeometry.fromPolylineXY([QgsPointXY(300, -v), QgsPointXY(700, -v)]))
        features.append(f)
    layer.dataProvider().addFeatures(features)
    common = {"INPUT": layer, "CAMERA": str(camera), "DEM": str(aletsch_dir / "dem.tif"), "VOID_VALUE": 0,
              "STEP": 5}
    without = run_alg("phototomap", {**common, "OUTPUT": str(tmp_path / "a.gpkg")})
    assert QgsVectorLayer(without["OUTPUT"], "a", "ogr").featureCount() == 2  # the border line on the ground
    given = run_alg("phototomap", {**common, "PHOTO": str(aletsch_dir / "photo.jpg"),
                                   "OUTPUT": str(tmp_path / "b.gpkg")})
    assert QgsVectorLayer(given["OUTPUT"], "b", "ogr").featureCount() == 1 and given["DROPPED"] > 0


def test_an_outline_that_crosses_itself_is_mapped_with_a_warning(processing_provider, small_scene, tmp_path):
    """A trial's flood outline crossed itself once: the dock mapped it, phototomap refused it under QGIS's default
    "stop on invalid geometry" and left a temporary file in the output folder (and Python 3.11 broken: the check's
    abort is thrown from inside the feature iterator). It is mapped as drawn, with a warning."""
    import processing
    from qgis.core import QgsFeatureRequest, QgsProcessingContext

    from tests.processing.conftest import recording_feedback

    bow_tie = photo_polygon_layer([(40, 70), (120, 110), (120, 70), (40, 110)])
    assert not next(bow_tie.getFeatures()).geometry().isGeosValid()
    context = QgsProcessingContext()
    context.setInvalidGeometryCheck(QgsFeatureRequest.GeometryAbortOnInvalid)
    log = recording_feedback()
    result = processing.run("monoplot:phototomap", {"INPUT": bow_tie, "CAMERA": small_scene["camera"],
                                                    "DEM": small_scene["dem"], "STEP": 5,
                                                    "OUTPUT": str(tmp_path / "out.gpkg")}, context=context,
                            feedback=log)
    assert QgsVectorLayer(result["OUTPUT"], "out", "ogr").featureCount() == 1
    assert any("crosses itself" in w for w in log.warnings)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.gpkg"]  # nothing else left behind
