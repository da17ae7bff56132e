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

__all__ = ["skyline_features"]


def skyline_features(image: np.ndarray, mask: Optional[np.ndarray] = None, width: int = 512,
                     min_prominence: float = 0.015) -> Tuple[np.ndarray, np.ndarray]:
    """Summits and notches of the skyline of an (H, W, 3) uint8 RGB photo.

    Args:
        image: the photo.
        mask: optional (H, W) bool picture area (default: the photo suggestions' own, no frame or caption).
        width: working width of the skyline search (pixels).
        min_prominence: least prominence along the boundary, as a share of the picture's height.
    Returns:
        ((K, 2) float64 full-resolution pixels (u, v), centres at +0.5; (K,) str "summit" or "notch"), summits
        first, each kind by prominence.
    """
    from scipy.signal import find_peaks

    from .auto.photo_edges import detect_photo_edges

    pe = detect_photo_edges(image, width=width, mask=mask)
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
