"""Rough cameras from Google Earth: a KML PhotoOverlay read into a :class:`~monoplot_plugin.core.camera.Camera` in
the DEM's CRS, the WGS 84 -> map CRS conversion (with the grid convergence) that EXIF positions use too, and a
camera moved from one projected CRS to another (:func:`camera_to_crs`).

GDAL's ``osr`` is imported only when a position is converted, so the camera math imports without it.
"""

from __future__ import annotations

import math
import re
from typing import Optional, Tuple

from .camera import Camera

__all__ = ["camera_from_kml", "lonlat_to_crs", "crs_to_wkt", "camera_to_crs"]


def camera_from_kml(kml, image_size, dst_crs_wkt: str, use_overlay_rotation: bool = True,
                    default_fov: Optional[float] = None, notes: Optional[list] = None) -> Camera:
    """A camera from a KML PhotoOverlay (Google Earth), reprojected to ``dst_crs_wkt``.

    Args:
        kml: path to a .kml file, or its text.
        image_size: (width, height) of the photo in pixels.
        dst_crs_wkt: WKT (or "EPSG:n") of the DEM's CRS.
        use_overlay_rotation: add the PhotoOverlay's ``<rotation>`` (image rotation, counter-clockwise) to the
            camera roll.
        default_fov: horizontal field of view (degrees) for a KML whose ``<Camera>`` has no ``<ViewVolume>`` (a
            view saved from Google Earth's camera alone); a note in ``notes`` says it was used. None: refused.
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
    if default_fov is not None and re.search(r"<(?:\w+:)?leftFov>", text) is None:
        left, right = -0.5 * float(default_fov), 0.5 * float(default_fov)
        if notes is not None:
            notes.append(f"the KML gives no field of view (no <ViewVolume>): {float(default_fov):.1f} deg is used")
    else:
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


def camera_to_crs(camera: Camera, dst_crs: str) -> Tuple[Camera, float]:
    """``camera`` (its ``crs_wkt`` set) in another CRS ``dst_crs`` (WKT or "EPSG:n", projected, metres): the
    position transformed, the heading turned by the difference of the two grids' north at the camera; height,
    pitch, roll and lens unchanged (the vertical datum is kept; the scale factors of two projections differ by far
    less than a rough camera's error). Returns (camera, degrees the heading turned).

    >>> cam = Camera((2640000.0, 1157000.0, 1500.0), 30.0, -2.0, 0.0, 50.0, (400, 300), crs_wkt="EPSG:2056")
    >>> utm, turned = camera_to_crs(cam, "EPSG:32632")
    >>> round(utm.position[0], -2), round(utm.position[1], -2), round(turned, 1), round(utm.heading - 30.0, 1)
    (420300.0, 5157100.0, 1.1, 1.1)
    >>> back, _ = camera_to_crs(utm, "EPSG:2056")
    >>> [round(abs(float(a - b)), 2) for a, b in zip(back.position, cam.position)], round(back.heading, 6)
    ([0.0, 0.0, 0.0], 30.0)
    """
    from osgeo import osr

    src, dst = osr.SpatialReference(), osr.SpatialReference()
    src.SetFromUserInput(camera.crs_wkt)
    dst.SetFromUserInput(dst_crs)
    for srs in (src, dst):
        srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    transform = osr.CoordinateTransformation(src, dst)
    x, y, z = (float(v) for v in camera.position)
    nx, ny, _ = transform.TransformPoint(x, y)
    # the heading's direction, 100 m ahead on the source grid, seen on the destination grid
    h = math.radians(camera.heading)
    ax, ay, _ = transform.TransformPoint(x + 100.0 * math.sin(h), y + 100.0 * math.cos(h))
    heading = math.degrees(math.atan2(ax - nx, ay - ny))
    turned = (heading - camera.heading + 180.0) % 360.0 - 180.0
    moved = Camera(position=(nx, ny, z), heading=camera.heading + turned, pitch=camera.pitch, roll=camera.roll,
                   fov=camera.fov, image_size=camera.image_size, principal_point=camera.principal_point,
                   k1=camera.k1, k2=camera.k2, crs_wkt=crs_to_wkt(dst_crs))
    return moved, turned
