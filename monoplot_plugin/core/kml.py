"""Rough cameras from Google Earth: a KML PhotoOverlay read into a :class:`~monoplot_plugin.core.camera.Camera` in
the DEM's CRS, and the WGS 84 -> map CRS conversion (with the grid convergence) that EXIF positions use too.

GDAL's ``osr`` is imported only when a position is converted, so the camera math imports without it.
"""

from __future__ import annotations

import math
import re
from typing import Optional, Tuple

from .camera import Camera

__all__ = ["camera_from_kml", "lonlat_to_crs", "crs_to_wkt"]


def camera_from_kml(kml, image_size, dst_crs_wkt: str, use_overlay_rotation: bool = True) -> Camera:
    """A camera from a KML PhotoOverlay (Google Earth), reprojected to ``dst_crs_wkt``.

    Args:
        kml: path to a .kml file, or its text.
        image_size: (width, height) of the photo in pixels.
        dst_crs_wkt: WKT (or "EPSG:n") of the DEM's CRS.
        use_overlay_rotation: add the PhotoOverlay's ``<rotation>`` (image rotation, counter-clockwise) to the
            camera roll.
    KML's ``tilt`` is 0 looking straight down and 90 at the horizon (pitch = tilt - 90); its ``heading`` is
    measured from true north, converted here to grid north with the meridian convergence at the camera.
    The horizontal field of view is ``rightFov - leftFov``. Altitude is taken as metres in the DEM's vertical
    datum (the difference between datums is a few metres, far below a rough prior's error).
    """
    text = kml
    if not str(kml).lstrip().startswith("<"):
        with open(kml, encoding="utf-8") as fh:
            text = fh.read()

    def number(tag: str, default: Optional[float] = None) -> float:
        match = re.search(rf"<(?:\w+:)?{tag}>\s*([-+0-9.eE]+)\s*</(?:\w+:)?{tag}>", text)
        if match is None:
            if default is None:
                raise ValueError(f"KML has no <{tag}> element")
            return default
        return float(match.group(1))

    lon, lat, alt = number("longitude"), number("latitude"), number("altitude", 0.0)
    heading_true, tilt, roll = number("heading", 0.0), number("tilt", 90.0), number("roll", 0.0)
    left, right = number("leftFov"), number("rightFov")
    if use_overlay_rotation:
        roll += number("rotation", 0.0)
    x, y, convergence = lonlat_to_crs(lon, lat, dst_crs_wkt)
    heading = (heading_true - convergence + 180.0) % 360.0 - 180.0
    return Camera(position=(x, y, alt), heading=heading, pitch=tilt - 90.0, roll=roll, fov=right - left,
                  image_size=image_size, crs_wkt=crs_to_wkt(dst_crs_wkt))


def crs_to_wkt(crs: str) -> str:
    """WKT of ``crs`` (WKT, "EPSG:n" or anything GDAL's ``SetFromUserInput`` reads)."""
    from osgeo import osr

    srs = osr.SpatialReference()
    srs.SetFromUserInput(crs)
    return srs.ExportToWkt()


def lonlat_to_crs(lon: float, lat: float, crs: str) -> Tuple[float, float, float]:
    """WGS 84 (lon, lat) -> (x, y) in ``crs`` (WKT or "EPSG:n") and the grid convergence there (degrees: true north
    minus grid north, clockwise), so that ``grid heading = true heading - convergence``."""
    from osgeo import osr

    src = osr.SpatialReference()
    src.ImportFromEPSG(4326)
    dst = osr.SpatialReference()
    dst.SetFromUserInput(crs)
    for srs in (src, dst):
        srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    transform = osr.CoordinateTransformation(src, dst)
    x, y, _ = transform.TransformPoint(lon, lat)
    x2, y2, _ = transform.TransformPoint(lon, lat + 1e-3)
    convergence = math.degrees(math.atan2(x2 - x, y2 - y))
    return x, y, convergence
