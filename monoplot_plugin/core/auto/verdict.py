"""The alignment's own evidence on an automatic registration's camera, and how it lowers the fit's verdict.

The fit (:func:`~monoplot_plugin.core.fit.fit_camera`) judges the camera by the matched points, which were drawn near
the aligned camera and so agree with it, right or wrong. The edges say more: whether the photo has a clear skyline,
how much of it lies on the DEM's, how tightly the DEM's contours fit the photo's edges, whether another view or a
camera moved by the prior's σ fits about as well. :func:`combine_evidence` can only lower the status ("ok" to
"uncertain", or "poor" when the skyline clearly disagrees) and says why.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..fit.near_ground import NEAR_SHIFT, NEAR_SHIFT_SHARE, loose_ground_text, loosely_placed_ground
from .photo_edges import SKY_FRACTION_MIN, PhotoEdges
from .sigma import carry_correlated, widen_std

if TYPE_CHECKING:  # the registration imports this module
    from .align import Aligner
    from .register import AutoFitResult

__all__ = ["alignment_evidence", "combine_evidence", "no_clear_skyline", "SKY_AGREEMENT_OK", "SKY_AGREEMENT_POOR",
           "EDGE_SCORE_OK", "NO_EDGES_SCORE", "FAINT_EDGES_SCORE", "prior_std", "prior_kept", "NEAR_RATIO",
           "ANGLE_SIGMA_OK", "PROBES_BACK_OK", "NEAR_SHIFT", "NEAR_SHIFT_SHARE"]

#: Least share of the photo's clear skyline on the DEM's (within 0.4 % of the width) for an "ok". Calibrated on
#: the synthetic scenes: right cameras 0.95-0.99, a camera 4 deg off in field of view whose suggestions still
#: paired (the pairs are drawn near the aligned camera, so they agree with it) 0.65.
SKY_AGREEMENT_OK = 0.8
#: Below this share of the photo's clear skyline on the DEM's the camera is "poor": on 76 registrations of the
#: synthetic scenes every camera that succeeded had 0.68 or more, and one 258 px off had 0.25; a desktop trial's
#: prior turned 90 deg ended 95 deg off at 0.15, "uncertain".
SKY_AGREEMENT_POOR = 0.35
#: Largest edge score (:func:`.fine.edge_score`, lower is better) of the camera returned for an "ok". Calibrated on 20
#: synthetic scenes: right cameras 0.12-0.21; a camera 21 % of the range off whose skyline still agreed 0.26.
EDGE_SCORE_OK = 0.23
#: Largest ratio of the prior's position σ to the median distance of the terrain seen for an "ok". Calibrated on
#: 20 synthetic scenes: cameras 2.5 % and 21 % of the range off were "ok" at ratios 0.14 and 0.20 (their
#: suggestions paired with the wrong camera: pairs drawn near it agree with it); right ones lost at 0.14 and 0.16.
NEAR_RATIO = 0.1
#: Largest σ (degrees) of heading and pitch (:mod:`.sigma`: the edges' covariance, rival hypotheses, the aligned
#: camera) for an "ok". Calibrated on 20 synthetic scenes: right "ok" cameras 0.08-0.29; a camera 1.8 % of the
#: range and 0.25 deg off, "ok" by every other rule (edge score 0.226), 0.70 from rivals the edges could not tell
#: apart.
ANGLE_SIGMA_OK = 0.5
#: An "ok" camera's σ may move at most NEAR_SHIFT_SHARE of the ground it sees by more than NEAR_SHIFT of the
#: picture's diagonal (one definition for every fit: :mod:`~..fit.near_ground`). The far ridges the edges align can
#: hold a camera whose position is known only along the view to ± 142 m: a trial's "ok" camera, 33 m off, had its
#: near slope (6 % of the ground, under 300 m) 367 px off at the median.
#: Fewest of the four position probes that must come back (within 1 % of the diagonal) for an "ok": right "ok"
#: cameras of 70 synthetic scenes had 2-4 back (4 for all but one); a wrong one (1.25 % of the range, 23 px on the
#: terrain) had 1, and another 0.
PROBES_BACK_OK = 2
#: Share of the photo's skyline under which the DEM's edge stands for the skyline (the DEM stops inside the view)
#: from which the message names it as a cause (words only: the status is the other rules').
DEM_EDGE_SHARE = 0.1


#: An edge score above this (1 = nothing matches) means the photo's edges match nothing of the DEM's.
NO_EDGES_SCORE = 0.98
#: Without a clear skyline, a camera whose edge score is above this is not returned (the prior is kept): faint
#: edges (a photo in fog) match a few of the DEM's by chance, and the search turns the camera towards them. The
#: Aletsch print and 6 synthetic scenes blended 80-97 % into fog gave such cameras at 0.66-0.97 (priors 0.94-1.0),
#: each farther off than its prior (77 and 245 px against 46 px on the GCPs; 10 deg off from a prior 3 deg off).
#: Right cameras on clear synthetic photos score 0.05-0.35; twice the "ok" limit leaves room for a real photo's
#: coarser match (the Aletsch GCP camera scores 0.59 on the print, whose skyline is clear).
FAINT_EDGES_SCORE = 2.0 * EDGE_SCORE_OK


def _metres(value: float) -> str:
    """A distance for a message: whole metres from 10 m, two figures below (a trial's σ of 0.5 m read "0 m").

    >>> [_metres(v) for v in (0.5, 0.736, 9.54, 147.0, 1234.0)]
    ['0.5', '0.74', '9.5', '147', '1234']
    """
    return f"{value:.0f}" if abs(value) >= 10.0 else f"{value:.2g}"


def alignment_evidence(al: Aligner, off, score: float, refined, photo: PhotoEdges, full_width: int) -> dict:
    """The ``auto_*`` evidence of the aligned offset ``off`` (edge score ``score``) among the ``refined``
    hypotheses ((score, offset), best first), with the photo's edges ``photo``."""
    # Distinct competitor: the best refined hypothesis more than 1 degree away in heading or pitch.
    best_off = refined[0][1]
    rival = [(sc, o) for sc, o in refined[1:] if np.max(np.abs(o[:2] - best_off[:2])) > 1.0]
    within = max(1.0, 0.004 * photo.width)  # 4 px on a 1000 px picture
    ev = {"auto_skyline_usable": bool(photo.usable), "auto_sky_fraction": float(photo.sky_fraction),
          "auto_sky_contrast": float(photo.contrast), "auto_align_score": float(score),
          "auto_sky_agreement": al.skyline_agreement(off, within),
          "auto_sky_at_dem_edge": al.skyline_at_dem_edge(off, within),
          "auto_rival_ratio": float(refined[0][0] / rival[0][0]) if rival and rival[0][0] > 0 else 0.0,
          "auto_evaluations": int(al.evaluations)}
    if rival:  # where it looks, from this camera (a phone trial's message named no direction)
        ev["auto_rival_heading_deg"], ev["auto_rival_pitch_deg"] = (float(d) for d in rival[0][1][:2] - best_off[:2])
    return ev


def _rival_words(ev: dict) -> str:
    """Where the rival view looks from the camera's, in words ("" when not known).

    >>> _rival_words({"auto_rival_heading_deg": -12.04, "auto_rival_pitch_deg": 1.5})
    ' (12.0° to the left and 1.5° higher)'
    >>> _rival_words({"auto_rival_heading_deg": 3.0, "auto_rival_pitch_deg": 0.2})
    ' (3.0° to the right)'
    """
    heading, pitch = ev.get("auto_rival_heading_deg"), ev.get("auto_rival_pitch_deg")
    if heading is None or pitch is None:
        return ""
    parts = []
    if abs(heading) >= 0.5:
        parts.append(f"{abs(heading):.1f}° to the {'right' if heading > 0 else 'left'}")
    if abs(pitch) >= 0.5:
        parts.append(f"{abs(pitch):.1f}° {'higher' if pitch > 0 else 'lower'}")
    return f" ({' and '.join(parts)})" if parts else ""


def no_clear_skyline(ev: dict) -> str:
    """Why the photo's skyline is not usable, in words: too few columns have one, or the line found has the colour
    of the picture under it (a trial's brick wall: "no clear skyline (76 % of its columns)" read as a contradiction).

    >>> no_clear_skyline({"auto_sky_fraction": 0.2})
    'the photo shows no clear skyline (20 % of its columns)'
    >>> no_clear_skyline({"auto_sky_fraction": 0.76})[:76]
    'the photo shows no clear skyline: the line found across 76 % of its columns '
    """
    share = 100 * ev["auto_sky_fraction"]
    if ev["auto_sky_fraction"] < SKY_FRACTION_MIN:
        return f"the photo shows no clear skyline ({share:.0f} % of its columns)"
    return (f"the photo shows no clear skyline: the line found across {share:.0f} % of its columns has much of the "
            "colour of what lies under it, as a wall's or a rock face's edge has, not a sky's")


def combine_evidence(result: AutoFitResult, ev: dict) -> None:
    """Add the alignment's evidence; it can only lower the fit's status. The reasons for doubt are kept in
    ``result.weak`` (the registration's ``_prior_kept`` gives them alone)."""
    result.evidence.update(ev)
    weak = result.weak = []
    if not ev["auto_skyline_usable"]:
        # "rests on suggestions alone" only when some were matched (a trial's fog photo: 0 matched points)
        weak.append(no_clear_skyline(ev) + (": the camera rests on suggestions alone" if len(result.pairs) else ""))
    elif ev["auto_sky_agreement"] < SKY_AGREEMENT_OK:
        weak.append(f"only {100 * ev['auto_sky_agreement']:.0f} % of the photo's skyline lies on the DEM's "
                    "skyline under the camera")
    at_edge = ev.get("auto_sky_at_dem_edge", 0.0) if ev["auto_skyline_usable"] else 0.0
    if at_edge >= DEM_EDGE_SHARE:
        # named: a trial's DEM stopped inside the view, and the message blamed the position's σ and rival views
        weak.append(f"the DEM ends inside the view: its edge stands for the skyline under {100 * at_edge:.0f} % of "
                    "the photo's skyline, where the terrain beyond it is missing and the photo cannot be compared "
                    "with it; a DEM reaching the horizon would judge the camera on all of it")
    if ev.get("auto_edge_score", 1.0) > EDGE_SCORE_OK:
        # with one cause the person can act on (a trial's EXIF GPS 250 m off, searched within its 30 m: the camera
        # ended 311 m from the truth, nothing said the σ might be too small)
        cause = ("the DEM's edge in the view is one cause" if at_edge >= DEM_EDGE_SHARE else
                 f"if the rough position may be farther off than its σ of "
                 f"{_metres(ev.get('auto_position_sigma_m', 0.0))} m, give a larger position uncertainty")
        weak.append(f"the DEM's skyline and contours fit the photo's edges only loosely under the camera (edge "
                    f"score {ev.get('auto_edge_score', 1.0):.3f}, over {EDGE_SCORE_OK:.3f}; 0 is a perfect fit): "
                    + cause)
    rng = ev.get("auto_range_m", float("nan"))
    near = not np.isfinite(rng) or ev.get("auto_position_sigma_m", 0.0) > NEAR_RATIO * rng
    if near:
        weak.append(f"the prior position's uncertainty ({_metres(ev.get('auto_position_sigma_m', 0.0))} m) is a "
                    f"large part of the distance to the terrain seen ({rng:.0f} m): edges alone cannot place the "
                    "camera")
    spread = max(result.std.get("heading", 0.0), result.std.get("pitch", 0.0))
    if spread > 90.0:  # a σ of thousands of degrees (a photo of fog) says nothing a reader can use
        weak.append("the photo's edges do not determine the view direction")
    elif spread > ANGLE_SIGMA_OK:
        weak.append(f"views the photo's edges cannot tell apart leave the view direction uncertain by {spread:.2f} "
                    "deg (σ)")
    if ev["auto_rival_ratio"] > 0.9:
        weak.append("a clearly different view direction aligns the edges almost as well" + _rival_words(ev))
    back = ev.get("auto_probe_returned", PROBES_BACK_OK)
    if back < PROBES_BACK_OK:
        weak.append(f"{'none' if back == 0 else f'only {back}'} of four cameras moved by the position's σ "
                    f"({_metres(ev.get('auto_position_sigma_m', 0.0))} m) and refined again came back to this one: it "
                    "sits in a basin narrower than the prior's uncertainty, and another camera may fit elsewhere")
    if ev.get("auto_probe_rivals", 0):
        weak.append(f"a camera {_metres(ev['auto_probe_distance_m'])} m away, turned to the same terrain, fits the "
                    f"photo's edges about as well (its edge score is {ev['auto_probe_ratio']:.2f} times this "
                    f"one's; lower is better) and puts the terrain {_shift_words(ev['auto_probe_shift_px'], result)}"
                    ": the edges cannot place the camera that closely")
    if near or back < PROBES_BACK_OK:
        # what the edges cannot place, only the prior does: its position σ is the honest one (a desktop trial's near
        # scene said ± 8 / 39 m with the camera 37 m off)
        # and the angles the fit found for the camera where it stands move with it (:func:`.sigma.carry_correlated`)
        widened = widen_std(result.std, {}, [], dict.fromkeys("xyz", float(ev.get("auto_position_sigma_m", 0.0))))
        result.std = carry_correlated(result.std, widened, result.correlation)
    ground = getattr(result, "ground", None)
    loose = loosely_placed_ground(result.camera, result.std, ground) if ground is not None else {}
    if loose:
        result.evidence["auto_ground_uncertain_share"] = loose["ground_loose_share"]
        text = loose_ground_text(loose, "the camera is not placed closely enough for the near terrain")
        if text:
            weak.append(text)
    text = (f" Automatic: skyline on {100 * ev['auto_sky_fraction']:.0f} % of the columns, "
            f"{100 * ev['auto_sky_agreement']:.0f} % of it on the DEM's; {len(result.image_points)} photo and "
            f"{len(result.world_points)} DEM suggestions kept as consistent with the aligned camera.")
    if ev["auto_skyline_usable"] and ev["auto_sky_agreement"] < SKY_AGREEMENT_POOR and result.status in ("ok",
                                                                                                      "uncertain"):
        # the reason first (the dock shows the message's start; the fit's own "Uncertain:" is a lesser matter now)
        result.status = "poor"
        result.message = (f"Probably wrong: only {100 * ev['auto_sky_agreement']:.0f} % of the photo's clear skyline "
                          "lies on the DEM's under this camera; give a better rough camera (its heading first) or "
                          "pair a few points. " + result.message.replace(" Uncertain: ", " Also: ") + text)
    elif weak and result.status == "ok":
        result.status = "uncertain"
        result.message += text + " Uncertain: " + "; ".join(weak) + ": check the matched points."
    else:
        result.message += text + (" Also: " + "; ".join(weak) + "." if weak else "")


def prior_std(sig: dict) -> dict:
    """The prior's σ by parameter name (roll half the angle σ, as the search takes it)."""
    return {"x": sig["position_m"], "y": sig["position_m"], "z": sig["position_m"], "heading": sig["angle_deg"],
            "pitch": sig["angle_deg"], "roll": 0.5 * sig["angle_deg"], "fov": sig["fov_deg"]}


def prior_kept(result: "AutoFitResult", prior, sig: dict) -> "AutoFitResult":
    """The prior camera back, "uncertain" (or the fit's "poor"), when the automatic camera does not fit the photo's
    edges clearly better than the prior did; its σ is the prior's."""
    ev = result.evidence
    # The reasons only: the figures of the fit on the suggestions were about a camera not returned, and quoting
    # them ("65 of 133 photo points matched", "the camera returned is the edge alignment's") on a photo of fog
    # contradicted "the prior is kept" (a trial).
    no_edges = min(ev["auto_edge_score"], ev["auto_prior_edge_score"]) > NO_EDGES_SCORE
    if no_edges:
        why = "the photo's edges match no camera's view of the DEM, the prior's neither (edge score 1 = no match)"
    elif not ev["auto_skyline_usable"] and ev["auto_edge_score"] > FAINT_EDGES_SCORE:
        why = (f"{no_clear_skyline(ev)}, and its "
               f"edges match the DEM's too loosely under the best camera found to trust it without a skyline (edge "
               f"score {ev['auto_edge_score']:.2f}, the prior's {ev['auto_prior_edge_score']:.2f}; 0 is a perfect "
               f"fit, 1 no match; without a skyline, a few faint edges can match the DEM's by chance)")
        result.weak = []  # the rest is about that camera, which is not returned (its σ, its rivals)
    else:
        why = (f"no camera found fits the photo's edges clearly better than the prior (edge score "
               f"{ev['auto_edge_score']:.3f} against the prior's {ev['auto_prior_edge_score']:.3f}; 0 is a "
               f"perfect fit)")
    reasons = "; ".join(result.weak)
    kept = type(result)(prior, "poor" if result.status == "poor" else "uncertain",
                         f"The automatic registration did not improve on the prior camera: {why}. The prior is "
                         "kept: check it, pair a few points by hand, or give a closer prior."
                         + (f" Also: {reasons}." if reasons else ""), result.mode, result.free,
                         evidence=dict(ev, auto_prior_kept=True, auto_no_edges=no_edges, auto_sigma_is_prior=True,
                                       auto_prior_kept_why=why),
                         std=prior_std(sig))
    kept.image_points, kept.world_points, kept.aligned, kept.skyline = (result.image_points, result.world_points,
                                                                        result.aligned, result.skyline)
    kept.elapsed_s = result.elapsed_s
    return kept


def _shift_words(shift_px: float, result) -> str:
    """How far a rival camera puts the terrain, in words: an RMS over terrain near one of the cameras runs to tens of
    thousands of pixels (a re-check trial read "24661 px elsewhere" on a 4000 px photo).

    >>> from types import SimpleNamespace
    >>> r = SimpleNamespace(camera=SimpleNamespace(image_size=(4000, 3000)))
    >>> _shift_words(61.4, r), _shift_words(24661.0, r)
    ('61 px elsewhere', "more than the picture's size elsewhere")
    """
    w, h = result.camera.image_size
    if shift_px > math.hypot(w, h):
        return "more than the picture's size elsewhere"
    return f"{shift_px:.0f} px elsewhere"
