"""Reading the input files of a run without Qt: camera files, photos, point tables (Processing and the batch).

Every reader raises :class:`InputError` with a message meant for the user (it names the file and says what is
wrong), which the algorithms turn into a ``QgsProcessingException``.
"""

from __future__ import annotations

import csv
import json
import os
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from ..core.camera import Camera
from .inputs import InputError, check_camera, check_photo_path, read_text  # noqa: F401 (InputError)

__all__ = ["InputError", "load_camera", "read_photo", "photo_size", "read_points_csv", "write_points_csv",
           "PHOTO_COLUMNS", "MAP_COLUMNS"]

#: Accepted column names (case-insensitive) for photo pixel coordinates: u = column, v = row, from the top-left
#: corner of the image, in pixels.
PHOTO_COLUMNS = (("u_px", "u", "col", "column", "x_px", "px"), ("v_px", "v", "row", "y_px", "py"))
#: Accepted column names (case-insensitive prefixes allowed, e.g. X_lv03) for map coordinates in the DEM's CRS.
MAP_COLUMNS = (("x", "easting", "east", "lon"), ("y", "northing", "north", "lat"),
               ("z", "z_m", "elevation", "elev", "alt", "altitude", "height"))




def load_camera(path: str, image_size: Optional[Tuple[int, int]] = None, crs_wkt: str = "") -> Camera:
    """A camera from a Monoplot JSON file (:meth:`Camera.save`) or a KML PhotoOverlay.

    Args:
        path: ``.json`` or ``.kml`` file.
        image_size: (width, height) in pixels of the photo; required for KML (which has no image size), and checked
            against the JSON camera's own size when both are known.
        crs_wkt: WKT (or "EPSG:n") of the DEM's CRS; required for KML (given in WGS84).
    """
    if not path:
        raise InputError("no camera file given")
    if not os.path.isfile(path):
        raise InputError(f"camera file not found: {path}")
    if path.lower().endswith(".kml"):
        if image_size is None:
            raise InputError(f"{os.path.basename(path)}: a KML camera needs the photo (for its size)")
        if not crs_wkt:
            raise InputError(f"{os.path.basename(path)}: a KML camera needs the DEM (for its CRS)")
        try:
            return Camera.from_kml(path, image_size=image_size, dst_crs_wkt=crs_wkt)
        except Exception as exc:  # malformed KML: say which file
            raise InputError(f"cannot read the KML camera {os.path.basename(path)}: {exc}") from exc
    if os.path.getsize(path) == 0:
        raise InputError(f"the camera file {os.path.basename(path)} is empty (0 bytes)")
    try:
        camera = Camera.from_json(read_text(path))
    except (OSError, ValueError, TypeError, KeyError, AttributeError, json.JSONDecodeError) as exc:
        raise InputError(f"cannot read the camera file {os.path.basename(path)} "
                         f"(expected Monoplot camera JSON): {exc}") from exc
    check_camera(camera, f"the camera {os.path.basename(path)}")
    if image_size is not None and tuple(camera.image_size) != tuple(image_size):
        raise InputError(f"camera {os.path.basename(path)} is for a {camera.width}x{camera.height} image but the "
                         f"photo is {image_size[0]}x{image_size[1]}")
    if crs_wkt and camera.crs_wkt and not _same_crs(camera.crs_wkt, crs_wkt):
        # its position would be read in the wrong coordinates: the camera sees no DEM, every product is empty
        raise InputError(f"camera {os.path.basename(path)} is in {_crs_name(camera.crs_wkt)} but the DEM is in "
                         f"{_crs_name(crs_wkt)}: use a DEM in the camera's CRS, or fit the camera on this DEM")
    return camera


def _srs(wkt: str):
    from osgeo import osr

    srs = osr.SpatialReference()
    if srs.SetFromUserInput(wkt) != 0:
        return None
    return srs


def _same_crs(a: str, b: str) -> bool:
    """Whether two CRS definitions (WKT, "EPSG:n") are the same; True when either cannot be parsed."""
    sa, sb = _srs(a), _srs(b)
    if sa is None or sb is None:
        return True
    return bool(sa.IsSame(sb, ["IGNORE_DATA_AXIS_TO_SRS_AXIS_MAPPING=YES",
                               "CRITERION=EQUIVALENT_EXCEPT_AXIS_ORDER_GEOGCRS"]))


def _crs_name(wkt: str) -> str:
    srs = _srs(wkt)
    if srs is None:
        return "an unknown CRS"
    code = srs.GetAuthorityCode(None)
    name = srs.GetName() or "an unnamed CRS"
    return f"{name} (EPSG:{code})" if code else name


def read_photo(path: str) -> np.ndarray:
    """A photo as an (H, W, 3) uint8 RGB array (grey images are repeated on 3 bands; alpha is dropped)."""
    check_photo_path(path)
    import cv2

    try:  # bytes, then imdecode: cv2.imread cannot open non-ASCII paths on Windows
        data = np.fromfile(path, dtype=np.uint8)
    except OSError as exc:
        raise InputError(f"cannot read the photo {os.path.basename(path)}: {exc}") from exc
    if _jpeg_truncated(data.tobytes()):
        # libjpeg fills the missing rows with grey and only prints a warning: products would drape grey on terrain
        raise InputError(f"cannot read the photo {os.path.basename(path)}: the JPEG file is truncated (its image "
                         f"data ends early; the missing part would be grey)")
    image = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None  # EXIF orientation applied, as imread
    if image is None or image.size == 0:
        raise InputError(f"cannot read the photo {os.path.basename(path)}: not an image file, or a damaged one")
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)  # 4 times faster than a reversed copy (1.5 MP: 2 ms)


def _jpeg_truncated(data: bytes) -> bool:
    """True for a JPEG whose last scan has no end-of-image marker after it (a cut-off download or copy).

    In entropy-coded data every 0xFF byte is stuffed (0xFF00) or a restart marker (0xFFD0-D7), so the last end of
    image (0xFFD9) comes after the last start of scan (0xFFDA) in a complete file, also with an EXIF thumbnail
    (whose own scan and end come before the main image's) or bytes appended after the end.

    >>> _jpeg_truncated(b"\\xff\\xd8\\xff\\xda..scan..\\xff\\xd9"), _jpeg_truncated(b"\\xff\\xd8\\xff\\xda..sc")
    (False, True)
    """
    if not data.startswith(b"\xff\xd8"):
        return False
    return data.rfind(b"\xff\xd9") < data.rfind(b"\xff\xda")


def photo_size(path: str) -> Tuple[int, int]:
    """(width, height) of a photo in pixels (reads the whole image, which also checks that it decodes)."""
    image = read_photo(path)
    return image.shape[1], image.shape[0]


def _find_column(header: Sequence[str], names: Sequence[str], exclude: Sequence[str] = ()) -> Optional[int]:
    lowered = [h.strip().lower() for h in header]
    for name in names:  # exact names first
        if name in lowered and lowered.index(name) not in exclude:
            return lowered.index(name)
    for name in names:  # then prefixes such as X_lv03, Z_m
        for i, h in enumerate(lowered):
            if i not in exclude and (h.startswith(name + "_") or h.startswith(name + " ")):
                return i
    return None


def read_points_csv(path: str) -> Dict[str, np.ndarray]:
    """Points from a CSV file with a header row.

    The table may hold photo points (columns ``u_px, v_px``), map points (``X, Y, Z`` in the DEM's CRS, names such
    as ``X_lv03`` or ``Z_m`` accepted) or both on each row (paired ground-control points, as in ``gcps.csv``).

    Returns:
        dict with ``"uv"``: (N, 2) float pixels and/or ``"xyz"``: (N, 3) float map coordinates (Z may be NaN when
        the table has no Z column; the caller samples the DEM), and ``"ids"``: (N,) str (column ``id`` or row
        number).

    >>> import tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "g.csv")
    >>> _ = open(path, "w").write("u_px,v_px,X_lv03,Y_lv03,Z_m\\n10,20,600000,150000,3000\\n")
    >>> points = read_points_csv(path)
    >>> points["uv"].tolist(), points["xyz"].tolist()
    ([[10.0, 20.0]], [[600000.0, 150000.0, 3000.0]])
    """
    if not path or not os.path.isfile(path):
        raise InputError(f"point file not found: {path}")
    import io

    text = read_text(path)  # UTF-8 with or without BOM, UTF-16
    try:
        dialect = csv.Sniffer().sniff(text[:4096], delimiters=",;\t ")
    except csv.Error:
        dialect = csv.excel
    rows = [row for row in csv.reader(io.StringIO(text, newline=""), dialect) if any(cell.strip() for cell in row)]
    name = os.path.basename(path)
    if len(rows) < 2:
        raise InputError(f"{name}: needs a header row and at least one point")
    header, body = rows[0], rows[1:]
    iu = _find_column(header, PHOTO_COLUMNS[0])
    iv = _find_column(header, PHOTO_COLUMNS[1])
    taken = [i for i in (iu, iv) if i is not None]
    ix = _find_column(header, MAP_COLUMNS[0], taken)
    iy = _find_column(header, MAP_COLUMNS[1], taken)
    iz = _find_column(header, MAP_COLUMNS[2], taken)
    iid = _find_column(header, ("id", "fid", "name"))
    result: Dict[str, np.ndarray] = {}

    def numbers(columns):
        out = np.full((len(body), len(columns)), np.nan)
        for r, row in enumerate(body):
            for c, col in enumerate(columns):
                if col is None:
                    continue
                try:
                    out[r, c] = float(row[col])
                except (IndexError, ValueError):
                    raise InputError(f"{name}, line {r + 2}: '{header[col]}' is not a number") from None
        return out

    if iu is not None and iv is not None:
        result["uv"] = numbers((iu, iv))
    if ix is not None and iy is not None:
        result["xyz"] = numbers((ix, iy, iz))
    if not result:
        raise InputError(f"{name}: no point columns found; expected u_px,v_px (photo pixels) and/or X,Y,Z "
                         f"(map coordinates), got {', '.join(header)}")
    result["ids"] = np.array([row[iid] if iid is not None and iid < len(row) else str(r + 1)
                              for r, row in enumerate(body)])
    return result


def write_points_csv(path: str, uv: Optional[np.ndarray] = None, xyz: Optional[np.ndarray] = None,
                     ids: Optional[Sequence] = None) -> None:
    """Write points in the format :func:`read_points_csv` reads (columns id, u_px, v_px, X, Y, Z)."""
    n = len(uv) if uv is not None else len(xyz)
    header = ["id"] + (["u_px", "v_px"] if uv is not None else []) + (["X", "Y", "Z"] if xyz is not None else [])
    import io

    from ..outputs.safe_write import write_text

    text = io.StringIO(newline="")
    writer = csv.writer(text)
    writer.writerow(header)
    for i in range(n):
        row = [ids[i] if ids is not None else i + 1]
        if uv is not None:
            row += [f"{v:.3f}" for v in uv[i]]
        if xyz is not None:
            row += [f"{v:.3f}" for v in xyz[i]]
        writer.writerow(row)
    write_text(path, text.getvalue(), overwrite=True)
