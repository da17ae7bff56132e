"""Monoplot's products: XYZ raster, photo features as 3-D map layers, map layers on the photo, orthophoto, report.

The writers here use GDAL/OGR (and matplotlib for the report) and never import qgis, so Processing algorithms and
plain scripts call them directly. :mod:`.qgis_layers` adds the written files to a QGIS project.

Every writer takes ``overwrite=False``: an existing output is never replaced unless asked, and writes go through a
temporary file renamed into place (:mod:`.safe_write`).
"""

from .safe_write import OutputError, OutputExistsError, atomic_output  # noqa: F401
from .xyz_raster import read_xyz_raster, write_xyz_raster  # noqa: F401

__all__ = ["OutputError", "OutputExistsError", "atomic_output", "read_xyz_raster", "write_xyz_raster"]
