"""QgsRasterLayer -> core :class:`~monoplot_plugin.core.dem.Dem`, read with GDAL on the main thread.

Tasks only ever get this in-memory copy, never the layer. ``Dem.open`` finds the voids (nodata, NaN, common
sentinels, zero-filled voids of a DEM that declares no nodata value, as the Aletsch DEM) and warps a geographic DEM
to UTM; this adapter turns what it did into notes for the user.

>>> import numpy as np
>>> z = np.array([[0.0, 2000.0], [2100.0, 2200.0]])   # a zero-filled void in high terrain (core's rule)
>>> zero_voids(z), bool(np.isnan(z[0, 0]))
(1, True)
"""

from __future__ import annotations

from typing import List, Optional, Tuple

import numpy as np
from qgis.core import QgsRasterLayer

from ..core.dem import Dem, zero_voids  # noqa: F401 (zero_voids: re-exported)

__all__ = ["DemError", "dem_layer_path", "overviews_to_build", "read_dem_layer", "read_dem_file", "zero_voids"]


class DemError(ValueError):
    """The layer cannot serve as a DEM (the message is meant for the user)."""


def read_dem_file(path: str, void_value: Optional[float] = None, progress=None,
                  is_canceled=None) -> Tuple[Dem, List[str]]:
    """(Dem, notes for the user) from a raster file; ``void_value`` = cells to treat as voids; ``progress`` and
    ``is_canceled`` while the file is read, or the overviews of a DEM too large to read whole are built (core
    :class:`~..core.dem.DemReadCanceled` on a cancel)."""
    from ..core.dem import DemReadCanceled
    from ..core.dem_large import open_dem

    try:  # a DEM too large to read whole is opened by windows (its overviews built once, said in the notes)
        dem, notes = open_dem(path, void_value=void_value, progress=progress, is_canceled=is_canceled)
    except DemReadCanceled:
        raise
    except Exception as exc:  # GDAL errors, missing CRS...: say it in words
        raise DemError(f"cannot read the DEM {path!r}: {exc}") from exc
    if dem.source_crs_wkt:
        notes.append("geographic DEM reprojected to UTM metres")
    if dem.void_notes:  # core's one rule: nodata, NaN, sentinels, zero-filled voids
        notes.append("treated as voids: " + "; ".join(dem.void_notes))
    if np.isnan(dem.elevation).all():
        raise DemError("the DEM has no valid cell")
    return dem, notes


def dem_layer_path(layer: QgsRasterLayer) -> str:
    """The file of a raster layer that can serve as the DEM.

    Raises:
        DemError: invalid layer, not a GDAL raster file, no CRS.
    """
    if layer is None or not layer.isValid():
        raise DemError("choose a valid DEM raster layer")
    if layer.providerType() != "gdal":
        raise DemError(f"the DEM layer {layer.name()!r} is not a raster file (provider {layer.providerType()})")
    if not layer.crs().isValid():
        raise DemError(f"the DEM layer {layer.name()!r} has no CRS; set one in its properties")
    return layer.source().split("|")[0]


def overviews_to_build(path: str) -> List[int]:
    """The overviews a DEM file too large to read whole still needs before it opens (core
    :func:`~..core.dem_large.overviews_to_build`); [] for any other file, and for one GDAL cannot read (reading it
    then says why)."""
    from ..core.dem_large import overviews_to_build as needed

    try:
        return needed(path)
    except Exception:  # noqa: BLE001 (the read that follows gives the message)
        return []


#: A DEM file of more cells than this is read in a task, not on the main thread: 25 M cells froze QGIS 3 s when
#: chosen, 100 M cells 8-10 s (a trial); a 2,000 x 2,000 GeoTIFF read in 0.06-0.09 s here.
BACKGROUND_READ_CELLS = 4_000_000


def read_in_background(path: str) -> bool:
    """Whether the dock should read the DEM file ``path`` in a task: its overviews are still to be built
    (:func:`overviews_to_build`), or it has more than :data:`BACKGROUND_READ_CELLS` cells; False for a file GDAL
    cannot open (reading it then says why)."""
    if overviews_to_build(path):
        return True
    from osgeo import gdal

    try:
        ds = gdal.Open(path)
        return ds is not None and ds.RasterXSize * ds.RasterYSize > BACKGROUND_READ_CELLS
    except RuntimeError:  # GDAL raising: the read that follows says why
        return False


def read_dem_layer(layer: QgsRasterLayer, void_value: Optional[float] = None) -> Tuple[Dem, List[str]]:
    """Copy a raster layer into a core Dem (first band).

    Raises:
        DemError: invalid layer, not a GDAL raster file, no CRS, nothing valid.
    """
    return read_dem_file(dem_layer_path(layer), void_value)
