"""The dock's side of the workflow steps: :mod:`..workflow` called for the dock, and what the dock shows.

No Qt and no qgis here, so tasks can call these in a worker thread. Shapes: ``uv`` (N, 2) pixels, ``xyz`` (M, 3) map
metres, per-pixel ``xyz`` rasters (H, W, 3) with NaN for sky. ``progress(fraction, message)`` and
``is_canceled()`` follow the workflow's one protocol; a cancel raises :class:`~..workflow.progress.Canceled`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..core.camera import Camera
from ..state import MAP, PHOTO, Point
from ..workflow import fit as fit_step
from ..workflow.mixed import fit_accepted
from ..workflow import suggest as suggest_step
from ..workflow.progress import Canceled, IsCanceled, Progress, check_canceled, part
from ..workflow.spread import plain_correlation

__all__ = ["FitOutcome", "suggest", "fit_and_render", "render_products", "residual_segments", "lookup_xyz",
           "locate_in_photo", "camera_sees_dem", "view_wedge", "mask_to_wkt", "colorize_relief", "XYZ_MAX_PIXELS",
           "Canceled"]

#: per-pixel XYZ for linked cursors is computed on at most this many pixels (a scaled copy of the camera)
XYZ_MAX_PIXELS = 1_500_000


# --- suggestions ----------------------------------------------------------------------------------------------

def suggest(photo_rgb: np.ndarray, dem, camera: Optional[Camera], n_photo: int, n_dem: int,
            progress: Progress, is_canceled: IsCanceled, position_sigma_m: Optional[float] = None,
            rough: Optional[Camera] = None) -> Tuple[List[Point], List[Point], float, str, bool]:
    """Key points on the photo (pixels) and on the DEM (map X, Y, Z) as "suggested" :class:`Point` objects
    (:func:`workflow.suggest.suggest`), the distance (m) within which terrain filling the rough camera's view
    was left out of the DEM suggestions (0 = none; :func:`core.suggest.blocked_view`), a warning when the photo
    shows almost nothing ("" otherwise; :func:`workflow.suggest.featureless_note`), and whether the DEM
    suggestions came from the ``rough`` camera (the fitted ``camera`` saw too little terrain)."""
    photo, dem_pts, from_rough = suggest_step.suggest(photo_rgb, dem, camera, n_photo, n_dem, progress,
                                                      is_canceled, position_sigma_m, rough)
    photo_points = [Point.new(PHOTO, u, v, score=float(s)) for (u, v), s in zip(photo.uv, photo.score)]
    kinds = list(getattr(dem_pts, "kind", [""] * len(dem_pts.score)))
    map_points = [Point.new(MAP, x, y, z, score=float(s), label=str(k) if k in ("summit", "saddle", "junction")
                            else "")
                  for (x, y, z), s, k in zip(dem_pts.xyz, dem_pts.score, kinds)]
    return (photo_points, map_points, float(getattr(dem_pts, "near_clip_m", 0.0)),
            suggest_step.featureless_note(photo), from_rough)


# --- fit --------------------------------------------------------------------------------------------------------

@dataclass
class FitOutcome:
    """What a fit task hands back: the camera, a summary, the overlay image and the per-pixel XYZ raster."""

    camera: Camera
    info: dict
    overlay: Optional[np.ndarray] = None
    xyz: Optional[np.ndarray] = None
    footprint_wkt: str = ""


def fit_and_render(uv: np.ndarray, xyz: np.ndarray, pairs: Sequence[Tuple[int, int]], start: Camera, dem,
                   progress: Progress, is_canceled: IsCanceled,
                   check_uv: Optional[np.ndarray] = None, check_xyz: Optional[np.ndarray] = None,
                   free: Optional[Sequence[str]] = None, options=None, done=None, on_ground: Optional[bool] = None,
                   eye_height: Optional[float] = None) -> FitOutcome:
    """Fit the camera (0-85 %, :func:`workflow.fit.fit`), then render the overlay and per-pixel XYZ (85-100 %).

    ``check_uv`` (C, 2) / ``check_xyz`` (C, 3): paired check points, not fitted; their error goes into the info
    (``check_rmse_px``, ``n_check``, ``check_errors`` in pixels). The camera is held on the ground by the
    workflow's one rule (:func:`workflow.fit.on_ground_rule`; ``on_ground`` / ``eye_height`` as there, None
    automatic). ``free`` / ``options``: the fitted
    parameters and the core ``FitOptions`` (the dock's fit settings, :mod:`.fit_settings`), None for the defaults.
    ``done``: a finished :class:`workflow.fit.FitDone` of these very inputs (the background refit's): only the
    products are rendered.

    Raises:
        FitRefused (a ValueError): the fit refused the input (too few points...), with the fit's own explanation.
        Canceled: the user canceled.
    """
    if done is None:
        done = fit_accepted(uv, xyz, start, dem, pairs=pairs or None, check_uv=check_uv, check_xyz=check_xyz,
                            progress=part(progress, 0.0, 0.85), is_canceled=is_canceled, free=free, options=options,
                            on_ground=on_ground, eye_height=eye_height)
    result, camera = done.result, done.camera
    info = {
        "status": result.status,
        "rmse_px": finite_or_none(result.rmse_px),
        "loo_rmse_px": finite_or_none(result.loo_rmse_px),
        "sigma": {k: float(v) for k, v in (result.std or {}).items()},
        # ... and their correlations: the products' error where their ground is (workflow.spread)
        "correlation": plain_correlation(result.correlation),
        # the camera's σ as a pixel error, on the terrain the fit matched: an unpaired fit's error figure
        "sigma_px": finite_or_none(fit_step.sigma_px(result, xyz)),
        "converged": result.status == "ok",
        "message": str(result.message),
        "mode": result.mode,
        "free": list(result.free),
        "on_ground": done.on_ground,
        "eye_height_m": done.eye_height,
        "height_freed": done.height_freed,
        "clearance_m": finite_or_none(fit_step.ground_clearance(camera, dem)),
        # the camera sees no part of the DEM (core fit.api.sees_no_terrain): no advice on its position or lens
        "sees_no_terrain": bool((result.evidence or {}).get("sees_no_terrain")),
        "n_photo": int(len(uv)),
        "n_map": int(len(xyz)),
        "n_pairs": int(len(pairs)),
        # the pairs checked an unpaired fit of the other points (workflow.mixed): its check errors end with theirs
        "pairs_checked": int(done.pairs_checked),
        # ... or, the paired fit kept over it, that fit's status ("" when none was tried)
        "alone_status": done.alone_status,
        "n_matched": int(_inliers(result).sum()),  # the pairs kept, as the message counts them
        "matched_idx": [[int(i), int(j)] for (i, j), ok in zip(np.asarray(result.pairs).reshape(-1, 2),
                                                              _inliers(result)) if ok],
        "outlier_idx": [int(i) for i in np.flatnonzero(np.asarray(result.photo_outliers, dtype=bool).reshape(-1))]
        if len(np.asarray(result.photo_outliers).reshape(-1)) == len(uv) else [],
        "elapsed_s": float(result.elapsed_s),
        "check_rmse_px": finite_or_none(result.check_rmse_px),
        "n_check": int(len(result.check_residuals_px)),
        "check_errors": [finite_or_none(np.hypot(*r)) for r in np.asarray(result.check_residuals_px).reshape(-1, 2)],
    }
    progress(0.88, "")
    overlay, pixel_xyz, footprint = render_products(camera, dem, is_canceled,
                                                    lambda f, m: progress(0.88 + 0.12 * f, m))
    progress(1.0, "")
    return FitOutcome(camera, info, overlay, pixel_xyz, footprint)


def _inliers(result) -> np.ndarray:
    """(K,) bool of the fit's pairs that it kept (all True when it does not say)."""
    k = len(np.asarray(result.pairs).reshape(-1, 2))
    inl = np.asarray(getattr(result, "inliers", np.ones(k, bool)), dtype=bool)
    return inl if inl.shape == (k,) else np.ones(k, bool)


def finite_or_none(v) -> Optional[float]:
    """``v`` as a float, None when it is None, NaN or infinite (the fit info keeps JSON-friendly numbers)."""
    return None if v is None or not math.isfinite(float(v)) else float(v)


def render_products(camera: Camera, dem, is_canceled: IsCanceled = lambda: False,
                    progress=None) -> Tuple[np.ndarray, np.ndarray, str]:
    """What the GUI shows for a fitted camera, at up to :data:`XYZ_MAX_PIXELS` pixels:

    (overlay RGBA (h, w, 4) uint8, per-pixel XYZ (h, w, 3) NaN = sky, visible-area WKT in the DEM CRS).
    ``progress(fraction, message)`` between its steps (over a 25 M-cell DEM a fit's bar stood at 88 % for 7 s).
    """
    from ..core.render import render_dem
    from ..core.xyz import compute_xyz_full

    w, h = camera.image_size
    small = camera.scaled(min(1.0, math.sqrt(XYZ_MAX_PIXELS / float(w * h))))
    report = progress or (lambda fraction, message: None)
    report(0.0, "the terrain each pixel sees")
    res = compute_xyz_full(small, dem, visibility=True)
    check_canceled(is_canceled)
    report(0.6, "the relief overlay")
    rendered = render_dem(small, dem, result=res)
    overlay = colorize_relief(np.asarray(rendered.shade), res.xyz)
    check_canceled(is_canceled)
    report(0.9, "the footprint on the map")
    return overlay, res.xyz, mask_to_wkt(res.visible, dem)


def colorize_relief(shade: np.ndarray, xyz: np.ndarray, contour_m: float = 100.0) -> np.ndarray:
    """RGBA (h, w, 4) uint8 overlay: shaded relief (``shade`` 0..1, NaN = sky) in cool greys with orange contour
    lines every ``contour_m`` metres of the heights in ``xyz``; the sky is transparent."""
    hit = np.isfinite(shade)
    s = np.nan_to_num(shade, nan=0.0).clip(0.0, 1.0)
    base = 40.0 + 200.0 * s
    rgba = np.zeros(shade.shape + (4,), np.uint8)
    rgba[..., 0] = (base * 0.80).astype(np.uint8)
    rgba[..., 1] = (base * 0.92).astype(np.uint8)
    rgba[..., 2] = base.astype(np.uint8)
    rgba[..., 3] = np.where(hit, 255, 0).astype(np.uint8)
    z = xyz[..., 2]
    band = np.floor(np.where(np.isfinite(z), z, 0.0) / contour_m)
    edge = np.zeros(shade.shape, bool)
    edge[:, 1:] |= band[:, 1:] != band[:, :-1]
    edge[1:, :] |= band[1:, :] != band[:-1, :]
    rgba[edge & hit] = (255, 140, 0, 255)
    return rgba


def mask_to_wkt(mask: np.ndarray, dem) -> str:
    """WKT MultiPolygon of the True cells of a (rows, cols) mask over ``dem`` (polygonised with GDAL, small gaps
    closed first); "" when the mask is empty."""
    from osgeo import gdal, ogr, osr
    from scipy import ndimage

    if mask is None or not mask.any():
        return ""
    closed = ndimage.binary_closing(mask, iterations=2)
    closed = ndimage.binary_opening(closed, iterations=1) | mask  # drop speckle, keep every seen cell
    rows, cols = closed.shape
    ds = gdal.GetDriverByName("MEM").Create("", cols, rows, 1, gdal.GDT_Byte)
    ds.SetGeoTransform(tuple(dem.geotransform))
    ds.GetRasterBand(1).WriteArray(closed.astype(np.uint8))
    srs = osr.SpatialReference()
    if dem.crs_wkt:
        srs.ImportFromWkt(dem.crs_wkt)
    vec = ogr.GetDriverByName("Memory").CreateDataSource("")
    layer = vec.CreateLayer("visible", srs)
    layer.CreateField(ogr.FieldDefn("v", ogr.OFTInteger))
    gdal.Polygonize(ds.GetRasterBand(1), ds.GetRasterBand(1), layer, 0)
    union = ogr.Geometry(ogr.wkbMultiPolygon)
    for feat in layer:
        geom = feat.GetGeometryRef()
        if geom is not None and feat.GetField("v") == 1:
            union.AddGeometry(geom.Clone())
    return union.ExportToWkt() if union.GetGeometryCount() else ""


# --- results ----------------------------------------------------------------------------------------------------

def residual_segments(camera: Camera, uv: np.ndarray, xyz: np.ndarray, pairs: Sequence[Tuple[int, int]]
                      ) -> List[Tuple[Tuple[float, float], Tuple[float, float]]]:
    """Each photo point -> its partner's projection (pairs) or the nearest projected map point (the fit's loss)."""
    if len(uv) == 0 or len(xyz) == 0:
        return []
    proj = camera.project(xyz)
    ok = np.isfinite(proj).all(axis=1)
    partner = dict(pairs)
    out = []
    for i, p in enumerate(uv):
        j = partner.get(i)
        if j is None or not ok[j]:
            if not ok.any():
                continue
            d = np.where(ok, np.hypot(proj[:, 0] - p[0], proj[:, 1] - p[1]), np.inf)
            j = int(np.argmin(d))
        out.append(((float(p[0]), float(p[1])), (float(proj[j, 0]), float(proj[j, 1]))))
    return out


def lookup_xyz(xyz: np.ndarray, photo_size: Tuple[int, int], u: float, v: float
               ) -> Optional[Tuple[float, float, float]]:
    """Ground (X, Y, Z) at photo pixel (u, v) from a (possibly downscaled) per-pixel XYZ raster; None for sky."""
    h, w = xyz.shape[:2]
    sx, sy = w / float(photo_size[0]), h / float(photo_size[1])
    col, row = int(math.floor(u * sx)), int(math.floor(v * sy))
    if not (0 <= col < w and 0 <= row < h):
        return None
    p = xyz[row, col]
    return None if not np.isfinite(p).all() else (float(p[0]), float(p[1]), float(p[2]))


def locate_in_photo(camera: Camera, dem, xyz: Optional[np.ndarray], x: float, y: float
                    ) -> Tuple[Optional[Tuple[float, float]], str]:
    """Where map point (x, y) appears: (pixel, "visible"), (pixel, "hidden") behind terrain, (None, "outside")."""
    z = float(dem.sample(x, y))
    if not math.isfinite(z):
        return None, "outside"
    uv, depth = camera.project_with_depth([[x, y, z]])
    if not (depth[0] > 0 and camera.in_image(uv)[0]):
        return None, "outside"
    u, v = float(uv[0, 0]), float(uv[0, 1])
    if xyz is None:
        return (u, v), "visible"
    seen = lookup_xyz(xyz, camera.image_size, u, v)
    cam = np.asarray(camera.position)
    dist = float(np.linalg.norm(np.array([x, y, z]) - cam))
    if seen is None:
        return (u, v), "visible"  # sky in the raster: the point is on the skyline
    seen_dist = float(np.linalg.norm(np.asarray(seen) - cam))
    tolerance = max(30.0, 0.02 * dist)  # DEM cells and the raster's pixel footprint
    return (u, v), ("hidden" if seen_dist < dist - tolerance else "visible")


def _dem_in_view(camera: Camera, dem, samples: int = 40) -> Tuple[np.ndarray, np.ndarray]:
    """(K, 3) DEM cells of a coarse grid of samples that project into the photo in front of ``camera``, and their
    (K,) depths (m)."""
    rows, cols = dem.elevation.shape
    r = np.linspace(0, rows - 1, min(samples, rows)).astype(int)
    c = np.linspace(0, cols - 1, min(samples, cols)).astype(int)
    rr, cc = np.meshgrid(r, c, indexing="ij")
    z = dem.elevation[rr, cc].ravel()
    x, y = dem.cell_to_map(cc.ravel() + 0.5, rr.ravel() + 0.5)
    pts = np.column_stack([np.asarray(x, float), np.asarray(y, float), z])[np.isfinite(z)]
    if not len(pts):
        return pts, np.zeros(0)
    uv, depth = camera.project_with_depth(pts)
    seen = camera.in_image(uv) & (depth > 0)
    return pts[seen], depth[seen]


def camera_sees_dem(camera: Camera, dem, samples: int = 40) -> bool:
    """True when some DEM cells project into the photo in front of the camera (coarse grid of samples)."""
    return bool(len(_dem_in_view(camera, dem, samples)[0]))


def typical_range(camera: Camera, dem, samples: int = 40) -> Optional[float]:
    """Median distance (m) from ``camera`` to the DEM cells it looks at (coarse grid of samples; hidden ones too),
    None when it looks at none."""
    depth = _dem_in_view(camera, dem, samples)[1]
    return float(np.median(depth)) if len(depth) else None


def view_wedge(camera: Camera, distance: float, steps: int = 24) -> List[Tuple[float, float]]:
    """Closed polygon (x, y) of the horizontal field of view out to ``distance`` metres (the prior's footprint).

    >>> w = view_wedge(Camera((0, 0, 0), 0, 0, 0, 90, (100, 100)), 10, steps=2)
    >>> [(round(x, 3), round(y, 3)) for x, y in w]
    [(0.0, 0.0), (-7.071, 7.071), (0.0, 10.0), (7.071, 7.071), (0.0, 0.0)]
    """
    x0, y0 = camera.position[:2]
    half = camera.fov / 2.0
    pts = [(x0, y0)]
    for i in range(steps + 1):
        a = math.radians(camera.heading - half + camera.fov * i / steps)
        pts.append((x0 + distance * math.sin(a), y0 + distance * math.cos(a)))
    pts.append((x0, y0))
    return pts


def wedge_reach(camera: Camera, ground_z: float, farthest: float) -> float:
    """How far (metres) the rough camera's view wedge is drawn: to ``farthest`` (the DEM's farthest corner), or, when
    the whole picture looks below the horizon (a drone at -45°), to 1.5 times where its top edge meets level ground
    at ``ground_z`` (a trial's wedge reached 1 km across the DEM for a footprint of 250 m).

    >>> cam = Camera((0, 0, 120), 0, -45, 0, 70, (400, 300))
    >>> round(wedge_reach(cam, 0.0, 5000.0)), wedge_reach(cam.with_parameters(pitch=-5), 0.0, 5000.0)
    (578, 5000.0)
    """
    top = camera.pitch + camera.vertical_fov / 2.0
    above = float(camera.position[2]) - float(ground_z)
    if top >= -1.0 or not math.isfinite(above) or above <= 0.0:
        return float(farthest)
    return float(min(farthest, 1.5 * above / math.tan(math.radians(-top))))
