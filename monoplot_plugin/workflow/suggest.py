"""The suggestion step: key points on the photo (pixels) and on the DEM (map X, Y, Z), for the dock and Processing.

With a camera, DEM suggestions are the terrain points it sees (a rendering from it); without, a map hillshade.
"""

from __future__ import annotations

from typing import Optional, Tuple

import numpy as np

from ..core.camera import Camera
from ..core.suggest import DemSuggestions, PhotoSuggestions, suggest_dem_points, suggest_photo_points
from .progress import IsCanceled, Progress, check_canceled

__all__ = ["suggest", "suggest_photo", "suggest_dem", "featureless_note"]


def suggest_photo(photo: np.ndarray, max_points: int) -> PhotoSuggestions:
    """Suggested points of an (H, W, 3) uint8 photo: ``.uv`` (N, 2) pixels, ``.score`` (N,) in [0, 1]."""
    return suggest_photo_points(photo, max_points=max_points)


def featureless_note(photo_points: PhotoSuggestions) -> str:
    """A warning when the photo shows almost nothing (its suggestions are on noise: fog, a blank or burnt-out frame,
    the wrong file), else ""; the dock and Processing show the same words."""
    if not photo_points.featureless:
        return ""
    return (f"The photo shows almost no structure (contrast {photo_points.contrast:.1f} grey levels at a coarse "
            f"scale): its {len(photo_points)} suggestions are on noise, not on features anyone could recognise. "
            "Check that it is the right photo; a photo in fog or a blank frame cannot be georeferenced.")


def suggest_dem(dem, max_points: int, camera: Optional[Camera] = None,
                position_sigma_m: Optional[float] = None, is_canceled: Optional[IsCanceled] = None) -> DemSuggestions:
    """Suggested terrain points: ``.xyz`` (M, 3) map coordinates, ``.score`` (M,), ``.kind`` ("summit", "saddle",
    "junction", "orb"...); with a camera only those it sees, past terrain nearer than its position's uncertainty
    (``position_sigma_m``, the user's, else 100 m) when such terrain fills its view (``.near_clip_m``). Raises
    :class:`~.progress.Canceled` between its steps once ``is_canceled()`` says so."""
    return suggest_dem_points(dem, camera=camera, max_points=max_points, position_sigma_m=position_sigma_m,
                              poll=lambda: check_canceled(is_canceled))


#: A fitted camera whose rendering gives fewer DEM suggestions than this share of those asked for gives way to the
#: rough camera's, when that gives more (:func:`suggest`)
FEW_DEM_SHARE = 0.2


def suggest(photo: np.ndarray, dem, camera: Optional[Camera], n_photo: int, n_dem: int,
            progress: Optional[Progress] = None, is_canceled: Optional[IsCanceled] = None,
            position_sigma_m: Optional[float] = None,
            rough: Optional[Camera] = None) -> Tuple[PhotoSuggestions, DemSuggestions, bool]:
    """Both sets of suggestions (photo, then DEM), with progress and cancel between them, and whether the DEM's came
    from the ``rough`` camera: a fitted ``camera`` that sees too little terrain for :data:`FEW_DEM_SHARE` of
    ``n_dem`` gives way to it when it gives more (a summit trial's failed automatic camera, pitched 35° up, "uncertain",
    left Suggest with 0 DEM suggestions and no way on)."""
    report = progress or (lambda fraction, message="": None)
    report(0.05, "photo")
    photo_points = suggest_photo(photo, n_photo)
    check_canceled(is_canceled)
    report(0.45, "DEM")
    dem_points = suggest_dem(dem, n_dem, camera, position_sigma_m, is_canceled)
    check_canceled(is_canceled)
    from_rough = False
    if rough is not None and camera is not None and rough != camera and len(dem_points) < FEW_DEM_SHARE * n_dem:
        report(0.7, "DEM, from the rough camera")
        from_prior = suggest_dem(dem, n_dem, rough, position_sigma_m, is_canceled)
        check_canceled(is_canceled)
        if len(from_prior) > len(dem_points):
            dem_points, from_rough = from_prior, True
    report(0.95, "")
    return photo_points, dem_points, from_rough
