"""A DEM file too large to read whole, as a :class:`~.dem.Dem` the rest of Monoplot can take unchanged.

:func:`open_dem` is the one place that decides: a DEM whose cells do not fit in what memory is free
(:func:`in_memory_limit`, ``MONOPLOT_DEM_MAX_CELLS`` overrides it) is opened as a :class:`LargeDem` instead of being
read whole. A LargeDem *is* a Dem: its ``elevation`` is one overview level of the file, the finest of at most
:data:`PREVIEW_CELLS` cells and a quarter of the limit (the "preview": checks, fits, the dock's previews and the
maps work on it), and it keeps the file's :class:`~.dem_window.DemSource` (``source``) for what needs the full
resolution:

- the per-pixel XYZ (the workflow's XYZ step uses :func:`~.xyz_lod.compute_xyz_lod`: full resolution near the
  camera, coarser levels where a cell is smaller than a pixel's footprint);
- rendering, suggestions and the orthophoto's grid (:func:`~.dem_window.as_dem`: what the camera sees, at the
  finest level within a cell budget);
- heights at points (:meth:`LargeDem.sample` reads the full-resolution cells around them).

Overviews are built when the file has none (once, as a ``.ovr`` beside it, with progress), and the notes say so.
A cut of a LargeDem (:meth:`LargeDem.crop`) is an ordinary Dem of the preview.

>>> import os, tempfile
>>> import numpy as np
>>> from .synthetic import synthetic_terrain
>>> folder = tempfile.TemporaryDirectory()
>>> path = os.path.join(folder.name, "dem.tif")
>>> synthetic_terrain((512, 512), cell=10.0, seed=2).save(path)
>>> dem, notes = open_dem(path, max_cells=100_000)           # more than 100,000 cells: opened by windows
>>> type(dem).__name__, dem.source.shape, dem.shape, dem.level
('LargeDem', (512, 512), (256, 256), 2)
>>> full = Dem.open(path)
>>> x, y = full.cell_to_map(100.3, 200.7)
>>> bool(abs(dem.sample(x, y) - full.sample(x, y)) < 1e-3)  # heights at points come from the full resolution
True
>>> type(open_dem(path)[0]).__name__                         # the same file fits in memory: read whole
'Dem'
>>> del dem; folder.cleanup()
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field
from typing import Callable, List, Optional, Tuple

import numpy as np

from .dem import Dem
from .dem_window import DemSource, as_dem, missing_overviews, open_dem_source

__all__ = ["LargeDem", "open_dem", "IMAGE_NOTE", "read_by_windows", "overviews_to_build", "in_memory_limit", "is_large",
           "PREVIEW_CELLS", "DEM_BYTES_PER_CELL", "PRODUCT_LOD"]

logger = logging.getLogger("monoplot")

#: The preview of a LargeDem (its ``elevation``) has at most this many cells.
PREVIEW_CELLS = 25e6
#: Bytes per DEM cell that the in-memory products need (the heights, the view's crop, the mesh, the hillshade of
#: the report); a DEM of more cells than the free memory holds at this rate is opened by windows.
DEM_BYTES_PER_CELL = 32
#: Level of detail of the products over a LargeDem (the XYZ raster): a band's cells are at most this many pixel
#: footprints (:func:`~.xyz_lod.compute_xyz_lod`; 1: 99.98 % of the pixels within 0.5 px of the full resolution on
#: the benchmark's 105 M-cell DEM, 2: 99.1 % and about twice as fast).
PRODUCT_LOD = 1.0
#: Points farther apart than this many full-resolution cells are sampled from separate reads.
_SAMPLE_BLOCK = 512

Progress = Callable[[float, str], None]


@dataclass(eq=False)
class LargeDem(Dem):
    """A Dem of one overview level of a DEM file (the preview, see the module docstring), with the file's
    :class:`~.dem_window.DemSource` as ``source`` and the level's factor as ``level``."""

    source: Optional[DemSource] = field(default=None, repr=False, compare=False)
    level: int = 1

    @property
    def key(self) -> Tuple:
        """What the file is, for caches: path, size, modification time, voids asked for."""
        st = os.stat(self.source.path)
        return (os.path.abspath(self.source.path), st.st_size, st.st_mtime_ns, self.source.void_value)

    def crop(self, row0: int, col0: int, rows: int, cols: int) -> Dem:
        """A cut of the preview: an ordinary Dem (the file's other cells are not in it)."""
        part = Dem.crop(self, row0, col0, rows, cols)
        return Dem(part.elevation, part.geotransform, part.crs_wkt, part.source_crs_wkt, part.window, part.void_notes)

    def preview(self) -> Dem:
        """The preview as an ordinary Dem."""
        return self.crop(0, 0, self.rows, self.cols)

    def sample(self, x, y, method: str = "bilinear"):
        """Heights at map points from the file's full resolution (the cells around the points are read, block by
        block); a great many points spread over the whole file are sampled from the preview instead."""
        src = self.source
        full = Dem(np.zeros((1, 1), dtype=np.float32), src.geotransform, self.crs_wkt)
        col, row = full.map_to_cell(x, y)
        scalar = np.ndim(col) == 0
        fc = np.atleast_1d(np.asarray(col, dtype=np.float64)).ravel()
        fr = np.atleast_1d(np.asarray(row, dtype=np.float64)).ravel()
        xs = np.broadcast_to(np.asarray(x, dtype=np.float64), np.shape(col)).ravel()
        ys = np.broadcast_to(np.asarray(y, dtype=np.float64), np.shape(col)).ravel()
        out = np.full(fc.shape, np.nan)
        ok = np.isfinite(fc) & np.isfinite(fr)
        block = np.where(ok, np.floor(np.nan_to_num(fr) / _SAMPLE_BLOCK) * 1e6
                         + np.floor(np.nan_to_num(fc) / _SAMPLE_BLOCK), np.nan)
        keys = np.unique(block[ok])
        if len(keys) > 2000:
            logger.debug("LargeDem.sample: %d points over %d blocks, sampled from the preview", ok.sum(), len(keys))
            out = np.asarray(Dem.sample(self, xs, ys, method), dtype=np.float64)
        else:
            rows, cols = src.shape
            for k in keys:
                sel = block == k
                r0 = max(0, int(np.floor(fr[sel].min() - 1.5)))
                c0 = max(0, int(np.floor(fc[sel].min() - 1.5)))
                r1 = min(rows, int(np.ceil(fr[sel].max() + 1.5)))
                c1 = min(cols, int(np.ceil(fc[sel].max() + 1.5)))
                if r1 - r0 < 2 or c1 - c0 < 2:
                    continue
                out[sel] = src.read((r0, c0, r1 - r0, c1 - c0)).sample(xs[sel], ys[sel], method)
        if scalar:
            return float(out.ravel()[0])
        return out.reshape(np.shape(col))

    def refine_hits(self, origin, dirs: np.ndarray, xyz: np.ndarray, ok: np.ndarray,
                    margin_cells: float = 4.0) -> Tuple[np.ndarray, np.ndarray]:
        """Ray hits traced on the preview, moved onto the file's full-resolution mesh.

        Each hit's ray is searched again over ``margin_cells`` preview cells either side of it, on the full
        resolution cells around it (read block by block, as :meth:`sample`). A hit keeps its preview position when
        the ray's start there is already under the full-resolution terrain (the true hit lies farther back, on a
        feature the preview averaged away) or when the full resolution has no hit within the margin.

        Args:
            origin: (3,) the camera centre (map coordinates); dirs: (N, 3) unit ray directions.
            xyz: (N, 3) hits on the preview (NaN rows: none); ok: (N,) bool, a hit.
        Returns:
            ((N, 3) hits, (N,) bool): the refined copy.
        """
        from .xyz import segment_first_hit

        xyz, ok = np.array(xyz, dtype=np.float64), np.asarray(ok, dtype=bool)
        idx = np.flatnonzero(ok)
        if not len(idx) or self.level <= 1:
            return xyz, ok
        src = self.source
        step = margin_cells * self.cell_size
        dirs = np.broadcast_to(np.asarray(dirs, dtype=np.float64), (len(ok), 3))
        start = xyz[idx] - step * dirs[idx]
        end = xyz[idx] + step * dirs[idx]
        full = Dem(np.zeros((1, 1), dtype=np.float32), src.geotransform, self.crs_wkt)
        (c_start, r_start), (c_end, r_end) = (full.map_to_cell(p[:, 0], p[:, 1]) for p in (start, end))
        cols, rows = np.stack([c_start, c_end], axis=1), np.stack([r_start, r_end], axis=1)
        block = np.floor(rows.min(axis=1) / _SAMPLE_BLOCK) * 1e6 + np.floor(cols.min(axis=1) / _SAMPLE_BLOCK)
        keys = np.unique(block)
        if len(keys) > 2000:  # a great many points spread over the file: the preview's hits stay
            return xyz, ok
        n_rows, n_cols = src.shape
        for k in keys:
            sel = np.flatnonzero(block == k)
            r0, c0 = max(0, int(rows[sel].min()) - 2), max(0, int(cols[sel].min()) - 2)
            r1, c1 = min(n_rows, int(np.ceil(rows[sel].max())) + 3), min(n_cols, int(np.ceil(cols[sel].max())) + 3)
            if r1 - r0 < 2 or c1 - c0 < 2:
                continue
            window = src.read((r0, c0, r1 - r0, c1 - c0))
            above = start[sel, 2] > np.nan_to_num(window.sample(start[sel, 0], start[sel, 1]), nan=np.inf)
            sel = sel[above]
            if not len(sel):
                continue
            t = segment_first_hit(window, start[sel], end[sel], voids_stop=True)
            hit = np.isfinite(t)
            xyz[idx[sel[hit]]] = start[sel[hit]] + t[hit, None] * (end[sel[hit]] - start[sel[hit]])
        return xyz, ok


def in_memory_limit() -> int:
    """The most cells a DEM may have to be read whole: ``MONOPLOT_DEM_MAX_CELLS`` when set, else what the free
    memory (:func:`~.xyz_strips.available_memory`) holds at :data:`DEM_BYTES_PER_CELL` bytes a cell."""
    from .xyz_strips import available_memory

    limit = os.environ.get("MONOPLOT_DEM_MAX_CELLS")
    if limit:
        return int(float(limit))
    return int(available_memory() // DEM_BYTES_PER_CELL)


def is_large(dem) -> bool:
    return isinstance(dem, LargeDem)


def _geographic(path: str) -> bool:
    from osgeo import gdal, osr

    gdal.UseExceptions()
    wkt = gdal.Open(str(path)).GetProjection() or ""
    srs = osr.SpatialReference()
    return bool(wkt) and srs.ImportFromWkt(wkt) == 0 and bool(srs.IsGeographic())


def _cells(path: str) -> int:
    from osgeo import gdal

    gdal.UseExceptions()
    ds = gdal.Open(str(path))
    return ds.RasterXSize * ds.RasterYSize


def read_by_windows(path: str, max_cells: Optional[int] = None) -> bool:
    """True when :func:`open_dem` opens the DEM file as a :class:`LargeDem` (more cells than ``max_cells``,
    default :func:`in_memory_limit`, and not in degrees)."""
    limit = in_memory_limit() if max_cells is None else int(max_cells)
    return _windowed(path, _cells(path), limit)


def _windowed(path: str, cells: int, limit: int) -> bool:
    return cells > limit and not _geographic(path)


def overviews_to_build(path: str, max_cells: Optional[int] = None) -> List[int]:
    """The overview factors :func:`open_dem` would build first ([] = it opens the file at once): for the dock,
    which then opens it in a task with progress and Cancel rather than freezing QGIS for minutes."""
    return missing_overviews(path) if read_by_windows(path, max_cells) else []


def open_dem(path: str, void_value: Optional[float] = None, progress: Optional[Progress] = None,
             max_cells: Optional[int] = None,
             is_canceled: Optional[Callable[[], bool]] = None) -> Tuple[Dem, List[str]]:
    """(Dem, notes for the user) of a DEM file: read whole when it has at most ``max_cells`` cells (default
    :func:`in_memory_limit`) or is in geographic degrees (reprojected whole, see :meth:`Dem.open`), else a
    :class:`LargeDem` (its overviews built first when missing, with ``progress(fraction, message)``; the notes say
    so; :class:`~.dem_window.OverviewsCanceled` when ``is_canceled()`` turns true while they are built). A DEM
    read whole reports its reading to ``progress`` too, and stops with :class:`~.dem.DemReadCanceled`."""
    cells = _cells(path)
    limit = in_memory_limit() if max_cells is None else int(max_cells)
    image = _image_note(path) + _units_note(path)
    if not _windowed(path, cells, limit):
        return Dem.open(path, void_value=void_value, progress=progress, is_canceled=is_canceled), image
    source, notes = open_dem_source(str(path), progress, void_value=void_value, is_canceled=is_canceled)
    preview = as_dem(source, max_cells=min(PREVIEW_CELLS, limit // 4))
    factor = int(round(source.shape[1] / max(1, preview.cols)))
    dem = LargeDem(preview.elevation, preview.geotransform, preview.crs_wkt, window=(0, 0),
                   void_notes=list(preview.void_notes), source=source, level=factor)
    name = os.path.basename(str(path))
    notes.insert(0, f"the DEM {name} has {_millions(cells)} M cells, more than are read whole here "
                    f"({_millions(limit)} M): it is read by windows (the XYZ raster at full resolution near the "
                    f"camera, coarser far away where a cell is smaller than a pixel; previews and checks on a 1/"
                    f"{factor} copy of {source.level_cell_size(factor):.3g} m cells)")
    logger.info("%s", notes[0])
    return dem, image + notes


def _units_note(path: str) -> List[str]:
    """What was done to the stored values to have metres (:func:`~.dem.band_to_metres`), said once."""
    from osgeo import gdal

    from .dem import band_to_metres

    ds = gdal.Open(str(path))  # kept while its band is used (a band outliving its dataset crashes GDAL)
    note = band_to_metres(ds.GetRasterBand(1))[2]
    return [f"{os.path.basename(str(path))}: {note}"] if note else []


#: The note of :func:`open_dem` on a raster that looks like an image (the dock shows it as a warning).
IMAGE_NOTE = "looks like an image, not elevations"


def _image_note(path: str) -> List[str]:
    """A note when the file has three or more bands of bytes: an RGB picture (an orthophoto, a scanned map) chosen
    as the DEM (a trial: Suggest then ran on grey values 0-255 as heights, the camera "2 m above ground", and
    nothing said so). Its first band is used all the same: a one-band byte DEM may be a coarse real one."""
    from osgeo import gdal

    ds = gdal.Open(str(path))
    if ds.RasterCount < 3 or ds.GetRasterBand(1).DataType != gdal.GDT_Byte:
        return []
    return [f"{os.path.basename(str(path))} has {ds.RasterCount} bands of bytes (0-255): it {IMAGE_NOTE}; its "
            f"first band is used as heights in metres. Choose an elevation raster"]


def _millions(cells: int) -> str:
    """Millions of cells for a message, to two significant digits below 10 M.

    >>> _millions(1_680_000_000), _millions(360_000), _millions(200_000)
    ('1,680', '0.36', '0.2')
    """
    m = cells / 1e6
    return f"{m:,.0f}" if m >= 10 else f"{m:.2g}"
