"""Which suggestions to show first: a spread-out ranking by strength, re-ranked by agreement with a camera.

The person judges a few suggestions at a time (issue 12). This module decides which, with plain arrays (numpy only):

* :func:`spread_order`: an order of N points in which every prefix is spread over the view: the strongest point of
  each cell of a grid first (cells by strength of their best point), then the second strongest of each cell, ...
* :func:`nearest`: for each query point, the nearest reference point and its distance (bucketed, O(N + M)).
* :func:`agreement`: how well each photo / DEM suggestion agrees with a camera: the distance (pixels) from a photo
  suggestion to the nearest projected DEM suggestion, and the other way round.
* :func:`priority`: strength and agreement combined into one ranking key (the agreement weighed by how much it
  says: little where the other view's points are dense for the camera's uncertainty).
* :func:`clutter`: the density of points over a picture, for :func:`priority`; :func:`chance`: how many of them lie
  by chance as near as a camera of some uncertainty puts a true partner.
* :func:`likely_pairs`: mutual nearest photo / projected-DEM suggestions closer than a threshold (and than the
  distance at which a partner is more likely the camera's than chance's).

Shapes: ``xy`` (N, 2) float coordinates (photo pixels ``(u, v)`` or map metres), ``score`` (N,) float (larger =
stronger), projected DEM points ``dem_uv`` (M, 2) pixels with NaN rows for points the camera does not see.
"""

from __future__ import annotations

from typing import Optional, Tuple

import numpy as np

__all__ = ["spread_order", "nearest", "agreement", "priority", "clutter", "chance", "likely_pairs"]


def spread_order(xy: np.ndarray, score: np.ndarray, per_page: int = 30,
                 bounds: Optional[Tuple[float, float, float, float]] = None) -> np.ndarray:
    """(N,) indices of ``xy`` in showing order: each of the first ``per_page`` falls in its own cell of a grid of
    about ``per_page`` cells over ``bounds`` (xmin, ymin, xmax, ymax; default: the points' bounding box), strongest
    cells first; then the runners-up of every cell, and so on. Ties keep the input order.

    >>> xy = np.array([[1, 1], [2, 2], [9, 9], [1, 9]], float)
    >>> spread_order(xy, np.array([5.0, 4.0, 1.0, 2.0]), per_page=4).tolist()
    [0, 3, 2, 1]
    >>> spread_order(np.zeros((0, 2)), np.zeros(0)).tolist()
    []
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    score = np.asarray(score, dtype=np.float64).reshape(-1)
    n = len(xy)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    if bounds is None:
        finite = np.isfinite(xy).all(axis=1)
        lo = xy[finite].min(axis=0) if finite.any() else np.zeros(2)
        hi = xy[finite].max(axis=0) if finite.any() else np.ones(2)
    else:
        lo, hi = np.array(bounds[:2], float), np.array(bounds[2:], float)
    span = np.maximum(hi - lo, 1e-9)
    # cells about square, about per_page of them over the bounds
    aspect = span[0] / span[1]
    nx = min(max(per_page, 1), max(1, int(round(np.sqrt(max(per_page, 1) * aspect)))))
    ny = max(1, int(round(max(per_page, 1) / nx)))
    cx = np.clip(((xy[:, 0] - lo[0]) / span[0] * nx).astype(np.int64, copy=False), 0, nx - 1)
    cy = np.clip(((xy[:, 1] - lo[1]) / span[1] * ny).astype(np.int64, copy=False), 0, ny - 1)
    cell = np.where(np.isfinite(xy).all(axis=1), cy * nx + cx, nx * ny)  # non-finite: a cell of their own
    s = np.where(np.isfinite(score), score, -np.inf)
    by_score = np.lexsort((np.arange(n), -s))  # strongest first, stable
    # rank of each point within its cell (0 = strongest of the cell)
    cells_sorted = cell[by_score]
    order_in_cell = np.lexsort((np.arange(n), cells_sorted))
    grouped = cells_sorted[order_in_cell]
    starts = np.r_[0, np.flatnonzero(np.diff(grouped)) + 1]
    rank_grouped = np.arange(n) - np.repeat(starts, np.diff(np.r_[starts, n]))
    rank = np.empty(n, dtype=np.int64)
    rank[by_score[order_in_cell]] = rank_grouped
    # within one round (same rank), the stronger point first: by_score position breaks the tie
    position = np.empty(n, dtype=np.int64)
    position[by_score] = np.arange(n)
    return np.lexsort((position, rank)).astype(np.int64)


def nearest(query: np.ndarray, ref: np.ndarray, max_distance: float) -> Tuple[np.ndarray, np.ndarray]:
    """For each row of ``query`` (N, 2): (index (N,) of the nearest finite row of ``ref`` (M, 2) within
    ``max_distance``, -1 if none; its distance (N,), inf if none).

    A k-d tree over the finite reference rows: about O((N + M) log M) whatever ``max_distance`` is (10,000 by 10,000
    points in under 10 ms; it runs on the main thread each time suggestions arrive).

    >>> i, d = nearest(np.array([[0, 0], [10, 10.0]]), np.array([[3, 4.0], [50, 50]]), 6.0)
    >>> i.tolist(), d.tolist()
    ([0, -1], [5.0, inf])
    """
    from scipy.spatial import cKDTree

    query = np.asarray(query, dtype=np.float64).reshape(-1, 2)
    ref = np.asarray(ref, dtype=np.float64).reshape(-1, 2)
    best_i = np.full(len(query), -1, dtype=np.int64)
    best_d = np.full(len(query), np.inf)
    ok_ref = np.flatnonzero(np.isfinite(ref).all(axis=1))
    active = np.flatnonzero(np.isfinite(query).all(axis=1))
    if not len(ok_ref) or not len(active) or not max_distance > 0:
        return best_i, best_d
    dist, index = cKDTree(ref[ok_ref]).query(query[active], k=1, distance_upper_bound=float(max_distance))
    found = np.isfinite(dist) & (dist <= max_distance)
    best_i[active[found]] = ok_ref[index[found]]
    best_d[active[found]] = dist[found]
    return best_i, best_d


def agreement(photo_uv: np.ndarray, dem_uv: np.ndarray, radius: float) -> Tuple[np.ndarray, np.ndarray,
                                                                                   np.ndarray, np.ndarray]:
    """How each suggestion agrees with a camera, given ``photo_uv`` (N, 2) and the DEM suggestions projected by it,
    ``dem_uv`` (M, 2) (NaN rows: not seen).

    Returns (photo partner (N,) index into ``dem_uv`` or -1, photo distance (N,) px or inf, DEM partner (M,) index
    into ``photo_uv`` or -1, DEM distance (M,) px or inf), each within ``radius`` pixels.

    >>> p, dp, q, dq = agreement(np.array([[0, 0.0], [100, 0]]), np.array([[1, 0.0], [np.nan, np.nan]]), 10)
    >>> p.tolist(), dp.tolist(), q.tolist(), dq.tolist()
    ([0, -1], [1.0, inf], [0, -1], [1.0, inf])
    """
    pi, pd = nearest(photo_uv, dem_uv, radius)
    di, dd = nearest(dem_uv, photo_uv, radius)
    return pi, pd, di, dd


def priority(score: np.ndarray, distance: Optional[np.ndarray] = None, sigma: float = 15.0,
             clutter: float = 0.0) -> np.ndarray:
    """(N,) ranking key, larger first: the detector ``score`` ranked to [0, 1), plus, with a camera, the agreement
    ``w * exp(-(distance / sigma)^2 / 2)`` (``distance`` (N,) px, inf = no partner).

    ``clutter``: the other view's points per square pixel under the camera (the density a partner is found by
    chance). A nearest partner says little when about ``2 pi clutter sigma^2`` of them lie that close to any spot
    (a rough camera's sigma of 30 px over 2,000 projected DEM points: ~14): the agreement's weight is
    ``w = 1 / (1 + 2 pi clutter sigma^2)``. Then the detector's ranking leads, the agreement only breaks near-ties;
    under a fitted camera (sigma of a few px) w is about 1 and the agreement dominates: a suggestion with a partner
    where the camera says goes before a strong one without. (Without the weight, the rough camera ranked first the
    suggestions in dense texture, which always have some partner near: of the photo suggestions near the features
    a person recognises, half as many on the first 30 pages, on Aletsch and on synthetic scenes.)

    >>> priority(np.array([1.0, 3.0, 2.0])).round(2).tolist()
    [0.0, 0.67, 0.33]
    >>> int(priority(np.array([1.0, 3.0]), np.array([0.0, np.inf])).argmax())
    0
    >>> int(priority(np.array([1.0, 3.0]), np.array([0.0, np.inf]), sigma=30.0, clutter=0.0025).argmax())
    1
    """
    score = np.asarray(score, dtype=np.float64).reshape(-1)
    n = len(score)
    rank = np.empty(n)
    rank[np.argsort(np.where(np.isfinite(score), score, -np.inf), kind="stable")] = np.arange(n)
    key = rank / max(n, 1)
    if distance is None:
        return key
    d = np.asarray(distance, dtype=np.float64).reshape(-1)
    with np.errstate(over="ignore", invalid="ignore"):
        agree = np.where(np.isfinite(d), np.exp(-0.5 * (d / max(sigma, 1e-9)) ** 2), 0.0)
    weight = 1.0 / (1.0 + chance(sigma, clutter))
    return 2.0 * weight * agree + key


def clutter(uv: np.ndarray, size) -> float:
    """Points per square pixel of ``uv`` (N, 2) (NaN rows: not seen) inside a picture of ``size`` (width, height).

    >>> clutter(np.array([[1.0, 1.0], [np.nan, np.nan], [5.0, 2.0], [50.0, 2.0]]), (10, 10))
    0.02
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    w, h = size
    inside = np.isfinite(uv).all(axis=1)
    inside[inside] = (uv[inside, 0] >= 0) & (uv[inside, 0] <= w) & (uv[inside, 1] >= 0) & (uv[inside, 1] <= h)
    return float(inside.sum()) / max(float(w) * float(h), 1.0)


def chance(sigma: float, clutter: float) -> float:
    """About how many points of a view with ``clutter`` points per square pixel lie, by chance, as near to a spot
    as a camera of uncertainty ``sigma`` px puts a true partner: ``2 pi clutter sigma^2``. A nearest partner at
    distance d is the camera's rather than chance's when ``exp(-d^2 / (2 sigma^2)) > chance`` (the density of a
    true partner's position against the density of chance points).

    >>> round(chance(30.0, 0.0025), 1), round(chance(4.0, 0.0025), 2)
    (14.1, 0.25)
    """
    return 2.0 * np.pi * max(float(clutter), 0.0) * float(sigma) ** 2


def likely_pairs(photo_uv: np.ndarray, dem_uv: np.ndarray, threshold: float, sigma: float = 0.0,
                 clutter: float = 0.0) -> np.ndarray:
    """(K, 2) int (photo index, DEM index) of mutual nearest neighbours closer than ``threshold`` pixels, closest
    first. ``photo_uv`` (N, 2), ``dem_uv`` (M, 2) projected DEM suggestions (NaN rows: not seen).

    With the camera's uncertainty ``sigma`` (px) and the views' ``clutter`` (points per px^2, the denser view's),
    also closer than the distance at which a partner is more likely the camera's than chance's (:func:`chance`):
    under a rough camera over dense suggestions, none (a link there is drawn by chance and would be accepted so).

    >>> likely_pairs(np.array([[0, 0.0], [5, 0], [50, 50]]), np.array([[4, 0.0], [52, 50], [90, 90]]), 3).tolist()
    [[1, 0], [2, 1]]
    >>> likely_pairs(np.array([[0, 0.0], [5, 0]]), np.array([[4, 0.0], [90, 90]]), 3, 30.0, 0.0025).tolist()
    []
    """
    c = chance(sigma, clutter)
    if c > 0:
        threshold = min(threshold, sigma * np.sqrt(2.0 * np.log(1.0 / c))) if c < 1.0 else 0.0
    pi, pd, di, _ = agreement(photo_uv, dem_uv, threshold)
    idx = np.flatnonzero((pi >= 0) & (pd <= threshold))
    mutual = idx[di[pi[idx]] == idx]
    order = np.argsort(pd[mutual], kind="stable")
    return np.column_stack([mutual[order], pi[mutual[order]]]).astype(np.int64).reshape(-1, 2)
