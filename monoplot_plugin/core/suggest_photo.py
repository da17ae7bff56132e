"""Where to look for GCPs in a photo: the picture area without blank margins, frames and printed captions.

Old prints and scans carry a paper border, a frame line and a printed title; key points there are useless (and a
caption is full of corners). :func:`picture_mask` keeps only the picture itself.

>>> img = np.full((100, 120), 250, np.uint8)            # white paper
>>> img[10:90, 15:105] = np.random.default_rng(0).integers(0, 200, (80, 90))   # the picture
>>> mask = picture_mask(img)
>>> bool(mask[50, 60]), bool(mask[5, 60]), bool(mask[50, 10])
(True, False, False)
"""

from __future__ import annotations

from typing import Optional, Tuple

import numpy as np

__all__ = ["picture_mask", "picture_box", "paper_and_strips", "scanner_strips", "box_beyond_captions",
           "caption_boxes", "to_gray", "coarse_contrast", "FEATURELESS_CONTRAST"]

#: Below this :func:`coarse_contrast` (grey levels) a photo shows almost nothing a person could recognise: its key
#: points are on noise. Measured: a grey frame of pure noise (σ 9 grey levels) 0.4; real photos (Aletsch, old
#: prints, rendered scenes) 38-61.
FEATURELESS_CONTRAST = 3.0


def to_gray(image: np.ndarray) -> np.ndarray:
    """(H, W) uint8 grey levels from an (H, W), (H, W, 3) or (H, W, 4) array (RGB order assumed; the weights are
    those of luma, so BGR inputs give nearly the same result)."""
    image = np.asarray(image)
    if image.ndim == 3:
        image = image[..., :3].astype(np.float32) @ np.array([0.299, 0.587, 0.114], dtype=np.float32)
    if image.dtype != np.uint8:
        image = np.clip(np.rint(image), 0, 255).astype(np.uint8) if image.max() > 1.0 or image.dtype.kind in "iu" \
            else np.clip(np.rint(image * 255.0), 0, 255).astype(np.uint8)
    return image


#: A scanner strip's grey is at most this (the scanner bed's black) or at least :data:`STRIP_BRIGHT` (a white lid).
STRIP_DARK = 60
STRIP_BRIGHT = 230
#: A band along a side at least this fraction of the image's shorter side wide is no scanner strip.
STRIP_MAX_WIDTH = 0.03
#: Between a strip and the paper, up to this fraction of the shorter side (at least 2 lines) may be of neither grey:
#: a resampled or blurred scan mixes them (a trial: at 3/4 size the line after a 7-row black strip was grey 169,
#: the strip was dropped, no paper found, and the border got map coordinates again).
STRIP_SOFT_EDGE = 0.004


def scanner_strips(gray: np.ndarray, tolerance: int = 30) -> Tuple[list, list]:
    """[top, bottom, left, right] widths of candidate scanner strips along the edges, and each strip's grey (None
    where there is none). Candidates only: :func:`paper_and_strips` keeps those followed by paper.

    A scanner strip is the scanner bed (black) or lid (white) seen past a print that did not reach the edge of the
    scan: a thin band of one very dark or very bright grey along a side. Its width is the number of outermost lines
    of which at least half is that grey (half, not all: a slightly turned print leaves a wedge); a band as wide as
    :data:`STRIP_MAX_WIDTH` of the shorter side is no strip but the picture (a night sky, a dark forest) or the paper.
    """
    h, w = gray.shape
    depth = max(2, int(STRIP_MAX_WIDTH * min(h, w)))
    widths, greys = [0, 0, 0, 0], [None, None, None, None]
    for side in range(4):
        band = _from_edge(gray, side)[:depth]
        grey = int(np.median(band[0]))
        if STRIP_DARK < grey < STRIP_BRIGHT:
            continue
        strip = (np.abs(band.astype(np.int16) - grey) <= tolerance).mean(axis=1) >= 0.5
        width = int(np.argmin(strip)) if not strip.all() else depth
        if 0 < width < depth:
            widths[side], greys[side] = width, grey
    return widths, greys


def _from_edge(array: np.ndarray, side: int) -> np.ndarray:
    """A view of ``array`` whose rows are its lines from side 0..3 (top, bottom, left, right) inwards."""
    return (array, array[::-1], array.T, array[:, ::-1].T)[side]


def _ring(gray: np.ndarray) -> np.ndarray:
    return np.concatenate([gray[0], gray[-1], gray[:, 0], gray[:, -1]]).astype(np.int16)


def paper_and_strips(gray: np.ndarray, tolerance: int = 30,
                     paper_fill: float = 0.9) -> Tuple[Optional[int], Tuple[int, ...], list]:
    """(paper grey or None when the photo fills its frame, (top, bottom, left, right) scanner strip widths, their
    greys): the paper is the median of the outermost pixel frame inside the strips, when at least 80 % of that frame
    is within ``tolerance`` of it.

    A trial's scan had a black strip 14 px wide on the right and 9 px at the bottom (under 1 % of the image): half
    of the outermost frame was black, no paper was found and the whole border and caption got map coordinates.
    A strip (:func:`scanner_strips`) is kept only when the line inside it is paper (``paper_fill`` of its pixels):
    a dark picture that fills its frame keeps its dark edges, for inside them is more picture. (A "strip" of the
    paper's own grey is peeled as paper; that is harmless.)
    """
    h, w = gray.shape
    widths, greys = scanner_strips(gray, tolerance)
    soft = max(2, int(STRIP_SOFT_EDGE * min(h, w)))
    while True:
        top, bottom, left, right = widths
        inner = gray[top:h - bottom, left:w - right].astype(np.int16)
        frame = _ring(inner)
        # the paper's grey from past a strip's possible soft edge: its mixed lines, half of the frame when two
        # sides have strips, made the median a dark grey (a blurred scan)
        t, b, le, r = (soft if grey is not None else 0 for grey in greys)
        paper = int(np.median(_ring(inner[t:inner.shape[0] - b, le:inner.shape[1] - r])))
        wrong, widen = [], {}
        for side, grey in enumerate(greys):
            if grey is None:
                continue
            lines = _from_edge(inner, side)[:soft + 1]
            # paper, or the strip's grey (a wedge's rest)
            paper_like = ((np.abs(lines - paper) <= tolerance) | (np.abs(lines - grey) <= tolerance)).mean(
                axis=1) >= paper_fill
            if not paper_like.any():
                wrong.append(side)
            elif not paper_like[0]:
                widen[side] = int(np.argmax(paper_like))  # the strip's soft edge belongs to it
        if not wrong and not widen:
            break
        for side in wrong:  # no paper inside it: the picture's own dark or bright edge, no scanner's
            widths[side], greys[side] = 0, None
        for side, lines_more in widen.items():
            widths[side] += lines_more
    # (No test of the paper's flatness: a print photographed under uneven light has a gradient of 20 levels and
    # more along its border, and many rendered scenes' edges are as flat as paper; the sides test of
    # :func:`picture_box` tells them apart.)
    if np.mean(np.abs(frame - paper) <= tolerance) < 0.8:
        return None, (0, 0, 0, 0), [None] * 4
    return paper, tuple(widths), greys


def picture_box(gray: np.ndarray, tolerance: int = 30, paper_fill: float = 0.9) -> Tuple[int, int, int, int]:
    """(row0, row1, col0, col1) of the picture inside a uniform paper border (the whole image when there is none).

    The paper and any scanner strips outside it come from :func:`paper_and_strips`. From each edge inside the
    strips, rows (columns) are border while at least ``paper_fill`` of their pixels lie within ``tolerance`` grey
    levels of the paper (or of a strip's grey in one run from its side: the rest of a wedge); the first row that is
    not ends the border. (Testing rows from the outside in, rather than counting picture-like rows, keeps white
    snow or pale sky inside the picture.)

    Paper is on every side of the picture, or there is no border: a blue sky at the top and brown slopes along the
    other edges have the same grey, and 10 of 50 rendered scenes (eval.auto) lost 14-91 % of their area to a
    "border" on one to three sides (the sky, or slopes of the sky's grey).
    """
    h, w = gray.shape
    paper, (top, bottom, left, right), greys = paper_and_strips(gray, tolerance, paper_fill)
    if paper is None:
        return 0, h, 0, w  # no uniform border: the photo fills the frame
    inner = gray[top:h - bottom, left:w - right].astype(np.int16)
    like = np.abs(inner - paper) <= tolerance
    depth = max(2, int(STRIP_MAX_WIDTH * min(h, w)))
    for side, grey in enumerate(greys):
        if grey is None:
            continue
        # The rest of a wedge is border too: the strip's grey in one run from the edge (not a frame line of that
        # grey beyond the paper, which kept pale sky inside the picture).
        run = _from_edge(np.abs(inner - grey) <= tolerance, side)[:depth]
        _from_edge(like, side)[:depth] |= np.logical_and.accumulate(run, axis=0)
    r0, r1 = _inner_span(like.mean(axis=1), paper_fill)
    c0, c1 = _inner_span(like.mean(axis=0), paper_fill)
    if r1 - r0 < 0.2 * h or c1 - c0 < 0.2 * w:
        return 0, h, 0, w
    if min(r0, like.shape[0] - r1, c0, like.shape[1] - c1) == 0:
        return 0, h, 0, w  # paper surrounds a print's picture: a "border" on some sides only is the scene's own
    return r0 + top, r1 + top, c0 + left, c1 + left


#: Margin writing (a caption line, a stamp, a note) is a band of lines along a side, no more than this share of the
#: image's extent thick, in which paper still fills at least :data:`TEXT_PAPER` of every line, with paper again on
#: its inner side: the border goes on past it. A frame line (no paper along it) or the picture (paper only in
#: patches) ends the border.
MARGIN_BAND = 0.08
TEXT_PAPER = 0.3


def _border_depth(paper_share: np.ndarray, paper_fill: float) -> int:
    """How many lines from the start of ``paper_share`` (each line's share of paper-grey pixels) are border: paper
    lines, and margin writing with paper beyond it (:data:`MARGIN_BAND`). A trial's scan had a two-line caption
    under the print: the border stopped at its smaller second line, which the text detector missed, and the
    picture's centre was put 70 px too low (the fitted pitch 2.6 degrees off).

    >>> paper = np.array([1.0] * 5 + [0.5] * 3 + [1.0] * 4 + [0.6] * 2 + [1.0] * 3 + [0.0] * 40)
    >>> _border_depth(paper, 0.9), _border_depth(np.array([1.0] * 5 + [0.0] * 2 + [1.0] * 4 + [0.0] * 40), 0.9)
    (17, 5)
    >>> text = [0.85, 0.92, 0.82, 0.91, 0.6, 0.7]  # a line of writing whose rows are partly paper-like
    >>> _border_depth(np.array([1.0] * 5 + text + [1.0] * 6 + [0.0] * 60), 0.9)
    17
    """
    n = len(paper_share)
    is_paper = paper_share >= paper_fill
    band_max, gap_min, depth = max(2, int(MARGIN_BAND * n)), max(2, int(0.004 * n)), 0
    while depth < n and is_paper[depth]:
        depth += 1
    while 0 < depth < n:  # no paper on this side: no border, nothing written in it
        # The band runs to the next run of at least gap_min paper lines: the rows between a text line's letters
        # (or a line of capitals' upper part) can be paper-like, and a band cut there stopped the border inside a
        # re-check trial's two-line caption (the picture's centre 64 px too low, the pitch 2 degrees off, 7-10 σ).
        end = depth
        while end < n and end - depth <= band_max:
            if not is_paper[end]:
                end += 1
                continue
            run = end
            while run < n and is_paper[run]:
                run += 1
            if run - end >= gap_min or run >= n:
                break
            end = run
        beyond = end
        while beyond < n and is_paper[beyond]:
            beyond += 1
        text_like = end - depth <= band_max and float(paper_share[depth:end].min()) >= TEXT_PAPER
        if not text_like or beyond - end < gap_min or beyond >= n or beyond > 0.3 * n:
            break
        depth = beyond
    return depth


def _inner_span(paper_share: np.ndarray, paper_fill: float) -> Tuple[int, int]:
    """(first, end) line of the picture between the border on both sides (:func:`_border_depth`)."""
    n = len(paper_share)
    a = _border_depth(paper_share, paper_fill)
    if a >= n:
        return n, n
    return a, n - _border_depth(paper_share[::-1], paper_fill)


def caption_boxes(gray: np.ndarray, box: Tuple[int, int, int, int], band: float = 0.12) -> list:
    """Boxes (row0, row1, col0, col1) of printed text lines near the top and bottom edges of the picture.

    A text line is a horizontal chain of at least five small, similar-height glyphs (bright on dark or dark on
    bright) within ``band`` x the picture height of its top or bottom edge; natural texture rarely lines up so.

    Only on a print (``box`` inside a paper border): in a photo that fills its frame, rock and grass at 2000 px lined
    up so six times (a desktop trial's rendered 24 MP photo: the products lost its summit and a full-width band, 8 %
    of the picture, unsaid), and letters printed over a picture (Aletsch's caption, on its terrain) have no plain
    ground that would tell them from such texture. A tightly cropped postcard keeps its caption in the products.
    """
    import cv2

    r0, r1, c0, c1 = box
    if box == (0, gray.shape[0], 0, gray.shape[1]):
        return []  # no paper border: a photo, not a print; see the docstring
    h = r1 - r0
    glyph_max = max(6, int(0.05 * h))
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (glyph_max, glyph_max))
    out = []
    band_px = max(glyph_max * 2, int(band * h))
    for top in (r0, r1 - band_px):
        sub = gray[max(r0, top):min(r1, top + band_px), c0:c1]
        if sub.size == 0:
            continue
        for op in (cv2.MORPH_TOPHAT, cv2.MORPH_BLACKHAT):
            hat = cv2.morphologyEx(sub, op, kernel)
            thr = max(40.0, float(np.percentile(hat, 97)))
            glyphs = (hat >= thr).astype(np.uint8)
            n, labels, stats, centroids = cv2.connectedComponentsWithStats(glyphs, connectivity=8)
            hs = stats[1:, cv2.CC_STAT_HEIGHT]
            ws = stats[1:, cv2.CC_STAT_WIDTH]
            keep = (hs >= 4) & (hs <= glyph_max) & (ws <= 2 * glyph_max) & (stats[1:, cv2.CC_STAT_AREA] >= 6)
            if keep.sum() < 5:
                continue
            cy = centroids[1:, 1][keep]
            cx = centroids[1:, 0][keep]
            gh = hs[keep]
            # Group glyphs by their centre row (text lines): rows within half a glyph height of each other.
            order = np.argsort(cy)
            groups, current = [], [order[0]]
            for a, b in zip(order[:-1], order[1:]):
                if cy[b] - cy[a] <= 0.5 * np.median(gh):
                    current.append(b)
                else:
                    groups.append(current)
                    current = [b]
            groups.append(current)
            for grp in groups:
                grp = np.asarray(grp)
                if len(grp) < 5:
                    continue
                xs = np.sort(cx[grp])
                gaps = np.diff(xs)
                # Glyphs of one line are regularly spaced: most gaps below three glyph heights.
                if np.mean(gaps <= 3 * np.median(gh[grp])) < 0.7:
                    continue
                # ... and close together: a line of n glyphs spans a few glyph heights per glyph, not five blobs of
                # a textured picture 300 px apart (a false caption masked the inside of a generated print)
                if xs[-1] - xs[0] > 5.0 * len(grp) * np.median(gh[grp]):
                    continue
                ys = cy[grp]
                half = float(np.median(gh[grp]))
                row_a = int(max(r0, top) + ys.min() - half - 2)
                row_b = int(max(r0, top) + ys.max() + half + 3)
                col_a = int(c0 + xs.min() - 2 * half)
                col_b = int(c0 + xs.max() + 2 * half)
                out.append((max(r0, row_a), min(r1, row_b), max(c0, col_a), min(c1, col_b)))
    return out


def box_beyond_captions(gray: np.ndarray) -> Tuple[Tuple[int, int, int, int], list]:
    """(picture box, caption boxes): :func:`picture_box` found again with the captions painted in the paper's grey,
    so that a caption printed in the margin does not stop the border (the paper between the picture and a caption
    under it was taken for picture: a generated print's products draped a white seam along the near edge).

    >>> import cv2
    >>> img = np.full((300, 400), 250, np.uint8)
    >>> img[20:240, 20:380] = np.random.default_rng(1).integers(0, 200, (220, 360))    # the picture
    >>> _ = cv2.putText(img, "MMMMMMMMMMMMMMM", (30, 275), cv2.FONT_HERSHEY_SIMPLEX, 0.8, 0, 3)  # a caption under it
    >>> box_beyond_captions(img)[0][1]
    240
    """
    box = picture_box(gray)
    captions = caption_boxes(gray, box)
    if not captions:
        return box, captions
    h, w = gray.shape
    paper = paper_and_strips(gray)[0]
    if paper is None:  # no border found: the captions are painted in the grey of the edges, as before strips
        paper = int(np.median(_ring(gray)))
    painted = gray.copy()
    for a, b, c, d in captions:
        painted[a:b, c:d] = paper
    r0, r1, c0, c1 = picture_box(painted)
    if (r0, r1, c0, c1) != (0, h, 0, w):
        box = (max(r0, box[0]), min(r1, box[1]), max(c0, box[2]), min(c1, box[3]))
    return _without_caption_strip(gray, box, captions), captions


#: A caption strip's lines are flat: this share of their pixels within :data:`STRIP_TOLERANCE` of its grey.
STRIP_FLAT = 0.95
STRIP_TOLERANCE = 12
#: ... it is at most this share of the picture box deep, and the picture's line next to it mostly of other greys
#: (a straight edge, where a plain sky ends at a skyline's highest peak first)
STRIP_DEPTH = 0.15
STRIP_EDGE = 0.6


def _without_caption_strip(gray: np.ndarray, box: Tuple[int, int, int, int], captions: list) -> Tuple[int, ...]:
    """``box`` without a strip of flat grey, the caption's own, that runs from its top or bottom edge past a caption
    printed in it: a trial's grey prints had their caption on a light strip between the picture and the scan's dark
    border, and the strip was taken for picture (the principal point 45 px low, contours drawn on the caption).

    >>> img = np.full((300, 400), 20, np.uint8)                                     # a scanner's dark border
    >>> img[20:230, 20:380] = np.random.default_rng(1).integers(40, 200, (210, 360))  # the picture
    >>> img[230:262, 20:380] = 225; img[238:254, 40:300:12] = 30                     # its caption strip, letters
    >>> _without_caption_strip(img, (20, 262, 20, 380), [(238, 254, 40, 300)])
    (20, 230, 20, 380)
    """
    r0, r1, c0, c1 = box
    for a, b, _, _ in captions:
        bottom = a - r0 > (r1 - r0) / 2
        if (bottom and not r0 < a < r1) or (not bottom and not r0 < b < r1):
            continue
        painted = gray[r0:r1, c0:c1].astype(np.int16)
        grey = int(np.median(painted[a - r0:b - r0]))
        for ca, cb, cc, cd in captions:  # the letters, painted in the strip's grey
            painted[max(0, ca - r0):max(0, cb - r0), max(0, cc - c0):max(0, cd - c0)] = grey
        share = (np.abs(painted - grey) <= STRIP_TOLERANCE).mean(axis=1)
        flat, depth = share >= STRIP_FLAT, int(STRIP_DEPTH * len(share))
        if bottom:
            run = np.flatnonzero(~flat[::-1])
            edge = len(flat) - (int(run[0]) if len(run) else len(flat))  # the strip's first line
            # past the caption's top, not deep, and ending on a straight edge (a picture's, not a skyline's peaks
            # over a plain sky or a lake with a title printed on it)
            if len(flat) - depth <= edge < a - r0 and edge > 0 and share[edge - 1] <= 1.0 - STRIP_EDGE:
                r1 = r0 + edge
        else:
            run = np.flatnonzero(~flat)
            edge = int(run[0]) if len(run) else 0
            if b - r0 < edge <= depth and edge < len(flat) and share[edge] <= 1.0 - STRIP_EDGE:
                r0 = r0 + edge
    return r0, r1, c0, c1


#: Paper between a frame line and the picture is looked for this deep inside the picture box (share of its extent).
FRAME_GAP = 0.05


def _paper_inside(gray: np.ndarray, box: Tuple[int, int, int, int], tolerance: int = 30) -> Tuple[int, ...]:
    """(top, bottom, left, right): how many lines inside each edge of the picture box still show paper, the gap
    between a frame line and the picture: up to the last line at least half of the paper's grey, within
    :data:`FRAME_GAP` of the edge (a print scanned a little turned makes the frame line and the gap wedges).
    A re-check trial's scan: the box ran along the outer edge of a frame line 14 px outside the picture; the
    paper between them was draped as a white seam along the orthophoto's near edge, and 21 suggestions sat on
    the picture's edge and corners.

    >>> img = np.full((440, 640), 240, np.uint8); img[20:420, 20:620] = 0; img[23:417, 23:617] = 240
    >>> img[30:410, 30:610] = 90   # a frame line 3 px wide, 7 px of paper, then the picture
    >>> _paper_inside(img, (20, 420, 20, 620))
    (10, 10, 10, 10)
    """
    paper = paper_and_strips(gray, tolerance)[0]
    if paper is None:
        return 0, 0, 0, 0
    r0, r1, c0, c1 = box
    like = np.abs(gray[r0:r1, c0:c1].astype(np.int16) - paper) <= tolerance
    depths = []
    for side in range(4):
        share = _from_edge(like, side).mean(axis=1)
        reach = min(len(share), max(3, int(FRAME_GAP * len(share))))
        papery = share[:reach] >= 0.5  # lines mostly of the paper's grey
        last = int(np.flatnonzero(papery)[-1]) if papery.any() else -1
        # Paper up to the reach is the picture's own (snow, a pale sky), no gap; so is paper in a few lines only.
        gap = 0 <= last < reach - 1 and papery[:last + 1].mean() >= 0.5
        depths.append(last + 1 if gap else 0)
    return tuple(depths)


def picture_mask(image: np.ndarray, inset: float = 0.006, ignore_captions: bool = True,
                 beyond_captions: bool = False) -> np.ndarray:
    """(H, W) bool: True where the photo shows the scene (not paper border, frame line or caption).

    Args:
        image: (H, W) or (H, W, 3) array.
        inset: fraction of the image size removed inside the detected picture edge (frame lines, ragged edges);
            none when the photo fills its frame (no border found) and ``beyond_captions``.
        ignore_captions: also remove printed text lines near the top and bottom of the picture.
        beyond_captions: the border goes on past a caption printed in the margin (:func:`box_beyond_captions`;
            the products' mask: a white seam of paper between the picture and its caption was draped).
    """
    gray = to_gray(image)
    h, w = gray.shape
    if beyond_captions:
        (r0, r1, c0, c1), captions = box_beyond_captions(gray)
        inset = inset if (r0, r1, c0, c1) != (0, h, 0, w) else 0.0
    else:
        r0, r1, c0, c1 = picture_box(gray)
        captions = caption_boxes(gray, (r0, r1, c0, c1)) if ignore_captions else []
    pad = int(round(inset * max(h, w)))
    top, bottom, left, right = _paper_inside(gray, (r0, r1, c0, c1)) if pad else (0, 0, 0, 0)
    mask = np.zeros((h, w), dtype=bool)
    mask[r0 + max(pad, top):max(r0 + pad, r1 - max(pad, bottom)),
         c0 + max(pad, left):max(c0 + pad, c1 - max(pad, right))] = True
    for a, b, c, d in captions if ignore_captions else []:
        mask[a:b, c:d] = False
    return mask


def coarse_contrast(image: np.ndarray, mask: Optional[np.ndarray] = None, width: int = 64) -> float:
    """Contrast of the photo at a coarse scale: the standard deviation (grey levels) of its ``width`` px wide
    thumbnail, inside ``mask`` (default :func:`picture_mask`). Noise and grain average out at that scale; sky and
    terrain, snow and rock, near and far slopes do not.

    >>> noise = np.random.default_rng(0).normal(128, 9, (300, 400)).clip(0, 255).astype(np.uint8)
    >>> coarse_contrast(noise) < FEATURELESS_CONTRAST
    True
    >>> scene = noise.copy(); scene[150:] //= 3                       # terrain darker than the sky
    >>> coarse_contrast(scene) > 10 * FEATURELESS_CONTRAST
    True
    """
    import cv2

    gray = to_gray(image)
    h, w = gray.shape
    size = (max(1, min(w, width)), max(1, round(h * min(w, width) / w)))
    small = cv2.resize(gray, size, interpolation=cv2.INTER_AREA).astype(np.float64)
    keep = picture_mask(gray) if mask is None else np.asarray(mask, dtype=bool)
    keep = cv2.resize(keep.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST).astype(bool)
    values = small[keep] if keep.sum() >= 4 else small.ravel()
    return float(values.std())
