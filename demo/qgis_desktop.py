"""``make qgis``: the real QGIS desktop with the Monoplot plugin from this checkout and the demo's project.

Runs the demo first when ``demo-output/`` has no results, writes ``demo-output/monoplot-demo.qgz`` (DEM,
hillshade, orthophoto, mapped outline, suggested DEM points, and a Monoplot session: the photo, the prior and fitted
cameras, the curated points and the demo's check points, which the dock restores when it opens; the photo-space
layers go in a second project, ``monoplot-demo-photo.qgz``), then starts ``qgis`` with an isolated profile where the
plugin is enabled and its dock open (your own QGIS settings are not touched).

``--project-only`` writes the projects and exits (used by the tests).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from monoplot_plugin.processing import cli  # noqa: E402


def add_in_order(project, layers) -> None:
    """Add the valid layers to the project's legend in the given order (first = on top)."""
    root = project.layerTreeRoot()
    for layer in layers:
        if layer.isValid():
            project.addMapLayer(layer, False)
            root.addLayer(layer)


def demo_session(out: Path, dem_layer):
    """The Monoplot dock's state for the demo: photo, DEM layer, prior and fitted cameras, the curated points
    (accepted, unpaired, as the fit used them) and the check points (paired, kept out of the fit)."""
    import csv

    from monoplot_plugin.core.camera import Camera
    from monoplot_plugin.state import ACCEPTED, CHECK, MAP, PHOTO, Point, ProjectState

    def rows(name):
        with open(out / name, newline="", encoding="utf-8") as fh:
            return list(csv.DictReader(fh))

    state = ProjectState(photo_path=str(out / "scene" / "photo.png"), dem_layer_id=dem_layer.id(),
                         dem_source=dem_layer.source())
    points = [Point.new(PHOTO, float(r["u_px"]), float(r["v_px"]), status=ACCEPTED)
              for r in rows("curated_photo_points.csv")]
    points += [Point.new(MAP, float(r["X"]), float(r["Y"]), float(r["Z"]), status=ACCEPTED)
               for r in rows("curated_dem_points.csv")]
    for r in rows("check_points.csv"):
        a = Point.new(PHOTO, float(r["u_px"]), float(r["v_px"]), status=CHECK, manual=True, label="check")
        b = Point.new(MAP, float(r["X"]), float(r["Y"]), float(r["Z"]), status=CHECK, manual=True, label="check")
        points += [a, b]
        state.pairs.append((a.id, b.id))
    state.points = {p.id: p for p in points}
    state.prior = Camera.from_json((out / "scene" / "prior.json").read_text()).to_dict()
    state.fitted = Camera.from_json((out / "camera.json").read_text()).to_dict()
    summary = json.loads((out / "summary.json").read_text())
    state.fit_info = {"status": "ok", "mode": "unpaired", "rmse_px": summary["fit_rmse_px"],
                      "n_photo": sum(p.space == PHOTO and p.status == ACCEPTED for p in points),
                      "n_map": sum(p.space == MAP and p.status == ACCEPTED for p in points),
                      "check_rmse_px": summary["check_reprojection_rmse_px"], "n_check": len(state.check_pairs())}
    return state


def write_projects(out: Path) -> Path:
    """Build the demo's map project (and the photo-space one) with PyQGIS, headless; returns the map project."""
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from qgis.core import (QgsApplication, QgsCoordinateReferenceSystem, QgsFillSymbol, QgsHillshadeRenderer,
                           QgsProject, QgsRasterLayer, QgsReferencedRectangle, QgsVectorLayer)

    app = QgsApplication([], False)
    app.initQgis()
    try:
        project = QgsProject()
        dem = QgsRasterLayer(str(out / "scene" / "dem.tif"), "DEM")
        layers = [  # legend order, top first
            QgsVectorLayer(str(out / "suggested_dem_points.gpkg"), "Suggested DEM points", "ogr"),
            QgsVectorLayer(str(out / "outline.gpkg"), "Glacier outline traced on the photo", "ogr"),
            QgsRasterLayer(str(out / "ortho.tif"), "Orthophoto (photo draped on the DEM)"),
            dem,
        ]
        if dem.isValid():
            dem.setRenderer(QgsHillshadeRenderer(dem.dataProvider(), 1, 315.0, 45.0))
        outline = layers[1]
        if outline.isValid():
            outline.renderer().setSymbol(QgsFillSymbol.createSimple(
                {"color": "0,0,0,0", "outline_color": "220,30,30", "outline_width": "0.8"}))
        add_in_order(project, layers)
        if dem.isValid():
            from monoplot_plugin.gui import persistence

            persistence.store_in_project(project, demo_session(out, dem))
        project.setCrs(dem.crs())
        if dem.isValid():
            project.viewSettings().setDefaultViewExtent(QgsReferencedRectangle(dem.extent(), dem.crs()))
        map_project = out / "monoplot-demo.qgz"
        project.write(str(map_project))

        photo_project = QgsProject()
        photo_layers = [  # legend order, top first
            QgsVectorLayer(str(out / "suggested_photo_points.gpkg"), "Suggested photo points", "ogr"),
            QgsVectorLayer(str(out / "outline_on_photo.gpkg"), "Outline traced on the photo", "ogr"),
            QgsRasterLayer(str(out / "xyz.tif"), "XYZ raster (identify a pixel: X, Y, Z)"),
            QgsRasterLayer(str(out / "scene" / "photo.png"), "Photo"),
        ]
        for layer in photo_layers:
            layer.setCrs(QgsCoordinateReferenceSystem())
        add_in_order(photo_project, photo_layers)
        photo_project.write(str(out / "monoplot-demo-photo.qgz"))
        # projects own their layers: empty them while QGIS is still up (exitQgis first would crash)
        project.clear()
        photo_project.clear()
        del layers, photo_layers, dem, project, photo_project
        return map_project
    finally:
        app.exitQgis()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "demo-output"))
    parser.add_argument("--project-only", action="store_true")
    parser.add_argument("--code", help="Python file QGIS runs once started (qgis --code; default: demo/open_dock.py)")
    args = parser.parse_args(argv)
    out = Path(args.out).resolve()
    if not (out / "camera.json").is_file():
        from demo import run_demo

        run_demo.run(out)
    project = write_projects(out)
    print(f"project: {project}")
    if args.project_only:
        return 0
    env = cli.prepare_environment(str(out / ".qgis"))
    if os.environ.get("DISPLAY"):  # a real screen: undo the Makefile's offscreen default
        env.pop("QT_QPA_PLATFORM", None)
    code = Path(args.code).resolve() if args.code else REPO / "demo" / "open_dock.py"
    command = ["qgis", "--nologo", "--noversioncheck", "--project", str(project), "--code", str(code)]
    return subprocess.call(command, env=env)


if __name__ == "__main__":
    sys.exit(main())
