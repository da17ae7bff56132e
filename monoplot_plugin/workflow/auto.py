"""The automatic registration step (issue 13): a camera from the photo, the DEM and a rough prior, for the dock and
Processing. One call of :func:`~monoplot_plugin.core.register_automatic`; the progress and cancel conventions of
:mod:`.progress`.

Shapes: ``photo`` (H, W, 3) uint8 RGB; the result's ``image_points`` (N, 2) pixels and ``world_points`` (M, 3) map
coordinates are the points the final fit used (``pairs`` index them), shown to the person as accepted points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..core.auto import AutoFitResult, register_any_heading, register_automatic
from ..core.auto.verdict import EDGE_SCORE_OK
from ..core.auto.heading import UNKNOWN_HEADING_WORDS
from ..core.fit.result import LEAD_MARKER
from ..core.camera import Camera
from .fit import (DEEP_UNDERGROUND_M, ON_GROUND_MAX_M, UNDERGROUND_TOLERANCE_M, depth_under_terrain,
                  flag_under_terrain, ground_clearance, measured_on_pairs, on_ground_rule)
from .progress import Canceled, IsCanceled, Progress, check_canceled, part
from .warmup import import_torch

__all__ = ["AutoDone", "register", "check_height", "DEFAULT_POSITION_SIGMA_M", "GPS_POSITION_SIGMA_M",
           "DEFAULT_ANGLE_SIGMA_DEG", "AUTOMATIC_LABEL", "cap_by_automatic", "rests_on_automatic", "sigma_at_least",
           "judge_by_check_points"]

#: the prior's uncertainty when nothing else says it (a position read off a map or EXIF GPS, a heading guessed)
DEFAULT_POSITION_SIGMA_M = 200.0
#: ... and for a position from a photo's EXIF GPS (a phone's or a drone's: usually within 30 m; the dock's too)
GPS_POSITION_SIGMA_M = 30.0
DEFAULT_ANGLE_SIGMA_DEG = 5.0
#: share of the progress bar the search near the rough heading fills when every direction may follow (that search
#: takes three to four times as long; a quarter left the bar at 22 % when none followed, a re-check trial)
NEAR_SEARCH_SHARE = 0.5
#: label of the points the automatic registration matched (the point table shows it; :func:`cap_by_automatic`
#: reads it)
AUTOMATIC_LABEL = "automatic"
#: statuses from the most to the least trusted
_RANK = {"ok": 0, "uncertain": 1, "poor": 2}


@dataclass
class AutoDone:
    """A finished automatic registration: the core result and the points it matched."""

    result: AutoFitResult

    @property
    def camera(self) -> Camera:
        return self.result.camera

    def matched_points(self):
        """((K, 2) photo pixels, (K, 3) map points) of the inlier pairs of the final fit (the points to show as
        accepted); empty arrays when the fit kept none."""
        r = self.result
        pairs = np.asarray(r.pairs, dtype=np.int64).reshape(-1, 2)
        if len(pairs) and len(r.inliers) == len(pairs):
            pairs = pairs[np.asarray(r.inliers, dtype=bool)]
        if not len(pairs) or not len(r.image_points) or not len(r.world_points):
            return np.zeros((0, 2)), np.zeros((0, 3))
        return r.image_points[pairs[:, 0]], r.world_points[pairs[:, 1]]


def register(photo: np.ndarray, dem, prior: Camera, position_sigma_m: Optional[float] = None,
             angle_sigma_deg: Optional[float] = None, fov_sigma_deg: Optional[float] = None,
             progress: Optional[Progress] = None, is_canceled: Optional[IsCanceled] = None,
             heading_known: bool = True, on_ground: Optional[bool] = None,
             eye_height: Optional[float] = None, every_direction_if_loose: bool = False,
             hold_position: bool = False) -> AutoDone:
    """Register ``photo`` on ``dem`` from ``prior`` with no points given. ``heading_known`` False: the prior's
    heading is a guess (no direction in the photo's EXIF): every direction of view is searched
    (:func:`~monoplot_plugin.core.auto.heading.register_any_heading`, three to four times as long).
    ``every_direction_if_loose``: when the search near the prior's heading ends short of "ok" with the DEM's edges
    fitting the photo's loosely (edge score over :data:`~monoplot_plugin.core.auto.verdict.EDGE_SCORE_OK`), every
    direction is searched too, and the better fit of the edges kept (:func:`_every_direction`).
    ``on_ground``, ``eye_height``: the camera height rule of a fit (:func:`~.fit.on_ground_rule`; None: a rough
    camera within a few metres of the terrain stands on it): a camera on the ground is searched and fitted on it.
    ``hold_position``: the prior's X, Y are known (unticked in the fit settings): the final fit holds them.

    Raises:
        Canceled: ``is_canceled()`` turned true (nothing to keep).
    """
    # torch through the one import thread (cancelable wait; two threads importing torch at once can fail)
    import_torch(is_canceled, progress)
    grounded, eye = on_ground_rule(prior, dem, on_ground, eye_height)
    search = dict(  # the prior's uncertainty and height rule, for the search near its heading and any other
        position_sigma_m=DEFAULT_POSITION_SIGMA_M if position_sigma_m is None else float(position_sigma_m),
        angle_sigma_deg=DEFAULT_ANGLE_SIGMA_DEG if angle_sigma_deg is None else float(angle_sigma_deg),
        fov_sigma_deg=fov_sigma_deg, eye_height_m=eye if grounded else None, hold_position=hold_position,
        is_canceled=is_canceled)
    # one bar over both searches: the one near the rough heading fills its first part, so a search of every
    # direction that follows continues the bar instead of starting it again at 0 %
    wider = every_direction_if_loose and heading_known
    near_end = NEAR_SEARCH_SHARE if wider else 1.0
    result = (register_automatic if heading_known else register_any_heading)(
        photo, dem, prior, progress=part(progress, 0.0, near_end), **search)
    if result.status == "canceled":
        raise Canceled(result.message or "canceled")
    check_canceled(is_canceled)
    ev = result.evidence or {}
    # not for a photo whose edges match nothing (fog, a blank frame): any direction would fit its chance edges
    if wider and result.status != "ok" and _edge_score(result) > EDGE_SCORE_OK \
            and ev.get("auto_skyline_usable") and not ev.get("auto_no_edges"):
        result = _every_direction(result, photo, dem, prior, search, part(progress, near_end, 1.0))
    check_height(result, prior, dem)
    return AutoDone(result)


def _edge_score(result) -> float:
    return float((result.evidence or {}).get("auto_edge_score", math.inf))


def _every_direction(near: AutoFitResult, photo, dem, prior: Camera, search: dict, progress) -> AutoFitResult:
    """The search over every direction after one near the prior's heading fitted the edges loosely; the result
    whose edges fit better, its message saying what was done. A trial's rough camera turned 183° away from the
    view: "uncertain", 195° off; searched every direction, 0.05° off (Processing's ANY_HEADING, which the dock did
    not offer)."""
    def report(fraction, message=""):
        if progress is not None:
            progress(fraction, "searching every direction: " + message if message else "")

    report(0.0, "the view found fits the photo's edges loosely")
    wide = register_any_heading(photo, dem, prior, progress=report, **search)
    if wide.status == "canceled":
        raise Canceled(wide.message or "canceled")
    check_canceled(search["is_canceled"])
    turn = (wide.camera.heading - prior.heading + 180.0) % 360.0 - 180.0
    if _edge_score(wide) < _edge_score(near):
        # the sweep's own words begin "The direction of view was not known": the rough camera gave one (a trial)
        swept = wide.message.replace(UNKNOWN_HEADING_WORDS, "", 1)
        wide.message = (f"{LEAD_MARKER} near the rough camera's heading the DEM's edges fitted the photo's "
                        f"loosely (edge score {_edge_score(near):.3f}); this view, {abs(turn):.0f}° to the "
                        f"{'right' if turn > 0 else 'left'} of it, fits them better ({_edge_score(wide):.3f}). "
                        + swept[:1].upper() + swept[1:])
        return wide
    near.message = (f"{near.message} Every direction was searched too: no view fitted the photo's edges better.")
    return near


def check_height(result, prior: Camera, dem) -> None:
    """The fit's rule on the camera's height, for a camera found with no points (in place): under the terrain it is
    no photographer's; from a rough camera standing on the ground (:func:`~.fit.on_ground_rule`), one that ends far
    above or under it has moved where the person said it was not. Either makes an "ok" "uncertain", and the message
    says so."""
    clearance, depth = ground_clearance(result.camera, dem), depth_under_terrain(result.camera, dem)
    if math.isfinite(depth) and depth > DEEP_UNDERGROUND_M:  # wrong, whatever the rough camera stood on
        flag_under_terrain(result, clearance, depth)
        return
    grounded, eye = on_ground_rule(prior, dem)
    said = ""
    if grounded and math.isfinite(clearance) and abs(clearance - eye) > ON_GROUND_MAX_M:
        said = (f"The camera found is {clearance:.0f} m above the terrain, but the rough camera stood on the ground "
                f"({eye:.0f} m): check it, or fit it on points with the camera held on the ground (the dock's Fit "
                f"settings, or fitcamera's Camera height).")
    elif grounded and math.isfinite(clearance) and clearance < -UNDERGROUND_TOLERANCE_M:
        # the registration itself never holds a camera on the ground: say what does (a trial's phone photo was told
        # to set "camera height: automatic", which it already was)
        said = (f"The camera found is {-clearance:.0f} m under the terrain; the rough camera stood on the ground, "
                f"where a fit on the matched points holds it (camera height automatic or on the ground, in the dock's "
                f"Fit settings or fitcamera's Camera height).")
    if said:
        result.message = f"{result.message} {said}"
        if result.status == "ok":
            result.status = "uncertain"
        return
    flag_under_terrain(result, clearance)


def cap_by_automatic(status: str, message: str, labels, n_pairs: int, n_check: int, automatic_status: str):
    """(status, message) of a fit capped by the automatic registration's verdict while it rests on the points the
    registration matched itself (``labels``: of the photo and map points fitted; see :func:`rests_on_automatic`).

    Those points were drawn near the registration's own camera: they agree with it whether it is right or wrong, so
    a fit on them says "ok" with a small RMSE and σ whatever the truth (seen in the desktop on Aletsch: the
    registration "uncertain" 27.8 px off, the Fit on its points "ok", σ 6 m; a trial's print: the registration
    "uncertain", its 157 + 157 matches and 5 points of the person's own fitted "ok", σ 1.6 px, the camera 588 m off).
    A pair or a check point lifts the cap, and so do points of the person's own once they are the majority.

    >>> cap_by_automatic("ok", "RMSE 1.5 px.", ["automatic"] * 4, 0, 0, "uncertain")[0]
    'uncertain'
    >>> cap_by_automatic("ok", "RMSE 1.5 px.", ["automatic"] * 9 + [""], 0, 0, "uncertain")[0]
    'uncertain'
    >>> cap_by_automatic("ok", "RMSE 1.5 px.", ["automatic", ""], 0, 0, "uncertain")[0]
    'ok'
    >>> cap_by_automatic("ok", "RMSE 1.5 px.", ["automatic"] * 4, 3, 0, "uncertain")[0]
    'ok'

    A fit already "uncertain" on its own still says it rests on the registration's points (a trial's Fit after
    Find camera said only that the near ground within 10 m was loose, the camera 148 m off):

    >>> cap_by_automatic("uncertain", "Near ground loose.", ["automatic"] * 4, 0, 0, "uncertain")[1][:46]
    'Near ground loose. Uncertain, as the automatic'
    """
    labels = list(labels)
    if _RANK.get(automatic_status, 0) < _RANK.get(status, 0) or automatic_status not in _RANK \
            or automatic_status == "ok" or not rests_on_automatic(labels, n_pairs, n_check):
        return status, message
    n_auto = sum(1 for label in labels if label == AUTOMATIC_LABEL)
    which = ("every point fitted is one it matched" if n_auto == len(labels) else
             f"{n_auto} of the {len(labels)} points fitted are ones it matched")
    return automatic_status, (f"{message} {automatic_status.capitalize()}, as the automatic registration was: "
                              f"{which} near its own camera, so they agree with that camera whether it is right or "
                              "not, and its σ are no smaller than the registration's. Pair a few points you recognise, "
                              "or mark check points, to confirm it (or reject its points and fit on your own).")


def rests_on_automatic(labels, n_pairs: int, n_check: int) -> bool:
    """True when most points fitted (``labels``, photo and map together) are ones the automatic registration matched
    and there is no pair or check point: a fit that then has little evidence of its own beyond the registration's
    (a few points of the person's own among a hundred matches cannot pull the camera anywhere: each finds a match).

    >>> rests_on_automatic(["automatic"] * 3, 0, 0), rests_on_automatic(["automatic", ""], 0, 0)
    (True, False)
    >>> rests_on_automatic(["automatic"] * 3 + [""], 0, 0), rests_on_automatic(["automatic"] * 3, 0, 2)
    (True, False)
    """
    labels = list(labels)
    n_auto = sum(1 for label in labels if label == AUTOMATIC_LABEL)
    return bool(labels) and not n_pairs and not n_check and n_auto > len(labels) / 2


def sigma_at_least(sigma: Optional[dict], floor: Optional[dict]) -> dict:
    """Each parameter's σ at least ``floor``'s: a fit on the registration's own points knows its camera no better
    than the registration did (their agreement with it says nothing new), however small its own σ.

    >>> sigma_at_least({"x": 0.5, "heading": 0.01}, {"x": 120.0, "heading": 0.3, "fov": 1.0})
    {'x': 120.0, 'heading': 0.3, 'fov': 1.0}
    """
    out = {k: float(v) for k, v in (sigma or {}).items()}
    for k, v in (floor or {}).items():
        if v is not None and math.isfinite(float(v)):
            out[k] = max(out.get(k, 0.0), float(v))
    return out


def judge_by_check_points(status: str, message: str, camera: Camera, check_uv: np.ndarray,
                          check_xyz: np.ndarray, rmse_px: float = float("nan"), paired: bool = False) -> dict:
    """The automatic camera measured by the person's check points (``check_uv`` (K, 2) pixels, ``check_xyz``
    (K, 3) map points, kept out of the registration): {"status", "message", "check_rmse_px", "n_check"}.

    The check points can only lower the registration's status (a run after a fit the check points called "poor"
    came back "uncertain" with the same camera, the check points ignored): "poor" or "uncertain" by the same rule
    as a camera loaded from a file (:func:`~..core.fit.check_points.judge_by_checks`), with the camera's own residuals
    ``rmse_px`` (pixels, the automatic registration's matched pairs) when it has some; ``paired``: those of a
    paired fit (every pair's).

    >>> from monoplot_plugin.core.camera import Camera
    >>> cam = Camera((0.0, 0.0, 100.0), 0.0, 0.0, 0.0, 60.0, (1000, 750))
    >>> xyz = np.array([[x, 2000.0, z] for x in (-300.0, 0.0, 300.0) for z in (0.0, 200.0)])
    >>> judge_by_check_points("uncertain", "m.", cam, cam.project(xyz) + 40.0, xyz)["status"]
    'poor'
    >>> judge_by_check_points("uncertain", "m.", cam, cam.project(xyz), xyz)["status"]
    'uncertain'
    >>> judge_by_check_points("ok", "m.", cam, cam.project(xyz[:2]) + 1.0, xyz[:2])["status"]  # 2 agree: not lowered
    'ok'
    """
    from ..core.fit.check_points import WEAK_SHARE, checks_beyond_residuals, judge_by_checks

    n_given = len(np.asarray(check_uv).reshape(-1, 2))
    out = {"status": status, "message": message, "check_rmse_px": None, "n_check": n_given}
    if not n_given:
        return out
    n, rmse = measured_on_pairs(camera, check_uv, check_xyz)
    diag = math.hypot(*camera.image_size)
    checked, text = judge_by_checks(rmse, n, diag, rmse_px, paired)
    out["check_rmse_px"] = rmse if math.isfinite(rmse) else None
    # (agreeing means within 1.5 % of the picture and within a few times the camera's own residuals)
    agree = rmse <= WEAK_SHARE * diag and not checks_beyond_residuals(rmse, rmse_px, diag, paired)
    if checked == "uncertain" and n and agree:
        # they agree, only too few to verify the camera alone: that lowers nothing its own evidence verified (a
        # trial: 2 check points at 0.9 px made an "ok" fit "uncertain" when imported after it, and left it "ok"
        # when imported before it, as a fit judges them)
        checked, text = status, f"Check points: {rmse:.1f} px on {n}."
    out["message"] = f"{message} {text}"
    if _RANK.get(checked, 1) > _RANK.get(status, 0):
        out["status"] = checked
    return out
