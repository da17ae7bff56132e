"""Digital elevation model: a grid of heights with a full GDAL affine geotransform.

Conventions
-----------
``elevation[row, col]`` is the height (metres) at the *centre* of cell (row, col); voids are NaN.

The geotransform is GDAL's 6-tuple ``(x0, a, b, y0, d, e)``; a map point and fractional cell coordinates
``(col, row)`` (corner of the top-left cell at (0, 0), cell centres at +0.5, as for photo pixels) are related by::

    x = x0 + col * a + row * b
    y = y0 + col * d + row * e

``b`` and ``d`` are the rotation terms; they are honoured everywhere (north-up or not).

Surface: Monoplot's terrain is the triangle mesh whose vertices are the cell centres, two triangles per square of
four neighbouring centres, split along the diagonal from (row, col) to (row + 1, col + 1). :meth:`Dem.sample` gives
either that surface (``method="mesh"``) or the bilinear one (``method="bilinear"``, the default); they agree at the
cell centres.

>>> dem = Dem.from_array([[0.0, 1.0], [2.0, 3.0]], (100.0, 10.0, 0.0, 200.0, 0.0, -10.0))
>>> dem.cell_to_map(0.5, 0.5)          # centre of the top-left cell
(105.0, 195.0)
>>> float(dem.sample(110.0, 190.0))    # halfway between the four centres
1.5
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace
from typing import Any, Callable, List, Optional, Sequence, Tuple

import numpy as np

from .dem_voids import (  # noqa: F401 (re-exported: one place to import a DEM's tools from)
    VOID_SENTINELS, band_to_metres, mark_voids, stored_to_metres, zero_voids)
from .dem_window_view import view_footprint, view_window  # noqa: F401 (view_footprint: re-exported)
from .dem_read import DemReadCanceled, open_decoding_on_all_cores, read_cells  # noqa: F401 (DemReadCanceled: re-exported)

__all__ = ["Dem", "DemReadCanceled", "utm_wkt_for_lonlat", "view_window", "view_footprint", "mark_voids", "zero_voids",
           "VOID_SENTINELS"]

logger = logging.getLogger("monoplot")

GeoTransform = Tuple[float, float, float, float, float, float]


@dataclass
class Dem:
    """Heights on a grid (see the module docstring for conventions).

    Attributes:
        elevation: (rows, cols) float32 or float64 array, metres, NaN for voids.
        geotransform: GDAL 6-tuple ``(x0, a, b, y0, d, e)`` (rotation terms b, d allowed).
        crs_wkt: WKT of the (projected, metric) CRS; "" when unknown.
        source_crs_wkt: CRS of the file the DEM came from, when it was reprojected (else "").
        window: (row0, col0) of this grid inside the grid it was cut from (0, 0 when not cut).
    """

    elevation: np.ndarray
    geotransform: GeoTransform
    crs_wkt: str = ""
    source_crs_wkt: str = field(default="", repr=False)
    window: Tuple[int, int] = (0, 0)
    void_notes: List[str] = field(default_factory=list, repr=False, compare=False)

    def __post_init__(self):
        elevation = np.asarray(self.elevation)
        if elevation.dtype not in (np.float32, np.float64):
            elevation = elevation.astype(np.float64)
        if elevation.ndim != 2:
            raise ValueError(f"elevation must be 2-D, got shape {elevation.shape}")
        self.elevation = elevation
        self.geotransform = tuple(float(g) for g in self.geotransform)
        if len(self.geotransform) != 6:
            raise ValueError("geotransform must have 6 terms")
        if abs(self._det()) < 1e-300:
            raise ValueError(f"geotransform {self.geotransform} is singular")

    # --- construction -----------------------------------------------------------------------------------------
    @classmethod
    def from_array(cls, elevation, geotransform: Sequence[float], crs_wkt: str = "",
                   void_value: Optional[float] = None, nodata: Optional[float] = None) -> "Dem":
        """A DEM from an array; cells equal to ``void_value`` or ``nodata`` (and non-finite ones) become NaN.

        >>> Dem.from_array([[0, 5], [6, 7]], (0, 1, 0, 2, 0, -1), void_value=0).elevation.tolist()
        [[nan, 5.0], [6.0, 7.0]]
        """
        elevation = np.array(elevation, dtype=np.float64 if np.asarray(elevation).dtype != np.float32
                             else np.float32)
        for value in (void_value, nodata):
            if value is not None and not (isinstance(value, float) and math.isnan(value)):
                elevation[elevation == value] = np.nan
        elevation[~np.isfinite(elevation)] = np.nan
        return cls(elevation, tuple(geotransform), _wkt_or_empty(crs_wkt))

    @classmethod
    def open(cls, path, void_value: Optional[float] = None, band: int = 1, camera=None,
             max_range: Optional[float] = None, margin_cells: int = 2, sentinels: bool = True,
             progress: Optional[Callable[[float, str], None]] = None,
             is_canceled: Optional[Callable[[], bool]] = None) -> "Dem":
        """Read a DEM with GDAL.

        Args:
            path: any raster GDAL reads.
            void_value: a height that marks voids although the file declares no nodata (e.g. ``0`` for the
                Aletsch DEM, which has 6,891 zero cells and no nodata). The band's nodata also becomes NaN.
            band: band number (1-based).
            camera: optional :class:`~monoplot_plugin.core.camera.Camera` in the DEM's CRS; with it only the
                window the camera can see (frustum, ``max_range`` metres) is read, for large DEMs.
            max_range: with ``camera``, the farthest distance (metres) of interest; None = unlimited.
            margin_cells: extra cells around that window.
            sentinels: also treat the common no-data sentinels as voids (see :func:`mark_voids`); what was treated
                as void is listed in ``void_notes`` (and logged).
            progress: ``progress(fraction, message)`` while the cells are read (a band of rows at a time), then once
                the voids are marked.
            is_canceled: polled as the cells are read; :class:`DemReadCanceled` once it says True.
        Returns:
            a :class:`Dem` in a metric CRS. A DEM in geographic coordinates is reprojected (bilinear) to the UTM
            zone of its centre, with an INFO log line on the "monoplot" logger; ``crs_wkt`` then says which CRS
            results are in and ``source_crs_wkt`` keeps the file's CRS.
        """
        from osgeo import gdal, osr

        gdal.UseExceptions()
        ds = open_decoding_on_all_cores(gdal, str(path))
        if ds is None:
            raise OSError(f"GDAL cannot open {path}")
        rb = ds.GetRasterBand(band)
        gt = ds.GetGeoTransform()
        wkt = ds.GetProjection() or ""
        srs = osr.SpatialReference()
        geographic = bool(wkt) and srs.ImportFromWkt(wkt) == 0 and bool(srs.IsGeographic())
        row0 = col0 = 0
        rows, cols = ds.RasterYSize, ds.RasterXSize
        a, b, _ = band_to_metres(rb)
        if camera is not None and not geographic:
            zmin, zmax = (a * z + b for z in rb.ComputeRasterMinMax(True))
            window = view_window(camera, gt, (rows, cols), zmin, zmax, max_range, margin_cells)
            if window is None:
                raise ValueError(f"the camera sees no part of {path}")
            row0, col0, rows, cols = window
        reading = None if progress is None else (lambda fraction, message="": progress(0.8 * fraction, message))
        data = read_cells(rb, col0, row0, cols, rows, reading, is_canceled)  # then voids, maybe a reprojection
        nodata = rb.GetNoDataValue()
        if row0 or col0:
            gt = (gt[0] + col0 * gt[1] + row0 * gt[2], gt[1], gt[2], gt[3] + col0 * gt[4] + row0 * gt[5], gt[4], gt[5])
        elevation = np.asarray(data, dtype=np.float64 if data.dtype != np.float32 else np.float32)  # no 2nd copy
        nodata = stored_to_metres(elevation, a, b, nodata)
        notes = mark_voids(elevation, nodata=nodata, void_value=void_value, sentinels=sentinels)
        if progress is not None:
            progress(0.9, "")
        dem = cls(elevation, tuple(gt), _wkt_or_empty(wkt))
        dem.window = (row0, col0)
        dem.void_notes = notes
        if notes:
            logger.info("DEM %s: %s", path, "; ".join(notes))
        if geographic:
            dem = dem.reprojected_to_utm()
            dem.void_notes = notes
            if camera is not None:
                dem = dem.crop_to_view(camera, max_range, margin_cells)
        return dem

    # --- properties -------------------------------------------------------------------------------------------
    def derived(self, name: str, compute: Callable[[np.ndarray], Any]) -> Any:
        """``compute(elevation)``, worked out once per Dem and kept under ``name``: what every exact line of sight
        scans the whole grid for (the height range, the voids closed), which took 0.5 s per feature traced on a
        100 M-cell DEM. The heights must not be edited in place afterwards; a new Dem (``crop``, ``replace``)
        starts afresh, and a copy sent elsewhere (pickled) leaves the kept values behind.

        >>> dem = Dem.from_array([[1.0, float("nan")], [5.0, 2.0]], (0, 1, 0, 2, 0, -1))
        >>> dem.derived("range", lambda z: (float(np.nanmin(z)), float(np.nanmax(z))))
        (1.0, 5.0)
        >>> dem.derived("range", lambda z: None)  # kept: not computed again
        (1.0, 5.0)
        """
        kept = self.__dict__.setdefault("_derived", {})
        key = (name, id(self.elevation))  # heights replaced by another array (attribute set) are new heights
        if key not in kept:
            kept[key] = compute(self.elevation)
        return kept[key]

    def height_range(self) -> Tuple[float, float]:
        """(lowest, highest) finite height in metres; (nan, nan) when there is none (kept: :meth:`derived`)."""
        return self.derived("height_range", _finite_min_max)

    def __getstate__(self):
        state = dict(self.__dict__)
        state.pop("_derived", None)  # a cache: a Dask worker's copy works it out again rather than receive it
        return state

    @property
    def shape(self) -> Tuple[int, int]:
        return self.elevation.shape

    @property
    def rows(self) -> int:
        return self.elevation.shape[0]

    @property
    def cols(self) -> int:
        return self.elevation.shape[1]

    def _det(self) -> float:
        g = self.geotransform
        return g[1] * g[5] - g[2] * g[4]

    @property
    def cell_size(self) -> float:
        """Mean cell edge length in map units (square root of the cell area)."""
        return math.sqrt(abs(self._det()))

    @property
    def is_geographic(self) -> bool:
        if not self.crs_wkt:
            return False
        from osgeo import osr

        srs = osr.SpatialReference()
        srs.ImportFromWkt(self.crs_wkt)
        return bool(srs.IsGeographic())

    def bounds(self) -> Tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the grid's outer corners."""
        cc = np.array([0, self.cols, 0, self.cols], dtype=float)
        rr = np.array([0, 0, self.rows, self.rows], dtype=float)
        x, y = self.cell_to_map(cc, rr)
        return float(x.min()), float(y.min()), float(x.max()), float(y.max())

    # --- coordinates ------------------------------------------------------------------------------------------
    def cell_to_map(self, col, row):
        """Fractional cell coordinates (col, row) -> map (x, y); scalars or arrays (centres at +0.5)."""
        g = self.geotransform
        col = np.asarray(col, dtype=np.float64)
        row = np.asarray(row, dtype=np.float64)
        x = g[0] + col * g[1] + row * g[2]
        y = g[3] + col * g[4] + row * g[5]
        if x.ndim == 0:
            return float(x), float(y)
        return x, y

    def map_to_cell(self, x, y):
        """Map (x, y) -> fractional cell coordinates (col, row), inverse of :meth:`cell_to_map`.

        >>> dem = Dem.from_array(np.zeros((3, 4)), (1000, 8.66, -5.0, 2000, 5.0, 8.66))   # rotated 30 degrees
        >>> [round(v, 9) for v in dem.map_to_cell(*dem.cell_to_map(2.5, 1.25))]
        [2.5, 1.25]
        """
        g = self.geotransform
        dx = np.asarray(x, dtype=np.float64) - g[0]
        dy = np.asarray(y, dtype=np.float64) - g[3]
        det = self._det()
        col = (g[5] * dx - g[2] * dy) / det
        row = (-g[4] * dx + g[1] * dy) / det
        if col.ndim == 0:
            return float(col), float(row)
        return col, row

    def near_edge(self, xyz, cells=2.5) -> np.ndarray:
        """(N,) bool: the map points ``xyz`` (N, 2 or 3) lie within ``cells`` cells (one for all, or (N,) one
        each; voids are looked for within at most :data:`VOID_REACH_MAX`) of the DEM's border or of a void. There
        the terrain stops, and a rendering of it ends in an edge no photo shows (the world goes on).

        >>> dem = Dem.from_array(np.zeros((100, 100)), (0, 10, 0, 1000, 0, -10))
        >>> dem.elevation[50, 80] = np.nan
        >>> dem.near_edge([[15.0, 500.0], [500.0, 500.0], [500.0, 985.0], [805.0, 495.0]]).tolist()
        [True, False, True, True]
        >>> dem.near_edge([[15.0, 500.0], [65.0, 500.0]], np.array([1.0, 7.0])).tolist()
        [False, True]
        """
        xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, np.shape(xyz)[-1])
        if not len(xyz):
            return np.zeros(0, dtype=bool)
        col, row = (np.atleast_1d(v) for v in self.map_to_cell(xyz[:, 0], xyz[:, 1]))
        cells = np.broadcast_to(np.asarray(cells, dtype=np.float64), col.shape)
        out = (col < cells) | (row < cells) | (col > self.cols - cells) | (row > self.rows - cells)
        reach = min(VOID_REACH_MAX, int(math.ceil(float(cells.max()))))
        to_void = self.derived("void_distance", _void_distance) if reach > 0 else None
        if to_void is not None:
            out |= to_void[np.clip(row.astype(np.int64), 0, self.rows - 1),
                           np.clip(col.astype(np.int64), 0, self.cols - 1)] <= reach
        return out

    def cell_centres(self) -> Tuple[np.ndarray, np.ndarray]:
        """(X, Y): two (rows, cols) float64 arrays of cell-centre map coordinates."""
        cc, rr = np.meshgrid(np.arange(self.cols) + 0.5, np.arange(self.rows) + 0.5)
        return self.cell_to_map(cc, rr)

    def vertices(self) -> np.ndarray:
        """(rows, cols, 3) float64 map coordinates of the mesh vertices (cell centres; NaN z for voids)."""
        x, y = self.cell_centres()
        return np.stack([x, y, self.elevation.astype(np.float64)], axis=-1)

    # --- sampling ---------------------------------------------------------------------------------------------
    def sample(self, x, y, method: str = "bilinear", to_extent: bool = False):
        """Height at map points; NaN outside the mesh (beyond the outer cell centres) or next to a void.

        Args:
            x, y: scalars or arrays of the same shape (map units).
            method: "bilinear" (bilinear between the four surrounding centres) or "mesh" (the two-triangle
                surface that :func:`~monoplot_plugin.core.xyz.compute_xyz` intersects).
            to_extent: points in the outer half of an edge cell (inside the raster's extent, beyond the outer cell
                centres) take the height of the nearest point of the mesh's edge instead of NaN: a point a person
                places on the map there (a trial's summit on the DEM's last half cell lost its height, and its pair
                was left out of the fit without a word).
        Returns:
            float or float64 array shaped like x.

        >>> dem = Dem.from_array([[0.0, 0.0], [0.0, 4.0]], (0, 1, 0, 2, 0, -1))
        >>> float(dem.sample(1.25, 0.75)), float(dem.sample(1.25, 0.75, method="mesh"))
        (2.25, 3.0)
        >>> bool(np.isnan(dem.sample(1.9, 0.1))), float(dem.sample(1.9, 0.1, to_extent=True))
        (True, 4.0)
        """
        col, row = self.map_to_cell(x, y)
        scalar = np.ndim(col) == 0
        fc = np.atleast_1d(np.asarray(col, dtype=np.float64)) - 0.5
        fr = np.atleast_1d(np.asarray(row, dtype=np.float64)) - 0.5
        if to_extent:
            with np.errstate(invalid="ignore"):
                edge = (fc >= -0.5) & (fr >= -0.5) & (fc <= self.cols - 0.5) & (fr <= self.rows - 0.5)
            fc = np.where(edge, np.clip(fc, 0.0, self.cols - 1), fc)
            fr = np.where(edge, np.clip(fr, 0.0, self.rows - 1), fr)
        out = np.full(fc.shape, np.nan)
        inside = (fc >= 0) & (fr >= 0) & (fc <= self.cols - 1) & (fr <= self.rows - 1)
        if self.cols >= 2 and self.rows >= 2 and inside.any():
            c = np.minimum(np.floor(fc[inside]).astype(np.int64), self.cols - 2)
            r = np.minimum(np.floor(fr[inside]).astype(np.int64), self.rows - 2)
            s = fc[inside] - c
            t = fr[inside] - r
            z = self.elevation
            z00, z01 = z[r, c].astype(np.float64), z[r, c + 1].astype(np.float64)
            z10, z11 = z[r + 1, c].astype(np.float64), z[r + 1, c + 1].astype(np.float64)
            if method == "bilinear":
                value = (z00 * (1 - s) * (1 - t) + z01 * s * (1 - t) + z10 * (1 - s) * t + z11 * s * t)
            elif method == "mesh":
                upper = s >= t  # triangle (r,c), (r,c+1), (r+1,c+1)
                value = np.where(upper, z00 + s * (z01 - z00) + t * (z11 - z01),
                                 z00 + t * (z10 - z00) + s * (z11 - z10))
                # A void vertex not used by the chosen triangle still leaves a hole in the mesh only where used.
                used_nan = np.where(upper, np.isnan(z00) | np.isnan(z01) | np.isnan(z11),
                                    np.isnan(z00) | np.isnan(z10) | np.isnan(z11))
                value = np.where(used_nan, np.nan, value)
            else:
                raise ValueError(f"unknown sampling method {method!r}")
            out[inside] = value
        if scalar:
            return float(out[0])
        return out.reshape(np.shape(col))

    # --- derived grids ----------------------------------------------------------------------------------------
    def gradient(self) -> Tuple[np.ndarray, np.ndarray]:
        """(dz/dx, dz/dy): two (rows, cols) float64 arrays of map-space slopes (rotation honoured)."""
        z = self.elevation.astype(np.float64)
        dz_drow, dz_dcol = np.gradient(z) if min(z.shape) >= 2 else (np.zeros_like(z), np.zeros_like(z))
        g = self.geotransform
        # [dz/dcol, dz/drow] = J^T [dz/dx, dz/dy] with J = [[a, b], [d, e]].
        det = self._det()
        dzdx = (g[5] * dz_dcol - g[4] * dz_drow) / det
        dzdy = (-g[2] * dz_dcol + g[1] * dz_drow) / det
        return dzdx, dzdy

    def hillshade(self, azimuth: float = 315.0, altitude: float = 45.0) -> np.ndarray:
        """(rows, cols) float64 shading 0..1 (Lambert) for a sun at ``azimuth`` (degrees clockwise from grid north)
        and ``altitude`` (degrees); NaN at voids.

        >>> flat = Dem.from_array(np.zeros((3, 3)), (0, 1, 0, 3, 0, -1))
        >>> round(float(flat.hillshade(altitude=30)[1, 1]), 6)
        0.5
        """
        from .grid import lambert

        dzdx, dzdy = self.gradient()
        return lambert(dzdx, dzdy, azimuth, altitude)

    # --- cutting and reprojection -----------------------------------------------------------------------------
    def crop(self, row0: int, col0: int, rows: int, cols: int) -> "Dem":
        """The sub-grid starting at cell (row0, col0), clipped to the grid; geotransform shifted to match."""
        r0, c0 = max(0, int(row0)), max(0, int(col0))
        r1, c1 = min(self.rows, int(row0) + int(rows)), min(self.cols, int(col0) + int(cols))
        r1, c1 = max(r1, r0), max(c1, c0)
        g = self.geotransform
        x0, y0 = self.cell_to_map(c0, r0)
        return replace(self, elevation=self.elevation[r0:r1, c0:c1], geotransform=(x0, g[1], g[2], y0, g[4], g[5]),
                       window=(self.window[0] + r0, self.window[1] + c0))

    def crop_to_view(self, camera, max_range: Optional[float] = None, margin_cells: int = 2) -> "Dem":
        """The part of the grid that ``camera`` can see within ``max_range`` metres (a rectangle of cells
        containing the camera's view frustum cut by the DEM's height range); self when that is everything."""
        zmin, zmax = self.height_range()
        window = view_window(camera, self.geotransform, self.shape, zmin, zmax, max_range, margin_cells)
        if window is None:
            return self.crop(0, 0, 0, 0)
        if window == (0, 0, self.rows, self.cols):
            return self
        return self.crop(*window)

    def reprojected_to_utm(self) -> "Dem":
        """This DEM warped (bilinear) to the UTM zone of its centre (WGS 84), with a log line; self if not
        geographic."""
        if not self.is_geographic:
            return self
        from osgeo import gdal, osr

        gdal.UseExceptions()
        src = osr.SpatialReference()
        src.ImportFromWkt(self.crs_wkt)
        src.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
        lon, lat = self.cell_to_map(self.cols / 2.0, self.rows / 2.0)
        wgs = osr.SpatialReference()
        wgs.ImportFromEPSG(4326)
        wgs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
        lon, lat, _ = osr.CoordinateTransformation(src, wgs).TransformPoint(lon, lat)
        dst_wkt = utm_wkt_for_lonlat(lon, lat)
        mem = self.to_gdal()
        out = gdal.Warp("", mem, format="MEM", dstSRS=dst_wkt, resampleAlg="bilinear", srcNodata=float("nan"),
                        dstNodata=float("nan"), outputType=gdal.GDT_Float32)
        data = out.GetRasterBand(1).ReadAsArray()
        dst = osr.SpatialReference()
        dst.ImportFromWkt(dst_wkt)
        dem = Dem.from_array(data, out.GetGeoTransform(), dst_wkt)
        dem.source_crs_wkt = self.crs_wkt
        logger.info("DEM in geographic coordinates reprojected to %s (%d x %d cells of %.1f m); results are in "
                    "that CRS", dst.GetName(), dem.cols, dem.rows, dem.cell_size)
        return dem

    def to_gdal(self, path: str = "", driver: str = "MEM"):
        """A GDAL dataset (Float32, nodata NaN) of this DEM: in memory by default, or a file (e.g. "GTiff")."""
        from osgeo import gdal

        gdal.UseExceptions()
        drv = gdal.GetDriverByName(driver)
        ds = drv.Create(path, self.cols, self.rows, 1, gdal.GDT_Float32)
        ds.SetGeoTransform(self.geotransform)
        if self.crs_wkt:
            ds.SetProjection(self.crs_wkt)
        rb = ds.GetRasterBand(1)
        rb.SetNoDataValue(float("nan"))
        rb.WriteArray(self.elevation.astype(np.float32))
        return ds

    def save(self, path) -> None:
        """Write a Float32 GeoTIFF (nodata NaN)."""
        ds = self.to_gdal(str(path), "GTiff")
        ds.FlushCache()
        ds = None


def utm_wkt_for_lonlat(lon: float, lat: float) -> str:
    """WKT of the WGS 84 / UTM zone that contains (lon, lat) in degrees.

    >>> 'UTM zone 32N' in utm_wkt_for_lonlat(8.09, 46.43)
    True
    """
    from osgeo import osr

    zone = int(math.floor((lon + 180.0) / 6.0)) % 60 + 1
    srs = osr.SpatialReference()
    srs.ImportFromEPSG((32600 if lat >= 0 else 32700) + zone)
    return srs.ExportToWkt()


#: :meth:`Dem.near_edge` looks for voids within at most this many cells
VOID_REACH_MAX = 8


def _void_distance(elevation: np.ndarray) -> Optional[np.ndarray]:
    """(rows, cols) float32, each cell's distance to the nearest void in cells, along rows and columns (0 on a
    void; one transform for every reach :meth:`Dem.near_edge` asks); None when there is none."""
    void = np.isnan(elevation)
    if not void.any():
        return None
    import cv2

    return cv2.distanceTransform((~void).astype(np.uint8), cv2.DIST_L1, 3)


def _finite_min_max(a: np.ndarray) -> Tuple[float, float]:
    if a.size == 0 or np.isnan(a).all():
        return float("nan"), float("nan")
    return float(np.nanmin(a)), float(np.nanmax(a))


def _wkt_or_empty(crs) -> str:
    """WKT for WKT / "EPSG:n" / proj strings; "" for empty."""
    if not crs:
        return ""
    text = str(crs)
    if text.lstrip().startswith(("PROJCS", "GEOGCS", "PROJCRS", "GEOGCRS", "COMPD", "GEODCRS", "BOUNDCRS")):
        return text
    from osgeo import osr

    srs = osr.SpatialReference()
    if srs.SetFromUserInput(text) != 0:
        raise ValueError(f"unknown CRS {crs!r}")
    return srs.ExportToWkt()
