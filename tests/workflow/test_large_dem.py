"""A DEM too large to read whole, from the product paths: the workflow opens it by windows on its own (and says so,
building its overviews with progress), and the XYZ raster, the orthophoto, the report and the suggestions work on
it, from the workflow and from ``qgis_process``. The "too large" limit is lowered (``MONOPLOT_DEM_MAX_CELLS``) so that
a cheap generated DEM — a VRT of 4 x 4 GeoTIFF tiles, 1 M cells — takes that path; the full-resolution results of
the same file read whole are the reference."""

import os

import numpy as np
import pytest
from osgeo import gdal

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.core.dem import Dem
from monoplot_plugin.core.dem_large import LargeDem
from monoplot_plugin.core.synthetic import synthetic_terrain
from monoplot_plugin.core.xyz import compute_xyz
from monoplot_plugin.workflow import products
from monoplot_plugin.workflow.inputs import check_view, load_dem
from monoplot_plugin.workflow.xyz import clear_cache

LIMIT = "200000"  # cells read whole at most, in these tests


def tiled_vrt(folder, tiles: int = 4, tile: int = 256, cell: float = 10.0) -> str:
    """A VRT over tiles x tiles GeoTIFF tiles cut from one synthetic terrain (EPSG:2056), without overviews."""
    dem = synthetic_terrain((tiles * tile, tiles * tile), cell=cell, seed=7)
    names = []
    for i in range(tiles):
        for j in range(tiles):
            name = os.path.join(folder, f"tile_{i}_{j}.tif")
            dem.crop(i * tile, j * tile, tile, tile).save(name)
            names.append(name)
    path = os.path.join(folder, "dem.vrt")
    gdal.BuildVRT(path, names).FlushCache()
    return path


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    folder = tmp_path_factory.mktemp("large_dem")
    path = tiled_vrt(str(folder))
    full = Dem.open(path)
    x, y = full.cell_to_map(80, 940)
    cam = Camera((x, y, float(np.nanmax(full.elevation)) + 150.0), heading=40.0, pitch=-7.0, roll=0.0, fov=60.0,
                 image_size=(360, 240))
    return path, full, cam


@pytest.fixture
def limit(monkeypatch):
    monkeypatch.setenv("MONOPLOT_DEM_MAX_CELLS", LIMIT)
    clear_cache()
    yield
    clear_cache()


def test_a_large_dem_is_opened_by_windows_and_says_so(scene, limit, tmp_path):
    path, full, cam = scene
    calls = []
    copy = str(tmp_path / "dem.vrt")  # a fresh copy without overviews (the tiles are shared)
    with open(path) as fh:
        text = fh.read().replace('relativeToVRT="1">', f'relativeToVRT="0">{os.path.dirname(path)}/')
    with open(copy, "w") as fh:
        fh.write(text)
    dem, notes = load_dem(copy, progress=lambda f, m="": calls.append((f, m)))
    assert isinstance(dem, LargeDem)
    assert dem.source.shape == (1024, 1024) and dem.source.levels[:2] == [1, 2]
    assert dem.elevation.size <= int(LIMIT)  # the preview fits the limit
    assert "read by windows" in notes[0] and any("built overviews" in n for n in notes)
    assert calls and calls[-1][0] == pytest.approx(1.0) and "overviews" in calls[-1][1]
    again, notes = load_dem(copy)
    assert not any("built overviews" in n for n in notes)  # built once
    check_view(cam, dem)
    # heights at points are the full resolution's, not the preview's
    x, y = full.cell_to_map(np.array([10.2, 500.7, 1000.1]), np.array([3.3, 640.5, 1020.0]))
    assert np.allclose(dem.sample(x, y), full.sample(x, y), atol=1e-3)
    # the dock's DEM adapter takes the same path
    from monoplot_plugin.adapters.dem import read_dem_file

    docked, notes = read_dem_file(copy)
    assert isinstance(docked, LargeDem) and "read by windows" in notes[0]
    # under the limit a DEM is read whole, as before
    os.environ["MONOPLOT_DEM_MAX_CELLS"] = str(full.elevation.size)
    assert type(load_dem(path)[0]) is Dem


def test_products_of_a_large_dem_match_the_full_resolution(scene, limit, tmp_path):
    path, full, cam = scene
    dem, _ = load_dem(path)
    assert isinstance(dem, LargeDem)
    out = products.write_xyz(tmp_path / "xyz.tif", cam, dem, distance=True)
    ds = gdal.Open(str(out))
    xyz = np.stack([ds.GetRasterBand(b).ReadAsArray() for b in (1, 2, 3)], axis=-1).astype(float)
    nodata = ds.GetRasterBand(1).GetNoDataValue()
    if nodata is not None:
        xyz[xyz[..., 0] == nodata] = np.nan
    reference = compute_xyz(cam, full)
    seen, got = np.isfinite(reference[..., 0]), np.isfinite(xyz[..., 0])
    assert seen.mean() > 0.3 and abs(seen.mean() - got.mean()) < 0.01
    both = seen & got
    ground = np.hypot(*(xyz[both, :2] - reference[both, :2]).T)
    assert np.mean(ground <= 2 * full.cell_size) > 0.97  # within a cell of the level used (1/1 or 1/2 here)
    # in strips (memory short): each strip the file's own z-buffer, the same raster
    from monoplot_plugin.core.xyz_strips import xyz_strips

    strips = np.concatenate([x for _, x, _ in xyz_strips(cam, dem, rows_per_strip=100)])
    assert np.mean(np.isfinite(strips[..., 0]) == got) > 0.99
    same = both & np.isfinite(strips[..., 0])
    assert np.median(np.hypot(*(strips[same, :2] - xyz[same, :2]).T)) < 0.01
    # the orthophoto: on the part of the file the camera sees, not the whole grid; the photo's colours on it
    photo = np.random.default_rng(0).integers(0, 255, (cam.height, cam.width, 3), dtype=np.uint8)
    ortho = gdal.Open(str(products.orthophoto(tmp_path / "ortho.tif", photo, cam, dem)))
    alpha = ortho.GetRasterBand(4).ReadAsArray()
    assert alpha.any() and ortho.RasterXSize * ortho.RasterYSize < full.elevation.size
    # the report (on the preview) and the suggestions (on what the camera sees)
    assert os.path.getsize(products.report(tmp_path / "report.png", photo, cam, dem)) > 0
    from monoplot_plugin.workflow.suggest import suggest_dem

    found = suggest_dem(dem, 50, cam)
    assert len(found.xyz) > 0 and np.isfinite(found.xyz).all()


def test_qgis_process_computes_xyz_over_a_large_dem(scene, tmp_path):
    from monoplot_plugin.processing import cli

    path, full, cam = scene
    env = dict(cli.prepare_environment(), MONOPLOT_DEM_MAX_CELLS=LIMIT)  # the shared folder: kernels compiled once
    cam_path = str(tmp_path / "camera.json")
    cam.save(cam_path)
    out = tmp_path / "xyz.tif"
    result = cli.run("monoplot:computexyz", {"CAMERA": cam_path, "DEM": path, "OUTPUT": str(out)}, env)
    ds = gdal.Open(str(out))  # kept: a band of a dataset already freed crashes GDAL's Python bindings
    z = ds.GetRasterBand(3).ReadAsArray()
    reference = compute_xyz(cam, full)[..., 2]
    assert result["results"]["GROUND_FRACTION"] == pytest.approx(np.isfinite(reference).mean(), abs=0.01)
    both = np.isfinite(reference) & np.isfinite(z) & (z > -1e30)
    assert np.median(np.abs(z[both] - reference[both])) < 1.0


def test_photo_points_on_a_large_dem_hit_the_full_resolution(scene, limit):
    """Features drawn on the photo (the dock's digitising, ``phototomap``) land on the file's full-resolution mesh,
    not on the preview's coarser one."""
    from monoplot_plugin.core.transforms import photo_points_to_map
    from monoplot_plugin.workflow.vectors import photo_to_map

    path, full, cam = scene
    dem, _ = load_dem(path)
    assert isinstance(dem, LargeDem) and dem.level >= 2
    rng = np.random.default_rng(3)
    uv = np.column_stack([rng.uniform(0, cam.width, 400), rng.uniform(0.35 * cam.height, cam.height, 400)])
    exact, seen = photo_points_to_map(uv, cam, full)
    got, hit = photo_points_to_map(uv, cam, dem)
    coarse, _ = photo_points_to_map(uv, cam, dem.preview())
    assert seen.mean() > 0.5 and abs(hit.mean() - seen.mean()) < 0.03
    both = seen & hit
    err = np.linalg.norm(got[both] - exact[both], axis=1)
    err_coarse = np.linalg.norm(coarse[both] - exact[both], axis=1)
    # most points on the full-resolution mesh (the rest: a ridge the preview averaged away hides them there)
    assert np.mean(err < 0.05 * full.cell_size) > 0.9
    assert np.median(err) < 0.1 * np.median(err_coarse)
    # the workflow's photo -> map (Processing's phototomap, the dock's drawn features) takes the same path
    assert np.allclose(photo_to_map(cam, dem, uv[both]), got[both], equal_nan=True)
