"""DEMs larger than memory: windowed and multi-level reads (DemSource), overview building, and the level-of-detail
z-buffer against the full-resolution one, on small generated GeoTIFFs."""

import os

import numpy as np
import pytest

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.dem import Dem
from monoplot_plugin.core.dem_window import (DemSource, OverviewsCanceled, build_overviews, footprint_spans,
                                             missing_overviews, open_dem_source)
from monoplot_plugin.core.synthetic import synthetic_terrain
from monoplot_plugin.core.xyz import compute_xyz, compute_xyz_full
from monoplot_plugin.core.xyz_lod import compute_xyz_lod


@pytest.fixture(scope="module")
def terrain(tmp_path_factory):
    dem = synthetic_terrain((600, 600), cell=20.0, seed=4)
    path = str(tmp_path_factory.mktemp("dem") / "dem.tif")
    dem.save(path)
    x, y = dem.cell_to_map(60, 540)
    cam = Camera((x, y, float(np.nanmax(dem.elevation)) + 150.0), heading=45.0, pitch=-6.0, roll=0.0, fov=60.0,
                 image_size=(480, 320))
    return dem, path, cam


def test_windowed_read_equals_the_full_read(terrain):
    dem, path, cam = terrain
    src = DemSource(path)
    full = Dem.open(path)
    part = src.read((37, 81, 120, 95))
    assert part.window == (37, 81)
    assert np.array_equal(part.elevation, full.elevation[37:157, 81:176])
    assert np.allclose(part.geotransform, full.crop(37, 81, 120, 95).geotransform)
    # the camera's footprint: cells inside the spans are the file's, the rest NaN (not read)
    view, (lo, hi), (v0, v1) = src.read_view(cam, 1, min_depth=0.0, max_depth=4000.0)
    assert 0 <= v0 < v1 <= cam.height
    r0, c0 = view.window
    assert (hi > lo).any()
    for r in range(0, view.rows, 17):
        assert np.array_equal(view.elevation[r, lo[r]:hi[r]], full.elevation[r0 + r, c0 + lo[r]:c0 + hi[r]])
        assert np.isnan(view.elevation[r, :lo[r]]).all() and np.isnan(view.elevation[r, hi[r]:]).all()


def test_spans_cover_the_whole_grid_without_a_footprint():
    lo, hi = footprint_spans((5, 6, 100, 70), None, 3.0)
    assert (lo == 0).all() and (hi == 70).all() and len(lo) == 100


def test_building_overviews_leaves_the_dem_alone_and_reports_progress(tmp_path):
    path = str(tmp_path / "dem.tif")
    synthetic_terrain((300, 300), cell=25.0, seed=1).save(path)
    with open(path, "rb") as fh:
        before = fh.read()
    assert DemSource(path).levels == [1]
    # without overviews a coarse level is decimated as it is read: the average of each 2 x 2 block
    blocks = Dem.open(path).elevation.reshape(150, 2, 150, 2).mean(axis=(1, 3))
    assert np.allclose(DemSource(path).read(None, 2).elevation, blocks, atol=1e-3)
    assert np.allclose(DemSource(path).read((10, 20, 30, 40), 2).elevation, blocks[10:40, 20:60], atol=1e-3)
    seen = []
    built = build_overviews(path, progress=lambda f, m: seen.append((f, m)), min_size=64)
    assert built == [2, 4]
    assert os.path.exists(path + ".ovr")
    with open(path, "rb") as fh:
        assert fh.read() == before
    assert seen and seen[-1][0] == pytest.approx(1.0) and "overviews" in seen[-1][1]
    src = DemSource(path)
    assert src.levels == [1, 2, 4] and src.level_shape(2) == (150, 150)
    # an overview level is the average of the full resolution's blocks, over the same extent
    assert np.allclose(src.read(None, 2).elevation, Dem.open(path).elevation.reshape(150, 2, 150, 2).mean(axis=(1, 3)),
                       atol=1e-3)
    assert np.allclose(src.read(None, 2).bounds(), Dem.open(path).bounds())
    assert build_overviews(path) == []  # already there: nothing to do


def test_lod_at_full_resolution_equals_the_z_buffer(terrain):
    """With every band at full resolution, the banded z-buffer (near planes, strips, spans) gives the same pixels."""
    dem, path, cam = terrain
    lod = compute_xyz_lod(cam, DemSource(path), lod=1e-3)
    assert set(np.unique(lod.factor).tolist()) <= {0, 1}
    full = compute_xyz_full(cam, dem, visibility=False)
    assert np.array_equal(lod.hit, full.hit)
    assert np.allclose(lod.xyz[lod.hit], full.xyz[full.hit], atol=1e-6)
    assert np.allclose(lod.distance[lod.hit], full.distance[full.hit], rtol=1e-6)


def test_lod_agrees_with_full_resolution_within_a_cell(terrain, tmp_path):
    dem, path, cam = terrain
    copy = str(tmp_path / "dem.tif")
    dem.save(copy)
    build_overviews(copy, min_size=64)
    src = DemSource(copy)
    lod = compute_xyz_lod(cam, src, lod=3.0)  # a small picture: coarser levels only this near with a coarse lod
    assert {1, 2} <= set(np.unique(lod.factor).tolist())  # near field exact, farther coarser
    assert [b[0] for b in lod.bands] == sorted(b[0] for b in lod.bands)
    full = compute_xyz(cam, dem)
    seen = np.isfinite(full[..., 0])
    assert abs(lod.hit.mean() - seen.mean()) < 0.01
    both = lod.hit & seen
    ground = np.hypot(*(lod.xyz[both, :2] - full[both, :2]).T)
    within = ground <= dem.cell_size * lod.factor[both]
    assert within.mean() > 0.97
    # near field: the same mesh, so the same points
    near = lod.factor[both] == 1
    assert np.median(ground[near]) < 1e-6


def test_zbuffer_spans_outside_cells_are_not_voids(terrain):
    """Cells outside the spans are NaN placeholders: no lid closes them, nothing is drawn there."""
    dem, path, cam = terrain
    full = compute_xyz_full(cam, dem, visibility=False)
    elev = dem.elevation.copy()
    lo = np.full(dem.rows, 100)
    hi = np.full(dem.rows, 500)
    elev[:, :100] = np.nan
    elev[:, 500:] = np.nan
    cut = Dem(elev, dem.geotransform, dem.crs_wkt)
    res = compute_xyz_full(cam, cut, crop=False, visibility=False, spans=(lo, hi))
    plain = compute_xyz_full(cam, Dem(dem.elevation[:, 100:500], dem.crop(0, 100, dem.rows, 400).geotransform),
                             crop=False, visibility=False)
    assert np.array_equal(res.hit, plain.hit) and res.hit.sum() < full.hit.sum()
    assert np.allclose(res.xyz[res.hit], plain.xyz[plain.hit])


def test_geographic_dem_is_refused(tmp_path):
    path = str(tmp_path / "geo.tif")
    Dem.from_array(np.ones((10, 10)), (8.0, 0.001, 0, 46.0, 0, -0.001), "EPSG:4326").save(path)
    with pytest.raises(ValueError, match="geographic"):
        DemSource(path)


def test_a_canceled_overview_build_leaves_no_half_written_file(tmp_path):
    path = str(tmp_path / "dem.tif")
    synthetic_terrain((600, 600), cell=10.0, seed=2).save(path)
    assert missing_overviews(path) == [2]
    calls = []

    def cancel_after_the_first_report():
        calls.append(1)
        return len(calls) > 1

    with pytest.raises(OverviewsCanceled):
        build_overviews(path, is_canceled=cancel_after_the_first_report)
    assert not os.path.exists(path + ".ovr") and missing_overviews(path) == [2]
    assert DemSource(path).levels == [1]
    with pytest.raises(OverviewsCanceled):  # open_dem_source passes the cancel on instead of noting a failure
        open_dem_source(path, is_canceled=lambda: True)
    assert build_overviews(path) == [2] and missing_overviews(path) == []


def test_open_dem_source_builds_overviews_once_and_says_so(tmp_path):
    path = str(tmp_path / "big.tif")
    synthetic_terrain((600, 600), cell=10.0, seed=2).save(path)
    fractions = []
    src, notes = open_dem_source(path, progress=lambda f, m: fractions.append(f))
    assert src.levels == [1, 2] and len(notes) == 1 and "overviews" in notes[0] and fractions
    src, notes = open_dem_source(path)
    assert notes == [] and src.levels == [1, 2]


def test_view_dem_is_one_dem_of_the_view_within_a_cell_budget(terrain):
    dem, path, cam = terrain
    src = DemSource(path)
    fine = src.view_dem(cam, max_cells=1e9)
    assert fine.cell_size == pytest.approx(dem.cell_size) and fine.rows * fine.cols <= dem.rows * dem.cols
    r0, c0 = fine.window
    assert np.array_equal(fine.elevation, dem.elevation[r0:r0 + fine.rows, c0:c0 + fine.cols])
    coarse = src.view_dem(cam, max_cells=fine.rows * fine.cols / 3)
    assert coarse.cell_size == pytest.approx(2 * dem.cell_size) and coarse.rows * coarse.cols <= fine.rows * fine.cols / 3
    # the same view either way: the z-buffer over both sees terrain in the same pixels, nearly
    a = np.isfinite(compute_xyz(cam, fine)[..., 0])
    b = np.isfinite(compute_xyz(cam, coarse)[..., 0])
    assert (a == b).mean() > 0.97


def test_rendering_and_suggestions_take_a_dem_source(terrain):
    from monoplot_plugin.core.render import render_dem
    from monoplot_plugin.core.suggest import suggest_dem_points

    dem, path, cam = terrain
    src = DemSource(path)
    view = src.view_dem(cam)
    small = cam.scaled(0.5)
    a, b = render_dem(small, src), render_dem(small, view)
    assert np.isfinite(a.shade).mean() > 0.3 and np.array_equal(a.shade, b.shade, equal_nan=True)
    points = suggest_dem_points(src, cam, max_points=200)
    assert 20 <= len(points.xyz) <= 200 and np.isfinite(points.xyz).all()


def test_lod_over_voids_equals_the_z_buffer(terrain, tmp_path):
    """Cells outside a band's spans are left unset unless the band has voids: then they are NaN again, so that an
    interior void still gets its lid and a pixel that sees it is nodata, as in the full-resolution z-buffer."""
    dem, _, cam = terrain
    holed = Dem(dem.elevation.copy(), dem.geotransform, dem.crs_wkt)
    holed.elevation[200:260, 150:230] = np.nan
    path = str(tmp_path / "holed.tif")
    holed.save(path)
    holed = Dem.open(path)
    lod = compute_xyz_lod(cam, DemSource(path), lod=1e-3)
    full = compute_xyz_full(cam, holed, visibility=False)
    assert np.array_equal(lod.hit, full.hit)
    assert np.allclose(lod.xyz[lod.hit], full.xyz[full.hit], atol=1e-6)


@pytest.mark.parametrize("kind", ["scaled", "feet"])
def test_stored_values_become_metres_read_whole_or_by_windows(terrain, tmp_path, kind):
    """A trial's DEMs: UInt16 with scale 0.1 and offset 500 (read as 4,000-9,000 m), and one in feet (read as
    metres); most of each became "voids above 9,000 m". Both are metres now, read whole or by windows, the
    nodata cells voids, and the notes say what was applied."""
    from osgeo import gdal

    from monoplot_plugin.core.dem_large import open_dem

    dem, _, cam = terrain
    metres = np.array(dem.elevation, dtype=np.float64)
    metres[5:9, 5:9] = np.nan
    path = str(tmp_path / f"{kind}.tif")
    ds = gdal.GetDriverByName("GTiff").Create(path, dem.cols, dem.rows, 1,
                                              gdal.GDT_UInt16 if kind == "scaled" else gdal.GDT_Float32)
    ds.SetGeoTransform(dem.geotransform)
    ds.SetProjection(dem.crs_wkt)
    band = ds.GetRasterBand(1)
    if kind == "scaled":
        stored = np.where(np.isnan(metres), 0, np.round((metres - 500.0) / 0.1)).astype(np.uint16)
        band.SetScale(0.1)
        band.SetOffset(500.0)
        band.SetNoDataValue(0)
        tolerance = 0.06
    else:
        stored = np.where(np.isnan(metres), -9999.0, metres / 0.3048).astype(np.float32)
        band.SetUnitType("ft")
        band.SetNoDataValue(-9999.0)
        tolerance = 0.01
    band.WriteArray(stored)
    ds = band = None
    whole, notes = open_dem(path)
    assert any(("scale 0.1 and offset 500" if kind == "scaled" else "in ft") in n for n in notes), notes
    windowed, _ = open_dem(path, max_cells=60_000)
    assert windowed.source is not None  # read by windows
    for got in (whole.elevation, windowed.source.read().elevation):
        assert np.array_equal(np.isnan(got), np.isnan(metres))
        assert np.nanmax(np.abs(got - metres)) < tolerance
    lo, hi = windowed.source._height_range()
    assert lo <= np.nanmin(metres) and hi >= np.nanmax(metres) and hi < 1.5 * np.nanmax(metres)
    framed = Dem.open(path, camera=cam, max_range=3000.0)  # the camera's window, from the range in metres
    assert np.nanmax(np.abs(framed.elevation - metres[framed.window[0]:framed.window[0] + framed.rows,
                                                       framed.window[1]:framed.window[1] + framed.cols])) < tolerance
