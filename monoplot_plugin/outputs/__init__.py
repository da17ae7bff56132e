"""Monoplot's products: XYZ raster, photo features as 3-D map layers, map layers on the photo, orthophoto, report.

The writers here use GDAL/OGR (and matplotlib for the report) and never import qgis, so Processing algorithms and
plain scripts call them directly. The dock adds the written files to the project (:mod:`..gui.map_layers`).

Every writer takes ``overwrite=False``: an existing output is never replaced unless asked, and writes go through a
temporary file renamed into place (:mod:`.safe_write`).
"""

from .safe_write import OutputError, OutputExistsError, atomic_output  # noqa: F401
from .xyz_raster import read_xyz_raster, write_xyz_raster  # noqa: F401
from .vectors import MapFeature, read_vector_layer, write_vector_layer  # noqa: F401
from .geometry import map_to_photo, photo_to_map_feature, sample_xyz, visibility_of_points  # noqa: F401
from .orthophoto import orthophoto_from_camera, write_orthophoto  # noqa: F401

# The report imports matplotlib on first use: ``from monoplot_plugin.outputs.report import write_report``.

__all__ = ["OutputError", "OutputExistsError", "atomic_output", "read_xyz_raster", "write_xyz_raster",
           "MapFeature", "read_vector_layer", "write_vector_layer", "map_to_photo", "photo_to_map_feature",
           "sample_xyz", "visibility_of_points", "orthophoto_from_camera", "write_orthophoto"]
