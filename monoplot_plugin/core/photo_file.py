"""Photo files -> (H, W, 3) uint8 RGB arrays: the one decoder of the dock (:mod:`..adapters.photo`) and of
Processing and the batch (:mod:`..workflow.files`), so that both see the same pixels (EXIF orientation applied,
grey images on three bands, alpha dropped) and refuse the same broken files."""

from __future__ import annotations

import os

import numpy as np

__all__ = ["PhotoFileError", "decode_photo", "jpeg_truncated"]


class PhotoFileError(ValueError):
    """The file is not a readable photo; the message names the file and says why (it is meant for the user)."""


def decode_photo(path: str) -> np.ndarray:
    """The photo at ``path`` as an (H, W, 3) uint8 RGB array, turned upright by its EXIF orientation.

    Raises:
        PhotoFileError: the file cannot be read, is not an image, is damaged, or is a truncated JPEG.
    """
    import cv2

    name = os.path.basename(path)
    try:  # bytes, then imdecode: cv2.imread cannot open non-ASCII paths on Windows
        data = np.fromfile(path, dtype=np.uint8)
    except OSError as exc:
        raise PhotoFileError(f"cannot read the photo {name}: {exc}") from exc
    if jpeg_truncated(data.tobytes()):
        # libjpeg fills the missing rows with grey and only prints a warning: products would drape grey on terrain
        raise PhotoFileError(f"cannot read the photo {name}: the JPEG file is truncated (its image data ends early; "
                             f"the missing part would be grey)")
    # EXIF orientation applied, as imread; 16 bits kept, to be brought to 8 by the bits the pixels use
    image = cv2.imdecode(data, cv2.IMREAD_COLOR | cv2.IMREAD_ANYDEPTH) if data.size else None
    if image is None or image.size == 0:
        raise PhotoFileError(f"cannot read the photo {name}: not an image file, or a damaged one")
    if image.dtype != np.uint8:
        image = to_8_bits(image)
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)  # 4 times faster than a reversed copy (1.5 MP: 2 ms)


def to_8_bits(image: np.ndarray) -> np.ndarray:
    """A 16-bit (or float) image as uint8, by the bits its values use: a camera's 12-bit data in a 16-bit TIFF
    (0-4095) keeps its contrast (a trial's became 0-16 grey levels, "a photo in fog", when the top 8 of 16 bits
    were kept); full-range 16-bit data loses its low 8 bits, as before. Floats in [0, 1] are scaled by 255.

    >>> to_8_bits(np.array([[0, 2048, 4095]], dtype=np.uint16)).tolist()
    [[0, 128, 255]]
    >>> to_8_bits(np.array([[0, 65535]], dtype=np.uint16)).tolist()
    [[0, 255]]
    """
    if np.issubdtype(image.dtype, np.floating):
        top = 1.0 if float(np.nanmax(image, initial=0.0)) <= 1.0 else 65535.0
        return np.clip(np.nan_to_num(image) * (255.0 / top), 0, 255).astype(np.uint8)
    peak = int(image.max(initial=0))
    bits = max(8, peak.bit_length())
    return (image >> (bits - 8)).astype(np.uint8) if bits > 8 else image.astype(np.uint8)


def jpeg_truncated(data: bytes) -> bool:
    """True for a JPEG whose last scan has no end-of-image marker after it (a cut-off download or copy).

    In entropy-coded data every 0xFF byte is stuffed (0xFF00) or a restart marker (0xFFD0-D7), so the last end of
    image (0xFFD9) comes after the last start of scan (0xFFDA) in a complete file, also with an EXIF thumbnail
    (whose own scan and end come before the main image's) or bytes appended after the end.

    >>> jpeg_truncated(b"\\xff\\xd8\\xff\\xda..scan..\\xff\\xd9"), jpeg_truncated(b"\\xff\\xd8\\xff\\xda..sc")
    (False, True)
    """
    if not data.startswith(b"\xff\xd8"):
        return False
    return data.rfind(b"\xff\xd9") < data.rfind(b"\xff\xda")
