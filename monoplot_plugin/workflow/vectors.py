"""Points between the photo and the map, for the vector products (Processing's photo <-> map algorithms and the
control points of a fit). Shapes: ``uv`` (N, 2) pixels, ``xyz`` (N, 3) map coordinates in the DEM's CRS.
"""

from __future__ import annotations

from typing import Callable, Optional

import numpy as np

from ..core.camera import Camera
from ..core.lookup import visibility_of_points
from ..core.transforms import photo_points_to_map
from .xyz import xyz_raster

__all__ = ["fill_missing_z", "photo_to_map", "visibility"]


def fill_missing_z(xyz: np.ndarray, dem) -> np.ndarray:
    """A copy of (N, 3) map points whose NaN heights are the DEM's there (bilinear; NaN outside the DEM).

    >>> from monoplot_plugin.core.dem import Dem
    >>> dem = Dem.from_array(np.full((4, 4), 100.0), (0, 10, 0, 40, 0, -10))
    >>> fill_missing_z(np.array([[15.0, 15.0, np.nan], [15.0, 15.0, 7.0]]), dem)[:, 2].tolist()
    [100.0, 7.0]
    """
    out = np.array(xyz, dtype=float).reshape(-1, 3)
    missing = ~np.isfinite(out[:, 2])
    if missing.any():
        out[missing, 2] = np.asarray(dem.sample(out[missing, 0], out[missing, 1]), dtype=float)
    return out


def photo_to_map(camera: Camera, dem, uv: np.ndarray, area: Optional[np.ndarray] = None) -> np.ndarray:
    """(N, 3) ground points seen at (N, 2) pixel positions: the exact first hit of each position's own ray on the
    DEM mesh (core :func:`photo_points_to_map`, as the dock does), not the centre of its pixel; NaN for sky,
    outside the photo and outside its picture ``area`` (a scanned print's picture, :func:`~.products.in_picture`)."""
    from .products import in_picture

    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    out = np.full((len(uv), 3), np.nan)
    with np.errstate(invalid="ignore"):
        inside = (np.isfinite(uv).all(axis=1) & (uv[:, 0] >= 0) & (uv[:, 0] <= camera.width) & (uv[:, 1] >= 0)
                  & (uv[:, 1] <= camera.height)) & in_picture(uv, area)
    if inside.any():
        out[inside] = photo_points_to_map(uv[inside], camera, dem)[0]
    return out


def visibility(camera: Camera, dem) -> Callable[[np.ndarray], np.ndarray]:
    """A function ``(N, 3) map points -> (N,) bool``: in the image and not hidden by terrain (depth test against
    the XYZ raster, core's :func:`visibility_of_points`)."""
    xyz = xyz_raster(camera, dem)

    def visible(points: np.ndarray) -> np.ndarray:
        return visibility_of_points(camera, np.asarray(points, dtype=float).reshape(-1, 3), xyz)[1]

    return visible
