"""Sampling and shading a regular grid (an image, a DEM's array): the one bilinear lookup and the one Lambert
hillshade of the core.

>>> g = np.array([[0.0, 1.0], [2.0, 3.0]])
>>> bilinear(g, np.array([0.5, 0.0, 5.0]), np.array([0.5, 1.0, -1.0])).tolist()
[1.5, 1.0, 2.0]
>>> round(float(lambert(np.zeros(1), np.zeros(1), 315.0, 30.0)[0]), 6)
0.5
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["bilinear", "lambert", "block_means"]


def bilinear(grid: np.ndarray, fr: np.ndarray, fc: np.ndarray) -> np.ndarray:
    """Bilinear lookup of a (rows, cols) ``grid`` at fractional (row, col) index positions (node (r, c) at (r, c)),
    clamped at the edges."""
    rows, cols = grid.shape[:2]
    r0 = np.clip(np.floor(fr).astype(np.int64), 0, max(rows - 2, 0))
    c0 = np.clip(np.floor(fc).astype(np.int64), 0, max(cols - 2, 0))
    t = np.clip(fr - r0, 0.0, 1.0)
    s = np.clip(fc - c0, 0.0, 1.0)
    r1 = np.minimum(r0 + 1, rows - 1)
    c1 = np.minimum(c0 + 1, cols - 1)
    return grid[r0, c0] * (1 - s) * (1 - t) + grid[r0, c1] * s * (1 - t) + grid[r1, c0] * (1 - s) * t + \
        grid[r1, c1] * s * t


def lambert(dzdx: np.ndarray, dzdy: np.ndarray, azimuth: float, altitude: float) -> np.ndarray:
    """Lambert shading 0..1 of slopes ``dzdx``, ``dzdy`` (any shape) for a sun at ``azimuth`` (degrees clockwise
    from grid north) and ``altitude`` (degrees above the horizon)."""
    a, h = math.radians(azimuth), math.radians(altitude)
    light = (math.sin(a) * math.cos(h), math.cos(a) * math.cos(h), math.sin(h))
    norm = np.sqrt(dzdx * dzdx + dzdy * dzdy + 1.0)
    return np.clip((-dzdx * light[0] - dzdy * light[1] + light[2]) / norm, 0.0, 1.0)


def block_means(z: np.ndarray, step: int, dtype=np.float64, poll=None, chunk_cells: int = 2_000_000) -> np.ndarray:
    """(rows // step, cols // step) mean of the finite cells of each ``step`` x ``step`` block of ``z``, in
    ``dtype`` (NaN where a block has none); the rows and columns that do not fill a block are left out.

    Done a band of blocks at a time (about ``chunk_cells`` cells of ``z``), calling ``poll()`` before each (it
    raises to stop): a mean over a 100 M-cell grid at once took 5 s and grid-sized temporaries, and could not be
    canceled.

    >>> block_means(np.array([[1.0, 3.0, 9.0], [np.nan, 5.0, 9.0], [7.0, 7.0, 7.0]]), 2).tolist()
    [[3.0]]
    >>> block_means(np.array([[np.nan, np.nan], [np.nan, np.nan]]), 2).tolist()
    [[nan]]
    """
    import warnings

    nr, nc = z.shape[0] // step, z.shape[1] // step
    out = np.empty((nr, nc), dtype=dtype)
    band = max(1, int(chunk_cells // (step * step * max(nc, 1))))  # block rows per band
    for a in range(0, nr, band):
        if poll is not None:
            poll()
        b = min(nr, a + band)
        blocks = np.asarray(z[a * step:b * step, :nc * step], dtype=dtype).reshape(b - a, step, nc, step)
        part = blocks.mean(axis=(1, 3), dtype=dtype)
        if np.isnan(part).any():  # blocks with voids: the mean of their valid cells (NaN when none)
            with np.errstate(invalid="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                part = np.nanmean(blocks, axis=(1, 3)).astype(dtype)
        out[a:b] = part
    return out
