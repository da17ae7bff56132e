"""Memory: a product that does not fit in the free memory is computed in strips of the photo (the same values as at
once), and one that does not fit even in thin strips is refused with the numbers, leaving the earlier output."""

import numpy as np
import pytest
from osgeo import gdal
from qgis.core import QgsProcessingException, QgsProcessingFeedback

from monoplot_plugin.core.dem import Dem
from monoplot_plugin.core.xyz import compute_xyz
from monoplot_plugin.core.xyz_strips import MemoryBudgetError, plan_strips
from monoplot_plugin.outputs.xyz_raster import read_xyz_raster
from tests.badinput.conftest import leftovers

EARLIER = b"an earlier output the user wants to keep"


def _limit_for_rows(small_scene, rows):
    """A MONOPLOT_MEMORY_LIMIT_MB that leaves room for about ``rows`` photo rows of the scene's XYZ raster."""
    cam = small_scene["cam"]
    fixed = 3 * Dem.open(small_scene["dem"]).elevation.nbytes
    return (fixed + rows * cam.width * 40 + 100) / (1 << 20)


def test_xyz_in_strips_equals_xyz_at_once(run_alg, small_scene, tmp_path, monkeypatch):
    monkeypatch.setenv("MONOPLOT_MEMORY_LIMIT_MB", str(_limit_for_rows(small_scene, 37)))
    feedback = QgsProcessingFeedback()
    out = tmp_path / "xyz.tif"
    result = run_alg("computexyz", {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"], "OUTPUT": str(out)},
                     feedback)
    assert "computed in strips of 37 rows" in feedback.textLog()
    back, _, _, _ = read_xyz_raster(out)
    expected = compute_xyz(small_scene["cam"], Dem.open(small_scene["dem"]))
    assert np.array_equal(np.isnan(back), np.isnan(expected))
    ground = np.isfinite(expected)
    assert np.abs(back[ground] - expected[ground]).max() <= 0.01
    assert result["GROUND_FRACTION"] == pytest.approx(np.isfinite(expected[..., 2]).mean())


def test_orthophoto_in_strips_equals_orthophoto_at_once(run_alg, small_scene, tmp_path, monkeypatch):
    from monoplot_plugin.core.dem import Dem

    cell = Dem.open(small_scene["dem"]).cell_size  # the DEM's 80 x 80 grid (the default is the photo's detail)
    whole = tmp_path / "whole.tif"
    run_alg("orthophoto", {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"], "PHOTO": small_scene["photo"],
                           "RESOLUTION": cell, "OUTPUT": str(whole)})
    grid = 80 * 80 * 40
    monkeypatch.setenv("MONOPLOT_MEMORY_LIMIT_MB",
                       str((_limit_for_rows(small_scene, 30) * (1 << 20) + grid + 30 * 160 * 3) / (1 << 20)))
    feedback = QgsProcessingFeedback()
    strips = tmp_path / "strips.tif"
    run_alg("orthophoto", {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"], "PHOTO": small_scene["photo"],
                           "RESOLUTION": cell, "OUTPUT": str(strips)}, feedback)
    assert "Orthophoto computed in strips of" in feedback.textLog()
    a = gdal.Open(str(whole)).ReadAsArray()
    b = gdal.Open(str(strips)).ReadAsArray()
    assert a[-1].any()
    same_alpha = (a[-1] > 0) == (b[-1] > 0)
    assert same_alpha.mean() > 0.99  # cells exactly on a strip border may be judged from the other strip
    both = (a[-1] > 0) & (b[-1] > 0)
    assert np.array_equal(a[:-1][:, both], b[:-1][:, both])


@pytest.mark.parametrize("algorithm", ["computexyz", "orthophoto"])
def test_no_room_even_for_strips_is_refused_with_the_numbers(algorithm, run_alg, small_scene, tmp_path,
                                                              monkeypatch):
    monkeypatch.setenv("MONOPLOT_MEMORY_LIMIT_MB", "0.05")
    out = tmp_path / "out.tif"
    out.write_bytes(EARLIER)
    params = {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"], "OUTPUT": str(out)}
    if algorithm == "orthophoto":
        params["PHOTO"] = small_scene["photo"]
    with pytest.raises(QgsProcessingException,
                       match=r"160 x 120 px photo needs .* MB at once, and .* MB even in strips of 16 rows, but only "
                             r"0 MB can be used now"):
        run_alg(algorithm, params)
    assert out.read_bytes() == EARLIER and leftovers(tmp_path) == []


def test_a_huge_camera_is_planned_in_strips_not_allocated(small_scene):
    """A 20,000 x 15,000 px camera (300 MP: 12 GB at once) within 4 GB: strips of a few thousand rows; a 100,000 px
    wide one within 40 MB is refused with the numbers."""
    cam = small_scene["cam"].__class__(position=(0, 0, 0), heading=0, pitch=0, roll=0, fov=50,
                                       image_size=(20000, 15000))
    rows = plan_strips(cam, budget=4 << 30)
    assert 2000 < rows < 15000
    wide = cam.__class__(position=(0, 0, 0), heading=0, pitch=0, roll=0, fov=50, image_size=(100000, 100000))
    with pytest.raises(MemoryBudgetError, match="needs 400.00 GB at once"):
        plan_strips(wide, budget=40 << 20)
