"""The skyline of a photo printed on paper and scanned: the print's white margin, paper border, frame line and
caption are not the sky's boundary, and the skyline found at each working width is the photo's own (a desktop trial:
a scanned print's skyline search locked onto the picture's top edge, "no clear skyline", at the 1024 px width)."""

import numpy as np
import pytest

from monoplot_plugin.core.auto.photo_edges import detect_photo_edges

WIDTHS = (256, 512, 1024)


def _scanned(picture: np.ndarray, scale: float, seed: int) -> np.ndarray:
    """``picture`` (RGB uint8) as an old print: enlarged ``scale`` times, slightly blurred, sepia, film grain."""
    import cv2

    big = cv2.resize(picture, None, fx=scale, fy=scale, interpolation=cv2.INTER_CUBIC)
    g = cv2.GaussianBlur(cv2.cvtColor(big, cv2.COLOR_RGB2GRAY).astype(np.float32), (0, 0), 1.3)
    g += np.random.default_rng(seed).normal(0.0, 7.0, g.shape)
    return np.clip(np.stack([g, 0.88 * g, 0.72 * g], axis=-1) * 0.93 + 12.0, 0, 255).astype(np.uint8)


def _margin_on_top(picture: np.ndarray, rows: int) -> np.ndarray:
    """A strip of the print's own white margin kept along the top (a scan cropped a little outside the picture)."""
    out = np.vstack([np.zeros((rows,) + picture.shape[1:], np.uint8), picture])
    out[:rows] = (225, 222, 215)
    return out


def _on_paper(picture: np.ndarray, seed: int):
    """(scan, picture mask): ``picture`` on yellowish paper with an uneven border, a dark frame line around it and a
    printed caption under it."""
    import cv2

    h, w = picture.shape[:2]
    top, bottom, left, right, caption = 44, 38, 62, 108, 130
    scan = np.empty((top + h + bottom + caption, left + w + right, 3), np.float32)
    scan[:] = (232, 222, 205)
    scan += np.random.default_rng(seed).normal(0.0, 4.0, scan.shape[:2] + (1,))
    scan[top:top + h, left:left + w] = picture
    cv2.rectangle(scan, (left - 6, top - 6), (left + w + 5, top + h + 5), (70, 60, 60), 2)
    cv2.putText(scan, "Aletschgletscher vom Eggishorn 1891", (left + 60, top + h + bottom + 55),
                cv2.FONT_HERSHEY_SCRIPT_COMPLEX, 1.6, (60, 45, 50), 2, cv2.LINE_AA)
    mask = np.zeros(scan.shape[:2], bool)
    mask[top:top + h, left:left + w] = True
    return np.clip(scan, 0, 255).astype(np.uint8), mask


def _skyline(image, mask=None):
    """{width: (skyline share, median skyline row in the picture's full-size pixels)}."""
    out = {}
    for width in WIDTHS:
        pe = detect_photo_edges(image, width=min(width, image.shape[1]), mask=mask)
        assert pe.usable, (width, pe.sky_fraction)
        out[width] = (pe.sky_fraction, float(np.median(pe.sky_row[pe.sky_valid])) / pe.scale)
    return out


@pytest.fixture(scope="module")
def aletsch_photo(aletsch_dir):
    import cv2

    return cv2.imread(str(aletsch_dir / "photo.jpg"))[:, :, ::-1].copy()


def test_aletsch_print_skyline_is_the_photos_at_every_width(aletsch_photo):
    """The Aletsch photo cropped inside its white border but for a thin strip at the top, printed, scanned 1.6 times
    larger: at each working width the skyline share is the photo's and the skyline lies where the photo's does."""
    crop = (8, 25, 30, 10)  # top, bottom, left, right: a few rows of the photo's own white border stay on top
    pic = aletsch_photo[crop[0]:-crop[1], crop[2]:-crop[3]]
    scale = 1.6
    original = _skyline(aletsch_photo)
    printed = _scanned(pic, scale, seed=7)
    assert (printed[:5].mean(axis=(0, 2)) > printed[40:60].mean() + 30).all()  # a bright margin strip on top
    on_paper, mask = _on_paper(printed, seed=7)
    found = {"cropped print": _skyline(printed), "on paper": _skyline(on_paper),
             "on paper, its picture given": _skyline(on_paper, mask)}
    for name, widths in found.items():
        for width, (share, row) in widths.items():
            top = 44 if name.startswith("on paper") else 0
            share_original = original[width][0] * (1.0 if top == 0 else mask.any(axis=0).mean())
            row_original = (original[width][1] - crop[0]) * scale + top
            assert share > share_original - 0.1, (name, width, share, share_original)
            assert abs(row - row_original) < 0.02 * printed.shape[0], (name, width, row, row_original)


@pytest.mark.parametrize("margin", [0.01, 0.03])
def test_rendered_print_with_a_white_strip_on_top(valley, margin):
    """A rendered photo, printed 3 times larger with a white strip along its top (1 or 3 % of its height): the
    skyline share at each width is that of the photo itself."""
    _, _, photo = valley
    printed = _scanned(photo, 3.0, seed=1)
    with_margin = _margin_on_top(printed, int(round(margin * printed.shape[0])))
    clean = _skyline(printed)
    for width, (share, _) in _skyline(with_margin).items():
        assert abs(share - clean[width][0]) < 0.08, (width, share, clean[width][0])
