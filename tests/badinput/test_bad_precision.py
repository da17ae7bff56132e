"""XYZ precision: a 7-digit UTM northing keeps 1 cm in the file (float32 would step by 0.5 m), in the layout both the
dock and Processing write; coordinates small enough for float32 stay float32 within 4 mm."""

import numpy as np
import pytest
from osgeo import gdal

from monoplot_plugin.outputs.xyz_raster import read_xyz_raster, write_xyz_raster


@pytest.mark.parametrize("origin,dtype", [((699999.123, 5199999.987), gdal.GDT_Float64),
                                          ((2699999.5, 1299999.5), gdal.GDT_Float64),  # Swiss LV95
                                          ((1000.25, 2000.75), gdal.GDT_Float32)],
                         ids=["utm", "lv95", "local"])
def test_xyz_values_keep_one_centimetre(origin, dtype, tmp_path):
    rng = np.random.default_rng(1)
    xyz = np.dstack([origin[0] + rng.uniform(0, 5000, (40, 50)), origin[1] + rng.uniform(0, 5000, (40, 50)),
                     rng.uniform(200, 4000, (40, 50))])
    xyz[:5] = np.nan  # sky
    path = write_xyz_raster(tmp_path / "xyz.tif", xyz, "EPSG:32632")
    ds = gdal.Open(str(path))
    assert ds.GetRasterBand(1).DataType == dtype
    back, _, _, _ = read_xyz_raster(path)
    sky = np.isnan(xyz)
    assert np.array_equal(np.isnan(back), sky)
    assert np.abs(back[~sky] - xyz[~sky]).max() <= 0.01


def test_processing_xyz_keeps_one_centimetre(run_alg, small_scene, tmp_path):
    """computexyz on a UTM scene (7-digit northings): the file holds core's values to 1 cm."""
    from monoplot_plugin.core.dem import Dem
    from monoplot_plugin.core.xyz import compute_xyz

    out = tmp_path / "xyz.tif"
    run_alg("computexyz", {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"], "OUTPUT": str(out)})
    back, _, _, _ = read_xyz_raster(out)
    expected = compute_xyz(small_scene["cam"], Dem.open(small_scene["dem"]))
    ground = np.isfinite(expected[..., 1])
    assert np.abs(back[ground] - expected[ground]).max() <= 0.01
