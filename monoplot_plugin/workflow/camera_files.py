"""Camera files, for the dock and Processing: the one reader of a Monoplot camera JSON or a KML PhotoOverlay.

Writers: :meth:`~monoplot_plugin.core.camera.Camera.to_json` (through ``outputs.safe_write.write_text``) and
:func:`~monoplot_plugin.outputs.camera_kml.write_camera_kml`.
"""

from __future__ import annotations

import json
import os
from typing import Optional, Tuple

from ..core.camera import Camera
from .inputs import InputError, _crs_name, check_camera, read_text

__all__ = ["load_camera", "save_camera"]


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


def save_camera(path: str, camera: Camera, name: str = "Monoplot camera") -> None:
    """Write ``camera`` to ``path``: a KML PhotoOverlay for ``.kml`` (position, angles, field of view only), else
    Monoplot's camera JSON (everything). Through a temporary file; an existing file is replaced."""
    from ..outputs.safe_write import write_text

    if str(path).lower().endswith(".kml"):
        from ..outputs.camera_kml import write_camera_kml

        write_camera_kml(path, camera, name=name, overwrite=True)
    else:
        write_text(path, camera.to_json(), overwrite=True)
