""":func:`register_any_heading`: the automatic registration of a photo whose direction of view is not known (a phone
picture with GPS but no compass tag, a print whose viewpoint is known but not where it looks).

1. Sweep: the horizon around the prior's position is cut into sectors as wide as the ordinary coarse search's
   heading range (:func:`sector_width`). In each sector that sees the DEM over at least half as much of its view as
   the best-covered one (:data:`MIN_SHARE_OF_BEST_VIEW`), and shows a skyline when the photo does, the DEM's skyline
   and contours are rendered once and the coarse grid of heading, pitch and field of view is scored against the
   photo's edges at 256 px (:class:`~.align.Aligner`, no pull to the prior: every sector is judged by the edges
   alone).
2. The best sectors (:data:`N_CANDIDATES`, at least a sector apart) are each registered by
   :func:`~.register.register_automatic` from the prior aimed at that sector's best view, with the prior's
   ordinary σ.
3. The registration whose camera fits the photo's edges best (``auto_edge_score``) is returned. Another candidate
   looking elsewhere that fits them nearly as well (:data:`~.sigma.RIVAL_RATIO`) makes an "ok" "uncertain": the
   photo's edges cannot tell the two directions apart, and the message names both.

Three to four times the time of one registration (the sweep itself is seconds).
"""

from __future__ import annotations

import math
import time
from typing import Callable, List, Optional, Tuple

import numpy as np

from ..camera import Camera
from ..fit import FitCanceled
from ..xyz.zbuffer import trial_cameras
from .align import Aligner, offsets_grid
from .dem_edges import coarse_dem, dem_edges, dem_in_view
from .photo_edges import detect_photo_edges
from .register import ALIGN_DEM_CELLS, MIN_VIEW_SEEN, WIDTHS, AutoFitResult, _sigmas, register_automatic
from .sigma import RIVAL_RATIO
from .verdict import NO_EDGES_SCORE

__all__ = ["register_any_heading", "sweep_headings", "sector_width", "N_CANDIDATES"]

#: Sectors of the sweep registered in full.
N_CANDIDATES = 3
#: A sector whose view sees the DEM over less than this share of the best-covered sector's is not searched.
MIN_SHARE_OF_BEST_VIEW = 0.5
#: A field of view known better than this (σ, degrees: a lens typed in and held) is the rough camera's in every
#: candidate, not the sweep's.
FOV_KNOWN_DEG = 0.5
#: Headings farther apart than this many σ of the angle are different directions of view (for the rival rule).
DISTINCT_SIGMAS = 3.0


def sector_width(angle_sigma_deg: float) -> float:
    """Width (degrees) of one sector of the sweep: the heading range of the ordinary coarse search (2.5 σ either
    side), so that the sectors tile the horizon as the prior's own search tiles its range.

    >>> sector_width(5.0), 360.0 / sector_width(5.0)
    (25.0, 14.4)
    """
    return 5.0 * float(angle_sigma_deg)


def sweep_headings(image: np.ndarray, dem, prior: Camera, sig: dict, is_canceled=None,
                   progress: Optional[Callable[[float, str], None]] = None) -> List[Tuple[float, float, float, float]]:
    """(score, heading, pitch, fov) of the best view in each sector around ``prior``'s position that sees the DEM,
    best first (score: :class:`~.align.Aligner`'s, lower is better). ``image``: (H, W, 3) uint8; ``sig``: the
    registration's σ (``angle_deg``, ``fov_deg``, ``position_m``)."""
    import cv2

    h, w = image.shape[:2]
    width = min(WIDTHS[0], w)
    small = image if w <= width else cv2.resize(image, (width, max(8, round(h * width / w))),
                                                interpolation=cv2.INTER_AREA)
    photo = detect_photo_edges(small, width=width)
    photo.scale = photo.width / float(w)
    align_dem = coarse_dem(dem, ALIGN_DEM_CELLS, is_canceled)
    sector = sector_width(sig["angle_deg"])
    n = int(math.ceil(360.0 / sector))
    margin = 0.5 * sector + 1.25 * sig["fov_deg"] + 2.0
    step = max(0.25, 4.0 * prior.fov / photo.width)
    grid = offsets_grid(sig, step, roll_steps=1)
    refs = [prior.with_parameters(heading=(prior.heading + k * 360.0 / n) % 360.0) for k in range(n)]
    seen = np.array([dem_in_view(ref, align_dem, 0.5 * sector) for ref in refs])
    found = []
    for k, ref in enumerate(refs):
        if is_canceled is not None and is_canceled():
            raise FitCanceled()
        if progress is not None:
            progress(k / n, "automatic registration: searching every direction of view")
        if seen[k] < max(MIN_VIEW_SEEN, MIN_SHARE_OF_BEST_VIEW * seen.max()):
            # a view off the DEM's edge onto a sliver of near terrain: its few edge points can match anything (the
            # dock's test scene, a camera at the DEM's south edge: 211° won, scored on a dozen contour points)
            continue
        edges = dem_edges(ref, align_dem, margin, ref.focal_px * photo.scale)
        if photo.usable and not len(edges.sky):
            continue  # no skyline of the DEM's this way to put on the photo's: the contours alone would be weighed
        al = Aligner(ref, photo, edges, sig, tau=6.0, is_canceled=is_canceled, max_points=700)
        al.with_prior = False  # each sector judged by the edges alone
        scores = al.score(grid)
        best = int(np.argmin(scores))
        dh, dp, _, df = grid[best, :4]
        found.append((float(scores[best]), (ref.heading + dh) % 360.0, ref.pitch + dp, ref.fov + df))
    return sorted(found)


def _heading_gap(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def register_any_heading(image, dem, prior: Camera, *, position_sigma_m: Optional[float] = None,
                         angle_sigma_deg: Optional[float] = None, fov_sigma_deg: Optional[float] = None,
                         eye_height_m: Optional[float] = None, hold_position: bool = False,
                         progress: Optional[Callable[[float, str], None]] = None,
                         is_canceled: Optional[Callable[[], bool]] = None) -> AutoFitResult:
    """:func:`~.register.register_automatic` for a ``prior`` whose heading says nothing (its position, height,
    pitch and field of view are used as in the ordinary registration). Arguments and result as there; the message
    starts by saying every direction was searched."""
    t0 = time.perf_counter()
    report = progress or (lambda f, m="": None)
    image = np.asarray(image)[..., :3]
    sig = _sigmas(prior, position_sigma_m, angle_sigma_deg, fov_sigma_deg)
    try:
        with trial_cameras():
            sectors = sweep_headings(image, dem, prior, sig, is_canceled, lambda f, m: report(0.15 * f, m))
    except FitCanceled:
        return AutoFitResult(prior, "canceled", "The automatic registration was canceled.", "unpaired",
                             aligned=prior)
    candidates = []
    for sector in sectors:
        if all(_heading_gap(sector[1], c[1]) >= sector_width(sig["angle_deg"]) for c in candidates):
            candidates.append(sector)
        if len(candidates) >= N_CANDIDATES:
            break
    if not candidates:  # no direction sees the DEM: the ordinary registration says so
        return register_automatic(image, dem, prior, position_sigma_m=position_sigma_m,
                                  angle_sigma_deg=angle_sigma_deg, fov_sigma_deg=fov_sigma_deg,
                                  eye_height_m=eye_height_m, hold_position=hold_position, progress=progress,
                                  is_canceled=is_canceled)
    results = []
    for i, (_, heading, pitch, fov) in enumerate(candidates):
        if sig["fov_deg"] < FOV_KNOWN_DEG:
            fov = prior.fov  # a lens typed in stays as known, not the sweep's (a trial: 0.137° off with 0.02° held)
        part = (0.15 + 0.85 * i / len(candidates), 0.85 / len(candidates))
        result = register_automatic(
            image, dem, prior.with_parameters(heading=heading, pitch=pitch, fov=fov),
            position_sigma_m=position_sigma_m, angle_sigma_deg=angle_sigma_deg, fov_sigma_deg=fov_sigma_deg,
            eye_height_m=eye_height_m, hold_position=hold_position,
            progress=lambda f, m="", part=part: report(part[0] + part[1] * f, m), is_canceled=is_canceled)
        if result.status == "canceled":
            return result
        results.append(result)
    best = _best_of(results, sig, len(sectors))
    best.elapsed_s = time.perf_counter() - t0  # the whole search, not the chosen registration's part
    return best


#: how the message of a search of every direction begins (the workflow leaves it out where a direction was given)
UNKNOWN_HEADING_WORDS = "The direction of view was not known: "


def _edge(result) -> float:
    value = result.evidence.get("auto_edge_score", float("inf"))
    return float(value) if np.isfinite(value) else float("inf")


def _best_of(results: List[AutoFitResult], sig: dict, n_sectors: int) -> AutoFitResult:
    """The result whose camera fits the photo's edges best, doubted when another direction fits them nearly as well."""
    results = sorted(results, key=_edge)
    best = results[0]
    head = (f"{UNKNOWN_HEADING_WORDS}{n_sectors} directions around the position that see the DEM "
            f"were searched and the best {len(results)} registered; this one fits the photo's edges best "
            f"(edge score {_edge(best):.3f}).")
    if _edge(best) >= NO_EDGES_SCORE:  # 1 is no match at all: "best" would say what it is not (a quarry trial)
        head = (f"{UNKNOWN_HEADING_WORDS}{n_sectors} directions around the position that see the DEM "
                f"were searched and the best {len(results)} registered; in none do the DEM's edges match the "
                f"photo's (edge score {_edge(best):.3f}, 1 for no match).")
    rivals = [r for r in results[1:] if _edge(r) <= RIVAL_RATIO * _edge(best)
              and _heading_gap(r.camera.heading, best.camera.heading) > DISTINCT_SIGMAS * sig["angle_deg"]]
    best.evidence["auto_heading_searched"] = True
    best.evidence["auto_heading_rivals"] = len(rivals)
    if rivals:
        r = rivals[0]
        doubt = (f"Uncertain: a camera looking {_heading_gap(r.camera.heading, best.camera.heading):.0f} deg "
                 f"elsewhere (heading {r.camera.heading:.0f} deg) fits the photo's edges almost as well (edge score "
                 f"{_edge(r):.3f}): give the direction of view, or pair a few points you recognise.")
        if best.status == "ok":
            best.status = "uncertain"
        best.weak.append(doubt.rstrip("."))
        best.message = f"{head} {doubt} {best.message}"
    else:
        best.message = f"{head} {best.message}"
    return best
