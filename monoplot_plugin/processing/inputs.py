"""Reading the inputs of the algorithms: camera files, photos, point tables. No qgis import here.

Every reader raises :class:`InputError` with a message meant for the user (it names the file and says what is
wrong), which the algorithms turn into a ``QgsProcessingException``.
"""

from __future__ import annotations

import json
import os
from typing import Optional, Tuple

import numpy as np

from ..core.camera import Camera
from ..workflow.inputs import InputError, check_camera, check_photo_path, read_text  # noqa: F401 (InputError)
from ..workflow.points_csv import MAP_COLUMNS, PHOTO_COLUMNS, read_points_csv, write_points_csv  # noqa: F401

__all__ = ["InputError", "load_camera", "read_photo", "photo_size", "read_points_csv", "write_points_csv",
           "PHOTO_COLUMNS", "MAP_COLUMNS"]

def load_camera(path: str, image_size: Optional[Tuple[int, int]] = None, crs_wkt: str = "") -> Camera:
    """A camera from a Monoplot JSON file (:meth:`Camera.save`) or a KML PhotoOverlay.

    Args:
        path: ``.json`` or ``.kml`` file.
        image_size: (width, height) in pixels of the photo; required for KML (which has no image size), and checked
            against the JSON camera's own size when both are known.
        crs_wkt: WKT (or "EPSG:n") of the DEM's CRS; required for KML (given in WGS84).
    """
    if not path:
        raise InputError("no camera file given")
    if not os.path.isfile(path):
        raise InputError(f"camera file not found: {path}")
    if path.lower().endswith(".kml"):
        if image_size is None:
            raise InputError(f"{os.path.basename(path)}: a KML camera needs the photo (for its size)")
        if not crs_wkt:
            raise InputError(f"{os.path.basename(path)}: a KML camera needs the DEM (for its CRS)")
        try:
            return Camera.from_kml(path, image_size=image_size, dst_crs_wkt=crs_wkt)
        except Exception as exc:  # malformed KML: say which file
            raise InputError(f"cannot read the KML camera {os.path.basename(path)}: {exc}") from exc
    if os.path.getsize(path) == 0:
        raise InputError(f"the camera file {os.path.basename(path)} is empty (0 bytes)")
    try:
        camera = Camera.from_json(read_text(path))
    except (OSError, ValueError, TypeError, KeyError, AttributeError, json.JSONDecodeError) as exc:
        raise InputError(f"cannot read the camera file {os.path.basename(path)} "
                         f"(expected Monoplot camera JSON): {exc}") from exc
    check_camera(camera, f"the camera {os.path.basename(path)}")
    if image_size is not None and tuple(camera.image_size) != tuple(image_size):
        raise InputError(f"camera {os.path.basename(path)} is for a {camera.width}x{camera.height} image but the "
                         f"photo is {image_size[0]}x{image_size[1]}")
    if crs_wkt and camera.crs_wkt and not _same_crs(camera.crs_wkt, crs_wkt):
        # its position would be read in the wrong coordinates: the camera sees no DEM, every product is empty
        raise InputError(f"camera {os.path.basename(path)} is in {_crs_name(camera.crs_wkt)} but the DEM is in "
                         f"{_crs_name(crs_wkt)}: use a DEM in the camera's CRS, or fit the camera on this DEM")
    return camera


def _srs(wkt: str):
    from osgeo import osr

    srs = osr.SpatialReference()
    if srs.SetFromUserInput(wkt) != 0:
        return None
    return srs


def _same_crs(a: str, b: str) -> bool:
    """Whether two CRS definitions (WKT, "EPSG:n") are the same; True when either cannot be parsed."""
    sa, sb = _srs(a), _srs(b)
    if sa is None or sb is None:
        return True
    return bool(sa.IsSame(sb, ["IGNORE_DATA_AXIS_TO_SRS_AXIS_MAPPING=YES",
                               "CRITERION=EQUIVALENT_EXCEPT_AXIS_ORDER_GEOGCRS"]))


def _crs_name(wkt: str) -> str:
    srs = _srs(wkt)
    if srs is None:
        return "an unknown CRS"
    code = srs.GetAuthorityCode(None)
    name = srs.GetName() or "an unnamed CRS"
    return f"{name} (EPSG:{code})" if code else name


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
    return np.ascontiguousarray(image[:, :, ::-1])


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
