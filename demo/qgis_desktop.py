"""``make qgis``: the real QGIS desktop with the Monoplot plugin from this checkout and the demo's project.

Runs the demo first when ``demo-output/`` has no results, writes ``demo-output/monoplot-demo.qgz`` (DEM,
hillshade, orthophoto, mapped outline, suggested DEM points; the photo-space layers in a second project,
``monoplot-demo-photo.qgz``), then starts ``qgis`` with an isolated profile where the plugin is enabled (your own
QGIS settings are not touched).

``--project-only`` writes the projects and exits (used by the tests).
"""

from __future__ import annotations

import argparse
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
    parser.add_argument("--code", help="Python file QGIS runs once started (qgis --code)")
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
    command = ["qgis", "--nologo", "--noversioncheck", "--project", str(project)]
    if args.code:
        command += ["--code", str(Path(args.code).resolve())]
    return subprocess.call(command, env=env)


if __name__ == "__main__":
    sys.exit(main())
