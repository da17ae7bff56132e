"""The DEM's side of the automatic registration: its skyline and occluding contours seen from a camera, as 3-D
points, so that camera hypotheses score them by projecting points instead of rendering again.

One z-buffer (:func:`~monoplot_plugin.core.xyz.compute_xyz_full`) from a *widened* camera (the hypothesis's
rotation and focal length, a picture enlarged to cover the angles and fields of view still to search) gives every
terrain point next to sky (the skyline) and the near side of every depth step (occluding contours,
:meth:`~monoplot_plugin.core.render.RenderedDem.edges`). Each edge point comes with a second point one pixel along
the edge, so a hypothesis projects the edge's direction too (the oriented chamfer). Points on the DEM's border or
next to voids are dropped: there the terrain ends, not the view.

For a DEM much finer than the camera needs, :func:`coarse_dem` averages blocks of cells first.

>>> from ..synthetic import synthetic_terrain
>>> from ..camera import Camera
>>> dem = synthetic_terrain((120, 120), cell=100.0, seed=3)
>>> x, y = dem.cell_to_map(60, 115)
>>> cam = Camera((x, y, float(dem.sample(x, y)) + 300), 0.0, 2.0, 0.0, 60.0, (160, 120))
>>> de = dem_edges(cam, dem, margin_deg=5.0)
>>> len(de.sky) > 50, de.sky.shape[1], de.camera.fov > 60.0
(True, 3, True)
>>> coarse_dem(dem, 3600).shape
(60, 60)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..camera import Camera, fov_from_focal
from ..dem import Dem
from ..grid import block_means

__all__ = ["DemEdges", "dem_edges", "coarse_dem", "widened_camera", "dem_in_view"]


@dataclass
class DemEdges:
    """Edge points of the terrain seen from ``camera`` (the widened render camera).

    Attributes:
        sky, sky_next: (S, 3) skyline points (terrain with sky right above) and a point one pixel along the edge.
        contour, contour_next: (K, 3) occluding-contour points (near side of a depth step) and their neighbours.
        camera: the widened camera that rendered them.
        border: (B, 3) skyline points left out of ``sky`` because the DEM ends there (:meth:`~..dem.Dem.near_edge`):
            where the DEM's edge stands for the skyline, the photo's skyline cannot be compared with it.
    """

    sky: np.ndarray
    sky_next: np.ndarray
    contour: np.ndarray
    contour_next: np.ndarray
    camera: Camera
    border: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))


def coarse_dem(dem: Dem, max_cells: int, is_canceled=None) -> Dem:
    """``dem`` averaged over square blocks of cells so that it has at most about ``max_cells`` cells (itself when
    it already has). Voids stay voids where a whole block is void. Works in bands of rows, polling
    ``is_canceled`` (raising :class:`~monoplot_plugin.core.fit.FitCanceled`) between them."""
    rows, cols = dem.shape
    factor = int(math.ceil(math.sqrt(rows * cols / float(max_cells))))
    if factor <= 1:
        return dem

    def poll() -> None:
        if is_canceled is not None and is_canceled():
            from ..fit import FitCanceled

            raise FitCanceled()

    elev = block_means(dem.elevation, factor, np.float32, poll)
    g = dem.geotransform
    gt = (g[0], g[1] * factor, g[2] * factor, g[3], g[4] * factor, g[5] * factor)
    return Dem.from_array(elev, gt, dem.crs_wkt)


def widened_camera(camera: Camera, focal_px: float, margin_deg: float, max_fov: float = 140.0) -> Camera:
    """``camera``'s rotation with focal length ``focal_px`` and a picture ``margin_deg`` wider on every side."""
    vfov = 2.0 * math.degrees(math.atan(camera.height / 2.0 / camera.focal_px))
    fov = min(max_fov, camera.fov + 2.0 * margin_deg)
    vfov = min(max_fov, vfov + 2.0 * margin_deg)
    width = max(16, int(round(2.0 * focal_px * math.tan(math.radians(fov) / 2.0))))
    height = max(16, int(round(2.0 * focal_px * math.tan(math.radians(vfov) / 2.0))))
    return Camera(camera.position, camera.heading, camera.pitch, camera.roll, fov_from_focal(focal_px, width),
                  (width, height), crs_wkt=camera.crs_wkt)


def dem_in_view(camera: Camera, dem: Dem, margin_deg: float, width: int = 160) -> float:
    """Share (0-1) of ``camera``'s picture, widened by ``margin_deg`` on every side, that sees the DEM, at
    ``width`` pixels; from at least 2 m above the terrain (a rough camera under the DEM, a wrong altitude, would see
    its inside).

    >>> from ..synthetic import synthetic_terrain
    >>> dem = synthetic_terrain((120, 120), cell=100.0, seed=3)
    >>> x, y = dem.cell_to_map(60, 115)
    >>> cam = Camera((x, y, float(dem.sample(x, y)) + 300), 0.0, 2.0, 0.0, 60.0, (160, 120))
    >>> dem_in_view(cam, dem, 5.0) > 0.2, dem_in_view(cam.with_parameters(pitch=70.0), dem, 5.0)
    (True, 0.0)
    """
    from ..xyz import compute_xyz

    ground = float(dem.sample(camera.position[0], camera.position[1]))
    if math.isfinite(ground) and camera.position[2] < ground + 2.0:
        camera = camera.with_parameters(z=ground + 2.0)
    wide = widened_camera(camera, camera.focal_px, margin_deg)
    wide = wide.scaled(min(1.0, width / wide.width))
    return float(np.isfinite(compute_xyz(wide, dem)[..., 2]).mean())


def _thin(idx: np.ndarray, most: int) -> np.ndarray:
    return idx if len(idx) <= most else idx[np.linspace(0, len(idx) - 1, most).astype(np.int64)]


def dem_edges(camera: Camera, dem: Dem, margin_deg: float, focal_px: float = None, max_points: int = 4000,
              max_range: float = None) -> DemEdges:
    """Skyline and occluding-contour points of ``dem`` seen from ``camera``'s position, over its view widened by
    ``margin_deg`` on each side, rendered at ``focal_px`` (default: the camera's own)."""
    import cv2

    from ..render import RenderedDem
    from ..xyz import compute_xyz_full

    cam = widened_camera(camera, camera.focal_px if focal_px is None else focal_px, margin_deg)
    res = compute_xyz_full(cam, dem, max_range=max_range, visibility=False)
    hit = res.hit
    depth = np.where(hit, res.distance, np.nan).astype(np.float64)
    edges = RenderedDem(shade=depth, depth=depth, result=res).edges()
    above = np.vstack([np.zeros((1, hit.shape[1]), dtype=bool), hit[:-1]])
    sky = hit & ~above
    sky[0] = False  # the render's top row: terrain may continue above it
    contour = edges & ~sky
    # Direction along the edge: perpendicular to the gradient of log depth (sky = far).
    logd = np.log(np.where(hit, depth, np.nanmax(depth) * 4.0 if hit.any() else 1.0)).astype(np.float32)
    logd = cv2.GaussianBlur(logd, (0, 0), 1.0)
    gx = cv2.Sobel(logd, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(logd, cv2.CV_32F, 0, 1, ksize=3)
    out = []
    border = np.zeros((0, 3))
    for mask, most in ((sky, max_points), (contour, max_points)):
        rows, cols = np.nonzero(mask)
        keep = _thin(np.arange(len(rows)), most)
        rows, cols = rows[keep], cols[keep]
        xyz = res.xyz[rows, cols]
        ok = np.isfinite(xyz).all(axis=1)
        at_edge = np.zeros_like(ok)
        at_edge[ok] = dem.near_edge(xyz[ok])
        if mask is sky and at_edge.any():  # lifted to the silhouette as the skyline points are (below)
            border = _lifted(cam, rows[at_edge], cols[at_edge], xyz[at_edge])
        ok &= ~at_edge
        rows, cols, xyz = rows[ok], cols[ok], xyz[ok]
        tx, ty = -gy[rows, cols], gx[rows, cols]
        norm = np.hypot(tx, ty)
        tx = np.where(norm > 1e-9, tx / np.maximum(norm, 1e-12), 1.0)
        ty = np.where(norm > 1e-9, ty / np.maximum(norm, 1e-12), 0.0)
        origin, dirs = cam.pixel_to_world_ray(np.stack([cols + 0.5 + tx, rows + 0.5 + ty], axis=1))
        dist = np.linalg.norm(xyz - origin, axis=1)
        nxt = origin + dirs * dist[:, None]
        if mask is sky:
            # The terrain point of the top terrain pixel lies under the silhouette, which crosses that pixel
            # anywhere in its upper half or the sky pixel's lower half: on average at the pixel's top edge. The
            # point at the same distance on the ray through that edge projects where the silhouette lies (the
            # photo's skyline is the sub-pixel boundary, :mod:`.photo_edges`); its neighbour likewise.
            lifted = _lifted(cam, rows, cols, xyz)
            xyz, nxt = lifted, nxt + (lifted - xyz)
        out.append((xyz, nxt))
    (s, sn), (c, cn) = out
    return DemEdges(s, sn, c, cn, cam, border)


def _lifted(cam: Camera, rows: np.ndarray, cols: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    """(N, 3) the terrain points ``xyz`` of the top terrain pixels (``rows``, ``cols``) moved, at the same distance
    from the camera, onto the ray through their pixel's top edge: where the silhouette lies (see :func:`dem_edges`)."""
    origin, up = cam.pixel_to_world_ray(np.stack([cols + 0.5, rows + 0.0], axis=1))
    return origin + up * np.linalg.norm(xyz - origin, axis=1)[:, None]
