"""Can the unpaired fit's camera slide along lines of DEM points? (the aperture problem of nearest-point matching)

Why: an unpaired fit pairs each photo point with the nearest projected DEM point. Where the DEM points lie along a
line (the two edges of a gully, a road, a ridge crest sampled densely), a photo point on that line matches *some*
DEM point wherever the camera slides along it: only the distance across the line is evidence. A camera that moves
every point along its own line keeps the same residuals, and the Jacobian of the pairs cannot show it (it holds the
pairs fixed). A desktop trial on a drone photo had DEM suggestions on two straight features: "ok" at 10 px while
108 px off. Generated (``tests/core/fit/test_aperture.py``): DEM points on two parallel lines seen from 100 m up,
"ok" at 6.6 px RMSE with the camera 28 m along the lines and 384 px off over the terrain.

:func:`slide_sigma_px` keeps only the across-line part of each pair that sits on a line of DEM points and measures
how far the camera can then move the matched points for the same cost.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["line_normals", "across_rows", "across_line_std", "slide_ratio", "slide_sigma_px", "NEIGHBOURS",
           "LINE_ASPECT", "REACH_RADII"]

#: How many of the nearest projected DEM points (besides the matched one) describe its neighbourhood.
NEIGHBOURS = 6
#: The neighbours lie within this many inlier radii of the matched point (a line sampled more sparsely than that
#: leaves only discrete slides, which the stability probes and the competitors test).
REACH_RADII = 8.0
#: A neighbourhood is a line when its width (second singular value) is under this share of its length.
LINE_ASPECT = 0.2


def line_normals(uv: np.ndarray, matched: np.ndarray, reach_px: float) -> np.ndarray:
    """(K, 2) unit normals of the line each matched projected DEM point lies on, NaN where it lies on none.

    ``uv``: (M, 2) projections of the usable DEM points; ``matched``: (K,) indices into ``uv``; ``reach_px``: the
    neighbours considered lie within this distance. A point with fewer than two neighbours there is isolated (its
    match is evidence in both directions); one whose :data:`NEIGHBOURS` nearest neighbours spread in both
    directions lies in a cloud (the consensus score's chance test weighs that).

    >>> uv = np.array([[0.0, 0], [10, 0], [20, 0], [30, 0], [500, 500]])
    >>> n = line_normals(uv, np.array([1, 4]), 50.0)
    >>> np.round(np.abs(n[0]), 6).tolist(), bool(np.isnan(n[1]).all())
    ([0.0, 1.0], True)
    """
    from scipy.spatial import cKDTree

    normals = np.full((len(matched), 2), np.nan)
    if len(uv) < 3 or not len(matched):
        return normals
    k = min(NEIGHBOURS + 1, len(uv))
    dist, idx = cKDTree(uv).query(uv[matched], k=k, distance_upper_bound=reach_px)
    for row, (d, i) in enumerate(zip(dist, idx)):
        near = i[np.isfinite(d)]
        if len(near) < 3:
            continue
        pts = uv[near] - uv[near].mean(axis=0)
        _, s, vt = np.linalg.svd(pts, full_matrices=False)
        if s[1] <= LINE_ASPECT * s[0]:
            normals[row] = vt[1]
    return normals


def across_rows(J: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """``J`` (2K, n) with each pair on a line (finite row of ``normals``, (K, 2)) reduced to its one across-line
    row: (2K - L, n) for L pairs on lines."""
    rows = []
    for k, normal in enumerate(normals):
        pair = J[2 * k:2 * k + 2]
        rows.append(normal[None, :] @ pair if np.isfinite(normal).all() else pair)
    return np.vstack(rows) if rows else J[:0]


def across_line_std(J: np.ndarray, normals: np.ndarray, residual_px: float, names, scales) -> dict:
    """σ of each free parameter (its units) from the across-line evidence only: ``s^2 (Ja^T Ja)^-1``, ``Ja`` from
    :func:`across_rows`, ``s`` the residuals' standard error per coordinate (at least 0.5 px). Empty when no pair
    lies on a line (the pairs' own covariance says it all) or when the camera slides freely.

    >>> J = np.array([[1.0, 0], [0, 1], [1, 0], [0, 1], [1, 0], [0, 1]])
    >>> std = across_line_std(J, np.array([[0.0, 1], [0.0, 1], [np.nan, np.nan]]), 1.0, ("x", "y"), (2.0, 1.0))
    >>> round(std["x"], 3), round(std["y"], 3)
    (2.0, 0.577)
    """
    on_line = np.isfinite(normals).all(axis=1)
    if not on_line.any():
        return {}
    J_across = across_rows(J, normals)
    try:
        cov = np.linalg.inv(J_across.T @ J_across) * max(residual_px, 0.5) ** 2
    except np.linalg.LinAlgError:  # slides freely: the verdict says so (slide_sigma_px), no number means much
        return {}
    variances = np.clip(np.diag(cov), 0.0, None)
    return {name: float(scales[i] * math.sqrt(variances[i])) for i, name in enumerate(names)}


def slide_ratio(J: np.ndarray, normals: np.ndarray) -> float:
    """In [0, 1]: the least across-line cost of a camera change per unit of the pixel motion it causes.

    ``J``: (2K, n) Jacobian of the K pairs' pixel residuals (u, v interleaved); ``normals``: (K, 2) from
    :func:`line_normals`. 1 when no pair lies on a line; near 0 when the camera can slide along the lines.

    >>> J = np.array([[1.0, 0], [0, 1], [1, 0], [0, 1]])      # two pairs, two parameters (a shift in u and v)
    >>> round(slide_ratio(J, np.array([[0.0, 1], [0.0, 1]])), 6), slide_ratio(J, np.full((2, 2), np.nan))
    (0.0, 1.0)
    """
    from scipy.linalg import eigh

    if not np.isfinite(normals).all(axis=1).any():
        return 1.0
    J_across = across_rows(J, normals)
    full, across = J.T @ J, J_across.T @ J_across
    try:
        low = float(eigh(across, full, eigvals_only=True, subset_by_index=[0, 0])[0])
    except (np.linalg.LinAlgError, ValueError):
        return 0.0
    return math.sqrt(min(1.0, max(0.0, low)))


def slide_sigma_px(ratio: float, residual_px: float, n_pairs: int) -> float:
    """σ in pixels (RMS over the pairs) of the camera's worst slide: ``s / (ratio sqrt(K))``, ``s`` the residuals'
    standard error per coordinate (at least 0.5 px). Infinite when the camera slides freely (``ratio`` 0)."""
    if n_pairs <= 0 or ratio <= 0.0:
        return math.inf
    return max(residual_px, 0.5) / (ratio * math.sqrt(n_pairs))
