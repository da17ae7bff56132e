"""Reading the input files of a run without Qt: photos here; camera files (:mod:`.camera_files`) and point tables
(:mod:`.points_csv`) have their own modules, shared with the dock, and are re-exported (Processing and the batch).

Every reader raises :class:`InputError` with a message meant for the user (it names the file and says what is
wrong), which the algorithms turn into a ``QgsProcessingException``.
"""

from __future__ import annotations

from typing import Tuple

import numpy as np

from ..core.photo_file import PhotoFileError, decode_photo
from .camera_files import load_camera  # noqa: F401 (its one home, shared with the dock)
from .inputs import InputError, check_photo_path  # noqa: F401 (InputError)
from .points_csv import MAP_COLUMNS, PHOTO_COLUMNS, read_points_csv, write_points_csv  # noqa: F401 (their home)

__all__ = ["InputError", "load_camera", "read_photo", "photo_size", "read_points_csv", "write_points_csv",
           "PHOTO_COLUMNS", "MAP_COLUMNS"]


def read_photo(path: str) -> np.ndarray:
    """A photo as an (H, W, 3) uint8 RGB array (:func:`~..core.photo_file.decode_photo`, the dock's decoder too)."""
    check_photo_path(path)
    try:
        return decode_photo(path)
    except PhotoFileError as exc:
        raise InputError(str(exc)) from exc


def photo_size(path: str) -> Tuple[int, int]:
    """(width, height) of a photo in pixels (reads the whole image, which also checks that it decodes)."""
    image = read_photo(path)
    return image.shape[1], image.shape[0]
