"""Monoplot's Processing provider: every step of the pipeline as a QGIS Processing algorithm.

Algorithms chain through files: the camera is a small JSON file (:meth:`Camera.to_json`), points are vector layers
or CSV files, products are GeoTIFF rasters and vector layers. They run in the toolbox, the Graphical Modeler, batch
mode and from the command line (``qgis_process run monoplot:<algorithm> -- ...``).
"""
