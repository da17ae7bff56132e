"""The automatic registration drawn over the photo: the DEM's skyline and occluding contours seen from the camera
found (magenta) and the photo's own detected skyline (cyan), on an RGBA overlay of the photo (any size: the lines
are scaled to it), so the person sees at a glance where the silhouettes agree and where they do not.

>>> from ..synthetic import synthetic_terrain
>>> from ..camera import Camera
>>> dem = synthetic_terrain((80, 80), cell=100.0, seed=3)
>>> x, y = dem.cell_to_map(40, 78)
>>> cam = Camera((x, y, float(dem.sample(x, y)) + 300), 0.0, 2.0, 0.0, 60.0, (160, 120))
>>> rgba = np.zeros((60, 80, 4), np.uint8)
>>> sky = np.stack([np.arange(160) + 0.5, np.full(160, 40.0)], axis=1)
>>> out = draw_alignment(rgba, cam, sky, dem)
>>> bool((out[..., :3] == SILHOUETTE).all(axis=2).any()), bool((out[20, :, :3] == SKYLINE).all(axis=1).any())
(True, True)
"""

from __future__ import annotations

import numpy as np

from ..camera import Camera
from .dem_edges import coarse_dem, dem_edges

__all__ = ["draw_alignment", "SILHOUETTE", "SKYLINE"]

#: RGB of the DEM's silhouettes and of the photo's skyline.
SILHOUETTE = (255, 0, 255)
SKYLINE = (0, 230, 255)


def draw_alignment(rgba: np.ndarray, camera: Camera, skyline: np.ndarray, dem, max_cells: int = 2_000_000
                   ) -> np.ndarray:
    """A copy of the (h, w, 4) uint8 ``rgba`` overlay (the photo's frame at any scale) with the DEM's skyline and
    occluding contours seen from ``camera`` and the photo's ``skyline`` ((W, 2) u, v in full-size pixels, NaN rows
    where none) drawn opaque."""
    import cv2

    out = np.ascontiguousarray(rgba, dtype=np.uint8).copy()
    h, w = out.shape[:2]
    s = w / float(camera.width)
    small = camera.scaled(s)
    edges = dem_edges(small, coarse_dem(dem, max_cells), 0.0, max_points=200_000)
    dots = np.zeros((h, w), np.uint8)
    for pts in (edges.sky, edges.contour):
        if len(pts):
            uv = small.project(pts)
            ok = np.isfinite(uv).all(axis=1)
            c, r = np.floor(uv[ok, 0]).astype(np.int64), np.floor(uv[ok, 1]).astype(np.int64)
            inside = (c >= 0) & (c < w) & (r >= 0) & (r < h)
            dots[r[inside], c[inside]] = 1
    width = max(1, int(round(w / 400.0)))  # lines that stay visible when the dock shows the photo reduced
    if width > 1:
        dots = cv2.dilate(dots, np.ones((width, width), np.uint8))
    out[dots > 0] = (*SILHOUETTE, 255)
    sky = np.asarray(skyline, dtype=np.float64).reshape(-1, 2) * s
    valid = np.isfinite(sky).all(axis=1)
    lines = np.zeros((h, w), np.uint8)
    # Polylines over the runs of columns with a skyline (a gap breaks the line).
    breaks = np.flatnonzero(np.diff(valid.astype(np.int8)) != 0) + 1
    for run in np.split(np.arange(len(sky)), breaks):
        if len(run) >= 2 and valid[run[0]]:
            cv2.polylines(lines, [np.round(sky[run]).astype(np.int32)], False, 1, width)
    out[lines > 0] = (*SKYLINE, 255)
    return out
