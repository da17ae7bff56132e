"""EXIF of real JPEG files (written by GDAL's JPEG driver) -> the lens and the field of view."""

from __future__ import annotations

import numpy as np
import pytest
from osgeo import gdal

from monoplot_plugin.adapters.exif import lens_fov, read_exif_prior, read_photo_taken


def _jpeg(path, size, **tags):
    w, h = size
    mem = gdal.GetDriverByName("MEM").Create("", w, h, 3)
    for b in range(3):
        mem.GetRasterBand(b + 1).WriteArray(np.full((h, w), 60, np.uint8))
    for key, value in tags.items():
        mem.SetMetadataItem("EXIF_" + key, value)
    gdal.GetDriverByName("JPEG").CreateCopy(str(path), mem, options=["WRITE_EXIF_METADATA=YES"])
    return str(path)


def test_35mm_equivalent_wins(tmp_path):
    path = _jpeg(tmp_path / "a.jpg", (300, 200), FocalLength="(5.6)", FocalLengthIn35mmFilm="28")
    exif = read_exif_prior(path, (300, 200))
    assert exif.focal_mm == pytest.approx(5.6) and exif.focal_35mm == 28.0
    assert exif.fov == pytest.approx(65.5, abs=0.05) and not exif.has_position


def test_focal_plane_resolution_in_inches_gives_the_sensor_width(tmp_path):
    # a 6000 px wide APS-C picture (23.5 mm): 6000 / (23.5 / 25.4) px per inch, the full image in PixelXDimension;
    # the file itself is a small copy (300 px): the sensor comes from the full-size width
    ppi = 6000 / (23.5 / 25.4)
    path = _jpeg(tmp_path / "b.jpg", (300, 200), FocalLength="(35)", FocalPlaneXResolution=f"({ppi:.4f})",
                 FocalPlaneResolutionUnit="2", PixelXDimension="6000", PixelYDimension="4000")
    exif = read_exif_prior(path, (300, 200))
    assert exif.sensor_width_mm == pytest.approx(23.5, abs=0.01)
    assert exif.fov == pytest.approx(lens_fov(35.0, 23.5), abs=1e-3)
    assert exif.fov == pytest.approx(37.1, abs=0.05)


def test_rotated_picture_uses_the_sensor_height(tmp_path):
    """EXIF orientation 6 (turned 90 degrees): the displayed width is the sensor's height."""
    ppmm = 6000 / 23.5
    path = _jpeg(tmp_path / "c.jpg", (300, 200), FocalLength="(35)", FocalPlaneXResolution=f"({ppmm:.4f})",
                 FocalPlaneYResolution=f"({ppmm:.4f})", FocalPlaneResolutionUnit="4", PixelXDimension="6000",
                 PixelYDimension="4000", Orientation="6")
    exif = read_exif_prior(path, (200, 300))  # displayed portrait
    assert exif.sensor_width_mm == pytest.approx(4000 / ppmm, abs=0.01)


def test_focal_length_alone_is_kept_without_a_field_of_view(tmp_path):
    path = _jpeg(tmp_path / "d.jpg", (300, 200), FocalLength="(30)")
    exif = read_exif_prior(path, (300, 200))
    assert exif is not None and exif.focal_mm == 30.0 and exif.fov is None and exif.sensor_width_mm is None


def test_no_exif_at_all(tmp_path):
    assert read_exif_prior(_jpeg(tmp_path / "e.jpg", (300, 200)), (300, 200)) is None


def test_lens_fov_needs_enough():
    with pytest.raises(ValueError):
        lens_fov(30.0)


def test_a_phones_portrait_picture_gets_the_diagonal_rules_width(tmp_path):
    """A trial: a 4:3 phone picture held upright (stored landscape, Orientation 6), 26 mm equivalent, got 49.6 deg
    as if 24 mm wide; the equivalent is defined on the diagonal: 53.1 deg (landscape: 67.3 deg, not 69.4)."""
    path = _jpeg(tmp_path / "phone.jpg", (800, 600), FocalLengthIn35mmFilm="26", Orientation="6")
    assert read_exif_prior(path, (600, 800)).fov == pytest.approx(53.06, abs=0.05)
    path = _jpeg(tmp_path / "phone_flat.jpg", (800, 600), FocalLengthIn35mmFilm="26")
    assert read_exif_prior(path, (800, 600)).fov == pytest.approx(67.3, abs=0.05)


def with_xmp(path, xmp: str) -> str:
    """The JPEG at ``path`` with an XMP packet in an APP1 segment after its start marker, as a drone writes it."""
    import struct

    data = open(path, "rb").read()
    payload = b"http://ns.adobe.com/xap/1.0/\x00" + xmp.encode("utf-8")
    segment = b"\xff\xe1" + struct.pack(">H", len(payload) + 2) + payload
    with open(path, "wb") as fh:
        fh.write(data[:2] + segment + data[2:])
    return str(path)


DJI_XMP = ('<?xpacket begin="\ufeff" id="W5M0MpCehiHzreSzNTczkc9d"?><x:xmpmeta xmlns:x="adobe:ns:meta/">'
           '<rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description rdf:about="" '
           'xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" drone-dji:AbsoluteAltitude="+612.35" '
           'drone-dji:RelativeAltitude="+{height}" drone-dji:GimbalRollDegree="+0.00" '
           'drone-dji:GimbalYawDegree="{yaw}" drone-dji:GimbalPitchDegree="{pitch}" '
           'drone-dji:FlightYawDegree="+87.10"/></rdf:RDF></x:xmpmeta><?xpacket end="w"?>')


def test_a_drones_gimbal_gives_pitch_and_heading(tmp_path):
    """A drone's EXIF has no direction of view; its XMP has the gimbal's (DJI): pitch -52.3, yaw -40.5 = 319.5."""
    path = _jpeg(tmp_path / "DJI_0042.jpg", (400, 300), FocalLengthIn35mmFilm="24",
                 GPSImgDirection="(87.1)")  # the aircraft's direction: the gimbal's wins
    exif = read_exif_prior(with_xmp(path, DJI_XMP.format(height="119.80", yaw="-40.50", pitch="-52.30")), (400, 300))
    assert exif.pitch == pytest.approx(-52.3) and exif.heading == pytest.approx(319.5)
    assert exif.heading_from_gimbal and not exif.heading_magnetic and exif.relative_altitude == pytest.approx(119.8)
    plain = read_exif_prior(_jpeg(tmp_path / "phone.jpg", (400, 300), FocalLengthIn35mmFilm="24"), (400, 300))
    assert plain.pitch is None and not plain.heading_from_gimbal


def _jpeg_at(path, dem, x, y, **tags):
    """A small JPEG whose GPS tags give map point (x, y) of ``dem``'s CRS, plus ``tags``."""
    from osgeo import osr

    src, dst = osr.SpatialReference(), osr.SpatialReference()
    src.ImportFromWkt(dem.crs_wkt)
    dst.ImportFromEPSG(4326)
    for srs in (src, dst):
        srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    lon, lat, _ = osr.CoordinateTransformation(src, dst).TransformPoint(x, y)

    def dms(value):
        d, m = int(value), int((value - int(value)) * 60)
        return f"({d}) ({m}) ({(value - d - m / 60) * 3600:.4f})"

    return _jpeg(path, (300, 200), GPSLatitude=dms(lat), GPSLatitudeRef="N", GPSLongitude=dms(lon),
                 GPSLongitudeRef="E", **tags)


def test_a_rough_camera_without_a_direction_tag_looks_at_the_dem_and_says_its_heading_is_unknown(tmp_path):
    """A batch row or autoregister without a prior: with a direction tag the heading is known; without one the camera
    looks at the DEM's centre and the registration is told to search every direction (it used to fail the row)."""
    from monoplot_plugin.adapters.exif import exif_rough_camera
    from monoplot_plugin.core.synthetic import synthetic_terrain

    dem = synthetic_terrain((80, 80), cell=50.0, seed=1)
    x0, y0, x1, y1 = dem.bounds()
    x, y = x0 + 0.5 * (x1 - x0), y0 + 0.1 * (y1 - y0)  # south of the centre: looking north
    camera, known = exif_rough_camera(_jpeg_at(tmp_path / "nodir.jpg", dem, x, y), (300, 200), dem)
    assert not known and abs((camera.heading + 180.0) % 360.0 - 180.0) < 1.0
    assert np.allclose(camera.position[:2], (x, y), atol=1.0)
    camera, known = exif_rough_camera(_jpeg_at(tmp_path / "east.jpg", dem, x, y, GPSImgDirection="(90.0)",
                                               GPSImgDirectionRef="T"), (300, 200), dem)
    assert known and abs(camera.heading - 90.0) < 3.0  # true north to the grid's: the convergence, small here
    with pytest.raises(ValueError, match="no GPS position"):
        exif_rough_camera(_jpeg(tmp_path / "plain.jpg", (300, 200)), (300, 200), dem)


def test_the_date_the_photo_was_taken(tmp_path):
    dated = _jpeg(tmp_path / "f.jpg", (300, 200), DateTimeOriginal="2026:05:01 06:30:00", DateTime="2026:06:01 08:00:00")
    assert read_photo_taken(dated) == "2026-05-01T06:30:00"  # when taken, not when last edited
    assert read_photo_taken(_jpeg(tmp_path / "g.jpg", (300, 200), DateTime="2026:06:01 08:00:00")) == \
        "2026-06-01T08:00:00"
    assert read_photo_taken(_jpeg(tmp_path / "h.jpg", (300, 200))) is None
    assert read_photo_taken(str(tmp_path / "missing.jpg")) is None
