"""QgsRasterLayer -> core :class:`~monoplot_plugin.core.dem.Dem`, read with GDAL on the main thread.

Tasks only ever get this in-memory copy, never the layer. Beyond what ``Dem.open`` does (nodata, geographic CRS
warped to UTM), this adapter recognises zero-filled voids in DEMs that declare no nodata value (the Aletsch DEM).
"""

from __future__ import annotations

from typing import List, Optional, Tuple

import numpy as np
from qgis.core import QgsRasterLayer

from ..core.dem import Dem

__all__ = ["DemError", "read_dem_layer", "read_dem_file", "zero_voids"]


class DemError(ValueError):
    """The layer cannot serve as a DEM (the message is meant for the user)."""


def zero_voids(elevation: np.ndarray, min_median: float = 300.0) -> int:
    """Turn exact zeros into NaN when the rest of the terrain is high (median > ``min_median`` m); in place.

    Mountain DEMs without a nodata value often fill voids with 0, which no real high-terrain DEM contains.
    Returns the number of cells changed.

    >>> z = np.array([[0.0, 2000.0], [2100.0, 2200.0]]); zero_voids(z), bool(np.isnan(z[0, 0]))
    (1, True)
    >>> z = np.array([[0.0, 2.0], [3.0, 4.0]]); zero_voids(z)
    0
    """
    zeros = elevation == 0
    if not zeros.any() or zeros.all() or np.nanmedian(elevation[~zeros]) <= min_median:
        return 0
    elevation[zeros] = np.nan
    return int(zeros.sum())


def read_dem_file(path: str, void_value: Optional[float] = None) -> Tuple[Dem, List[str]]:
    """(Dem, notes for the user) from a raster file; ``void_value`` = cells to treat as voids."""
    from osgeo import gdal

    try:
        dem = Dem.open(path, void_value=void_value)
    except Exception as exc:  # GDAL errors, missing CRS...: say it in words
        raise DemError(f"cannot read the DEM {path!r}: {exc}") from exc
    notes = []
    if dem.source_crs_wkt:
        notes.append("geographic DEM reprojected to UTM metres")
    if void_value is None:
        ds = gdal.Open(path)
        if ds is not None and ds.GetRasterBand(1).GetNoDataValue() is None:
            if not dem.elevation.flags.writeable or dem.elevation.dtype not in (np.float32, np.float64):
                dem.elevation = dem.elevation.astype(np.float64)
            n = zero_voids(dem.elevation)
            if n:
                notes.append(f"{n} cells at 0 m treated as voids (the DEM declares no nodata value)")
    if np.isnan(dem.elevation).all():
        raise DemError("the DEM has no valid cell")
    return dem, notes


def read_dem_layer(layer: QgsRasterLayer, void_value: Optional[float] = None) -> Tuple[Dem, List[str]]:
    """Copy a raster layer into a core Dem (first band).

    Raises:
        DemError: invalid layer, not a GDAL raster file, no CRS, nothing valid.
    """
    if layer is None or not layer.isValid():
        raise DemError("choose a valid DEM raster layer")
    if layer.providerType() != "gdal":
        raise DemError(f"the DEM layer {layer.name()!r} is not a raster file (provider {layer.providerType()})")
    if not layer.crs().isValid():
        raise DemError(f"the DEM layer {layer.name()!r} has no CRS; set one in its properties")
    return read_dem_file(layer.source().split("|")[0], void_value)
