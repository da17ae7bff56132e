"""The outputs every algorithm writes, with the parameters that make each of them (shared by the bad-output
cases)."""

import shutil
from pathlib import Path

import numpy as np
from qgis.core import QgsFeature, QgsGeometry, QgsPointXY, QgsVectorLayer

from monoplot_plugin.core.dem import Dem
from monoplot_plugin.core.xyz import compute_xyz
from monoplot_plugin.processing.inputs import write_points_csv
from monoplot_plugin.outputs.safe_write import sidecar_suffixes


def scene_points(scene, folder: Path) -> dict:
    """Paired GCP CSV of 20 ground points the scene camera sees, a prior off by 50 m, a drawn photo polygon and
    a map polygon (memory layers are made per call: see :func:`parameters`)."""
    cam = scene["cam"]
    xyz = compute_xyz(cam, Dem.open(scene["dem"]))
    rows, cols = np.nonzero(np.isfinite(xyz[..., 2]))
    pick = np.random.default_rng(3).choice(len(rows), 20, replace=False)
    world = xyz[rows[pick], cols[pick]]
    gcps = folder / "gcps.csv"
    write_points_csv(str(gcps), uv=cam.project(world), xyz=world)
    prior = cam.with_parameters(x=cam.position[0] + 50, y=cam.position[1] - 30, heading=cam.heading + 1.5)
    prior.save(folder / "prior.json")
    v0, v1 = np.percentile(rows, [60, 90])
    ground = xyz[int(np.percentile(rows, 80)), 60:100]
    ground = ground[np.isfinite(ground[:, 2])]
    return {"gcps": str(gcps), "prior": str(folder / "prior.json"), "photo_box": (40, v0, 120, v1),
            "map_xy": ground[:, :2]}


def photo_layer(box):
    u0, v0, u1, v1 = box
    layer = QgsVectorLayer("Polygon", "drawn", "memory")
    feature = QgsFeature()
    feature.setGeometry(QgsGeometry.fromPolygonXY([[QgsPointXY(u0, -v0), QgsPointXY(u1, -v0), QgsPointXY(u1, -v1),
                                                    QgsPointXY(u0, -v1)]]))
    layer.dataProvider().addFeatures([feature])
    return layer


def map_layer(xy):
    layer = QgsVectorLayer("LineString?crs=EPSG:32632", "trail", "memory")
    feature = QgsFeature()
    feature.setGeometry(QgsGeometry.fromPolylineXY([QgsPointXY(float(x), float(y)) for x, y in xy]))
    layer.dataProvider().addFeatures([feature])
    return layer


#: id -> (algorithm, output file name)
OUTPUTS = {
    "camera_json": ("fitcamera", "camera.json"),
    "xyz_tif": ("computexyz", "xyz.tif"),
    "features_gpkg": ("phototomap", "outline.gpkg"),
    "features_shp": ("phototomap", "outline.shp"),
    "on_photo_gpkg": ("maptophoto", "trail_on_photo.gpkg"),
    "ortho_tif": ("orthophoto", "ortho.tif"),
    "report_png": ("report", "report.png"),
    "report_pdf": ("report", "report.pdf"),
    "photo_points_gpkg": ("suggestphotopoints", "photo_points.gpkg"),
    "dem_points_gpkg": ("suggestdempoints", "dem_points.gpkg"),
}


def parameters(case: str, scene, points, out: Path) -> dict:
    """Processing parameters writing output ``case`` to ``out``."""
    algorithm = OUTPUTS[case][0]
    common = {"CAMERA": scene["camera"], "DEM": scene["dem"], "OUTPUT": str(out)}
    if algorithm == "fitcamera":
        return {"PHOTO": scene["photo"], "DEM": scene["dem"], "PRIOR": points["prior"], "PHOTO_CSV": points["gcps"],
                "PAIRED": True, "OUTPUT": str(out)}
    if algorithm == "computexyz":
        return common
    if algorithm == "phototomap":
        return {**common, "INPUT": photo_layer(points["photo_box"]), "STEP": 5}
    if algorithm == "maptophoto":
        return {**common, "INPUT": map_layer(points["map_xy"])}
    if algorithm in ("orthophoto", "report"):
        return {**common, "PHOTO": scene["photo"]}
    if algorithm == "suggestphotopoints":
        return {"PHOTO": scene["photo"], "MAX_POINTS": 30, "OUTPUT": str(out)}
    if algorithm == "suggestdempoints":
        return {"DEM": scene["dem"], "MAX_POINTS": 30, "OUTPUT": str(out)}
    raise KeyError(case)


def members(path: Path) -> list:
    """Every file of an output (a Shapefile's sidecars too) that exists."""
    stem = path.name[: len(path.name) - len(path.suffix)]
    return [path.with_name(stem + s) for s in sidecar_suffixes(path) if path.with_name(stem + s).exists()]


def copy_output(source: Path, folder: Path) -> None:
    for member in members(source):
        shutil.copy2(member, folder / member.name)
