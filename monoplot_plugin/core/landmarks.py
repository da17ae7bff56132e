"""Terrain landmarks of a DEM for the DEM suggestions (:mod:`.suggest`): summits ranked by topographic
prominence, saddles and ridge junctions."""

from __future__ import annotations

import math

import numpy as np

from .grid import block_means

__all__ = ["terrain_landmarks"]


_RING = [(-1, -1), (-1, 0), (-1, 1), (0, 1), (1, 1), (1, 0), (1, -1), (0, -1)]


def _ring_stack(z: np.ndarray) -> np.ndarray:
    """(8, rows, cols) the 8 neighbours of each cell in circular order (edge cells padded by replication)."""
    p = np.pad(z, 1, mode="edge")
    r, c = z.shape
    return np.stack([p[1 + dr:1 + dr + r, 1 + dc:1 + dc + c] for dr, dc in _RING])


def _prominence(z: np.ndarray, peaks_rc: np.ndarray, levels: int = 60) -> np.ndarray:
    """Topographic prominence (metres, quantised to the level step) of the given peak cells.

    Lowering a water level from the top, a peak's key col is the highest level at which its island joins one with
    higher ground; prominence = height - col. The highest peak gets height - lowest ground.
    """
    from scipy import ndimage

    finite = np.isfinite(z)
    zf = np.where(finite, z, -np.inf)
    hp = zf[peaks_rc[:, 0], peaks_rc[:, 1]]
    lo, hi = float(np.min(z[finite])), float(np.max(z[finite]))
    prom = hp - lo
    unresolved = np.ones(len(hp), dtype=bool)
    flat = zf.ravel()
    by_height = np.argsort(-flat, kind="stable")  # once; cells above a level are a prefix of this order
    sorted_heights = flat[by_height]
    for t in np.linspace(hi, lo, levels)[1:]:
        if not unresolved.any():
            break
        labels, n = ndimage.label(zf >= t)
        if n == 0:
            continue
        count = int(np.searchsorted(-sorted_heights, -t, side="right"))
        prefix = by_height[:count]
        top = np.full(n + 1, -np.inf)
        # Highest cell of each island: write in increasing height so that the last (highest) write wins.
        top[labels.ravel()[prefix[::-1]]] = flat[prefix[::-1]]
        lab = labels[peaks_rc[unresolved, 0], peaks_rc[unresolved, 1]]
        idx = np.flatnonzero(unresolved)
        higher = (lab > 0) & (top[lab] > hp[idx] + 1e-9)
        prom[idx[higher]] = hp[idx[higher]] - t
        unresolved[idx[higher]] = False
    return prom


def terrain_landmarks(dem, max_cells: int = 160_000, min_prominence: float = 30.0, smooth_cells: float = 1.0):
    """Summits (by prominence), saddles and ridge junctions of a DEM.

    Works on a version of the grid reduced to at most ``max_cells`` cells (block maxima for summits), then puts
    each landmark back on the full grid's highest (summits) or own cell.

    Returns:
        (xyz (K, 3) map coordinates, kind (K,) str, strength (K,) metres, prominence (K,) metres or NaN).
    """
    from scipy import ndimage

    z = np.asarray(dem.elevation)  # float32 or float64; never copied whole (100 M cells: 0.8 GB as float64)
    rows, cols = z.shape
    step = max(1, int(math.ceil(math.sqrt(rows * cols / max_cells))))
    zr = block_means(z, step) if step > 1 else z.astype(np.float64)
    finite = np.isfinite(zr)
    if finite.sum() < 9:
        empty = np.zeros((0, 3))
        return empty, np.zeros(0, dtype="<U8"), np.zeros(0), np.zeros(0)
    fill = np.where(finite, zr, np.nanmin(zr))
    zs = ndimage.gaussian_filter(fill, smooth_cells) if smooth_cells > 0 else fill
    zs = np.where(finite, zs, np.nan)
    out_rc, out_kind, out_strength, out_prom = [], [], [], []

    # Summits: local maxima of a 5 x 5 window, away from voids, ranked by prominence.
    zmax = ndimage.maximum_filter(np.where(finite, zs, -np.inf), size=5)
    void_near = ndimage.maximum_filter((~finite).astype(np.uint8), size=5) > 0
    peaks = np.argwhere((zs == zmax) & finite & ~void_near)
    if len(peaks):
        prom = _prominence(zs, peaks)
        ok = prom >= min_prominence
        out_rc.append(peaks[ok])
        out_kind += ["summit"] * int(ok.sum())
        out_strength.append(prom[ok])
        out_prom.append(prom[ok])

    ring = _ring_stack(np.where(finite, zs, np.nan))
    diff = ring - zs[None]
    # Saddles: going round the 8 neighbours, heights go above / below the centre four times (two ridges up, two
    # valleys down); strength = the smaller of the two climbs and the two drops.
    sign = np.sign(diff)
    changes = np.sum(sign != np.roll(sign, 1, axis=0), axis=0)
    interior = np.isfinite(ring).all(axis=0) & finite
    saddle = interior & (changes >= 4)
    if saddle.any():
        filled = np.where(np.isfinite(diff), diff, 0.0)
        rise = filled.max(axis=0)
        drop = -filled.min(axis=0)
        strength = np.minimum(rise, drop)
        # One saddle per 5 x 5 neighbourhood: the strongest.
        best = strength == ndimage.maximum_filter(np.where(saddle, strength, -np.inf), size=5)
        rc = np.argwhere(saddle & best & (strength > 0.2 * step * dem.cell_size * 0.1))
        out_rc.append(rc)
        out_kind += ["saddle"] * len(rc)
        out_strength.append(strength[rc[:, 0], rc[:, 1]] * 2.0)
        out_prom.append(np.full(len(rc), np.nan))

    # Ridge junctions: ridge cells (higher than both neighbours across some direction, convex) where three or
    # more ridge branches meet in the 8-neighbourhood.
    across = [(0, 4), (1, 5), (2, 6), (3, 7)]
    ridge_depth = np.full(zs.shape, -np.inf)
    for a, b in across:
        lower = np.minimum(-diff[a], -diff[b])
        ridge_depth = np.maximum(ridge_depth, lower)
    ridge = interior & (ridge_depth > 0)
    if ridge.any():
        rring = _ring_stack(ridge.astype(np.int8)).astype(bool)
        branches = np.sum(rring & ~np.roll(rring, 1, axis=0), axis=0)
        junction = ridge & (branches >= 3)
        strength = np.where(junction, ridge_depth, -np.inf)
        best = strength == ndimage.maximum_filter(strength, size=7)
        rc = np.argwhere(junction & best)
        out_rc.append(rc)
        out_kind += ["junction"] * len(rc)
        out_strength.append(ridge_depth[rc[:, 0], rc[:, 1]])
        out_prom.append(np.full(len(rc), np.nan))

    if not out_rc:
        return np.zeros((0, 3)), np.zeros(0, dtype="<U8"), np.zeros(0), np.zeros(0)
    rc = np.concatenate(out_rc).astype(np.int64)
    kind = np.array(out_kind, dtype="<U8")
    strength = np.concatenate(out_strength)
    prom = np.concatenate(out_prom)
    # Back to full-resolution cells: summits on the highest cell of their block, others on the block centre.
    r_full = rc[:, 0] * step + step // 2
    c_full = rc[:, 1] * step + step // 2
    if step > 1:
        for i in np.flatnonzero(kind == "summit"):
            block = z[rc[i, 0] * step:(rc[i, 0] + 1) * step, rc[i, 1] * step:(rc[i, 1] + 1) * step]
            if np.isfinite(block).any():
                a, b = np.unravel_index(np.nanargmax(block), block.shape)
                r_full[i], c_full[i] = rc[i, 0] * step + a, rc[i, 1] * step + b
    r_full = np.clip(r_full, 0, rows - 1)
    c_full = np.clip(c_full, 0, cols - 1)
    x, y = dem.cell_to_map(c_full + 0.5, r_full + 0.5)
    zz = z[r_full, c_full]
    good = np.isfinite(zz)
    xyz = np.stack([np.atleast_1d(x), np.atleast_1d(y), zz], axis=1)
    return xyz[good], kind[good], strength[good], prom[good]
