"""The registration's fine stage, the edge score that judges its cameras, and position probes.

- :func:`refine_fine`: a camera refined at full working size by the edge alignment (:mod:`.align`), the distance
  scale shrinking round by round and the DEM's edges rendered again from where each round ends.
- :func:`edge_score`: how well the DEM's skyline and contours seen from a camera fall on the photo's edges (lower is
  better), without the pull to the prior: the one score that compares cameras at different positions.
- :func:`position_probes`: edges seen from afar pin the view direction well and the position poorly. A camera moved
  by the prior's position σ (ahead, behind, left, right), turned to look at the same terrain and refined again,
  either finds its way back, or ends elsewhere. One that ends elsewhere with nearly the same edge score, and puts
  the terrain more than 1 % of the picture's diagonal away from where the camera returned puts it, is a camera the
  photo's edges cannot tell apart from it: the registration is then "uncertain" and its σ covers the probe.
- :func:`terrain_shift_px`: how far apart two cameras put the same terrain in the picture.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..camera import Camera
from .align import Aligner, camera_from_offset, ground_heights
from .dem_edges import dem_edges
from .photo_edges import PhotoEdges

__all__ = ["refine_fine", "edge_score", "position_probes", "terrain_shift_px", "offset_between", "Probe",
           "grounded_height_sigma",
           "FINE_ROUNDS", "CHECK_TAU", "PROBE_RATIO", "PROBE_SHIFT"]

#: (distance scale in working px, step factor) of the fine rounds.
FINE_ROUNDS = ((8.0, 0.5), (4.0, 0.25), (2.5, 0.1))
#: A pass of :func:`refine_fine` that moves the camera by at most this share of the prior's position σ: settled.
PASS_SETTLED = 0.01
#: Distance scale (px per 1024 working px) of :func:`edge_score`.
CHECK_TAU = 4.0
#: Share of the picture (its width or height) the DEM's edges must span for :func:`edge_score` to count their match
#: in full; less counts in proportion (a patch of edges is weak evidence of a view).
EDGE_SPREAD_FULL = 0.3
#: A probe whose edge score is at most this many times the returned camera's fits the edges "nearly as well".
#: Measured on 38 synthetic scenes with the default σ: probes that found their way back (under 3 px) scored
#: 0.99-1.11 of the camera; wrong "ok" cameras had probes 13-78 px away at 0.96-1.14.
PROBE_RATIO = 1.15
#: Least shift of the terrain (share of the picture's diagonal) for a probe to count as a different camera.
PROBE_SHIFT = 0.01


@dataclass
class Probe:
    """A position probe: where it ended, its edge score over the camera's, the terrain's shift (px) between them."""

    camera: Camera
    score_ratio: float
    shift_px: float
    #: the last fine round's :class:`Aligner` and the offset from its reference to ``camera``
    aligner: Optional[Aligner] = None
    offset: Optional[np.ndarray] = None

    @property
    def returned(self) -> bool:
        """True when the probe came back to the camera, for the picture (within :data:`PROBE_SHIFT` of the
        diagonal)."""
        w, h = self.camera.image_size
        return self.shift_px <= PROBE_SHIFT * math.hypot(w, h)

    @property
    def rival(self) -> bool:
        """True when the probe fits the edges nearly as well and moves the terrain visibly."""
        w, h = self.camera.image_size
        return self.score_ratio <= PROBE_RATIO and self.shift_px > PROBE_SHIFT * math.hypot(w, h)


def grounded_height_sigma(dem, camera: Camera, std: dict) -> float:
    """σ (m) of the height of a camera held on the ground: the terrain's rise over the position's σ (``std``'s x and
    y) at its position, and 1 m for the eye height (a re-check trial read "Z ± 200" of a camera held 2 m up)."""
    x, y, _ = camera.position
    sx, sy = float(std.get("x", 0.0)), float(std.get("y", 0.0))
    z = np.asarray(dem.sample(np.array([x + sx, x - sx, x, x]), np.array([y, y, y + sy, y - sy])),
                   dtype=np.float64).reshape(-1)
    dx, dy = 0.5 * (z[0] - z[1]), 0.5 * (z[2] - z[3])
    rise = math.hypot(dx if np.isfinite(dx) else 0.0, dy if np.isfinite(dy) else 0.0)
    return float(math.hypot(rise, 1.0))


def offset_between(cam: Camera, ref: Camera) -> np.ndarray:
    """The offsets vector (see :mod:`.align`) that takes ``cam`` to ``ref``."""
    d = np.subtract(ref.position, cam.position)
    return np.array([(ref.heading - cam.heading + 180.0) % 360.0 - 180.0, ref.pitch - cam.pitch,
                     ref.roll - cam.roll, ref.fov - cam.fov, d[0], d[1], d[2]])


def fine_steps(sig: dict) -> tuple:
    """(steps, least steps) of the compass search over the offsets, from the prior's σ."""
    steps = np.array([1.0, 1.0, 1.0, 1.0] + [0.5 * sig["position_m"]] * 3)
    mins = np.array([0.1, 0.1, 0.1, 0.1] + [0.05 * sig["position_m"]] * 3)
    return steps, mins


def refine_fine(cam: Camera, prior: Camera, photo: PhotoEdges, dem, sig: dict, is_canceled=None,
                poll=None, passes: int = 1) -> tuple:
    """``cam`` refined at ``photo``'s working size: (camera, the last round's :class:`Aligner`, the offset from
    that aligner's reference to the camera). A wide distance scale first smooths the score's shallow minima.

    Each round scores cameras against the DEM's edges rendered from where the round starts; near terrain changes
    its silhouette as the camera moves, so one pass of the rounds cannot walk far in position. ``passes``: the
    rounds start over, from wide to narrow again, up to this many times (fewer when a pass no longer moves the
    camera by :data:`PASS_SETTLED` of the prior's position σ)."""
    steps, mins = fine_steps(sig)
    for _ in range(max(1, passes)):
        start = np.asarray(cam.position, dtype=np.float64)
        for tau, scale in FINE_ROUNDS:
            if poll is not None:
                poll(is_canceled)
            edges = dem_edges(cam, dem, 2.0, cam.focal_px * photo.scale)
            al = Aligner(cam, photo, edges, sig, tau=tau, prior_offset=offset_between(cam, prior),
                         is_canceled=is_canceled, max_points=1200)
            off, _ = al.pattern_search(np.zeros(7), steps * scale, mins * scale, max_iter=30)
            off, _ = al.least_squares(off)
            cam = camera_from_offset(cam, off, sig.get("ground"))
        if np.linalg.norm(np.asarray(cam.position) - start) <= PASS_SETTLED * sig["position_m"]:
            break
    return cam, al, off


def edge_score(camera: Camera, photo: PhotoEdges, dem, sig: dict, is_canceled=None) -> float:
    """How well the DEM's skyline and contours seen from ``camera`` fall on the photo's (lower is better, 0..1 and
    more): the aligner's score without the pull to the prior, its match (1 - score) counted in proportion to the
    share of the picture the edges span (:meth:`~.align.Aligner.edge_spread`) up to :data:`EDGE_SPREAD_FULL`."""
    edges = dem_edges(camera, dem, 1.0, camera.focal_px * photo.scale)
    al = Aligner(camera, photo, edges, sig, tau=CHECK_TAU * photo.width / 1024.0, is_canceled=is_canceled,
                 max_points=2000)
    al.with_prior = False
    score = float(al.score(np.zeros((1, 7)))[0])
    # Edges that fill a patch of the picture match its edges there by chance as well as not: the match counts in
    # proportion to the share spanned, up to EDGE_SPREAD_FULL (a trial's rough camera 84° off in heading: a camera
    # 800 m up whose few contours, in a tenth of the picture's width, sat on the photo's edges scored 0.016, the
    # true camera 0.62, and it was returned).
    spread = al.edge_spread(np.zeros(7))
    return score + max(0.0, 1.0 - score) * (1.0 - min(1.0, spread / EDGE_SPREAD_FULL))


def _terrain(camera: Camera, dem, width: float = 24.0) -> np.ndarray:
    """(N, 3) terrain points ``camera`` sees on a grid ``width`` pixels wide."""
    from ..xyz import compute_xyz_full

    res = compute_xyz_full(camera.scaled(min(1.0, width / camera.width)), dem, visibility=False)
    return res.xyz[res.hit]


def terrain_shift_px(other: Camera, camera: Camera, dem, seen=None) -> float:
    """RMS distance (full-size px) between where ``other`` and ``camera`` put the terrain ``camera`` sees (a grid
    24 px wide; ``seen``: those points when already known); NaN when it sees none."""
    xyz = _terrain(camera, dem) if seen is None else seen
    if not len(xyz):
        return float("nan")
    d2 = np.sum((other.project(xyz) - camera.project(xyz)) ** 2, axis=1)
    d2 = d2[np.isfinite(d2)]  # behind ``other``: no pixel (a phone photo's probe: a warning in QGIS's log)
    return float(np.sqrt(np.mean(d2))) if len(d2) else float("nan")


def aimed_from(camera: Camera, position, dem, seen=None) -> Camera:
    """``camera`` moved to ``position`` and turned (heading, pitch) to look at the terrain it looked at (a grid 32 px
    wide; ``seen``: those points when already known)."""
    xyz = _terrain(camera, dem, width=32.0) if seen is None else seen
    if not len(xyz):
        return camera.with_parameters(x=position[0], y=position[1], z=position[2])
    target = np.median(xyz, axis=0)
    d0, d1 = target - np.asarray(camera.position), target - np.asarray(position)

    def angles(d):
        return math.degrees(math.atan2(d[0], d[1])), math.degrees(math.atan2(d[2], math.hypot(d[0], d[1])))

    (h0, p0), (h1, p1) = angles(d0), angles(d1)
    return camera.with_parameters(x=position[0], y=position[1], z=position[2], heading=camera.heading + h1 - h0,
                                  pitch=camera.pitch + p1 - p0)


def position_probes(camera: Camera, prior: Camera, photo: PhotoEdges, dem, sig: dict, is_canceled=None,
                    poll=None, base=None, done=None) -> list:
    """Four :class:`Probe` from ``camera`` moved by the prior's position σ ahead, behind, left and right, each aimed
    at the same terrain and refined by :func:`refine_fine` (bounded by the prior's σ as the search is). ``base``:
    ``camera``'s :func:`edge_score` when already known; ``done(fraction)``, when given, after each probe (the bar
    stood still at 90 % for 36 s over a 100 M-cell DEM)."""
    base = edge_score(camera, photo, dem, sig, is_canceled) if base is None else base
    h = math.radians(camera.heading)
    ahead = np.array([math.sin(h), math.cos(h), 0.0])
    left = np.array([-ahead[1], ahead[0], 0.0])
    aimed_at, shown = _terrain(camera, dem, width=32.0), _terrain(camera, dem)  # once for the four probes
    probes = []
    for direction in (ahead, -ahead, left, -left):
        to = np.asarray(camera.position) + sig["position_m"] * direction
        if sig.get("ground") is not None:  # a camera on the ground moves along it (on this DEM)
            to[2] = ground_heights((dem, sig["ground"][1]), [to[0]], [to[1]], [to[2]])[0]
        start = aimed_from(camera, to, dem, aimed_at)
        ended, al, off = refine_fine(start, prior, photo, dem, sig, is_canceled, poll)
        score = edge_score(ended, photo, dem, sig, is_canceled)
        probes.append(Probe(ended, score / base if base > 0 else float("inf"),
                            terrain_shift_px(ended, camera, dem, shown), al, off))
        if done is not None:
            done(len(probes) / 4.0)
    return probes
