"""Voids and units of a DEM's stored heights: which cells are no-data (declared, sentinels, zero-filled voids, no
height on Earth) and how stored values become metres (scale, offset, feet). Pure numpy; GDAL bands are read, not
imported here.

>>> z = np.array([[-32768.0, 812.0], [790.0, 805.0]])
>>> mark_voids(z)
['1 cells at -32768 (a common no-data value)']
"""

from __future__ import annotations

import math
from typing import List, Optional, Tuple

import numpy as np

__all__ = ["VOID_SENTINELS", "band_to_metres", "mark_voids", "stored_to_metres", "zero_voids"]

#: Heights that mean "no data" in DEMs that do not say so (ESRI/ASCII grids, SRTM, GMTED, exports of GIS tools).
VOID_SENTINELS = (-9999.0, -99999.0, -32768.0, -32767.0, -3.4028234663852886e38)
#: Below the deepest ocean trench or above the highest summit: not a height on Earth.
LOWEST_TERRAIN_M, HIGHEST_TERRAIN_M = -11000.0, 9000.0


#: :func:`zero_voids` judges a DEM's median height on an even sample of about this many cells.
MEDIAN_SAMPLE_CELLS = 1_000_000


def zero_voids(elevation: np.ndarray, min_median: float = 300.0) -> int:
    """Turn exact zeros into NaN when the rest of the terrain is high (median > ``min_median`` m); in place.

    Mountain DEMs without a nodata value often fill voids with 0, which no real high-terrain DEM contains.
    Returns the number of cells changed.

    >>> z = np.array([[0.0, 2000.0], [2100.0, 2200.0]]); zero_voids(z), bool(np.isnan(z[0, 0]))
    (1, True)
    >>> z = np.array([[0.0, 2.0], [3.0, 4.0]]); zero_voids(z)
    0
    """
    zeros = elevation == 0
    if not zeros.any() or zeros.all():
        return 0
    flat = elevation.reshape(-1)
    # the median of an even sample of at most about 1 M cells: of all 100 M cells it took 4.8 s (a copy, a sort)
    sample = flat[::max(1, flat.size // MEDIAN_SAMPLE_CELLS)]
    rest = sample[(sample != 0) & np.isfinite(sample)]
    if rest.size == 0 or np.median(rest) <= min_median:
        return 0
    elevation[zeros] = np.nan
    return int(zeros.sum())


#: Vertical units a band may declare (GDAL's unit type, lower case) that are not metres: their length in metres.
FOOT_UNITS = {"ft": 0.3048, "foot": 0.3048, "feet": 0.3048, "international foot": 0.3048,
              "us-ft": 1200.0 / 3937.0, "ftus": 1200.0 / 3937.0, "us survey foot": 1200.0 / 3937.0,
              "us_survey_foot": 1200.0 / 3937.0}


def band_to_metres(band) -> Tuple[float, float, str]:
    """(a, b, note): heights in metres are ``a * stored + b`` for a GDAL band, from its scale and offset and a
    declared unit of feet; the note says what was applied ("" for plain metres). A trial's DEM stored as UInt16
    with scale 0.1 and offset 500 was read as 4,000-9,000 m, and one in feet as metres: most of both became
    "voids above 9,000 m"."""
    scale, offset = band.GetScale(), band.GetOffset()
    scale = 1.0 if scale in (None, 0.0) else float(scale)
    offset = 0.0 if offset is None else float(offset)
    unit = (band.GetUnitType() or "").strip().lower()
    foot = FOOT_UNITS.get(unit, 1.0)
    said = []
    if scale != 1.0 or offset != 0.0:
        said.append(f"the band's scale {scale:g} and offset {offset:g} applied")
    if foot != 1.0:
        said.append(f"heights in {unit} (the band's unit) converted to metres")
    return scale * foot, offset * foot, "; ".join(said)


def stored_to_metres(elevation: np.ndarray, a: float, b: float, nodata: Optional[float]) -> Optional[float]:
    """Turn stored values into metres in place (``a * z + b``, :func:`band_to_metres`); the stored ``nodata``
    cells become NaN first. Returns the nodata value still to look for (None once they are NaN).

    >>> z = np.array([[4000.0, 0.0]])
    >>> stored_to_metres(z, 0.1, 500.0, 0.0), z.tolist()
    (None, [[900.0, nan]])
    """
    if a == 1.0 and b == 0.0:
        return nodata
    void = elevation == nodata if nodata is not None and not math.isnan(nodata) else None
    elevation *= a
    elevation += b
    if void is not None:
        elevation[void] = np.nan
    return None


def mark_voids(elevation: np.ndarray, nodata: Optional[float] = None, void_value: Optional[float] = None,
               sentinels: bool = True) -> List[str]:
    """Set every void cell of a float elevation grid to NaN, in place; return one sentence per kind of void found.

    Voids are: the declared ``nodata`` value; the user's ``void_value``; NaN and infinite cells; and, with
    ``sentinels``, the common sentinels (:data:`VOID_SENTINELS`), heights that are no height on Earth (below
    -11,000 m or above 9,000 m), and, when the file declares no nodata value, the zero-filled voids of a high DEM
    (:func:`zero_voids`).

    >>> z = np.array([[-9999.0, 1500.0], [np.nan, 1510.0]])
    >>> mark_voids(z)
    ['1 NaN cells', '1 cells at -9999 (a common no-data value)']
    >>> int(np.isnan(z).sum())
    2
    """
    notes: List[str] = []
    lo = hi = math.nan
    if elevation.size:  # one pass for the common case: every height is finite and none is a void's value
        lo, hi = float(np.min(elevation)), float(np.max(elevation))
        special = [v for v in (nodata, void_value) if v is not None and not math.isnan(v)]
        if sentinels:
            special += list(VOID_SENTINELS) + ([0.0] if nodata is None and void_value is None else [])
        if (math.isfinite(lo) and math.isfinite(hi) and not any(lo <= v <= hi for v in special)
                and (not sentinels or (lo >= LOWEST_TERRAIN_M and hi <= HIGHEST_TERRAIN_M))):
            return notes
    known = math.isfinite(lo) and math.isfinite(hi)  # else a NaN or an infinity hides the range

    def mark(mask: np.ndarray, text: str) -> None:
        n = int(mask.sum())
        if n:
            elevation[mask] = np.nan
            notes.append(f"{n} {text}")

    def in_range(value) -> bool:  # only values within the heights' range are compared (each a pass of the grid)
        return value is not None and not math.isnan(value) and (not known or lo <= value <= hi)

    with np.errstate(invalid="ignore"):
        nan = ~np.isfinite(elevation) if not known else None
        if in_range(nodata):
            mark(elevation == nodata, f"cells at the declared nodata value {nodata:g}")
        if in_range(void_value):
            mark(elevation == void_value, f"cells at the void value {void_value:g} you gave")
        if nan is not None:
            mark(nan, "NaN cells")
        if sentinels:
            for value in VOID_SENTINELS:
                if in_range(value):
                    mark(elevation == value, f"cells at {value:g} (a common no-data value)")
            if not known or lo < LOWEST_TERRAIN_M or hi > HIGHEST_TERRAIN_M:
                mark((elevation < LOWEST_TERRAIN_M) | (elevation > HIGHEST_TERRAIN_M),
                     f"cells below {LOWEST_TERRAIN_M:g} m or above {HIGHEST_TERRAIN_M:g} m (no height on Earth)")
            if nodata is None and void_value is None:
                n = zero_voids(elevation)
                if n:
                    notes.append(f"{n} cells at 0 m (zero-filled voids of a high DEM that declares no nodata value)")
    return notes
