"""Processing's photo <-> map geometry: features moved between photo pixel space and the map (the vertex arrays
of :mod:`..adapters.photo_space`)."""

from __future__ import annotations

from typing import Optional, Tuple

import numpy as np
from qgis.core import QgsGeometry, QgsWkbTypes

from ..adapters.photo_space import PHOTO_Y_SIGN
from ..adapters.photo_space import build_geometry as _build
from ..adapters.photo_space import geometry_parts as _parts
from ..core.transforms import ground_pieces, silhouette_crossings, true_runs
from ..adapters.photo_space import computed_fields, geometry_kind
from ..outputs.vectors import MapFeature
from ..workflow.features import feature_errors, ground_per_pixel, surface_factor
from . import pipeline

#: Relative range jump between consecutive line vertices that cuts the line (a silhouette).
SILHOUETTE_JUMP = 0.1


def photo_to_map_geometry(geometry: QgsGeometry, camera, dem, step: float, y_sign: float = PHOTO_Y_SIGN,
                          pixel_rmse: Optional[float] = None,
                          area=None) -> Tuple[Optional[QgsGeometry], int, dict]:
    """A photo-space geometry (x = u, y = y_sign * v) -> map geometry with Z in the DEM's CRS.

    Lines and rings are densified every ``step`` pixels first; every vertex is intersected exactly with the DEM.
    Lines break where vertices see the sky and at silhouettes; polygon rings drop the vertices over the sky (the
    ring closes across the gap). Returns (geometry or None, number of vertices dropped, the computed fields the
    dock's drawings get: :data:`~..outputs.vectors.COMPUTED_FIELDS`, by :meth:`MapFeature.measures`; ``xy_error_m``
    and ``z_error_m`` with ``pixel_rmse``, the photo's pixel error). ``area``: a scanned print's picture ((H, W)
    bool): vertices on its paper or caption are dropped as sky is.
    """
    if geometry is None or geometry.isNull():
        return None, 0, {}
    if step > 0 and geometry.type() != QgsWkbTypes.PointGeometry:
        geometry = geometry.densifyByDistance(step)
    kind, parts = _parts(geometry)
    out_parts, dropped, sky_parts, ground_uv = [], 0, 0, []
    for rings in parts:
        out_rings = []
        for a in rings:
            uv = np.column_stack([a[:, 0], y_sign * a[:, 1]])
            xyz = pipeline.photo_to_map(camera, dem, uv, area)
            ok = np.isfinite(xyz).all(axis=1)
            ground_uv.append(uv[ok])
            dropped += int((~ok).sum())
            sky_parts += len(true_runs(~ok))
            if kind == "line":
                # cut over the sky and at silhouettes, as the dock's digitising does
                out_rings.extend(xyz[p:q] for p, q in ground_pieces(xyz, ok, camera.position, SILHOUETTE_JUMP)[0])
            else:
                out_rings.append(xyz[ok])
        if kind == "line":
            out_parts.extend([[r] for r in out_rings])
        else:
            out_parts.append(out_rings)
    built = _build(kind, out_parts, with_z=True)
    if built is None:
        return None, dropped, {}
    # measured on what was built (rings of fewer than 3 ground vertices and 1-vertex pieces are not); holes are
    # not subtracted from the area (drawings on the photo have none)
    built_kind, built_parts = _parts(built)
    pieces = [rings[0] for rings in built_parts]
    errors = feature_errors(np.vstack(ground_uv), camera, dem, pixel_rmse)
    median, largest = ground_per_pixel(np.vstack(ground_uv), camera, dem)
    crossings = sum(silhouette_crossings(p, camera.position, SILHOUETTE_JUMP) for p in pieces) \
        if built_kind == "polygon" else 0
    return built, dropped, MapFeature(built_kind, pieces, sky_parts=sky_parts, **errors,
                                      silhouettes=crossings, m_per_px=median, m_px_max=largest,
                                      surface_factor=_surface_factor(pieces, dem) if built_kind == "polygon"
                                      else None).measures()


def _surface_factor(rings, dem) -> Optional[float]:
    """The rings' :func:`~..workflow.features.surface_factor`, weighted by their map areas (None when unknown)."""
    from ..outputs.vectors import polygon_area

    weighted = [(polygon_area(r[:, :2]), surface_factor(r[:, :2], dem)) for r in rings]
    weighted = [(a, f) for a, f in weighted if f is not None and a > 0]
    total = sum(a for a, _ in weighted)
    return sum(a * f for a, f in weighted) / total if total > 0 else None


def map_to_photo_geometry(geometry: QgsGeometry, camera, dem, step: float, visible=None, y_sign: float = PHOTO_Y_SIGN,
                          drop_hidden: bool = True) -> Tuple[Optional[QgsGeometry], float]:
    """A map geometry (DEM CRS) -> (photo-space geometry (x = u, y = y_sign * v), the share of its vertices the
    camera sees).

    Z comes from the geometry, else from the DEM. ``visible``: optional callable ``(xyz (N, 3)) -> (N,) bool``
    (:func:`pipeline.visibility`); with ``drop_hidden`` lines are split where vertices are hidden, points dropped;
    polygons are kept when at least one vertex is visible (a partly hidden polygon is drawn whole: the share says
    how much of its outline is seen). The share is NaN without ``visible``.
    """
    if geometry is None or geometry.isNull():
        return None, float("nan")
    if step > 0 and geometry.type() != QgsWkbTypes.PointGeometry:
        geometry = geometry.densifyByDistance(step)
    kind, parts = _parts(geometry)
    out_parts = []
    seen_count, total = 0, 0
    for rings in parts:
        out_rings = []
        for a in rings:
            xyz = pipeline.fill_missing_z(a, dem)
            uv = camera.project(xyz)
            finite = np.isfinite(uv).all(axis=1)
            seen = finite & visible(xyz) if visible is not None else finite
            seen_count, total = seen_count + int(seen.sum()), total + len(seen)
            ok = seen if drop_hidden else finite
            photo = np.column_stack([uv[:, 0], y_sign * uv[:, 1], np.zeros(len(uv))])
            if kind == "polygon":
                out_rings.append(photo[finite])
            elif kind == "line" and visible is not None and drop_hidden:
                out_rings.extend(photo[p:q] for p, q in true_runs(ok))
            else:
                out_rings.append(photo[ok])
        if kind == "line":
            out_parts.extend([[r] for r in out_rings])
        else:
            out_parts.append(out_rings)
    share = seen_count / total if visible is not None and total else float("nan")
    if kind == "polygon" and drop_hidden and visible is not None and seen_count == 0:
        return None, share
    return _build(kind, out_parts, with_z=False), share


def measured_fields(fields, geometry_type) -> Tuple[object, list]:
    """(the input's ``fields`` and the computed fields of its geometry kind, the names added): a field the input
    already has keeps the input's value (no duplicate name)."""
    from qgis.core import QgsFields

    out = QgsFields(fields)
    added = []
    for field in computed_fields(geometry_kind(geometry_type) or "point"):
        if out.indexFromName(field.name()) < 0:
            out.append(field)
            added.append(field.name())
    return out, added
