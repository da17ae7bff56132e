"""A rough camera from a photo's EXIF tags (GPS position, altitude, direction, 35 mm focal length), read with GDAL.

Phones and drones write these; historical scans do not (then :func:`read_exif_prior` returns None).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Dict, Optional, Tuple

__all__ = ["ExifPrior", "read_exif_prior", "parse_exif_prior", "horizontal_fov_from_35mm"]


@dataclass
class ExifPrior:
    """What EXIF tells about the camera (None where the tag is missing).

    Attributes:
        lon, lat: WGS 84 degrees (None when the photo has no GPS position).
        altitude: metres above sea level.
        heading: direction of view, degrees from north (GPSImgDirection).
        fov: horizontal field of view in degrees, for the picture as displayed (EXIF orientation applied).
    """

    lon: Optional[float] = None
    lat: Optional[float] = None
    altitude: Optional[float] = None
    heading: Optional[float] = None
    fov: Optional[float] = None

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


def horizontal_fov_from_35mm(focal_35mm: float, landscape: bool = True) -> float:
    """Horizontal field of view (degrees) of a 36 x 24 mm frame behind a lens of ``focal_35mm`` mm.

    >>> round(horizontal_fov_from_35mm(28.0), 1), round(horizontal_fov_from_35mm(28.0, landscape=False), 1)
    (65.5, 46.4)
    """
    width = 36.0 if landscape else 24.0
    return math.degrees(2.0 * math.atan(width / (2.0 * focal_35mm)))


def parse_exif_prior(metadata: Dict[str, str], size: Tuple[int, int]) -> ExifPrior:
    """ExifPrior from GDAL's ``EXIF_*`` metadata of a photo displayed at ``size`` = (W, H) pixels.

    >>> md = {"EXIF_GPSLatitude": "(46) (25) (53.04)", "EXIF_GPSLatitudeRef": "N",
    ...       "EXIF_GPSLongitude": "(8) (5) (35.88)", "EXIF_GPSLongitudeRef": "E", "EXIF_GPSAltitude": "(2929)",
    ...       "EXIF_GPSImgDirection": "(297.1)", "EXIF_FocalLengthIn35mmFilm": "28"}
    >>> p = parse_exif_prior(md, (4000, 3000))
    >>> round(p.lon, 4), round(p.lat, 4), p.altitude, p.heading, round(p.fov, 1)
    (8.0933, 46.4314, 2929.0, 297.1, 65.5)
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
    f35 = _numbers(metadata.get("EXIF_FocalLengthIn35mmFilm", ""))
    if f35 and f35[0] > 0:
        out.fov = horizontal_fov_from_35mm(f35[0], landscape=size[0] >= size[1])
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
    prior = parse_exif_prior(ds.GetMetadata() or {}, size)
    return prior if (prior.has_position or prior.fov is not None) else None
