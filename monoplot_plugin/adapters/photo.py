"""Photo files -> QImage (EXIF orientation applied; the core's one decoder) and numpy arrays for the core."""

from __future__ import annotations

import os
from typing import Tuple

import numpy as np
from qgis.PyQt.QtGui import QImage

from ..core.photo_file import PhotoFileError, decode_photo

__all__ = ["PhotoError", "read_photo", "qimage_to_array", "array_to_qimage"]


class PhotoError(ValueError):
    """The photo cannot be read (the message is meant for the user)."""


def read_photo(path: str) -> QImage:
    """Read a JPEG/PNG/TIFF photo, turned upright according to its EXIF orientation, with the decoder Processing
    uses (:func:`~..core.photo_file.decode_photo`: the same pixels, the same refusals of broken files).

    Raises:
        PhotoError: unreadable, empty, damaged or truncated file; or a photo under 16 px.
    """
    if not os.path.isfile(path):
        raise PhotoError(f"cannot read the photo {path!r}: " + ("it is a folder" if os.path.isdir(path) else
                                                                 "no such file"))
    try:
        array = decode_photo(path)
    except PhotoFileError as exc:
        raise PhotoError(str(exc)) from exc
    if array.shape[1] < 16 or array.shape[0] < 16:
        raise PhotoError(f"the photo {path!r} is too small ({array.shape[1]} x {array.shape[0]} px)")
    return array_to_qimage(array)


def qimage_to_array(image: QImage) -> np.ndarray:
    """QImage -> (H, W, 3) uint8 RGB array (a copy, safe to hand to a background task)."""
    img = image.convertToFormat(QImage.Format.Format_RGB888)
    h, w, stride = img.height(), img.width(), img.bytesPerLine()
    buf = np.frombuffer(img.constBits().asstring(stride * h), dtype=np.uint8).reshape(h, stride)
    return buf[:, : w * 3].reshape(h, w, 3).copy()


def array_to_qimage(array: np.ndarray) -> QImage:
    """(H, W) gray or (H, W, 3) RGB or (H, W, 4) RGBA uint8 array (or floats in [0, 1]) -> QImage (a copy)."""
    a = np.asarray(array)
    if a.dtype != np.uint8:
        a = np.clip(np.nan_to_num(a.astype(np.float64)) * (255.0 if a.max(initial=0) <= 1.0 else 1.0), 0, 255)
        a = a.astype(np.uint8)
    if a.ndim == 2:
        a = np.ascontiguousarray(a)
        fmt, channels = QImage.Format.Format_Grayscale8, 1
    elif a.shape[2] == 3:
        a = np.ascontiguousarray(a)
        fmt, channels = QImage.Format.Format_RGB888, 3
    else:
        a = np.ascontiguousarray(a[:, :, :4])
        fmt, channels = QImage.Format.Format_RGBA8888, 4
    h, w = a.shape[:2]
    return QImage(a.data, w, h, w * channels, fmt).copy()


def image_size(image: QImage) -> Tuple[int, int]:
    return image.width(), image.height()
