"""Dem: GDAL reading, voids, affine with rotation, sampling, view cropping, geographic reprojection."""

import logging
import math
import os

import numpy as np
import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.dem import Dem, view_window
from monoplot_plugin.core.xyz import compute_xyz

osgeo = pytest.importorskip("osgeo")
from osgeo import gdal, osr  # noqa: E402

gdal.UseExceptions()


def write_tif(path, data, gt, epsg, nodata=None, dtype=gdal.GDT_Float32):
    ds = gdal.GetDriverByName("GTiff").Create(str(path), data.shape[1], data.shape[0], 1, dtype)
    ds.SetGeoTransform(gt)
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(epsg)
    ds.SetProjection(srs.ExportToWkt())
    band = ds.GetRasterBand(1)
    if nodata is not None:
        band.SetNoDataValue(nodata)
    band.WriteArray(data)
    ds.FlushCache()
    ds = None


def test_open_nodata_and_void_value(tmp_path):
    data = np.arange(20, dtype=np.int16).reshape(4, 5) + 100
    data[0, 0] = -9999
    data[1, 1] = 0
    write_tif(tmp_path / "d.tif", data, (1000.0, 10.0, 0.0, 2000.0, 0.0, -10.0), 2056, nodata=-9999,
              dtype=gdal.GDT_Int16)
    plain = Dem.open(tmp_path / "d.tif")
    assert np.isnan(plain.elevation[0, 0]) and plain.elevation[1, 1] == 0
    voids = Dem.open(tmp_path / "d.tif", void_value=0)
    assert np.isnan(voids.elevation).sum() == 2
    assert voids.geotransform == (1000.0, 10.0, 0.0, 2000.0, 0.0, -10.0)
    assert "2056" in voids.crs_wkt or "CH1903+" in voids.crs_wkt
    # bilinear sampling next to a void is NaN; elsewhere it interpolates
    assert math.isnan(voids.sample(1010.0, 1990.0))
    x, y = voids.cell_to_map(3.0, 3.0)  # between centres of rows 2..3, cols 2..3
    assert voids.sample(x, y) == pytest.approx(np.mean(data[2:4, 2:4]))


def test_reading_reports_progress_and_stops_on_cancel(tmp_path):
    from monoplot_plugin.core.dem import DemReadCanceled
    from monoplot_plugin.core.dem_large import open_dem

    z = np.random.default_rng(0).normal(1000, 50, (400, 300)).astype(np.float32)
    write_tif(tmp_path / "d.tif", z, (0.0, 5.0, 0.0, 2000.0, 0.0, -5.0), 32632)
    seen = []
    dem = Dem.open(tmp_path / "d.tif", progress=lambda fraction, message="": seen.append(fraction))
    assert np.array_equal(dem.elevation, z)
    assert len(seen) > 10 and seen == sorted(seen) and seen[-1] == pytest.approx(0.9)  # the voids after the reading
    polls = []
    with pytest.raises(DemReadCanceled):  # canceled at the 5th poll: the reading stops in mid-file
        open_dem(str(tmp_path / "d.tif"), is_canceled=lambda: polls.append(1) or len(polls) >= 5)
    assert len(polls) == 5


def test_rotated_affine_round_trip_and_sampling():
    gt = (5000.0, 8.0, 6.0, 9000.0, 6.0, -8.0)  # rotated, 10 m cells
    z = np.add.outer(np.arange(6.0) * 2, np.arange(7.0))  # z = 2 * row + col at centres (row, col index)
    dem = Dem.from_array(z, gt)
    assert dem.cell_size == pytest.approx(10.0)
    cols = np.array([0.5, 3.25, 6.5])
    rows = np.array([0.5, 2.75, 5.5])
    x, y = dem.cell_to_map(cols, rows)
    c2, r2 = dem.map_to_cell(x, y)
    assert np.allclose(c2, cols) and np.allclose(r2, rows)
    # linear surface: bilinear and mesh samples are exact
    expected = 2 * (rows - 0.5) + (cols - 0.5)
    assert np.allclose(dem.sample(x, y), expected)
    assert np.allclose(dem.sample(x, y, method="mesh"), expected)
    assert np.isnan(dem.sample(*dem.cell_to_map(0.2, 0.2)))  # outside the outer centres
    # gradients of z = 2 row + col, in map space, agree with finite differences
    gx, gy = dem.gradient()
    xa, ya = dem.cell_to_map(3.5, 2.5)
    h = 0.5
    assert gx[2, 3] == pytest.approx((dem.sample(xa + h, ya) - dem.sample(xa - h, ya)) / (2 * h))
    assert gy[2, 3] == pytest.approx((dem.sample(xa, ya + h) - dem.sample(xa, ya - h)) / (2 * h))


def test_hillshade_faces_the_sun():
    x = np.arange(20.0)
    east_up = Dem.from_array(np.tile(x * 1.0, (10, 1)), (0, 1, 0, 10, 0, -1))  # rises eastwards, faces west
    west_sun = east_up.hillshade(azimuth=270, altitude=30)
    east_sun = east_up.hillshade(azimuth=90, altitude=30)
    assert west_sun[5, 10] > east_sun[5, 10]
    assert 0.0 <= east_sun.min() and west_sun.max() <= 1.0


def test_geographic_dem_is_reprojected_to_utm(tmp_path, caplog):
    lon0, lat0, step = 8.0, 46.5, 0.001  # about 77 m x 111 m cells
    lon = lon0 + (np.arange(40) + 0.5) * step
    lat = lat0 - (np.arange(30) + 0.5) * step
    z = 1000.0 + 2.0 * (lon[None, :] - lon0) / step + 0.0 * lat[:, None]
    write_tif(tmp_path / "geo.tif", z.astype(np.float32), (lon0, step, 0.0, lat0, 0.0, -step), 4326)
    with caplog.at_level(logging.INFO, logger="monoplot"):
        dem = Dem.open(tmp_path / "geo.tif")
    assert "UTM zone 32N" in dem.crs_wkt
    assert any("reprojected" in r.getMessage() for r in caplog.records)
    assert not dem.is_geographic and dem.source_crs_wkt
    assert 50.0 < dem.cell_size < 120.0
    # a point in the middle keeps its height (linear in longitude)
    src, dst = osr.SpatialReference(), osr.SpatialReference()
    src.ImportFromEPSG(4326)
    dst.ImportFromWkt(dem.crs_wkt)
    for s in (src, dst):
        s.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    x, y, _ = osr.CoordinateTransformation(src, dst).TransformPoint(lon0 + 20 * step, lat0 - 15 * step)
    assert dem.sample(x, y) == pytest.approx(1000.0 + 2.0 * 20.0, abs=0.5)


def test_crop_to_view_keeps_what_the_camera_sees():
    z = np.zeros((300, 300))
    dem = Dem.from_array(z, (0.0, 10.0, 0.0, 3000.0, 0.0, -10.0))
    cam = Camera((1500.0, 1500.0, 50.0), heading=90.0, pitch=-3.0, roll=0.0, fov=40.0, image_size=(80, 60))
    crop = dem.crop_to_view(cam, max_range=1200.0)
    assert crop.rows < 300 and crop.cols < 300
    full = compute_xyz(cam, dem, crop=False, max_range=1200.0)
    cropped = compute_xyz(cam, dem, crop=True, max_range=1200.0)
    assert np.array_equal(np.isnan(full), np.isnan(cropped))
    assert np.allclose(full[np.isfinite(full)], cropped[np.isfinite(cropped)])
    # looking east from the middle: the window lies east of the camera
    xmin, _, xmax, _ = crop.bounds()
    assert 1500.0 < xmin < 1700.0 and xmax >= 1500.0 + 1100.0  # nearest ground seen is ~150 m away
    assert view_window(cam.with_parameters(heading=-90.0, x=-5000.0), dem.geotransform, dem.shape, 0.0, 0.0,
                       1000.0) is None


def test_open_reads_only_the_window(tmp_path):
    z = (np.random.default_rng(0).random((200, 220)) * 10).astype(np.float32)
    write_tif(tmp_path / "big.tif", z, (0.0, 5.0, 0.0, 1000.0, 0.0, -5.0), 32632)
    cam = Camera((100.0, 500.0, 40.0), heading=90.0, pitch=-10.0, roll=0.0, fov=30.0, image_size=(40, 30))
    part = Dem.open(tmp_path / "big.tif", camera=cam, max_range=300.0)
    assert part.rows < 200 and part.cols < 220
    r0, c0 = part.window
    assert np.array_equal(part.elevation, z[r0:r0 + part.rows, c0:c0 + part.cols])
    x0, y0 = part.cell_to_map(0, 0)
    assert (x0, y0) == (c0 * 5.0, 1000.0 - r0 * 5.0)


def test_aletsch_dem_with_void_value(aletsch_dir):
    dem = Dem.open(os.path.join(aletsch_dir, "dem.tif"), void_value=0)
    assert dem.shape == (720, 693)
    assert int(np.isnan(dem.elevation).sum()) == 6891
    assert 500 < np.nanmin(dem.elevation) < np.nanmax(dem.elevation) < 4300


def test_geographic_dem_in_memory_is_refused_by_compute_xyz():
    dem = Dem.from_array(np.zeros((5, 5)), (8.0, 0.001, 0.0, 46.5, 0.0, -0.001), "EPSG:4326")
    cam = Camera((8.002, 46.498, 100.0), heading=0.0, pitch=-10.0, roll=0.0, fov=60.0, image_size=(8, 6))
    with pytest.raises(ValueError, match="geographic"):
        compute_xyz(cam, dem)
    utm = dem.reprojected_to_utm()
    assert not utm.is_geographic and utm.source_crs_wkt


def test_heights_worked_out_once_stay_behind_when_the_dem_is_pickled():
    """The kept height range and closed voids are per Dem: a cut starts afresh, a pickled copy (a Dask worker's)
    does not carry them, and gives the same answers."""
    import pickle

    z = np.arange(20.0).reshape(4, 5)
    z[1, 2] = np.nan
    dem = Dem.from_array(z, (0.0, 1.0, 0.0, 4.0, 0.0, -1.0))
    assert dem.height_range() == (0.0, 19.0)
    assert dem.crop(0, 0, 2, 5).height_range() == (0.0, 9.0)
    copy = pickle.loads(pickle.dumps(dem))
    assert "_derived" in dem.__dict__ and "_derived" not in copy.__dict__
    assert copy.height_range() == (0.0, 19.0) and np.array_equal(copy.elevation, dem.elevation, equal_nan=True)
