"""The photo's side of the automatic registration: its skyline and its strong terrain edges, at a working size.

The skyline is the path across the columns that, from the top, first meets a strong edge under a smooth sky
(dynamic programming: each column's row maximises the edge strength less the texture above it, with a penalty on
row jumps between neighbouring columns). A column counts as skyline only when the edge is clearly stronger than the
sky's own texture and there is some sky above it; fog, close-ups and blank pictures leave few such columns, and
:attr:`PhotoEdges.usable` then says so. A smooth band of terrain over a contrasting one (a rock face over grass, seen
from a camera looking down) passes those tests too; what it lacks is a sky's colour of its own: when much of the
picture under the line has the colour of what lies above it (:data:`SKY_LIKE_MAX`), the line is no skyline and the
photo has none usable. The sky is reached from the top of the picture area, below a straight edge across it near
its top (:data:`BORDER_BAND`): a print's white margin or frame line left inside the area is no sky, and its edge no
skyline.

Edges: Canny on the smoothed grey picture below the skyline, inside :func:`~..suggest_photo.picture_mask` (no
frame, caption or margin), each with its orientation (modulo 180 degrees) for the oriented chamfer score.

>>> img = np.zeros((60, 80, 3), np.uint8); img[:25] = (120, 160, 230)          # sky above row 25
>>> img[25:] = np.random.default_rng(0).integers(40, 120, (35, 80, 1))          # textured terrain
>>> pe = detect_photo_edges(img, width=80)
>>> pe.usable, abs(float(np.median(pe.sky_row[pe.sky_valid])) - 25.0) <= 1.0
(True, True)
>>> blank = detect_photo_edges(np.full((60, 80, 3), 128, np.uint8), width=80)
>>> blank.usable, blank.sky_fraction
(False, 0.0)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Tuple

import numpy as np

from ..suggest_photo import picture_mask, to_gray

__all__ = ["PhotoEdges", "detect_photo_edges", "N_ORIENTATIONS", "orientation_bin"]

#: Orientation bins of the oriented chamfer score (edge directions modulo 180 degrees).
N_ORIENTATIONS = 6
#: Skyline search: edge strength saturates at CAP (in noise-floor units: any clear edge counts the same, so the
#: first one from the top wins over a stronger one lower down, e.g. snow against a pale sky above a rock band),
#: PEN weighs the texture above the path.
CAP = 4.0
#: Least edge strength (noise-floor units) of a clear skyline column.
VALID = 3.0
#: Least share of the picture's columns with a clear skyline for it to be usable.
SKY_FRACTION_MIN = 0.25
PEN = 0.3
#: Largest share of the picture under the skyline whose colour lies within the spread of the colour above it (CIE
#: Lab, 2 standard deviations, each at least 2 units) for the skyline to be usable. Measured on rendered photos:
#: skylines against the sky 0.00-0.05 (also the Aletsch print, in colour and in grey); a rock face over grass seen
#: from a camera looking down, no sky in the picture, 0.56-0.70.
SKY_LIKE_MAX = 0.3
#: ... in a picture without colour (a grey print, a black-and-white scan), where sky and terrain share their greys
#: and only the sky's smoothness tells them apart: the share of the picture under the skyline within 2 standard
#: deviations of the sky's own smooth shading (a quadratic in u, v: vignetting, a sky's gradient) continued there.
#: Measured at 256-1024 px: grey skylines against the sky 0.00-0.15 (rendered photos, a trial's four grey prints,
#: the Aletsch print scanned on paper; at most 0.08 from 512 px), the rock faces over grass above 0.26-0.71 (by
#: colour, the trial's prints read 0.48: "no clear skyline", though it was traced exactly).
GREY_SKY_LIKE_MAX = 0.2
#: A straight horizontal edge across at least BORDER_SPAN of the picture's columns within the top BORDER_BAND of its
#: height is the picture's own top border (a print's white margin or frame line inside the picture area), not a
#: skyline: the sky is searched below it. A skyline so near the top would leave too thin a sky to count anyway, and
#: mountains are not straight over three quarters of the width.
BORDER_BAND = 0.05
BORDER_SPAN = 0.75


def orientation_bin(theta: np.ndarray) -> np.ndarray:
    """Bin index of edge directions ``theta`` (radians, any range; modulo pi)."""
    t = np.mod(theta, np.pi)
    return np.minimum((t / np.pi * N_ORIENTATIONS).astype(np.int64), N_ORIENTATIONS - 1)


@dataclass
class PhotoEdges:
    """Skyline and edges of a photo at the working size ``(width, height)`` (``scale`` = working / full size).

    Attributes:
        sky_row: (W,) float v of the skyline in each column (working pixels, sub-pixel: the boundary between the
            last sky row and the first terrain row).
        sky_valid: (W,) bool, the column has a clear skyline.
        edges: (H, W) bool edge pixels (skyline included).
        sky_dt: (H, W) float32 distance (working px) to the nearest valid skyline pixel.
        oriented_dt: (N_ORIENTATIONS, H, W) float32 distance to the nearest edge of a similar direction.
        mask: (H, W) bool, the picture area.
        usable: enough clear skyline columns to align on.
        sky_fraction: share of the picture's columns with a clear skyline.
        contrast: median ratio of the skyline's edge strength to the sky's texture.
        sky_like_below: share of the picture under the skyline with the colour of what lies above it
            (:data:`SKY_LIKE_MAX`); NaN when there is no clear skyline.
    """

    width: int
    height: int
    scale: float
    sky_row: np.ndarray
    sky_valid: np.ndarray
    edges: np.ndarray
    sky_dt: np.ndarray
    oriented_dt: np.ndarray
    mask: np.ndarray
    usable: bool
    sky_fraction: float
    contrast: float
    sky_like_below: float = float("nan")


def _skyline_dp(strength: np.ndarray, texture: np.ndarray, mask: np.ndarray, jump: int, jump_cost: float,
                gap: int = 1):
    """(W,) row per column maximising strength - cumulated texture above - jump_cost * |row change|; the texture
    of the ``gap`` rows right above a row is not counted (the edge's own blur). Ties go to the first row change
    from ``-jump`` up.

    numpy, one column at a time over every row change at once: the numba kernel it replaces made QGIS 3.40 crash
    (signal 11 in LLVM's optimiser, compiling it in the warm-up thread of the desktop, 3 runs of 3); this takes
    67 ms against its 22 ms for 384 x 512.

    >>> strength = np.zeros((6, 5)); strength[[3, 3, 1, 3, 3], range(5)] = 1.0
    >>> _skyline_dp(strength, np.zeros((6, 5)), np.ones((6, 5), bool), 1, 0.3).tolist()  # row 1 is 2 jumps away
    [3, 3, 3, 3, 3]
    """
    H, W = strength.shape
    above = np.vstack([np.zeros((gap + 1, W)), np.cumsum(texture, axis=0)[:-gap - 1]])
    gain = np.where(mask, strength - above, -1e9)
    offsets = np.arange(-jump, jump + 1)
    rows = np.arange(H)
    src = rows[None, :] + offsets[:, None]  # (2 jump + 1, H): the row each row change comes from
    outside = (src < 0) | (src >= H)
    src = np.clip(src, 0, H - 1)
    cost = jump_cost * np.abs(offsets).astype(np.float64)[:, None]
    score = gain[:, 0].astype(np.float64)
    back = np.zeros((H, W), dtype=np.int16)
    for c in range(1, W):
        cand = np.where(outside, -np.inf, score[src] - cost)
        arg = np.argmax(cand, axis=0)  # the first best: the smallest row change index, as the loop it replaces
        score = cand[arg, rows] + gain[:, c]
        back[:, c] = offsets[arg]
    path = np.zeros(W, dtype=np.int64)
    path[-1] = int(np.argmax(score))
    for c in range(W - 1, 0, -1):
        path[c - 1] = path[c] + back[path[c], c]
    return path


def detect_photo_edges(image: np.ndarray, width: int = 512, mask=None) -> PhotoEdges:
    """Skyline and oriented edges of an (H, W, 3) uint8 RGB photo reduced to ``width`` columns (never enlarged).

    Args:
        image: the photo.
        width: working width in pixels.
        mask: optional (H, W) bool picture area at full size (default :func:`picture_mask`).
    """
    import cv2

    full_h, full_w = image.shape[:2]
    scale = min(1.0, float(width) / full_w)
    W, H = max(8, int(round(full_w * scale))), max(8, int(round(full_h * scale)))
    rgb = cv2.resize(np.ascontiguousarray(image[..., :3]), (W, H), interpolation=cv2.INTER_AREA) \
        if (W, H) != (full_w, full_h) else np.ascontiguousarray(image[..., :3])
    gray = to_gray(rgb)
    if mask is None:
        pic = picture_mask(gray)
    else:
        pic = cv2.resize(np.asarray(mask, np.uint8), (W, H), interpolation=cv2.INTER_NEAREST).astype(bool)
    sigma = max(0.8, W / 600.0)
    blur = cv2.GaussianBlur(rgb.astype(np.float32), (0, 0), sigma)
    gy = np.abs(cv2.Sobel(blur, cv2.CV_32F, 0, 1, ksize=3)).sum(axis=2) / 8.0
    gx = np.abs(cv2.Sobel(blur, cv2.CV_32F, 1, 0, ksize=3)).sum(axis=2) / 8.0
    mag = np.hypot(gx, gy)
    # Noise floor: the texture of the smoothest tenth of the picture; the sky's texture counts above it only.
    inside = mag[pic] if pic.any() else mag.ravel()
    floor = float(np.percentile(inside, 30)) + 1.0
    texture = np.maximum(mag - 1.5 * floor, 0.0) / floor
    raw = gy / floor
    strength = np.minimum(raw, CAP)
    jump = max(2, int(round(H / 40)))
    gap = int(np.ceil(2 * sigma)) + 1
    pic = _below_top_border(raw, pic, VALID, gap)
    # The picture's own border (a print's margin, a frame) is an edge too: the skyline starts a blur width inside.
    inner = cv2.erode(pic.astype(np.uint8), np.ones((2 * gap + 1, 2 * gap + 1), np.uint8)).astype(bool)
    inner = inner if inner.any() else pic
    # Only the picture's texture weighs on the path: a frame line or paper edge outside it is no texture of the sky
    # (counted, it made any path under the picture's top edge cost more than the edge itself).
    path = _skyline_dp(strength, PEN * texture * inner, inner, jump, 0.3, gap)
    cols = np.arange(W)
    top = np.argmax(inner, axis=0)  # first picture row of each column
    at = raw[path, cols]
    # Clear skyline: an edge well above the noise with at least a few rows of sky over it, in the picture.
    sky_rows = path - top
    sky_tex = np.array([float(np.mean(mag[top[c]:max(top[c] + 1, path[c] - 1), c])) for c in cols]) / floor
    valid = (at >= VALID) & (sky_rows >= max(2, H // 50)) & (at >= 4.0 * np.maximum(sky_tex, 0.5)) & inner[path, cols]
    # Isolated valid columns are chance: keep runs of at least 3 % of the width.
    run = max(3, W // 33)
    k = np.convolve(valid.astype(float), np.ones(run), mode="same")
    valid &= k >= 0.6 * run
    sky_fraction = float(valid.sum()) / max(1, int(pic.any(axis=0).sum()))
    contrast = float(np.median(at[valid] / np.maximum(sky_tex[valid], 0.5))) if valid.any() else 0.0
    boundary = _boundary_rows(raw, path, gap, VALID)
    like, like_max = _sky_like_below(rgb, boundary, valid, top, pic, gap)
    usable = sky_fraction >= SKY_FRACTION_MIN and not like > like_max
    # Terrain edges: Canny below the skyline (clouds are not terrain), inside the picture.
    g8 = cv2.GaussianBlur(gray, (0, 0), sigma)
    med = float(np.median(g8[pic])) if pic.any() else 128.0
    edges = cv2.Canny(g8, max(10.0, 0.33 * med), max(30.0, 0.9 * med), L2gradient=True) > 0
    below = np.arange(H)[:, None] >= (path[None, :] + 1)
    edges &= pic & below
    sky = np.zeros((H, W), dtype=bool)
    sky[path[valid], cols[valid]] = True
    edges |= sky
    theta = np.arctan2(cv2.Sobel(g8.astype(np.float32), cv2.CV_32F, 0, 1, ksize=3),
                       cv2.Sobel(g8.astype(np.float32), cv2.CV_32F, 1, 0, ksize=3)) + np.pi / 2  # edge direction
    # The skyline's direction is that of the path.
    slope = np.gradient(path.astype(np.float64))
    theta[path, cols] = np.arctan2(slope, 1.0)
    sky_dt = _dt(sky, H, W)
    bins = orientation_bin(theta)
    oriented = np.empty((N_ORIENTATIONS, H, W), dtype=np.float32)
    for b in range(N_ORIENTATIONS):
        # Each bin also takes its neighbours' edges: directions near a bin boundary must not be lost.
        near = (bins == b) | (bins == (b + 1) % N_ORIENTATIONS) | (bins == (b - 1) % N_ORIENTATIONS)
        oriented[b] = _dt(edges & near, H, W)
    return PhotoEdges(W, H, scale, boundary, valid, edges, sky_dt, oriented, pic, bool(usable),
                      round(sky_fraction, 3), round(contrast, 2), round(like, 3))


def _below_top_border(raw: np.ndarray, pic: np.ndarray, least: float, tol: int) -> np.ndarray:
    """``pic`` without its rows down to the lowest straight horizontal edge (:data:`BORDER_SPAN`) in its top
    :data:`BORDER_BAND`: a print's margin or frame line left inside the picture area, whose edge (blurred over a few
    rows) was taken for the skyline with a sky a few rows tall over it, or made every path under it too costly.

    ``raw``: (H, W) vertical edge strength in noise-floor units, ``least`` that of a clear edge; ``tol``: rows of
    slack (blur, a slight tilt of the scan) within which a column's edge counts for a row.
    """
    import cv2

    cols = pic.any(axis=0)
    rows = np.flatnonzero(pic.any(axis=1))
    if not cols.any() or len(rows) < 8:
        return pic
    r0 = int(rows[0])
    depth = int(np.ceil(BORDER_BAND * len(rows)))
    strong = ((raw >= least) & pic)[r0:r0 + depth].astype(np.uint8)
    near = cv2.dilate(strong, np.ones((2 * tol + 1, 1), np.uint8)).astype(bool)
    lined = np.flatnonzero(near[:, cols].mean(axis=1) >= BORDER_SPAN)
    if not len(lined):
        return pic
    out = pic.copy()
    out[:r0 + int(lined[-1]) + 1] = False
    return out


def _sky_like_below(rgb: np.ndarray, boundary: np.ndarray, valid: np.ndarray, top: np.ndarray, pic: np.ndarray,
                    gap: int) -> Tuple[float, float]:
    """(share, its limit): the share of the picture under the skyline (``gap`` rows clear of it) whose colour lies
    within 2 standard deviations (each at least 2 Lab units) of the colour above it in the clear columns (limit
    :data:`SKY_LIKE_MAX`); in a picture without colour, of the sky's smooth shading continued under the skyline
    (limit :data:`GREY_SKY_LIKE_MAX`). NaN when either side is empty."""
    import cv2

    H, W = rgb.shape[:2]
    rows = np.arange(H)[:, None]
    above = (rows >= top[None, :]) & (rows < boundary[None, :] - gap) & valid[None, :] & pic
    below = (rows > boundary[None, :] + gap) & pic
    if above.sum() < 20 or below.sum() < 20:
        return float("nan"), SKY_LIKE_MAX
    lab = cv2.cvtColor(rgb.astype(np.float32) / 255.0, cv2.COLOR_RGB2LAB)
    sky = lab[above]
    if _monochrome(lab[pic]):
        terms = _quadratic(*np.nonzero(above)[::-1], W)
        coef = np.linalg.lstsq(terms, sky[:, 0], rcond=None)[0]
        spread = max(float(np.std(sky[:, 0] - terms @ coef)), 2.0)
        v, u = np.nonzero(below)  # the shading continued, within the sky's own greys
        shade = np.clip(_quadratic(u, v, W) @ coef, sky[:, 0].min(), sky[:, 0].max())
        return float(np.mean(np.abs(lab[below][:, 0] - shade) < 2.0 * spread)), GREY_SKY_LIKE_MAX
    mean, spread = sky.mean(axis=0), np.maximum(sky.std(axis=0), 2.0)
    d = np.linalg.norm((lab[below] - mean) / spread, axis=1)
    return float(np.mean(d < 2.0)), SKY_LIKE_MAX


#: A picture whose Lab a and b depart by less than this (standard deviation) from a function of its lightness has no
#: colour to tell sky from terrain: a grey print saved as RGB, or a toned one (sepia: its tint follows the grey).
GREY_CHROMA = 2.0


def _monochrome(lab: np.ndarray) -> bool:
    """Whether the (N, 3) Lab colours are one tint's greys: a and b a quadratic of L within :data:`GREY_CHROMA`."""
    lab = lab[:: max(1, len(lab) // 20000)]
    if len(lab) < 10:
        return False
    terms = np.column_stack([np.ones(len(lab)), lab[:, 0], lab[:, 0] ** 2])
    chroma = lab[:, 1:]
    rest = chroma - terms @ np.linalg.lstsq(terms, chroma, rcond=None)[0]
    return bool(np.max(rest.std(axis=0)) < GREY_CHROMA)


def _quadratic(u: np.ndarray, v: np.ndarray, width: int) -> np.ndarray:
    """(N, 6) the terms of a quadratic in the pixel positions ``u``, ``v`` (scaled by the picture's width)."""
    a, b = np.asarray(u, float) / width, np.asarray(v, float) / width
    return np.column_stack([np.ones_like(a), a, b, a * a, a * b, b * b])


def _boundary_rows(gy: np.ndarray, path: np.ndarray, gap: int, least: float) -> np.ndarray:
    """(W,) sub-pixel v of the sky/terrain boundary in each column: the peak of the vertical gradient ``gy`` (H, W)
    from the path's row down to ``gap`` rows below it, refined by a parabola through the peak and its neighbours.

    The path stops at the first row whose (capped) edge strength is clear, which on a blurred boundary lies a blur
    width above it; the gradient's peak does not. The central difference at row ``r`` is centred on ``v = r + 0.5``,
    so a step between rows ``b - 1`` and ``b`` peaks at ``v = b``, the boundary.
    """
    H, W = gy.shape
    cols = np.arange(W)
    rows = np.clip(path[None, :] + np.arange(-1, gap + 1)[:, None], 0, H - 1)  # (K, W) candidate rows
    g = gy[rows, cols[None, :]]
    # The first clear peak from the top (a stronger edge lower down, e.g. a rock band under a pale summit, is not
    # the skyline): a local maximum of at least ``least``, else the window's strongest.
    up = np.vstack([np.full((1, W), -np.inf), g[:-1]])
    down = np.vstack([g[1:], np.full((1, W), -np.inf)])
    peaks = (g >= up) & (g >= down) & (g >= least)
    k = np.where(peaks.any(axis=0), np.argmax(peaks, axis=0), np.argmax(g, axis=0))
    peak = rows[k, cols]
    a, b, c = gy[np.maximum(peak - 1, 0), cols], gy[peak, cols], gy[np.minimum(peak + 1, H - 1), cols]
    den = a - 2.0 * b + c
    shift = np.where(den < -1e-9, 0.5 * (a - c) / np.where(den < -1e-9, den, -1.0), 0.0)
    return peak + 0.5 + np.clip(shift, -0.5, 0.5)


def _dt(on: np.ndarray, H: int, W: int) -> np.ndarray:
    import cv2

    if not on.any():
        return np.full((H, W), float(H + W), dtype=np.float32)
    return cv2.distanceTransform((~on).astype(np.uint8), cv2.DIST_L2, 3).astype(np.float32)
