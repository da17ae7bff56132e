"""The per-pixel XYZ step and its one cache, shared by every product of a fitted camera.

One layout everywhere: (H, W, 3) float64 map coordinates X, Y, Z of the ground seen through each photo pixel, NaN
for the sky (written as the 3-band XYZ GeoTIFF; the distance band is an option of the writer, not of the layout).

The cache holds the last full-resolution result, keyed on *content*: the camera's JSON and a digest of the DEM
(elevations, geotransform, CRS), so that a new Dem object with the same data reuses it and a Dem whose data
differ never does (the key used to be ``id(dem)``, which a new object can reuse after the old one is freed).

A DEM too large to read whole (core :class:`~..core.dem_large.LargeDem`, from :func:`~.inputs.load_dem`) gets the
level-of-detail z-buffer of its file instead (:func:`large_dem_result`): the same layout, exact at full resolution
near the camera.
"""

from __future__ import annotations

import hashlib
import threading
from typing import Optional, Tuple

import numpy as np

from ..core.camera import Camera
from ..core.dem_large import PRODUCT_LOD, is_large
from ..core.xyz import XyzResult, compute_xyz_full
from ..core.xyz_lod import compute_xyz_lod
from .progress import IsCanceled, Progress, check_canceled

__all__ = ["dem_digest", "xyz_key", "xyz_result", "xyz_raster", "xyz_uncached", "large_dem_result", "clear_cache"]

_lock = threading.Lock()
_cache: dict = {}  # one entry: {"key": (camera JSON, DEM digest), "result": XyzResult, "visibility": bool}


def dem_digest(dem) -> str:
    """A digest of what a DEM is (elevations, geotransform, CRS): equal for equal data, whatever the object.

    >>> from monoplot_plugin.core.dem import Dem
    >>> a = Dem.from_array(np.zeros((3, 3)), (0, 1, 0, 3, 0, -1))
    >>> b = Dem.from_array(np.zeros((3, 3)), (0, 1, 0, 3, 0, -1))
    >>> c = Dem.from_array(np.ones((3, 3)), (0, 1, 0, 3, 0, -1))
    >>> dem_digest(a) == dem_digest(b), dem_digest(a) == dem_digest(c)
    (True, False)
    """
    h = hashlib.blake2b(digest_size=16)
    elevation = np.ascontiguousarray(dem.elevation)
    h.update(str((elevation.shape, elevation.dtype.str, tuple(float(v) for v in dem.geotransform),
                  dem.crs_wkt, tuple(getattr(dem, "window", (0, 0))))).encode())
    h.update(memoryview(elevation).cast("B"))
    return h.hexdigest()


def xyz_key(camera: Camera, dem, visibility: bool = False) -> Tuple:
    """The cache key; for a DEM file read by windows (core :class:`~..core.dem_large.LargeDem`) the file's identity,
    and which of its two results (the level-of-detail XYZ, or the preview's with visibility)."""
    if is_large(dem):
        return camera.to_json(), dem.key, "preview" if visibility else "lod"
    return camera.to_json(), dem_digest(dem)


def large_dem_result(camera: Camera, dem, visibility: bool = False,
                     progress: Optional[Progress] = None) -> XyzResult:
    """The XyzResult of a DEM file read by windows: without ``visibility`` the level-of-detail z-buffer of the file
    (:func:`~..core.xyz_lod.compute_xyz_lod` at core ``PRODUCT_LOD``; ``triangle`` is then only
    0 for a hit and -1 for none, ``visible`` empty, ``dem`` the preview); with it, the z-buffer of the preview (for
    the report's map of what the camera sees)."""
    if visibility:
        return compute_xyz_full(camera, dem.preview(), visibility=True)
    lod = compute_xyz_lod(camera, dem.source, lod=PRODUCT_LOD, progress=progress)
    triangle = np.where(lod.factor > 0, 0, -1).astype(np.int32)
    return XyzResult(lod.xyz, lod.distance, triangle, np.zeros((0, 0), dtype=bool), dem, camera)


def xyz_result(camera: Camera, dem, visibility: bool = True, progress: Optional[Progress] = None,
               is_canceled: Optional[IsCanceled] = None) -> XyzResult:
    """The z-buffer of ``dem`` seen from ``camera`` at the photo's full resolution (core
    :func:`compute_xyz_full`): ``.xyz`` (H, W, 3), ``.distance`` (H, W), ``.visible`` per DEM cell when
    ``visibility``. The last result is cached (see the module docstring)."""
    key = xyz_key(camera, dem, visibility)
    with _lock:
        cached = _cache.get("key") == key and (_cache.get("visibility") or not visibility)
        if cached:
            result = _cache["result"]
    if not cached:
        check_canceled(is_canceled)
        if is_large(dem):
            result = large_dem_result(camera, dem, visibility, progress)
        else:
            result = compute_xyz_full(camera, dem, visibility=visibility)
        with _lock:
            _cache.clear()  # one entry: rasters are large
            _cache.update(key=key, result=result, visibility=visibility)
    check_canceled(is_canceled)
    if progress is not None:
        progress(1.0, "")
    return result


def xyz_uncached(camera: Camera, dem) -> np.ndarray:
    """(H, W, 3) XYZ of ``camera`` over ``dem`` without the cache (a batch's per-frame cameras): core
    ``compute_xyz``, or the level-of-detail z-buffer of a DEM file read by windows."""
    if is_large(dem):
        return large_dem_result(camera, dem).xyz
    return compute_xyz_full(camera, dem, visibility=False).xyz


def xyz_raster(camera: Camera, dem, progress: Optional[Progress] = None,
               is_canceled: Optional[IsCanceled] = None) -> np.ndarray:
    """(H, W, 3) map coordinates of the ground seen through every pixel; NaN for sky (cached, see
    :func:`xyz_result`)."""
    return xyz_result(camera, dem, visibility=False, progress=progress, is_canceled=is_canceled).xyz


def cached_result(camera: Camera, dem) -> Optional[XyzResult]:
    """The cached result for this camera and DEM, or None (never computes)."""
    key = xyz_key(camera, dem)
    with _lock:
        return _cache["result"] if _cache.get("key") == key else None


def clear_cache() -> None:
    """Forget the cached result (and the DEM crop it holds)."""
    with _lock:
        _cache.clear()
