"""Fixtures for the Processing tests: QGIS Processing initialised with the Monoplot provider, and a small scene.

The small scene is built here from plain numbers (a smooth hill DEM in UTM 32N, a camera looking at it, a textured
photo), so that the product algorithms are tested on files written by GDAL, as users give them.
"""

import sys

import numpy as np
import pytest
from osgeo import gdal, osr

from monoplot_plugin.core.camera import Camera
from monoplot_plugin.workflow.camera_files import camera_json

WIDTH, HEIGHT = 160, 120


@pytest.fixture(scope="session")
def processing_provider(qgis_app):
    """Processing framework initialised and the Monoplot provider registered (once per session)."""
    if "/usr/share/qgis/python/plugins" not in sys.path:
        sys.path.append("/usr/share/qgis/python/plugins")
    from processing.core.Processing import Processing
    from qgis.core import QgsApplication

    Processing.initialize()
    registry = QgsApplication.processingRegistry()
    provider = registry.providerById("monoplot")
    if provider is None:
        from monoplot_plugin.processing.provider import MonoplotProvider

        provider = MonoplotProvider()
        registry.addProvider(provider)
    return provider


@pytest.fixture()
def run_alg(processing_provider):
    """``run_alg("computexyz", {...})`` -> results dict, through ``processing.run`` with a real feedback."""
    import processing
    from qgis.core import QgsProcessingFeedback

    def run(name, parameters, feedback=None):
        return processing.run(f"monoplot:{name}", parameters, feedback=feedback or QgsProcessingFeedback())

    return run


def hill_elevation(rows=80, cols=80):
    """(rows, cols) metres: a ridge with two summits rising to the north, plus gentle waves."""
    yy, xx = np.mgrid[0:rows, 0:cols].astype(float)
    z = 500.0 + 6.0 * (rows - yy)
    z += 700.0 * np.exp(-((xx - 30) ** 2 + (yy - 25) ** 2) / 150.0)
    z += 500.0 * np.exp(-((xx - 55) ** 2 + (yy - 30) ** 2) / 100.0)
    z += 20.0 * np.sin(xx / 4.0) * np.cos(yy / 5.0)
    return z


def write_dem(path, elevation, origin=(500000.0, 5100000.0), cell=30.0, epsg=32632):
    rows, cols = elevation.shape
    ds = gdal.GetDriverByName("GTiff").Create(str(path), cols, rows, 1, gdal.GDT_Float32)
    ds.SetGeoTransform((origin[0], cell, 0.0, origin[1], 0.0, -cell))
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(epsg)
    ds.SetProjection(srs.ExportToWkt())
    ds.GetRasterBand(1).WriteArray(elevation.astype(np.float32))
    ds = None
    return path


def scene_camera(size=(WIDTH, HEIGHT)):
    """A camera south of the hill, looking north and slightly down, seeing terrain and sky."""
    return Camera(position=(501200.0, 5097000.0, 1500.0), heading=5.0, pitch=-4.0, roll=0.0, fov=50.0,
                  image_size=size)


def recording_feedback():
    """A real QgsProcessingFeedback that keeps what an algorithm logs: ``.infos`` and ``.warnings`` (lists)."""
    from qgis.core import QgsProcessingFeedback

    class Recording(QgsProcessingFeedback):
        def __init__(self):
            super().__init__()
            self.infos, self.warnings = [], []

        def pushInfo(self, info):  # noqa: N802 (QGIS API)
            self.infos.append(info)

        def pushWarning(self, warning):  # noqa: N802 (QGIS API)
            self.warnings.append(warning)

    return Recording()


def write_photo(path, size=(WIDTH, HEIGHT), seed=0):
    import cv2

    rng = np.random.default_rng(seed)
    image = rng.integers(0, 255, (size[1], size[0], 3), dtype=np.uint8)
    cv2.imwrite(str(path), image)
    return path


@pytest.fixture(scope="session")
def small_scene(tmp_path_factory):
    """dict of paths: dem (GeoTIFF), camera (JSON, no fit verdict), fitted (the same camera with the verdict "ok"),
    photo (PNG), and the Camera itself."""
    folder = tmp_path_factory.mktemp("scene")
    dem = write_dem(folder / "dem.tif", hill_elevation())
    camera = scene_camera()
    camera_path = folder / "camera.json"
    camera.save(camera_path)
    photo = write_photo(folder / "photo.png")
    fitted = folder / "fitted.json"  # the same camera, written as a fit writes it: with its verdict
    fitted.write_text(camera_json(camera, {"status": "ok", "message": "the scene's true camera"}))
    return {"dir": folder, "dem": str(dem), "camera": str(camera_path), "photo": str(photo), "cam": camera,
            "fitted": str(fitted)}
