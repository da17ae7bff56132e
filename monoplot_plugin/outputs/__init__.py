"""Monoplot's file writers: XYZ raster, 3-D map layers, orthophoto, report (the products' steps: ..workflow).

The writers here use GDAL/OGR (and matplotlib for the report) and never import qgis, so Processing algorithms and
plain scripts call them directly. The dock adds the written files to the project (:mod:`..gui.map_layers`).

Every writer takes ``overwrite=False``: an existing output is never replaced unless asked, and writes go through a
temporary file renamed into place (:mod:`.safe_write`).
"""

from .safe_write import OutputError, OutputExistsError, atomic_output  # noqa: F401
from .xyz_raster import read_xyz_raster, write_xyz_raster  # noqa: F401
from .vectors import MapFeature, read_vector_layer, write_vector_layer  # noqa: F401
from .orthophoto import orthophoto_from_camera, write_orthophoto  # noqa: F401

# The report imports matplotlib on first use: ``from monoplot_plugin.outputs.report import write_report``.

__all__ = ["OutputError", "OutputExistsError", "atomic_output", "read_xyz_raster", "write_xyz_raster",
           "MapFeature", "read_vector_layer", "write_vector_layer", "orthophoto_from_camera", "write_orthophoto"]
