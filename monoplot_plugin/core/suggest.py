"""Suggested ground-control points: key points in the photo and on the DEM, for the user to accept or reject.

Photo (:func:`suggest_photo_points`): ORB key points (OpenCV FAST + Harris score) and Shi-Tomasi corners, which
find the blunt corners (glacier junctions, moraine tips) that FAST misses, inside the picture proper (no paper
border, frame or printed caption, see :func:`~monoplot_plugin.core.suggest_photo.picture_mask`), spread over the
picture by grid bucketing.

DEM (:func:`suggest_dem_points`): with an approximate camera, the DEM is rendered from it with the core's z-buffer
(:func:`~monoplot_plugin.core.xyz.compute_xyz_full`): shaded relief plus dark silhouettes, and the same detectors
run on that picture, so suggestions are the terrain points that look like corners *from there* (peaks on the
skyline, ridge crossings, spur tips); each key point takes the X, Y, Z of the nearest terrain it shows (the
foreground side of a silhouette). Only points the camera sees, inside its view (plus a margin), are suggested.
Without a camera the detectors run on a map hillshade. Terrain landmarks are added in both cases: summits ranked
by topographic prominence, saddles and ridge junctions, X / Y from the geotransform and Z from the DEM; with a
camera also the peaks of the silhouettes it sees (:func:`silhouette_peaks`, kind "skyline").

Scores (documented, in [0, 1], higher first):

- key points: the percentile rank of the detector response among that detector's candidates in the same picture
  (ORB: Harris response; corners: the smaller eigenvalue of the structure tensor), so both detectors compare;
- landmarks: ``0.5 + 0.5 * rank`` of their strength (prominence for summits, relief drop for saddles, ridge
  sharpness for junctions), so that landmarks come before ordinary key points of the same rank.

Ids are stable for the same input and settings: suggestions sorted by decreasing score (ties by position) and
numbered "p0000", "p0001", ... (photo) or "d0000", ... (DEM).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional, Tuple

import numpy as np

from .suggest_photo import picture_mask, to_gray

__all__ = ["PhotoSuggestions", "DemSuggestions", "suggest_photo_points", "suggest_dem_points", "detect_keypoints",
           "spread_by_grid", "thin_evenly", "terrain_landmarks", "silhouette_peaks", "PHOTO_DETECTOR", "DEM_DETECTOR"]


@dataclass
class PhotoSuggestions:
    """Suggested photo points.

    Attributes:
        uv: (N, 2) float64 pixels (u = column, v = row; pixel centres at +0.5, like the rest of Monoplot).
        score: (N,) float64 in [0, 1], decreasing.
        ids: N stable ids "p0000", ...
        source: (N,) str: "orb" or "corner".
    """

    uv: np.ndarray
    score: np.ndarray
    ids: list
    source: np.ndarray

    def __len__(self) -> int:
        return len(self.ids)

    def subset(self, keep) -> "PhotoSuggestions":
        """The suggestions selected by a bool mask or an index array (ids unchanged)."""
        idx = np.flatnonzero(keep) if np.asarray(keep).dtype == bool else np.asarray(keep, dtype=np.int64)
        return PhotoSuggestions(self.uv[idx], self.score[idx], [self.ids[i] for i in idx], self.source[idx])


@dataclass
class DemSuggestions:
    """Suggested DEM points.

    Attributes:
        xyz: (M, 3) float64 map coordinates (DEM CRS; Z from the DEM, metres).
        score: (M,) float64 in [0, 1], decreasing.
        ids: M stable ids "d0000", ...
        kind: (M,) str: "summit", "saddle", "junction", "skyline" (peak of a silhouette seen by the camera), "orb" or
            "corner".
        uv: (M, 2) their pixels in the approximate camera (NaN without a camera).
        prominence: (M,) metres for summits (NaN for the others).
    """

    xyz: np.ndarray
    score: np.ndarray
    ids: list
    kind: np.ndarray
    uv: np.ndarray
    prominence: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __len__(self) -> int:
        return len(self.ids)

    def subset(self, keep) -> "DemSuggestions":
        """The suggestions selected by a bool mask or an index array (ids unchanged)."""
        idx = np.flatnonzero(keep) if np.asarray(keep).dtype == bool else np.asarray(keep, dtype=np.int64)
        return DemSuggestions(self.xyz[idx], self.score[idx], [self.ids[i] for i in idx], self.kind[idx],
                              self.uv[idx], self.prominence[idx])


# ----------------------------------------------------------------------------------------------------------------
# Detectors and spreading (shared by photo and DEM)
# ----------------------------------------------------------------------------------------------------------------
def _percentile_rank(values: np.ndarray) -> np.ndarray:
    """(N,) rank of each value in (0, 1] (1 = the strongest)."""
    n = len(values)
    if n == 0:
        return np.zeros(0)
    order = np.argsort(values, kind="stable")
    rank = np.empty(n)
    rank[order] = np.arange(1, n + 1) / n
    return rank


def detect_keypoints(gray: np.ndarray, mask: Optional[np.ndarray] = None, orb_features: int = 4000,
                     fast_threshold: int = 10, scale_factor: float = 1.2, n_levels: int = 4, edge_threshold: int = 15,
                     patch_size: int = 15, corner_count: int = 4000, corner_quality: float = 0.005,
                     corner_min_distance: float = 5.0, corner_block_size: int = 5) -> Tuple[np.ndarray, np.ndarray,
                                                                                           np.ndarray]:
    """ORB key points and Shi-Tomasi corners of one grey picture.

    Args:
        gray: (H, W) uint8.
        mask: optional (H, W) bool, where to look.
        orb_features, fast_threshold, scale_factor, n_levels, edge_threshold, patch_size: ``cv2.ORB_create``
            settings (``orb_features=0`` switches ORB off).
        corner_count, corner_quality, corner_min_distance, corner_block_size: ``cv2.goodFeaturesToTrack``
            settings (``corner_count=0`` switches corners off).
    Returns:
        (uv (K, 2) pixels with centres at +0.5, score (K,) percentile rank per detector, source (K,) str).
    """
    import cv2

    mask8 = None if mask is None else np.ascontiguousarray(mask, dtype=np.uint8) * 255
    uv, score, source = [], [], []
    if orb_features > 0:
        orb = cv2.ORB_create(nfeatures=int(orb_features), scaleFactor=float(scale_factor), nlevels=int(n_levels),
                             edgeThreshold=int(edge_threshold), patchSize=int(patch_size),
                             fastThreshold=int(fast_threshold))
        kps = orb.detect(gray, mask8)
        if kps:
            uv.append(np.array([k.pt for k in kps], dtype=np.float64) + 0.5)
            score.append(_percentile_rank(np.array([k.response for k in kps])))
            source.append(np.full(len(kps), "orb"))
    if corner_count > 0:
        found = cv2.goodFeaturesToTrack(gray, maxCorners=int(corner_count), qualityLevel=float(corner_quality),
                                        minDistance=float(corner_min_distance), mask=mask8,
                                        blockSize=int(corner_block_size))
        if found is not None and len(found):
            pts = found.reshape(-1, 2).astype(np.float64)
            eig = cv2.cornerMinEigenVal(gray, int(corner_block_size))
            r = eig[np.clip(pts[:, 1].round().astype(int), 0, gray.shape[0] - 1),
                    np.clip(pts[:, 0].round().astype(int), 0, gray.shape[1] - 1)]
            uv.append(pts + 0.5)
            score.append(_percentile_rank(r))
            source.append(np.full(len(pts), "corner"))
    if not uv:
        return np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype="<U6")
    return np.concatenate(uv), np.concatenate(score), np.concatenate(source).astype("<U8")


def spread_by_grid(uv: np.ndarray, score: np.ndarray, size: Tuple[float, float], cell_px: float, per_cell: int,
                   min_distance: float = 0.0) -> np.ndarray:
    """Indices of the points kept by grid bucketing: at most ``per_cell`` best-scored points per ``cell_px``
    square, and none closer than ``min_distance`` to a better one. Sorted by decreasing score.

    >>> uv = np.array([[1.0, 1.0], [2.0, 1.0], [15.0, 1.0]])
    >>> spread_by_grid(uv, np.array([0.5, 0.9, 0.1]), (20, 10), cell_px=10, per_cell=1).tolist()
    [1, 2]
    """
    if len(uv) == 0:
        return np.zeros(0, dtype=np.int64)
    w, _ = size
    ncols = int(math.ceil(w / cell_px)) + 1
    cell = (np.floor(uv[:, 1] / cell_px) * ncols + np.floor(uv[:, 0] / cell_px)).astype(np.int64)
    order = np.lexsort((uv[:, 0], uv[:, 1], -score, cell))
    sorted_cells = cell[order]
    first = np.r_[True, sorted_cells[1:] != sorted_cells[:-1]]
    start = np.maximum.accumulate(np.where(first, np.arange(len(order)), 0))
    rank_in_cell = np.arange(len(order)) - start
    kept = order[rank_in_cell < per_cell]
    kept = kept[np.lexsort((uv[kept, 0], uv[kept, 1], -score[kept]))]
    if min_distance > 0 and len(kept) > 1:
        from scipy.spatial import cKDTree

        tree = cKDTree(uv[kept])
        alive = np.ones(len(kept), dtype=bool)
        for i in range(len(kept)):  # greedy non-maximum suppression in score order
            if alive[i]:
                for j in tree.query_ball_point(uv[kept[i]], min_distance):
                    if j > i:
                        alive[j] = False
        kept = kept[alive]
    return kept


def thin_evenly(uv: np.ndarray, score: np.ndarray, size: Tuple[float, float], count: int) -> np.ndarray:
    """Indices of at most ``count`` points spread over a picture of ``size`` (width, height) pixels.

    A grid with about ``count`` cells covers the picture; the best point of every cell comes first, then the second
    best of every cell, and so on (each round by decreasing score), so that a short list shows every part of the
    picture instead of the few places where the detector scores highest.

    >>> uv = np.array([[1.0, 1.0], [2.0, 2.0], [3.0, 1.0], [15.0, 8.0]])
    >>> thin_evenly(uv, np.array([0.9, 0.8, 0.7, 0.1]), (20, 10), count=2).tolist()
    [0, 3]
    """
    n = len(uv)
    if n <= count:
        return np.lexsort((np.arange(n), -score))
    w, h = size
    cell = math.sqrt(max(w * h, 1.0) / max(count, 1))
    ncols = int(math.ceil(w / cell)) + 1
    finite = np.isfinite(uv).all(axis=1)
    safe = np.where(finite[:, None], uv, 0.0)
    cell_id = (np.floor(safe[:, 1] / cell) * ncols + np.floor(safe[:, 0] / cell)).astype(np.int64)
    order = np.lexsort((np.arange(n), -score, cell_id))
    sorted_cells = cell_id[order]
    first = np.r_[True, sorted_cells[1:] != sorted_cells[:-1]]
    start = np.maximum.accumulate(np.where(first, np.arange(n), 0))
    rank = np.empty(n, dtype=np.int64)
    rank[order] = np.arange(n) - start
    rank[~finite] = n  # points without pixels go last
    return np.lexsort((np.arange(n), -score, rank))[:count]


def _stable_order(score: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.lexsort((a, b, -np.round(score, 12)))


# ----------------------------------------------------------------------------------------------------------------
# Photo
# ----------------------------------------------------------------------------------------------------------------
#: Detector settings of :func:`suggest_photo_points` (dense, small-scale corners: a GCP is a precise spot, and the
#: user's curation needs a suggestion within a few pixels of the feature they recognise; tuned on Aletsch).
PHOTO_DETECTOR = dict(orb_features=4000, fast_threshold=10, corner_count=8000, corner_quality=0.001,
                      corner_min_distance=3.0, corner_block_size=7)
#: Detector settings of :func:`suggest_dem_points` (on the rendering: only clear corners, fewer but sharper).
DEM_DETECTOR = dict(orb_features=4000, fast_threshold=10, corner_count=8000, corner_quality=0.01,
                    corner_min_distance=5.0, corner_block_size=5)


def suggest_photo_points(image: np.ndarray, max_points: int = 8000, cell_px: Optional[float] = None,
                         per_cell: int = 3, min_distance_px: Optional[float] = None, work_size: int = 2000,
                         mask: Optional[np.ndarray] = None, ignore_captions: bool = True,
                         **detector) -> PhotoSuggestions:
    """Suggest photo points worth pairing with the DEM.

    Args:
        image: (H, W) or (H, W, 3) uint8 array (RGB).
        max_points: at most this many suggestions. The default is dense on purpose: the user accepts the few that
            sit on features they recognise. A shorter list is thinned evenly over the picture
            (:func:`thin_evenly`: the best point of each part of the picture first), not cut by score alone.
        cell_px: bucketing cell in full-resolution pixels (default: the long side / 170, 6 px on a 1024 px photo).
        per_cell: at most this many per cell.
        min_distance_px: no two suggestions closer (default: cell_px / 2).
        work_size: the picture is reduced so that its long side is at most this (speed on 24 MP photos);
            coordinates are returned at full resolution.
        mask: optional (H, W) bool, where to look (default :func:`~monoplot_plugin.core.suggest_photo.picture_mask`:
            no blank margins, frame or caption).
        ignore_captions: with the default mask, also remove printed text lines.
        **detector: settings of :func:`detect_keypoints` (ORB and corner detector), over :data:`PHOTO_DETECTOR`.
    Returns:
        :class:`PhotoSuggestions`.
    """
    import cv2

    gray = to_gray(image)
    h, w = gray.shape
    scale = min(1.0, float(work_size) / max(h, w))
    small = cv2.resize(gray, (max(1, round(w * scale)), max(1, round(h * scale))),
                       interpolation=cv2.INTER_AREA) if scale < 1.0 else gray
    if mask is None:
        small_mask = picture_mask(small, ignore_captions=ignore_captions)
    else:
        small_mask = np.asarray(mask, dtype=bool)
        if scale < 1.0:
            small_mask = cv2.resize(small_mask.astype(np.uint8), (small.shape[1], small.shape[0]),
                                    interpolation=cv2.INTER_NEAREST).astype(bool)
    uv, score, source = detect_keypoints(small, small_mask, **{**PHOTO_DETECTOR, **detector})
    uv = uv / scale
    cell = float(cell_px) if cell_px else max(w, h) / 170.0
    min_dist = cell / 2.0 if min_distance_px is None else float(min_distance_px)
    keep = spread_by_grid(uv, score, (w, h), cell, per_cell, min_dist)
    keep = keep[thin_evenly(uv[keep], score[keep], (w, h), max_points)]
    uv, score, source = uv[keep], score[keep], source[keep]
    order = _stable_order(score, uv[:, 0], uv[:, 1])
    uv, score, source = uv[order], score[order], source[order]
    return PhotoSuggestions(uv, score, [f"p{i:04d}" for i in range(len(uv))], source)


# ----------------------------------------------------------------------------------------------------------------
# DEM: terrain landmarks
# ----------------------------------------------------------------------------------------------------------------
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

    z = np.asarray(dem.elevation, dtype=np.float64)
    rows, cols = z.shape
    step = max(1, int(math.ceil(math.sqrt(rows * cols / max_cells))))
    zr = z[:rows - rows % step or rows, :cols - cols % step or cols]
    if step > 1:
        import warnings

        zr = zr[: (zr.shape[0] // step) * step, : (zr.shape[1] // step) * step]
        zr = zr.reshape(zr.shape[0] // step, step, zr.shape[1] // step, step)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-void blocks stay NaN
            zr = np.nanmean(zr, axis=(1, 3))
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


# ----------------------------------------------------------------------------------------------------------------
# DEM: suggestions
# ----------------------------------------------------------------------------------------------------------------
def _render_for_keypoints(res, dem) -> np.ndarray:
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
        norm = np.sqrt(dzdx * dzdx + dzdy * dzdy + 1.0)
        shade = np.zeros(len(x))
        alt = math.radians(40.0)
        for az in (315.0, 45.0, 135.0, 225.0):
            a = math.radians(az)
            lx, ly, lz = math.sin(a) * math.cos(alt), math.cos(a) * math.cos(alt), math.sin(alt)
            shade += np.clip((-dzdx * lx - dzdy * ly + lz) / norm, 0.0, 1.0) / 4.0
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


def _bilinear(grid: np.ndarray, fr: np.ndarray, fc: np.ndarray) -> np.ndarray:
    rows, cols = grid.shape
    fr = np.clip(fr, 0, rows - 1.000001)
    fc = np.clip(fc, 0, cols - 1.000001)
    r = np.floor(fr).astype(np.int64)
    c = np.floor(fc).astype(np.int64)
    r1 = np.minimum(r + 1, rows - 1)
    c1 = np.minimum(c + 1, cols - 1)
    s, t = fc - c, fr - r
    return (grid[r, c] * (1 - s) * (1 - t) + grid[r, c1] * s * (1 - t) + grid[r1, c] * (1 - s) * t
            + grid[r1, c1] * s * t)


def _scaled_camera(camera, max_width: int):
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


def _foreground_xyz(res, uv: np.ndarray, radius: int = 2) -> np.ndarray:
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


def suggest_dem_points(dem, camera=None, max_points: int = 8000, cell_px: Optional[float] = None,
                       per_cell: int = 1, min_distance_px: Optional[float] = None, render_width: int = 1024,
                       view_margin: float = 0.05, max_range: Optional[float] = None, landmarks: bool = True,
                       max_landmarks: int = 300, map_size: int = 2048, **detector) -> DemSuggestions:
    """Suggest DEM points worth pairing with the photo.

    Args:
        dem: :class:`~monoplot_plugin.core.dem.Dem`.
        camera: optional approximate :class:`~monoplot_plugin.core.camera.Camera`. With it, only points it sees
            (z-buffer visibility) inside its picture plus ``view_margin`` are suggested, and key points come from a
            rendering of the DEM from it.
        max_points: most suggestions in all; a shorter list than the candidates is thinned evenly over the
            camera's picture (over the map without a camera), see :func:`thin_evenly`.
        cell_px, per_cell, min_distance_px: spreading of the key points, in pixels of the camera's picture (with a
            camera) or of the map rendering (without); default cell = long side / 128 (8 px of a 1024 px
            rendering), distance = cell / 3.
        render_width: the camera's picture is rendered at most this wide (speed).
        view_margin: fraction of the picture size around it that still counts as "in view".
        max_range: ignore terrain farther from the camera (metres).
        landmarks: add summits, saddles and ridge junctions (:func:`terrain_landmarks`).
        max_landmarks: most landmarks (best first).
        map_size: without a camera, the hillshade is reduced so that its long side is at most this.
        **detector: settings of :func:`detect_keypoints`, over :data:`DEM_DETECTOR`.
    Returns:
        :class:`DemSuggestions` (``uv`` = pixels in ``camera``, NaN without one).
    """
    xyz_list, score_list, kind_list, prom_list = [], [], [], []
    res = None
    if camera is not None:
        from .xyz import compute_xyz_full

        small, scale = _scaled_camera(camera, render_width)
        res = compute_xyz_full(small, dem, max_range=max_range, crop=True, visibility=False)
        img = _render_for_keypoints(res, dem)
        mask = np.asarray(res.hit)
        import cv2

        mask = cv2.dilate(mask.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
        uv, score, source = detect_keypoints(img, mask, **{**DEM_DETECTOR, **detector})
        cell = (float(cell_px) * scale) if cell_px else max(small.width, small.height) / 128.0
        min_dist = cell / 3.0 if min_distance_px is None else float(min_distance_px) * scale
        keep = spread_by_grid(uv, score, small.image_size, cell, per_cell, min_dist)
        pts = _foreground_xyz(res, uv[keep])
        ok = np.isfinite(pts).all(axis=1)
        xyz_list.append(pts[ok])
        score_list.append(score[keep][ok])
        kind_list.append(source[keep][ok])
        prom_list.append(np.full(int(ok.sum()), np.nan))
        if landmarks:
            spts, sstrength = silhouette_peaks(res)
            if len(spts):
                xyz_list.append(spts)
                score_list.append(0.5 + 0.5 * _percentile_rank(sstrength))
                kind_list.append(np.full(len(spts), "skyline"))
                prom_list.append(np.full(len(spts), np.nan))
    else:
        import cv2

        scale = min(1.0, float(map_size) / max(dem.shape))
        view = dem
        if scale < 1.0:  # shade a reduced grid (same extent): hillshades of 25 M cells take seconds
            size = (max(2, round(dem.cols * scale)), max(2, round(dem.rows * scale)))
            small_z = cv2.resize(np.nan_to_num(dem.elevation.astype(np.float32), nan=np.float32(np.nanmin(
                dem.elevation))), size, interpolation=cv2.INTER_AREA)
            g = dem.geotransform
            sx, sy = dem.cols / size[0], dem.rows / size[1]
            view = type(dem).from_array(small_z, (g[0], g[1] * sx, g[2] * sy, g[3], g[4] * sx, g[5] * sy))
        shade = np.zeros(view.shape)
        for az in (315.0, 45.0, 135.0, 225.0):
            shade += np.nan_to_num(view.hillshade(az, 40.0), nan=0.0) / 4.0
        img = np.clip(30 + 200 * shade, 0, 255).astype(np.uint8)
        img = cv2.createCLAHE(clipLimit=4.0, tileGridSize=(8, 8)).apply(img)
        valid = np.isfinite(dem.elevation)
        if scale < 1.0:
            valid = cv2.resize(valid.astype(np.uint8), (img.shape[1], img.shape[0]),
                               interpolation=cv2.INTER_NEAREST).astype(bool)
        valid = cv2.erode(valid.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
        uv, score, source = detect_keypoints(img, valid, **{**DEM_DETECTOR, **detector})
        cell = float(cell_px) if cell_px else max(img.shape) / 128.0
        min_dist = cell / 3.0 if min_distance_px is None else float(min_distance_px)
        keep = spread_by_grid(uv, score, (img.shape[1], img.shape[0]), cell, per_cell, min_dist)
        colf, rowf = uv[keep, 0] / scale, uv[keep, 1] / scale
        x, y = dem.cell_to_map(colf, rowf)
        zz = dem.sample(x, y)
        pts = np.stack([np.atleast_1d(x), np.atleast_1d(y), np.atleast_1d(zz)], axis=1)
        ok = np.isfinite(pts).all(axis=1)
        xyz_list.append(pts[ok])
        score_list.append(score[keep][ok])
        kind_list.append(source[keep][ok])
        prom_list.append(np.full(int(ok.sum()), np.nan))

    if landmarks:
        lxyz, lkind, lstrength, lprom = terrain_landmarks(dem)
        if len(lxyz):
            if res is not None:
                seen = _visible_in_view(dem, camera, lxyz, view_margin)
                lxyz, lkind, lstrength, lprom = lxyz[seen], lkind[seen], lstrength[seen], lprom[seen]
            lscore = np.zeros(len(lxyz))
            for k in np.unique(lkind):
                sel = lkind == k
                lscore[sel] = 0.5 + 0.5 * _percentile_rank(lstrength[sel])
            top = np.argsort(-lscore, kind="stable")[:max_landmarks]
            xyz_list.append(lxyz[top])
            score_list.append(lscore[top])
            kind_list.append(lkind[top])
            prom_list.append(lprom[top])

    xyz = np.concatenate(xyz_list) if xyz_list else np.zeros((0, 3))
    score = np.concatenate(score_list) if score_list else np.zeros(0)
    kind = np.concatenate(kind_list).astype("<U8") if kind_list else np.zeros(0, dtype="<U8")
    prom = np.concatenate(prom_list) if prom_list else np.zeros(0)
    if camera is not None and len(xyz):
        uv, depth = camera.project_with_depth(xyz)
        inside = camera.in_image(uv, margin=view_margin * max(camera.image_size)) & (depth > 0)
        xyz, score, kind, prom, uv = xyz[inside], score[inside], kind[inside], prom[inside], uv[inside]
    else:
        uv = np.full((len(xyz), 2), np.nan)
    # Landmarks first where a key point falls on the same spot (within a third of a DEM cell: duplicates).
    order = _stable_order(score, xyz[:, 0], xyz[:, 1])
    if len(order) > max_points:  # a short list spread over the camera's picture (or the map), not all on one ridge
        spread_uv = uv if camera is not None else np.stack(dem.map_to_cell(xyz[:, 0], xyz[:, 1]), axis=1)
        spread_size = camera.image_size if camera is not None else (dem.cols, dem.rows)
        order = order[thin_evenly(spread_uv[order], score[order], spread_size, max_points)]
        order = order[_stable_order(score[order], xyz[order, 0], xyz[order, 1])]
    xyz, score, kind, prom, uv = xyz[order], score[order], kind[order], prom[order], uv[order]
    return DemSuggestions(xyz, score, [f"d{i:04d}" for i in range(len(xyz))], kind, uv, prom)


def _visible_in_view(dem, camera, xyz: np.ndarray, margin: float) -> np.ndarray:
    """(K,) bool: DEM points inside the camera's view (plus margin) and in its line of sight (exact test with
    :func:`~monoplot_plugin.core.xyz.segment_first_hit`; a point is seen when the first terrain hit on the way is
    within one cell of it)."""
    from .xyz import segment_first_hit

    uv, depth = camera.project_with_depth(xyz)
    inside = camera.in_image(uv, margin=margin * max(camera.image_size)) & (depth > 0)
    if not inside.any():
        return inside
    origin = np.asarray(camera.position, dtype=np.float64)
    targets = xyz[inside] + np.array([0.0, 0.0, 1.0])  # a metre above the ground: the point itself is on it
    s = segment_first_hit(dem, np.broadcast_to(origin, targets.shape), targets)
    length = np.linalg.norm(targets - origin, axis=1)
    seen = ~np.isfinite(s) | ((1.0 - s) * length <= 1.5 * dem.cell_size)
    out = inside.copy()
    out[inside] = seen
    return out
