"""A camera as a KML PhotoOverlay (Google Earth), the inverse of :meth:`~monoplot_plugin.core.camera.Camera.from_kml`.

KML angles: ``heading`` from true north (the camera's grid heading plus the meridian convergence at the camera),
``tilt`` 0 looking straight down and 90 at the horizon (tilt = pitch + 90), ``roll``; the view volume is
``leftFov``/``rightFov`` (half the horizontal field of view each side) and ``bottomFov``/``topFov`` (vertical).
Altitude is the camera height in the DEM's vertical datum, ``absolute``. Principal point offset and distortion are
not part of a PhotoOverlay: they are lost (the JSON camera keeps everything).

>>> import tempfile, os
>>> from monoplot_plugin.core.camera import Camera
>>> cam = Camera((642000.0, 150000.0, 2900.0), -60.0, -11.0, 1.5, 63.0, (1024, 763), crs_wkt="EPSG:21781")
>>> path = os.path.join(tempfile.mkdtemp(), "camera.kml")
>>> _ = write_camera_kml(path, cam, name="Aletsch")
>>> back = Camera.from_kml(path, (1024, 763), "EPSG:21781")
>>> [abs(a - b) < 0.01 for a, b in zip(back.position, cam.position)]   # metres
[True, True, True]
>>> round(back.heading, 6), round(back.pitch, 6), round(back.roll, 6), round(back.fov, 6)
(-60.0, -11.0, 1.5, 63.0)
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Tuple
from xml.sax.saxutils import escape

from ..core.camera import Camera
from ..core.kml import lonlat_to_crs
from .safe_write import write_text

__all__ = ["camera_to_kml", "write_camera_kml", "crs_to_lonlat"]


def crs_to_lonlat(x: float, y: float, crs: str) -> Tuple[float, float]:
    """(lon, lat) in WGS 84 of map point (x, y) in ``crs`` (WKT or "EPSG:n")."""
    from osgeo import osr

    src = osr.SpatialReference()
    src.SetFromUserInput(crs)
    dst = osr.SpatialReference()
    dst.ImportFromEPSG(4326)
    for srs in (src, dst):
        srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    lon, lat, _ = osr.CoordinateTransformation(src, dst).TransformPoint(float(x), float(y))
    return lon, lat


def camera_to_kml(camera: Camera, name: str = "Monoplot camera") -> str:
    """KML text of a PhotoOverlay for ``camera`` (which needs its CRS, ``camera.crs_wkt``)."""
    if not camera.crs_wkt:
        raise ValueError("the camera has no CRS: its position cannot be given in longitude and latitude")
    x, y, z = (float(v) for v in camera.position)
    lon, lat = crs_to_lonlat(x, y, camera.crs_wkt)
    convergence = lonlat_to_crs(lon, lat, camera.crs_wkt)[2]
    heading = (camera.heading + convergence + 180.0) % 360.0 - 180.0
    half_h, half_v = camera.fov / 2.0, camera.vertical_fov / 2.0
    if not all(math.isfinite(v) for v in (lon, lat, z, heading, half_h, half_v)):
        raise ValueError("the camera's position or angles are not finite")
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<kml xmlns="http://www.opengis.net/kml/2.2">
  <PhotoOverlay>
    <name>{escape(name)}</name>
    <Camera>
      <longitude>{lon:.10f}</longitude>
      <latitude>{lat:.10f}</latitude>
      <altitude>{z:.3f}</altitude>
      <heading>{heading:.6f}</heading>
      <tilt>{camera.pitch + 90.0:.6f}</tilt>
      <roll>{camera.roll:.6f}</roll>
      <altitudeMode>absolute</altitudeMode>
    </Camera>
    <ViewVolume>
      <leftFov>{-half_h:.6f}</leftFov>
      <rightFov>{half_h:.6f}</rightFov>
      <bottomFov>{-half_v:.6f}</bottomFov>
      <topFov>{half_v:.6f}</topFov>
      <near>10</near>
    </ViewVolume>
  </PhotoOverlay>
</kml>
"""


def write_camera_kml(path, camera: Camera, name: str = "Monoplot camera", overwrite: bool = True) -> Path:
    """Write :func:`camera_to_kml` to ``path`` (through a temporary file); returns the path."""
    return write_text(path, camera_to_kml(camera, name), overwrite=overwrite)
