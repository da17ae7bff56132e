"""Key point detectors and their spreading over a picture, shared by the photo and the DEM suggestions
(:mod:`.suggest`): ORB and Shi-Tomasi corners scored by percentile rank, grid bucketing, even thinning."""

from __future__ import annotations

import math
from typing import Optional, Tuple

import numpy as np

__all__ = ["detect_keypoints", "spread_by_grid", "thin_evenly", "percentile_rank", "stable_order"]


def percentile_rank(values: np.ndarray) -> np.ndarray:
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
            score.append(percentile_rank(np.array([k.response for k in kps])))
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
            score.append(percentile_rank(r))
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


def stable_order(score: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.lexsort((a, b, -np.round(score, 12)))
