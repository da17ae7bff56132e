"""Photo pixel space in QGIS, and QgsGeometry <-> numpy vertex arrays (the one place for both).

Photo-space layers and the photo canvas put pixel ``(u, v)`` (u = column, v = row from the top-left corner) at
``(x, y) = (u, -v)``, like QGIS's Georeferencer, so that the photo shows the right way up with the image at
``x in [0, W]``, ``y in [-H, 0]``. Photo-space layers have no CRS.

>>> p = photo_point(10, 20)
>>> (p.x(), p.y()), pixel_of(p)
((10.0, -20.0), (10.0, 20.0))
>>> photo_vertices(photo_geometry("polygon", [(0, 0), (4, 0), (4, 3)])).tolist()
[[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]]
"""

from __future__ import annotations

from typing import List, Optional, Tuple

import numpy as np
from qgis.core import (QgsGeometry, QgsLineString, QgsMultiLineString, QgsMultiPoint, QgsMultiPolygon, QgsPoint,
                       QgsPointXY, QgsPolygon, QgsWkbTypes)

__all__ = ["PHOTO_Y_SIGN", "photo_point", "pixel_of", "photo_geometry", "photo_vertices", "qgs_geometry",
           "geometry_kind", "computed_fields", "geometry_parts", "build_geometry", "outline_parts"]

#: Sign of the photo-space y axis: y = PHOTO_Y_SIGN * v.
PHOTO_Y_SIGN = -1.0


def photo_point(u: float, v: float) -> QgsPointXY:
    """Photo pixel (u, v) -> photo-space point (u, -v)."""
    return QgsPointXY(float(u), PHOTO_Y_SIGN * float(v))


def pixel_of(point) -> Tuple[float, float]:
    """Photo-space point (any object with x() and y()) -> photo pixel (u, v)."""
    return float(point.x()), PHOTO_Y_SIGN * float(point.y())


def photo_geometry(kind: str, vertices_uv) -> QgsGeometry:
    """Pixel vertices (u, v) -> photo-canvas geometry (x = u, y = -v)."""
    pts = [photo_point(u, v) for u, v in np.asarray(vertices_uv, dtype=float).reshape(-1, 2)]
    if kind == "point":
        return QgsGeometry.fromPointXY(pts[0])
    if kind == "line":
        return QgsGeometry.fromPolylineXY(pts)
    return QgsGeometry.fromPolygonXY([pts + [pts[0]]])


def photo_vertices(geometry: QgsGeometry) -> np.ndarray:
    """(N, 2) pixel vertices (u, v) of a photo-canvas geometry (polygon: exterior ring without the closing
    vertex)."""
    pts = [pixel_of(p) for p in geometry.vertices()]
    if geometry.type() == QgsWkbTypes.GeometryType.PolygonGeometry and len(pts) > 1 and pts[0] == pts[-1]:
        pts = pts[:-1]
    return np.array(pts, dtype=float).reshape(-1, 2)


def qgs_geometry(feature):
    """A QGIS 3-D geometry (QgsPoint / QgsMultiLineString / QgsMultiPolygon with Z) for an outputs ``MapFeature``."""
    if feature.kind == "point":
        x, y, z = feature.parts[0][0]
        return QgsPoint(float(x), float(y), float(z))
    multi = QgsMultiLineString() if feature.kind == "line" else QgsMultiPolygon()
    for part in feature.parts:
        if feature.kind == "polygon" and not np.array_equal(part[0], part[-1]):
            part = np.vstack([part, part[:1]])
        line = QgsLineString([QgsPoint(float(x), float(y), float(z)) for x, y, z in part])
        if feature.kind == "line":
            multi.addGeometry(line)
        else:
            polygon = QgsPolygon()
            polygon.setExteriorRing(line)
            multi.addGeometry(polygon)
    return multi


def geometry_kind(geometry_type) -> Optional[str]:
    """"point", "line" or "polygon" of a ``QgsWkbTypes`` geometry type; None for any other."""
    return {QgsWkbTypes.PointGeometry: "point", QgsWkbTypes.LineGeometry: "line",
            QgsWkbTypes.PolygonGeometry: "polygon"}.get(geometry_type)


def computed_fields(kind: str) -> list:
    """The ``QgsField`` of each measure Monoplot adds to a map feature of ``kind``
    (:data:`~..outputs.vectors.COMPUTED_FIELDS`: ``sky_parts`` and ``silhouette`` integers, the others reals)."""
    from qgis.core import QgsField
    from qgis.PyQt.QtCore import QVariant

    from ..outputs.vectors import COMPUTED_FIELDS, INTEGER_FIELDS

    return [QgsField(n, QVariant.Type.Int if n in INTEGER_FIELDS else QVariant.Type.Double)
            for n in COMPUTED_FIELDS[kind]]


def geometry_parts(geometry: QgsGeometry) -> Tuple[str, List[List[np.ndarray]]]:
    """(kind, parts): kind "point" | "line" | "polygon"; each part is a list of (N, 3) vertex arrays (rings for
    polygons, one array for lines and points); Z is NaN when the geometry has none."""
    kind = geometry_kind(geometry.type())
    if kind is None:
        raise ValueError("unsupported geometry type")
    has_z = QgsWkbTypes.hasZ(geometry.wkbType())
    parts = []
    for part in geometry.constParts():
        if kind == "polygon":
            rings = [part.exteriorRing()] + [part.interiorRing(i) for i in range(part.numInteriorRings())]
        else:
            rings = [part]
        arrays = []
        for ring in rings:
            vertices = [(v.x(), v.y(), v.z() if has_z else np.nan) for v in ring.vertices()]
            arrays.append(np.array(vertices, dtype=float).reshape(-1, 3))
        parts.append(arrays)
    return kind, parts


def build_geometry(kind: str, parts: List[List[np.ndarray]], with_z: bool) -> Optional[QgsGeometry]:
    """A multi geometry from parts of (N, 2 or 3) arrays; None when nothing valid is left."""
    def line(a):
        xs, ys = a[:, 0].tolist(), a[:, 1].tolist()
        return QgsLineString(xs, ys, a[:, 2].tolist()) if with_z else QgsLineString(xs, ys)

    if kind == "point":
        multi = QgsMultiPoint()
        for rings in parts:
            for a in rings:
                for p in a:
                    multi.addGeometry(QgsPoint(p[0], p[1], p[2]) if with_z else QgsPoint(p[0], p[1]))
    elif kind == "line":
        multi = QgsMultiLineString()
        for rings in parts:
            for a in rings:
                if len(a) >= 2:
                    multi.addGeometry(line(a))
    else:
        multi = QgsMultiPolygon()
        for rings in parts:
            if len(rings) == 0 or len(rings[0]) < 3:
                continue
            polygon = QgsPolygon()
            exterior = rings[0] if np.allclose(rings[0][0], rings[0][-1], equal_nan=True) else \
                np.vstack([rings[0], rings[0][:1]])
            polygon.setExteriorRing(line(exterior))
            for hole in rings[1:]:
                if len(hole) >= 3:
                    closed = hole if np.allclose(hole[0], hole[-1], equal_nan=True) else np.vstack([hole, hole[:1]])
                    polygon.addInteriorRing(line(closed))
            multi.addGeometry(polygon)
    if multi.numGeometries() == 0:
        return None
    return QgsGeometry(multi)


def outline_parts(geom: QgsGeometry, cell: float) -> List[np.ndarray]:
    """(N, 2) coordinate arrays of the lines / rings of a geometry; points as a tiny cross of one cell."""
    parts = []
    if geom.type() == QgsWkbTypes.GeometryType.PointGeometry:
        for p in geom.vertices():
            parts.append(np.array([[p.x() - cell, p.y()], [p.x() + cell, p.y()]]))
            parts.append(np.array([[p.x(), p.y() - cell], [p.x(), p.y() + cell]]))
        return parts
    if geom.type() == QgsWkbTypes.GeometryType.PolygonGeometry:
        for polygon in (geom.asMultiPolygon() if geom.isMultipart() else [geom.asPolygon()]):
            parts.extend(np.array([(p.x(), p.y()) for p in ring]) for ring in polygon)
        return parts
    for line in (geom.asMultiPolyline() if geom.isMultipart() else [geom.asPolyline()]):
        parts.append(np.array([(p.x(), p.y()) for p in line]))
    return parts
