"""Layers of the dock's products in the QGIS project, and map layers drawn onto the photo.

- :func:`photo_group`: the layer-tree group named after the photo that holds every product of that photo.
- :func:`add_xyz_layer`, :func:`add_orthophoto_layer`, :func:`add_vector_file_layer`: add written files, styled.
- :func:`map_layer_on_photo`: any vector layer of the project projected onto the photo, hidden parts dashed.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional, Tuple

import numpy as np
from qgis.core import (QgsCategorizedSymbolRenderer, QgsCoordinateReferenceSystem, QgsCoordinateTransform, QgsFeature,
                       QgsField, QgsGeometry, QgsLayerTreeGroup, QgsProject, QgsRasterLayer, QgsRendererCategory,
                       QgsSymbol, QgsVectorLayer, QgsWkbTypes)
from qgis.PyQt.QtCore import Qt, QVariant
from qgis.PyQt.QtGui import QColor

from ..adapters.layers import crs_from_wkt as _crs
from ..adapters.layers import style_xyz_layer
from ..adapters.photo_space import outline_parts, photo_point
from ..workflow.features import map_to_photo

__all__ = ["photo_group", "add_layer", "add_xyz_layer", "add_orthophoto_layer", "add_vector_file_layer",
           "map_layer_on_photo", "overlay_outcome"]


def photo_group(project: QgsProject, photo_name: str) -> QgsLayerTreeGroup:
    """The top-level layer group named after the photo (file stem), created on first use."""
    name = Path(photo_name).stem or "Monoplot"
    root = project.layerTreeRoot()
    group = root.findGroup(name)
    return group if group is not None else root.insertGroup(0, name)


def _file_of(layer) -> str:
    """The file behind a file-based layer (GeoPackage sources carry ``|layername=...``), normalised; "" if none
    (a memory layer: its source ``memory?geometry=...`` of a drawn layer is longer than a file name may be, and
    ``is_file`` raised "File name too long": every export after a drawing ended in a traceback, a trial)."""
    if layer.providerType() == "memory":
        return ""
    path = layer.source().split("|")[0]
    try:
        return str(Path(path).resolve()) if path and Path(path).is_file() else ""
    except (OSError, ValueError):  # not a path this system can have
        return ""


def add_layer(project: QgsProject, layer, group: Optional[QgsLayerTreeGroup]):
    """Add ``layer`` to ``group`` (or the legend's root): vector layers above the group's rasters, so that an
    opaque orthophoto never hides the outlines drawn on the photo; a layer of the group on the same file (an
    export written again to the same path) is replaced, not duplicated."""
    if group is None:
        project.addMapLayer(layer, True)
        return layer
    source = _file_of(layer)
    if source:
        old = [node.layer() for node in group.findLayers()
               if node.layer() is not None and node.layer() is not layer and _file_of(node.layer()) == source
               and node.layer().type() == layer.type()]
        if old:
            project.removeMapLayers([o.id() for o in old])
    project.addMapLayer(layer, False)
    if isinstance(layer, QgsVectorLayer):
        group.insertLayer(0, layer)
    else:
        group.addLayer(layer)
    return layer


def add_xyz_layer(path, project: QgsProject, group: Optional[QgsLayerTreeGroup] = None,
                  visible: bool = False) -> QgsRasterLayer:
    """Add an XYZ raster (see :mod:`..outputs.xyz_raster`): Z as a colour ramp, no CRS (photo pixel space, drawn without
    reprojection), identify shows X, Y, Z (and DISTANCE) of the clicked photo pixel.

    It lies at x in [0, W], y in [-H, 0] of whatever CRS the map has, far from the real terrain, so it is added
    unchecked (``visible=False``): a hidden layer does not stretch "zoom to full extent"; check it and "zoom to
    layer" to look at it and identify-click it.
    """
    layer = QgsRasterLayer(str(path), f"{Path(path).stem} (X Y Z, photo pixels)")
    if not layer.isValid():
        raise ValueError(f"QGIS cannot open {path}")
    style_xyz_layer(layer)
    add_layer(project, layer, group)
    node = (group or project.layerTreeRoot()).findLayer(layer.id())
    if node is not None:
        node.setItemVisibilityChecked(visible)
    return layer


def add_orthophoto_layer(path, project: QgsProject, group: Optional[QgsLayerTreeGroup] = None) -> QgsRasterLayer:
    """Add an orthophoto GeoTIFF (RGB + alpha: unseen cells transparent)."""
    layer = QgsRasterLayer(str(path), f"{Path(path).stem} (orthophoto)")
    if not layer.isValid():
        raise ValueError(f"QGIS cannot open {path}")
    return add_layer(project, layer, group)


def add_vector_file_layer(path, project: QgsProject, group: Optional[QgsLayerTreeGroup] = None) -> QgsVectorLayer:
    """Add the vector file ``path`` (see :func:`add_layer`), named by its stem; by its file name when another file's
    layer of the group has that name (a trial saved the drawn features as GeoPackage, then as Shapefile, and got
    two layers of each name)."""
    name = Path(path).stem
    if group is not None and any(node.layer() is not None and node.layer().name() == name
                                 and _file_of(node.layer()) != str(Path(path).resolve())
                                 for node in group.findLayers()):
        name = Path(path).name
    layer = QgsVectorLayer(str(path), name, "ogr")
    if not layer.isValid():
        raise ValueError(f"QGIS cannot open {path}")
    return add_layer(project, layer, group)


def map_layer_on_photo(layer: QgsVectorLayer, camera, dem,
                       project: Optional[QgsProject] = None) -> QgsVectorLayer:
    """A pixel-space line layer of ``layer``'s lines and polygon outlines as the camera sees them.

    Each output feature is one piece with the field ``visible`` (1 seen, 0 hidden behind terrain); styled solid
    for visible, dashed for hidden. Points become short pieces around them. Add it to the photo canvas with
    ``PhotoCanvas.set_extra_layers``.
    """
    transform = QgsCoordinateTransform(layer.crs(), _crs(dem.crs_wkt), project or QgsProject.instance())
    out = QgsVectorLayer("LineString", f"{layer.name()} on photo", "memory")
    out.setCrs(QgsCoordinateReferenceSystem())
    provider = out.dataProvider()
    provider.addAttributes([QgsField("source_fid", QVariant.Type.LongLong), QgsField("visible", QVariant.Type.Int)])
    out.updateFields()
    with np.errstate(invalid="ignore", divide="ignore"):  # vertices a transform could not place (NaN): dropped
        new = _pieces_on_photo(layer, transform, out, camera, dem)
    provider.addFeatures(new)
    out.updateExtents()
    _style_visible_hidden(out)
    return out


def _pieces_on_photo(layer, transform, out, camera, dem) -> list:
    """The features of ``out`` (pieces with ``source_fid`` and ``visible``) for ``layer`` seen by ``camera``."""
    new = []
    for feature in layer.getFeatures():
        geom = QgsGeometry(feature.geometry())
        if geom.isNull():
            continue
        if layer.crs().isValid() and transform.isValid():
            geom.transform(transform)
        for part in outline_parts(geom, dem.cell_size):
            for path in map_to_photo([part], camera, dem):
                for uv, visible in path.pieces():
                    f = QgsFeature(out.fields())
                    f.setGeometry(QgsGeometry.fromPolylineXY([photo_point(u, v) for u, v in uv]))
                    f["source_fid"] = feature.id()
                    f["visible"] = int(visible)
                    new.append(f)
    return new


def overlay_outcome(layer: QgsVectorLayer, overlay: QgsVectorLayer, tr=str) -> Tuple[str, bool]:
    """(message, doubtful) for ``layer`` drawn on the photo as ``overlay`` (:func:`map_layer_on_photo`): how many of
    its features the camera sees; doubtful when none is in view or the layer has no CRS (taken as the DEM's)."""
    total = layer.featureCount()
    sources = {f["source_fid"] for f in overlay.getFeatures()}
    # features, not pieces: a line along a valley floor grazed by 15 m DEM bumps made "9 pieces hidden" of 1-10 px,
    # which read as far more occlusion than there was (a trial)
    hidden = len({f["source_fid"] for f in overlay.getFeatures() if not f["visible"]})
    no_crs = "" if layer.crs().isValid() else " " + tr(
        "The layer has no CRS: its coordinates were taken to be in the DEM's CRS.")
    if not sources:
        return tr("None of the {0} features of {1} is in the photo's view: they lie outside what the camera sees, or "
                  "the layer's CRS is not what it says.").format(total, layer.name()) + no_crs, True
    text = tr("Drawn on the photo: {0} of the {1} features of {2}").format(len(sources), total, layer.name())
    if hidden and layer.geometryType() == QgsWkbTypes.GeometryType.PointGeometry:  # a point is hidden, not partly
        text += " " + tr("({0} of them hidden behind terrain)").format(hidden)
    elif hidden:
        text += " " + tr("({0} of them partly hidden behind terrain, dashed)").format(hidden)
    return text + "." + no_crs, bool(no_crs)


def _style_visible_hidden(layer: QgsVectorLayer) -> None:
    solid = QgsSymbol.defaultSymbol(layer.geometryType())
    solid.setColor(QColor(255, 60, 60))
    solid.symbolLayer(0).setWidth(0.7)
    dashed = solid.clone()
    dashed.symbolLayer(0).setPenStyle(Qt.PenStyle.DashLine)
    dashed.setOpacity(0.8)
    layer.setRenderer(QgsCategorizedSymbolRenderer("visible", [
        QgsRendererCategory(1, solid, "visible"), QgsRendererCategory(0, dashed, "hidden behind terrain")]))
