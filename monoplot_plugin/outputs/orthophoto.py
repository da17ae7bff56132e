"""Orthophoto GeoTIFF: the photo draped onto the DEM grid, in the DEM's CRS.

Layout: the photo's bands (1 grey or 3 RGB, Byte) plus an alpha band; cells the camera does not see (hidden behind
terrain, outside the photo, DEM voids) have alpha 0, which GDAL exposes as the mask of every band (``GMF_ALPHA``) and
QGIS draws transparent. Geotransform and CRS are the DEM's, so it lines up with the DEM cell for cell. Tiled,
DEFLATE-compressed at level 1 with the horizontal predictor (a time-lapse writes one per frame: level 6 took 13 times
longer for 10 % fewer bytes).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable, Optional, Sequence

import numpy as np
from osgeo import gdal

from ._gdal import gdal_errors_as_exceptions, gdal_failure, raster_verifier, srs_from_user
from ..core.lookup import orthorectify
from .safe_write import OutputError, atomic_output
from .xyz_raster import fit_metadata

__all__ = ["write_orthophoto", "orthophoto_from_camera"]


def write_orthophoto(path, image: np.ndarray, geotransform: Sequence[float], crs_wkt: str, *,
                     overwrite: bool = False, fit: Optional[dict] = None) -> Path:
    """Write a (rows, cols, bands + 1) uint8 array whose last band is alpha (0 = unseen) as a GeoTIFF.

    Args:
        path: target ``.tif``.
        image: (rows, cols, 2) grey + alpha or (rows, cols, 4) RGB + alpha, uint8.
        geotransform: the DEM's GDAL geotransform.
        crs_wkt: the DEM's CRS.
        overwrite: replace an existing file (default: refuse with OutputExistsError).
        fit: optional verdict of the camera (``status``, ``message``...), kept as ``MONOPLOT_FIT`` in the metadata
            (:func:`~.xyz_raster.fit_metadata`): an orthophoto of an "uncertain" camera says so.
    """
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] not in (2, 4) or image.dtype != np.uint8:
        raise ValueError(f"image must be uint8 (rows, cols, 2 or 4), got {image.dtype} {image.shape}")
    rows, cols, nbands = image.shape
    srs = srs_from_user(crs_wkt)
    options = ["TILED=YES", "COMPRESS=DEFLATE", "ZLEVEL=1", "PREDICTOR=2", "BIGTIFF=IF_SAFER", "ALPHA=YES",
               f"PHOTOMETRIC={'RGB' if nbands == 4 else 'MINISBLACK'}"]
    target = Path(os.fspath(path))
    with atomic_output(target, overwrite, verify=raster_verifier(cols, rows, nbands)) as tmp:
        ds = None
        try:
            with gdal_errors_as_exceptions():
                ds = gdal.GetDriverByName("GTiff").Create(tmp, cols, rows, nbands, gdal.GDT_Byte, options=options)
                ds.SetGeoTransform(tuple(float(g) for g in geotransform))
                ds.SetProjection(srs.ExportToWkt())
                ds.SetMetadata({"MONOPLOT_FORMAT": "monoplot-orthophoto/1", **fit_metadata(fit)})
                interp = ([gdal.GCI_RedBand, gdal.GCI_GreenBand, gdal.GCI_BlueBand] if nbands == 4
                          else [gdal.GCI_GrayIndex]) + [gdal.GCI_AlphaBand]
                for index in range(nbands):
                    band = ds.GetRasterBand(index + 1)
                    band.SetColorInterpretation(interp[index])
                    band.WriteArray(image[..., index])
                    band = None
                ds.FlushCache()
                ds = None
        except RuntimeError as exc:
            raise gdal_failure(exc, target) from exc
        finally:
            ds = None
    return target


def orthophoto_from_camera(path, photo: np.ndarray, camera, dem, xyz: Optional[np.ndarray] = None, *,
                           overwrite: bool = False, rows_per_strip: Optional[int] = None,
                           allow_empty: bool = True,
                           between_chunks: Optional[Callable[[float], None]] = None,
                           fit: Optional[dict] = None) -> Path:
    """Orthorectify ``photo`` onto ``dem`` (:func:`monoplot_plugin.core.lookup.orthorectify`) and write it.

    Args:
        photo: (H, W) or (H, W, 3) uint8, the size of the camera's image.
        camera: the fitted Camera. dem: core Dem (grid and CRS of the result).
        xyz: (H, W, 3) per-pixel map coordinates of the photo (occlusion test); None: computed here, in strips of
            the image when the whole raster does not fit in the free memory (core :mod:`~..core.xyz_strips`).
        rows_per_strip: force strips of this many image rows (None: planned from the free memory).
        allow_empty: write an orthophoto with no cell seen (else OutputError, nothing written).
        between_chunks: called with the fraction done while the cells are looked up (the caller's progress and
            cancel; see core :func:`~..core.lookup.ortho_lookup`).
        fit: the camera's verdict, kept in the metadata (:func:`write_orthophoto`).
    Raises:
        MemoryBudgetError (core) with the numbers when even thin strips do not fit.
    """
    photo = np.asarray(photo)
    if photo.ndim == 3 and photo.shape[2] == 4:
        photo = photo[..., :3]
    if photo.ndim == 3 and photo.shape[2] not in (1, 3):
        raise ValueError(f"photo must have 1 or 3 bands, got {photo.shape}")
    photo = photo.astype(np.uint8, copy=False)
    if xyz is not None:
        image = orthorectify(photo, camera, dem, xyz, between_chunks=between_chunks)
    else:
        image = orthorectify_in_strips(photo, camera, dem, rows_per_strip, between_chunks)
    if not allow_empty and not image[..., -1].any():
        raise OutputError(f"the orthophoto {Path(os.fspath(path)).name} would be empty: the camera sees no cell of "
                          f"the DEM")
    return write_orthophoto(path, image, dem.geotransform, dem.crs_wkt, overwrite=overwrite, fit=fit)


def orthorectify_in_strips(photo: np.ndarray, camera, dem, rows_per_strip: Optional[int] = None,
                           between_chunks: Optional[Callable[[float], None]] = None) -> np.ndarray:
    """:func:`.geometry.orthorectify` with the XYZ raster computed strip by strip: a DEM cell takes its colour from
    the strip of the photo it falls in (strips do not overlap, so each cell is decided once)."""
    from ..core.xyz import compute_xyz
    from ..core.xyz_strips import plan_strips, strip_camera

    rows, cols = dem.shape
    bands = 1 if photo.ndim == 2 else photo.shape[2]
    grid_bytes = rows * cols * (24 + 8 + bands + 1)  # cell vertices, projections, the image
    n = rows_per_strip or plan_strips(camera, extra_per_row=camera.width * bands, fixed=grid_bytes,
                                      what="orthophoto")
    out = np.zeros((rows, cols, bands + 1), dtype=np.uint8)
    for row0 in range(0, camera.height, n):
        strip = strip_camera(camera, row0, min(n, camera.height - row0))
        part = orthorectify(photo[row0:row0 + strip.height], strip, dem, compute_xyz(strip, dem))
        seen = part[..., -1] > 0
        out[seen] = part[seen]
        if between_chunks is not None:
            between_chunks(min(1.0, (row0 + strip.height) / camera.height))
    return out
