"""The suggestion step: key points on the photo (pixels) and on the DEM (map X, Y, Z), for the dock and Processing.

With a camera, DEM suggestions are the terrain points it sees (a rendering from it); without, a map hillshade.
"""

from __future__ import annotations

from typing import Optional, Tuple

import numpy as np

from ..core.camera import Camera
from ..core.suggest import DemSuggestions, PhotoSuggestions, suggest_dem_points, suggest_photo_points
from .progress import IsCanceled, Progress, check_canceled

__all__ = ["suggest", "suggest_photo", "suggest_dem", "featureless_note", "merge_dem_suggestions"]


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


#: A fitted camera whose rendering gives fewer DEM suggestions than this share of those asked for is helped by the
#: rough camera's, when that gives more (:func:`suggest`)
FEW_DEM_SHARE = 0.2
#: A rough camera's DEM suggestion nearer than this (m, in X and Y) to one of the fitted camera's is the same point
SAME_DEM_POINT_M = 1.0


def merge_dem_suggestions(first: DemSuggestions, second: DemSuggestions, max_points: int,
                          camera: Optional[Camera] = None) -> DemSuggestions:
    """``first`` (all of them, in their order), then those of ``second`` farther than :data:`SAME_DEM_POINT_M` from
    every point of ``first``, up to ``max_points`` in all. Scores stay decreasing (``second``'s are capped at
    ``first``'s lowest), ids are renumbered, and ``.uv`` is where ``camera`` (if given) sees each point.

    >>> import numpy as np
    >>> def dem_points(xs, score):
    ...     n = len(xs)
    ...     return DemSuggestions(np.c_[xs, np.zeros(n), np.zeros(n)], np.asarray(score, float),
    ...                           [f"d{i:04d}" for i in range(n)], np.array(["orb"] * n), np.full((n, 2), np.nan),
    ...                           np.full(n, np.nan))
    >>> merged = merge_dem_suggestions(dem_points([0.0, 10.0], [0.9, 0.5]), dem_points([0.2, 30.0, 40.0],
    ...                                [1.0, 0.8, 0.6]), max_points=3)
    >>> merged.xyz[:, 0].tolist(), merged.score.tolist(), merged.ids
    ([0.0, 10.0, 30.0], [0.9, 0.5, 0.5], ['d0000', 'd0001', 'd0002'])
    """
    from scipy.spatial import cKDTree

    extra = np.arange(len(second))
    if len(first) and len(second):
        distance, _ = cKDTree(first.xyz[:, :2]).query(second.xyz[:, :2])
        extra = extra[distance > SAME_DEM_POINT_M]
    extra = extra[:max(0, max_points - len(first))]
    xyz = np.concatenate([first.xyz, second.xyz[extra]]).reshape(-1, 3)
    lowest = float(first.score.min()) if len(first) else np.inf
    score = np.concatenate([first.score, np.minimum(second.score[extra], lowest)])
    uv = (camera.project(xyz) if camera is not None and len(xyz)
          else np.concatenate([first.uv, second.uv[extra]]).reshape(-1, 2))
    prominence = np.concatenate([_prominence(first), _prominence(second)[extra]])
    return DemSuggestions(xyz, score, [f"d{i:04d}" for i in range(len(xyz))],
                          np.concatenate([first.kind, second.kind[extra]]), uv, prominence,
                          max(first.near_clip_m, second.near_clip_m))


def _prominence(points: DemSuggestions) -> np.ndarray:
    return points.prominence if len(points.prominence) == len(points) else np.full(len(points), np.nan)


def suggest(photo: np.ndarray, dem, camera: Optional[Camera], n_photo: int, n_dem: int,
            progress: Optional[Progress] = None, is_canceled: Optional[IsCanceled] = None,
            position_sigma_m: Optional[float] = None,
            rough: Optional[Camera] = None) -> Tuple[PhotoSuggestions, DemSuggestions, bool]:
    """Both sets of suggestions (photo, then DEM), with progress and cancel between them, and whether DEM suggestions
    of the ``rough`` camera were added: when a fitted ``camera`` sees too little terrain for :data:`FEW_DEM_SHARE` of
    ``n_dem`` and the rough camera gives more, the fitted camera's come first and the rough camera's fill up to
    ``n_dem`` (:func:`merge_dem_suggestions`). A summit trial's failed automatic camera, pitched 35° up, left Suggest
    with 0 DEM suggestions and no way on; a flood trial's right one, over a flat valley floor, gave few, and taking
    the rough camera's instead (22° off) threw away the right ones."""
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
            dem_points, from_rough = merge_dem_suggestions(dem_points, from_prior, n_dem, camera), True
    report(0.95, "")
    return photo_points, dem_points, from_rough
