"""Bad DEMs, photos, point tables and cameras through the Processing algorithms (in-process): each case asserts
the message the user sees, and that the earlier output at OUTPUT survives byte for byte (no temporary file left).
Voids (declared nodata, NaN, sentinels, zero-filled) are used as voids, said in the log, and never seen through."""

import json

import numpy as np
import pytest
from osgeo import gdal, osr
from qgis.core import QgsProcessingException, QgsProcessingFeedback

from monoplot_plugin.core.dem import Dem
from monoplot_plugin.core.xyz import compute_xyz
from tests.badinput.conftest import leftovers
from tests.processing.conftest import hill_elevation, write_photo

EARLIER = b"an earlier output the user wants to keep"
ORIGIN, CELL = (500000.0, 5100000.0), 30.0


def dem_file(path, z, epsg=32632, nodata=None, georef=True, dtype=gdal.GDT_Float32, origin=ORIGIN, cell=CELL):
    z = np.asarray(z)
    ds = gdal.GetDriverByName("GTiff").Create(str(path), z.shape[1], z.shape[0], 1, dtype)
    if georef:
        ds.SetGeoTransform((origin[0], cell, 0.0, origin[1], 0.0, -cell))
    if epsg:
        srs = osr.SpatialReference()
        srs.ImportFromEPSG(epsg)
        ds.SetProjection(srs.ExportToWkt())
    band = ds.GetRasterBand(1)
    if nodata is not None:
        band.SetNoDataValue(nodata)
    band.WriteArray(z)
    ds = None
    return str(path)


def refused(run_alg, algorithm, params, out, match):
    """Run, expect a QgsProcessingException matching ``match``; the earlier output must be intact."""
    out.write_bytes(EARLIER)
    with pytest.raises(QgsProcessingException, match=match):
        run_alg(algorithm, {**params, "OUTPUT": str(out)})
    assert out.read_bytes() == EARLIER
    assert leftovers(out.parent) == []


# --- DEMs -----------------------------------------------------------------------------------------------------------
def _bad_dem(kind, folder, small_scene):
    z = hill_elevation()
    if kind == "no_crs":
        return dem_file(folder / "dem.tif", z, epsg=None), "has no CRS"
    if kind == "photo_as_dem":
        return str(write_photo(folder / "photo_as_dem.tif")), "has no georeferencing.*is it a photo"
    if kind == "text_as_dem":
        (folder / "dem.asc").write_text("this is not a raster\n")
        return str(folder / "dem.asc"), "not a raster GDAL can read"
    if kind == "folder_as_dem":
        (folder / "dem_folder").mkdir()
        return str(folder / "dem_folder"), "is a folder, not a raster file"
    if kind == "all_nodata":
        return dem_file(folder / "dem.tif", np.full_like(z, -9999.0), nodata=-9999.0), "has no valid cell"
    if kind == "all_nan":
        return dem_file(folder / "dem.tif", np.full_like(z, np.nan)), "has no valid cell"
    if kind == "one_cell":
        return dem_file(folder / "dem.tif", z[:1, :1]), "too small: 1 x 1 cells"
    if kind == "one_row":
        return dem_file(folder / "dem.tif", z[:1, :]), "too small: 80 x 1 cells"
    if kind == "one_valid_row":
        z = z.copy()
        z[1:] = np.nan
        return dem_file(folder / "dem.tif", z), "too few valid cells"
    if kind == "off_view":
        return dem_file(folder / "dem.tif", z, origin=(ORIGIN[0] + 60000.0, ORIGIN[1])), \
            "(sees no part of the DEM|would be empty: no pixel of the photo sees the DEM)"
    raise KeyError(kind)


DEM_CASES = ["no_crs", "photo_as_dem", "text_as_dem", "folder_as_dem", "all_nodata", "all_nan", "one_cell", "one_row",
             "one_valid_row", "off_view"]


@pytest.mark.parametrize("kind", DEM_CASES)
def test_bad_dem_is_refused_in_words(kind, run_alg, small_scene, tmp_path):
    dem, match = _bad_dem(kind, tmp_path, small_scene)
    refused(run_alg, "computexyz", {"CAMERA": small_scene["camera"], "DEM": dem}, tmp_path / "xyz.tif", match)


def test_missing_dem_is_refused_in_words(run_alg, small_scene, tmp_path):
    refused(run_alg, "computexyz", {"CAMERA": small_scene["camera"], "DEM": str(tmp_path / "nope.tif")},
            tmp_path / "xyz.tif", "(DEM not found|could not be loaded|DEM)")


def test_camera_looking_at_the_sky_is_an_empty_product(run_alg, small_scene, tmp_path):
    sky = small_scene["cam"].with_parameters(pitch=60.0)
    sky.save(tmp_path / "sky.json")
    params = {"CAMERA": str(tmp_path / "sky.json"), "DEM": small_scene["dem"]}
    refused(run_alg, "computexyz", params, tmp_path / "xyz.tif", "sees no part of the DEM: it stands at .* pitch 60.0")
    over = small_scene["cam"].with_parameters(z=1000.0, pitch=40.0)  # in the height range, looking over it
    over.save(tmp_path / "over.json")
    params = {"CAMERA": str(tmp_path / "over.json"), "DEM": small_scene["dem"]}
    refused(run_alg, "computexyz", params, tmp_path / "xyz.tif", "XYZ raster would be empty.*looks at the sky")
    refused(run_alg, "orthophoto", {**params, "PHOTO": small_scene["photo"]}, tmp_path / "o.tif",
            "orthophoto would be empty")
    result = run_alg("computexyz", {**params, "ALLOW_EMPTY": True, "OUTPUT": str(tmp_path / "empty.tif")})
    assert result["GROUND_FRACTION"] == 0.0  # asked for: written


# --- voids --------------------------------------------------------------------------------------------------------
BLOCK = (slice(18, 34), slice(20, 42))  # over the first summit, which the scene camera looks at


def _void_dem(kind, folder):
    z = hill_elevation()
    if kind == "nan":
        z[BLOCK] = np.nan
        return dem_file(folder / "dem.tif", z), "NaN cells"
    if kind == "minus_9999_undeclared":
        z[BLOCK] = -9999.0
        return dem_file(folder / "dem.tif", z), "at -9999 \\(a common no-data value\\)"
    if kind == "minus_32768_int16":
        z[BLOCK] = -32768
        return dem_file(folder / "dem.tif", z.astype(np.int16), dtype=gdal.GDT_Int16), "at -32768"
    if kind == "large_negative":
        z[BLOCK] = -1.0e6
        return dem_file(folder / "dem.tif", z), "no height on Earth"
    if kind == "declared_nodata":
        z[BLOCK] = -500.0
        return dem_file(folder / "dem.tif", z, nodata=-500.0), "declared nodata value -500"
    if kind == "zero_filled":
        z[BLOCK] = 0.0
        return dem_file(folder / "dem.tif", z), "at 0 m \\(zero-filled voids"
    raise KeyError(kind)


VOID_CASES = ["nan", "minus_9999_undeclared", "minus_32768_int16", "large_negative", "declared_nodata",
              "zero_filled"]


@pytest.fixture(scope="module")
def void_truth(small_scene):
    """The scene's XYZ raster on the complete terrain, and which pixels see the block that the cases make void."""
    dem = Dem.open(small_scene["dem"])
    xyz = compute_xyz(small_scene["cam"], dem)
    col, row = dem.map_to_cell(xyz[..., 0], xyz[..., 1])
    with np.errstate(invalid="ignore"):
        on_block = ((row >= BLOCK[0].start) & (row <= BLOCK[0].stop) & (col >= BLOCK[1].start)
                    & (col <= BLOCK[1].stop))
    assert on_block.sum() > 200
    return {"xyz": xyz, "on_block": on_block}


@pytest.mark.parametrize("kind", VOID_CASES)
def test_voids_are_nodata_never_the_ground_behind(kind, run_alg, small_scene, void_truth, tmp_path):
    dem, note = _void_dem(kind, tmp_path)
    feedback = QgsProcessingFeedback()
    out = tmp_path / "xyz.tif"
    run_alg("computexyz", {"CAMERA": small_scene["camera"], "DEM": dem, "OUTPUT": str(out)}, feedback)
    import re

    assert re.search("treated as void in dem.tif .*" + note, feedback.textLog()), feedback.textLog()
    ds = gdal.Open(str(out))
    got = np.dstack([ds.GetRasterBand(b).ReadAsArray().astype(float) for b in (1, 2, 3)])
    on_block = void_truth["on_block"]
    # every pixel that looks at the (now missing) block is nodata: none sees the ground behind it, none a pit
    assert np.isnan(got[on_block]).all()
    # and the rest of the picture is unchanged, apart from the block's silhouette
    rest = ~on_block & np.isfinite(void_truth["xyz"][..., 2])
    same = np.isclose(got[rest][:, 2], void_truth["xyz"][rest][:, 2], atol=0.5)
    assert same.mean() > 0.9
    assert np.nanmin(got[..., 2]) > 400.0  # nothing at -9999, 0 or -1e6


def test_void_value_parameter_names_the_value(run_alg, small_scene, tmp_path):
    z = hill_elevation()
    z[BLOCK] = 1234.5
    dem = dem_file(tmp_path / "dem.tif", z)
    feedback = QgsProcessingFeedback()
    run_alg("computexyz", {"CAMERA": small_scene["camera"], "DEM": dem, "VOID_VALUE": 1234.5,
                           "OUTPUT": str(tmp_path / "xyz.tif")}, feedback)
    assert "cells at the void value 1234.5 you gave" in feedback.textLog()


# --- photos -------------------------------------------------------------------------------------------------------
def _bad_photo(kind, folder):
    if kind == "folder":
        (folder / "photo.jpg").mkdir()
        return str(folder / "photo.jpg"), "is a folder, not an image file"
    if kind == "text":
        (folder / "photo.jpg").write_text("not an image")
        return str(folder / "photo.jpg"), "not an image file, or a damaged one"
    if kind == "empty":
        (folder / "photo.jpg").write_bytes(b"")
        return str(folder / "photo.jpg"), "not an image file, or a damaged one"
    if kind == "truncated_jpeg":
        import cv2

        ok, data = cv2.imencode(".jpg", np.random.default_rng(0).integers(0, 255, (120, 160, 3), dtype=np.uint8))
        (folder / "photo.jpg").write_bytes(data.tobytes()[: len(data) // 2])
        return str(folder / "photo.jpg"), "truncated"
    if kind == "missing":
        return str(folder / "nope.jpg"), "photo not found"
    if kind == "camera_json":  # QGIS alone said "Incorrect parameter value for PHOTO"
        (folder / "camera.json").write_text("{}")
        return str(folder / "camera.json"), "Photo: camera.json is a .json file, expected one of .jpg"
    raise KeyError(kind)


@pytest.mark.parametrize("kind", ["folder", "text", "empty", "truncated_jpeg", "missing", "camera_json"])
def test_bad_photo_is_refused_in_words(kind, run_alg, small_scene, tmp_path):
    photo, match = _bad_photo(kind, tmp_path)
    refused(run_alg, "orthophoto", {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"], "PHOTO": photo},
            tmp_path / "ortho.tif", match)


# --- cameras ------------------------------------------------------------------------------------------------------
def _bad_camera(kind, folder, small_scene):
    path = folder / "camera.json"
    data = json.loads(small_scene["cam"].to_json())
    if kind == "nan_position":
        text = small_scene["cam"].to_json().replace("501200.0", "NaN", 1)
        path.write_text(text)
        return str(path), "has no valid X \\(not a number\\)"
    if kind == "zero_fov":
        data["fov"] = 0.0
        path.write_text(json.dumps(data))
        return str(path), "fov must be between 0 and 180"
    if kind == "empty_file":
        path.write_bytes(b"")
        return str(path), "is empty \\(0 bytes\\)"
    if kind == "truncated_json":
        path.write_text(small_scene["cam"].to_json()[:60])
        return str(path), "cannot read the camera file camera.json \\(expected Monoplot camera JSON\\)"
    if kind == "not_json":
        path.write_bytes(b"\x89PNG\r\n\x1a\n binary")
        return str(path), "cannot read the camera file"
    if kind == "missing":
        return str(folder / "nope.json"), "camera file not found"
    if kind == "other_crs":  # UTM numbers labelled LV95: transformed as LV95, it stands far from the DEM
        cam = small_scene["cam"].with_parameters()
        cam.crs_wkt = "EPSG:2056"
        cam.save(path)
        return str(path), "sees no part of the DEM.*Is the camera in the DEM's CRS"
    if kind == "geographic_crs":
        cam = small_scene["cam"].with_parameters()
        cam.crs_wkt = "EPSG:4326"
        cam.save(path)
        return str(path), "is in .*4326.*but the DEM is in"
    if kind == "kml_without_photo":
        kml = folder / "prior.kml"
        kml.write_text("<kml><PhotoOverlay/></kml>")
        return str(kml), "a KML camera needs the photo"
    raise KeyError(kind)


CAMERA_CASES = ["nan_position", "zero_fov", "empty_file", "truncated_json", "not_json", "missing", "other_crs",
                "geographic_crs", "kml_without_photo"]


@pytest.mark.parametrize("kind", CAMERA_CASES)
def test_bad_camera_is_refused_in_words(kind, run_alg, small_scene, tmp_path):
    camera, match = _bad_camera(kind, tmp_path, small_scene)
    refused(run_alg, "computexyz", {"CAMERA": camera, "DEM": small_scene["dem"]}, tmp_path / "xyz.tif", match)


def test_a_camera_in_another_projected_crs_is_transformed_into_the_dems(run_alg, small_scene, tmp_path):
    """A desktop trial: an LV95 camera with a DEM in UTM was refused. Now it is transformed (heading turned to the
    DEM's grid north), said in the log, and gives the XYZ raster the same camera in UTM gives."""
    from osgeo import gdal
    from qgis.core import QgsProcessingFeedback

    from monoplot_plugin.core.kml import camera_to_crs

    class Log(QgsProcessingFeedback):
        said: list = []

        def pushInfo(self, info):  # noqa: N802 (QGIS API)
            self.said.append(info)

    cam = small_scene["cam"].with_parameters()
    cam.crs_wkt = "EPSG:32632"
    lv95, turned = camera_to_crs(cam, "EPSG:2056")
    assert abs(turned) > 0.3  # grid norths differ here: a heading copied as is would be off
    lv95.save(tmp_path / "lv95.json")
    log = Log()
    rasters = []
    for name, camera in (("utm", small_scene["camera"]), ("lv95", str(tmp_path / "lv95.json"))):
        out = str(tmp_path / f"{name}.tif")
        run_alg("computexyz", {"CAMERA": camera, "DEM": small_scene["dem"], "OUTPUT": out}, log)
        ds = gdal.Open(out)
        rasters.append(np.dstack([ds.GetRasterBand(b).ReadAsArray() for b in (1, 2, 3)]))
    assert any("transformed from CH1903+ / LV95 (EPSG:2056)" in s for s in log.said), log.said
    both = np.isfinite(rasters[0][..., 2]) & np.isfinite(rasters[1][..., 2])
    assert both.mean() > 0.2 and np.nanmedian(np.abs(rasters[0][both] - rasters[1][both])) < 1.0


# --- point tables -------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def gcps(small_scene):
    cam = small_scene["cam"]
    xyz = compute_xyz(cam, Dem.open(small_scene["dem"]))
    rows, cols = np.nonzero(np.isfinite(xyz[..., 2]))
    pick = np.random.default_rng(5).choice(len(rows), 15, replace=False)
    world = xyz[rows[pick], cols[pick]]
    prior = cam.with_parameters(x=cam.position[0] + 40, y=cam.position[1] - 20, heading=cam.heading + 1.0)
    prior_path = small_scene["dir"] / "gcp_prior.json"
    prior.save(prior_path)
    return {"uv": cam.project(world), "xyz": world, "prior": str(prior_path)}


def _csv_text(gcps, ids=None):
    lines = ["id,u_px,v_px,X,Y,Z"]
    for i, ((u, v), (x, y, z)) in enumerate(zip(gcps["uv"], gcps["xyz"])):
        lines.append(f"{ids[i] if ids else i + 1},{u:.3f},{v:.3f},{x:.3f},{y:.3f},{z:.3f}")
    return "\r\n".join(lines) + "\r\n"


@pytest.mark.parametrize("encoding", ["utf-8", "utf-8-sig", "utf-16", "utf-16-le", "utf-16-be", "latin-1"])
def test_gcp_table_in_any_common_encoding_fits(encoding, run_alg, small_scene, gcps, tmp_path):
    names = [f"Gipfel {i} – Süd" if encoding != "latin-1" else f"Gipfel {i} Süd" for i in range(15)]
    path = tmp_path / "gcps.csv"
    path.write_bytes(_csv_text(gcps, names).encode(encoding))
    result = run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"], "PRIOR": gcps["prior"],
                                   "PHOTO_CSV": str(path), "PAIRED": True, "OUTPUT": str(tmp_path / "camera.json")})
    assert result["N_PHOTO"] == 15 and result["RMSE_PX"] < 1.0


@pytest.mark.parametrize("kind,text,match", [
    ("no_columns", "a,b,c\n1,2,3\n", "no point columns found"),
    ("text_in_numbers", "u_px,v_px,X,Y,Z\n10,20,abc,5,6\n", "line 2: 'X' is \"abc\", not a number"),
    ("header_only", "u_px,v_px,X,Y,Z\n", "needs a header row and at least one point"),
    ("too_few", "u_px,v_px,X,Y,Z\n10,20,501000,5099000,900\n", "Too few pairs for a 7-parameter camera: 1 left"),
], ids=["no_columns", "text_in_numbers", "header_only", "too_few"])
def test_bad_gcp_table_is_refused_in_words(kind, text, match, run_alg, small_scene, gcps, tmp_path):
    path = tmp_path / "gcps.csv"
    path.write_text(text)
    refused(run_alg, "fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"], "PRIOR": gcps["prior"],
                                   "PHOTO_CSV": str(path), "PAIRED": True}, tmp_path / "camera.json", match)


def test_geographic_dem_with_a_lonlat_gcp_table_fits_in_utm(run_alg, small_scene, gcps, tmp_path):
    """The DEM in EPSG:4326 is used in UTM; the GCP table in its lon/lat is converted with it (it was not, and the
    fit returned the prior with RMSE nan and status ok)."""
    dem = Dem.open(small_scene["dem"])
    gdal.Warp(str(tmp_path / "dem4326.tif"), small_scene["dem"], dstSRS="EPSG:4326", resampleAlg="bilinear")
    utm, wgs = osr.SpatialReference(), osr.SpatialReference()
    utm.SetFromUserInput(dem.crs_wkt)
    wgs.ImportFromEPSG(4326)
    for s in (utm, wgs):
        s.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    lonlat = np.asarray(osr.CoordinateTransformation(utm, wgs).TransformPoints(gcps["xyz"][:, :2].tolist()))
    path = tmp_path / "gcps_lonlat.csv"
    text = ["id,u_px,v_px,lon,lat,Z"] + [f"{i},{u:.3f},{v:.3f},{lo:.9f},{la:.9f},{z:.2f}" for i, ((u, v), (lo, la), z)
                                         in enumerate(zip(gcps["uv"], lonlat[:, :2], gcps["xyz"][:, 2]))]
    path.write_text("\n".join(text) + "\n")
    feedback = QgsProcessingFeedback()
    result = run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": str(tmp_path / "dem4326.tif"),
                                   "PRIOR": gcps["prior"], "PHOTO_CSV": str(path), "PAIRED": True,
                                   "OUTPUT": str(tmp_path / "camera.json")}, feedback)
    assert "were converted from WGS 84" in feedback.textLog()
    assert np.isfinite(result["RMSE_PX"]) and result["RMSE_PX"] < 5.0
    # the same DEM in degrees with the table in metres, the project's CRS: it is not "converted from WGS 84"
    # (a trial: LV03 GCPs all left off the DEM, the fit refused)
    from qgis.core import QgsCoordinateReferenceSystem, QgsProject

    from monoplot_plugin.workflow.inputs import _transform

    mercator = _transform(gcps["xyz"], dem.crs_wkt, "EPSG:3857")  # another projected CRS than the one used
    path = tmp_path / "gcps_metres.csv"
    path.write_text("\n".join(["u_px,v_px,X,Y,Z"] + [f"{u:.3f},{v:.3f},{x:.3f},{y:.3f},{z:.2f}" for (u, v), (x, y, z)
                                                      in zip(gcps["uv"], mercator)]) + "\n")
    QgsProject.instance().setCrs(QgsCoordinateReferenceSystem("EPSG:3857"))
    try:
        feedback = QgsProcessingFeedback()
        result = run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": str(tmp_path / "dem4326.tif"),
                                       "PRIOR": gcps["prior"], "PHOTO_CSV": str(path), "PAIRED": True,
                                       "OUTPUT": str(tmp_path / "camera_m.json")}, feedback)
    finally:
        QgsProject.instance().setCrs(QgsCoordinateReferenceSystem())
    assert "EPSG:3857) coordinates and were converted to the DEM's CRS" in feedback.textLog(), feedback.textLog()
    assert "from WGS 84" not in feedback.textLog() and result["RMSE_PX"] < 5.0


def test_a_gcp_table_in_the_projects_crs_is_converted_and_one_off_the_dem_warned(run_alg, small_scene, gcps,
                                                                                tmp_path):
    """fitcamera as the dock: a table whose numbers are in the project's CRS (not the DEM's) is converted and said
    so; one whose numbers fit no CRS is fitted as given, with a warning that its points lie off the DEM."""
    from qgis.core import QgsCoordinateReferenceSystem, QgsProject

    from monoplot_plugin.workflow.inputs import _transform

    dem = Dem.open(small_scene["dem"])
    project = QgsProject.instance()
    project.setCrs(QgsCoordinateReferenceSystem("EPSG:3857"))
    try:
        mercator = _transform(gcps["xyz"], dem.crs_wkt, "EPSG:3857")
        path = tmp_path / "gcps_3857.csv"
        rows = ["u_px,v_px,X,Y,Z"] + [f"{u:.3f},{v:.3f},{x:.3f},{y:.3f},{z:.2f}"
                                      for (u, v), (x, y, z) in zip(gcps["uv"], mercator)]
        path.write_text("\n".join(rows) + "\n")
        feedback = QgsProcessingFeedback()
        result = run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"],
                                       "PRIOR": gcps["prior"], "PHOTO_CSV": str(path), "PAIRED": True,
                                       "OUTPUT": str(tmp_path / "camera.json")}, feedback)
        assert "EPSG:3857) coordinates and were converted to the DEM's CRS" in feedback.textLog()
        assert result["RMSE_PX"] < 5.0
        shifted = gcps["xyz"] + [2e6, 0.0, 0.0]
        rows = ["u_px,v_px,X,Y,Z"] + [f"{u:.3f},{v:.3f},{x:.3f},{y:.3f},{z:.2f}"
                                      for (u, v), (x, y, z) in zip(gcps["uv"], shifted)]
        path.write_text("\n".join(rows) + "\n")
        feedback = QgsProcessingFeedback()
        try:
            run_alg("fitcamera", {"PHOTO": small_scene["photo"], "DEM": small_scene["dem"], "PRIOR": gcps["prior"],
                                  "PHOTO_CSV": str(path), "PAIRED": True, "OUTPUT": str(tmp_path / "c2.json")},
                    feedback)
        except QgsProcessingException:
            pass  # the fit may refuse the points; the warning came first
        assert f"{len(shifted)} of {len(shifted)} map points of gcps_3857.csv lie outside the DEM" in \
            feedback.textLog()
    finally:
        project.setCrs(QgsCoordinateReferenceSystem())


def test_aletsch_zero_voids_are_voids_in_processing_too(run_alg, aletsch_dir, tmp_path):
    """The Aletsch DEM declares no nodata and fills its voids with 0: computexyz (as the dock) treats them as voids,
    says so, and no pixel lands at 0 m."""
    from monoplot_plugin.processing.inputs import load_camera, photo_size

    size = photo_size(str(aletsch_dir / "photo.jpg"))
    dem = Dem.open(aletsch_dir / "dem.tif")
    camera = load_camera(str(aletsch_dir / "prior_pose.kml"), size, dem.crs_wkt)
    camera = camera.scaled(0.25) if hasattr(camera, "scaled") else camera
    camera.save(tmp_path / "camera.json")
    feedback = QgsProcessingFeedback()
    out = tmp_path / "xyz.tif"
    run_alg("computexyz", {"CAMERA": str(tmp_path / "camera.json"), "DEM": str(aletsch_dir / "dem.tif"),
                           "OUTPUT": str(out)}, feedback)
    assert "6891 cells at 0 m (zero-filled voids" in feedback.textLog()
    ds = gdal.Open(str(out))  # kept: a band outliving its dataset crashes GDAL's Python bindings
    z = ds.GetRasterBand(3).ReadAsArray()
    assert np.isfinite(z).mean() > 0.2 and np.nanmin(z) > 500.0
