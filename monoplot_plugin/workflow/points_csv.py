"""Point tables as CSV files, for the dock and Processing: the one reader and the one writer.

Photo points are pixels ``u_px, v_px`` (column, row from the top-left corner); map points ``X, Y, Z`` in the DEM's
CRS; a row may hold both (a paired ground-control point, as in ``gcps.csv``). An optional ``id`` column names the
points and an optional ``check`` column (1/0, true/false, yes/no) marks check points: pairs kept out of the fit to
measure it; without one, a ``type`` (or ``role``, ``use``…) column whose values include CP or check does. A Z
given in the table is the surveyed height and is used as given; an empty or missing Z is NaN (the caller samples
the DEM).
"""

from __future__ import annotations

import csv
import io
import os
import re
from typing import Dict, Optional, Sequence

import numpy as np

from .inputs import InputError, read_text

__all__ = ["read_points_csv", "write_points_csv", "PHOTO_COLUMNS", "MAP_COLUMNS", "CHECK_COLUMNS"]

#: Accepted column names (case-insensitive) for photo pixel coordinates: u = column, v = row, from the top-left
#: corner of the image, in pixels.
PHOTO_COLUMNS = (("u_px", "u", "col", "column", "x_px", "px", "image_x", "img_x", "pixel_x"),
                 ("v_px", "v", "row", "y_px", "py", "image_y", "img_y", "pixel_y"))
#: Accepted column names (case-insensitive prefixes allowed, e.g. X_lv03) for map coordinates in the DEM's CRS;
#: a surveyor's E, N, H only as they are (no prefix: "n_obs" is not a northing).
MAP_COLUMNS = (("x", "easting", "east", "lon", "e"), ("y", "northing", "north", "lat", "n"),
               ("z", "z_m", "elevation", "elev", "alt", "altitude", "height", "h"))
_EXACT_ONLY = ("e", "n", "h")
#: Accepted names of the check-point flag column.
CHECK_COLUMNS = ("check", "is_check", "checkpoint", "check_point")
#: Column names of a point's name ("Punkt": a Swiss table's; without one, points are numbered by row).
ID_COLUMNS = ("id", "fid", "name", "point", "punkt", "label", "nr", "gcp")
_TRUE = ("1", "true", "yes", "y", "t", "check", "x")
#: Names of a column that says each point's role (GCP or check point), read as the check flag when a row's value is
#: one of :data:`CHECK_ROLES` (a trial's ``type`` column of CP / GCP was ignored: its check points were fitted).
ROLE_COLUMNS = ("type", "role", "use", "usage", "kind", "class", "category", "purpose")
CHECK_ROLES = ("cp", "chk", "check", "checkpoint", "check point", "check_point", "check-point", "icp", "validation",
               "independent", "control check")


def _find_column(header: Sequence[str], names: Sequence[str], exclude: Sequence[str] = ()) -> Optional[int]:
    lowered = [h.strip().lower() for h in header]
    for name in names:  # exact names first
        if name in lowered and lowered.index(name) not in exclude:
            return lowered.index(name)
    for name in names:  # then prefixes such as X_lv03, Z_m
        if name in _EXACT_ONLY:
            continue
        for i, h in enumerate(lowered):
            if i not in exclude and (h.startswith(name + "_") or h.startswith(name + " ")):
                return i
    return None


def read_points_csv(path: str) -> Dict[str, np.ndarray]:
    """Points from a CSV file with a header row.

    The table may hold photo points (columns ``u_px, v_px``), map points (``X, Y, Z`` in the DEM's CRS, names such
    as ``X_lv03`` or ``Z_m`` accepted) or both on each row (paired ground-control points, as in ``gcps.csv``).

    Returns:
        dict with ``"uv"``: (N, 2) float pixels and/or ``"xyz"``: (N, 3) float map coordinates (Z is NaN where
        the table has no Z column or an empty cell; the caller samples the DEM), ``"ids"``: (N,) str (column
        ``id`` or row number), ``"unused"``: the names of numeric columns it did not read, and, when the table has
        a check column, ``"check"``: (N,) bool. A ";" or tab-separated table may use decimal commas.

    >>> import tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "g.csv")
    >>> _ = open(path, "w").write("u_px,v_px,X_lv03,Y_lv03,Z_m\\n10,20,600000,150000,3000\\n")
    >>> points = read_points_csv(path)
    >>> points["uv"].tolist(), points["xyz"].tolist()
    ([[10.0, 20.0]], [[600000.0, 150000.0, 3000.0]])
    >>> write_points_csv(path, uv=[[1, 2]], xyz=[[3, 4, 5]], ids=["a"], check=[True])
    >>> points = read_points_csv(path)
    >>> points["ids"].tolist(), points["check"].tolist(), points["xyz"].tolist()
    (['a'], [True], [[3.0, 4.0, 5.0]])
    >>> _ = open(path, "w").write("id,u,v,X,Y,Z,type\\nA,1,2,3,4,5,GCP\\nB,6,7,8,9,10,CP\\n")
    >>> read_points_csv(path)["check"].tolist()  # a column of each point's role: CP marks a check point
    [False, True]
    >>> _ = open(path, "w").write("u_px,X,Y,Z\\n10,600000,150000,3000\\n")
    >>> try:
    ...     read_points_csv(path)
    ... except InputError as exc:
    ...     print(exc)
    g.csv: a u_px column but no v_px column (found u_px, X, Y, Z)
    """
    if not path or not os.path.isfile(path):
        raise InputError(f"point file not found: {path}")
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
    iid = _find_column(header, ID_COLUMNS)
    icheck = _find_column(header, CHECK_COLUMNS)
    check_words = _TRUE
    if icheck is None:
        irole = _find_column(header, ROLE_COLUMNS)
        if irole is not None and any(irole < len(row) and row[irole].strip().lower() in CHECK_ROLES for row in body):
            icheck, check_words = irole, CHECK_ROLES
    result: Dict[str, np.ndarray] = {}

    def numbers(columns):
        out = np.full((len(body), len(columns)), np.nan)
        for r, row in enumerate(body):
            for c, col in enumerate(columns):
                if col is None:
                    continue
                cell = row[col].strip() if col < len(row) else ""
                if not cell and c == 2:
                    continue  # no surveyed height on this row: NaN, the DEM's
                try:
                    out[r, c] = float(cell)
                except ValueError:
                    out[r, c] = _decimal_comma(cell, dialect.delimiter, f"{name}, line {r + 2}: '{header[col]}'")
        return out

    for (a, b), names in (((iu, iv), PHOTO_COLUMNS), ((ix, iy), MAP_COLUMNS[:2])):
        if (a is None) != (b is None):  # half a pair of columns: name the missing one (a generic refusal did not)
            have, lack = (names[0][0], names[1][0]) if b is None else (names[1][0], names[0][0])
            raise InputError(f"{name}: a {have} column but no {lack} column (found {', '.join(header)})")
    if iu is not None and iv is not None:
        result["uv"] = numbers((iu, iv))
    if ix is not None and iy is not None:
        result["xyz"] = numbers((ix, iy, iz))
    if not result:
        raise InputError(f"{name}: no point columns found; expected u_px,v_px (photo pixels) and/or X,Y,Z "
                         f"(map coordinates), got {', '.join(header)}")
    result["ids"] = np.array([row[iid] if iid is not None and iid < len(row) else str(r + 1)
                              for r, row in enumerate(body)])
    result["named"] = iid is not None  # the ids are the table's own, not row numbers
    if icheck is not None:
        result["check"] = np.array([icheck < len(row) and row[icheck].strip().lower() in check_words
                                    for row in body])
    # numeric columns read as nothing (a trial's image_x, image_y gave 8 map points and no word of the photo's)
    used = {iu, iv, ix, iy, iz, iid, icheck}
    result["unused"] = [header[i].strip() for i in range(len(header)) if i not in used and i < len(body[0])
                        and _is_number(body[0][i], dialect.delimiter)]
    return result


def _is_number(cell: str, delimiter: str) -> bool:
    try:
        float(cell)
        return True
    except ValueError:
        pass
    try:
        _decimal_comma(cell.strip(), delimiter, "")
        return True
    except InputError:
        return False


def _decimal_comma(cell: str, delimiter: str, where: str) -> float:
    """A cell that is not a plain number: a decimal comma where columns are not separated by commas (a spreadsheet
    of a European locale: "301,68" in a ";" table) is read as a point, and so are thousands grouped the ways
    spreadsheets write them ("642.691,951" in a ";" table, "642'691.951" or "642’691.951" Swiss, "642 691,95");
    else an :class:`InputError` that quotes it.

    >>> _decimal_comma("301,68", ";", "g.csv, line 2: 'u_px'")
    301.68
    >>> [_decimal_comma(c, ";", "") for c in ("642.691,951", "642'691.951", "642’691.951", "1 642 691,5")]
    [642691.951, 642691.951, 642691.951, 1642691.5]
    >>> try:
    ...     _decimal_comma("12 m", ",", "g.csv, line 2: 'Z'")
    ... except InputError as exc:
    ...     print(exc)
    g.csv, line 2: 'Z' is "12 m", not a number
    """
    text = cell.replace("\u00a0", " ").replace("\u202f", " ").strip()
    if re.fullmatch(r"-?\d{1,3}(['’]\d{3})+(\.\d+)?", text):  # Swiss: 642'691.951
        return float(re.sub(r"['’]", "", text))
    if delimiter != ",":
        if re.fullmatch(r"-?\d{1,3}([. ]\d{3})+(,\d+)?", text):  # 642.691,951 or 642 691,951
            return float(re.sub(r"[. ]", "", text).replace(",", "."))
        if text.count(",") == 1 and "." not in text:
            try:
                return float(text.replace(",", "."))
            except ValueError:
                pass
    hint = " (a decimal comma in a comma-separated table? separate the columns with ; or use decimal points)" \
        if "," in cell and delimiter == "," else ""
    raise InputError(f'{where} is "{cell}", not a number{hint}')


def write_points_csv(path: str, uv: Optional[np.ndarray] = None, xyz: Optional[np.ndarray] = None,
                     ids: Optional[Sequence] = None, check: Optional[Sequence[bool]] = None) -> None:
    """Write points in the format :func:`read_points_csv` reads (columns id, u_px, v_px, X, Y, Z, check).

    A NaN Z is written as an empty cell (read back as "take the DEM's"). Map coordinates keep 12 significant
    digits: millimetres in metres, and about 0.1 mm in degrees (three decimals of a longitude are 55 m)."""
    from ..outputs.safe_write import write_text

    n = len(uv) if uv is not None else len(xyz)
    header = (["id"] + (["u_px", "v_px"] if uv is not None else []) + (["X", "Y", "Z"] if xyz is not None else [])
              + (["check"] if check is not None else []))
    text = io.StringIO(newline="")
    writer = csv.writer(text)
    writer.writerow(header)
    for i in range(n):
        row = [ids[i] if ids is not None else i + 1]
        if uv is not None:
            row += [f"{float(v):.3f}" for v in uv[i]]
        if xyz is not None:
            row += ["" if not np.isfinite(float(v)) else f"{float(v):.12g}" for v in xyz[i]]
        if check is not None:
            row.append(1 if check[i] else 0)
        writer.writerow(row)
    write_text(path, text.getvalue(), overwrite=True)
