"""Photo files: the one decoder of the dock and Processing (core/photo_file.py), on real files written here."""

import cv2
import numpy as np

from monoplot_plugin.core.photo_file import decode_photo


def _scene(shape=(120, 160)):
    rows, cols = np.mgrid[0:shape[0], 0:shape[1]]
    return (np.sin(rows / 7.0) * np.cos(cols / 11.0) + 1.0) / 2.0  # 0..1, structure everywhere


def test_twelve_bit_data_in_a_sixteen_bit_tiff_keeps_its_contrast(tmp_path):
    """A trial: a camera's 12-bit data (0-4080) in a 16-bit TIFF became 0-16 grey levels ("the photo shows almost no
    structure ... a photo in fog"). It keeps its 256 levels; full-range 16-bit data and 8-bit files are as before."""
    base = _scene()
    for bits in (12, 16):
        stored = np.round(base * (2 ** bits - 1)).astype(np.uint16)
        path = str(tmp_path / f"photo{bits}.tif")
        assert cv2.imwrite(path, np.dstack([stored] * 3))
        rgb = decode_photo(path)
        assert rgb.dtype == np.uint8 and rgb.shape == (120, 160, 3)
        assert rgb.max() >= 250 and rgb.min() <= 5, (bits, rgb.min(), rgb.max())
        assert np.abs(rgb[..., 0].astype(float) - base * 255).max() <= 1.5
    eight = str(tmp_path / "photo8.png")
    assert cv2.imwrite(eight, np.dstack([np.round(base * 255).astype(np.uint8)] * 3))
    assert np.array_equal(decode_photo(eight)[..., 0], np.round(base * 255).astype(np.uint8))
