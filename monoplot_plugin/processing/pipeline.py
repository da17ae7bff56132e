"""The Processing side of the workflow steps: :mod:`..workflow` called with Processing's conventions.

No qgis import here (the batch runs these in a loop). What this module adds to the workflow: errors the user must
fix become :class:`InputError` (which the algorithms turn into a ``QgsProcessingException``), and results come as
plain arrays. ``progress`` and ``is_canceled`` follow the workflow's one protocol (:mod:`..workflow.progress`).
"""

from __future__ import annotations

from typing import Dict, Optional, Tuple

import numpy as np

from ..core.camera import Camera
from ..workflow import fit as fit_step
from ..workflow import products, vectors
from ..workflow import suggest as suggest_step
from ..workflow.progress import IsCanceled, Progress
from ..workflow.xyz import clear_cache, xyz_raster  # noqa: F401 (the algorithms' names for them)
from .inputs import InputError

photo_to_map = vectors.photo_to_map
visibility = vectors.visibility
fill_missing_z = vectors.fill_missing_z


# --- suggestions ----------------------------------------------------------------------------------------------
def suggest_photo(photo: np.ndarray, max_points: int) -> Tuple[np.ndarray, np.ndarray, str]:
    """(uv (N, 2) pixels, scores (N,) in [0, 1], a warning or "") of suggested points on an (H, W, 3) uint8 photo;
    the warning when the photo shows almost nothing (:func:`workflow.suggest.featureless_note`)."""
    result = suggest_step.suggest_photo(photo, max_points)
    return (np.asarray(result.uv, dtype=float).reshape(-1, 2), np.asarray(result.score, dtype=float),
            suggest_step.featureless_note(result))


def suggest_dem(dem, max_points: int, camera: Optional[Camera] = None, position_sigma_m: Optional[float] = None,
                is_canceled: Optional[IsCanceled] = None) -> Tuple[np.ndarray, np.ndarray, list, float]:
    """(xyz (N, 3) map coordinates, scores (N,), kinds such as "summit" or "orb", near clip) of suggested terrain
    points; with a camera only those it sees. The near clip (m, 0 = none) is the distance within which terrain that
    fills the camera's view was left out (:func:`core.suggest.blocked_view`)."""
    result = suggest_step.suggest_dem(dem, max_points, camera, position_sigma_m, is_canceled)
    return (np.asarray(result.xyz, dtype=float).reshape(-1, 3), np.asarray(result.score, dtype=float),
            [str(k) for k in result.kind], float(result.near_clip_m))


# --- fit ------------------------------------------------------------------------------------------------------
def fit(image_size, uv: np.ndarray, xyz: np.ndarray, prior: Camera, dem, paired: bool,
        progress: Optional[Progress] = None, is_canceled: Optional[IsCanceled] = None,
        on_ground: Optional[bool] = None, eye_height: Optional[float] = None,
        check: Optional[np.ndarray] = None, free=None) -> Tuple[Camera, Dict]:
    """Fit a camera to (N, 2) photo points and (M, 3) DEM points, from ``prior`` (:func:`workflow.fit.fit`).

    Paired: row i of ``uv`` and of ``xyz`` are the same point. ``on_ground`` / ``eye_height``: the workflow's one
    rule (:func:`workflow.fit.on_ground_rule`; None: automatic, as in the dock); ``check`` (N,) bool: the paired
    rows that are check points (measured, not fitted); ``free``: the parameters fitted (None: the default seven).
    Returns (camera, info) with
    ``info["rmse_px"]``, ``"status"`` ("ok", "uncertain" or "poor"),
    ``"message"`` and ``"summary"`` (the fit's JSON digest). Raises :class:`InputError` when the fit refuses the
    points (the message says what to add) and :class:`~..workflow.progress.Canceled` when canceled.
    """
    return fit_step.fit_points(image_size, uv, xyz, prior, dem, paired, progress=progress, is_canceled=is_canceled,
                               on_ground=on_ground, eye_height=eye_height, check=check, free=free)


# --- products ---------------------------------------------------------------------------------------------------
def write_xyz(path: str, camera: Camera, dem, crs_wkt: str, photo_name: str = "",
              progress: Optional[Progress] = None, is_canceled: Optional[IsCanceled] = None,
              photo: Optional[np.ndarray] = None, fit: Optional[dict] = None, area: Optional[np.ndarray] = None):
    """Write the XYZ raster (the one layout: photo pixel space, bands X, Y, Z); with the ``photo``, its print border
    and caption get no coordinates (:func:`workflow.products.picture_area`; ``area``: that area already found);
    ``fit``: the camera's verdict, kept in the metadata as the dock keeps it."""
    return products.write_xyz(path, camera, dem, crs_wkt, photo_name=photo_name, overwrite=True, progress=progress,
                              is_canceled=is_canceled, photo=photo, fit=fit, area=area)


def orthophoto(path: str, photo: np.ndarray, camera: Camera, dem, resolution: Optional[float],
               progress: Optional[Progress] = None, is_canceled: Optional[IsCanceled] = None, grid=None,
               fit: Optional[dict] = None):
    """Write the photo draped on the DEM (:func:`workflow.products.orthophoto`); ``fit``: the camera's verdict,
    kept in the metadata."""
    try:
        return products.orthophoto(path, photo, camera, dem, resolution, overwrite=True, progress=progress,
                                   is_canceled=is_canceled, grid=grid, fit=fit)
    except products.ProductError as exc:
        raise InputError(str(exc)) from exc


def report(path: str, photo: np.ndarray, camera: Camera, dem, points_csv: Optional[str] = None, verdict: str = "",
           sigmas: Optional[dict] = None, photo_taken: str = ""):
    """Write a one-page report (PNG or PDF by extension) of a fitted camera; ``verdict``: "status: message" of
    the fit that wrote the camera (its badge and text then say it, as the dock's report does); ``sigmas``: that
    fit's σ per parameter (None: from the table's paired points, if any); ``photo_taken``: its EXIF date."""
    return products.report(path, photo, camera, dem, points_csv=points_csv, overwrite=True, verdict=verdict,
                           sigmas=sigmas, photo_taken=photo_taken)
