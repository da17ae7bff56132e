"""A rough camera from a photo's EXIF tags (GPS position, altitude, direction, focal length) and a drone's XMP
gimbal angles (pitch, heading), read with GDAL.

Phones and drones write these; historical scans do not (then :func:`read_exif_prior` returns None).

The field of view comes from ``FocalLengthIn35mmFilm``, else from ``FocalLength`` with the sensor's size, which EXIF
gives as ``FocalPlaneXResolution`` (pixels per ``FocalPlaneResolutionUnit``) over the image width. A focal length
without either is kept (``focal_mm``, ``fov`` None), so the dock can say so and ask for the sensor width instead of
ignoring it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Dict, Optional, Tuple

__all__ = ["ExifPrior", "read_exif_prior", "parse_exif_prior", "parse_xmp_gimbal", "horizontal_fov_from_35mm",
           "lens_fov", "exif_camera", "exif_rough_camera", "heading_to_dem_centre"]

#: Millimetres per FocalPlaneResolutionUnit (EXIF: 1 none, 2 inch, 3 cm; 4 mm and 5 µm in some writers).
_UNIT_MM = {1: 25.4, 2: 25.4, 3: 10.0, 4: 1.0, 5: 0.001}


@dataclass
class ExifPrior:
    """What EXIF tells about the camera (None where the tag is missing).

    Attributes:
        lon, lat: WGS 84 degrees (None when the photo has no GPS position).
        altitude: metres above sea level.
        heading: direction of view, degrees from north (GPSImgDirection).
        heading_magnetic: the direction is from magnetic north (GPSImgDirectionRef "M"), not true north: it is off
            by the local magnetic declination, which Monoplot does not know.
        fov: horizontal field of view in degrees, for the picture as displayed (EXIF orientation applied).
        focal_mm: the lens's focal length (FocalLength), focal_35mm: its 35 mm equivalent.
        sensor_width_mm: width of the sensor along the displayed picture's horizontal axis (from the focal plane
            resolution), when EXIF says it.
        pitch: the camera's elevation in degrees (negative looks down), from a drone's XMP gimbal tags
            (:func:`parse_xmp_gimbal`); then ``heading`` is the gimbal's too (``heading_from_gimbal``).
        relative_altitude: metres above the drone's take-off point (XMP), when it says so.
    """

    lon: Optional[float] = None
    lat: Optional[float] = None
    altitude: Optional[float] = None
    heading: Optional[float] = None
    heading_magnetic: bool = False
    fov: Optional[float] = None
    focal_mm: Optional[float] = None
    focal_35mm: Optional[float] = None
    sensor_width_mm: Optional[float] = None
    pitch: Optional[float] = None
    heading_from_gimbal: bool = False
    relative_altitude: Optional[float] = None

    @property
    def has_position(self) -> bool:
        return self.lon is not None and self.lat is not None


def _numbers(text: str):
    return [float(v) for v in re.findall(r"[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?", text or "")]


def _dms(value: str, ref: str) -> Optional[float]:
    parts = _numbers(value)
    if not parts:
        return None
    deg = parts[0] + (parts[1] / 60.0 if len(parts) > 1 else 0.0) + (parts[2] / 3600.0 if len(parts) > 2 else 0.0)
    return -deg if (ref or "").strip().upper() in ("S", "W") else deg


#: The diagonal of a 36 x 24 mm frame: a 35 mm equivalent focal length gives the picture's diagonal field of view.
FULL_FRAME_DIAGONAL_MM = math.hypot(36.0, 24.0)


def horizontal_fov_from_35mm(focal_35mm: float, landscape: bool = True,
                             size: Optional[Tuple[int, int]] = None) -> float:
    """Horizontal field of view (degrees) of a picture behind a lens of ``focal_35mm`` mm 35 mm equivalent.

    The equivalent is defined on the diagonal (CIPA DC-008): a picture of ``size`` (width, height) px is as wide
    as 43.27 mm times its width over its diagonal; without ``size``, a 3:2 frame (36 or, portrait, 24 mm). A
    phone's 4:3 portrait picture at 26 mm is 53.1 deg wide (a trial: 49.6 deg as 24 mm wide, 3.5 deg narrow).

    >>> round(horizontal_fov_from_35mm(28.0), 1), round(horizontal_fov_from_35mm(28.0, landscape=False), 1)
    (65.5, 46.4)
    >>> [round(horizontal_fov_from_35mm(f, size=size), 1) for f, size in ((26.0, (600, 800)), (28.0, (300, 200)))]
    [53.1, 65.5]
    """
    if size is not None and size[0] > 0 and size[1] > 0:
        width = FULL_FRAME_DIAGONAL_MM * size[0] / math.hypot(size[0], size[1])
    else:
        width = 36.0 if landscape else 24.0
    return math.degrees(2.0 * math.atan(width / (2.0 * focal_35mm)))


def lens_fov(focal_mm: float, sensor_width_mm: Optional[float] = None, focal_35mm: Optional[float] = None,
             landscape: bool = True, size: Optional[Tuple[int, int]] = None) -> float:
    """Horizontal field of view (degrees) of a lens of ``focal_mm`` on a sensor ``sensor_width_mm`` wide, or of its
    35 mm equivalent ``focal_35mm`` (then ``focal_mm`` is not needed; ``size``: the picture's, see
    :func:`horizontal_fov_from_35mm`).

    >>> round(lens_fov(30.0, 22.2), 1), round(lens_fov(0, focal_35mm=48.0), 1)   # the issue's 30 mm on 22.2 mm
    (40.6, 41.1)
    """
    from ..core.camera import fov_from_focal

    if focal_35mm:
        return horizontal_fov_from_35mm(focal_35mm, landscape, size)
    if not focal_mm or not sensor_width_mm or focal_mm <= 0 or sensor_width_mm <= 0:
        raise ValueError("a focal length and a sensor width (or a 35 mm equivalent) are needed")
    return fov_from_focal(focal_mm, sensor_width_mm)  # the same formula in millimetres as in pixels


def _rotated(metadata: Dict[str, str]) -> bool:
    """True when the EXIF orientation turns the picture by 90 degrees (values 5 to 8)."""
    value = _numbers(metadata.get("EXIF_Orientation", ""))
    return bool(value) and int(value[0]) in (5, 6, 7, 8)


def _sensor_width_mm(metadata: Dict[str, str], size: Tuple[int, int]) -> Optional[float]:
    """Sensor size along the displayed horizontal axis (mm) from the focal-plane resolution, or None."""
    rotated = _rotated(metadata)
    tag = "EXIF_FocalPlaneYResolution" if rotated else "EXIF_FocalPlaneXResolution"
    res = _numbers(metadata.get(tag, "")) or _numbers(metadata.get("EXIF_FocalPlaneXResolution", ""))
    unit = _numbers(metadata.get("EXIF_FocalPlaneResolutionUnit", "")) or [2.0]
    if not res or res[0] <= 0 or int(unit[0]) not in _UNIT_MM:
        return None
    # the resolution refers to the full-size image the camera wrote (PixelX/YDimension), before the orientation
    raw = _numbers(metadata.get("EXIF_PixelYDimension" if rotated else "EXIF_PixelXDimension", ""))
    pixels = raw[0] if raw and raw[0] > 0 else float(size[0])
    return pixels / res[0] * _UNIT_MM[int(unit[0])]


#: XMP tags of drone cameras, per maker's namespace prefix: (pitch, yaw, height above the take-off point). Both
#: makers give degrees with pitch 0 level and -90 straight down, yaw clockwise from north (as Monoplot's camera).
_XMP_TAGS = {"drone-dji": ("GimbalPitchDegree", "GimbalYawDegree", "RelativeAltitude"),
             "drone-parrot": ("CameraPitchDegree", "CameraYawDegree", "RelativeAltitude")}


def _xmp_value(xmp: str, prefix: str, name: str) -> Optional[float]:
    """The number of the XMP property ``prefix:name``, written as an attribute or as an element; None if absent."""
    tag = re.escape(f"{prefix}:{name}")
    found = re.search(tag + r'\s*=\s*"([^"]*)"', xmp) or re.search("<" + tag + r">\s*([^<]*)<", xmp)
    values = _numbers(found.group(1)) if found else []
    return values[0] if values and math.isfinite(values[0]) else None


def parse_xmp_gimbal(xmp: str) -> Dict[str, float]:
    """What a drone's XMP packet says of its camera: ``pitch`` and ``heading`` (degrees), ``relative_altitude``
    (metres above the take-off point); only the ones present (empty for a photo of another device).

    DJI writes them as ``drone-dji:GimbalPitchDegree``..., Parrot as ``drone-parrot:CameraPitchDegree``... (a
    drone's EXIF has no direction of view, and its pitch is often -30 to -90 degrees: without these the rough camera
    looked at the horizon).

    >>> parse_xmp_gimbal('<rdf:Description drone-dji:GimbalPitchDegree="-45.20" drone-dji:GimbalYawDegree="-123.4" '
    ...                  'drone-dji:RelativeAltitude="+120.10"/>')
    {'pitch': -45.2, 'heading': 236.6, 'relative_altitude': 120.1}
    >>> parse_xmp_gimbal('<drone-parrot:CameraPitchDegree>-30</drone-parrot:CameraPitchDegree>'), parse_xmp_gimbal('')
    ({'pitch': -30.0}, {})
    """
    for prefix, (pitch_tag, yaw_tag, height_tag) in _XMP_TAGS.items():
        if prefix + ":" not in xmp:
            continue
        pitch, yaw = _xmp_value(xmp, prefix, pitch_tag), _xmp_value(xmp, prefix, yaw_tag)
        height = _xmp_value(xmp, prefix, height_tag)
        out = {}
        if pitch is not None and -90.0 <= pitch <= 90.0:
            out["pitch"] = pitch
        if yaw is not None:
            out["heading"] = yaw % 360.0
        if height is not None:
            out["relative_altitude"] = height
        return out
    return {}


def parse_exif_prior(metadata: Dict[str, str], size: Tuple[int, int], xmp: str = "") -> ExifPrior:
    """ExifPrior from GDAL's ``EXIF_*`` metadata of a photo displayed at ``size`` = (W, H) pixels, and from its
    ``xmp`` packet (a drone's gimbal, :func:`parse_xmp_gimbal`).

    >>> md = {"EXIF_GPSLatitude": "(46) (25) (53.04)", "EXIF_GPSLatitudeRef": "N",
    ...       "EXIF_GPSLongitude": "(8) (5) (35.88)", "EXIF_GPSLongitudeRef": "E", "EXIF_GPSAltitude": "(2929)",
    ...       "EXIF_GPSImgDirection": "(297.1)", "EXIF_FocalLengthIn35mmFilm": "28"}
    >>> p = parse_exif_prior(md, (4000, 3000))
    >>> round(p.lon, 4), round(p.lat, 4), p.altitude, p.heading, round(p.fov, 1), p.heading_magnetic
    (8.0933, 46.4314, 2929.0, 297.1, 63.4, False)
    >>> parse_exif_prior(dict(md, EXIF_GPSImgDirectionRef="M"), (4000, 3000)).heading_magnetic
    True
    >>> p = parse_exif_prior({"EXIF_FocalLength": "(30)", "EXIF_FocalPlaneXResolution": "(1000)",
    ...                       "EXIF_FocalPlaneResolutionUnit": "4", "EXIF_PixelXDimension": "22200"}, (4290, 2856))
    >>> round(p.sensor_width_mm, 1), round(p.fov, 1)
    (22.2, 40.6)
    >>> p = parse_exif_prior({"EXIF_FocalLength": "(30)"}, (4290, 2856))   # no sensor size: no field of view
    >>> p.focal_mm, p.fov
    (30.0, None)
    """
    out = ExifPrior()
    if "EXIF_GPSLatitude" in metadata and "EXIF_GPSLongitude" in metadata:
        out.lat = _dms(metadata["EXIF_GPSLatitude"], metadata.get("EXIF_GPSLatitudeRef", "N"))
        out.lon = _dms(metadata["EXIF_GPSLongitude"], metadata.get("EXIF_GPSLongitudeRef", "E"))
    alt = _numbers(metadata.get("EXIF_GPSAltitude", ""))
    if alt:
        below = _numbers(metadata.get("EXIF_GPSAltitudeRef", "")) == [1.0]  # 1 = below sea level
        out.altitude = -alt[0] if below else alt[0]
    direction = _numbers(metadata.get("EXIF_GPSImgDirection", ""))
    if direction:
        out.heading = direction[0] % 360.0
        out.heading_magnetic = metadata.get("EXIF_GPSImgDirectionRef", "").strip().upper().startswith("M")
    gimbal = parse_xmp_gimbal(xmp or "")
    out.pitch, out.relative_altitude = gimbal.get("pitch"), gimbal.get("relative_altitude")
    if "heading" in gimbal:  # the camera's own direction (a GPSImgDirection may be the aircraft's)
        out.heading, out.heading_magnetic, out.heading_from_gimbal = gimbal["heading"], False, True
    landscape = size[0] >= size[1]
    f35 = _numbers(metadata.get("EXIF_FocalLengthIn35mmFilm", ""))
    focal = _numbers(metadata.get("EXIF_FocalLength", ""))
    out.focal_mm = focal[0] if focal and focal[0] > 0 else None
    out.sensor_width_mm = _sensor_width_mm(metadata, size)
    if f35 and f35[0] > 0:
        out.focal_35mm = f35[0]
        out.fov = horizontal_fov_from_35mm(f35[0], landscape=landscape, size=size)
    elif out.focal_mm is not None and out.sensor_width_mm is not None:
        out.fov = lens_fov(out.focal_mm, out.sensor_width_mm)
    return out


def read_exif_prior(path: str, size: Tuple[int, int]) -> Optional[ExifPrior]:
    """ExifPrior of the photo file, or None when it has no useful tag (or GDAL cannot open it)."""
    from osgeo import gdal

    try:
        ds = gdal.Open(path)
    except RuntimeError:
        return None
    if ds is None:
        return None
    prior = parse_exif_prior(ds.GetMetadata() or {}, size, "".join(ds.GetMetadata("xml:XMP") or []))
    return prior if (prior.has_position or prior.fov is not None or prior.focal_mm is not None) else None


def parse_photo_taken(metadata: Dict[str, str]) -> Optional[str]:
    """When the photo was taken (``DateTimeOriginal``, else ``DateTime``) as ISO 8601 local time, or None.

    >>> parse_photo_taken({"EXIF_DateTimeOriginal": "2026:05:01 06:30:00"})
    '2026-05-01T06:30:00'
    >>> parse_photo_taken({"EXIF_DateTimeOriginal": "0000:00:00 00:00:00"}) is None   # a camera without a clock
    True
    """
    for tag in ("EXIF_DateTimeOriginal", "EXIF_DateTime"):
        found = re.match(r"\s*(\d{4})[:-](\d{2})[:-](\d{2})[ T](\d{2}):(\d{2}):(\d{2})", metadata.get(tag, ""))
        if found and int(found.group(1)) > 0:
            year, month, day, hour, minute, second = found.groups()
            return f"{year}-{month}-{day}T{hour}:{minute}:{second}"
    return None


def read_photo_taken(path: str) -> Optional[str]:
    """:func:`parse_photo_taken` of the photo file (None when it has no date or GDAL cannot open it)."""
    from osgeo import gdal

    try:
        ds = gdal.Open(path) if path else None
    except RuntimeError:
        return None
    return parse_photo_taken(ds.GetMetadata() or {}) if ds is not None else None


def exif_camera(exif: Optional[ExifPrior], size: Tuple[int, int], dem, heading: Optional[float] = None,
                crs_wkt: str = ""):
    """A rough :class:`~monoplot_plugin.core.camera.Camera` in ``dem``'s CRS from the EXIF tags: GPS position,
    altitude (else 2 m above the DEM, never below 1 m above it), a drone's gimbal heading or GPSImgDirection (else
    ``heading``, degrees from grid north), a drone's gimbal pitch (else level), field of view (else 60 degrees).

    Raises:
        ValueError: no GPS position, no direction and no ``heading`` given, or the position outside the DEM (the
            message says which).
    """
    from ..core.camera import Camera
    from ..core.kml import lonlat_to_crs

    if exif is None or not exif.has_position:
        raise ValueError("the photo has no GPS position in its EXIF tags")
    crs_wkt = crs_wkt or dem.crs_wkt  # the DEM's CRS (given apart where the DEM object has none: a batch's)
    x, y, convergence = lonlat_to_crs(exif.lon, exif.lat, crs_wkt)
    if exif.heading is not None:
        heading = exif.heading - convergence
    elif heading is None:
        raise ValueError("the photo's EXIF tags have no direction of view (GPSImgDirection)")
    ground = float(dem.sample(x, y))
    if not math.isfinite(ground):
        raise ValueError("the photo's GPS position lies outside the DEM")
    z = exif.altitude if exif.altitude is not None else ground + 2.0
    pitch = exif.pitch if exif.pitch is not None else 0.0
    return Camera((x, y, max(z, ground + 1.0)), float(heading), float(pitch), 0.0, exif.fov or 60.0, tuple(size),
                  crs_wkt=crs_wkt)


def exif_rough_camera(path: str, size: Tuple[int, int], dem, crs_wkt: str = ""):
    """(rough camera, heading known) of the photo file at ``path`` from its EXIF tags (:func:`exif_camera`): what a
    batch row naming no prior camera, and ``autoregister`` without a prior, start from. Without a direction tag the
    camera looks at the DEM's centre and the heading is not known (the automatic registration then searches every
    direction). Module-level and free of QGIS, so a batch job can carry it to a Dask worker.

    Raises:
        ValueError: the tags give no GPS position, or the position is off the DEM.
    """
    exif = read_exif_prior(path, size)
    if exif is not None and exif.has_position and exif.heading is None:
        from ..core.kml import lonlat_to_crs

        x, y, _ = lonlat_to_crs(exif.lon, exif.lat, crs_wkt or dem.crs_wkt)
        return exif_camera(exif, size, dem, heading=heading_to_dem_centre(x, y, dem), crs_wkt=crs_wkt), False
    return exif_camera(exif, size, dem, crs_wkt=crs_wkt), True


def heading_to_dem_centre(x: float, y: float, dem) -> float:
    """Heading (degrees from the grid's north) from map point (x, y) to the centre of ``dem``'s extent: the guess
    for a rough camera whose photo gives a position and no direction.

    >>> from monoplot_plugin.core.dem import Dem
    >>> dem = Dem.from_array([[0.0] * 4] * 4, (0, 10, 0, 40, 0, -10))
    >>> heading_to_dem_centre(20.0, -30.0, dem), heading_to_dem_centre(-30.0, 20.0, dem)
    (0.0, 90.0)
    """
    x0, y0, x1, y1 = dem.bounds()
    return math.degrees(math.atan2((x0 + x1) / 2 - x, (y0 + y1) / 2 - y))
