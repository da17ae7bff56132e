"""The demo itself (quick mode): the whole pipeline through qgis_process; its figures are checked."""

import json
from pathlib import Path

import pytest
from osgeo import gdal, ogr


@pytest.fixture(scope="module")
def demo_summary(tmp_path_factory):
    from demo import run_demo

    out = tmp_path_factory.mktemp("demo") / "demo-output"
    summary = run_demo.run(out, quick=True, verbose=False)
    return out, summary


def test_demo_recovers_the_hidden_camera(demo_summary):
    out, summary = demo_summary
    errors, prior = summary["pose_error"], summary["prior_pose_error"]
    # quick scene: 480x360 px, 50 m DEM, ground 1.6-5 km away; measured 40 m, 0.15/0.4/0.1 deg, fov 0.75 deg,
    # 1.7 px on check points, outline 28 m (bounds leave room for platform differences, not for a broken fit)
    assert errors["position_m"] < 0.6 * prior["position_m"]
    assert max(errors["heading_deg"], errors["pitch_deg"], errors["roll_deg"]) < 0.8 and errors["fov_deg"] < 1.2
    assert summary["check_reprojection_rmse_px"] < 3.0
    assert summary["prior_check_reprojection_rmse_px"] > 10 * summary["check_reprojection_rmse_px"]
    assert summary["outline_mean_error_m"] < 60.0
    assert summary["outline_round_trip_px"] < 1.5  # photo -> map -> photo with the same camera
    assert json.loads((out / "summary.json").read_text())["pose_error"] == errors


def test_demo_outputs_are_readable_gis_files(demo_summary):
    out, _ = demo_summary
    for name in ("outline.gpkg", "outline.shp"):
        ds = ogr.Open(str(out / name))
        layer = ds.GetLayer(0)
        assert layer.GetFeatureCount() == 1
        feature = layer.GetNextFeature()  # keep the feature alive while its geometry is used
        geometry = feature.GetGeometryRef()
        assert geometry.GetArea() > 0 and geometry.Is3D()
    for name, bands in (("xyz.tif", 3), ("ortho.tif", 4)):
        ds = gdal.Open(str(out / name))
        assert ds is not None and ds.RasterCount >= bands
    assert (out / "report.png").stat().st_size > 50_000


def test_make_qgis_project_lists_the_demo_layers(demo_summary, qgis_app):
    """``make qgis`` writes a project of the demo's outputs before starting QGIS (here without starting it)."""
    import subprocess
    import sys

    from qgis.core import QgsProject

    out, _ = demo_summary
    subprocess.run([sys.executable, "demo/qgis_desktop.py", "--project-only", "--out", str(out)], check=True,
                   timeout=120, capture_output=True)
    project = QgsProject()
    assert project.read(str(out / "monoplot-demo.qgz"))
    names = [layer.name() for layer in project.layerTreeRoot().layerOrder()]
    assert names[0] == "Suggested DEM points" and names[-1] == "DEM" and len(names) == 4
    assert all(layer.isValid() for layer in project.mapLayers().values())
    # the Monoplot session the dock restores: photo, DEM layer, cameras, curated points and check points
    from monoplot_plugin.gui import persistence
    from monoplot_plugin.state import ACCEPTED, PHOTO

    state = persistence.load(project)
    assert state is not None and Path(state.photo_path).is_file()
    assert project.mapLayer(state.dem_layer_id).name() == "DEM"
    assert state.prior is not None and state.fitted is not None
    assert len(state.check_pairs()) >= 10 and len(state.in_space(PHOTO, (ACCEPTED,))) >= 10
    assert state.fit_info["check_rmse_px"] < 5
    project.clear()
