""":func:`register_automatic`: a camera from the photo, the DEM and a rough prior, with no clicks.

1. The photo's skyline and oriented edges (:mod:`.photo_edges`) at three working sizes (256, 512, 1024 px).
2. The DEM's skyline and occluding contours seen from the prior (:mod:`.dem_edges`), over a view widened by the
   angles still to search.
3. Coarse grid over heading, pitch, roll and field of view at 256 px; the best distinct hypotheses are refined by a
   compass search over all seven parameters (position within its σ) at 512 px; the three best are rendered again
   from where they stand and refined at full working size, in up to three passes (:mod:`.align`, :mod:`.fine`).
4. With the aligned camera: Monoplot's own photo and DEM suggestions (:mod:`~monoplot_plugin.core.suggest`), the
   pairs that camera brings within a few pixels of each other kept, with points along the skyline (the photo's
   sub-pixel skyline, the DEM silhouette the aligned camera puts next to it), and the ordinary unpaired fit
   (:func:`~monoplot_plugin.core.fit.fit_camera`: consensus, refinement, verdict) run on them from the aligned
   camera. The result is that fit's :class:`~monoplot_plugin.core.fit.FitResult`, with its status, message and σ.
5. The alignment's own evidence can only lower the status: without a clear skyline, or when the skyline does not
   agree with the DEM's, or when a clearly different camera aligns nearly as well, an "ok" becomes "uncertain"
   with the reason in the message (never a confident camera from a photo that says little). Position probes
   (:func:`.fine.position_probes`): the camera moved by the position σ four ways, aimed at the same terrain and
   refined again; one ending elsewhere with nearly the same edge score is such a camera, and the σ covers it; when
   fewer than two come back, the camera sits in a basin narrower than the prior's uncertainty: "uncertain" too.
6. Never worse than the prior: when the camera returned does not fit the photo's edges clearly better than the prior
   did (the same score, each rendered from where it stands, no pull to the prior), the prior is returned,
   "uncertain" (or the fit's "poor"), with what the fit found in the message.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable, NamedTuple, Optional

import numpy as np

from ..camera import Camera
from ..fit import DEFAULT_FREE, FitCanceled, FitResult, fit_camera
from ..fit.near_ground import ground_seen
from ..fit.result import rms
from ..fit.verdict import FEWER_SIDE_ADVICE, FEWER_SIDE_CAUSES, outlier_note
from ..xyz.zbuffer import trial_cameras
from .align import Aligner, camera_from_offset, ground_heights, offsets_grid
from .dem_edges import coarse_dem, dem_edges, dem_in_view
from .fine import (PROBE_RATIO, edge_score, fine_steps, grounded_height_sigma, offset_between, position_probes,
                   refine_fine)
from .photo_edges import PhotoEdges, detect_photo_edges
from .points import FIT_DEM_CELLS, consistent_points, skyline_points
from .sigma import RIVAL_RATIO, camera_values, edge_std, widen_std
from .verdict import (EDGE_SCORE_OK, FAINT_EDGES_SCORE, alignment_evidence, combine_evidence, prior_kept,
                      prior_std)

__all__ = ["register_automatic", "AutoFitResult", "ALIGN_DEM_CELLS", "FIT_DEM_CELLS"]

#: Most DEM cells used by the alignment (finer DEMs are averaged by blocks).
ALIGN_DEM_CELLS = 2_000_000
WIDTHS = (256, 512, 1024)
#: Distinct view directions of the coarse grid refined at 512 px (at 256 px and the prior's position the grid's
#: best is often not the right basin), and how many of the refined are refined again at full size.
N_STARTS = 8
N_FINALS = 3
#: Passes of the fine stage (:func:`.fine.refine_fine`) for the best hypotheses (a near camera's silhouettes change
#: as it moves: each pass renders them again and starts with wide steps); probes keep one. Measured on the synthetic
#: scenes against one pass: 25 -> 26 of 50 within 1 % of the range (eval σ), 9 -> 11 of 20 (default σ).
FINE_PASSES = 3
#: Distance (prior position σ) of the coarse search's positions around the prior's (:func:`_positions`).
POSITION_SIGMAS = 1.0
#: Least improvement of the edge score (:func:`.fine.edge_score`) for the automatic camera to be returned instead
#: of the prior.
PRIOR_MARGIN = 0.01
#: A position probe (:func:`.fine.position_probes`) whose edge score is below this share of the camera's is a
#: basin the search missed: the registration goes on from it, at most :data:`MAX_ESCAPES` times. Right cameras'
#: probes scored 0.99-1.11 of them on 70 synthetic scenes; missed basins 0.33-0.89 (at 0.89, a camera "ok" but
#: 35 m off whose foreground was hundreds of pixels off went on to 17 px, "uncertain").
ESCAPE_RATIO = 0.9
MAX_ESCAPES = 2
#: Least share of the prior's view (widened by the search's angular margin) that must see the DEM for a search:
#: below it there are no terrain edges to align (a desktop trial's DEM off to the side ended "uncertain", the
#: prior kept and the reason at the end of a long message).
MIN_VIEW_SEEN = 0.001


@dataclass
class AutoFitResult(FitResult):
    """A :class:`~monoplot_plugin.core.fit.FitResult` with what the automatic registration matched.

    Extra attributes:
        image_points, world_points: (N, 2) photo and (M, 3) DEM points given to the final fit (``pairs`` and
            ``inliers`` index them): the "accepted points" of a semi-automatic session.
        aligned: the camera after the edge alignment, before the fit.
        skyline: (W, 2) photo skyline (u, v) in full-size pixels, NaN where the photo shows no clear skyline.
        weak: the reasons for doubt the verdict gave (sentences without the final stop).
        ground: (K, 3) a sample of the terrain the camera sees (:func:`~..fit.near_ground.ground_seen`), for the
            verdict.
    """

    image_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    world_points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    aligned: Optional[Camera] = None
    skyline: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    weak: list = field(default_factory=list)
    ground: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))


def _sigmas(prior: Camera, position_sigma_m, angle_sigma_deg, fov_sigma_deg) -> dict:
    return {"position_m": float(200.0 if position_sigma_m is None else position_sigma_m),
            "angle_deg": float(5.0 if angle_sigma_deg is None else angle_sigma_deg),
            "fov_deg": float(0.1 * prior.fov if fov_sigma_deg is None else fov_sigma_deg)}


def _distinct(offsets: np.ndarray, scores: np.ndarray, k: int, min_deg: float, min_m: float) -> list:
    """Indices of the ``k`` best offsets, each distinct from the others: ``min_deg`` apart in heading or pitch, or
    ``min_m`` apart in position (the two distances in units of these add up to at least 1)."""
    kept = []
    for i in np.argsort(scores):
        if all(np.max(np.abs(offsets[i, :2] - offsets[j, :2])) / min_deg
               + np.linalg.norm(offsets[i, 4:7] - offsets[j, 4:7]) / min_m >= 1.0 for j in kept):
            kept.append(int(i))
        if len(kept) >= k:
            break
    return kept


def _positions(sig: dict, prior: Optional[Camera] = None, dem=None) -> np.ndarray:
    """(P, 7) offsets of the coarse search's positions: the prior's and :data:`POSITION_SIGMAS` σ from it east,
    west, north and south (a camera that far off sees near terrain from another side: no turn of the view at the
    prior's position makes up for it)."""
    d = POSITION_SIGMAS * sig["position_m"]
    out = np.zeros((5, 7))
    out[1:, 4:6] = [(d, 0.0), (-d, 0.0), (0.0, d), (0.0, -d)]
    if sig.get("ground") is not None and dem is not None:  # on the ground (of ``dem``) wherever it moves
        x, y, z = prior.position
        out[1:, 6] = ground_heights((dem, sig["ground"][1]), x + out[1:, 4], y + out[1:, 5], np.full(4, z)) - z
    return out


def _check_inputs(image, prior: Camera) -> np.ndarray:
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] < 3 or image.dtype != np.uint8:
        raise ValueError(f"image must be an (H, W, 3) uint8 RGB array, got {image.shape} {image.dtype}")
    h, w = image.shape[:2]
    if (w, h) != tuple(prior.image_size):
        raise ValueError(f"the prior camera's image size {prior.image_size} is not the photo's ({w}, {h})")
    return image[..., :3]


def register_automatic(image, dem, prior: Camera, *, position_sigma_m: Optional[float] = None,
                       angle_sigma_deg: Optional[float] = None, fov_sigma_deg: Optional[float] = None,
                       eye_height_m: Optional[float] = None, hold_position: bool = False,
                       progress: Optional[Callable[[float, str], None]] = None,
                       is_canceled: Optional[Callable[[], bool]] = None) -> FitResult:
    """Register a photo on a DEM from a rough camera, with no points given.

    Args:
        image: (H, W, 3) uint8 RGB photo.
        dem: :class:`~monoplot_plugin.core.dem.Dem` (projected CRS, metres).
        prior: rough :class:`~monoplot_plugin.core.camera.Camera` in the DEM's CRS, image size of the photo.
        position_sigma_m, angle_sigma_deg, fov_sigma_deg: one σ of the prior's position, heading / pitch (roll
            half of it) and horizontal field of view (defaults 200 m, 5°, 10 % of the field of view).
        eye_height_m: the camera stood this high above the ground (a photographer, a mast): its height follows the
            terrain wherever the search moves it, known as well as the terrain's height varies within the
            position's σ (:func:`~.fine.grounded_height_sigma`), and the final fit holds it there. None: the height is
            searched as the position is (a flood trial's camera on an embankment, left free, ended 31-64 m under
            the terrain, its height traded against the field of view).
        hold_position: the prior's X, Y are known: the search keeps within ``position_sigma_m`` of them and the
            final fit on the matched points holds them (a time-lapse trial's mast, its position unticked: the
            consensus fit, pulled by 231 matched points against a 1 m prior, moved it 1.7-6.6 m).
        progress: optional ``callable(fraction, message)``.
        is_canceled: optional ``callable() -> bool``; polled at least every few tenths of a second.
    Returns:
        :class:`AutoFitResult` (a :class:`~monoplot_plugin.core.fit.FitResult`): status "ok", "uncertain",
        "poor", "refused" or "canceled", with the message saying why.
    """
    t0 = time.perf_counter()
    image = _check_inputs(image, prior)
    report = never_back(progress)
    sig = _sigmas(prior, position_sigma_m, angle_sigma_deg, fov_sigma_deg)
    sig["hold_position"] = bool(hold_position)
    if eye_height_m is not None:
        z = float(ground_heights((dem, eye_height_m), [prior.position[0]], [prior.position[1]], [math.nan])[0])
        if math.isfinite(z):
            prior = prior.with_parameters(z=z)
            sig["ground"] = (dem, float(eye_height_m))
    state = {"camera": prior}
    try:
        with trial_cameras():  # the search renders many cameras; one under the DEM is no news for the log
            result = _register(image, dem, prior, sig, report, is_canceled, state)
    except FitCanceled:
        result = AutoFitResult(state["camera"], "canceled", "The automatic registration was canceled; the camera "
                               "is the best found so far.", "unpaired", aligned=state["camera"])
    if sig.get("ground") is not None and result.std and result.status != "canceled":
        result.std["z"] = grounded_height_sigma(dem, result.camera, result.std)  # held on the ground
    result.elapsed_s = time.perf_counter() - t0
    if result.status != "canceled":  # a canceled search is not done (a batch's bar went to 50 % on Cancel)
        report(1.0, "")  # not the status: the workflow may still lower it (the height rule)
    return result


def never_back(progress: Optional[Callable[[float, str], None]]) -> Callable[..., None]:
    """``progress`` that never goes back (a search going on from a position probe starts its last stages again: a
    trial's bar went from 89 % to 85 %).

    >>> seen = []; report = never_back(lambda f, m: seen.append(f)); report(0.5); report(0.3, "again"); seen
    [0.5, 0.5]
    """
    shown = [0.0]

    def report(fraction: float, message: str = "") -> None:
        shown[0] = max(shown[0], fraction)
        if progress is not None:
            progress(shown[0], message)

    return report


def _poll(is_canceled) -> None:
    if is_canceled is not None and is_canceled():
        raise FitCanceled()


def _register(image, dem, prior, sig, report, is_canceled, state) -> FitResult:
    h, w = image.shape[:2]
    report(0.0, "automatic registration: photo skyline and edges")
    import cv2

    # One reduction of a large photo first (a 24 MP resize per working size would take seconds).
    reduced = image if w <= WIDTHS[-1] else cv2.resize(image, (WIDTHS[-1], max(8, round(h * WIDTHS[-1] / w))),
                                                      interpolation=cv2.INTER_AREA)
    photos = {}
    for i, width in enumerate(WIDTHS):
        _poll(is_canceled)
        pe = detect_photo_edges(reduced, width=min(width, w))
        pe.scale = pe.width / float(w)  # working pixels per full-size pixel
        photos[width] = pe
        report(0.05 * (i + 1) / len(WIDTHS), "automatic registration: photo skyline and edges")
    fine = photos[WIDTHS[-1]]
    _poll(is_canceled)
    report(0.05, "automatic registration: DEM at the working resolution")
    align_dem = coarse_dem(dem, ALIGN_DEM_CELLS, is_canceled)
    _poll(is_canceled)
    margin = 2.5 * sig["angle_deg"] + 1.25 * sig["fov_deg"] + 2.0
    seen = dem_in_view(prior, align_dem, margin)
    if seen < MIN_VIEW_SEEN:
        return AutoFitResult(
            prior, "poor", f"The DEM is not in view: from the prior camera, with the view widened by {margin:.0f} "
            f"deg on every side, {100 * seen:.1f} % of the picture sees the DEM, so there is no terrain to align the "
            f"photo with. Give a DEM that covers what the photo shows, or check the prior's position and heading. "
            f"The prior is kept.", "unpaired", evidence={"auto_dem_in_view": seen}, std=prior_std(sig))
    # Coarse: a grid of view directions and fields of view at the prior's position and around it, each position
    # rendered from where it stands.
    report(0.1, "automatic registration: coarse search of the view direction")
    p0 = photos[WIDTHS[0]]
    step = max(0.25, 4.0 * prior.fov / p0.width)
    grid = offsets_grid(sig, step)
    # around the prior's position one roll (the medium search refines it): a third of the full grid's time
    around = offsets_grid(sig, step, roll_steps=1)
    offsets, scores = [], []
    positions = _positions(sig, prior, align_dem)
    # the bar moves with the cameras scored: the prior's full grid alone took 30 of a 60 s coarse search (a batch)
    total, scored = len(grid) + (len(positions) - 1) * len(around), 0
    for k, pos in enumerate(positions):
        grid = grid if k == 0 else around
        ref = camera_from_offset(prior, pos, sig.get("ground"))
        coarse = Aligner(ref, p0, dem_edges(ref, align_dem, margin, ref.focal_px * p0.scale), sig, tau=6.0,
                         prior_offset=offset_between(ref, prior), is_canceled=is_canceled, max_points=700)
        scores.append(coarse.score(grid, done=lambda f, before=scored, n=len(grid): report(
            0.1 + 0.2 * (before + f * n) / total, "automatic registration: coarse search of the view direction")))
        scored += len(grid)
        offsets.append(grid + pos[None, :])
    offsets, scores = np.vstack(offsets), np.concatenate(scores)
    starts = [offsets[i] for i in _distinct(offsets, scores, N_STARTS, 2.0 * step, POSITION_SIGMAS
                                            * sig["position_m"])]
    # Medium: compass search over the seven parameters from each distinct start, the DEM rendered from the start's
    # position.
    report(0.3, "automatic registration: refining the best hypotheses")
    p1 = photos[WIDTHS[1]]
    steps, mins = fine_steps(sig)
    refined, mediums = [], {}
    for i, s in enumerate(starts):
        key = tuple(np.round(s[4:7], 3))
        if key not in mediums:
            ref = camera_from_offset(prior, np.r_[np.zeros(4), s[4:7]], sig.get("ground"))
            mediums[key] = (Aligner(ref, p1, dem_edges(ref, align_dem, margin, ref.focal_px * p1.scale), sig,
                                    tau=5.0, prior_offset=offset_between(ref, prior), is_canceled=is_canceled,
                                    max_points=800), s[4:7])
        medium, pos = mediums[key]
        start = np.r_[s[:4], np.zeros(3)]
        off, sc = medium.pattern_search(start, steps, mins, max_iter=40)
        off, sc = medium.least_squares(off, iterations=8)
        off = off + np.r_[np.zeros(4), pos]  # from the prior
        refined.append((sc, off))
        state["camera"] = camera_from_offset(prior, min(refined, key=lambda t: t[0])[1], sig.get("ground"))
        report(0.3 + 0.25 * (i + 1) / len(starts), "automatic registration: refining the best hypotheses")
    refined.sort(key=lambda t: t[0])
    # Fine: render again from the best cameras and refine at full working size, the distance scale shrinking
    # (a wide scale first smooths the score's many shallow minima), rendering again from where each round ends.
    finals = []
    for j, (_, off) in enumerate(refined[:N_FINALS]):
        cam, al, o2 = refine_fine(camera_from_offset(prior, off, sig.get("ground")), prior, fine, align_dem, sig,
                                  is_canceled, _poll, passes=FINE_PASSES)
        # Judged by the edges alone, each rendered from where it stands (no pull to the prior, one distance
        # scale). ``al`` is the last round's, ``o2`` the offset from its reference to ``cam``.
        finals.append((edge_score(cam, fine, align_dem, sig, is_canceled), cam, al, o2,
                       float(al.score(o2[None])[0])))
        report(0.55 + 0.15 * (j + 1) / min(N_FINALS, len(refined)), "automatic registration: fine alignment")
    finals.sort(key=lambda t: t[0])
    prior_edge = edge_score(prior, fine, align_dem, sig, is_canceled)
    search = _Search(image, dem, prior, sig, report, is_canceled, fine, align_dem, refined, prior_edge, {})
    state["camera"] = finals[0][1]
    result, probes = _finish(finals, 0.7, search)
    state["camera"] = result.camera
    return _escape(result, probes, finals, search, state)


class _Search(NamedTuple):
    """What the stages after the fine search share: the inputs, the working photo edges and DEM, the medium stage's
    refined hypotheses (score, offset), the prior's edge score, and what the final fit's points need that does not
    depend on the camera (:func:`.points.consistent_points`' cache: a retry does not find it again)."""

    image: np.ndarray
    dem: object
    prior: Camera
    sig: dict
    report: Callable
    is_canceled: Optional[Callable[[], bool]]
    fine: PhotoEdges
    align_dem: object
    refined: list
    prior_edge: float
    cache: dict


def _finish(finals, at: float, search: _Search):
    """From the best of ``finals`` ((edge score, camera, aligner, offset, aligner score), best first): consistent
    suggestions, the consensus fit, σ, the verdict, position probes; (result, probes). ``at``: progress start."""
    image, dem, prior, sig, report, is_canceled, fine, align_dem, refined, prior_edge, cache = search
    w = image.shape[1]
    aligned_edge, aligned, al, off, best_score = finals[0]
    report(at, "automatic registration: suggestions consistent with the aligned camera")
    evidence = alignment_evidence(al, off, best_score, refined, fine, w)
    evidence["auto_range_m"] = _typical_range(aligned, align_dem)
    evidence["auto_position_sigma_m"] = float(sig["position_m"])
    _poll(is_canceled)
    image_points, world_points = consistent_points(image, dem, aligned, is_canceled, _poll, cache)
    sky_uv, sky_xyz = skyline_points(aligned, fine, align_dem)
    image_points, world_points = np.vstack([image_points, sky_uv]), np.vstack([world_points, sky_xyz])
    evidence["auto_skyline_points"] = int(len(sky_uv))
    fit_at = max(at, 0.5 * (at + 0.9))  # 0.7 -> 0.8: the fit takes 0.8 to 0.9; a retry (0.95) stays at 0.95
    report(fit_at, "automatic registration: consensus fit")
    # a field of view known better than half a degree (a lens typed in) stays as known
    fit_sig = {"position_sigma_m": sig["position_m"], "angle_sigma_deg": 1.0,
               "fov_sigma_deg": sig["fov_deg"] if sig["fov_deg"] < 0.5 else max(0.5, 0.25 * sig["fov_deg"])}
    if sig.get("ground") is not None:  # held on the ground, as the search held it
        fit_sig.update(ground=dem, eye_height=sig["ground"][1])
    if sig.get("hold_position"):  # at the prior's X, Y (the aligned camera is within the search's σ of them)
        aligned = camera_from_offset(aligned, np.r_[np.zeros(4), np.subtract(prior.position[:2], aligned.position[:2]),
                                                    0.0], sig.get("ground"))
        fit_sig["free"] = [name for name in DEFAULT_FREE if name not in ("x", "y")]
    fit = fit_camera(image_points, world_points, aligned, is_canceled=is_canceled,
                     progress=lambda f, m="": report(fit_at + max(0.0, 0.9 - fit_at) * f, m),
                     time_budget_s=2.0,
                     # the aligned camera is already close: one start, a small consensus search
                     n_starts=1, n_escapes=0, consensus_hypotheses=800, consensus_starts=2, bootstrap=5,
                     **fit_sig)
    if fit.status == "canceled":
        raise FitCanceled()
    result = AutoFitResult(**vars(fit))
    result.image_points, result.world_points, result.aligned = image_points, world_points, aligned
    # the dock adds only the matched pairs as accepted points: no advice about "accepted" points it never shows
    note = outlier_note(fit.evidence, sure=fit.status == "ok")
    if note:
        result.message = result.message.replace(note, "")
    # the points are the registration's own suggestions, none flagged in the dock: no advice to reject them
    result.message = result.message.replace(f"{FEWER_SIDE_CAUSES}; {FEWER_SIDE_ADVICE}",
                                            "the suggestions or the aligned camera they were kept by are wrong")
    # The fit on the suggestions refines the aligned camera only when its camera fits the photo's edges at least as
    # well: pairs drawn near the aligned camera can also pull it off (each camera rendered from where it stands).
    evidence["auto_edge_score"] = edge_score(result.camera, fine, align_dem, sig, is_canceled)
    evidence["auto_aligned_returned"] = bool(aligned_edge < evidence["auto_edge_score"])
    if evidence["auto_aligned_returned"]:
        fit_edge = evidence["auto_edge_score"]
        result.camera, evidence["auto_edge_score"] = aligned, aligned_edge
        pairs = np.asarray(result.pairs, dtype=np.int64).reshape(-1, 2)
        if len(pairs):  # the residuals and RMSE of the camera returned, on the same pairs
            result.residuals_px = aligned.project(world_points[pairs[:, 1]]) - image_points[pairs[:, 0]]
            kept = result.inliers if len(result.inliers) == len(pairs) else np.ones(len(pairs), dtype=bool)
            result.rmse_px = rms(np.linalg.norm(result.residuals_px[kept], axis=1))
        result.message += (f" The camera returned is the edge alignment's: it fits the photo's skyline and ridges "
                           f"better than the fit on these points (edge score, 0 for a perfect fit: {aligned_edge:.3f} "
                           f"against {fit_edge:.3f}); on the same pairs it gives {result.rmse_px:.1f} px RMSE.")
    # σ that also covers what the automatic pairs, drawn near the aligned camera, cannot see (:mod:`.sigma`)
    rivals = [camera_values(c) for sc, c, *_ in finals[1:] if sc <= RIVAL_RATIO * aligned_edge]
    result.std = widen_std(result.std, camera_values(result.camera), [camera_values(aligned)] + rivals,
                           edge_std(al, off))
    evidence["auto_rivals"] = len(rivals)
    cols = (np.arange(fine.width) + 0.5) / fine.scale
    rows = np.where(fine.sky_valid, fine.sky_row / fine.scale, np.nan)
    result.skyline = np.stack([cols, rows], axis=1)
    # The skyline judged again under the camera returned (the fit may have moved it).
    evidence["auto_sky_agreement"] = al.skyline_agreement(offset_between(al.ref, result.camera), 0.004 * fine.width
                                                          if fine.width >= 250 else 1.0)
    # Never a camera that fits the photo's edges worse than the prior did: judged by the same score, each camera
    # rendered from where it stands, without the pull to the prior.
    evidence["auto_prior_edge_score"] = prior_edge
    keep_prior = (evidence["auto_edge_score"] > evidence["auto_prior_edge_score"] - PRIOR_MARGIN
                  or not evidence["auto_skyline_usable"] and evidence["auto_edge_score"] > FAINT_EDGES_SCORE)
    probes = []
    if not keep_prior:
        start = max(at, 0.9)
        report(start, "automatic registration: probing the position")
        probes = _probe_position(result, prior, fine, align_dem, sig, evidence, is_canceled,
                                 lambda f: report(start + (0.99 - start) * f, "automatic registration: probing the "
                                                  "position"))
    if evidence["auto_edge_score"] > EDGE_SCORE_OK:
        # the photo's edges do not support the camera: it is known no better than the prior (before the verdict's
        # message, which quotes the σ shown)
        result.std = widen_std(result.std, {}, [], prior_std(sig))
        evidence["auto_sigma_is_prior"] = True
    result.ground = ground_seen(result.camera, align_dem)
    combine_evidence(result, evidence)
    if keep_prior:
        result = prior_kept(result, prior, sig)
    return result, probes


def _escape(result, probes, finals, search: _Search, state):
    """A position probe that fits the edges clearly better than the camera found (:data:`ESCAPE_RATIO`) is a basin
    the search missed, by its own measure: go on from there (:func:`_finish`), and keep what that gives when its
    edge score is lower; at most :data:`MAX_ESCAPES` times."""
    for escape in range(MAX_ESCAPES):
        best = min(probes, key=lambda p: p.score_ratio, default=None)
        if best is None or best.score_ratio >= ESCAPE_RATIO:
            break
        entry = (best.score_ratio * result.evidence["auto_edge_score"], best.camera, best.aligner, best.offset,
                 float(best.aligner.score(best.offset[None])[0]))
        again, again_probes = _finish([entry] + finals, 0.95, search)
        if again.evidence["auto_edge_score"] >= result.evidence["auto_edge_score"]:
            break
        moved = float(np.linalg.norm(np.subtract(best.camera.position, result.camera.position)))
        again.message += (f" The search went on from a camera {moved:.0f} m away that a position probe found to fit "
                          f"the photo's edges clearly better (edge score {again.evidence['auto_edge_score']:.3f} "
                          f"against {result.evidence['auto_edge_score']:.3f}).")
        again.evidence["auto_escapes"] = escape + 1
        result, probes, finals = again, again_probes, [entry] + finals
        state["camera"] = result.camera
    return result


def _probe_position(result: AutoFitResult, prior: Camera, photo: PhotoEdges, dem, sig: dict, evidence: dict,
                    is_canceled, done=None) -> list:
    """Cameras moved by the position σ and refined again (:func:`.fine.position_probes`): those that fit the edges
    nearly as well elsewhere are recorded as evidence; returns the probes.

    The σ is widened to cover every probe that fits the edges nearly as well (:data:`~.fine.PROBE_RATIO`), also one
    that moves the terrain too little to be a rival: where it ended, the edges no longer tell the cameras apart (a
    desktop trial's 24 MP photo: a probe 14 m ahead with the field of view 0.2 deg wider scored 1.02 times the
    camera, which was 22 m and 0.39 deg from the truth with σ ± 4.5 m and ± 0.08 deg)."""
    probes = position_probes(result.camera, prior, photo, dem, sig, is_canceled, _poll,
                             base=evidence["auto_edge_score"], done=done)
    alike = [p for p in probes if p.score_ratio <= PROBE_RATIO]
    result.std = widen_std(result.std, camera_values(result.camera), [camera_values(p.camera) for p in alike], {})
    rivals = [p for p in probes if p.rival]
    evidence["auto_probe_rivals"] = len(rivals)
    evidence["auto_probe_best_ratio"] = float(min(p.score_ratio for p in probes))
    evidence["auto_probe_returned"] = sum(p.returned for p in probes)
    if rivals:
        worst = max(rivals, key=lambda p: p.shift_px)
        evidence["auto_probe_shift_px"] = float(worst.shift_px)
        evidence["auto_probe_ratio"] = float(worst.score_ratio)
        evidence["auto_probe_distance_m"] = float(np.linalg.norm(np.subtract(worst.camera.position,
                                                                             result.camera.position)))
    return probes


def _typical_range(camera: Camera, dem) -> float:
    """Median distance (m) of the terrain over the picture (a 64 px wide z-buffer), NaN when none is seen."""
    from ..xyz import compute_xyz_full

    res = compute_xyz_full(camera.scaled(min(1.0, 64.0 / camera.width)), dem, visibility=False)
    d = res.distance[res.hit]
    return float(np.median(d)) if len(d) else float("nan")
