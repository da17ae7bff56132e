"""The algorithms from the command line (the real qgis_process binary) and chained in a Graphical Modeler model."""


import subprocess

import numpy as np
import pytest
from osgeo import gdal

from monoplot_plugin.core.dem import Dem
from monoplot_plugin.core.xyz import compute_xyz
from monoplot_plugin.processing import cli


@pytest.fixture(scope="module")
def qgis_env(tmp_path_factory):
    return cli.prepare_environment(str(tmp_path_factory.mktemp("qgis")))


def test_qgis_process_lists_the_provider(qgis_env):
    import subprocess

    listing = subprocess.run([cli.qgis_process_binary(), "list"], env=qgis_env, capture_output=True, text=True,
                             timeout=120).stdout
    for name in ("suggestphotopoints", "suggestdempoints", "fitcamera", "computexyz", "phototomap", "maptophoto",
                 "orthophoto", "report", "batch"):
        assert f"monoplot:{name}" in listing


def test_qgis_process_runs_compute_xyz(qgis_env, small_scene, tmp_path):
    out = tmp_path / "xyz.tif"
    result = cli.run("monoplot:computexyz", {"CAMERA": small_scene["camera"], "DEM": small_scene["dem"],
                                             "OUTPUT": str(out)}, qgis_env)
    assert result["results"]["OUTPUT"] == str(out)
    ds = gdal.Open(str(out))
    z = ds.GetRasterBand(3).ReadAsArray()
    expected = compute_xyz(small_scene["cam"], Dem.open(small_scene["dem"]))[..., 2]
    assert np.allclose(z, expected, equal_nan=True, atol=0.5)
    assert result["results"]["GROUND_FRACTION"] == pytest.approx(np.isfinite(expected).mean())


def test_qgis_process_reports_a_clear_error(qgis_env, small_scene, tmp_path):
    with pytest.raises(cli.QgisProcessError, match="camera file not found"):
        cli.run("monoplot:computexyz", {"CAMERA": str(tmp_path / "missing.json"), "DEM": small_scene["dem"],
                                        "OUTPUT": str(tmp_path / "x.tif")}, qgis_env)


def test_model_chains_fit_into_xyz(processing_provider, small_scene, tmp_path):
    """A Graphical Modeler model: fitcamera's camera file feeds computexyz, as a user would wire them."""
    import processing
    from qgis.core import (QgsProcessingModelAlgorithm, QgsProcessingModelChildAlgorithm,
                           QgsProcessingModelChildParameterSource, QgsProcessingModelOutput,
                           QgsProcessingModelParameter, QgsProcessingParameterFile,
                           QgsProcessingParameterRasterLayer)

    from monoplot_plugin.processing.inputs import write_points_csv

    cam = small_scene["cam"]
    xyz = compute_xyz(cam, Dem.open(small_scene["dem"]))
    rows, cols = np.nonzero(np.isfinite(xyz[..., 2]))
    pick = np.random.default_rng(1).choice(len(rows), 12, replace=False)
    world = xyz[rows[pick], cols[pick]]
    gcps = tmp_path / "gcps.csv"
    write_points_csv(str(gcps), uv=cam.project(world), xyz=world)
    prior = tmp_path / "prior.json"
    cam.with_parameters(heading=cam.heading + 1.0, x=cam.position[0] + 40).save(prior)

    model = QgsProcessingModelAlgorithm("fit then xyz", "monoplot tests")
    for name, param in (("photo", QgsProcessingParameterFile("photo", "photo")),
                        ("gcps", QgsProcessingParameterFile("gcps", "gcps")),
                        ("prior", QgsProcessingParameterFile("prior", "prior")),
                        ("dem", QgsProcessingParameterRasterLayer("dem", "dem"))):
        model.addModelParameter(param, QgsProcessingModelParameter(name))
    fit = QgsProcessingModelChildAlgorithm("monoplot:fitcamera")
    fit.setChildId("fit")
    for key, source in (("PHOTO", "photo"), ("PHOTO_CSV", "gcps"), ("PRIOR", "prior"), ("DEM", "dem")):
        fit.addParameterSources(key, [QgsProcessingModelChildParameterSource.fromModelParameter(source)])
    model.addChildAlgorithm(fit)
    xyz_child = QgsProcessingModelChildAlgorithm("monoplot:computexyz")
    xyz_child.setChildId("xyz")
    xyz_child.addParameterSources("CAMERA", [QgsProcessingModelChildParameterSource.fromChildOutput("fit",
                                                                                                  "OUTPUT")])
    xyz_child.addParameterSources("DEM", [QgsProcessingModelChildParameterSource.fromModelParameter("dem")])
    output = QgsProcessingModelOutput("xyz_raster")
    output.setChildOutputName("OUTPUT")
    xyz_child.setModelOutputs({"xyz_raster": output})
    model.addChildAlgorithm(xyz_child)

    out = tmp_path / "model_xyz.tif"
    result = processing.run(model, {"photo": small_scene["photo"], "gcps": str(gcps), "prior": str(prior),
                                    "dem": small_scene["dem"], "xyz:xyz_raster": str(out)})
    assert out.is_file() and result["xyz:xyz_raster"] == str(out)
    ds = gdal.Open(str(out))
    z = ds.GetRasterBand(3).ReadAsArray()
    assert np.nanmax(np.abs(z - xyz[..., 2])) < 25.0  # the fitted camera sees the same ground


def test_qgis_process_prints_the_warning_of_an_uncertain_camera(qgis_env, small_scene, tmp_path):
    """A trial: the dialog warned that the camera file was written by an "uncertain" fit, ``qgis_process`` said
    nothing (it sets no feedback on the context, where the warning went)."""
    from monoplot_plugin.workflow.camera_files import save_camera

    camera = tmp_path / "uncertain.json"
    save_camera(str(camera), small_scene["cam"], verdict={"status": "uncertain", "message": "two cameras agree"})
    command = [cli.qgis_process_binary(), "run", "monoplot:computexyz", "--", *cli.parameter_arguments(
        {"CAMERA": str(camera), "DEM": small_scene["dem"], "OUTPUT": str(tmp_path / "xyz.tif")})]
    process = subprocess.run(command, env=qgis_env, capture_output=True, text=True, timeout=120)
    assert process.returncode == 0, process.stderr[-2000:]
    assert 'written by a fit whose verdict was "uncertain"' in process.stdout and "two cameras agree" in process.stdout
