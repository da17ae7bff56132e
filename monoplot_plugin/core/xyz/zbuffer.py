"""The full-frame z-buffer: :func:`compute_xyz_full` and :func:`compute_xyz` (see the package docstring for the
method), and the :class:`XyzResult` they return."""

from __future__ import annotations

import contextlib
import logging
import math
import threading
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..camera import Camera
from ..dem import Dem
from ..distortion import valid_radius2
from ._jit import _threads
from .exact import _exact_hits, _visibility
from .mesh import _drop_void_hits, _filled_voids, _spans_have_nan
from .raster import _clear_buffers, _merge, _rasterise

__all__ = ["compute_xyz", "compute_xyz_full", "XyzResult", "NEAR_PLANE_M", "DONE_TILE", "trial_cameras"]

logger = logging.getLogger("monoplot")
_TRIALS = threading.local()


@contextlib.contextmanager
def trial_cameras():
    """In this thread, renders are of cameras a search only tries: a camera below the DEM is not worth a warning
    each (the automatic registration tried dozens, and the log filled with them), only a debug line."""
    before = getattr(_TRIALS, "on", False)
    _TRIALS.on = True
    try:
        yield
    finally:
        _TRIALS.on = before

#: Terrain closer than this to the camera plane (metres) is clipped away.
NEAR_PLANE_M = 0.01
#: Pixels per side of the tiles of ``compute_xyz_full(done=...)`` (a power of two: the kernels shift, not divide).
DONE_TILE = 16


@dataclass
class XyzResult:
    """Everything the z-buffer knows about one camera over one DEM.

    Attributes:
        xyz: (H, W, 3) float64 map coordinates of each pixel's first terrain hit (centre of the pixel); NaN = none.
        distance: (H, W) float32 metres from the camera centre to that hit; NaN = none.
        triangle: (H, W) int32 id of the hit triangle in ``dem`` (``2 * (row * (cols - 1) + col) + k``, k = 0 for
            (r, c), (r, c+1), (r+1, c+1) and 1 for (r, c), (r+1, c+1), (r+1, c)); -1 = none.
        visible: (rows, cols) bool over the DEM that was *passed in*: the camera sees that cell's centre.
        dem: the grid actually intersected (a crop of the input when ``crop=True``; ``dem.window`` says where).
        camera: the camera.
    """

    xyz: np.ndarray
    distance: np.ndarray
    triangle: np.ndarray
    visible: np.ndarray
    dem: Dem
    camera: Camera

    @property
    def hit(self) -> np.ndarray:
        """(H, W) bool: the pixel sees terrain."""
        return self.triangle >= 0

    def depth(self) -> np.ndarray:
        """(H, W) float64 depth along the optical axis (metres), NaN for sky."""
        rel = self.xyz - np.asarray(self.camera.position)
        return rel @ self.camera.forward


def _intrinsics(cam: Camera) -> np.ndarray:
    """(f, cx, cy, k1, k2, r2max, a, b) for the kernels; r2max: :func:`~..distortion.valid_radius2`; a, b: the
    half-widths (normalised, x / z and y / z) of the pyramid triangles are clipped to where a corner lies beyond
    r2max (:func:`~.raster._raster_clipped`): its corners on the valid radius in the direction of the picture's
    farthest corner from the principal point. Radial distortion keeps directions, and a barrel lens's undistorted
    picture lies inside the rectangle of its undistorted corners, so the pyramid holds the whole picture."""
    r2max = valid_radius2(cam.k1, cam.k2) if (cam.k1 != 0.0 or cam.k2 != 0.0) else np.inf
    a = b = np.inf
    if np.isfinite(r2max):
        ex = max(cam.cx, cam.width - cam.cx) / cam.focal_px
        ey = max(cam.cy, cam.height - cam.cy) / cam.focal_px
        angle = math.atan2(ey, ex)
        a, b = math.sqrt(r2max) * math.cos(angle), math.sqrt(r2max) * math.sin(angle)
    return np.array([cam.focal_px, cam.cx, cam.cy, cam.k1, cam.k2, r2max, a, b], dtype=np.float64)


def _cull_sign(cam: Camera, dem: Dem) -> float:
    """Screen-area sign of front-facing triangles: only the terrain's upper side is drawn.

    A ray that starts above the terrain meets it first from its upper side, so triangles seen from below (back
    faces) can never be its first hit. A camera *below* the surface at its own position is a DEM that is too coarse
    or a fit that ended a few metres low (a photographer on a summit that a 25 m DEM rounds off): drawing the
    underside would fill the whole picture with the slope above the camera. Culling it instead lets the rays leave
    the ground and see the terrain beyond, as the photo does; the log says the camera is below the DEM.
    """
    x, y, z = cam.position
    ground = dem.sample(x, y, method="mesh")
    if not math.isnan(ground) and z <= ground:
        level = logging.DEBUG if getattr(_TRIALS, "on", False) else logging.WARNING
        # where it stands: a batch's log gave the line twice with nothing to tell which photo's camera it was
        logger.log(level, "camera at X %.0f, Y %.0f is %.1f m below the DEM surface there: the terrain is seen "
                   "from above only", x, y, ground - z)
    g = dem.geotransform
    # triangle (r, c), (r, c+1), (r+1, c+1) is counter-clockwise in (col, row); the map flips it when the affine's
    # determinant is negative (north-up), and the image's downward v axis flips it once more
    return -1.0 if g[1] * g[5] - g[2] * g[4] > 0 else 1.0


def _depth_buffers(xyz: np.ndarray, n: int):
    """Cleared per-chunk buffers for :func:`_rasterise`: (n, H, W) float32 inverse depths and int32 triangle ids.

    They live inside the memory of the (H, W, 3) float64 output, which has room for three chunks (24 bytes per
    pixel) and is written only after the chunks are merged. Fresh memory is slow here: the first touch of each
    page is a fault, zeroed by the kernel, so a 24 MP call that reuses the output saves 384 MB of it (and what it
    faults in, it faults in once, for both uses). More chunks than fit get arrays of their own."""
    H, W, _ = xyz.shape
    if n <= 3:
        flat = xyz.reshape(-1).view(np.float32)
        zbufs = flat[:n * H * W].reshape(n, H, W)
        tbufs = flat[n * H * W:2 * n * H * W].view(np.int32).reshape(n, H, W)
    else:
        zbufs = np.empty((n, H, W), dtype=np.float32)
        tbufs = np.empty((n, H, W), dtype=np.int32)
    _clear_buffers(zbufs, tbufs)
    return zbufs, tbufs


def _chunk_count(H: int, W: int) -> int:
    threads = _threads()
    budget = int(1.2e9 // max(1, H * W * 8))  # bytes of per-chunk buffers we allow
    return max(1, min(threads, budget))


def compute_xyz_full(cam: Camera, dem: Dem, max_range: Optional[float] = None, crop: bool = True,
                     visibility: bool = True, rel_tol: float = 0.005, abs_tol: Optional[float] = None,
                     near: float = NEAR_PLANE_M, spans=None, done=None, scratch=None) -> XyzResult:
    """Z-buffer ``dem`` from ``cam``: per-pixel XYZ and distance, and per-cell visibility.

    Args:
        cam: camera in the DEM's CRS.
        dem: the terrain.
        max_range: ignore terrain farther than this (metres); None = no limit.
        crop: first cut the DEM to the rectangle the camera can see (saves time on large DEMs).
        visibility: compute :attr:`XyzResult.visible` (else all False).
        rel_tol, abs_tol: a cell centre counts as visible when the surface seen at its pixel is no nearer than its
            own range minus ``rel_tol * range + abs_tol`` (abs_tol defaults to one cell). Decided at pixel
            resolution: cells that project within a pixel of an occluding ridge can be misjudged; for exact
            line-of-sight tests use :func:`segment_first_hit` (``lookup.visibility_of_points`` does where the
            pixels cannot decide).
        near: terrain nearer than this depth (metres along the optical axis) is clipped away; the far bands of a
            level-of-detail view (:mod:`..xyz_lod`) start at their own depth.
        spans: None, or (lo, hi): (rows,) integer arrays; only the cells [lo[r], hi[r]) of each row r are terrain
            (the part of a window a level-of-detail band needs); the cells outside, NaN, are not voids. No crop.
        done: None, or a (ceil(H / DONE_TILE), ceil(W / DONE_TILE)) uint8 array, 1 for the tiles of
            :data:`DONE_TILE` x :data:`DONE_TILE` pixels whose every pixel is answered already (by a nearer band):
            terrain that falls only there is not drawn, and those pixels' results are not to be used.
        scratch: None, or a float64 array of H * W * 3 elements that becomes the result's ``xyz`` (reused memory
            for a caller that z-buffers many times; the result is overwritten by the next call).
    Returns:
        :class:`XyzResult`.
    """
    if dem.is_geographic:
        raise ValueError("the DEM is in geographic degrees: use Dem.open (reprojects to UTM) or "
                         "dem.reprojected_to_utm() and a camera in that CRS")
    W, H = cam.width, cam.height
    full_shape = dem.shape
    work = dem.crop_to_view(cam, max_range) if crop and spans is None else dem
    elev = np.ascontiguousarray(work.elevation)
    rows, cols = elev.shape
    visible = np.zeros(full_shape, dtype=bool)
    if spans is None:
        lo = np.zeros(rows, dtype=np.int64)
        hi = np.full(rows, cols, dtype=np.int64)
        has_voids = elev.size > 0 and bool(np.isnan(np.min(elev)))  # one pass, no mask for a DEM without voids
    else:
        lo = np.ascontiguousarray(spans[0], dtype=np.int64)
        hi = np.ascontiguousarray(spans[1], dtype=np.int64)
        has_voids = elev.size > 0 and _spans_have_nan(elev, lo, hi)
    void = np.isnan(elev) if has_voids else None
    if has_voids and not void.all() and rows >= 2 and cols >= 2:
        elev, void = _filled_voids(elev, void)
        has_voids = bool(void.any())
    if rows < 2 or cols < 2 or (void is not None and np.isnan(elev).all()):
        return XyzResult(np.full((H, W, 3), np.nan), np.full((H, W), np.nan, dtype=np.float32),
                         np.full((H, W), -1, dtype=np.int32), visible, work, cam)
    if 2 * (rows - 1) * (cols - 1) >= 2 ** 31 - 1:
        raise ValueError(f"DEM of {rows} x {cols} cells is too large for one pass: crop it or use max_range")
    gt = np.asarray(work.geotransform, dtype=np.float64)
    C = np.asarray(cam.position, dtype=np.float64)
    R = np.ascontiguousarray(cam.rotation, dtype=np.float64)
    intr = _intrinsics(cam)
    near = max(float(near), NEAR_PLANE_M)
    n = _chunk_count(H, W)
    # scratch for the depth buffers first; every pixel is written by _exact_hits
    xyz = np.empty((H, W, 3)) if scratch is None else scratch[:H * W * 3].reshape(H, W, 3)
    zbufs, tbufs = _depth_buffers(xyz, n)
    if done is None:
        done, tile = np.zeros((1, 1), dtype=np.uint8), 1 << 30
    else:
        done, tile = np.ascontiguousarray(done, dtype=np.uint8), DONE_TILE
    _rasterise(elev, gt, C, R, intr, near, _cull_sign(cam, work), zbufs, tbufs, lo, hi, done, tile)
    tri = np.empty((H, W), dtype=np.int32)
    _merge(zbufs, tbufs, tri)
    del zbufs, tbufs
    if has_voids:
        _drop_void_hits(tri, void)
    limit = np.inf if max_range is None else float(max_range)
    dist = np.empty((H, W), dtype=np.float32)
    _exact_hits(tri, elev, gt, C, R, intr, limit, _threads(), xyz, dist)
    if visibility:
        vis = np.empty((rows, cols), dtype=np.bool_)
        _visibility(tri, elev, gt, C, R, intr, near, float(rel_tol),
                    float(work.cell_size if abs_tol is None else abs_tol), vis)
        if has_voids:
            vis &= ~void
        if max_range is not None:
            X, Y = work.cell_centres()
            rng = np.sqrt((X - C[0]) ** 2 + (Y - C[1]) ** 2 + (elev - C[2]) ** 2)
            vis &= rng <= max_range
        r0 = work.window[0] - dem.window[0]
        c0 = work.window[1] - dem.window[1]
        visible[r0:r0 + rows, c0:c0 + cols] = vis
    return XyzResult(xyz, dist, tri, visible, work, cam)


def compute_xyz(cam: Camera, dem: Dem, max_range: Optional[float] = None, crop: bool = True) -> np.ndarray:
    """(H, W, 3) float64 map coordinates of the first terrain point seen by each pixel centre; NaN where the ray
    meets no terrain (sky, voids, beyond the DEM or ``max_range``). See :func:`compute_xyz_full` for more."""
    return compute_xyz_full(cam, dem, max_range=max_range, crop=crop, visibility=False).xyz
