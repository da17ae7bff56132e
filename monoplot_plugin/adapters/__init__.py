"""QGIS <-> core conversions: layers to core objects (DEM, photo) and core results to layers."""
