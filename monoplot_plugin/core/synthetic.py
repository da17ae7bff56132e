"""Synthetic alpine scenes for tests, benchmarks and the demo: a DEM and a photo-like picture of it.

Nothing is downloaded: the relief is fractal value noise plus ridged noise, deterministic from a seed.

>>> dem = synthetic_terrain((64, 80), cell=50.0, seed=1)
>>> dem.shape, dem.geotransform[1], bool(np.isfinite(dem.elevation).all())
((64, 80), 50.0, True)
>>> 500 < float(dem.elevation.min()) < float(dem.elevation.max()) < 4800
True
"""

from __future__ import annotations

import math
from typing import Optional, Tuple

import numpy as np

from .camera import Camera
from .dem import Dem
from .grid import bilinear

__all__ = ["synthetic_terrain", "render_photo", "SWISS_LV95_WKT", "DEFAULT_ORIGIN"]

#: Top-left corner used by default: a plausible place in the Swiss LV95 grid (EPSG:2056), metres.
DEFAULT_ORIGIN = (2640000.0, 1160000.0)


def _lv95_wkt() -> str:
    try:
        from osgeo import osr

        srs = osr.SpatialReference()
        srs.ImportFromEPSG(2056)
        return srs.ExportToWkt()
    except Exception:  # GDAL missing: the geometry still works, the CRS is only a label
        return ""


SWISS_LV95_WKT = _lv95_wkt()


def _value_noise(shape: Tuple[int, int], cell: float, wavelength: float, rng: np.random.Generator) -> np.ndarray:
    """(rows, cols) smooth noise in [-1, 1] with features ``wavelength`` metres wide (cubic interpolation of a
    coarse random grid).

    The values are those of ``ndimage.zoom(grid, factor, order=3, mode="mirror", prefilter=False)`` cropped to
    the window wanted (past the coarse grid's first cell, the last row and column repeated where zoom's rounded
    size falls short), but only that window is interpolated: on a fine grid the whole zoom is far larger than the
    DEM (a 300 x 300 grid of 2 m cells zoomed a 5 x 5 grid by 3,000: 15,000 x 15,000 values, 23 s, for 90,000).
    """
    from scipy import ndimage

    rows, cols = shape
    factor = wavelength / cell
    gr = int(math.ceil(rows / factor)) + 4
    gc = int(math.ceil(cols / factor)) + 4
    grid = rng.uniform(-1.0, 1.0, size=(gr, gc))
    if factor <= 1.0:
        return grid[:rows, :cols]
    off = int(factor)  # skip the border of the coarse grid
    at = []  # coarse-grid coordinate of each wanted row, then column: zoom's own mapping (grid_mode False)
    for n_in, n_want in ((gr, rows), (gc, cols)):
        n_out = int(round(n_in * factor))  # zoom's output size
        step = (n_in - 1) / (n_out - 1) if n_out > 1 else 1.0
        at.append(np.minimum(np.arange(off, off + n_want), n_out - 1) * step)
    out = np.empty((rows, cols))
    block = max(1, 2_000_000 // max(cols, 1))  # rows at a time: the coordinates of a large DEM stay small
    for r0 in range(0, rows, block):
        rr, cc = np.meshgrid(at[0][r0:r0 + block], at[1], indexing="ij")
        out[r0:r0 + block] = ndimage.map_coordinates(grid, [rr, cc], order=3, mode="mirror", prefilter=False)
    return out


def synthetic_terrain(shape: Tuple[int, int] = (400, 400), cell: float = 25.0, seed: int = 0,
                      origin: Optional[Tuple[float, float]] = None, base: float = 900.0,
                      relief: float = 3000.0, crs_wkt: Optional[str] = None) -> Dem:
    """A DEM with alpine relief: sharp ridges and peaks, broad valleys.

    Args:
        shape: (rows, cols).
        cell: cell size in metres (north-up grid).
        seed: the same seed gives the same terrain.
        origin: (x, y) of the top-left corner; default :data:`DEFAULT_ORIGIN` (Swiss LV95).
        base, relief: lowest valley floors and the height range, in metres (peaks reach about base + relief).
        crs_wkt: CRS of the result; default EPSG:2056.
    Returns:
        :class:`~monoplot_plugin.core.dem.Dem` with float32 elevations (no voids).

    Features are sized in metres, not cells, so a finer grid of the same extent shows the same mountains.
    """
    rows, cols = int(shape[0]), int(shape[1])
    rng = np.random.default_rng(seed)
    x0, y0 = DEFAULT_ORIGIN if origin is None else origin
    extent = max(rows, cols) * cell
    fbm = np.zeros((rows, cols))
    ridged = np.zeros((rows, cols))
    wavelength = max(6000.0, extent / 2.0)
    amplitude = 1.0
    total = 0.0
    weight = np.ones((rows, cols))
    octave = 0
    while wavelength >= 2.5 * cell and octave < 12:
        n = _value_noise((rows, cols), cell, wavelength, rng)
        fbm += amplitude * n
        if wavelength <= 3200.0:  # ridges at mountain scale; coarser ridges would be straight creases
            r = (1.0 - np.abs(n)) ** 2
            ridged += amplitude * r * weight
            weight = np.clip(r * 1.6, 0.0, 1.0)  # ridges sharpen where coarser ridges are
        total += amplitude
        amplitude *= 0.42
        wavelength *= 0.5
        octave += 1
    fbm /= max(total, 1e-9)
    ridged /= max(total, 1e-9)
    h = 0.65 * ridged / max(float(ridged.max()), 1e-9) + 0.35 * (fbm * 0.5 + 0.5)
    h = (h - h.min()) / max(float(h.max() - h.min()), 1e-9)
    h = h ** 1.6  # broad valley floors, steep peaks
    elevation = (base + relief * h).astype(np.float32)
    gt = (float(x0), float(cell), 0.0, float(y0), 0.0, -float(cell))
    return Dem(elevation, gt, SWISS_LV95_WKT if crs_wkt is None else crs_wkt)


def _smooth_random(shape, rng, sigma):
    from scipy import ndimage

    field = ndimage.gaussian_filter(rng.standard_normal(shape), sigma)
    return field / max(float(field.std()), 1e-12)


def render_photo(cam: Camera, dem: Dem, seed: int = 0, haze: bool = True, noise: bool = True,
                 snowline: float = 2900.0, treeline: float = 2000.0, sun_azimuth: float = 135.0,
                 sun_altitude: float = 40.0, max_range: Optional[float] = None) -> np.ndarray:
    """A photo-like picture of ``dem`` seen by ``cam``: (H, W, 3) uint8 RGB.

    Terrain colours: forest below ``treeline``, meadow, rock above it and on slopes over about 35 degrees, snow above
    ``snowline`` (irregular) on slopes under about 45 degrees; a texture fixed to the ground (per DEM cell, from
    ``seed``) so that key points are tied to the terrain; Lambert shading from the sun; distance haze; a sky
    gradient; sensor noise. Built on :func:`~monoplot_plugin.core.xyz.compute_xyz_full`.

    >>> dem = synthetic_terrain((60, 60), cell=100.0, seed=2)
    >>> x, y = dem.cell_to_map(30, 59)
    >>> cam = Camera((x, y, 4000.0), heading=0, pitch=-10, roll=0, fov=60, image_size=(96, 64))
    >>> img = render_photo(cam, dem)
    >>> img.shape, img.dtype.name
    ((64, 96, 3), 'uint8')
    """
    from .xyz import compute_xyz_full

    rng = np.random.default_rng(seed)
    res = compute_xyz_full(cam, dem, max_range=max_range, crop=True, visibility=False)
    work = res.dem
    H, W = cam.height, cam.width
    hit = res.hit
    img = np.empty((H, W, 3), dtype=np.float64)

    # sky: deep blue overhead to pale near the horizon, by the elevation angle of each pixel's ray
    _, dirs = cam.pixel_to_world_ray(cam.pixel_centres().reshape(-1, 2))
    elev_angle = np.clip(dirs[:, 2].reshape(H, W), -1.0, 1.0)
    t = np.clip(elev_angle * 3.0, 0.0, 1.0)[..., None]
    horizon = np.array([0.85, 0.90, 0.95])
    zenith = np.array([0.28, 0.48, 0.82])
    img[:] = horizon * (1 - t) + zenith * t

    if hit.any():
        xyz = res.xyz[hit]
        col, row = work.map_to_cell(xyz[:, 0], xyz[:, 1])
        # ground-fixed textures come from the full DEM grid so that crops do not change them
        tex_rng = np.random.default_rng(seed + 7919)
        texture = _smooth_random(dem.shape, tex_rng, 0.7) * 0.6 + _smooth_random(dem.shape, tex_rng, 3.0) * 0.4
        patches = _smooth_random(dem.shape, tex_rng, 6.0)
        fr = row - 0.5 + work.window[0] - dem.window[0]
        fc = col - 0.5 + work.window[1] - dem.window[1]
        tex = bilinear(texture, fr, fc)
        patch = bilinear(patches, fr, fc)

        dzdx, dzdy = work.gradient()
        gx = np.nan_to_num(bilinear(dzdx, row - 0.5, col - 0.5))
        gy = np.nan_to_num(bilinear(dzdy, row - 0.5, col - 0.5))
        slope = np.degrees(np.arctan(np.hypot(gx, gy)))
        a, h = math.radians(sun_azimuth), math.radians(sun_altitude)
        light = np.array([math.sin(a) * math.cos(h), math.cos(a) * math.cos(h), math.sin(h)])
        norm = np.sqrt(gx * gx + gy * gy + 1.0)
        lambert = np.clip((-gx * light[0] - gy * light[1] + light[2]) / norm, 0.0, 1.0)
        shade = 0.35 + 0.75 * lambert

        z = xyz[:, 2]
        forest = np.array([0.16, 0.27, 0.13])
        meadow = np.array([0.42, 0.50, 0.25])
        rock = np.array([0.45, 0.42, 0.38])
        snow = np.array([0.93, 0.94, 0.97])
        tree_edge = treeline + 120.0 * patch
        colour = np.where((z < tree_edge)[:, None], forest, meadow)
        rocky = (z > tree_edge + 450.0 + 150.0 * patch) | (slope > 35.0 + 5.0 * patch)
        colour = np.where(rocky[:, None], rock, colour)
        snowy = (z > snowline + 200.0 * patch) & (slope < 45.0 + 5.0 * tex)
        colour = np.where(snowy[:, None], snow, colour)
        colour = colour * (1.0 + 0.18 * tex)[:, None]
        terrain = colour * shade[:, None]
        if haze:
            d = res.distance[hit].astype(np.float64)
            k = (1.0 - np.exp(-d / 30000.0))[:, None]
            terrain = terrain * (1 - k) + horizon * k
        img[hit] = terrain

    if noise:
        img += rng.normal(0.0, 0.012, size=img.shape)
    return np.clip(np.round(img * 255.0), 0, 255).astype(np.uint8)
