"""The XYZ raster: a photo-sized GeoTIFF whose pixels hold the ground coordinates seen through them.

Layout (``MONOPLOT_FORMAT=monoplot-xyz/1`` in the dataset metadata):

- Bands 1-3: float32 X, Y, Z in the DEM's CRS (band descriptions ``X``, ``Y``, ``Z``; unit type from the CRS, e.g.
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
  (e.g. ``EPSG:21781``); the camera as JSON in ``MONOPLOT_CAMERA``; the photo's file name in ``MONOPLOT_PHOTO``.
- Tiled 256 x 256, DEFLATE (or LZW) compression with the floating-point predictor, BIGTIFF when needed.

float32 keeps about 7 significant digits: a 6-digit easting (Swiss LV03, UTM) is stored to 6 cm, a 7-digit UTM
northing to 0.5 m, far below a DEM cell. Pass ``dtype="float64"`` for exact values.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Optional, Tuple

import numpy as np
from osgeo import gdal

from ._gdal import crs_authid, gdal_errors_as_exceptions, gdal_failure, linear_unit_name, srs_from_user
from .safe_write import OutputError, atomic_output

__all__ = ["write_xyz_raster", "read_xyz_raster", "PHOTO_GEOTRANSFORM", "XYZ_FORMAT"]

#: Geotransform of every photo-space raster Monoplot writes: x = column, y = -row, 1 unit = 1 pixel.
PHOTO_GEOTRANSFORM = (0.0, 1.0, 0.0, 0.0, 0.0, -1.0)
XYZ_FORMAT = "monoplot-xyz/1"
BAND_NAMES = ("X", "Y", "Z", "DISTANCE")


def write_xyz_raster(path, xyz: np.ndarray, crs_wkt: str, distance: Optional[np.ndarray] = None, *,
                     overwrite: bool = False, compress: str = "DEFLATE", dtype: str = "float32",
                     camera=None, photo_name: str = "") -> Path:
    """Write the per-pixel ground coordinates of a photo as a GeoTIFF (layout in the module docstring).

    Args:
        path: target ``.tif`` (any Unicode path).
        xyz: (H, W, 3) ground coordinates in ``crs_wkt`` (map units); NaN where the pixel sees sky or no DEM.
        crs_wkt: CRS of the values (the DEM's), WKT or "EPSG:n".
        distance: optional (H, W) metres from the camera to the ground point; written as band 4.
        overwrite: replace an existing file (default: refuse with OutputExistsError).
        compress: "DEFLATE" (default) or "LZW".
        dtype: "float32" (default) or "float64".
        camera: optional :class:`~monoplot_plugin.core.camera.Camera`, stored as JSON in the metadata.
        photo_name: optional name of the photo, stored in the metadata.
    Returns:
        the Path written.
    Raises:
        ValueError for wrong shapes; OutputError (OutputExistsError) when the file cannot be written.
    """
    xyz = np.asarray(xyz)
    if xyz.ndim != 3 or xyz.shape[2] != 3:
        raise ValueError(f"xyz must be (H, W, 3), got {xyz.shape}")
    height, width = xyz.shape[:2]
    bands = [xyz[..., 0], xyz[..., 1], xyz[..., 2]]
    if distance is not None:
        distance = np.asarray(distance)
        if distance.shape != (height, width):
            raise ValueError(f"distance must be {(height, width)}, got {distance.shape}")
        bands.append(distance)
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
    options = ["TILED=YES", "BLOCKXSIZE=256", "BLOCKYSIZE=256", f"COMPRESS={compress.upper()}", "PREDICTOR=3",
               "BIGTIFF=IF_SAFER", "INTERLEAVE=BAND"]
    target = Path(os.fspath(path))
    with atomic_output(target, overwrite) as tmp:
        ds = None
        try:
            with gdal_errors_as_exceptions():
                ds = gdal.GetDriverByName("GTiff").Create(tmp, width, height, len(bands), gdal_type, options=options)
                ds.SetGeoTransform(PHOTO_GEOTRANSFORM)
                ds.SetMetadata(metadata)
                for index, values in enumerate(bands, start=1):
                    band = ds.GetRasterBand(index)
                    band.SetDescription(BAND_NAMES[index - 1])
                    band.SetNoDataValue(float("nan"))
                    band.SetUnitType("metre" if index == 4 else unit)
                    band.WriteArray(np.where(np.isfinite(values), values, np.nan).astype(dtype, copy=False))
                    band = None
                ds.FlushCache()
                ds = None  # closes the file: errors while writing the last tiles surface here
        except RuntimeError as exc:
            raise gdal_failure(exc, target) from exc
        finally:
            ds = None  # closed before the temporary file is renamed or removed
    return target


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
