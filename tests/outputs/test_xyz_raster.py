"""XYZ raster: written through GDAL, opened back with GDAL; no data loss on refusal or failure."""

import os

import numpy as np
import pytest
from osgeo import gdal

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.outputs import OutputError, OutputExistsError, read_xyz_raster, write_xyz_raster
from monoplot_plugin.outputs.xyz_raster import PHOTO_GEOTRANSFORM

from outputs_helpers import CRS, read_only_folder, run_as_unprivileged


def test_xyz_raster_reads_back_with_gdal(plane_scene, tmp_path):
    scene = plane_scene
    path = write_xyz_raster(tmp_path / "xyz.tif", scene.xyz, scene.dem.crs_wkt, scene.distance,
                            camera=scene.camera, photo_name="photo.jpg")
    ds = gdal.Open(str(path))
    assert (ds.RasterXSize, ds.RasterYSize, ds.RasterCount) == (scene.camera.width, scene.camera.height, 4)
    assert [ds.GetRasterBand(i).GetDescription() for i in range(1, 5)] == ["X", "Y", "Z", "DISTANCE"]
    # 6-digit eastings: float32 would step by 6 cm, so the bands are float64 (<= 1 cm in any CRS)
    assert all(ds.GetRasterBand(i).DataType == gdal.GDT_Float64 for i in range(1, 5))
    assert all(np.isnan(ds.GetRasterBand(i).GetNoDataValue()) for i in range(1, 5))
    assert ds.GetRasterBand(3).GetUnitType() == "metre"
    # Photo pixel space: no map CRS on the raster, the value CRS in metadata.
    assert ds.GetProjection() == ""
    assert ds.GetGeoTransform() == PHOTO_GEOTRANSFORM
    meta = ds.GetMetadata()
    assert meta["MONOPLOT_VALUE_CRS_AUTHID"] == CRS
    assert Camera.from_json(meta["MONOPLOT_CAMERA"]) == scene.camera
    structure = ds.GetMetadata("IMAGE_STRUCTURE")
    assert structure["COMPRESSION"] == "DEFLATE"
    assert ds.GetRasterBand(1).GetBlockSize() == [256, 256]
    z = ds.GetRasterBand(3).ReadAsArray()
    sky = np.isnan(scene.xyz[..., 2])
    assert sky.any() and (~sky).any()
    assert np.array_equal(np.isnan(z), sky)
    assert np.allclose(z[~sky], scene.xyz[..., 2][~sky], atol=1e-3)
    xyz, value_crs, distance, _ = read_xyz_raster(path)
    assert np.abs(xyz[~sky] - scene.xyz[~sky]).max() <= 0.01
    assert distance is not None and value_crs
    ds = None


def test_xyz_raster_lzw_without_distance(plane_scene, tmp_path):
    path = write_xyz_raster(tmp_path / "xyz.tif", plane_scene.xyz, CRS, compress="LZW")
    ds = gdal.Open(str(path))
    assert ds.RasterCount == 3
    assert ds.GetMetadata("IMAGE_STRUCTURE")["COMPRESSION"] == "LZW"


def test_existing_output_is_refused_then_replaced_on_request(plane_scene, tmp_path):
    path = tmp_path / "xyz.tif"
    write_xyz_raster(path, plane_scene.xyz, CRS)
    before = path.read_bytes()
    with pytest.raises(OutputExistsError, match="already exists"):
        write_xyz_raster(path, plane_scene.xyz + 1.0, CRS)
    assert path.read_bytes() == before
    write_xyz_raster(path, plane_scene.xyz + 1.0, CRS, overwrite=True)
    assert path.read_bytes() != before
    assert sorted(os.listdir(tmp_path)) == ["xyz.qml", "xyz.tif"]  # no temporary file left


def test_writing_reports_progress_and_a_cancel_stops_it_part_way(plane_scene, tmp_path, monkeypatch):
    """The rows written are reported as they go; a cancel stops the write at the next part (not only before the
    final rename), and the earlier file stays as it was."""
    from monoplot_plugin.outputs import xyz_raster
    from monoplot_plugin.outputs.safe_write import OutputCanceled, cancel_before_commit

    monkeypatch.setattr(xyz_raster, "WRITE_ROWS", 8)  # several parts per band on this small raster
    path = tmp_path / "xyz.tif"
    done = []
    write_xyz_raster(path, plane_scene.xyz, CRS, progress=done.append)
    rows = plane_scene.xyz.shape[0]
    assert len(done) == 3 * -(-rows // 8) and done == sorted(done) and done[-1] == 1.0
    before = path.read_bytes()
    parts = []
    with cancel_before_commit(lambda: len(parts) >= 2), pytest.raises(OutputCanceled, match="not written"):
        write_xyz_raster(path, plane_scene.xyz + 1.0, CRS, overwrite=True, progress=parts.append)
    assert len(parts) == 2  # stopped at the third part of the first band, not after the whole file
    assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["xyz.qml", "xyz.tif"]


def test_failure_half_way_leaves_earlier_output_intact(plane_scene, tmp_path):
    path = tmp_path / "xyz.tif"
    write_xyz_raster(path, plane_scene.xyz, CRS)
    before = path.read_bytes()
    broken = plane_scene.xyz.astype(object)  # passes the shape check, fails while writing the bands
    with pytest.raises(TypeError):
        write_xyz_raster(path, broken, CRS, overwrite=True)
    assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["xyz.qml", "xyz.tif"]


def test_non_ascii_path(plane_scene, tmp_path):
    folder = tmp_path / "Glétscher Ålétsch 氷河"
    folder.mkdir()
    path = write_xyz_raster(folder / "Aletschgletscher 1890 – xyz.tif", plane_scene.xyz, CRS)
    assert gdal.Open(str(path)).RasterCount == 3


WRITE_TWICE = ("import sys, numpy as np\n"
               "from monoplot_plugin.outputs import write_xyz_raster, OutputError\n"
               "xyz = np.ones((20, 30, 3))\n"
               "for name, overwrite in (('new.tif', False), ('xyz.tif', True)):\n"
               "    try:\n"
               "        write_xyz_raster(sys.argv[1] + '/' + name, xyz, 'EPSG:21781', overwrite=overwrite)\n"
               "        print('WROTE', name)\n"
               "    except OutputError as exc:\n"
               "        print('REFUSED', exc)\n")


def test_read_only_folder_is_reported_and_earlier_output_kept(plane_scene, world_readable_tmp):
    folder = world_readable_tmp / "read-only folder"
    folder.mkdir()
    earlier = write_xyz_raster(folder / "xyz.tif", plane_scene.xyz, CRS)
    before = earlier.read_bytes()
    with read_only_folder(folder) as how:
        if how == "other-user":
            result = run_as_unprivileged(WRITE_TWICE, folder)
            assert result.returncode == 0, result.stderr
            output = result.stdout
        else:
            lines = []
            for name, overwrite in (("new.tif", False), ("xyz.tif", True)):
                try:
                    write_xyz_raster(folder / name, np.ones((20, 30, 3)), CRS, overwrite=overwrite)
                    lines.append(f"WROTE {name}")
                except OutputError as exc:
                    lines.append(f"REFUSED {exc}")
            output = "\n".join(lines)
    lines = output.strip().splitlines()
    assert len(lines) == 2 and all(line.startswith("REFUSED") for line in lines), output
    assert "permission denied" in lines[0] and "read-only" in lines[0]
    assert earlier.read_bytes() == before
    assert sorted(os.listdir(folder)) == ["xyz.qml", "xyz.tif"]


def test_missing_folder_and_bad_shapes_are_clear_errors(plane_scene, tmp_path):
    with pytest.raises(OutputError, match="does not exist"):
        write_xyz_raster(tmp_path / "nowhere" / "xyz.tif", plane_scene.xyz, CRS)
    with pytest.raises(ValueError, match=r"\(H, W, 3\)"):
        write_xyz_raster(tmp_path / "xyz.tif", plane_scene.xyz[..., :2], CRS)


FILL_THE_DISK = ("import resource, signal, sys, numpy as np\n"
                 "from monoplot_plugin.outputs import write_xyz_raster, OutputError\n"
                 "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # the write fails (EFBIG) instead of killing us\n"
                 "resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))\n"
                 "xyz = np.random.default_rng(0).uniform(6e5, 7e5, (600, 800, 3))\n"
                 "try:\n"
                 "    write_xyz_raster(sys.argv[1], xyz, 'EPSG:21781', overwrite=True)\n"
                 "    print('WROTE')\n"
                 "except OutputError as exc:\n"
                 "    print('REFUSED', exc)\n")


def test_running_out_of_space_half_way_keeps_the_earlier_output(plane_scene, tmp_path):
    """A real failed write: the OS refuses to grow the file past 200 kB, as on a full disk."""
    import subprocess
    import sys

    path = write_xyz_raster(tmp_path / "xyz.tif", plane_scene.xyz, CRS)
    before = path.read_bytes()
    result = subprocess.run([sys.executable, "-c", FILL_THE_DISK, str(path)], capture_output=True, text=True,
                            timeout=60, env=dict(os.environ, PYTHONPATH=os.getcwd()))
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("REFUSED cannot write") and "disk is full" in result.stdout, result.stdout
    assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["xyz.qml", "xyz.tif"]
