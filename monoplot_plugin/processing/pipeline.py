"""The steps of the Monoplot pipeline as plain functions over core objects (no qgis import).

The algorithms are thin wrappers around these; the batch runs them in a loop. Each function documents its
shapes and units; ``progress`` arguments are callables ``progress(fraction in [0, 1]) -> bool`` that return True
when the user asked to cancel.
"""

from __future__ import annotations

from typing import Callable, Dict, Optional, Tuple

import numpy as np

from ..core.camera import Camera
from .inputs import InputError

Progress = Optional[Callable[[float], bool]]


def _tick(progress: Progress, fraction: float) -> bool:
    return bool(progress(fraction)) if progress is not None else False


# --- DEM ------------------------------------------------------------------------------------------------------
def load_dem(path: str, void_value: Optional[float] = None):
    """A core :class:`Dem` from a raster file (``void_value``: elevation meaning 'no data', e.g. 0)."""
    from ..core.dem import Dem

    try:
        return Dem.open(path, void_value=void_value)
    except Exception as exc:  # GDAL cannot read it: say which file
        raise InputError(f"cannot read the DEM {path}: {exc}") from exc


def sample_dem(dem, xy: np.ndarray) -> np.ndarray:
    """(N,) bilinear DEM elevations at (N, 2) map coordinates; NaN outside the DEM or in voids."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    if len(xy) == 0:
        return np.zeros(0)
    return np.asarray(dem.sample(xy[:, 0], xy[:, 1]), dtype=float)


# --- suggestions ----------------------------------------------------------------------------------------------
def suggest_photo(photo: np.ndarray, max_points: int) -> Tuple[np.ndarray, np.ndarray]:
    """(uv (N, 2) pixels, scores (N,) in [0, 1]) of suggested points on an (H, W, 3) uint8 photo."""
    from ..core.suggest import suggest_photo_points

    result = suggest_photo_points(photo, max_points=max_points)
    return np.asarray(result.uv, dtype=float).reshape(-1, 2), np.asarray(result.score, dtype=float)


def suggest_dem(dem, max_points: int, camera: Optional[Camera] = None,
                progress: Progress = None) -> Tuple[np.ndarray, np.ndarray, list]:
    """(xyz (N, 3) map coordinates, scores (N,), kinds such as "summit" or "orb") of suggested terrain points;
    with a camera only those it sees."""
    from ..core.suggest import suggest_dem_points

    result = suggest_dem_points(dem, camera=camera, max_points=max_points)
    _tick(progress, 1.0)
    return (np.asarray(result.xyz, dtype=float).reshape(-1, 3), np.asarray(result.score, dtype=float),
            [str(k) for k in result.kind])


# --- fit ------------------------------------------------------------------------------------------------------
def fit(image_size, uv: np.ndarray, xyz: np.ndarray, prior: Camera, dem, paired: bool,
        progress: Progress = None, on_ground: bool = False, eye_height: float = 1.7) -> Tuple[Camera, Dict]:
    """Fit a camera to (N, 2) photo points and (M, 3) DEM points, from ``prior`` (core :func:`fit_camera`).

    Paired: row i of ``uv`` and of ``xyz`` are the same point. ``on_ground``: the camera stands ``eye_height``
    metres above the DEM. Returns (camera, info) with ``info["rmse_px"]``, ``"status"`` ("ok" or "poor"),
    ``"message"`` and ``"summary"`` (the fit's JSON digest). Raises :class:`InputError` when the fit refuses the
    points (the message says what to add) and :class:`FitCanceledError` when canceled.
    """
    from ..core.fit import fit_camera

    if tuple(image_size) != tuple(prior.image_size):
        raise InputError(f"the prior camera is for a {prior.width}x{prior.height} image, the photo is "
                         f"{image_size[0]}x{image_size[1]}")
    pairs = np.column_stack([np.arange(len(uv)), np.arange(len(uv))]) if paired else None
    state = {"fraction": 0.0}

    def report(fraction, message=""):
        state["fraction"] = fraction
        _tick(progress, fraction)

    result = fit_camera(uv, xyz, prior, pairs=pairs, ground=dem if on_ground else None, eye_height=eye_height,
                        progress=report, is_canceled=lambda: _tick(progress, state["fraction"]))
    if result.status == "refused":
        raise InputError(f"the fit refused these points: {result.message}")
    if result.status == "canceled":
        raise FitCanceledError(result.message)
    camera = result.camera
    rmse = float(result.rmse_px) if np.isfinite(result.rmse_px) else point_rmse(camera, uv, xyz, paired)
    return camera, {"rmse_px": rmse, "status": result.status, "message": result.message,
                    "summary": result.summary()}


class FitCanceledError(RuntimeError):
    """The user canceled the fit."""


def point_rmse(camera: Camera, uv: np.ndarray, xyz: np.ndarray, paired: bool) -> float:
    """RMS pixel distance from photo points to their (paired) or nearest (unpaired) projected DEM point."""
    projected = camera.project(xyz)
    if paired:
        d = np.linalg.norm(projected - uv, axis=1)
    else:
        ok = np.isfinite(projected).all(axis=1)
        if not ok.any():
            return float("inf")
        d = np.linalg.norm(uv[:, None, :] - projected[None, ok, :], axis=2).min(axis=1)
    d = d[np.isfinite(d)]
    return float(np.sqrt(np.mean(d ** 2))) if len(d) else float("inf")


# --- per-pixel XYZ ----------------------------------------------------------------------------------------------
#: The last XYZ raster: camera JSON, the Dem object itself (held, so that a new Dem can never be mistaken for it),
#: and the (H, W, 3) array.
_XYZ_CACHE: Dict[str, object] = {}


def xyz_raster(camera: Camera, dem, progress: Progress = None) -> np.ndarray:
    """(H, W, 3) map coordinates of the ground seen through every pixel; NaN for sky. The last one is kept (a
    time-lapse batch and the vector conversions reuse it for the same camera and Dem object)."""
    key = camera.to_json()
    if _XYZ_CACHE.get("camera") != key or _XYZ_CACHE.get("dem") is not dem:
        from ..core.xyz import compute_xyz

        _XYZ_CACHE.clear()  # one entry: rasters are large
        _XYZ_CACHE.update(camera=key, dem=dem, xyz=np.asarray(compute_xyz(camera, dem)))
    _tick(progress, 1.0)
    return _XYZ_CACHE["xyz"]


def clear_cache() -> None:
    """Forget the cached XYZ raster (and the DEM it holds)."""
    _XYZ_CACHE.clear()


def photo_to_map(camera: Camera, dem, uv: np.ndarray) -> np.ndarray:
    """(N, 3) ground points seen at (N, 2) pixel positions: the exact first hit of each position's own ray on the
    DEM mesh (core, as the dock does), not the centre of its pixel; NaN for sky and outside the photo."""
    from ..core.transforms import photo_points_to_map

    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    out = np.full((len(uv), 3), np.nan)
    with np.errstate(invalid="ignore"):
        inside = (np.isfinite(uv).all(axis=1) & (uv[:, 0] >= 0) & (uv[:, 0] <= camera.width) & (uv[:, 1] >= 0)
                  & (uv[:, 1] <= camera.height))
    if inside.any():
        out[inside] = photo_points_to_map(uv[inside], camera, dem)[0]
    return out


def visibility(camera: Camera, dem):
    """A function ``(N, 3) map points -> (N,) bool``: in the image and not hidden by terrain (depth test against
    the XYZ raster, outputs' :func:`visibility_of_points`)."""
    from ..outputs.geometry import visibility_of_points

    xyz = xyz_raster(camera, dem)

    def visible(points: np.ndarray) -> np.ndarray:
        return visibility_of_points(camera, np.asarray(points, dtype=float).reshape(-1, 3), xyz)[1]

    return visible


def write_xyz(path: str, xyz: np.ndarray, crs_wkt: str, camera: Optional[Camera] = None, photo_name: str = ""):
    """Write the XYZ raster (outputs' GeoTIFF layout: photo pixel space, bands X, Y, Z)."""
    from ..outputs.xyz_raster import write_xyz_raster

    write_xyz_raster(path, xyz, crs_wkt, overwrite=True, camera=camera, photo_name=photo_name)


# --- orthophoto and report ------------------------------------------------------------------------------------
def orthophoto(path: str, photo: np.ndarray, camera: Camera, dem, crs_wkt: str, resolution: Optional[float],
               progress: Progress = None) -> None:
    """Write the photo draped on the DEM as a north-up RGBA GeoTIFF on the DEM's grid, or on a grid of cell size
    ``resolution`` over the same extent (elevations resampled bilinearly)."""
    from ..outputs.orthophoto import orthophoto_from_camera

    xyz = xyz_raster(camera, dem)
    _tick(progress, 0.5)
    grid = dem if not resolution else dem_at_resolution(dem, resolution)
    orthophoto_from_camera(path, photo, camera, grid, xyz, overwrite=True)
    _tick(progress, 1.0)


def dem_at_resolution(dem, resolution: float):
    """A north-up copy of ``dem`` with square cells of ``resolution`` map units over the same extent."""
    from ..core.dem import Dem

    xmin, ymin, xmax, ymax = dem.bounds()
    cols = max(2, int(round((xmax - xmin) / resolution)))
    rows = max(2, int(round((ymax - ymin) / resolution)))
    if rows * cols > 50_000_000:
        raise InputError(f"orthophoto of {cols}x{rows} cells at {resolution} map units is too large")
    xs = xmin + (np.arange(cols) + 0.5) * resolution
    ys = ymax - (np.arange(rows) + 0.5) * resolution
    gx, gy = np.meshgrid(xs, ys)
    elevation = np.asarray(dem.sample(gx.ravel(), gy.ravel()), dtype=float).reshape(rows, cols)
    return Dem.from_array(elevation, (xmin, resolution, 0.0, ymax, 0.0, -resolution), crs_wkt=dem.crs_wkt)


def report(path: str, photo: np.ndarray, camera: Camera, dem, points_csv: Optional[str] = None) -> None:
    """Write a one-page report (PNG or PDF by extension) of a fitted camera."""
    from ..outputs.report import write_report

    write_report(path, photo, camera, dem, points_csv=points_csv, overwrite=True)
