"""The picture area of scanned prints: paper border, frame line, caption and the scanner's strips along the edges."""

import numpy as np
import pytest

from monoplot_plugin.core.suggest_photo import box_beyond_captions, picture_box, picture_mask

cv2 = pytest.importorskip("cv2")

PIC = (52, 452, 36, 636)  # rows, columns of the picture in scanned_print's page


def textured_picture(h=400, w=600, seed=0, low=0, high=255):
    rng = np.random.default_rng(seed)
    base = cv2.equalizeHist(cv2.GaussianBlur(rng.integers(0, 255, (h, w)).astype(np.uint8), (0, 0), 3))
    return (low + base.astype(np.float32) * (high - low) / 255.0).astype(np.uint8)


def scanned_print(paper=235, strip=8, right=12, bottom=8, wedge=0, top=0, left=0, pale_sky=False, narrow_top=0):
    """A print as a trial's generator made it: picture at PIC, uneven paper border, a frame line 4 px outside the
    picture, a caption in a wide bottom margin, and the scanner's strip of grey ``strip`` past the paper on the
    right (``right`` px, ``wedge`` px more at the bottom: the print turned a little), at the bottom, top and left.
    ``pale_sky``: the picture's top rows as pale as the paper; ``narrow_top``: px less paper above the picture."""
    rng = np.random.default_rng(3)
    page = (paper + rng.normal(0, 3, (560, 700))).clip(0, 255).astype(np.uint8)
    r0, r1, c0, c1 = PIC
    page[r0:r1, c0:c1] = textured_picture()
    if pale_sky:
        page[r0:r0 + 40, c0:c1] = page[r0:r0 + 40, c0:c1] // 16 + paper - 8
    cv2.rectangle(page, (c0 - 4, r0 - 4), (c1 + 3, r1 + 3), 60, 2)
    cv2.putText(page, "Aletschgletscher vom Eggishorn 1891", (c0 + 40, r1 + 60), cv2.FONT_HERSHEY_SIMPLEX, 0.9,
                40, 2)
    page = page[narrow_top:]
    h, w = page.shape
    widths = np.rint(np.linspace(right, right + wedge, h)).astype(int)
    scan = np.full((top + h + bottom, left + w + right + wedge), strip, np.uint8)
    scan[top:top + h, left:left + w] = page
    for row, width in enumerate(widths):  # the paper reaches as far as the strip leaves it
        scan[top + row, left + w:left + w + right + wedge - width] = page[row, -1]
    return scan


def assert_picture_found(scan, top=0, left=0, few=6):
    """The picture (at PIC in the page, the page at ``top``, ``left`` in the scan) is found within ``few`` px."""
    r0, r1, c0, c1 = PIC[0] + top, PIC[1] + top, PIC[2] + left, PIC[3] + left
    box = box_beyond_captions(scan)[0]
    assert np.allclose(box, (r0, r1, c0, c1), atol=few), box
    mask = picture_mask(scan, beyond_captions=True)
    inside = np.zeros_like(mask)
    inside[r0 + 2 * few:r1 - 2 * few, c0 + 2 * few:c1 - 2 * few] = True
    outside = np.ones_like(mask)
    outside[r0 - few:r1 + few, c0 - few:c1 + few] = False
    assert mask[inside].all() and not mask[outside].any()  # border, strips and caption out; the picture kept


def test_a_black_scanner_strip_on_two_sides_does_not_hide_the_border():
    """A trial's scan had a 14 px black strip on the right and 9 px at the bottom: no paper was found, the border
    and caption got map coordinates."""
    scan = scanned_print()
    assert picture_box(scan[:-8, :-12]) == picture_box(scan)  # the same as with the strips cropped off
    assert_picture_found(scan)


def test_a_turned_print_leaves_a_wedge_of_scanner_bed():
    assert_picture_found(scanned_print(right=4, wedge=14))


def test_a_strip_on_every_side_and_a_frame_line_of_its_grey_keep_a_pale_sky_in_the_picture():
    """The strip's grey past its run from the edge is no border: a frame line of that grey near the strip stops the
    border, or the pale sky under it would be taken for paper."""
    scan = scanned_print(strip=45, top=6, left=6, right=6, bottom=6, pale_sky=True, narrow_top=40)
    assert_picture_found(scan, top=6 - 40, left=6)


def test_a_white_lid_past_yellowed_paper():
    assert_picture_found(scanned_print(paper=190, strip=252, right=10, bottom=6))


def test_a_strip_of_the_papers_own_grey_is_paper():
    assert_picture_found(scanned_print(paper=250, strip=250))


def test_a_dark_picture_that_fills_its_frame_keeps_its_dark_edges():
    """A night or dark-forest photo: a black band along its top and right (a night sky, a dark slope) is no scanner
    strip, for inside it is more picture, not paper."""
    dark = textured_picture(low=0, high=70)
    night = dark.copy()
    night[:10] = 3
    night[:, -7:] = 3
    for photo in (dark, night):
        assert picture_box(photo) == (0, 400, 0, 600)
        assert picture_mask(photo, beyond_captions=True).all()


@pytest.mark.parametrize("soften", ["blur", "half", "three_quarters"])
def test_a_strips_soft_edge_from_resampling_or_blur_does_not_hide_the_border(soften):
    """A re-check trial: the same scan at 3/4 or 1/2 size, or blurred by σ 0.8, marked the whole image as the
    picture again (the line between the strip and the paper is a mix of both greys: the strip was dropped, and the
    mixed lines made the paper's grey dark)."""
    scan = scanned_print(bottom=9, right=14)
    scale = {"blur": 1.0, "half": 0.5, "three_quarters": 0.75}[soften]
    if soften == "blur":
        scan = cv2.GaussianBlur(scan, (0, 0), 0.8)
    else:
        scan = cv2.resize(scan, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    box = np.array(box_beyond_captions(scan)[0]) / scale
    assert np.allclose(box, PIC, atol=8), box


def scene_with_edges_of_one_grey(sides=("top", "left"), grey=118, spread=6):
    """A photo that fills its frame, whose edges on ``sides`` are smooth bands of ``grey`` (a blue sky at the top and
    shaded slopes along the left have the same grey) with ``spread`` levels of shading, and a middle textured within
    40 levels of it (most of its edge pixels are within the border test's tolerance too, as in the rendered scenes)."""
    rng = np.random.default_rng(5)
    photo = textured_picture(seed=2, low=grey - 40, high=grey + 40)
    band = (grey + rng.normal(0, 2, photo.shape) + np.linspace(-spread, spread, photo.shape[1])).clip(0, 255)
    bands = {"top": np.s_[:120], "bottom": np.s_[-120:], "left": np.s_[:, :150], "right": np.s_[:, -150:]}
    for side in sides:
        photo[bands[side]] = band[bands[side]].astype(np.uint8)
    return photo


@pytest.mark.parametrize("sides", [("top", "left"), ("top", "left", "bottom")])
def test_a_scene_whose_edges_share_a_grey_on_some_sides_has_no_border(sides):
    """10 of 50 rendered scenes lost 14-91 % of their area to a "border" on one to three sides: paper surrounds a
    print's picture, so a band on some sides only is the scene's own."""
    photo = scene_with_edges_of_one_grey(sides)
    assert picture_box(photo) == (0, 400, 0, 600)
    assert picture_mask(photo, beyond_captions=True).all()


def test_a_print_photographed_under_uneven_light_keeps_its_border():
    """A print photographed (not scanned) has a gradient of light over its paper: 20 levels across, 10 down."""
    scan = scanned_print(right=0, bottom=0).astype(np.float32)
    h, w = scan.shape
    scan += np.linspace(-10, 10, w)[None, :] + np.linspace(-5, 5, h)[:, None]
    assert_picture_found(scan.clip(0, 255).astype(np.uint8))


def test_a_caption_of_two_lines_of_different_sizes_stays_outside_the_picture():
    """A trial's scan of an 1890 print: a title line and a smaller publisher's line under it. The text detector
    found only the title; the border stopped at the second line, and the picture's centre (the principal point)
    was put 70 px too low. Both lines, and a stamp in the top margin, are margin writing."""
    scan = scanned_print()
    r1 = PIC[1]
    cv2.putText(scan, "Verlag der Photoglob Co., Zuerich", (PIC[2] + 180, r1 + 92), cv2.FONT_HERSHEY_PLAIN, 1.0, 50,
                1)
    cv2.putText(scan, "No. 4417", (PIC[2] + 250, PIC[0] - 22), cv2.FONT_HERSHEY_PLAIN, 1.2, 50, 1)
    assert_picture_found(scan)
    assert picture_box(scan) == box_beyond_captions(scan)[0]  # found by the border itself, caption detector or not


def test_a_caption_whose_letters_leave_rows_of_paper_stays_outside_the_picture():
    """A re-check trial's 1900 print, laid out as scanned: white margin, no frame line, a serif title and a
    smaller line under it. In the capitals' upper rows and between the small line's letters, 90 % of a row is
    still paper: the border stopped there, the picture's bottom was put 127 px low, and the fitted pitch was 2
    degrees (7-10 σ) off."""
    rng = np.random.default_rng(5)
    r0, r1, c0, c1 = 50, 1150, 60, 1660
    scan = (247 + rng.normal(0, 2, (r1 + 170, c1 + 60))).clip(0, 255).astype(np.uint8)
    scan[r0:r1, c0:c1] = cv2.resize(textured_picture(h=275, w=400, low=40, high=200), (c1 - c0, r1 - r0))
    cv2.putText(scan, "Der Bergsee unter dem Hohgrat, von der Alphuette aus", (c0 + 170, r1 + 70),
                cv2.FONT_HERSHEY_TRIPLEX, 1.2, 50, 2, cv2.LINE_AA)
    cv2.putText(scan, "Phot. J. Gabler, Interlaken   No. 2214      1900", (c0 + 330, r1 + 125),
                cv2.FONT_HERSHEY_COMPLEX_SMALL, 1.4, 50, 1, cv2.LINE_AA)
    assert np.allclose(box_beyond_captions(scan)[0], (r0, r1, c0, c1), atol=4), box_beyond_captions(scan)[0]


def test_a_caption_on_a_light_strip_between_the_picture_and_a_dark_border_is_not_picture():
    """A trial's grey prints: a dark scanner border all round, the picture, and under it a light strip with the
    caption. The strip was taken for picture: the principal point 45 px low, contours drawn on the caption."""
    rng = np.random.default_rng(8)
    r0, r1, c0, c1 = 45, 885, 45, 1245
    scan = (24 + rng.normal(0, 3, (1020, 1290))).clip(0, 255).astype(np.uint8)
    scan[r0:r1, c0:c1] = cv2.resize(textured_picture(h=280, w=400, low=60, high=200), (c1 - c0, r1 - r0))
    scan[r1:975, c0:c1] = (224 + rng.normal(0, 3, (975 - r1, c1 - c0))).clip(0, 255).astype(np.uint8)
    cv2.putText(scan, "Tafel 2. Blick ins Hochtal, 1912. Phot. Archiv Gletscherkunde Nr. 114", (c0 + 30, r1 + 52),
                cv2.FONT_HERSHEY_SIMPLEX, 0.9, 40, 2, cv2.LINE_AA)
    assert np.allclose(box_beyond_captions(scan)[0], (r0, r1, c0, c1), atol=4), box_beyond_captions(scan)[0]
    rows = np.flatnonzero(picture_mask(scan, beyond_captions=True).any(axis=1))
    assert rows[0] >= r0 and rows[-1] < r1


def test_paper_between_a_frame_line_and_the_picture_is_not_picture():
    """A re-check trial's scan: a frame line 14 px outside the picture. The box runs along the frame line; the
    paper inside it was draped as a white seam along the orthophoto's edges and got suggestions on the picture's
    edge and corners."""
    scan = scanned_print()
    r0, r1, c0, c1 = PIC
    cv2.rectangle(scan, (c0 - 4, r0 - 4), (c1 + 3, r1 + 3), 235, 2)  # the fixture's own frame line: paper again
    cv2.rectangle(scan, (c0 - 16, r0 - 16), (c1 + 15, r1 + 15), 40, 3)
    mask = picture_mask(scan, beyond_captions=True)
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    assert abs(rows[0] - r0) <= 3 and abs(rows[-1] + 1 - r1) <= 3 and abs(cols[0] - c0) <= 3, (rows[0], rows[-1])
    assert abs(cols[-1] + 1 - c1) <= 3
    assert mask[r0 + 8:r1 - 8, c0 + 8:c1 - 8].all()


def test_a_photo_that_fills_its_frame_loses_nothing_to_captions():
    """A desktop trial's 24 MP photo: glyph-like rock and grass near its top and bottom were taken for printed text
    lines, and its products lost the summit and a full-width band (8 % of the picture) without a word. Without a
    paper border there is no print, and no caption is looked for: even letters written into the picture stay."""
    photo = textured_picture(seed=4)
    photo[355:400] = 40  # a dark strip the text is printed on
    cv2.putText(photo, "2019/07/14 14:32 MMMMMMM", (20, 385), cv2.FONT_HERSHEY_SIMPLEX, 0.8, 250, 2)
    assert picture_box(photo) == (0, 400, 0, 600)
    assert picture_mask(photo, beyond_captions=True).all()
    framed = np.full((480, 700), 245, np.uint8)  # the same picture on paper: its caption is found
    framed[40:440, 50:650] = photo
    assert not picture_mask(framed, beyond_captions=True)[40 + 375, 50 + 100]
