"""Photo features -> 3-D map layers (GeoPackage, Shapefile) read back with OGR; map -> photo round trip."""

import math
import os

import numpy as np
import pytest
from osgeo import ogr

from monoplot_plugin.outputs import OutputExistsError
from monoplot_plugin.core.lookup import sample_xyz
from monoplot_plugin.workflow.features import map_to_photo, photo_to_map_feature
from monoplot_plugin.outputs.vectors import MapFeature, write_vector_layer

from outputs_helpers import CRS, plane_height

FIELDS = [("name", "string"), ("year", "integer"), ("thick_m", "real"), ("seen", "date")]


def ground_polygon(scene):
    """A photo polygon fully on the ground, in the lower half of the photo."""
    w, h = scene.camera.width, scene.camera.height
    return np.array([[0.2 * w, 0.6 * h], [0.8 * w, 0.6 * h], [0.7 * w, 0.95 * h], [0.3 * w, 0.9 * h]])


def open_layer(path):
    ds = ogr.Open(str(path))
    assert ds is not None
    return ds, ds.GetLayer(0)


@pytest.mark.parametrize("suffix", [".gpkg", ".shp"])
def test_digitised_features_read_back_with_z_and_attributes(plane_scene, tmp_path, suffix):
    scene = plane_scene
    polygon = photo_to_map_feature("polygon", ground_polygon(scene), scene.xyz,
                                   {"name": "Zunge ö", "year": 1890, "thick_m": 12.5, "seen": "1890-07-14"})
    assert polygon is not None and polygon.sky_parts == 0
    path = write_vector_layer(tmp_path / f"glacier{suffix}", [polygon], scene.dem.crs_wkt, fields=FIELDS)
    ds, layer = open_layer(path)
    assert layer.GetFeatureCount() == 1
    assert ogr.GT_HasZ(layer.GetGeomType())
    assert layer.GetSpatialRef().GetAuthorityCode(None) == "21781"
    feature = layer.GetNextFeature()
    assert feature["name"] == "Zunge ö" and feature["year"] == 1890 and feature["thick_m"] == 12.5
    assert feature["seen"].startswith("1890")
    geom = feature.GetGeometryRef()
    assert geom.Is3D()
    # Vertices lie on the terrain and the area field matches OGR's own planimetric area.
    ring = geom.GetGeometryRef(0).GetGeometryRef(0) if geom.GetGeometryCount() and \
        geom.GetGeometryRef(0).GetGeometryCount() else geom.GetGeometryRef(0)
    pts = np.array(ring.GetPoints())
    assert np.allclose(pts[:, 2], plane_height(pts[:, 0], pts[:, 1]), atol=0.01)
    assert feature["area"] == pytest.approx(geom.GetArea(), rel=1e-6)
    assert feature["area"] > 1e5  # hundreds of metres across at km range
    assert feature["sky_parts"] == 0
    ds = None  # noqa: F841 (closes the GDAL dataset)


def test_lines_follow_terrain_and_sky_parts_are_split_off(plane_scene, tmp_path):
    scene = plane_scene
    w, h = scene.camera.width, scene.camera.height
    sky_row = np.flatnonzero(np.isnan(scene.xyz[:, w // 2, 2]))[-1] - 5  # well inside the sky
    ground_row = int(0.8 * h)
    # Ground -> sky -> ground: one drawn line, two map parts, one sky piece reported.
    line = photo_to_map_feature("line", [[0.2 * w, ground_row], [0.5 * w, sky_row], [0.8 * w, ground_row]],
                                scene.xyz, {"name": "crest"})
    assert line is not None and len(line.parts) == 2 and line.sky_parts == 1
    assert line.measures()["length3d"] >= line.measures()["length"] > 0
    sky_point = photo_to_map_feature("point", [[0.5 * w, sky_row]], scene.xyz)
    assert sky_point is None
    path = write_vector_layer(tmp_path / "lines.gpkg", [line], CRS, fields=[("name", "string")])
    ds, layer = open_layer(path)
    feature = layer.GetNextFeature()
    geom = feature.GetGeometryRef()
    assert geom.GetGeometryName() == "MULTILINESTRING" and geom.GetGeometryCount() == 2
    assert feature["sky_parts"] == 1 and feature["length"] == pytest.approx(geom.Length(), rel=1e-6)
    # Densified: many vertices, each on the terrain.
    pts = np.array(geom.GetGeometryRef(0).GetPoints())
    assert len(pts) > 10
    assert np.allclose(pts[:, 2], plane_height(pts[:, 0], pts[:, 1]), atol=0.01)


def test_polygon_partly_over_sky_keeps_ground_part(plane_scene):
    scene = plane_scene
    w = scene.camera.width
    sky_row = np.flatnonzero(np.isnan(scene.xyz[:, w // 2, 2]))[-1] - 5
    polygon = photo_to_map_feature("polygon", [[0.3 * w, sky_row], [0.7 * w, sky_row], [0.7 * w, 140],
                                               [0.3 * w, 140]], scene.xyz)
    assert polygon is not None and polygon.sky_parts == 1
    assert np.isfinite(polygon.parts[0]).all()


def test_shapefile_limits_and_overwrite(plane_scene, tmp_path):
    feature = MapFeature("point", [[600100.0, 200100.0, 410.0]], {"a_long_field_name": "x"})
    with pytest.raises(ValueError, match="10 characters"):
        write_vector_layer(tmp_path / "p.shp", [feature], CRS, fields=[("a_long_field_name", "string")])
    with pytest.raises(ValueError, match="reserved"):
        write_vector_layer(tmp_path / "p.gpkg", [feature], CRS, fields=[("sky_parts", "integer")])
    path = write_vector_layer(tmp_path / "p.shp", [feature], CRS)
    dbf = (tmp_path / "p.dbf").read_bytes()
    with pytest.raises(OutputExistsError):
        write_vector_layer(tmp_path / "p.shp", [feature, feature], CRS)
    assert (tmp_path / "p.dbf").read_bytes() == dbf
    write_vector_layer(path, [feature, feature], CRS, overwrite=True)
    ds, layer = open_layer(path)
    assert layer.GetFeatureCount() == 2
    assert not [n for n in os.listdir(tmp_path) if "tmp" in n]


def test_overwriting_a_geopackage_keeps_its_other_layers(tmp_path):
    """A desktop trial: "Save drawn features" over a GeoPackage that held two other layers left only the drawn one.
    Now only the layer of that name is replaced; a GeoPackage of that layer alone is replaced whole, as before."""
    from monoplot_plugin.outputs.vectors import other_layers

    point = MapFeature("point", [[600100.0, 200100.0, 410.0]])
    target = tmp_path / "survey.gpkg"
    write_vector_layer(target, [point, point], CRS, layer_name="stakes")
    write_vector_layer(target, [point], CRS, layer_name="cairns", overwrite=True)
    assert other_layers(target, "survey") == ["stakes", "cairns"]
    write_vector_layer(target, [point] * 3, CRS, overwrite=True)  # layer "survey", the file's stem
    write_vector_layer(target, [point] * 4, CRS, overwrite=True)  # again: replaced, not added twice
    ds = ogr.Open(str(target))
    counts = {ds.GetLayer(i).GetName(): ds.GetLayer(i).GetFeatureCount() for i in range(ds.GetLayerCount())}
    assert counts == {"stakes": 2, "cairns": 1, "survey": 4}
    ds = None
    alone = tmp_path / "alone.gpkg"
    write_vector_layer(alone, [point], CRS)
    write_vector_layer(alone, [point] * 2, CRS, overwrite=True)
    ds, layer = open_layer(alone)  # the data source kept alive while its layer is used
    assert other_layers(alone, "alone") == [] and layer.GetFeatureCount() == 2
    assert not [n for n in os.listdir(tmp_path) if "tmp" in n]


def test_polygon_drawn_across_a_ridge_counts_its_silhouette_crossings(tmp_path):
    """A desktop trial: a polygon drawn on the photo across ridges became a map polygon of 11.3 km² of which 1.6 km²
    were seen, and nothing said so. Its outline crosses the ridge's silhouette twice (down one side, up the
    other, at least): ``silhouette`` says so, and a polygon on one slope says 0; both written to the file."""
    from monoplot_plugin.core.camera import Camera
    from monoplot_plugin.core.synthetic import synthetic_terrain
    from monoplot_plugin.core.xyz import compute_xyz_full

    dem = synthetic_terrain((60, 60), cell=50.0, seed=11, relief=800.0)
    x, y = dem.cell_to_map(30, 59)
    cam = Camera((x, y, float(dem.sample(x, y + 40.0)) + 300.0), heading=0.0, pitch=-15.0, roll=2.0, fov=60.0,
                 image_size=(120, 90))
    distance = compute_xyz_full(cam, dem).distance
    # a column where the range jumps by half between two rows that both see terrain: a silhouette
    jumps = np.argwhere(np.isfinite(distance[1:]) & np.isfinite(distance[:-1]) &
                        (distance[:-1] > 1.5 * distance[1:]))
    jumps = jumps[(jumps[:, 1] > 10) & (jumps[:, 1] < 110) & (jumps[:, 0] > 5) & (jumps[:, 0] < 80)]
    assert len(jumps)
    row, col = jumps[0]
    across = [[col - 3, row - 4], [col + 3, row - 4], [col + 3, row + 5], [col - 3, row + 5]]
    below = [[col - 3, row + 3], [col + 3, row + 3], [col + 3, row + 6], [col - 3, row + 6]]
    crossing = photo_to_map_feature("polygon", across, camera=cam, dem=dem)
    one_slope = photo_to_map_feature("polygon", below, camera=cam, dem=dem)
    assert crossing.silhouettes >= 2 and one_slope.silhouettes == 0  # (rough terrain: more ridges may be crossed)
    assert crossing.measures()["silhouette"] == crossing.silhouettes
    path = write_vector_layer(tmp_path / "outlines.gpkg", [crossing, one_slope], CRS)
    ds, layer = open_layer(path)
    assert [f["silhouette"] for f in layer] == [crossing.silhouettes, 0]


def test_map_polygon_to_photo_and_back_within_one_cell(plane_scene):
    scene = plane_scene
    cell = scene.dem.cell_size
    # A map polygon in front of the camera (about 1.5-3 km away).
    ring = np.array([[601500.0, 202000.0], [602600.0, 202100.0], [602500.0, 203300.0], [601700.0, 203000.0],
                     [601500.0, 202000.0]])
    (path,) = map_to_photo([ring], scene.camera, scene.dem)
    assert path.visible.all()
    back = sample_xyz(scene.xyz, path.uv, scene.camera.position)
    dense = np.column_stack([path.uv, back])
    assert np.isfinite(back).all()
    # Every drawn vertex comes back within one DEM cell of the map outline it came from.
    from monoplot_plugin.core.transforms import densify
    truth = densify(ring, cell / 2.0)
    error = np.linalg.norm(back[:, :2] - truth, axis=1)
    assert np.median(error) < cell / 2 and error.max() < cell, (np.median(error), error.max(), dense.shape)


def test_map_line_behind_the_camera_or_off_photo_is_hidden(plane_scene):
    scene = plane_scene
    cam_x, cam_y, _ = scene.camera.position
    line = np.array([[cam_x - 200.0, cam_y - 800.0], [cam_x, cam_y + 2500.0]])  # starts behind the camera
    (path,) = map_to_photo([line], scene.camera, scene.dem)
    assert path.visible.any() and not path.visible.all()
    pieces = path.pieces()
    assert any(vis for _, vis in pieces)
    assert all(np.isfinite(uv).all() for uv, _ in pieces)


@pytest.mark.parametrize("suffix", [".gpkg", ".shp"])
def test_a_line_from_near_to_far_says_how_much_ground_a_pixel_spans_along_it(plane_scene, tmp_path, suffix):
    """A flood line drawn from low above a plain ran from 5 m to 910 m off under a good camera: the ground one
    photo pixel spans is a field of every feature, the median and the worst, whatever the camera's verdict."""
    from monoplot_plugin.core.transforms import photo_points_to_map

    s = plane_scene
    top = np.flatnonzero(np.isfinite(s.xyz[:, 120, 2])).min() + 0.5  # the far edge of the DEM
    line = photo_to_map_feature("line", [[120, 158], [120, top]], camera=s.camera, dem=s.dem)
    ends = photo_points_to_map(np.array([[120, top], [120, top + 1], [120, 157], [120, 158]]), s.camera, s.dem)[0]
    far, near = np.linalg.norm(ends[1, :2] - ends[0, :2]), np.linalg.norm(ends[3, :2] - ends[2, :2])
    assert far > 5 * near  # one pixel of v moves the far end much more than the near one
    assert far / 2 < line.m_px_max < 2 * far
    assert near / 2 < line.m_per_px < line.m_px_max / 5
    path = write_vector_layer(tmp_path / f"flood{suffix}", [line], s.dem.crs_wkt)
    ds, layer = open_layer(path)
    feature = layer.GetNextFeature()
    assert feature["m_per_px"] == pytest.approx(line.m_per_px, abs=1e-3)
    assert feature["m_px_max"] == pytest.approx(line.m_px_max, abs=1e-3)


def test_a_line_from_near_to_far_has_the_xy_error_of_its_far_end_too(plane_scene):
    """A trial's flood line under an "ok" camera: xy_error_m said 2.3 m (the median over the line) while its far
    end was hundreds of metres off. It is the RMS over the line now: the far end weighs in."""
    from monoplot_plugin.core.transforms import ground_error_m

    s = plane_scene
    top = np.flatnonzero(np.isfinite(s.xyz[:, 120, 2])).min() + 0.5
    uv = np.column_stack([np.full(40, 120.0), np.linspace(158.0, top, 40)])
    line = photo_to_map_feature("line", uv, camera=s.camera, dem=s.dem, pixel_rmse=2.0)
    each = ground_error_m(uv, s.camera, s.dem, 2.0)
    each = each[np.isfinite(each)]
    assert line.xy_error_m > 2.0 * float(np.median(each))  # not the median: the far end counts
    assert line.xy_error_m <= float(each.max())
    ds = None  # noqa: F841 (closes the GDAL dataset)
    assert photo_to_map_feature("line", [[120, 158], [120, top]], s.xyz).m_px_max is None  # no camera: unknown


@pytest.mark.parametrize("suffix", [".gpkg", ".shp"])
def test_a_feature_on_a_slope_says_how_far_off_its_heights_may_be(plane_scene, tmp_path, suffix):
    """``z_error_m``: a flood analyst's marks were 3-6 m too high under a camera whose pixel error was known, and
    only the cursor gave heights a ±. It is the RMS of the height error of the feature's ground samples (the
    pixel error carried by the slope's footprint), written with the other measures."""
    from monoplot_plugin.core.transforms import ground_error_m

    s = plane_scene
    top = np.flatnonzero(np.isfinite(s.xyz[:, 120, 2])).min() + 0.5
    uv = np.column_stack([np.full(40, 120.0), np.linspace(158.0, top, 40)])
    line = photo_to_map_feature("line", uv, camera=s.camera, dem=s.dem, pixel_rmse=2.0)
    each = ground_error_m(uv, s.camera, s.dem, 2.0, vertical=True)
    each = each[np.isfinite(each)]
    assert float(each.min()) > 0  # a tilted plane: a pixel's footprint climbs
    assert line.z_error_m == pytest.approx(float(np.sqrt(np.mean(each ** 2))), rel=0.05)
    assert 0 < line.z_error_m < line.xy_error_m  # the plane climbs less than it runs
    assert photo_to_map_feature("line", uv, camera=s.camera, dem=s.dem).z_error_m is None  # no pixel error
    path = write_vector_layer(tmp_path / f"marks{suffix}", [line], s.dem.crs_wkt)
    ds, layer = open_layer(path)
    assert layer.GetNextFeature()["z_error_m"] == pytest.approx(line.z_error_m, abs=1e-3)
    ds = None  # noqa: F841 (closes the GDAL dataset)


@pytest.mark.parametrize("suffix", [".gpkg", ".shp"])
def test_a_polygon_on_a_slope_says_its_area_along_the_terrain(plane_scene, tmp_path, suffix):
    """A drone trial's rockfall scar on a 45° slope: 9994 m² in ``area`` (the map's), 14184 m² of rock face, and
    nothing said which the field was. ``area3d`` is the area along the terrain's surface: on the scene's plane,
    z = 400 + 0.1 x, the map area times sqrt(1 + 0.1²)."""
    s = plane_scene
    ring = [[60, 150], [100, 150], [100, 110], [60, 110]]
    polygon = photo_to_map_feature("polygon", ring, camera=s.camera, dem=s.dem)
    measures = polygon.measures()
    assert measures["area3d"] == pytest.approx(measures["area"] * math.sqrt(1.01), rel=1e-3)
    assert photo_to_map_feature("polygon", ring, s.xyz).measures().get("area3d") is None  # no DEM: unknown
    path = write_vector_layer(tmp_path / f"scar{suffix}", [polygon], s.dem.crs_wkt)
    ds, layer = open_layer(path)
    assert layer.GetNextFeature()["area3d"] == pytest.approx(measures["area3d"], abs=0.1)
    ds = None  # noqa: F841 (closes the GDAL dataset)
