"""The camera fit step: the one on-ground rule and the one call of the core fit, for the dock and Processing.

Shapes: ``uv`` (N, 2) photo pixels, ``xyz`` (M, 3) map coordinates in the DEM's CRS, ``pairs`` (K, 2) indices
(photo row, map row) or None for an unpaired fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np

from ..core.camera import Camera
from ..core.fit import FitOptions, FitResult, fit_camera, sigma_pixels
from ..core.fit.lsq import GROUND_HEIGHT_SIGMA_M
from .height_choice import (DEFAULT_EYE_HEIGHT_M, FREE_HEIGHT_MIN_PAIRS, UNDERGROUND_TOLERANCE_M,  # noqa: F401
                            UNSURE_HEIGHT_M, ground_clearance, height_explained, weigh_eye_height,
                            weigh_free_height)
from .progress import Canceled, IsCanceled, Progress, check_canceled
from .warmup import import_torch

__all__ = ["ON_GROUND_MAX_M", "DEFAULT_EYE_HEIGHT_M", "FitRefused", "FitDone", "ground_clearance",
           "ground_height_sigma", "on_ground_rule", "fit", "point_rmse", "fit_points", "measured_on_pairs",
           "hidden_share", "flag_hidden_points", "sight_within_sigma", "MIN_PAIRS_WITHOUT_PRIOR",
           "start_above_points", "sigma_px"]

#: a start camera at most this high above the terrain is taken as a photographer on the ground (a person, a
#: tripod, a lookout tower, a rooftop): the fit keeps its height above the terrain (z follows the DEM, one unknown
#: less), which also keeps it from ending underground. A higher start keeps z free: drones, aircraft and balloons,
#: and the rough priors whose height is only known to tens of metres (KML from a virtual globe, GPS altitude), whose
#: error the hold would carry into the fit (a 150 m-high drone held at 150 m over other terrain ends 100 m off).
ON_GROUND_MAX_M = 20.0
#: a camera this far under even the lowest terrain within one DEM cell of it stands where no error of the DEM's
#: (a gorge a coarse grid fills) puts a photographer: "poor" (a trial's brick-wall close-up, registered
#: automatically, ended 71 m under a flat valley floor, "uncertain", and its wall was draped on the valley)
DEEP_UNDERGROUND_M = 10.0
#: Shares of the map points a fit used that terrain may hide from its camera before the fit is "uncertain" and
#: "poor" (:func:`flag_hidden_points`): a right camera sees the points it matched, bar a coarse DEM's few.
HIDDEN_DOUBT, HIDDEN_POOR = 0.25, 0.5
#: DEM cells around a camera whose terrain does not hide its points (:func:`hidden_share`): the ground it stands on
STANDING_CELLS = 2.0


class FitRefused(ValueError):
    """The fit refused its input (too few points, ...); the message is the fit's own explanation."""


@dataclass
class FitDone:
    """A finished fit: the core result and how the camera was held (on the ground, at which eye height)."""

    result: FitResult
    on_ground: bool
    eye_height: Optional[float]
    #: the automatic rule held the camera on the ground, and the pairs demanded its height free (FREE_HEIGHT_F)
    height_freed: bool = False
    #: pairs kept out of the fit as its check points (:func:`~.mixed.fit_accepted`), after the given check points
    pairs_checked: int = 0
    #: the status of that unpaired fit when the paired fit was kept over it ("" when none was tried)
    alone_status: str = ""

    @property
    def camera(self) -> Camera:
        return self.result.camera


def ground_height_sigma(camera: Camera, std: Optional[dict], dem) -> Optional[float]:
    """The σ (m) of the height of a camera held on the ground: how far the terrain under it moves when the camera
    moves one σ in X or in Y (``std``), the larger side of each, combined with the σ of its height over the terrain
    (:data:`~..core.fit.lsq.GROUND_HEIGHT_SIGMA_M`, which the X, Y σ already carry). None without both σ or outside
    the DEM.
    Its height is not fitted, so it had no ± of its own: a summit trial's camera, held on the ground 47 m off in Y
    (σ 14 m), stood 37 m low with its Z shown as exact.

    >>> from monoplot_plugin.core.dem import Dem
    >>> ramp = Dem.from_array(np.tile(np.arange(50.0) * 2.0, (50, 1)), (0, 10, 0, 500, 0, -10))  # 0.2 m/m east
    >>> cam = Camera((250.0, 250.0, 51.6), 90.0, 0.0, 0.0, 60.0, (100, 100))
    >>> round(ground_height_sigma(cam, {"x": 20.0, "y": 30.0}, ramp), 2)  # 20 m east: 4 m up; north: flat
    4.01
    >>> ground_height_sigma(cam, {"x": 0.0, "y": 0.0}, ramp)  # X, Y exact: the eye's height over the ground alone
    0.3
    >>> ground_height_sigma(cam, {"x": 20.0}, ramp) is None
    True
    """
    if not std or "x" not in std or "y" not in std:
        return None
    sx, sy = float(std["x"]), float(std["y"])
    if not (math.isfinite(sx) and math.isfinite(sy)):
        return None
    x, y = float(camera.position[0]), float(camera.position[1])
    xs = np.array([x, x - sx, x + sx, x, x])
    ys = np.array([y, y, y, y - sy, y + sy])
    z = np.asarray(dem.sample(xs, ys), dtype=np.float64)
    if not math.isfinite(z[0]):
        return None
    moved = np.abs(z[1:] - z[0])
    along_x = np.nanmax(moved[:2]) if np.isfinite(moved[:2]).any() else 0.0
    along_y = np.nanmax(moved[2:]) if np.isfinite(moved[2:]).any() else 0.0
    return float(math.hypot(along_x, along_y, GROUND_HEIGHT_SIGMA_M))


def on_ground_rule(start: Camera, dem, on_ground: Optional[bool] = None,
                   eye_height: Optional[float] = None) -> Tuple[bool, float]:
    """(on the ground?, eye height in metres) of a fit from ``start``.

    ``on_ground`` None: automatic, a start within :data:`ON_GROUND_MAX_M` of the terrain is on the ground, at
    ``eye_height`` when given, else at its present height above it (:data:`DEFAULT_EYE_HEIGHT_M` under it: a person
    stands on the ground, and a rough camera 0.6 m under a 5 m DEM held a phone camera at 0 m, 164-210 px off, in a
    trial). A start deep under the terrain
    (a rough camera's wrong altitude) is held on the ground too: tried on a generated scene with 8 to 10 unpaired
    points, its height fitted freely ended 120 m up and 250-290 m off, held at 0 m (30 m under the truth) 44 m off.
    True / False: as asked, at ``eye_height`` (default :data:`DEFAULT_EYE_HEIGHT_M`).
    """
    if on_ground is None:
        clearance = ground_clearance(start, dem)
        if math.isfinite(clearance) and clearance < ON_GROUND_MAX_M:
            if eye_height is not None:
                return True, float(eye_height)
            return True, clearance if clearance > 0.0 else DEFAULT_EYE_HEIGHT_M
        return False, DEFAULT_EYE_HEIGHT_M
    return bool(on_ground), DEFAULT_EYE_HEIGHT_M if eye_height is None else float(eye_height)


def fit(uv: np.ndarray, xyz: np.ndarray, start: Camera, dem, pairs=None, on_ground: Optional[bool] = None,
        eye_height: Optional[float] = None, check_uv: Optional[np.ndarray] = None,
        check_xyz: Optional[np.ndarray] = None, progress: Optional[Progress] = None,
        is_canceled: Optional[IsCanceled] = None, free: Optional[Sequence[str]] = None,
        options: Optional[FitOptions] = None) -> FitDone:
    """Fit the camera from ``start`` (core :func:`fit_camera`), held on the ground by :func:`on_ground_rule`.

    Automatic (``on_ground`` None) and free in height, a camera that ends under the terrain (by more than
    :data:`UNDERGROUND_TOLERANCE_M`) is refitted on the ground at ``eye_height`` (default
    :data:`DEFAULT_EYE_HEIGHT_M`), from where the free fit ended.

    ``check_uv`` (C, 2) / ``check_xyz`` (C, 3): paired check points, kept out of the fit and measured.
    ``free``: the parameter names to fit (None: the core's default); ``options``: a core ``FitOptions`` (the prior's
    uncertainty...), None for the defaults.

    Raises:
        FitRefused: the fit refused the input, with the fit's own explanation.
        Canceled: ``is_canceled()`` turned true.
    """
    grounded, eye = on_ground_rule(start, dem, on_ground, eye_height)
    pairs = None if pairs is None or len(pairs) == 0 else np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    if pairs is None:  # the unpaired fit's descent needs torch: its import waited for cancelably
        import_torch(is_canceled, progress)
    has_check = check_uv is not None and len(check_uv) > 0

    def run(from_camera, held, at, report):
        result = fit_camera(uv, xyz, from_camera, pairs=pairs, ground=dem if held else None, eye_height=at,
                            terrain=dem, check_image_points=check_uv if has_check else None,
                            check_world_points=check_xyz if has_check else None, free=free, options=options,
                            progress=report, is_canceled=is_canceled)
        if result.status == "canceled":
            raise Canceled(str(result.message) or "canceled")
        check_canceled(is_canceled)
        if result.status == "refused":
            raise FitRefused(result.message)
        return result

    result = run(start, grounded, eye, progress)
    height_free = free is None or "z" in free
    if on_ground is None and grounded and height_free and pairs is not None and \
            len(pairs) >= FREE_HEIGHT_MIN_PAIRS:
        report = None if progress is None else (
            lambda f, m="": progress(0.5 + 0.5 * f, m or "trying the camera's height free"))
        free_result = run(start, False, eye, report)
        if height_explained(result, free_result, len(pairs)) and \
                ground_clearance(free_result.camera, dem) >= -UNDERGROUND_TOLERANCE_M:
            free_result.message = (
                f"{free_result.message} Height fitted freely: held on the ground the pairs fit at "
                f"{result.rmse_px:.1f} px, free they place the camera "
                f"{ground_clearance(free_result.camera, dem):.0f} m above the terrain at {free_result.rmse_px:.1f} px.")
            flag_hidden_points(free_result, xyz, dem)
            return FitDone(free_result, False, None, height_freed=True)
        weigh_free_height(result, free_result, eye, dem)
    if on_ground is None and not grounded and height_free and \
            ground_clearance(result.camera, dem) < -UNDERGROUND_TOLERANCE_M:
        # A camera cannot stand under the terrain: the points left its height undetermined. Refit as a
        # photographer on the ground, from where the free fit ended.
        report = None if progress is None else (
            lambda f, m="": progress(0.5 + 0.5 * f, m or "camera under the terrain: refitting on the ground"))
        grounded, eye = True, DEFAULT_EYE_HEIGHT_M if eye_height is None else float(eye_height)
        result = run(result.camera, grounded, eye, report)
    elif not grounded:
        flag_under_terrain(result, ground_clearance(result.camera, dem), depth_under_terrain(result.camera, dem))
    if on_ground is None and eye_height is None and grounded and pairs is None and eye > UNSURE_HEIGHT_M:
        # held at the height the rough camera had (a phone's GPS altitude is often 10-30 m off): at eye height too
        report = None if progress is None else (
            lambda f, m="": progress(0.5 + 0.5 * f, m or "trying the camera at eye height"))
        at_eye = run(start, True, DEFAULT_EYE_HEIGHT_M, report)
        result, eye = weigh_eye_height(result, at_eye, eye)
    flag_hidden_points(result, xyz, dem, grounded)
    return FitDone(result, grounded, eye if grounded else None)


def depth_under_terrain(camera: Camera, dem) -> float:
    """How far (m) ``camera`` stands under the lowest terrain within one DEM cell of it (3 x 3 samples a cell
    apart): what no smoothing of a coarse DEM explains; negative above it, NaN outside the DEM.

    >>> from monoplot_plugin.core.dem import Dem
    >>> dem = Dem.from_array(np.array([[100.0, 100.0, 100.0], [100.0, 40.0, 100.0], [100.0, 100.0, 100.0]]),
    ...                      (0, 10, 0, 30, 0, -10))
    >>> round(depth_under_terrain(Camera((15, 15, 20), 0, 0, 0, 60, (10, 10)), dem), 1)  # the pit's floor: 40
    20.0
    """
    x, y, z = (float(v) for v in camera.position)
    step = float(dem.cell_size)
    offsets = np.array([-step, 0.0, step])
    xs, ys = np.meshgrid(x + offsets, y + offsets)
    heights = np.asarray(dem.sample(xs.ravel(), ys.ravel()), dtype=np.float64)
    heights = heights[np.isfinite(heights)]
    return float(heights.min() - z) if len(heights) else float("nan")


def flag_under_terrain(result: FitResult, clearance: float, depth: float = float("nan")) -> None:
    """A camera more than :data:`UNDERGROUND_TOLERANCE_M` under the terrain is no photographer's: say so in
    ``result.message``, and an "ok" becomes "uncertain" (in place). ``depth`` (:func:`depth_under_terrain`) over
    :data:`DEEP_UNDERGROUND_M`: the camera is wrong, "poor"."""
    if math.isfinite(depth) and depth > DEEP_UNDERGROUND_M and result.status in ("ok", "uncertain"):
        result.status = "poor"
        result.message = (f"Probably wrong: the camera ends {max(depth, -clearance):.0f} m under the terrain, under "
                          f"even the lowest ground within a DEM cell of it, where no photo can be taken: check the "
                          f"rough camera, the points and the DEM. {result.message}")
        return
    if not (math.isfinite(clearance) and clearance < -UNDERGROUND_TOLERANCE_M):
        return
    result.message = (f"{result.message} The camera ends {-clearance:.0f} m under the terrain, where no photo "
                      f"can be taken: fit it on the ground (camera height: automatic or on the ground), or check "
                      f"the points and the DEM.")
    if result.status == "ok":
        result.status = "uncertain"


def hidden_share(camera: Camera, xyz: np.ndarray, dem) -> Tuple[int, int]:
    """(how many of the map points ``xyz`` (K, 3) terrain hides from ``camera``, how many were looked at): a line of
    sight that enters the terrain short of its point by more than three DEM cells and 2 % of its length (a coarse
    DEM's grazing slopes, a surveyed height a little under the DEM's, stay seen). The line is looked at from
    :data:`STANDING_CELLS` DEM cells out: nearer, the terrain is the ground the camera stands on, which the DEM
    cannot resolve at that scale (a summit's camera, fitted 5-14 m behind its top on a 25 m DEM, 2 px on 10 pairs,
    had every line of sight enter its own summit 2-4 m away, and was called "poor"); a line under the terrain
    there is hidden (a camera 80 m behind a summit).

    >>> from monoplot_plugin.core.dem import Dem
    >>> dem = Dem.from_array(np.where(np.arange(40)[None, :] == 20, 100.0, 0.0).repeat(40, 0), (0, 10, 0, 400, 0, -10))
    >>> cam = Camera((50.0, 200.0, 10.0), 90.0, 0.0, 0.0, 60.0, (100, 100))
    >>> hidden_share(cam, np.array([[150.0, 200.0, 0.0], [350.0, 200.0, 0.0]]), dem)  # the second behind the wall
    (1, 2)
    """
    from ..core.xyz.sight import segment_first_hit

    xyz = np.asarray(xyz, dtype=float).reshape(-1, 3)
    xyz = xyz[np.isfinite(xyz).all(axis=1)]
    if not len(xyz):
        return 0, 0
    origin = np.asarray(camera.position, dtype=float)
    length = np.linalg.norm(xyz - origin, axis=1)
    out = np.minimum(STANDING_CELLS * dem.cell_size, 0.5 * length)  # metres from the camera
    starts = origin + (xyz - origin) * (out / np.maximum(length, 1e-9))[:, None]
    under = starts[:, 2] < np.nan_to_num(dem.sample(starts[:, 0], starts[:, 1], method="mesh"), nan=-np.inf)
    s = segment_first_hit(dem, starts, xyz)
    short = np.where(np.isfinite(s), (1.0 - s) * (length - out), 0.0)
    hidden = under | (short > np.maximum(3.0 * dem.cell_size, 0.02 * length))
    return int(hidden.sum()), len(xyz)


def flag_hidden_points(result: FitResult, xyz: np.ndarray, dem, on_ground: bool = False) -> None:
    """A camera that cannot see most of the map points it was fitted to stands where no photo of them was taken (a
    trial: a fit from a phone's GPS position slid 117 m back behind the ridge it stood on, distant terrain trading
    that for the field of view; "ok" at 1.9 px, and every XYZ pixel and drawn point fell on the slope in front of
    it). Over :data:`HIDDEN_POOR` of them hidden is "poor", over :data:`HIDDEN_DOUBT` an "ok" becomes "uncertain";
    "uncertain" only, with what to do, when a camera within twice its σ in X and Y (``on_ground``: as high above the
    terrain there) sees them (:func:`sight_within_sigma`). Said in ``result.message`` (in place)."""
    if result.status not in ("ok", "uncertain") or dem is None:
        return
    pairs = np.asarray(result.pairs, dtype=np.int64).reshape(-1, 2)
    if len(pairs) and len(result.inliers) == len(pairs):
        pairs = pairs[np.asarray(result.inliers, dtype=bool)]
    if len(pairs) < 4:
        return
    points = np.asarray(xyz, dtype=float)[pairs[:, 1]]
    hidden, seen = hidden_share(result.camera, points, dem)
    if not seen or hidden <= HIDDEN_DOUBT * seen:
        return
    near = sight_within_sigma(result.camera, result.std, points, dem, on_ground)
    if near is not None:
        result.status = "uncertain"
        result.message = (f"{result.message} Uncertain: terrain hides {hidden} of the {seen} map points it was "
                          f"fitted to from the camera, though it would see them {near:.0f} m away, within twice its "
                          f"σ: its position is loosely known there; give the known position and fix it in Fit "
                          f"settings, or add points on the near ground.")
        return
    text = (f"terrain hides {hidden} of the {seen} map points it was fitted to from the camera: it probably ended "
            f"behind a ridge or a slope, where no photo of them was taken; check its position (give the known "
            f"position and fix it in Fit settings) or the points")
    if hidden > HIDDEN_POOR * seen:
        result.status = "poor"
        result.message = f"{result.message} Probably wrong: {text}."
    else:
        result.status = "uncertain"
        result.message = f"{result.message} Uncertain: {text}."


def sight_within_sigma(camera: Camera, std: dict, xyz: np.ndarray, dem, on_ground: bool) -> Optional[float]:
    """Metres to the nearest camera position, on a grid of -2 to +2 σ in X and in Y (``std``; ``on_ground``: as
    high above the terrain as ``camera``, else as high), from which terrain hides at most :data:`HIDDEN_DOUBT` of
    the (K, 3) map points ``xyz``; None when none does or the σ are unknown. A summit's camera fitted 7-14 m behind
    its top on a 10 m DEM (σ 4-7 m, 2 px on 10 pairs) was "poor", "terrain hides 8 of the 10 map points"; the
    summit 2σ away sees them."""
    sx, sy = float(std.get("x", 0.0) or 0.0), float(std.get("y", 0.0) or 0.0)
    if not (np.isfinite(sx) and np.isfinite(sy)) or max(sx, sy) <= 0.0:
        return None
    x0, y0, z0 = (float(v) for v in camera.position)
    clearance = ground_clearance(camera, dem)
    found = []
    for a in (-2.0, -1.0, 0.0, 1.0, 2.0):
        for b in (-2.0, -1.0, 0.0, 1.0, 2.0):
            x, y = x0 + a * sx, y0 + b * sy
            z = float(dem.sample(x, y)) + clearance if on_ground else z0
            if not np.isfinite(z) or (a == 0.0 and b == 0.0):
                continue
            hidden, seen = hidden_share(camera.with_parameters(x=x, y=y, z=z), xyz, dem)
            if seen and hidden <= HIDDEN_DOUBT * seen:
                found.append(math.hypot(x - x0, y - y0))
    return min(found) if found else None


def sigma_px(result: FitResult, xyz: np.ndarray) -> float:
    """The fit's σ as a pixel error (core :func:`~..core.fit.sigma_pixels`) over the (M, 3) DEM points ``xyz`` it
    matched (its kept pairs' DEM points; all of ``xyz`` when it kept none): what an unpaired fit's products are
    said to be worth (:func:`.features.pixel_error`). NaN without σ."""
    xyz = np.asarray(xyz, dtype=float).reshape(-1, 3)
    pairs = np.asarray(result.pairs).reshape(-1, 2)
    kept = np.asarray(getattr(result, "inliers", np.ones(len(pairs), bool)), dtype=bool).reshape(-1)
    used = np.unique(pairs[kept, 1]) if len(pairs) and kept.shape == (len(pairs),) and kept.any() else None
    points = xyz[used[used < len(xyz)]] if used is not None else xyz
    return sigma_pixels(result.camera, result.std, points if len(points) else xyz)


def measured_on_pairs(camera: Camera, uv: np.ndarray, xyz: np.ndarray) -> Tuple[int, float]:
    """(how many of the pairs, (K, 2) pixels / (K, 3) map points, the camera projects; their RMSE in pixels, NaN
    for none): a camera measured on check points or on pairs it was not fitted to.

    >>> cam = Camera((0, 0, 0), 0, 0, 0, 90, (100, 100))
    >>> world = np.array([[0.0, 10.0, 0.0], [0.0, -10.0, 0.0]])
    >>> measured_on_pairs(cam, np.vstack([cam.project(world[:1]) + [3.0, 4.0], [[0.0, 0.0]]]), world)
    (1, 5.0)
    """
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    xyz = np.asarray(xyz, dtype=float).reshape(-1, 3)
    d = np.hypot(*(camera.project(xyz) - uv).T) if len(uv) else np.zeros(0)
    d = d[np.isfinite(d)]
    return int(len(d)), float(np.sqrt(np.mean(d ** 2))) if len(d) else math.nan


def point_rmse(camera: Camera, uv: np.ndarray, xyz: np.ndarray, paired: bool) -> float:
    """RMS pixel distance from photo points to their (paired) or nearest (unpaired) projected DEM point.

    >>> cam = Camera((0, 0, 0), 0, 0, 0, 90, (100, 100))
    >>> world = np.array([[0.0, 10.0, 0.0]])
    >>> point_rmse(cam, cam.project(world) + [3.0, 4.0], world, paired=True)
    5.0
    """
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


def fit_points(image_size, uv: np.ndarray, xyz: np.ndarray, prior: Camera, dem, paired: bool,
               progress: Optional[Progress] = None, is_canceled: Optional[IsCanceled] = None,
               on_ground: Optional[bool] = None, eye_height: Optional[float] = None,
               check: Optional[np.ndarray] = None, free: Optional[Sequence[str]] = None) -> Tuple[Camera, dict]:
    """:func:`fit` of (N, 2) photo points and (M, 3) DEM points from ``prior``, with the file-based callers'
    conventions (Processing, the batch): ``on_ground`` / ``eye_height`` as in :func:`on_ground_rule` (None:
    automatic, the dock's default too); ``paired`` means row i of ``uv`` and of ``xyz`` are the same point;
    ``check`` (N,) bool marks the paired rows that are check points (a GCP table's ``check`` column): kept out of
    the fit and measured, as in the dock; ``free``: the parameters fitted (None: the core's default); a refusal or
    a prior of another image size is an
    :class:`~.inputs.InputError`. Returns (camera, info) with ``info["rmse_px"]``, ``"status"``, ``"message"``,
    ``"summary"`` (the fit's JSON digest), ``"n_check"``, ``"check_rmse_px"`` (NaN without check points) and
    ``"sigma_px"`` (:func:`sigma_px`)."""
    from .inputs import InputError

    if tuple(image_size) != tuple(prior.image_size):
        raise InputError(f"the prior camera is for a {prior.width}x{prior.height} image, the photo is "
                         f"{image_size[0]}x{image_size[1]}")
    check = np.zeros(len(uv), dtype=bool) if check is None or not paired else np.asarray(check, dtype=bool)
    check_uv, check_xyz = (uv[check], xyz[check]) if check.any() else (None, None)
    uv, xyz = (uv[~check], xyz[~check]) if check.any() else (uv, xyz)
    pairs = np.column_stack([np.arange(len(uv)), np.arange(len(uv))]) if paired else None
    try:
        done = fit(uv, xyz, prior, dem, pairs=pairs, on_ground=on_ground, eye_height=eye_height,
                   check_uv=check_uv, check_xyz=check_xyz, progress=progress, is_canceled=is_canceled, free=free)
    except FitRefused as exc:
        raise InputError(f"the fit refused these points: {exc}") from exc
    result, camera = done.result, done.camera
    rmse = float(result.rmse_px) if np.isfinite(result.rmse_px) else point_rmse(camera, uv, xyz, paired)
    return camera, {"rmse_px": rmse, "status": result.status, "message": result.message,
                    "summary": result.summary(), "n_check": int(check.sum()),
                    "check_rmse_px": float(result.check_rmse_px) if check.any() else float("nan"),
                    "sigma_px": sigma_px(result, xyz), "on_ground": bool(done.on_ground),
                    "eye_height_m": done.eye_height if done.on_ground else None}


#: Paired ground-control points from which a camera is solved with no prior (a direct linear transform needs 6).
MIN_PAIRS_WITHOUT_PRIOR = 6


def start_above_points(xyz: np.ndarray, image_size, crs_wkt: str) -> Camera:
    """A stand-in prior for a paired fit with no prior camera (``fitcamera`` without PRIOR, the dock without a rough
    camera): 1 km above the points' centroid, level, 60° wide (the paired fit starts from its DLT and PnP
    solutions, which do not depend on it; the height keeps the automatic height rule from holding it on the ground).

    >>> start_above_points(np.array([[0.0, 0.0, 100.0], [10.0, 0.0, 300.0]]), (800, 600), "").position
    (5.0, 0.0, 1300.0)
    """
    xyz = np.asarray(xyz, dtype=float).reshape(-1, 3)
    x, y = np.nanmean(xyz[:, :2], axis=0)
    return Camera((float(x), float(y), float(np.nanmax(xyz[:, 2])) + 1000.0), 0.0, 0.0, 0.0, 60.0,
                  tuple(image_size), crs_wkt=crs_wkt)
