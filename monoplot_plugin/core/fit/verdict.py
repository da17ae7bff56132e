"""The verdict: "ok" only when the evidence says so.

Statuses (:data:`~monoplot_plugin.core.fit.result.STATUSES`):

- ``ok``: enough well-spread inliers, far more than a wrongly placed camera gets by chance, no competing camera
  explains the points nearly as well, small residuals (and check points agree, when given).
- ``uncertain``: a camera was fitted but some evidence is weak (the message says which and what to do).
- ``poor``: the camera is probably wrong (few inliers, not better than chance, large residuals or check points).
- ``refused``: degenerate input (duplicated or collinear points, parameters the points cannot determine).

The evidence is a plain dict (:func:`judge` documents its keys) kept in :attr:`FitResult.evidence`, so the dock,
Processing and the report show the same figures.

>>> judge({"mode": "paired", "n_free": 7, "n_pairs": 11, "rmse_px": 2.0, "diag": 1000.0})[0]
'ok'
>>> judge({"mode": "paired", "n_free": 7, "n_pairs": 11, "rmse_px": 20.0, "diag": 1000.0})[0]
'uncertain'
>>> judge({"mode": "paired", "n_free": 7, "n_pairs": 11, "rmse_px": 80.0, "diag": 1000.0})[0]
'poor'
>>> judge({"mode": "paired", "n_free": 7, "n_pairs": 10, "rmse_px": 2.0, "diag": 1000.0, "spread": 0.014})[1]
'paired fit on 10 pairs: RMSE 2.0 px (too few pairs for a leave-one-out check). Uncertain: the pairs cover a small \
part of the picture (1.4 %): elsewhere the camera is extrapolated; add pairs spread over the picture.'
>>> judge({"mode": "paired", "n_free": 7, "n_pairs": 4, "rmse_px": 0.1, "diag": 1000.0})[1].split("Uncertain: ")[1]
'4 pairs for 7 free parameters leave 1 equation to spare, too few to test the camera (no pair can be left out): \
pair 2 more points, mark check points, or fix the parameters you know.'
>>> judge({"mode": "paired", "n_free": 6, "n_pairs": 4, "rmse_px": 0.1, "diag": 1000.0})[1].split(": pair ")[1][:13]
'1 more point,'
>>> judge({"mode": "paired", "n_free": 7, "n_pairs": 12, "rmse_px": float("nan"), "diag": 1000.0})[1][:72]
'paired fit on 12 pairs: no camera found puts the points in front of it. '
>>> judge({"mode": "paired", "n_free": 7, "n_pairs": 11, "rmse_px": 2.0, "diag": 1000.0, "check_rmse_px": 12.0,
...        "n_check": 10})[0]
'uncertain'
>>> judge({"mode": "paired", "n_free": 7, "n_pairs": 11, "rmse_px": 2.0, "diag": 1000.0, "check_rmse_px": 25.0,
...        "n_check": 8})[0]
'poor'
"""

from __future__ import annotations

import math
from typing import Tuple

import numpy as np

from .check_points import CHECK_OVER_RESIDUALS, MIN_CHECKS, POOR_SHARE, WEAK_SHARE, checks_beyond_residuals
from .lens import lens_text
from .near_ground import FIT_CONSEQUENCE, HELD_CONSEQUENCE, loose_ground_text
from .result import worst_check_words

__all__ = ["degenerate_points", "weakest_parameter", "weak_direction_matters", "judge", "outlier_note",
           "photo_spread", "pairs_wanted", "POOR_SHARE", "WEAK_SHARE", "MIN_CHECKS"]

#: Why few of the fewer side's points match, and what to do (the automatic registration words it for its own points,
#: which nobody accepted). Unpaired, a right point may simply have no accepted counterpart in the other view: a trial
#: accepted 85 right photo points of which only 37 had one, and "reject the flagged points" would have lost 32 right
#: ones.
FEWER_SIDE_CAUSES = ("many accepted points have no accepted counterpart in the other view, or are wrong, or the "
                     "camera is")
FEWER_SIDE_ADVICE = ("look at the flagged points: reject the wrong ones, accept the counterparts of the right ones, "
                     "and fit again")
#: a clearly different camera whose score is at least this share of the fit's makes it uncertain (the search's
#: competitors, ``competitor_ratio``, and the stability probes' rivals, ``rival_ratio``)
COMPETITOR_RATIO = 0.8
#: least convex-hull share of the picture (:func:`photo_spread`) of the matched points of an unpaired fit, and of
#: the pairs of a paired fit with position or field of view free, for an "ok". Pairs: a desktop trial's 10 exact
#: pairs over 6.5 % of the picture were "ok" at 1.9 px RMSE with the camera 256 m off (187 px across the picture);
#: each of the 100 real sets of ``eval.smapshot`` covers at least 10.5 % (median 35 %).
MIN_SPREAD, MIN_SPREAD_PAIRED = 0.05, 0.10
#: a paired fit with fewer equations to spare than this (2 x pairs - free parameters) is at most "uncertain": no
#: pair can be left out (the rest would leave nothing to spare), and its residuals cannot show a wrong camera; the
#: advice asks for enough pairs to leave FEW_SPARE_TARGET spare
MIN_SPARE, FEW_SPARE_TARGET = 3, 4
#: pairs beyond the inlier radius (within twice it, more than chance adds) above this share of the inliers: the
#: residuals are truncated by the radius, which makes an unpaired fit uncertain when converging on the pairs within
#: twice the radius moves the camera (see :func:`judge`, ``beyond_radius`` and ``truncation_px``)
TRUNCATED_SHARE = 0.25
#: σ of the camera's slide along lines of DEM points (:mod:`~monoplot_plugin.core.fit.aperture`) above this share of
#: the picture's diagonal makes an unpaired fit uncertain. Generated DEM points on two parallel lines seen from a
#: drone: 2.3-4 % (the camera 230-380 px off, "ok" before); the synthetic suite's "ok" fits: at most 0.063 %
#: (median 0.008 %, 2026-12-05).
SLIDE_SHARE = 0.005


def degenerate_points(q: np.ndarray, world: np.ndarray, needed: int) -> str:
    """Empty string, or why (K, 2) photo points paired with (K, 3) DEM points cannot fix a camera: fewer than
    ``needed`` distinct points on either side, or all on one line.

    >>> q = np.array([[10.0, 10]] * 11); w = np.array([[0.0, 500, 10]] * 11)
    >>> degenerate_points(q, w, 4).split(":")[0]
    'The 11 pairs hold only 1 distinct photo point and 1 distinct DEM point'
    >>> t = np.linspace(0, 1, 8)[:, None]
    >>> degenerate_points(np.hstack([t * 500, t * 300]), np.hstack([t * 900, t * 50 + 1000, t * 20]), 4)[:38]
    'The 8 photo points lie on a straight l'
    """
    k = len(q)
    scale_q = max(1.0, float(np.ptp(q, axis=0).max())) if k else 1.0
    scale_w = max(1.0, float(np.ptp(world, axis=0).max())) if k else 1.0
    distinct_q = len(np.unique(np.round(q / (1e-6 * scale_q)), axis=0)) if k else 0
    distinct_w = len(np.unique(np.round(world / (1e-6 * scale_w)), axis=0)) if k else 0
    if min(distinct_q, distinct_w) < needed:
        return (f"The {k} pairs hold only {distinct_q} distinct photo point{'s' if distinct_q != 1 else ''} and "
                f"{distinct_w} distinct DEM point{'s' if distinct_w != 1 else ''}: a camera needs at least "
                f"{needed} different points on each side. Remove the duplicates and add points.")
    if k >= 3:
        sq = np.linalg.svd(q - q.mean(axis=0), compute_uv=False)
        if sq[1] <= 1e-3 * sq[0]:
            return (f"The {k} photo points lie on a straight line: the camera could turn about it. Add points off "
                    f"that line (spread over the picture).")
        sw = np.linalg.svd(world - world.mean(axis=0), compute_uv=False)
        if sw[1] <= 1e-3 * sw[0]:
            return (f"The {k} DEM points lie on a straight line: the camera could turn about it. Add points off "
                    f"that line.")
    return ""


def weakest_parameter(J: np.ndarray, names, scales) -> Tuple[float, str]:
    """(condition number of the scaled Jacobian, name of the parameter with the largest share of its weakest
    direction). ``J`` is (2K, n) in the parameter vector's units."""
    if J.size == 0 or J.shape[0] < J.shape[1]:
        return math.inf, names[0] if names else ""
    bad = ~np.isfinite(J).all(axis=0)
    if bad.any():  # a point on the camera's plane (a wrong pair can drag the camera there): nothing to measure
        return math.inf, names[int(np.argmax(bad))]
    norms = np.linalg.norm(J, axis=0)
    norms[norms == 0] = 1.0
    _, s, vt = np.linalg.svd(J / norms, full_matrices=False)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    return cond, names[int(np.argmax(np.abs(vt[-1])))]


def weak_direction_matters(camera, weakest: str) -> bool:
    """False when the weakest direction is only the angles' own redundancy: looking nearly straight up or down,
    heading and roll turn about the same axis, so the points cannot tell them apart but the camera is the same."""
    return not (abs(camera.pitch) > 80.0 and weakest in ("heading", "roll"))


def photo_spread(q: np.ndarray, image_size) -> float:
    """Convex-hull area of the photo points as a share of the picture (0 for fewer than 3 or collinear points).

    >>> round(photo_spread(np.array([[0.0, 0], [100, 0], [0, 100]]), (100, 100)), 6)
    0.5
    """
    if len(q) < 3:
        return 0.0
    from scipy.spatial import ConvexHull, QhullError

    try:
        area = ConvexHull(q).volume  # in 2-D, "volume" is the area
    except (QhullError, ValueError):
        return 0.0
    return float(area / (image_size[0] * image_size[1]))


def judge(e: dict) -> Tuple[str, str]:
    """(status, message) from the evidence ``e``.

    Keys (missing ones are not judged): ``mode`` ("paired"/"unpaired"), ``n_free``, ``diag`` (px),
    ``n_pairs`` (pairs used), ``rmse_px``, ``loo_rmse_px``, ``check_rmse_px`` and ``n_check`` (independent check
    points), ``condition`` and ``weakest`` (Jacobian), and for unpaired fits ``n_photo`` (photo points given),
    ``n_inliers`` (mutual-nearest pairs within ``radius_px``), ``n_dem`` (DEM points given), ``chance_max`` /
    ``chance_mean`` (the same score for cameras turned away, see
    :func:`~monoplot_plugin.core.fit.consensus.chance_inliers`), ``score`` (the fit's consensus score),
    ``competitor_ratio`` (best distinct competing camera's score / ``score``), ``photo_outliers`` (accepted
    photo points that fit no DEM point), ``rival_px`` / ``rival_m`` (a
    camera the stability probes reached that moves the inliers by more than the fit's precision: how far, RMS in
    pixels, and its distance in metres; 0 for none, see :mod:`~monoplot_plugin.core.fit.stability`), ``rival_ratio``
    (its net score / the fit's),
    ``beyond_radius`` (mutual-nearest pairs within twice the radius but not within it, less what chance adds),
    ``truncation_px`` (how far the camera converged on the pairs within twice the radius moves the inliers, RMS),
    ``precision_px`` (the pixel σ of the inliers' projections under the fit's covariance), ``slide_px`` (σ of the
    camera sliding along lines of DEM points, :mod:`~monoplot_plugin.core.fit.aperture`); for both modes
    ``spread`` (convex-hull share of the picture of the pairs or matched points, :func:`photo_spread`).

    >>> e = {"mode": "unpaired", "n_free": 7, "diag": 2000.0, "rmse_px": 3.0, "n_photo": 40, "n_dem": 30,
    ...      "n_inliers": 25, "radius_px": 20.0, "score": 20.0, "chance_max": 1.0, "spread": 0.4}
    >>> rival = dict(e, rival_px=9.0, rival_m=480.0, rival_ratio=0.9)
    >>> judge(e)[0], judge(rival)[0], judge(dict(e, beyond_radius=12.0, truncation_px=9.0))[0]
    ('ok', 'uncertain', 'uncertain')
    >>> few = dict(e, spread=0.01, check_rmse_px=0.4, n_check=3, has_check=True)
    >>> judge(few)[0], judge(few)[1].split("; ")[-1][:56]
    ('uncertain', 'the 3 check points are off by 0.4 px, under 1.5 % of the')
    >>> judge(dict(few, n_check=4))[0]
    'ok'
    >>> judge(rival)[1].split("Uncertain: ")[1][:60]
    'two cameras 480 m apart explain your points about equally we'
    >>> judge(dict(rival, rival_m=2.0))[1].split("Uncertain: ")[1][:60]
    'two cameras at nearly the same place, turned differently, ex'
    """
    diag = float(e.get("diag", 1000.0))
    n_free = int(e.get("n_free", 7))
    rmse = float(e.get("rmse_px", math.nan))
    poor, weak = [], []
    if e.get("mode") == "paired":
        text = f"paired fit on {e.get('n_pairs', 0)} pairs: RMSE {rmse:.1f} px"
    else:
        text = (f"unpaired fit: {e.get('n_inliers', 0)} of {e.get('n_photo', 0)} photo points matched a DEM point "
                f"within {e.get('radius_px', 0):.0f} px, RMSE {rmse:.1f} px")
    loo = float(e.get("loo_rmse_px", math.nan))
    if not np.isfinite(rmse):  # no camera put the points in front of it ("RMSE nan px (too few pairs for a
        # leave-one-out check)" with 12 pairs whose heights were in feet, a trial)
        text = text.split(": RMSE")[0].split(", RMSE")[0] + ": no camera found puts the points in front of it"
    elif np.isfinite(loo):
        text += f", leave-one-out {loo:.1f} px"
    else:
        text += " (too few pairs for a leave-one-out check)"
    check = float(e.get("check_rmse_px", math.nan))
    if np.isfinite(check):
        text += f"; check points {check:.1f} px"
    text += "."
    suspect = suspect_pair_text(e)
    if not np.isfinite(rmse):
        poor.append("the points fit no camera: check the pairs (a wrong link?), the points' heights and their unit, "
                    "and the free parameters" + suspect)
    elif rmse > POOR_SHARE * diag:
        poor.append("the residuals are large: check the pairs (a wrong link?) or the free parameters" + suspect)
    elif e.get("mode") == "paired" and rmse > WEAK_SHARE * diag:
        # pairs a person placed err by a few pixels: residuals over 1.5 % of the picture mean a wrong pair or a
        # held parameter that is wrong (a desktop trial: a camera held on the ground 30 m under where it stood,
        # "ok" at 36.8 px, 2.6 % of the picture, 37 m off)
        weak.append(f"the residuals are large ({100 * rmse / diag:.1f} % of the picture's diagonal): look for a "
                    f"wrong pair, or free a held parameter (a camera held on the ground: let it be in the air)"
                    + suspect)
    elif e.get("mode") == "paired" and suspect:
        # one pair the others cannot place: a wrong point or surveyed height pulls the camera while the RMSE over
        # all pairs stays small (generated: one height 60 m off of 12 pairs, "ok" at 10.3 px, the camera 27 m off)
        weak.append("one pair disagrees with the others" + suspect)
    spare = 2 * int(e.get("n_pairs", 0)) - n_free
    more = pairs_wanted(int(e.get("n_pairs", 0)), n_free)
    if e.get("mode") == "paired" and np.isfinite(rmse) and more:
        # the residuals of as many equations as unknowns (and one) are near zero whatever the camera: generated
        # scenes, 4 noisy pairs for 7 parameters: 24 of 100 fits "ok", 13 of them over 1.5 times the error of the
        # scene's best camera off, 5 over twice it (5-660 px)
        weak.append(f"{e.get('n_pairs', 0)} pairs for {n_free} free parameters leave {max(spare, 0)} equation"
                    f"{'s' if spare != 1 else ''} to spare, too few to test the camera (no pair can be left out): "
                    f"pair {more} more point{'s' if more != 1 else ''}, mark check points, or fix the parameters "
                    f"you know")
    # Check points far worse than the fit's own residuals: the residuals flatter the camera (pairs that agree with
    # each other, not with the terrain), whatever the share of the picture.
    check_far = checks_beyond_residuals(check, rmse, diag, e.get("mode") == "paired")
    named = worst_check_words(e)
    if np.isfinite(check) and check > POOR_SHARE * diag:
        poor.append("the independent check points disagree with the camera" + named)
    elif np.isfinite(check) and check > WEAK_SHARE * diag and check_far:
        # off by more than 1.5 % of the picture AND several times the fit's own residuals: the independent evidence
        # contradicts a camera its pairs agree on (a generated scene: check points 27.6 px, residuals 2 px, the
        # camera 185 m off, was "uncertain")
        poor.append(f"the independent check points are off by {check:.1f} px, {check / max(rmse, 1.0):.0f} times "
                    f"the fit's residuals{named}")
    elif np.isfinite(check) and check > WEAK_SHARE * diag:
        weak.append("the check points are off by more than 1.5 % of the picture" + named)
    if check_far and not poor and check <= WEAK_SHARE * diag:
        # paired: few pairs bend to fit a wrong one (a drone trial's GCP 2 m too high, 5 pairs: its residual 0.9 px)
        wrong_pair = ", or a pair's map position or height is wrong (the camera bends to fit it)" \
            if e.get("mode") == "paired" else ""
        weak.append(f"the check points are off by {check:.1f} px, {check / max(rmse, 1.0):.0f} times the fit's "
                    f"residuals: the camera is less accurate than its residuals say; add points near the check "
                    f"points or pair a few{wrong_pair}{named}")
    cond = float(e.get("condition", 1.0))
    if cond > 1e6:
        weak.append(f"the points barely determine {e.get('weakest', 'a parameter')}: fix it or add points that "
                    f"constrain it")
    if np.isfinite(loo) and np.isfinite(rmse) and loo > 3.0 * max(rmse, 1.0) and loo > 0.01 * diag:
        weak.append("leaving one pair out changes the prediction a lot: add points")
    spread = float(e.get("spread", 1.0))
    if spread < (MIN_SPREAD if e.get("mode") != "paired" else MIN_SPREAD_PAIRED if n_free > 3 else 0.0):
        # a cluster fixes the camera only where it is: elsewhere position, angles and field of view trade off (a
        # generated scene: 10 exact pairs over 1.4 % of the picture, "ok" at 2 px RMSE, the camera 115 m and 1.9 deg
        # off, 190 px across the picture). The three angles alone (position and field of view known) have no such
        # trade-off: a few pairs anywhere fix them.
        which = "pairs" if e.get("mode") == "paired" else "matched points"
        weak.append(f"the {which} cover a small part of the picture ({100 * spread:.1f} %): elsewhere the camera is "
                    f"extrapolated; add {'pairs' if which == 'pairs' else 'points'} spread over the picture")
    loose = loose_ground_text(e, FIT_CONSEQUENCE if e.get("position_free", True) else HELD_CONSEQUENCE)
    if loose:
        weak.append(loose)
    lens = lens_text(e)
    if lens:
        weak.append(lens)
    if e.get("mode") == "unpaired":
        n_in = int(e.get("n_inliers", 0))
        chance = float(e.get("chance_max", 0.0))
        score = float(e.get("score", 0.0))
        needed = n_free // 2 + 2
        if n_in < needed:
            poor.append(f"only {n_in} photo points match a DEM point ({needed} at least are needed)")
        elif score <= chance + 1.0:
            poor.append("a camera turned well away matches as many points: the match is a coincidence")
        else:
            if score < 1.5 * chance + 2.0 or n_in < 2 * n_free:
                weak.append("few points match compared with what a wrongly placed camera gets by chance: accept "
                            "more points on recognisable features, or pair a few")
            n_photo, n_dem = int(e.get("n_photo", 0)), int(e.get("n_dem", 0))
            smaller, which = (n_photo, "photo") if n_photo <= n_dem else (n_dem, "DEM")
            if smaller and n_in < 0.4 * smaller:
                weak.append(f"only {n_in} of the {smaller} {which} points (the fewer side) match a partner: "
                            f"{FEWER_SIDE_CAUSES}; {FEWER_SIDE_ADVICE}")
            ratio = float(e.get("competitor_ratio", 0.0))
            if ratio >= COMPETITOR_RATIO:
                weak.append("another camera, clearly different, explains the points almost as well: add two paired "
                            "points or check points")
            if float(e.get("rival_ratio", 0.0)) >= COMPETITOR_RATIO and ratio < COMPETITOR_RATIO:
                metres = float(e.get("rival_m", 0.0))
                where = f"{metres:.0f} m apart" if metres >= 10.0 else "at nearly the same place, turned differently,"
                weak.append(f"two cameras {where} explain your points about equally well (they place the matched "
                            f"points {float(e.get('rival_px', 0.0)):.0f} px apart): add two paired points or check "
                            f"points")
            slide = float(e.get("slide_px", 0.0))
            if slide > SLIDE_SHARE * diag:
                weak.append(f"the matched DEM points lie along lines, and the camera can slide along them by about "
                            f"{min(slide, diag):.0f} px (1 σ) with the same residuals: add points off those lines "
                            f"(summits, junctions, corners) or pair a few")
            beyond = float(e.get("beyond_radius", 0.0))
            moved = float(e.get("truncation_px", 0.0))
            if beyond > TRUNCATED_SHARE * n_in and moved > max(2.0, 3.0 * float(e.get("precision_px", 0.0))):
                weak.append(f"{beyond:.0f} more photo points lie just beyond the {float(e.get('radius_px', 0)):.0f} "
                            f"px matching radius than chance explains, and counting them moves the camera by "
                            f"{moved:.0f} px: the points or the DEM (a coarse one?) err by about the radius; add "
                            f"paired or check points, or use a finer DEM")
        if not e.get("has_check", False) and not poor:
            text += " The residuals measure how well the automatic pairs agree: check points measure accuracy."
    # Independent check points that agree outweigh weak matching evidence: they measure the camera itself.
    checked_ok = (np.isfinite(check) and check <= WEAK_SHARE * diag and not check_far
                  and int(e.get("n_check", 0)) >= MIN_CHECKS)
    if checked_ok and not poor and weak:
        # ... except loose near ground that no check point is on: summits 4-7 km away verified a trial's flood camera
        # "despite" its near-ground warning, the camera 6 m off and the ground within 300 m 1000 px off
        unverified = [w for w in weak if w == loose and not check_reaches_loose_ground(e)]
        # ... and a pair the others cannot place: it pulls the camera where the check points do not look (an
        # archivist's GCP 400 m off: 3 check points at 5.3 px, the camera 108 m off, the ground 53 m off in places)
        unverified += [w for w in weak if suspect and w.endswith(suspect)]
        verified = [w for w in weak if w not in unverified]
        if verified:
            text += " Verified by the check points despite: " + "; ".join(verified) + "."
        weak = [w + (f" (the check points, the nearest {float(e['check_nearest_m']):.0f} m away, do not reach that "
                     f"ground: a check point on it would verify it)" if np.isfinite(e.get("check_nearest_m", np.nan))
                     else "") for w in unverified]
    elif weak and not poor and np.isfinite(check) and check <= WEAK_SHARE * diag and not check_far:
        # too few to verify: say how close it is (a trial marked 3 good pairs as check points, as advised, and a
        # fit "ok" with them as pairs turned "uncertain" with no word on what would settle it)
        n_check = int(e.get("n_check", 0))
        # ... and what "spread" must include: loose near ground is verified only by a check point on it (a re-check
        # trial marked 4 far check points as told and was then told they "do not reach that ground")
        near = ""
        if loose in weak and not check_reaches_loose_ground(e):
            near = f", one of them within {float(e['ground_loose_reach_m']):.0f} m of the camera," \
                if np.isfinite(e.get("ground_loose_reach_m", np.nan)) else ", one of them on the near ground,"
        # "off by", not "agree": a trial read "the 3 check points agree (19.6 px)" as reassurance
        off = f"the {n_check} check point{'s are' if n_check != 1 else ' is'} off by {check:.1f} px"
        if suspect and any(w.endswith(suspect) for w in weak):  # no check point vouches for a camera a pair pulls
            weak.append(off + ", which cannot vouch for a camera that pair pulls: correct or delete it and fit again")
        else:
            weak.append(off + f", under 1.5 % of the picture: {MIN_CHECKS} or more, spread over the picture{near} "
                        f"verify the camera despite the rest")
    note = (" " + e["note"]) if e.get("note") else ""
    # A camera judged probably wrong cannot say which points are wrong: no outlier advice under it (a person told to
    # reject them rejected a correct point, see :func:`flags_outliers`).
    note = ("" if poor else outlier_note(e, sure=not weak)) + note
    if poor:
        return "poor", text + " Probably wrong: " + "; ".join(poor) + "." + note
    if weak:
        return "uncertain", text + " Uncertain: " + "; ".join(weak) + "." + note
    return "ok", text + note


def pairs_wanted(n_pairs: int, n_free: int) -> int:
    """How many more pairs a paired fit of ``n_pairs`` for ``n_free`` parameters needs before its residuals can test
    it (fewer than :data:`MIN_SPARE` equations to spare; enough for :data:`FEW_SPARE_TARGET`); 0 when it has enough.

    >>> pairs_wanted(4, 7), pairs_wanted(4, 6), pairs_wanted(5, 7), pairs_wanted(11, 7)
    (2, 1, 0, 0)
    """
    spare = 2 * int(n_pairs) - int(n_free)
    return 0 if spare >= MIN_SPARE or n_free <= 0 else (FEW_SPARE_TARGET - spare + 1) // 2


def check_reaches_loose_ground(e: dict) -> bool:
    """True when a check point lies within the loosely placed ground (``check_nearest_m`` at most
    ``ground_loose_reach_m``, :func:`~.near_ground.loosely_placed_ground`): then it measures that ground too.

    >>> check_reaches_loose_ground({"check_nearest_m": 4000.0, "ground_loose_reach_m": 300.0})
    False
    >>> check_reaches_loose_ground({"check_nearest_m": 150.0, "ground_loose_reach_m": 300.0})
    True
    """
    nearest, reach = float(e.get("check_nearest_m", np.nan)), float(e.get("ground_loose_reach_m", np.nan))
    return bool(np.isfinite(nearest) and np.isfinite(reach) and nearest <= reach)


def suspect_pair_text(e: dict) -> str:
    """"; first check the pair at photo pixel (412, 233): ..." when one pair of a paired fit stands out: its
    leave-one-out error (``e["worst_pair_uv"]``, ``"worst_loo_px"``, ``"median_loo_px"``) over 1.5 % of the
    picture and 3 times the median pair's, and its own residual (``"worst_residual_px"``, ``"median_residual_px"``)
    3 times the others' median. A desktop trial: one GCP's surveyed height 50 m off held the camera on the ground
    at 40 px, and the message named no pair. The residual condition keeps out a right pair that only leverages the
    fit (a corner of few pairs: small residual, large leave-one-out error; 10 of smapshot's 100 real sets).

    >>> e = {"diag": 1000.0, "worst_pair_uv": (412.0, 233.0), "worst_loo_px": 95.0, "median_loo_px": 6.0,
    ...      "worst_residual_px": 30.0, "median_residual_px": 4.0}
    >>> suspect_pair_text(e)[:60]
    '; first check the pair at photo pixel (412, 233): left out, '
    >>> suspect_pair_text(dict(e, worst_loo_px=12.0)), suspect_pair_text(dict(e, worst_residual_px=2.0))
    ('', '')
    """
    worst, median = float(e.get("worst_loo_px", math.nan)), float(e.get("median_loo_px", math.nan))
    own, others = float(e.get("worst_residual_px", math.nan)), float(e.get("median_residual_px", math.nan))
    uv = e.get("worst_pair_uv")
    diag = float(e.get("diag", 1000.0))
    if uv is None or not np.isfinite(worst) or worst <= WEAK_SHARE * diag or \
            not worst > CHECK_OVER_RESIDUALS * max(median, 1.0) or not own > CHECK_OVER_RESIDUALS * max(others, 1.0):
        return ""
    return (f"; first check the pair at photo pixel ({uv[0]:.0f}, {uv[1]:.0f}): left out, the other pairs put it "
            f"{worst:.0f} px from where it is ({worst / max(median, 1.0):.0f} times the median pair's), a wrong "
            "point or a wrong surveyed height")


def flags_outliers(status: str) -> bool:
    """Whether a fit with ``status`` may flag accepted points as outliers: not when it is "poor" (or "refused",
    "canceled"), since the camera that would call them wrong is itself probably wrong. In the scripted Aletsch
    trial an early refit on 5 + 5 correct points, "poor", flagged one and the person rejected it.

    >>> flags_outliers("uncertain"), flags_outliers("poor")
    (True, False)
    """
    return status in ("ok", "uncertain")


def outlier_note(e: dict, sure: bool = True) -> str:
    """The verdict's sentence on the accepted photo points an unpaired fit explains by no terrain point ("" when
    none); evidence ``e`` as :func:`judge` reads it. ``sure``: the camera is "ok"; under an uncertain one the
    flagged points may be right and the camera wrong, and the advice says so.

    >>> outlier_note({"mode": "unpaired", "photo_outliers": 3, "n_photo": 40})[:40]
    ' 3 of 40 accepted photo points fit no te'
    >>> "one by one" in outlier_note({"mode": "unpaired", "photo_outliers": 3, "n_photo": 40}, sure=False)
    True
    """
    if e.get("mode") != "unpaired" or not int(e.get("photo_outliers", 0)):
        return ""
    text = (f" {int(e['photo_outliers'])} of {int(e.get('n_photo', 0))} accepted photo points fit no terrain "
            f"point under this camera (flagged as outliers)")
    if sure:
        return text + (": reject those that are wrong; a right one needs its counterpart accepted in the other "
                       "view.")
    return text + (": the camera is uncertain, so they may be right and the camera wrong; judge them one by one "
                   "rather than rejecting them all.")
