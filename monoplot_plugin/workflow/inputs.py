"""The one set of input checks, for the dock and for Processing alike (no Qt, no qgis).

Every function raises :class:`InputError` with a message meant for the user: it names the file and says what is
wrong and what to do. What was silently taken as something else is said in notes (lists of sentences) instead.

- DEMs (:func:`load_dem`): a raster GDAL reads, georeferenced, with a CRS, at least 2 x 2 valid cells; voids from
  the declared nodata, NaN, common sentinels and zero-filled voids (core :func:`~..core.dem.mark_voids`), named in
  the notes.
- Photos (:func:`check_photo_path`): a file, not a folder.
- Cameras (:func:`check_camera`): finite parameters, a usable field of view; (:func:`check_view`) the camera sees
  some of the DEM.
- Text tables (:func:`read_text`): UTF-8 with or without BOM, UTF-16 (BOM or not), else Latin-1.
- Map points (:func:`points_to_dem_crs`): converted from their stated CRS, or from the DEM file's CRS when the DEM
  was reprojected (a geographic DEM is used in UTM: its CSV points are in degrees).
- Products (:func:`check_not_empty`): an empty product is an error unless asked for.
"""

from __future__ import annotations

import math
import os
from typing import List, Optional, Sequence, Tuple

import numpy as np

__all__ = ["InputError", "photo_points_in_frame", "load_dem", "check_dem_file", "check_photo_path", "check_camera",
           "check_view", "read_text", "points_to_dem_crs", "OFF_DEM_NOTE", "HEIGHT_UNIT_NOTE", "is_warning_note",
           "check_not_empty", "MIN_DEM_CELLS"]

#: Rows and columns a DEM needs at the least (the mesh has a triangle per half of a square of four cells).
MIN_DEM_CELLS = 2


class InputError(ValueError):
    """An input the user has to fix; the message says which and why."""


# --- DEM --------------------------------------------------------------------------------------------------------
def check_dem_file(path: str) -> str:
    """The CRS (WKT) of a DEM file, after the checks that need only its header (see :func:`load_dem`)."""
    from osgeo import gdal

    name = os.path.basename(_check_file(path, "DEM", "a raster file"))
    saved = gdal.GetUseExceptions()
    gdal.UseExceptions()
    try:
        ds = gdal.Open(path)
    except RuntimeError as exc:
        raise InputError(f"cannot read the DEM {name}: not a raster GDAL can read ({_first_line(exc)})") from None
    finally:
        if not saved:
            gdal.DontUseExceptions()
    gt = ds.GetGeoTransform(can_return_null=True)
    if gt is None:
        kind = (f"{ds.RasterCount} band(s) of {gdal.GetDataTypeName(ds.GetRasterBand(1).DataType)}"
                if ds.RasterCount else "no band")
        raise InputError(f"the DEM {name} has no georeferencing ({ds.RasterXSize} x {ds.RasterYSize} pixels, "
                         f"{kind}): is it a photo? Give an elevation raster with map coordinates")
    wkt = ds.GetProjection()
    if not wkt:
        raise InputError(f"the DEM {name} has no CRS (coordinate reference system): set one, e.g. "
                         f"gdal_edit.py -a_srs EPSG:2056 {name}, or in the layer's properties in QGIS")
    if ds.RasterXSize < MIN_DEM_CELLS or ds.RasterYSize < MIN_DEM_CELLS:
        raise InputError(f"the DEM {name} is too small: {ds.RasterXSize} x {ds.RasterYSize} cells (at least "
                         f"{MIN_DEM_CELLS} x {MIN_DEM_CELLS}; a useful DEM has hundreds)")
    return wkt


def load_dem(path: str, void_value: Optional[float] = None, progress=None) -> Tuple[object, List[str]]:
    """(core Dem, notes for the user) of a DEM file, checked. A DEM too large to read whole is opened by windows
    (core :func:`~..core.dem_large.open_dem`: its overviews built first when missing, with ``progress``).

    Raises InputError for: no file or a folder; a file GDAL cannot read (a text file, a damaged raster); no
    georeferencing (a photo given as DEM); no CRS; fewer than 2 x 2 cells; no valid cell.

    >>> load_dem("/no/such/dem.tif")
    Traceback (most recent call last):
    ...
    monoplot_plugin.workflow.inputs.InputError: DEM not found: /no/such/dem.tif
    """
    from ..core.dem_large import open_dem

    check_dem_file(path)
    name = os.path.basename(path)
    try:
        dem, notes = open_dem(path, void_value=void_value, progress=progress)
    except Exception as exc:  # GDAL read errors, a CRS PROJ does not know
        raise InputError(f"cannot read the DEM {name}: {_first_line(exc)}") from exc
    if dem.source_crs_wkt:
        notes.append(f"the DEM is in degrees: used in {_crs_name(dem.crs_wkt)} (metres); results are in that CRS")
    void_text = "; ".join(dem.void_notes)
    valid = np.isfinite(dem.elevation)
    if not valid.any():
        raise InputError(f"the DEM {name} has no valid cell: all {dem.elevation.size} cells are voids"
                         + (f" ({void_text})" if void_text else ""))
    rows_ok = int(valid.any(axis=1).sum())
    cols_ok = int(valid.any(axis=0).sum())
    if rows_ok < MIN_DEM_CELLS or cols_ok < MIN_DEM_CELLS:
        raise InputError(f"the DEM {name} has too few valid cells ({int(valid.sum())}: {cols_ok} column(s) x "
                         f"{rows_ok} row(s)) to make a terrain surface")
    if void_text:
        share = 100.0 * (1.0 - valid.mean())
        notes.append(f"treated as void in {name} ({share:.1f} % of the grid): {void_text}; pixels that see a void "
                     f"are nodata")
    return dem, notes


def _first_line(exc: Exception) -> str:
    return str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__


def _crs_name(wkt: str) -> str:
    from osgeo import osr

    srs = osr.SpatialReference()
    if not wkt or srs.SetFromUserInput(wkt) != 0:
        return "an unknown CRS"
    code = srs.GetAuthorityCode(None)
    return f"{srs.GetName()} (EPSG:{code})" if code else srs.GetName()


# --- photo and camera -------------------------------------------------------------------------------------------
def check_photo_path(path: str) -> str:
    """The photo path, checked: given, existing, a file (not a folder)."""
    return _check_file(path, "photo", "an image file")


def _check_file(path: str, what: str, kind: str) -> str:
    """``path``, or InputError: nothing given, a folder, not there."""
    if not path:
        raise InputError(f"no {what} given")
    if os.path.isdir(path):
        raise InputError(f"the {what} {path} is a folder, not {kind}")
    if not os.path.isfile(path):
        raise InputError(f"{what} not found: {path}")
    return path


def check_camera(camera, name: str = "the camera") -> None:
    """Refuse a camera with non-finite or impossible parameters (NaN position, field of view not in (0, 180))."""
    values = {"X": camera.position[0], "Y": camera.position[1], "Z": camera.position[2], "heading": camera.heading,
              "pitch": camera.pitch, "roll": camera.roll, "fov": camera.fov}
    bad = [k for k, v in values.items() if not math.isfinite(float(v))]
    if bad:
        raise InputError(f"{name} has no valid {', '.join(bad)} (not a number): fit it again or fix the file")
    if not 0.0 < float(camera.fov) < 180.0:
        raise InputError(f"{name} has a field of view of {camera.fov:g} degrees (must be between 0 and 180)")
    if camera.width < 1 or camera.height < 1:
        raise InputError(f"{name} is for a {camera.width} x {camera.height} image")


def check_view(camera, dem, name: str = "the camera") -> None:
    """Refuse a camera that sees no part of the DEM (wrong CRS, wrong position, looking away)."""
    from ..core.dem import view_window

    z = dem.elevation[np.isfinite(dem.elevation)]
    window = view_window(camera, dem.geotransform, dem.shape, float(z.min()), float(z.max()))
    if window is None:
        xmin, ymin, xmax, ymax = dem.bounds()
        x, y, h = camera.position
        raise InputError(f"{name} sees no part of the DEM: it stands at ({x:.1f}, {y:.1f}, {h:.1f}), heading "
                         f"{camera.heading:.1f}, pitch {camera.pitch:.1f}; the DEM covers x {xmin:.1f} to {xmax:.1f}, "
                         f"y {ymin:.1f} to {ymax:.1f} (heights {z.min():.0f} to {z.max():.0f} m). Is the camera in "
                         f"the DEM's CRS?")


def check_not_empty(count: int, what: str, allow_empty: bool = False, hint: str = "") -> None:
    """An empty product is an error (with ``hint``: why it may be empty), unless ``allow_empty``."""
    if count == 0 and not allow_empty:
        raise InputError(f"the {what} would be empty" + (f": {hint}" if hint else "")
                         + " (allow empty outputs to write it anyway)")


# --- text tables and point coordinates ------------------------------------------------------------------------
def read_text(path: str) -> str:
    """The text of a table file: UTF-8 (with or without BOM), UTF-16 (with BOM, or without one when every other
    byte is zero), else Windows-1252 (a Windows spreadsheet's), else Latin-1 (never fails on bytes).

    >>> import tempfile
    >>> p = os.path.join(tempfile.mkdtemp(), "t.csv")
    >>> _ = open(p, "wb").write("id,X\\n1,7\\n".encode("utf-16"))
    >>> read_text(p)
    'id,X\\n1,7\\n'
    """
    with open(path, "rb") as fh:
        data = fh.read()
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        return data.decode("utf-16")
    if data.startswith(b"\xef\xbb\xbf"):
        return data[3:].decode("utf-8", errors="replace")
    if len(data) >= 4 and data[1::2].count(0) > 0.4 * (len(data) // 2):
        return data.decode("utf-16-le", errors="replace")
    if len(data) >= 4 and data[0::2].count(0) > 0.4 * (len(data) // 2):
        return data.decode("utf-16-be", errors="replace")
    for encoding in ("utf-8", "cp1252"):  # a Windows spreadsheet's ‘Gipfel’ – 12 read as Latin-1 had control codes
        try:
            return data.decode(encoding)
        except UnicodeDecodeError:
            pass
    return data.decode("latin-1")


def points_to_dem_crs(xyz: np.ndarray, dem, points_crs: str = "", name: str = "the points",
                      candidates: Sequence[str] = ()) -> Tuple[np.ndarray, List[str]]:
    """(N, 3) map points in the DEM's working CRS, and notes.

    The points are in ``points_crs`` when given (WKT or "EPSG:n"), else in the CRS of the DEM file: for a DEM in
    degrees that Monoplot uses in UTM (``dem.source_crs_wkt``) they are converted too. A table without a stated CRS
    whose numbers put most points off the DEM is tried as longitude/latitude (WGS 84) and in each of the
    ``candidates`` (the project's CRS): the first that puts most of them on the DEM is taken (noted). Points left
    off the DEM are noted too (a trial: a GCP table in the project's CRS, LV95, read as the DEM's LV03 put the 11
    points 2,200 km away, the fit said "ok" and the XYZ raster was empty, without a word). Points whose X and Y,
    swapped, fall on the DEM when they do not as given are swapped (noted).
    """
    xyz = np.array(xyz, dtype=float).reshape(-1, 3)
    notes: List[str] = []
    source = points_crs or dem.source_crs_wkt or ""
    if not points_crs and dem.source_crs_wkt and len(xyz) and not _degrees(xyz):
        # a DEM file in degrees (``source_crs_wkt``: it is used in UTM), a table in metres (a trial: LV03 GCPs with
        # the DEM in EPSG:4326 were "converted from WGS 84", every point left off the DEM, the fit refused): its CRS
        # is not the DEM file's, guess it
        source = ""
    if len(xyz) and dem.crs_wkt and (not source or _same_crs(source, dem.crs_wkt)) and \
            _inside(dem, xyz).mean() < 0.5 and _inside(dem, xyz[:, [1, 0, 2]]).mean() >= 0.5:
        # a Swiss or survey table: Y is the easting, X the northing (a trial's "Punkt;u_px;v_px;Y;X;H" put all 11
        # points off the DEM, and the fit, 124 px, said nothing of the axes)
        swapped = xyz[:, [1, 0, 2]]
        notes.append(f"{_points_of(name)} have X and Y the other way round (Y east, X north, as Swiss and many "
                     "survey tables write them) and were swapped")
        return swapped, notes + _dem_notes(dem, swapped, name)
    if not source and len(xyz) and dem.crs_wkt and _inside(dem, xyz).mean() < 0.5:
        lonlat = _degrees(xyz)
        guesses = ([("EPSG:4326", "longitude/latitude (WGS 84)")] if lonlat else []) + [
            (crs, f"{_crs_name(crs)} coordinates") for crs in candidates if crs and not _same_crs(crs, dem.crs_wkt)]
        for crs, words in guesses:
            try:
                converted = _transform(xyz, crs, dem.crs_wkt)
            except Exception:  # a CRS that cannot be converted is no guess  # noqa: BLE001
                continue
            if _inside(dem, converted).mean() >= 0.5:
                notes.append(f"{_points_of(name)} look like {words} and were converted to the DEM's CRS")
                return converted, notes + _dem_notes(dem, converted, name)
    if not source or not dem.crs_wkt or _same_crs(source, dem.crs_wkt):
        return xyz, notes + _dem_notes(dem, xyz, name)
    converted = _transform(xyz, source, dem.crs_wkt)
    notes.append(f"{_points_of(name)} were converted from {_crs_name(source)} to {_crs_name(dem.crs_wkt)}")
    return converted, notes + _dem_notes(dem, converted, name)


def photo_points_in_frame(uv: np.ndarray, size: Sequence[float], name: str = "the points"
                          ) -> Tuple[np.ndarray, List[str]]:
    """(N, 2) photo points and notes: points whose u and v are the other way round (row first, as a table of rows
    and columns writes them) are swapped, when several lie off the ``size`` (W, H) photo as given and every one lies
    on it swapped (noted). A trial's table with v first: 5 of its 12 points off the photo came in rejected, and the
    fit on the 7 others, their u and v swapped too, was wrong.

    >>> uv = np.array([[100.0, 1200.0], [900.0, 1400.0], [500.0, 300.0]])
    >>> swapped, notes = photo_points_in_frame(uv, (1500, 1000), "gcps.csv")
    >>> swapped.tolist(), notes[0][:55]
    ([[1200.0, 100.0], [1400.0, 900.0], [300.0, 500.0]], 'The points of gcps.csv have u and v the other way round')
    >>> photo_points_in_frame(uv[:1], (1500, 1000))[1]  # one point off the photo: a typo as likely as a swap
    []
    """
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    w, h = float(size[0]), float(size[1])
    given = np.isfinite(uv).all(axis=1)

    def on_photo(points):
        return (points[:, 0] >= 0) & (points[:, 0] <= w) & (points[:, 1] >= 0) & (points[:, 1] <= h)

    off = given & ~on_photo(uv)
    if off.sum() < 2 or not on_photo(uv[given][:, ::-1]).all():
        return uv, []
    return uv[:, ::-1].copy(), [f"{_points_of(name)} have u and v the other way round ({int(off.sum())} of "
                                f"{int(given.sum())} lie off the {w:.0f} x {h:.0f} photo as given, every one on it "
                                "swapped) and were swapped: the columns are u_px (across), v_px (down)"]


#: Notes of :func:`points_to_dem_crs` that say this are warnings (points off the DEM), the others information.
OFF_DEM_NOTE = "lie outside the DEM"
#: ... and so are those that say this (heights in feet against metres, :func:`_height_unit_notes`).
HEIGHT_UNIT_NOTE = "times the DEM's there"
#: Metres in a foot.
FOOT_M = 0.3048


def is_warning_note(note: str) -> bool:
    """A note of :func:`points_to_dem_crs` that is a warning, not information."""
    return OFF_DEM_NOTE in note or HEIGHT_UNIT_NOTE in note


def _dem_notes(dem, xyz: np.ndarray, name: str) -> List[str]:
    return _off_dem_notes(dem, xyz, name) + _height_unit_notes(dem, xyz, name)


def _height_unit_notes(dem, xyz: np.ndarray, name: str) -> List[str]:
    """A warning when the points' own heights are the DEM's in another unit: about 0.305 times them (a DEM in feet
    that does not say so, or points in metres against it) or 3.28 times. A trial's DEM in feet without its unit
    tag: the fit ended "poor", 800 px, with advice to check the pairs, and nothing hinted at feet.

    >>> from monoplot_plugin.core.dem import Dem
    >>> dem = Dem.from_array(np.full((10, 10), 3000.0), (0, 10, 0, 100, 0, -10))
    >>> pts = np.array([[15.0, 15.0, 914.4], [55.0, 45.0, 915.0], [75.0, 85.0, 913.9]])
    >>> "0.305 times the DEM's there" in _height_unit_notes(dem, pts, "gcps.csv")[0]
    True
    >>> _height_unit_notes(dem, pts * [1, 1, 3.28], "gcps.csv")
    []
    """
    z = np.asarray(xyz, dtype=float)[:, 2]
    given = np.isfinite(xyz).all(axis=1) & _inside(dem, xyz)
    if given.sum() < 3:
        return []
    ground = np.asarray(dem.sample(xyz[given, 0], xyz[given, 1]), dtype=float)
    usable = np.isfinite(ground) & (np.abs(ground) > 10.0)
    if usable.sum() < 3:
        return []
    ratio = z[given][usable] / ground[usable]
    for factor, why in ((FOOT_M, "the DEM's heights are probably in feet without saying so (set its unit, or "
                                  "convert it to metres), or the points' are metres against a DEM in feet"),
                        (1.0 / FOOT_M, "the points' heights are probably in feet (give them in metres), or the "
                                       "DEM's in metres against points in feet")):
        if np.mean(np.abs(ratio / factor - 1.0) < 0.05) >= 0.8:
            return [f"{_points_of(name)} have heights about {factor:.3g} {HEIGHT_UNIT_NOTE} (median of "
                    f"{len(ratio)}): {why}"]
    return []


def _points_of(name: str) -> str:
    """The subject of a note: "The points of gcps.csv" for a file name (it read "gcps.csv look like ...").

    >>> _points_of("gcps.csv"), _points_of("the points")
    ('The points of gcps.csv', 'The points')
    """
    return "The points" if name == "the points" else f"The points of {name}"


def _off_dem_notes(dem, xyz: np.ndarray, name: str) -> List[str]:
    given = np.isfinite(xyz[:, :2]).all(axis=1)
    off = int((given & ~_inside(dem, xyz)).sum())
    if not off:
        return []
    return [f"{off} of {int(given.sum())} map points of {name} {OFF_DEM_NOTE}: are their X, Y in the DEM's CRS, "
            f"{_crs_name(dem.crs_wkt)}?"]


def _degrees(xyz: np.ndarray) -> bool:
    """Every X, Y could be a longitude and a latitude."""
    return bool((np.abs(xyz[:, 0]) <= 180).all() and (np.abs(xyz[:, 1]) <= 90).all())


def _same_crs(a: str, b: str) -> bool:
    from osgeo import osr

    sa, sb = osr.SpatialReference(), osr.SpatialReference()
    return sa.SetFromUserInput(a) == 0 and sb.SetFromUserInput(b) == 0 and bool(sa.IsSame(sb))


def _inside(dem, xyz: np.ndarray) -> np.ndarray:
    xmin, ymin, xmax, ymax = dem.bounds()
    return (xyz[:, 0] >= xmin) & (xyz[:, 0] <= xmax) & (xyz[:, 1] >= ymin) & (xyz[:, 1] <= ymax)


def _transform(xyz: np.ndarray, source: str, target: str) -> np.ndarray:
    from osgeo import osr

    a, b = osr.SpatialReference(), osr.SpatialReference()
    a.SetFromUserInput(source)
    b.SetFromUserInput(target)
    for srs in (a, b):
        srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    out = xyz.copy()
    if len(xyz):
        pts = osr.CoordinateTransformation(a, b).TransformPoints(
            [(float(x), float(y), 0.0) for x, y in xyz[:, :2]])
        out[:, :2] = np.asarray(pts, dtype=float)[:, :2]
    return out
