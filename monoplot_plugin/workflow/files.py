"""Reading the input files of a run without Qt: photos here; camera files (:mod:`.camera_files`) and point tables
(:mod:`.points_csv`) have their own modules, shared with the dock, and are re-exported (Processing and the batch).

Every reader raises :class:`InputError` with a message meant for the user (it names the file and says what is
wrong), which the algorithms turn into a ``QgsProcessingException``.
"""

from __future__ import annotations

import os
from typing import Tuple

import numpy as np

from .camera_files import load_camera  # noqa: F401 (its one home, shared with the dock)
from .inputs import InputError, check_photo_path  # noqa: F401 (InputError)
from .points_csv import MAP_COLUMNS, PHOTO_COLUMNS, read_points_csv, write_points_csv  # noqa: F401 (their home)

__all__ = ["InputError", "load_camera", "read_photo", "photo_size", "read_points_csv", "write_points_csv",
           "PHOTO_COLUMNS", "MAP_COLUMNS"]


def read_photo(path: str) -> np.ndarray:
    """A photo as an (H, W, 3) uint8 RGB array (grey images are repeated on 3 bands; alpha is dropped)."""
    check_photo_path(path)
    import cv2

    try:  # bytes, then imdecode: cv2.imread cannot open non-ASCII paths on Windows
        data = np.fromfile(path, dtype=np.uint8)
    except OSError as exc:
        raise InputError(f"cannot read the photo {os.path.basename(path)}: {exc}") from exc
    if _jpeg_truncated(data.tobytes()):
        # libjpeg fills the missing rows with grey and only prints a warning: products would drape grey on terrain
        raise InputError(f"cannot read the photo {os.path.basename(path)}: the JPEG file is truncated (its image "
                         f"data ends early; the missing part would be grey)")
    image = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None  # EXIF orientation applied, as imread
    if image is None or image.size == 0:
        raise InputError(f"cannot read the photo {os.path.basename(path)}: not an image file, or a damaged one")
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)  # 4 times faster than a reversed copy (1.5 MP: 2 ms)


def _jpeg_truncated(data: bytes) -> bool:
    """True for a JPEG whose last scan has no end-of-image marker after it (a cut-off download or copy).

    In entropy-coded data every 0xFF byte is stuffed (0xFF00) or a restart marker (0xFFD0-D7), so the last end of
    image (0xFFD9) comes after the last start of scan (0xFFDA) in a complete file, also with an EXIF thumbnail
    (whose own scan and end come before the main image's) or bytes appended after the end.

    >>> _jpeg_truncated(b"\\xff\\xd8\\xff\\xda..scan..\\xff\\xd9"), _jpeg_truncated(b"\\xff\\xd8\\xff\\xda..sc")
    (False, True)
    """
    if not data.startswith(b"\xff\xd8"):
        return False
    return data.rfind(b"\xff\xd9") < data.rfind(b"\xff\xda")


def photo_size(path: str) -> Tuple[int, int]:
    """(width, height) of a photo in pixels (reads the whole image, which also checks that it decodes)."""
    image = read_photo(path)
    return image.shape[1], image.shape[0]
