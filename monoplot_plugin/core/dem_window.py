"""DEMs larger than memory: a DEM file read by windows, at the level of detail a camera needs.

A :class:`DemSource` keeps the file open and reads nothing up front. For a camera it plans distance bands
(:meth:`DemSource.bands`): band ``k`` covers the depths (distance along the optical axis) ``[near_k, far_k)`` and is
read at the coarsest level whose cells are at most ``lod`` times the footprint of a pixel at ``near_k``
(``near_k / f`` metres, f = focal length in pixels), through a window that holds the camera's view frustum between
those depths (:func:`~.dem.view_window`). The first band is always at full resolution. Levels are the file's GDAL
overviews (:func:`build_overviews` makes them, as a ``.ovr`` beside the file, when they are missing); without
overviews a coarse level is read by decimating (GDAL's averaging read), which touches every full-resolution block
of the window. :func:`~.xyz_lod.compute_xyz_lod` z-buffers the bands near to far.

Each band is an ordinary :class:`~.dem.Dem` (a window of one level), voids marked as :meth:`Dem.open` marks them.

>>> import os, tempfile
>>> import numpy as np
>>> from .dem import Dem
>>> path = os.path.join(tempfile.mkdtemp(), "dem.tif")
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
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import dataclass
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np

from .dem import Dem, _wkt_or_empty, mark_voids, view_window

__all__ = ["DemSource", "DemBand", "build_overviews", "overview_factors", "LOD_OVERLAP"]

logger = logging.getLogger("monoplot")

#: A band's hits are kept up to this fraction beyond its far depth (the next band starts at that far depth), so a
#: ray that grazes the seam between two levels keeps the finer one's answer.
LOD_OVERLAP = 0.05

Progress = Callable[[float, str], None]


@dataclass
class DemBand:
    """One distance band of a camera's view: ``dem`` (one level, one window) for depths ``[near, far)`` metres."""

    dem: Dem
    level: int
    near: float
    far: float


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


def build_overviews(path: str, progress: Optional[Progress] = None, min_size: int = 256,
                    resampling: str = "AVERAGE") -> List[int]:
    """Build the missing GDAL overviews of a DEM file (2, 4, ... down to ``min_size`` cells), as an external
    ``.ovr`` beside it (the DEM itself is not modified); ``progress(fraction, message)`` as they are computed.
    Returns the factors built ([] when the file has them already or is too small); says so on the log."""
    from osgeo import gdal

    gdal.UseExceptions()
    ds = gdal.Open(str(path), gdal.GA_ReadOnly)
    band = ds.GetRasterBand(1)
    have = {round(ds.RasterXSize / band.GetOverview(i).XSize) for i in range(band.GetOverviewCount())}
    factors = [f for f in overview_factors((ds.RasterYSize, ds.RasterXSize), min_size) if f not in have]
    if not factors:
        return []
    message = f"building overviews {factors} of the DEM {os.path.basename(str(path))} (once; saved beside it)"
    logger.info("%s", message)

    def callback(fraction, _msg, _data):
        if progress is not None:
            progress(float(fraction), message)
        return 1

    ds.BuildOverviews(resampling, factors, callback=callback)
    ds = None
    return factors


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
        self.void_value = void_value
        self.sentinels = sentinels
        overviews = [self._band.GetOverview(i) for i in range(self._band.GetOverviewCount())]
        overviews.sort(key=lambda b: -b.XSize)
        self._overviews = {max(1, round(self.shape[1] / b.XSize)): b for b in overviews}
        self.levels = [1] + sorted(f for f in self._overviews if f > 1)
        self.zmin, self.zmax = self._height_range()

    @property
    def cells(self) -> int:
        return self.shape[0] * self.shape[1]

    @property
    def cell_size(self) -> float:
        g = self.geotransform
        return math.sqrt(abs(g[1] * g[5] - g[2] * g[4]))

    def _height_range(self) -> Tuple[float, float]:
        lo, hi = self._band.GetMinimum(), self._band.GetMaximum()
        if lo is not None and hi is not None:
            return float(lo), float(hi)
        if len(self.levels) > 1:
            z = self._overviews[self.levels[-1]].ReadAsArray().astype(np.float64)
            mark_voids(z, nodata=self.nodata, void_value=self.void_value, sentinels=self.sentinels)
            lo, hi = float(np.nanmin(z)), float(np.nanmax(z))
        else:  # exact for small files; GDAL samples large ones
            lo, hi = self._band.ComputeRasterMinMax(self.cells > 4e6)
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

    def read(self, window: Optional[Sequence[int]] = None, factor: int = 1) -> Dem:
        """The Dem of ``window`` = (row0, col0, rows, cols) in the cells of level ``factor`` (None = all of it);
        read from the overview of that factor, else decimated by GDAL's averaging read."""
        from osgeo import gdal

        rows_l, cols_l = self.level_shape(factor)
        row0, col0, rows, cols = (0, 0, rows_l, cols_l) if window is None else (int(w) for w in window)
        if factor == 1:
            data = self._band.ReadAsArray(col0, row0, cols, rows)
        elif factor in self._overviews:
            data = self._overviews[factor].ReadAsArray(col0, row0, cols, rows)
        else:
            sx, sy = self.shape[1] / cols_l, self.shape[0] / rows_l
            x0, y0 = int(round(col0 * sx)), int(round(row0 * sy))
            w = min(self.shape[1] - x0, int(round(cols * sx)))
            h = min(self.shape[0] - y0, int(round(rows * sy)))
            data = self._band.ReadAsArray(x0, y0, w, h, buf_xsize=cols, buf_ysize=rows,
                                          resample_alg=gdal.GRIORA_Average)
        elevation = np.array(data, dtype=np.float32)
        notes = mark_voids(elevation, nodata=self.nodata, void_value=self.void_value, sentinels=self.sentinels)
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

    def plan(self, camera, max_range: Optional[float] = None, lod: float = 1.0) -> List[Tuple[int, float, float]]:
        """(factor, near depth, far depth) of each band, near to far (see the module docstring); the last band's
        far depth is ``inf`` (or ``max_range``)."""
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
                plan.append((factor, near, far))
            near = far
            if max_range is not None and near >= max_range:
                break
        return plan

    def bands(self, camera, max_range: Optional[float] = None, lod: float = 1.0) -> List[DemBand]:
        """The :class:`DemBand` s of ``camera``'s view, near to far, read now (empty bands left out)."""
        out = []
        cos_edge = _cos_edge(camera)
        for factor, near, far in self.plan(camera, max_range, lod):
            reach = far * (1.0 + LOD_OVERLAP) / cos_edge
            if max_range is not None:
                reach = min(reach, float(max_range))
            window = self.window(camera, factor, min_range=near, max_range=None if math.isinf(reach) else reach)
            if window is None:
                continue
            out.append(DemBand(self.read(window, factor), factor, near, far))
        return out


def _cos_edge(camera) -> float:
    """Smallest cosine between the optical axis and the rays through the image corners (depth / distance)."""
    corners = np.array([[0, 0], [camera.width, 0], [0, camera.height], [camera.width, camera.height]], dtype=float)
    rays = camera.pixel_to_camera_ray(corners)
    return float(max(0.05, rays[:, 2].min()))
