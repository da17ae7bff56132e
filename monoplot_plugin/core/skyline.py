"""The skyline's summits and notches as photo suggestions: the features a person recognises first on a mountain
photo, and the photo's side of the DEM's summit and saddle landmarks (:mod:`.landmarks`).

The sky/terrain boundary comes from :func:`~.auto.photo_edges.detect_photo_edges` (at its working width); its local
extremes with enough prominence (in 1-D, as a summit's topographic prominence along the boundary) are refined at
full resolution: within a few pixels, each column's boundary is the strongest downward brightness step, and the
summit is the column where it is highest (the notch: lowest).

>>> img = np.zeros((200, 300, 3), np.uint8); img[:] = (120, 160, 230)            # sky
>>> rows = np.arange(200)[:, None]; cols = np.arange(300)[None, :]
>>> ground = rows >= 60 + np.abs(cols - 150) * 0.5                                # one summit at (150, 60)
>>> img[ground] = 70
>>> uv, kind = skyline_features(img)
>>> [(round(float(u)), round(float(v)), str(k)) for (u, v), k in zip(uv, kind)]
[(150, 60, 'summit')]
"""

from __future__ import annotations

from typing import Optional, Tuple

import numpy as np

__all__ = ["skyline_features", "above_skyline"]

#: Working width of the skyline search (pixels).
SKYLINE_WIDTH = 512


def skyline_features(image: np.ndarray, mask: Optional[np.ndarray] = None, width: int = SKYLINE_WIDTH,
                     min_prominence: float = 0.015, edges=None) -> Tuple[np.ndarray, np.ndarray]:
    """Summits and notches of the skyline of an (H, W, 3) uint8 RGB photo.

    Args:
        image: the photo.
        mask: optional (H, W) bool picture area (default: the photo suggestions' own, no frame or caption).
        width: working width of the skyline search (pixels).
        min_prominence: least prominence along the boundary, as a share of the picture's height.
        edges: the photo's :class:`~.auto.photo_edges.PhotoEdges` at ``width`` when already found.
    Returns:
        ((K, 2) float64 full-resolution pixels (u, v), centres at +0.5; (K,) str "summit" or "notch"), summits
        first, each kind by prominence.
    """
    from scipy.signal import find_peaks

    from .auto.photo_edges import detect_photo_edges

    pe = edges if edges is not None else detect_photo_edges(image, width=width, mask=mask)
    found = []  # (kind, prominence, column of the small picture)
    valid = np.array(pe.sky_valid, dtype=bool)
    v = np.asarray(pe.sky_row, dtype=np.float64)
    min_prom = min_prominence * pe.height
    # runs of clear skyline columns, each on its own; gaps of a few columns (a tree, a weak edge) do not cut them
    holes = np.flatnonzero(~valid)
    for gap in np.split(holes, np.flatnonzero(np.diff(holes) > 1) + 1) if len(holes) else []:
        if len(gap) <= 3 and gap[0] > 0 and gap[-1] < len(valid) - 1:
            valid[gap] = True
    edges = np.flatnonzero(np.diff(np.r_[0, valid.astype(np.int8), 0]))
    for a, b in zip(edges[::2], edges[1::2]):
        if b - a < 5:
            continue
        run = v[a:b]
        for kind, signal in (("summit", -run), ("notch", run)):
            peaks, props = find_peaks(signal, prominence=min_prom)
            for p, prom in zip(peaks, props["prominences"]):
                if 0 < p < len(run) - 1:  # at the run's end the extreme may lie beyond it
                    found.append((kind, float(prom), a + int(p)))
    if not found:
        return np.zeros((0, 2)), np.zeros(0, dtype="<U6")
    found.sort(key=lambda f: (f[0] != "summit", -f[1]))
    uv = np.array([_refine(image, (c + 0.5) / pe.scale, v[c] / pe.scale, 1.5 / pe.scale, kind == "summit")
                   for kind, _, c in found])
    return uv, np.array([f[0] for f in found], dtype="<U6")


def _refine(image: np.ndarray, u: float, v: float, radius: float, summit: bool) -> Tuple[float, float]:
    """(u, v) of the highest (``summit``) or lowest boundary point within ``radius`` pixels of (u, v) in the
    (H, W, 3) ``image``: each column's boundary is its strongest downward step from sky to terrain there."""
    from .suggest_photo import to_gray

    h, w = image.shape[:2]
    r = int(np.ceil(max(2.0, radius)))
    c0, c1 = max(0, int(u) - r), min(w, int(u) + r + 1)
    r0, r1 = max(0, int(v) - 2 * r), min(h - 1, int(v) + 2 * r + 1)
    if c1 - c0 < 1 or r1 - r0 < 2:
        return u, v
    gray = to_gray(np.ascontiguousarray(image[r0:r1 + 1, c0:c1])).astype(np.float32)
    step = np.abs(np.diff(gray, axis=0))  # step[i] between rows r0 + i and r0 + i + 1
    rows = np.argmax(step, axis=0) + r0 + 1.0  # the first terrain row of each column
    j = int(np.argmin(rows) if summit else np.argmax(rows))
    return c0 + j + 0.5, float(rows[j])


def above_skyline(uv: np.ndarray, edges, margin_px: float, reach: float = 0.03) -> np.ndarray:
    """(N,) bool: the full-resolution pixels ``uv`` (N, 2) lie in the sky, more than ``margin_px`` above the clear
    skyline of their column (:class:`~.auto.photo_edges.PhotoEdges` ``edges``); a column without a clear skyline
    takes its nearest clear neighbour's within ``reach`` (a share of the width: the skyline search leaves the
    picture's outermost columns out), else it says False. Nothing in the sky can be a terrain point's partner:
    under the right camera the DEM is below.

    >>> from types import SimpleNamespace
    >>> pe = SimpleNamespace(scale=0.5, width=8, sky_valid=[False] + [True] * 3 + [False] * 4, sky_row=[10.0] * 8)
    >>> above_skyline(np.array([[1.0, 2.0], [3.0, 2.0], [3.0, 19.0], [9.0, 2.0], [15.0, 2.0]]), pe, 4.0).tolist()
    [True, True, False, True, False]
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    if not len(uv):
        return np.zeros(0, dtype=bool)
    valid = np.asarray(edges.sky_valid, dtype=bool)
    clear = np.flatnonzero(valid)
    if not len(clear):
        return np.zeros(len(uv), dtype=bool)
    col = np.clip((uv[:, 0] * edges.scale).astype(int), 0, edges.width - 1)
    at = np.clip(np.searchsorted(clear, col), 1, max(1, len(clear) - 1))
    left, right = clear[at - 1], clear[np.minimum(at, len(clear) - 1)]
    nearest = np.where(np.abs(col - left) <= np.abs(right - col), left, right)
    near = np.abs(nearest - col) <= max(1.0, reach * edges.width)
    row = np.asarray(edges.sky_row, dtype=np.float64)[nearest] / edges.scale
    return near & (uv[:, 1] < row - margin_px)
