"""The points an automatic registration gives its final fit: Monoplot's own photo and DEM suggestions that the aligned
camera brings together (:func:`consistent_points`), and points along the skyline the alignment matched
(:func:`skyline_points`).

Shapes: photo points (N, 2) full-size pixels; DEM points (N, 3) map coordinates (metres).
"""

from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ..camera import Camera
from .dem_edges import coarse_dem, dem_edges
from .photo_edges import PhotoEdges

__all__ = ["consistent_points", "skyline_points", "pairing_gate_px", "FIT_DEM_CELLS"]

#: Most DEM cells used by the final DEM suggestions (finer DEMs are averaged by blocks).
FIT_DEM_CELLS = 6_000_000


def consistent_points(image, dem, camera: Camera, is_canceled=None, poll=None, cache: Optional[dict] = None):
    """Photo and DEM suggestions, kept when the camera brings a DEM suggestion within a few pixels of a photo
    suggestion (each photo point's nearest, mutual). ``cache``: a dict kept between calls on the same photo and DEM
    (the photo's suggestions and the reduced DEM do not depend on the camera)."""
    from scipy.spatial import cKDTree

    from ..suggest import suggest_dem_points

    poll = poll or (lambda is_canceled: None)
    cache = {} if cache is None else cache
    if "photo_uv" not in cache:
        cache["photo_uv"] = _photo_suggestions(image)
    q = cache["photo_uv"]
    poll(is_canceled)
    if "fit_dem" not in cache:
        cache["fit_dem"] = coarse_dem(dem, FIT_DEM_CELLS, is_canceled)
    poll(is_canceled)
    demsug = suggest_dem_points(cache["fit_dem"], camera, max_points=1500)
    poll(is_canceled)
    uv = camera.project(demsug.xyz)
    ok = np.isfinite(uv).all(axis=1) & camera.in_image(uv)
    if len(q) == 0 or not ok.any():
        return q[:0], demsug.xyz[:0]
    gate = pairing_gate_px(camera)
    idx_dem = np.nonzero(ok)[0]
    d_q, j = cKDTree(uv[idx_dem]).query(q, distance_upper_bound=gate)
    d_p, i = cKDTree(q).query(uv[idx_dem], distance_upper_bound=gate)
    keep_q = np.isfinite(d_q)
    keep_q[keep_q] &= i[j[keep_q]] == np.nonzero(keep_q)[0]
    jj = np.unique(j[keep_q])
    return q[keep_q], demsug.xyz[idx_dem[jj]]


def _photo_suggestions(image) -> np.ndarray:
    """(N, 2) full-size pixels of Monoplot's photo suggestions (found on a copy at most 2048 px on its long side)."""
    import cv2

    from ..suggest import suggest_photo_points

    h, w = image.shape[:2]
    scale = min(1.0, 2048.0 / max(h, w))
    small = cv2.resize(image, (round(w * scale), round(h * scale)), interpolation=cv2.INTER_AREA) \
        if scale < 1.0 else image
    return suggest_photo_points(small, max_points=1500).uv / scale


def pairing_gate_px(camera: Camera) -> float:
    """Pixels within which the aligned camera brings a DEM point to a photo point for the two to be kept."""
    return max(3.0, 0.012 * math.hypot(camera.width, camera.height))


def skyline_points(camera: Camera, photo: PhotoEdges, dem, most: int = 120):
    """((K, 2) photo pixels, (K, 3) map points) along the skyline: photo skyline points at evenly spaced clear
    columns, each with the DEM silhouette point the aligned ``camera`` projects nearest to it (within
    :func:`pairing_gate_px`, one photo point per DEM point).

    The suggestions are corners and peaks; these tie the final fit to the skyline the alignment matched, the
    photo's most precise edge (sub-pixel, :mod:`.photo_edges`), so that the fit refines the aligned camera instead
    of trading the skyline's agreement for the suggestions' pairing noise. The fit pairs them again by itself
    (unpaired), so a point the camera moves off the skyline is not forced."""
    from scipy.spatial import cKDTree

    cols = np.nonzero(photo.sky_valid)[0]
    empty = (np.zeros((0, 2)), np.zeros((0, 3)))
    if not photo.usable or not len(cols):
        return empty
    cols = cols[np.unique(np.linspace(0, len(cols) - 1, min(most, len(cols))).astype(np.int64))]
    uv = np.stack([(cols + 0.5) / photo.scale, photo.sky_row[cols] / photo.scale], axis=1)
    sky = dem_edges(camera, dem, 0.5, camera.focal_px * photo.scale).sky
    proj = camera.project(sky) if len(sky) else np.zeros((0, 2))
    ok = np.isfinite(proj).all(axis=1) & camera.in_image(proj) if len(sky) else np.zeros(0, bool)
    if not ok.any():
        return empty
    d, j = cKDTree(proj[ok]).query(uv, distance_upper_bound=pairing_gate_px(camera))
    keep = np.isfinite(d)
    j, first = np.unique(j[keep], return_index=True)
    return uv[np.nonzero(keep)[0][first]], sky[ok][j]
