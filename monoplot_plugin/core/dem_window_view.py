"""What a camera can see of a grid: the window of cells (and the footprint inside it) that its view frustum, cut to
the grid's height range and to a range of distances, can reach. :class:`~.dem.Dem` crops with it, and
:class:`~.dem_window.DemSource` reads with it.

>>> from .camera import Camera
>>> cam = Camera((50.0, 0.0, 100.0), heading=0, pitch=-45, roll=0, fov=40, image_size=(40, 30))
>>> view_window(cam, (0, 1, 0, 200, 0, -1), (200, 100), 0.0, 0.0)   # the ground 57-173 m north (rows 27-143)
(17, 0, 134, 100)
"""

from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

import numpy as np

__all__ = ["view_window", "view_footprint"]


def view_window(camera, geotransform: Sequence[float], shape: Tuple[int, int], zmin: float, zmax: float,
                max_range: Optional[float] = None, margin_cells: int = 2, samples: int = 64, min_range: float = 0.0):
    """The rectangle of cells a camera can see: (row0, col0, rows, cols) clipped to the grid, or None (see
    :func:`view_footprint`, of which it is the first item)."""
    found = view_footprint(camera, geotransform, shape, zmin, zmax, max_range, margin_cells, samples, min_range)
    return None if found is None else found[0]


def view_footprint(camera, geotransform: Sequence[float], shape: Tuple[int, int], zmin: float, zmax: float,
                   max_range: Optional[float] = None, margin_cells: int = 2, samples: int = 64,
                   min_range: float = 0.0, min_depth: float = 0.0, max_depth: Optional[float] = None):
    """(window, ends, pad, image_rows) of what a camera can see, or None: ``window`` = (row0, col0, rows, cols), the
    rectangle of cells clipped to the grid; ``ends``: (N, 2) fractional (row, col) of the sample ray pieces' ends,
    whose convex hull widened by ``pad`` cells holds the view (None when the view reaches infinity: then the window
    spans the grid); ``image_rows``: (first, last), the image rows whose rays can meet that part of the grid.

    Rays along the image border and over a grid inside it are cut to the height slab ``[zmin, zmax]`` and to
    ``max_range`` metres; the window is the bounding box (in cell space, so rotated grids work) of the ends of those
    ray pieces, widened by ``margin_cells`` plus the gap between neighbouring sample rays. A view that reaches
    infinity (rays that stay in the slab) without ``max_range`` keeps the whole grid along that direction.
    ``min_range``: leave out what is nearer than that (metres), for the far bands of a level-of-detail view;
    ``min_depth``, ``max_depth``: the same along the optical axis (the depth slab of such a band).
    """
    rows, cols = int(shape[0]), int(shape[1])
    if rows == 0 or cols == 0 or not (np.isfinite(zmin) and np.isfinite(zmax)):
        return None
    w, h = camera.width, camera.height
    t = np.linspace(0.0, 1.0, samples + 1)
    border = np.concatenate([np.stack([t * w, np.zeros_like(t)], 1), np.stack([t * w, np.full_like(t, h)], 1),
                             np.stack([np.zeros_like(t), t * h], 1), np.stack([np.full_like(t, w), t * h], 1)])
    gu, gv = np.meshgrid(np.linspace(0, w, 9), np.linspace(0, h, 9))
    uv = np.concatenate([border, np.stack([gu.ravel(), gv.ravel()], 1)])
    origin, dirs = camera.pixel_to_world_ray(uv)
    cz = origin[2]
    dz = dirs[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (zmin - cz) / dz
        t2 = (zmax - cz) / dz
    lo = np.where(dz != 0, np.minimum(t1, t2), np.where((cz >= zmin) & (cz <= zmax), 0.0, np.inf))
    hi = np.where(dz != 0, np.maximum(t1, t2), np.where((cz >= zmin) & (cz <= zmax), np.inf, -np.inf))
    lo = np.maximum(lo, max(0.0, float(min_range)))
    cos = np.maximum(dirs @ camera.forward, 1e-6)
    if min_depth > 0.0:
        lo = np.maximum(lo, float(min_depth) / cos)
    if max_depth is not None:
        hi = np.minimum(hi, float(max_depth) / cos)
    ok = hi >= lo
    if max_range is not None:
        # A ray reaching the slab beyond max_range still bounds the view: keep its point at max_range (the sphere
        # cap between sample rays is otherwise missed).
        hi = np.minimum(hi, float(max_range))
        lo = np.minimum(lo, float(max_range))
    if not ok.any():
        return None
    g = geotransform
    det = g[1] * g[5] - g[2] * g[4]
    if np.isinf(hi[ok]).any():
        return (0, 0, rows, cols), None, 0.0, _rows_of(uv[ok, 1], h, samples)
    ends = np.concatenate([origin + dirs[ok] * lo[ok, None], origin + dirs[ok] * hi[ok, None]])
    dx, dy = ends[:, 0] - g[0], ends[:, 1] - g[3]
    col = (g[5] * dx - g[2] * dy) / det
    row = (-g[4] * dx + g[1] * dy) / det
    # Gap between neighbouring sample rays at the farthest distance, in cells.
    step = math.radians(max(camera.fov, camera.vertical_fov)) / samples * 2.0
    cell = math.sqrt(abs(det))
    gap = float(np.max(hi[ok])) * step / cell
    pad = margin_cells + gap + 1.0
    r0 = max(0, int(math.floor(row.min() - pad)))
    c0 = max(0, int(math.floor(col.min() - pad)))
    r1 = min(rows, int(math.ceil(row.max() + pad)))
    c1 = min(cols, int(math.ceil(col.max() + pad)))
    if r1 <= r0 or c1 <= c0:
        return None
    return (r0, c0, r1 - r0, c1 - c0), np.stack([row, col], axis=1), pad, _rows_of(uv[ok, 1], h, samples)


def _rows_of(v: np.ndarray, height: int, samples: int) -> Tuple[int, int]:
    """Image rows [first, last) that the sample rays at heights ``v`` stand for, widened by two sample steps."""
    step = 2.0 * height / samples
    return max(0, int(math.floor(v.min() - step))), min(int(height), int(math.ceil(v.max() + step)))
