"""DEMs larger than memory: a DEM file read by windows, at the level of detail a camera needs.

A :class:`DemSource` keeps the file open and reads nothing up front. For a camera it plans distance bands
(:meth:`DemSource.bands`): band ``k`` covers the depths (distance along the optical axis) ``[near_k, far_k)`` and is
read at the coarsest level whose cells are at most ``lod`` times the footprint of a pixel at ``near_k``
(``near_k / f`` metres, f = focal length in pixels), through the cells that the camera's view frustum between those
depths covers, row by row (:meth:`DemSource.read_view`, :func:`~.dem_window_view.view_footprint`). The first band is
always at full resolution. Levels are the file's GDAL overviews (:func:`build_overviews` makes them, as a ``.ovr``
beside the file, when they are missing; :func:`open_dem_source` does it and says so); without overviews a coarse
level is read by decimating (GDAL's averaging read), which touches every full-resolution block it covers.
:func:`~.xyz_lod.compute_xyz_lod` z-buffers the bands near to far; the steps that take one DEM (rendering,
suggestions) take :meth:`DemSource.view_dem`, one ordinary Dem of the view within a cell budget (:func:`as_dem`).

Each band is an ordinary :class:`~.dem.Dem` (a window of one level), voids marked as :meth:`Dem.open` marks them.

>>> import os, tempfile
>>> import numpy as np
>>> from .dem import Dem
>>> folder = tempfile.TemporaryDirectory()
>>> path = os.path.join(folder.name, "dem.tif")
>>> Dem.from_array(np.arange(64.0 * 64).reshape(64, 64), (0, 1, 0, 64, 0, -1), "EPSG:2056").save(path)
>>> src = DemSource(path)
>>> src.shape, src.levels
((64, 64), [1])
>>> build_overviews(path, min_size=16)
[2, 4]
>>> DemSource(path).levels
[1, 2, 4]
>>> src.read((2, 3, 4, 5)).elevation.shape, src.read((2, 3, 4, 5)).window
((4, 5), (2, 3))
>>> del src; folder.cleanup()
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import dataclass
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np

from .dem import Dem, DemReadCanceled, _wkt_or_empty, band_to_metres, mark_voids, stored_to_metres
from .dem_window_view import view_footprint, view_window

__all__ = ["DemSource", "DemBand", "as_dem", "open_dem_source", "build_overviews", "missing_overviews",
           "OverviewsCanceled", "overview_factors",
           "footprint_spans", "LOD_OVERLAP"]

logger = logging.getLogger("monoplot")

#: A band's hits are kept up to this fraction beyond its far depth (the next band starts at that far depth), so a
#: ray that grazes the seam between two levels keeps the finer one's answer.
LOD_OVERLAP = 0.05

Progress = Callable[[float, str], None]


@dataclass
class DemBand:
    """One distance band of a camera's view: ``dem`` (one level, one window) for depths ``[near, far)`` metres, of
    which the cells ``[lo[r], hi[r])`` of each row r were read (``spans`` = (lo, hi); NaN elsewhere)."""

    dem: Dem
    level: int
    near: float
    far: float
    spans: Tuple[np.ndarray, np.ndarray]


def overview_factors(size: Tuple[int, int], min_size: int = 256) -> List[int]:
    """Overview factors 2, 4, 8, ... until the smaller side of the grid would fall below ``min_size`` cells.

    >>> overview_factors((40960, 40960))
    [2, 4, 8, 16, 32, 64, 128]
    >>> overview_factors((300, 200))
    []
    """
    factors = []
    f = 2
    while min(size) // f >= min_size:
        factors.append(f)
        f *= 2
    return factors


class OverviewsCanceled(DemReadCanceled):
    """The person canceled while the overviews were built (the partial ``.ovr`` file was removed)."""


def missing_overviews(path: str, min_size: int = 256) -> List[int]:
    """The overview factors :func:`build_overviews` would build for the DEM file at ``path`` ([] = none)."""
    from osgeo import gdal

    gdal.UseExceptions()
    ds = gdal.Open(str(path), gdal.GA_ReadOnly)
    band = ds.GetRasterBand(1)
    have = {round(ds.RasterXSize / band.GetOverview(i).XSize) for i in range(band.GetOverviewCount())}
    return [f for f in overview_factors((ds.RasterYSize, ds.RasterXSize), min_size) if f not in have]


def build_overviews(path: str, progress: Optional[Progress] = None, min_size: int = 256,
                    resampling: str = "AVERAGE", is_canceled: Optional[Callable[[], bool]] = None) -> List[int]:
    """Build the missing GDAL overviews of a DEM file (2, 4, ... down to ``min_size`` cells), as an external
    ``.ovr`` beside it (the DEM itself is not modified); ``progress(fraction, message)`` as they are computed.
    Returns the factors built ([] when the file has them already or is too small); says so on the log.

    Raises :class:`OverviewsCanceled` when ``is_canceled()`` turns true; a ``.ovr`` file this call started is then
    removed, so that a half-written one never serves as the DEM's far terrain."""
    from osgeo import gdal

    gdal.UseExceptions()
    factors = missing_overviews(path, min_size)
    if not factors:
        return []
    message = f"building overviews {factors} of the DEM {os.path.basename(str(path))} (once; saved beside it)"
    logger.info("%s", message)
    ovr = str(path) + ".ovr"
    existed = os.path.exists(ovr)
    canceled = []

    def callback(fraction, _msg, _data):
        if is_canceled is not None and is_canceled():
            canceled.append(True)
            return 0  # GDAL stops and raises
        if progress is not None:
            progress(float(fraction), message)
        return 1

    ds = gdal.Open(str(path), gdal.GA_ReadOnly)
    try:
        ds.BuildOverviews(resampling, factors, callback=callback)
    except RuntimeError:
        if not canceled:
            raise
    finally:
        ds = None
    if canceled:
        if not existed and os.path.exists(ovr):
            os.remove(ovr)
        raise OverviewsCanceled("canceled while building the DEM's overviews")
    return factors


def as_dem(dem, camera=None, max_range: Optional[float] = None, max_cells: float = 25e6) -> Dem:
    """``dem`` itself when it is a :class:`Dem`; for a :class:`DemSource`, one Dem to work on: what ``camera`` sees
    (:meth:`DemSource.view_dem`), or without a camera the whole grid at the finest level of at most ``max_cells``
    cells. The steps that take one DEM (rendering, suggestions) call it, so that they take a large DEM file too."""
    if not isinstance(dem, DemSource):
        source = getattr(dem, "source", None)  # a LargeDem (core.dem_large): its file, for what the camera sees
        if camera is None or not isinstance(source, DemSource):
            return dem
        dem = source
    if camera is not None:
        return dem.view_dem(camera, max_cells=max_cells, max_range=max_range)
    levels = dem.levels if len(dem.levels) > 1 else [1] + overview_factors(dem.shape)
    for factor in levels:
        rows, cols = dem.level_shape(factor)
        if rows * cols <= max_cells:
            break
    return dem.read(None, factor)


def open_dem_source(path: str, progress: Optional[Progress] = None, build: bool = True,
                    void_value: Optional[float] = None,
                    is_canceled: Optional[Callable[[], bool]] = None) -> Tuple["DemSource", List[str]]:
    """(DemSource, notes for the user) of a large DEM file: its overviews are built first when it has none (with
    ``progress``, and a note that says so; :class:`OverviewsCanceled` when ``is_canceled()`` turns true meanwhile);
    a DEM folder that cannot be written to is noted (far terrain is then decimated as it is read, which is
    slower)."""
    notes: List[str] = []
    if build:
        try:
            built = build_overviews(path, progress, is_canceled=is_canceled)
        except RuntimeError as exc:
            notes.append(f"could not build overviews of {os.path.basename(path)} ({str(exc).strip()}): far terrain "
                         f"is decimated as it is read, which is slower")
        else:
            if built:
                notes.append(f"built overviews 1/{built[0]} to 1/{built[-1]} of {os.path.basename(path)} (once, saved "
                             f"as {os.path.basename(path)}.ovr) to read far terrain at a coarser resolution")
    return DemSource(path, void_value=void_value), notes


class DemSource:
    """A DEM file opened for windowed, multi-level reads (see the module docstring). Geographic DEMs are refused
    (``Dem.open`` reprojects them whole); the Dem API for DEMs that fit in memory is unchanged.

    Attributes:
        path, shape (rows, cols), geotransform, crs_wkt, nodata; ``levels``: the factors available (1 = full
        resolution, then the overviews); zmin, zmax: the height range (from the file's statistics or its coarsest
        overview, widened by a tenth of the range: an average can miss a peak).
    """

    def __init__(self, path: str, void_value: Optional[float] = None, band: int = 1, sentinels: bool = True):
        from osgeo import gdal, osr

        gdal.UseExceptions()
        self.path = str(path)
        self._ds = gdal.Open(self.path)
        self._band = self._ds.GetRasterBand(band)
        self.shape = (self._ds.RasterYSize, self._ds.RasterXSize)
        self.geotransform = tuple(float(g) for g in self._ds.GetGeoTransform())
        self.crs_wkt = _wkt_or_empty(self._ds.GetProjection() or "")
        srs = osr.SpatialReference()
        if self.crs_wkt and srs.ImportFromWkt(self.crs_wkt) == 0 and srs.IsGeographic():
            raise ValueError(f"{path} is in geographic degrees: read it with Dem.open, which reprojects it to UTM")
        self.nodata = self._band.GetNoDataValue()
        self._a, self._b, _ = band_to_metres(self._band)  # stored values -> metres (open_dem says what was done)
        self.void_value = void_value
        self.sentinels = sentinels
        overviews = [self._band.GetOverview(i) for i in range(self._band.GetOverviewCount())]
        overviews.sort(key=lambda b: -b.XSize)
        self._overviews = {max(1, round(self.shape[1] / b.XSize)): b for b in overviews}
        self.levels = [1] + sorted(f for f in self._overviews if f > 1)
        self.zmin, self.zmax = self._height_range()

    def close(self) -> None:
        """Release the GDAL file now, overview bands first (an application that quits frees GDAL before Python's
        last objects: a dataset still open then crashed QGIS on exit)."""
        self._overviews, self._band, self._ds = {}, None, None

    def __getstate__(self):  # GDAL handles do not pickle: a copy (a Dask worker's) reopens the file
        return {"path": self.path, "void_value": self.void_value, "sentinels": self.sentinels}

    def __setstate__(self, state):
        self.__init__(state["path"], void_value=state["void_value"], sentinels=state["sentinels"])

    @property
    def cells(self) -> int:
        return self.shape[0] * self.shape[1]

    @property
    def cell_size(self) -> float:
        g = self.geotransform
        return math.sqrt(abs(g[1] * g[5] - g[2] * g[4]))

    def _in_metres(self, block: np.ndarray) -> Optional[float]:
        """The stored values of ``block`` as metres, in place; the nodata value still to look for
        (:func:`~.dem.stored_to_metres`)."""
        return stored_to_metres(block, self._a, self._b, self.nodata)

    def _height_range(self) -> Tuple[float, float]:
        lo, hi = self._band.GetMinimum(), self._band.GetMaximum()
        if lo is not None and hi is not None:
            return float(self._a * lo + self._b), float(self._a * hi + self._b)
        if len(self.levels) > 1:
            z = self._overviews[self.levels[-1]].ReadAsArray().astype(np.float64)
            mark_voids(z, nodata=self._in_metres(z), void_value=self.void_value, sentinels=self.sentinels)
            lo, hi = float(np.nanmin(z)), float(np.nanmax(z))
        else:  # exact for small files; GDAL samples large ones
            lo, hi = (self._a * z + self._b for z in self._band.ComputeRasterMinMax(self.cells > 4e6))
        pad = 0.1 * (hi - lo) + 1.0
        return float(lo - pad), float(hi + pad)

    def level_shape(self, factor: int) -> Tuple[int, int]:
        if factor == 1:
            return self.shape
        if factor in self._overviews:
            b = self._overviews[factor]
            return (b.YSize, b.XSize)
        return (max(1, self.shape[0] // factor), max(1, self.shape[1] // factor))

    def level_geotransform(self, factor: int) -> Tuple[float, ...]:
        """Geotransform of a level: the same extent over fewer, larger cells."""
        rows, cols = self.level_shape(factor)
        sx, sy = self.shape[1] / cols, self.shape[0] / rows
        g = self.geotransform
        return (g[0], g[1] * sx, g[2] * sy, g[3], g[4] * sx, g[5] * sy)

    def level_cell_size(self, factor: int) -> float:
        g = self.level_geotransform(factor)
        return math.sqrt(abs(g[1] * g[5] - g[2] * g[4]))

    def _read_block(self, factor: int, row0: int, col0: int, rows: int, cols: int,
                    out: Optional[np.ndarray] = None) -> np.ndarray:
        """The cells [row0, row0 + rows) x [col0, col0 + cols) of level ``factor`` as GDAL gives them: from the
        band or its overview of that factor, else decimated (averaged) from the full resolution. ``out``: a
        (rows, cols) array (a view is fine) that GDAL fills, converting to its type, and that is returned."""
        if factor == 1:
            return self._band.ReadAsArray(col0, row0, cols, rows, buf_obj=out)
        if factor in self._overviews:
            return self._overviews[factor].ReadAsArray(col0, row0, cols, rows, buf_obj=out)
        from osgeo import gdal

        rows_l, cols_l = self.level_shape(factor)
        sx, sy = self.shape[1] / cols_l, self.shape[0] / rows_l
        x0, y0 = int(round(col0 * sx)), int(round(row0 * sy))
        w = min(self.shape[1] - x0, int(round(cols * sx)))
        h = min(self.shape[0] - y0, int(round(rows * sy)))
        return self._band.ReadAsArray(x0, y0, w, h, buf_xsize=cols, buf_ysize=rows, resample_alg=gdal.GRIORA_Average,
                                      buf_obj=out)

    def read(self, window: Optional[Sequence[int]] = None, factor: int = 1) -> Dem:
        """The Dem of ``window`` = (row0, col0, rows, cols) in the cells of level ``factor`` (None = all of it);
        read from the overview of that factor, else decimated by GDAL's averaging read."""
        rows_l, cols_l = self.level_shape(factor)
        row0, col0, rows, cols = (0, 0, rows_l, cols_l) if window is None else (int(w) for w in window)
        elevation = self._read_block(factor, row0, col0, rows, cols, out=np.empty((rows, cols), dtype=np.float32))
        notes = mark_voids(elevation, nodata=self._in_metres(elevation), void_value=self.void_value,
                           sentinels=self.sentinels)
        g = self.level_geotransform(factor)
        gt = (g[0] + col0 * g[1] + row0 * g[2], g[1], g[2], g[3] + col0 * g[4] + row0 * g[5], g[4], g[5])
        dem = Dem(elevation, gt, self.crs_wkt)
        dem.window = (row0, col0)
        dem.void_notes = notes
        return dem

    def window(self, camera, factor: int = 1, min_range: float = 0.0, max_range: Optional[float] = None,
               margin_cells: int = 2):
        """(row0, col0, rows, cols) in level ``factor``'s cells that hold what ``camera`` can see between
        ``min_range`` and ``max_range`` metres; None when it sees nothing of the DEM there."""
        return view_window(camera, self.level_geotransform(factor), self.level_shape(factor), self.zmin, self.zmax,
                           max_range, margin_cells, min_range=min_range)

    def read_view(self, camera, factor: int = 1, min_depth: float = 0.0, max_depth: Optional[float] = None,
                  max_range: Optional[float] = None, margin_cells: int = 2, placeholders: bool = True,
                  out: Optional[np.ndarray] = None):
        """(Dem, (lo, hi), image rows) of what ``camera`` sees between the depths ``min_depth`` and ``max_depth``
        (metres along the optical axis; and within ``max_range`` metres) at level ``factor``:
        a window whose rows hold, each, a span of cells ``[lo[r], hi[r])`` (the view's footprint, block by block);
        only those are read, the others are NaN (not voids: ``compute_xyz_full(..., spans=(lo, hi))``); image rows:
        (first, last), the rows of the image whose rays can meet them. None when the camera sees nothing there.
        Without ``placeholders`` the cells outside the spans are left unset (the z-buffer never reads them: it skips
        allocating and writing a window-sized array) unless the view has voids, whose lids need them NaN; ``out``
        (without placeholders): a 1-D float32 array whose memory holds the window when it is large enough (a caller
        reading slab after slab reuses one allocation: the first touch of fresh memory is a page fault the kernel
        must zero, which cost more than the reads themselves)."""
        found = view_footprint(camera, self.level_geotransform(factor), self.level_shape(factor), self.zmin,
                               self.zmax, max_range, margin_cells, samples=256, min_depth=min_depth,
                               max_depth=max_depth)
        if found is None:
            return None
        window, ends, pad, image_rows = found
        row0, col0, rows, cols = window
        lo, hi = footprint_spans(window, ends, pad)
        if placeholders:
            elevation = np.full((rows, cols), np.nan, dtype=np.float32)
        elif out is not None and out.dtype == np.float32 and out.size >= rows * cols:
            elevation = out[:rows * cols].reshape(rows, cols)
        else:
            elevation = np.empty((rows, cols), dtype=np.float32)
        g = self.level_geotransform(factor)
        dem = Dem(elevation, (g[0] + col0 * g[1] + row0 * g[2], g[1], g[2], g[3] + col0 * g[4] + row0 * g[5], g[4],
                              g[5]), self.crs_wkt)
        dem.window = (row0, col0)
        notes = []
        voids = False
        for r in range(0, rows, _SPAN_BLOCK):
            r1 = min(rows, r + _SPAN_BLOCK)
            c0, c1 = int(lo[r:r1].min()), int(hi[r:r1].max())
            if c1 <= c0:
                continue
            block = self._read_block(factor, row0 + r, col0 + c0, r1 - r, c1 - c0, out=elevation[r:r1, c0:c1])
            found = mark_voids(block, nodata=self._in_metres(block), void_value=self.void_value,
                               sentinels=self.sentinels)
            notes += found
            voids = voids or bool(found)
        if voids and not placeholders:
            for r in range(rows):
                elevation[r, :lo[r]] = np.nan
                elevation[r, max(lo[r], hi[r]):] = np.nan
        dem.void_notes = notes
        return dem, (lo, hi), image_rows

    def view_dem(self, camera, max_cells: float = 25e6, max_range: Optional[float] = None) -> Dem:
        """One ordinary :class:`Dem` of what ``camera`` sees, at the finest level whose window has at most
        ``max_cells`` cells: for the steps that take a single DEM at preview resolution (rendering for suggestions,
        the orthophoto's grid). Raises ValueError when the camera sees none of the DEM."""
        levels = self.levels if len(self.levels) > 1 else [1] + overview_factors(self.shape)
        window = None
        for factor in levels:
            window = self.window(camera, factor, max_range=max_range)
            if window is None:
                raise ValueError(f"the camera sees no part of {self.path}")
            if window[2] * window[3] <= max_cells:
                break
        return self.read(window, factor)

    def plan(self, camera, max_range: Optional[float] = None, lod: float = 1.0,
             split: bool = True) -> List[Tuple[int, float, float]]:
        """(factor, near depth, far depth) of each band, near to far (see the module docstring); the last band's
        far depth is ``inf`` (or ``max_range``). With ``split``, bands are cut into thinner slabs of the same level
        (the first, from the camera, at 1/8, 1/4 and 1/2 of its depth; the others in two): a slab draws only the
        terrain in front of what nearer slabs left unanswered, so terrain hidden behind them costs little."""
        f = camera.focal_px
        plan = []
        near = 0.0
        levels = self.levels if len(self.levels) > 1 else [1] + overview_factors(self.shape)
        for i, factor in enumerate(levels):
            nxt = levels[i + 1] if i + 1 < len(levels) else None
            far = math.inf if nxt is None else self.level_cell_size(nxt) * f / lod
            if max_range is not None:
                far = min(far, float(max_range))
            if far > near:
                if not split or math.isinf(far):
                    cuts = [near, far]
                elif near == 0.0:
                    cuts = [0.0, far / 8, far / 4, far / 2, far]
                else:
                    cuts = [near, math.sqrt(near * far), far]
                plan += [(factor, a, b) for a, b in zip(cuts[:-1], cuts[1:])]
            near = far
            if max_range is not None and near >= max_range:
                break
        return plan

    def bands(self, camera, max_range: Optional[float] = None, lod: float = 1.0) -> List[DemBand]:
        """The :class:`DemBand` s of ``camera``'s view, near to far, read now (empty ones left out); for callers that
        want them all at once (:func:`~.xyz_lod.compute_xyz_lod` reads one at a time)."""
        out = []
        for factor, near, far in self.plan(camera, max_range, lod):
            keep = None if math.isinf(far) else far * (1.0 + LOD_OVERLAP)
            view = self.read_view(camera, factor, min_depth=near, max_depth=keep, max_range=max_range)
            if view is not None and (view[1][1] > view[1][0]).any():
                out.append(DemBand(view[0], factor, near, far, view[1]))
        return out


#: Rows (and columns) of the blocks in which :meth:`DemSource.read_view` reads a view's footprint.
_SPAN_BLOCK = 32


def footprint_spans(window, ends, pad: float, block: int = _SPAN_BLOCK):
    """(lo, hi): per row of ``window`` (row0, col0, rows, cols), the columns [lo, hi) (relative to the window) that
    the convex hull of ``ends`` ((N, 2) grid row, col), widened by ``pad`` cells, touches, in whole blocks of
    ``block`` cells; the whole width when ``ends`` is None.

    >>> lo, hi = footprint_spans((0, 0, 1024, 1024), np.array([[0.0, 0.0], [0.0, 10.0], [1000.0, 1000.0]]), 2.0)
    >>> (int(lo[0]), int(hi[0])), (int(lo[1023]), int(hi[1023]))    # the hull and a block of margin every way
    ((0, 128), (928, 1024))
    """
    import cv2

    row0, col0, rows, cols = (int(w) for w in window)
    if ends is None:
        return np.zeros(rows, dtype=np.int64), np.full(rows, cols, dtype=np.int64)
    nr, nc = -(-rows // block), -(-cols // block)
    pts = ((ends - np.array([row0, col0])) / block)[:, ::-1].astype(np.float32)  # (x = col, y = row) in blocks
    hull = cv2.convexHull(pts).reshape(-1, 2).astype(np.float64)
    xmin, xmax = _strip_extents(hull, nr)  # the blocks of row i that the hull touches: its part between y = i, i + 1
    found = (xmin <= xmax) & (xmax >= -1.0) & (xmin <= nc + 1.0)  # (the original clip box: -1 ... nc + 1)
    first = np.where(found, np.maximum(0, np.floor(np.maximum(xmin, -1.0))), nc).astype(np.int64)
    last = np.where(found, np.minimum(nc - 1, np.floor(np.minimum(xmax, nc + 1.0))), -1).astype(np.int64)
    grow = int(math.ceil(pad / block))
    # widened by ``grow`` blocks every way: the blocks of rows i - grow ... i + grow
    window_min = np.lib.stride_tricks.sliding_window_view(
        np.pad(first, grow, constant_values=np.iinfo(np.int64).max), 2 * grow + 1).min(axis=1)
    window_max = np.lib.stride_tricks.sliding_window_view(np.pad(last, grow, constant_values=-1),
                                                          2 * grow + 1).max(axis=1)
    some = window_max >= 0
    lo_b = np.where(some, np.maximum(0, window_min - grow), nc)
    hi_b = np.where(some, np.minimum(nc - 1, window_max + grow), -1)
    empty = hi_b < lo_b
    lo = np.repeat(np.where(empty, 0, lo_b * block), block)[:rows]
    hi = np.minimum(np.repeat(np.where(empty, 0, (hi_b + 1) * block), block)[:rows], cols)
    return lo.astype(np.int64), hi.astype(np.int64)


def _strip_extents(poly: np.ndarray, n: int):
    """(xmin, xmax), (n,) each: the extent in x of the part of a convex polygon ((N, 2) x, y) between y = i and
    y = i + 1, for i = 0 ... n - 1 (xmin > xmax where it has none): where its edges cross the lines y = 0 ... n,
    and its vertices between them.

    >>> xmin, xmax = _strip_extents(np.array([[0.0, 0.5], [4.0, 0.5], [2.0, 2.5]]), 4)
    >>> xmin.tolist(), xmax.tolist()
    ([0.0, 0.5, 1.5, inf], [4.0, 3.5, 2.5, -inf])
    """
    lines = np.arange(n + 1, dtype=np.float64)
    a, b = poly, np.roll(poly, -1, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (lines[None, :] - a[:, 1:2]) / (b[:, 1:2] - a[:, 1:2])  # NaN along horizontal edges: their ends count
        x = a[:, 0:1] + t * (b[:, 0:1] - a[:, 0:1])
    cross = (t >= 0.0) & (t <= 1.0)
    on_min = np.where(cross, x, np.inf).min(axis=0)
    on_max = np.where(cross, x, -np.inf).max(axis=0)
    xmin = np.minimum(on_min[:-1], on_min[1:])
    xmax = np.maximum(on_max[:-1], on_max[1:])
    y = poly[:, 1]
    inside = (y >= 0.0) & (y <= n)
    for strip in (np.floor(y), np.ceil(y) - 1.0):  # a vertex on a line y = i lies in strips i - 1 and i
        k = strip[inside & (strip >= 0) & (strip < n)].astype(np.int64)
        px = poly[inside & (strip >= 0) & (strip < n), 0]
        np.minimum.at(xmin, k, px)
        np.maximum.at(xmax, k, px)
    return xmin, xmax
