"""Per-pixel XYZ over a DEM larger than memory: the camera's distance bands z-buffered near to far.

:meth:`~.dem_window.DemSource.plan` cuts the view into depth bands, the first at full resolution, each farther one
at a coarser level (cells at most ``lod`` pixel footprints), and the bands into thinner slabs. Each slab is read
(:meth:`~.dem_window.DemSource.read_view`: only the cells its part of the frustum covers) and z-buffered on its own
with its near plane at the slab's start (:func:`~.xyz.compute_xyz_full` with ``near`` and ``spans``), over only the
image rows that still need it and that its terrain can reach (a strip camera, :func:`~.xyz_strips.strip_camera`);
terrain that would fall only on pixels answered by nearer slabs is not drawn (``done`` tiles). A pixel takes the
first slab, near to far, whose hit lies before that slab's far depth (plus :data:`~.dem_window.LOD_OVERLAP`).
Terrain of a farther slab cannot hide a nearer one's, and the nearer one has been searched before, so each pixel
gets its first hit, exact on the mesh of the level it falls in. One slab's DEM is in memory at a time.

>>> import os, tempfile
>>> from .camera import Camera
>>> from .dem_window import DemSource, build_overviews
>>> from .synthetic import synthetic_terrain
>>> dem = synthetic_terrain((512, 512), cell=20.0, seed=1)
>>> folder = tempfile.TemporaryDirectory()
>>> path = os.path.join(folder.name, "dem.tif"); dem.save(path); _ = build_overviews(path, min_size=64)
>>> x, y = dem.cell_to_map(50, 460)
>>> cam = Camera((x, y, float(dem.elevation.max()) + 200), 45, -8, 0, 60, (300, 200))
>>> res = compute_xyz_lod(cam, DemSource(path), lod=2.0)
>>> sorted(set(res.factor[res.factor > 0].tolist()))     # near field at full resolution, then coarser
[1, 2, 4]
>>> folder.cleanup()
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Callable, List, Optional, Tuple

import numpy as np

from .camera import Camera
from .dem_window import LOD_OVERLAP, DemSource
from .xyz import compute_xyz_full
from .xyz.zbuffer import DONE_TILE
from .xyz._jit import njit, prange
from .xyz_strips import strip_camera

__all__ = ["LodXyz", "compute_xyz_lod"]

logger = logging.getLogger("monoplot")


@dataclass
class LodXyz:
    """Per-pixel XYZ of a level-of-detail view.

    Attributes:
        xyz: (H, W, 3) float64 map coordinates of each pixel's first terrain hit; NaN = none.
        distance: (H, W) float32 metres from the camera; NaN = none.
        factor: (H, W) int16 level of the hit (1 = full resolution, 2, 4, ... = overview factor; 0 = none).
        bands: (factor, near, far, (rows, cols) of the window, cells read in it, seconds) of each band z-buffered.
        camera: the camera.
    """

    xyz: np.ndarray
    distance: np.ndarray
    factor: np.ndarray
    camera: Camera
    bands: List[Tuple[int, float, float, Tuple[int, int], int, float]] = field(default_factory=list)

    @property
    def hit(self) -> np.ndarray:
        return self.factor > 0


def compute_xyz_lod(cam: Camera, source: DemSource, max_range: Optional[float] = None, lod: float = 1.0,
                    progress: Optional[Callable[[float, str], None]] = None, split: bool = True) -> LodXyz:
    """Z-buffer the DEM file of ``source`` from ``cam`` band by band, near to far (see the module docstring).

    Args:
        cam: camera in the DEM's CRS.
        source: the DEM file.
        max_range: ignore terrain farther than this (metres); None = no limit.
        lod: a band's cells are at most this many pixel footprints at its near depth (1: sub-pixel everywhere;
            larger is faster and coarser far away).
        progress: ``progress(fraction, message)`` after each band.
        split: z-buffer each band in thinner slabs (:meth:`~.dem_window.DemSource.plan`), the same result faster
            when nearer terrain hides much of the farther one.
    """
    import time

    H, W = cam.height, cam.width
    xyz = np.full((H, W, 3), np.nan)
    dist = np.full((H, W), np.nan, dtype=np.float32)
    factor = np.zeros((H, W), dtype=np.int16)
    todo_rows = np.ones(H, dtype=bool)
    todo = np.ones((H, W), dtype=np.bool_)
    C = np.asarray(cam.position, dtype=np.float64)
    forward = cam.forward
    plan = source.plan(cam, max_range, lod, split=split)
    out = LodXyz(xyz, dist, factor, cam)
    rising = _rising_rows(cam)
    scratch = np.empty(H * W * 3)  # the z-buffer's depth buffers and XYZ, one allocation for every band
    held = np.empty(0, dtype=np.float32)  # the slabs' windows: the largest one read so far, reused
    for i, (level, near, far) in enumerate(plan):
        # rows whose rays all rise and are above the highest terrain at this depth see nothing farther
        todo_rows &= ~((rising > 0.0) & (C[2] + near * rising > source.zmax))
        rows = np.flatnonzero(todo_rows)
        if rows.size == 0:
            logger.debug("LOD: every pixel done before band x%d", level)
            break
        r0, r1 = int(rows[0]), int(rows[-1]) + 1
        t0 = time.perf_counter()
        last = i == len(plan) - 1
        keep = math.inf if last else far * (1.0 + LOD_OVERLAP)
        sub = strip_camera(cam, r0, r1 - r0)
        view = source.read_view(sub, level, min_depth=near, max_depth=None if math.isinf(keep) else keep,
                                max_range=max_range, placeholders=False, out=held)
        if view is None:
            logger.debug("LOD band x%d: nothing in view", level)
            continue
        dem, spans, (v0, v1) = view
        if dem.elevation.size > held.size:
            held = dem.elevation.reshape(-1)
        window = (*dem.window, *dem.shape)
        cells = int((spans[1] - spans[0]).clip(0).sum())
        if cells == 0 or v1 <= v0:  # the window's rectangle meets the grid, the view's footprint does not
            logger.debug("LOD band x%d: no cell in view (rows %d-%d)", level, r0, r1)
            continue
        r0, r1 = r0 + v0, r0 + v1  # only the rows whose rays can reach this band's terrain
        sub = strip_camera(cam, r0, r1 - r0)
        res = compute_xyz_full(sub, dem, max_range=max_range, crop=False, visibility=False, near=near, spans=spans,
                               done=None if i == 0 else _done_tiles(todo[r0:r1]),
                               scratch=scratch[:(r1 - r0) * W * 3])
        del dem
        _take_hits(res.triangle, res.xyz, res.distance, C, forward, keep, level, r0, todo, xyz, dist, factor)
        del res
        todo_rows &= todo.any(axis=1)
        seconds = time.perf_counter() - t0
        out.bands.append((level, near, far, (int(window[2]), int(window[3])), cells, seconds))
        logger.debug("LOD band x%d, depth %.0f-%.0f m: rows %d-%d, %d x %d cells, %.2f s", level, near, far, r0, r1,
                     window[2], window[3], seconds)
        if progress is not None:
            progress((i + 1) / len(plan), f"terrain {near / 1000:.1f}-{far / 1000:.1f} km at 1/{level} resolution")
    return out


def _rising_rows(cam: Camera, samples: int = 33) -> np.ndarray:
    """(H,) per image row, the least height its rays gain per metre of depth (sampled along the row; > 0: all
    rise)."""
    u = np.linspace(0.0, cam.width, samples)
    v = np.arange(cam.height) + 0.5
    uu, vv = np.meshgrid(u, v)
    rays = cam.pixel_to_camera_ray(np.stack([uu.ravel(), vv.ravel()], 1))
    world = rays @ cam.rotation
    rise = (world[:, 2] / rays[:, 2]).reshape(cam.height, samples).min(axis=1)  # height gained per metre of depth
    return rise


@njit(parallel=True, cache=True)
def _take_hits(tri, sxyz, sdist, C, forward, keep, level, r0, todo, xyz, dist, factor):
    """Copy a band's hits (strip of rows from r0) that lie before the depth ``keep`` into the pixels still to do."""
    h, W = tri.shape
    for i in prange(h):
        for j in range(W):
            if tri[i, j] < 0 or not todo[r0 + i, j]:
                continue
            depth = ((sxyz[i, j, 0] - C[0]) * forward[0] + (sxyz[i, j, 1] - C[1]) * forward[1]
                     + (sxyz[i, j, 2] - C[2]) * forward[2])
            if depth < keep:
                xyz[r0 + i, j, 0] = sxyz[i, j, 0]
                xyz[r0 + i, j, 1] = sxyz[i, j, 1]
                xyz[r0 + i, j, 2] = sxyz[i, j, 2]
                dist[r0 + i, j] = sdist[i, j]
                factor[r0 + i, j] = level
                todo[r0 + i, j] = False


def _done_tiles(todo: np.ndarray) -> np.ndarray:
    """(ceil(h / DONE_TILE), ceil(w / DONE_TILE)) uint8: 1 for the tiles without a pixel still to do."""
    h, w = todo.shape
    t = DONE_TILE
    padded = np.zeros((-(-h // t) * t, -(-w // t) * t), dtype=bool)
    padded[:h, :w] = todo
    return (~padded.reshape(padded.shape[0] // t, t, padded.shape[1] // t, t).any(axis=(1, 3))).astype(np.uint8)
