"""The DEM as the approximate camera sees it, for the DEM suggestions (:mod:`.suggest`): a rendering for the key
point detectors, the peaks of its silhouettes, and the foreground terrain under a key point."""

from __future__ import annotations


import numpy as np

from .grid import lambert

__all__ = ["render_for_keypoints", "silhouette_peaks", "foreground_xyz", "scaled_camera"]


def render_for_keypoints(res, dem) -> np.ndarray:
    """(H, W) uint8 picture of the terrain seen by the camera: shaded relief (the mean of four sun directions, so
    no slope is flat black), silhouettes drawn dark, sky white."""
    import cv2

    hit = res.hit
    xyz = res.xyz
    img = np.full(hit.shape, 255.0)
    if hit.any():
        # Slopes by central differences at the seen points only (the DEM may be far larger than the picture).
        x, y = xyz[hit, 0], xyz[hit, 1]
        h = dem.cell_size
        dzdx = (dem.sample(x + h, y) - dem.sample(x - h, y)) / (2 * h)
        dzdy = (dem.sample(x, y + h) - dem.sample(x, y - h)) / (2 * h)
        dzdx, dzdy = np.nan_to_num(dzdx), np.nan_to_num(dzdy)
        shade = np.zeros(len(x))
        for az in (315.0, 45.0, 135.0, 225.0):
            shade += lambert(dzdx, dzdy, az, 40.0) / 4.0
        img[hit] = 30.0 + 200.0 * shade
        logd = np.log(np.where(hit, res.distance, np.nanmax(res.distance[hit]) * 4)).astype(np.float32)
        edges = np.abs(cv2.Sobel(logd, cv2.CV_32F, 1, 0, ksize=3)) + np.abs(cv2.Sobel(logd, cv2.CV_32F, 0, 1,
                                                                                            ksize=3))
        img[edges > 0.4] = 0.0
    img = np.clip(img, 0, 255).astype(np.uint8)
    # Local contrast equalisation: a DEM rendering is smooth; without it the detectors only fire on the skyline.
    clahe = cv2.createCLAHE(clipLimit=4.0, tileGridSize=(8, 8))
    out = clahe.apply(img)
    out[~hit] = 255
    return out


def scaled_camera(camera, max_width: int):
    """``camera`` with its image reduced to ``max_width`` columns (same view), and the scale factor."""
    scale = min(1.0, float(max_width) / camera.width)
    return camera.scaled(scale), scale


def silhouette_peaks(res, half_width: int = 15, min_rise_px: float = 3.0, tolerance: float = 0.25):
    """Peaks of the silhouettes seen by the camera: terrain points at the top of an occluding contour (sky or
    farther terrain right above them) that are higher in the picture than the contour ``half_width`` pixels to
    either side by at least ``min_rise_px``. These are the summits and ridge tops a person picks on a skyline.

    Args:
        res: :class:`~monoplot_plugin.core.xyz.XyzResult` of the (reduced) camera.
        tolerance: contour pixels within this fraction of each other's distance belong to the same ridge.
    Returns:
        (xyz (K, 3) map coordinates of the peak pixels' terrain, strength (K,) rise in pixels).
    """
    hit = np.asarray(res.hit)
    dist = np.where(hit, res.distance, np.inf).astype(np.float64)
    above = np.vstack([np.full((1, dist.shape[1]), np.inf), dist[:-1]])
    top = hit & (above > 1.15 * dist)  # sky, or terrain at least 15 % farther, just above
    rows, cols = np.nonzero(top)
    d = dist[rows, cols]
    out, strength, candidates = [], [], []
    by_col = {}
    for i, c in enumerate(cols):
        by_col.setdefault(int(c), []).append(i)
    # Contour pixels of the same ridge are those at a similar distance (a silhouette piece may jump several rows
    # from one column to the next on steep slopes, so pixel connectivity would cut it up).
    for i in range(len(rows)):
        r, c, di = rows[i], int(cols[i]), d[i]
        best_above = False
        for cc in range(c - half_width, c + half_width + 1):
            for j in by_col.get(cc, ()):
                if abs(d[j] - di) <= tolerance * di:
                    if rows[j] < r:
                        best_above = True
                        break
            if best_above:
                break
        if best_above:
            continue
        rises = []
        for side in (range(c - half_width, c), range(c + 1, c + half_width + 1)):
            drop = 0.0
            for cc in side:
                same = [rows[j] for j in by_col.get(cc, ()) if abs(d[j] - di) <= tolerance * di]
                if same:
                    drop = max(drop, float(min(same) - r))
            rises.append(drop)
        rise = min(rises)
        if rise >= min_rise_px:
            candidates.append((int(r), c, float(rise)))
    # A flat top is a run of equal rows: keep its middle pixel.
    candidates.sort()
    k = 0
    while k < len(candidates):
        m = k
        while (m + 1 < len(candidates) and candidates[m + 1][0] == candidates[k][0]
               and candidates[m + 1][1] <= candidates[m][1] + 1):
            m += 1
        r, c, rise = candidates[(k + m) // 2]
        out.append(res.xyz[r, c])
        strength.append(rise)
        k = m + 1
    if not out:
        return np.zeros((0, 3)), np.zeros(0)
    xyz = np.asarray(out)
    ok = np.isfinite(xyz).all(axis=1)
    return xyz[ok], np.asarray(strength)[ok]


def foreground_xyz(res, uv: np.ndarray, radius: int = 2) -> np.ndarray:
    """(K, 3) XYZ of the nearest terrain within ``radius`` pixels of each key point (NaN when only sky)."""
    dist = np.where(res.hit, res.distance, np.inf)
    h, w = dist.shape
    out = np.full((len(uv), 3), np.nan)
    cols = np.clip(np.floor(uv[:, 0]).astype(int), 0, w - 1)
    rows = np.clip(np.floor(uv[:, 1]).astype(int), 0, h - 1)
    best = np.full(len(uv), np.inf)
    for dr in range(-radius, radius + 1):
        for dc in range(-radius, radius + 1):
            r = np.clip(rows + dr, 0, h - 1)
            c = np.clip(cols + dc, 0, w - 1)
            d = dist[r, c]
            better = d < best
            best[better] = d[better]
            out[better] = res.xyz[r[better], c[better]]
    return out
