"""The DEM seen from the camera: a photo-sized shaded relief and depth, for overlays on the photo.

>>> import numpy as np
>>> from .camera import Camera
>>> from .dem import Dem
>>> dem = Dem.from_array(np.zeros((40, 40)), (0, 10, 0, 400, 0, -10))
>>> view = render_dem(Camera((200, -50, 100), 0, -20, 0, 60, (32, 24)), dem)
>>> view.shade.shape, view.depth.shape, view.rgba().shape
((24, 32), (24, 32), (24, 32, 4))
>>> bool(np.isnan(view.depth[0, 0])), bool(np.isfinite(view.depth[-1, 16]))   # sky at the top, ground below
(True, True)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from .camera import Camera
from .dem import Dem
from .grid import bilinear, lambert
from .xyz import XyzResult, compute_xyz_full

__all__ = ["RenderedDem", "render_dem", "shade_points"]


@dataclass
class RenderedDem:
    """A rendering of the terrain from a camera.

    Attributes:
        shade: (H, W) float64 Lambert shading 0..1 of the terrain each pixel sees; NaN for sky.
        depth: (H, W) float64 distance in metres from the camera centre to that terrain point; NaN for sky.
        result: the :class:`~monoplot_plugin.core.xyz.XyzResult` it was made from (xyz, visibility...).
    """

    shade: np.ndarray
    depth: np.ndarray
    result: XyzResult

    def edges(self, jump: float = 0.05, contrast: float = 3.0) -> np.ndarray:
        """(H, W) bool: silhouettes and horizon lines: terrain next to sky, or a depth step between neighbouring
        pixels larger than ``jump`` (relative) and ``contrast`` times the steps beside it (so that the steady depth
        growth of ground seen at a grazing angle is not taken for an edge). The nearer pixel of a step is marked."""
        d = self.depth
        hit = np.isfinite(d)
        out = np.zeros(d.shape, dtype=bool)
        for axis in (0, 1):
            dd = np.moveaxis(d, axis, 0)
            hh = np.moveaxis(hit, axis, 0)
            oo = np.moveaxis(out, axis, 0)
            diff = np.abs(dd[1:] - dd[:-1])  # step between k and k+1
            near = np.fmin(dd[1:], dd[:-1])
            mag = np.nan_to_num(diff, nan=0.0)
            side = np.zeros_like(mag)
            side[1:] = mag[:-1]
            side[:-1] = np.maximum(side[:-1], mag[1:])
            with np.errstate(invalid="ignore"):
                step = (hh[1:] != hh[:-1]) | ((diff > jump * near) & (diff > contrast * side))
                first_nearer = np.nan_to_num(dd[:-1], nan=np.inf) <= np.nan_to_num(dd[1:], nan=np.inf)
            oo[:-1] |= step & first_nearer
            oo[1:] |= step & ~first_nearer
        return out & hit

    def rgba(self, colour: Sequence[int] = (255, 255, 255), opacity: float = 0.6, edges: bool = True,
             edge_colour: Sequence[int] = (255, 40, 40)) -> np.ndarray:
        """(H, W, 4) uint8 overlay: grey-scale shading (scaled by ``colour``) at ``opacity`` where terrain is seen,
        transparent sky, and optionally opaque silhouette lines in ``edge_colour``."""
        H, W = self.shade.shape
        out = np.zeros((H, W, 4), dtype=np.uint8)
        hit = np.isfinite(self.shade)
        s = 0.25 + 0.75 * np.nan_to_num(self.shade)[..., None]  # some ambient light: shadows stay readable
        out[..., :3] = np.clip(np.round(s * np.asarray(colour, dtype=np.float64)), 0, 255).astype(np.uint8)
        out[..., 3] = np.where(hit, int(round(255 * opacity)), 0)
        if edges:
            e = self.edges()
            out[e, :3] = np.asarray(edge_colour, dtype=np.uint8)
            out[e, 3] = 255
        return out


def shade_points(dem: Dem, xyz: np.ndarray, azimuth: float = 315.0, altitude: float = 45.0) -> np.ndarray:
    """(N,) Lambert shading 0..1 at (N, 3) map points, from the DEM's slope interpolated bilinearly."""
    dzdx, dzdy = dem.gradient()
    col, row = dem.map_to_cell(xyz[:, 0], xyz[:, 1])
    fr = np.asarray(row) - 0.5
    fc = np.asarray(col) - 0.5
    gx, gy = bilinear(np.nan_to_num(dzdx), fr, fc), bilinear(np.nan_to_num(dzdy), fr, fc)
    return lambert(gx, gy, azimuth, altitude)


def render_dem(cam: Camera, dem: Dem, azimuth: float = 315.0, altitude: float = 45.0,
               max_range: Optional[float] = None, result: Optional[XyzResult] = None) -> RenderedDem:
    """Shaded relief and depth of ``dem`` as the camera sees it, photo-sized (H, W).

    Args:
        cam, dem: camera (in the DEM's CRS) and terrain (a Dem, or a large DEM file's
            :class:`~monoplot_plugin.core.dem_window.DemSource`: what the camera sees of it, see ``as_dem``).
        azimuth, altitude: sun direction in degrees (clockwise from grid north; above the horizon).
        max_range: ignore terrain farther than this (metres).
        result: a :func:`~monoplot_plugin.core.xyz.compute_xyz_full` result to reuse (skips the z-buffer).
    """
    if result is None:
        from .dem_window import as_dem

        dem = as_dem(dem, cam, max_range)
    res = result if result is not None else compute_xyz_full(cam, dem, max_range=max_range, visibility=False)
    H, W = cam.height, cam.width
    shade = np.full((H, W), np.nan)
    hit = res.hit
    if hit.any():
        shade[hit] = shade_points(res.dem, res.xyz[hit], azimuth, altitude)
    depth = res.distance.astype(np.float64)
    return RenderedDem(shade=shade, depth=depth, result=res)
