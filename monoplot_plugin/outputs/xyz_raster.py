"""The XYZ raster: a photo-sized GeoTIFF whose pixels hold the ground coordinates seen through them.

Layout (``MONOPLOT_FORMAT=monoplot-xyz/1`` in the dataset metadata):

- Bands 1-3: X, Y, Z (float64, or float32 when that is as exact, see below) in the DEM's CRS (band descriptions
  ``X``, ``Y``, ``Z``; unit type from the CRS, e.g.
  ``metre``). Optional band 4 ``DISTANCE``: metres from the camera centre to the ground point.
- Nodata: NaN in every band for sky, and for pixels whose ray misses the DEM (voids, outside the grid). NaN is the
  one value that can never be a real coordinate.
- Raster space = photo pixel space, not map space. A photo-space raster has no place on the map, so the file has
  **no spatial reference** and the geotransform ``(0, 1, 0, 0, 0, -1)``: raster x = column ``u``, raster y = -row
  ``v`` (the convention of QGIS's georeferencer), so the centre of pixel (row i, column j) lies at
  ``(j + 0.5, -(i + 0.5))`` and the raster shows upright. In QGIS, a layer with no CRS is drawn without
  reprojection, so the identify tool on the XYZ layer (or on the photo canvas, which uses the same pixel space)
  reports "X", "Y", "Z" of the ground point seen through the clicked photo pixel.
- The CRS of the *values* is in the metadata: ``MONOPLOT_VALUE_CRS`` (WKT) and ``MONOPLOT_VALUE_CRS_AUTHID``
  (e.g. ``EPSG:21781``); the camera as JSON in ``MONOPLOT_CAMERA``; the photo's file name in ``MONOPLOT_PHOTO``;
  how sure the camera is (status, fit and check-point RMSE in pixels) in ``MONOPLOT_FIT`` when the writer knows it.
- Beside it, ``name.qml``: the QGIS style of :mod:`.xyz_style` (Z as a colour ramp), which QGIS loads when the
  file is added by hand.
- Tiled 256 x 256, DEFLATE (or LZW) compression with the floating-point predictor, BIGTIFF when needed. DEFLATE at
  level 1: 3 times faster to write than the default level 6 for 3 % more bytes (1.5 MP: 0.3 s against 0.9 s);
  tiles compressed on every core (GDAL's ``NUM_THREADS``).

Precision: every value is stored to 1 cm or better in any CRS. float32 keeps about 7 significant digits (a 7-digit
UTM northing would step by 0.5 m), so the bands are float64 unless every coordinate is below 131,072 map units
(float32 then rounds by at most 4 mm, and the file is half the size). The dock and Processing write the same
layout (both call :func:`write_xyz_raster` with the default ``dtype="auto"``). Plain band values, no scale/offset
metadata: QGIS would apply an offset in float32 and lose the precision again.
"""

from __future__ import annotations

import json
import os
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterable, Optional, Tuple

import numpy as np
from osgeo import gdal

from ._gdal import (crs_authid, gdal_errors_as_exceptions, gdal_failure, linear_unit_name, raster_verifier,
                    srs_from_user)
from .safe_write import OutputError, atomic_output, stop_if_canceled
from .xyz_style import write_xyz_style

__all__ = ["write_xyz_raster", "write_xyz_raster_strips", "read_xyz_raster", "storage_dtype", "storage_dtype_for_range",
           "PHOTO_GEOTRANSFORM", "XYZ_FORMAT"]

#: Geotransform of every photo-space raster Monoplot writes: x = column, y = -row, 1 unit = 1 pixel.
PHOTO_GEOTRANSFORM = (0.0, 1.0, 0.0, 0.0, 0.0, -1.0)
XYZ_FORMAT = "monoplot-xyz/1"
BAND_NAMES = ("X", "Y", "Z", "DISTANCE")


def fit_metadata(fit: Optional[dict]) -> dict:
    """``{"MONOPLOT_FIT": JSON}`` of how sure the camera of a product is (its ``status``, ``message``, ``rmse_px``,
    ``check_rmse_px``, ``n_check``, ``mode``), {} without: the file says what its positions are worth.

    >>> fit_metadata({"status": "uncertain", "rmse_px": 2.5, "points": [1, 2]})
    {'MONOPLOT_FIT': '{"status": "uncertain", "rmse_px": 2.5}'}
    >>> fit_metadata({"status": "ok", "message": "σ 2 m"})
    {'MONOPLOT_FIT': '{"status": "ok", "message": "σ 2 m"}'}
    >>> fit_metadata(None)
    {}
    """
    if not fit:
        return {}
    keep = ("status", "message", "rmse_px", "check_rmse_px", "n_check", "mode")
    # as written (a trial's Information tab read "the camera's \u03c3"): GDAL keeps the metadata as UTF-8
    return {"MONOPLOT_FIT": json.dumps({k: fit[k] for k in keep if fit.get(k) is not None}, ensure_ascii=False)}


def write_xyz_raster(path, xyz: np.ndarray, crs_wkt: str, distance: Optional[np.ndarray] = None, *,
                     overwrite: bool = False, compress: str = "DEFLATE", dtype: str = "auto",
                     camera=None, photo_name: str = "", fit: Optional[dict] = None,
                     progress: Optional[Callable[[float], None]] = None) -> Path:
    """Write the per-pixel ground coordinates of a photo as a GeoTIFF (layout in the module docstring).

    Args:
        path: target ``.tif`` (any Unicode path).
        xyz: (H, W, 3) ground coordinates in ``crs_wkt`` (map units); NaN where the pixel sees sky or no DEM.
        crs_wkt: CRS of the values (the DEM's), WKT or "EPSG:n".
        distance: optional (H, W) metres from the camera to the ground point; written as band 4.
        overwrite: replace an existing file (default: refuse with OutputExistsError).
        compress: "DEFLATE" (default) or "LZW".
        dtype: "auto" (default: float32 when every value is below :data:`FLOAT32_EXACT_LIMIT`, else float64),
            "float32" or "float64".
        camera: optional :class:`~monoplot_plugin.core.camera.Camera`, stored as JSON in the metadata.
        photo_name: optional name of the photo, stored in the metadata.
        fit: optional summary of how sure the camera is (``status``, ``rmse_px``, ``check_rmse_px``, ``n_check``),
            stored as JSON in ``MONOPLOT_FIT``: the file says what its positions are worth.
        progress: optional ``progress(fraction of the rows written)``; a cancel of
            :func:`~.safe_write.cancel_before_commit` acts between parts of a band (OutputCanceled).
    Returns:
        the Path written.
    Raises:
        ValueError for wrong shapes; OutputError (OutputExistsError) when the file cannot be written.
    """
    xyz = np.asarray(xyz)
    if xyz.ndim != 3 or xyz.shape[2] != 3:
        raise ValueError(f"xyz must be (H, W, 3), got {xyz.shape}")
    height, width = xyz.shape[:2]
    if distance is not None:
        distance = np.asarray(distance)
        if distance.shape != (height, width):
            raise ValueError(f"distance must be {(height, width)}, got {distance.shape}")
    return write_xyz_raster_strips(path, [(0, xyz, distance)], width, height, crs_wkt,
                                   storage_dtype(xyz) if dtype == "auto" else dtype, distance is not None,
                                   overwrite=overwrite, compress=compress, camera=camera, photo_name=photo_name,
                                   fit=fit, progress=progress)


def write_xyz_raster_strips(path, strips: Iterable, width: int, height: int, crs_wkt: str, dtype: str,
                            with_distance: bool = False, *, overwrite: bool = False, compress: str = "DEFLATE",
                            camera=None, photo_name: str = "", fit: Optional[dict] = None,
                            progress: Optional[Callable[[float], None]] = None) -> Path:
    """Write the XYZ raster strip by strip (the memory-bounded path: a strip is computed, written, dropped).

    Args:
        strips: ``(row0, (rows, W, 3) xyz, (rows, W) distance or None)`` covering every row once, e.g. core's
            :func:`~monoplot_plugin.core.xyz_strips.xyz_strips`.
        width, height: size of the photo in pixels.
        dtype: "float32" or "float64" (see :func:`storage_dtype`, :func:`storage_dtype_for_range`).
        with_distance: write band 4 from the strips' distances.
        Other arguments as :func:`write_xyz_raster`.
    """
    if compress.upper() not in ("DEFLATE", "LZW"):
        raise ValueError(f"compress must be DEFLATE or LZW, got {compress}")
    gdal_type = {"float32": gdal.GDT_Float32, "float64": gdal.GDT_Float64}[dtype]
    srs = srs_from_user(crs_wkt)
    try:
        unit = linear_unit_name(crs_wkt)
    except (ValueError, RuntimeError):
        unit = ""
    metadata = {
        "MONOPLOT_FORMAT": XYZ_FORMAT,
        "MONOPLOT_VALUE_CRS": srs.ExportToWkt(),
        "MONOPLOT_VALUE_CRS_AUTHID": crs_authid(crs_wkt) or "",
        "MONOPLOT_PIXEL_SPACE": ("x = photo column u, y = -photo row v; "
                                 "pixel (row i, col j) centre at (j+0.5, -(i+0.5))"),
        "MONOPLOT_PHOTO": photo_name,
        "MONOPLOT_CAMERA": camera.to_json(indent=None) if camera is not None else "",
    }
    metadata.update(fit_metadata(fit))
    options = ["TILED=YES", "BLOCKXSIZE=256", "BLOCKYSIZE=256", f"COMPRESS={compress.upper()}", "PREDICTOR=3",
               "BIGTIFF=IF_SAFER", "INTERLEAVE=BAND", "NUM_THREADS=ALL_CPUS"]  # tiles compressed on every core
    if compress.upper() == "DEFLATE":
        options.append("ZLEVEL=1")
    nbands = 4 if with_distance else 3
    target = Path(os.fspath(path))
    with atomic_output(target, overwrite, verify=raster_verifier(width, height, nbands)) as tmp, \
            gdal_cache_at_most(GDAL_CACHE_BYTES):
        ds = None
        try:
            with gdal_errors_as_exceptions():
                ds = gdal.GetDriverByName("GTiff").Create(tmp, width, height, nbands, gdal_type, options=options)
                ds.SetGeoTransform(PHOTO_GEOTRANSFORM)
                ds.SetMetadata(metadata)
                for index in range(1, nbands + 1):
                    band = ds.GetRasterBand(index)
                    band.SetDescription(BAND_NAMES[index - 1])
                    band.SetNoDataValue(float("nan"))
                    band.SetUnitType("metre" if index == 4 else unit)
                    band = None
                written, parts_done = 0, 0
                z_low, z_high = np.inf, -np.inf
                for row0, xyz, distance in strips:
                    # fmin / fmax skip the NaN of the sky without a copy of the strip's finite heights
                    with np.errstate(invalid="ignore"):  # a strip of sky only reduces to NaN, which fmin skips
                        z_low = float(np.fmin(z_low, np.fmin.reduce(xyz[..., 2], axis=None)))
                        z_high = float(np.fmax(z_high, np.fmax.reduce(xyz[..., 2], axis=None)))
                    values = [xyz[..., 0], xyz[..., 1], xyz[..., 2]] + ([distance] if with_distance else [])
                    for index, band_values in enumerate(values, start=1):
                        band = ds.GetRasterBand(index)
                        for r in range(0, band_values.shape[0], WRITE_ROWS):  # converted a slice at a time
                            stop_if_canceled(target)  # a 24 MP raster took seconds to write: Cancel acts now
                            part = band_values[r:r + WRITE_ROWS]
                            band.WriteArray(np.where(np.isfinite(part), part, np.nan).astype(dtype, copy=False),
                                            0, int(row0) + r)
                            parts_done += len(part)
                            if progress is not None:
                                progress(min(1.0, parts_done / (height * nbands)))
                        band = None
                    written += xyz.shape[0]
                    # every view of the strip goes now, before the next strip is computed (one strip in memory)
                    del xyz, distance, values, band_values, part
                if written != height:
                    raise OutputError(f"{target.name}: {written} of {height} rows were computed")
                ds.FlushCache()
                ds = None  # closes the file: errors while writing the last tiles surface here
        except OutputError:  # a cancel, a short strip: said as it is
            raise
        except RuntimeError as exc:
            raise gdal_failure(exc, target) from exc
        finally:
            ds = None  # closed before the temporary file is renamed or removed
    # how QGIS draws it when the file is added by hand (Z as a colour ramp, not X, Y, Z as red, green, blue)
    write_xyz_style(target, z_low if np.isfinite(z_low) else None, z_high if np.isfinite(z_high) else None)
    return target


#: Rows of a band converted for GDAL at a time (the conversion copy stays small whatever the strip).
WRITE_ROWS = 256
#: GDAL's block cache while an XYZ raster is streamed (its default, 5 % of the RAM, would hold written tiles).
GDAL_CACHE_BYTES = 256 << 20


@contextmanager
def gdal_cache_at_most(limit: int):
    """Cap GDAL's block cache inside the block (restored after)."""
    saved = gdal.GetCacheMax()
    gdal.SetCacheMax(min(saved, int(limit)))
    try:
        yield
    finally:
        gdal.SetCacheMax(saved)


#: Largest magnitude float32 stores to within 1 cm (its spacing there is 7.8 mm: rounding is at most 3.9 mm).
FLOAT32_EXACT_LIMIT = 131072.0


def storage_dtype(xyz: np.ndarray) -> str:
    """"float32" when every finite value of ``xyz`` keeps 1 cm in float32, else "float64".

    >>> storage_dtype(np.array([[[600000.0, 5100000.0, 3000.0]]])), storage_dtype(np.array([[[1000.0, 2000.0, 5.0]]]))
    ('float64', 'float32')
    """
    with np.errstate(invalid="ignore"):
        high, low = float(np.fmax.reduce(xyz, axis=None)), float(np.fmin.reduce(xyz, axis=None))  # NaN-skipping
    if not (np.isfinite(high) and np.isfinite(low)):  # all NaN (or infinite values, which must not be rounded)
        return "float32" if np.isnan(high) and np.isnan(low) else "float64"
    return "float32" if max(abs(high), abs(low)) < FLOAT32_EXACT_LIMIT else "float64"


def storage_dtype_for_range(low: float, high: float) -> str:
    """:func:`storage_dtype` from the range the values can take (a DEM's bounds and heights), before computing.

    >>> storage_dtype_for_range(-500.0, 5100000.0), storage_dtype_for_range(0.0, 9000.0)
    ('float64', 'float32')
    """
    return "float32" if max(abs(low), abs(high)) < FLOAT32_EXACT_LIMIT else "float64"


def read_xyz_raster(path) -> Tuple[np.ndarray, str, Optional[np.ndarray], dict]:
    """Read an XYZ raster back.

    Returns:
        (xyz (H, W, 3) float64 with NaN nodata, value CRS WKT, distance (H, W) or None, dataset metadata dict).
    """
    with gdal_errors_as_exceptions():
        ds = gdal.Open(os.fspath(path))
        meta = ds.GetMetadata() or {}
        if meta.get("MONOPLOT_FORMAT") != XYZ_FORMAT:
            raise OutputError(f"{path} is not a Monoplot XYZ raster")
        arrays = [ds.GetRasterBand(i).ReadAsArray().astype(np.float64) for i in range(1, ds.RasterCount + 1)]
    xyz = np.stack(arrays[:3], axis=-1)
    distance = arrays[3] if len(arrays) > 3 else None
    return xyz, meta.get("MONOPLOT_VALUE_CRS", ""), distance, meta
