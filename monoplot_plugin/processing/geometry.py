"""QgsGeometry <-> numpy vertex arrays, for moving features between photo pixel space and the map."""

from __future__ import annotations

from typing import List, Optional, Tuple

import numpy as np
from qgis.core import (
    QgsGeometry,
    QgsLineString,
    QgsMultiLineString,
    QgsMultiPoint,
    QgsMultiPolygon,
    QgsPoint,
    QgsPolygon,
    QgsWkbTypes,
)

from ..core.transforms import ground_pieces, true_runs
from . import pipeline

#: Relative range jump between consecutive line vertices that cuts the line (a silhouette).
SILHOUETTE_JUMP = 0.1


def _parts(geometry: QgsGeometry) -> Tuple[str, List[List[np.ndarray]]]:
    """(kind, parts): kind "point" | "line" | "polygon"; each part is a list of (N, 3) vertex arrays (rings for
    polygons, one array for lines and points); Z is NaN when the geometry has none."""
    kind = {QgsWkbTypes.PointGeometry: "point", QgsWkbTypes.LineGeometry: "line",
            QgsWkbTypes.PolygonGeometry: "polygon"}.get(geometry.type())
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


def _build(kind: str, parts: List[List[np.ndarray]], with_z: bool) -> Optional[QgsGeometry]:
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


def photo_to_map_geometry(geometry: QgsGeometry, camera, dem, step: float,
                          y_sign: float = -1.0) -> Tuple[Optional[QgsGeometry], int]:
    """A photo-space geometry (x = u, y = y_sign * v) -> map geometry with Z in the DEM's CRS.

    Lines and rings are densified every ``step`` pixels first; every vertex is intersected exactly with the DEM.
    Lines break where vertices see the sky and at silhouettes; polygon rings drop the vertices over the sky (the
    ring closes across the gap). Returns (geometry or None, number of vertices dropped).
    """
    if geometry is None or geometry.isNull():
        return None, 0
    if step > 0 and geometry.type() != QgsWkbTypes.PointGeometry:
        geometry = geometry.densifyByDistance(step)
    kind, parts = _parts(geometry)
    out_parts, dropped = [], 0
    for rings in parts:
        out_rings = []
        for a in rings:
            uv = np.column_stack([a[:, 0], y_sign * a[:, 1]])
            xyz = pipeline.photo_to_map(camera, dem, uv)
            ok = np.isfinite(xyz).all(axis=1)
            dropped += int((~ok).sum())
            if kind == "line":
                # cut over the sky and at silhouettes, as the dock's digitising does
                out_rings.extend(xyz[p:q] for p, q in ground_pieces(xyz, ok, camera.position, SILHOUETTE_JUMP)[0])
            else:
                out_rings.append(xyz[ok])
        if kind == "line":
            out_parts.extend([[r] for r in out_rings])
        else:
            out_parts.append(out_rings)
    return _build(kind, out_parts, with_z=True), dropped


def map_to_photo_geometry(geometry: QgsGeometry, camera, dem, step: float, visible=None,
                          y_sign: float = -1.0) -> Optional[QgsGeometry]:
    """A map geometry (DEM CRS) -> photo-space geometry (x = u, y = y_sign * v).

    Z comes from the geometry, else from the DEM. ``visible``: optional callable ``(xyz (N, 3)) -> (N,) bool``
    (:func:`pipeline.visibility`); lines are split where vertices are hidden, points dropped; polygons are kept
    when at least one vertex is visible (a partly hidden polygon is drawn whole).
    """
    if geometry is None or geometry.isNull():
        return None
    if step > 0 and geometry.type() != QgsWkbTypes.PointGeometry:
        geometry = geometry.densifyByDistance(step)
    kind, parts = _parts(geometry)
    out_parts = []
    any_visible = False
    for rings in parts:
        out_rings = []
        for a in rings:
            xyz = pipeline.fill_missing_z(a, dem)
            uv = camera.project(xyz)
            ok = np.isfinite(uv).all(axis=1)
            if visible is not None:
                ok &= visible(xyz)
            any_visible |= bool(ok.any())
            photo = np.column_stack([uv[:, 0], y_sign * uv[:, 1], np.zeros(len(uv))])
            if kind == "polygon":
                out_rings.append(photo[np.isfinite(uv).all(axis=1)])
            elif kind == "line" and visible is not None:
                out_rings.extend(photo[p:q] for p, q in true_runs(ok))
            else:
                out_rings.append(photo[ok])
        if kind == "line":
            out_parts.extend([[r] for r in out_rings])
        else:
            out_parts.append(out_rings)
    if kind == "polygon" and not any_visible:
        return None
    return _build(kind, out_parts, with_z=False)
