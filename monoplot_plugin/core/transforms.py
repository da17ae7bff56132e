"""Geometry between the photo and the map. Plain numpy, no shapely/OGR.

Geometries are numpy arrays: a point set is (N, 2) pixels or (N, 3) map coordinates; a line is one (N, 2) / (N, 3)
array; a polygon is a list of rings (the first is the outer ring; rings are not closed: the last vertex is not
repeated).

Photo -> map (:func:`photo_points_to_map`, :func:`photo_line_to_map`, :func:`photo_polygon_to_map`): each pixel
position's ray is intersected exactly with the terrain mesh (line of sight walked cell by cell, float64, see
:func:`~monoplot_plugin.core.xyz.segment_first_hit`), so a point drawn between pixel centres is as exact as one on a
centre. Lines are first densified along the pixel path (``step_px``), so that the map line follows the terrain.
Vertices whose ray meets no terrain (sky, voids, off the DEM) are dropped and the line is split there; it is also
split where consecutive samples jump in range (a silhouette: the line passes from a near ridge to a far slope). Pieces
are never joined across a gap; :class:`DropReport` says what was dropped.

Map -> photo (:func:`map_to_photo`): vertices are projected, and each is tested for occlusion by an exact line of
sight from the camera (terrain between them hides it); lines are densified in map units first so that hidden runs
are found.

Orthorectification (the photo draped onto the DEM grid) is :func:`monoplot_plugin.core.lookup.orthorectify`.

>>> import numpy as np
>>> from .camera import Camera
>>> from .dem import Dem
>>> dem = Dem.from_array(np.full((50, 50), 10.0), (0, 10, 0, 500, 0, -10))
>>> cam = Camera((250, 0, 110), heading=0, pitch=-30, roll=0, fov=60, image_size=(64, 48))
>>> xyz, ok = photo_points_to_map([[32.0, 40.0], [32.0, 1.0]], cam, dem)
>>> ok.tolist(), bool(np.allclose(cam.project(xyz[:1]), [[32.0, 40.0]]))
([True, False], True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

import numpy as np

from .camera import Camera
from .dem import Dem
from .xyz import segment_first_hit

__all__ = ["DropReport", "PhotoToMap", "MapToPhoto", "photo_points_to_map", "ground_error_m", "silhouette_crossings",
           "photo_line_to_map", "photo_polygon_to_map", "map_to_photo", "map_points_to_photo", "densify", "true_runs",
           "ground_pieces"]


@dataclass
class DropReport:
    """What a photo -> map conversion could not keep.

    Attributes:
        input_vertices: vertices given (after densification: samples tested).
        dropped: samples whose ray meets no terrain (sky, voids, off the DEM, behind the camera).
        splits_at_sky: number of places where a piece was cut because samples were dropped.
        splits_at_jumps: number of places where a piece was cut at a range jump (silhouette).
        short_pieces: pieces discarded because fewer than 2 samples (lines) remained.
        messages: human-readable lines.
    """

    input_vertices: int = 0
    dropped: int = 0
    splits_at_sky: int = 0
    splits_at_jumps: int = 0
    short_pieces: int = 0
    messages: List[str] = field(default_factory=list)

    @property
    def complete(self) -> bool:
        """True when nothing was dropped or split."""
        return self.dropped == 0 and self.splits_at_sky == 0 and self.splits_at_jumps == 0 and self.short_pieces == 0


@dataclass
class PhotoToMap:
    """Result of a photo -> map line or polygon conversion.

    Attributes:
        parts: list of (M, 3) float64 map-coordinate arrays (line pieces, or polygon rings when ``closed``).
        closed: for polygons: True when every ring was kept whole (``parts`` are then the rings, outer first);
            False when some ring had to be cut (``parts`` are then open line pieces of the outline).
        report: :class:`DropReport`.
    """

    parts: List[np.ndarray]
    closed: bool
    report: DropReport


@dataclass
class MapToPhoto:
    """One map part drawn on the photo.

    Attributes:
        uv: (N, 2) float64 pixels (NaN behind the camera).
        xyz: (N, 3) the map vertices used (densified, heights draped on the DEM mesh where z was not given).
        visible: (N,) bool: in front of the camera, inside the image and not hidden by terrain.
        occluded: (N,) bool: in front of the camera but hidden by terrain.
        in_image: (N,) bool.
    """

    uv: np.ndarray
    xyz: np.ndarray
    visible: np.ndarray
    occluded: np.ndarray
    in_image: np.ndarray

    def visible_runs(self) -> List[np.ndarray]:
        """(M, 2) pixel pieces of consecutive visible vertices (at least 2 each)."""
        return [self.uv[a:b] for a, b in true_runs(self.visible) if b - a >= 2]

    def hidden_runs(self) -> List[np.ndarray]:
        """(M, 2) pixel pieces of consecutive occluded vertices (for dashed drawing)."""
        return [self.uv[a:b] for a, b in true_runs(self.occluded & self.in_image) if b - a >= 2]


# ----------------------------------------------------------------------------------------------------------------
# helpers
# ----------------------------------------------------------------------------------------------------------------

def true_runs(mask: np.ndarray) -> List[Tuple[int, int]]:
    """[(start, stop), ...] of the runs of True in a 1-D bool array.

    >>> true_runs(np.array([True, True, False, True, False, False, True]))
    [(0, 2), (3, 4), (6, 7)]
    """
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    d = np.diff(m.astype(np.int8))
    starts = np.nonzero(d == 1)[0]
    stops = np.nonzero(d == -1)[0]
    return [(int(a), int(b)) for a, b in zip(starts, stops)]


def densify(vertices, step: float, closed: bool = False) -> np.ndarray:
    """Insert vertices so that consecutive ones are at most ``step`` apart (Euclidean in the first two coordinates;
    other coordinates interpolated linearly). Original vertices are kept; a segment with a non-finite end (a
    vertex a coordinate transform could not place) is kept as it is.

    >>> densify([[0.0, 0.0], [3.0, 0.0]], 1.0).tolist()
    [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]]
    >>> densify([[0.0, 0.0], [float("nan"), 0.0], [2.0, 0.0]], 1.0).shape
    (3, 2)
    """
    v = np.asarray(vertices, dtype=np.float64)
    if v.ndim != 2 or len(v) == 0:
        return v.reshape(-1, v.shape[-1] if v.ndim == 2 else 2)
    if closed:
        v = np.concatenate([v, v[:1]])
    out = [v[:1]]
    for a, b in zip(v[:-1], v[1:]):
        length = float(np.hypot(*(b[:2] - a[:2])))
        n = max(1, int(math.ceil(length / step))) if step > 0 and math.isfinite(length) else 1
        t = (np.arange(1, n + 1) / n)[:, None]
        out.append(a + (b - a) * t)
    res = np.concatenate(out)
    return res[:-1] if closed else res


def _far_distance(cam: Camera, dem: Dem) -> float:
    """A distance from the camera beyond every DEM vertex."""
    xmin, ymin, xmax, ymax = dem.bounds()
    zmin, zmax = dem.height_range()
    zmin, zmax = (0.0, 0.0) if math.isnan(zmin) else (zmin, zmax)
    cx, cy, cz = cam.position
    dx = max(abs(xmin - cx), abs(xmax - cx))
    dy = max(abs(ymin - cy), abs(ymax - cy))
    dz = max(abs(zmin - cz), abs(zmax - cz))
    return 1.01 * math.sqrt(dx * dx + dy * dy + dz * dz) + 1.0


def photo_points_to_map(uv, cam: Camera, dem: Dem) -> Tuple[np.ndarray, np.ndarray]:
    """Exact terrain points seen at pixel positions.

    Args:
        uv: (N, 2) pixel positions (any sub-pixel position; centres at +0.5).
    Returns:
        ((N, 3) float64 map coordinates, NaN rows where the ray meets no terrain; (N,) bool hit mask).
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    origin, dirs = cam.pixel_to_world_ray(uv)
    far = _far_distance(cam, dem)
    targets = origin + dirs * far
    s = segment_first_hit(dem, origin, targets, voids_stop=True)  # a ray meeting a void sees no ground
    ok = np.isfinite(s)
    xyz = np.where(ok[:, None], origin + dirs * (far * np.nan_to_num(s))[:, None], np.nan)
    refine = getattr(dem, "refine_hits", None)  # a DEM read by windows: traced on its preview, then at full resolution
    if refine is not None:
        xyz, ok = refine(origin, dirs, xyz, ok)
    return xyz, ok


def ground_error_m(uv, cam: Camera, dem: Dem, pixel_rmse: float, vertical: bool = False) -> np.ndarray:
    """Horizontal position error (metres, RMS) of the terrain point seen at each pixel, for a reprojection error of
    ``pixel_rmse`` pixels (RMS of the 2-D error, as a fit's check-point RMSE) in the photo; with ``vertical``, the
    error of its height instead (nil on flat ground, large where a pixel's footprint climbs a slope).

    The error is carried to the ground by the terrain's footprint of a pixel there:
    ``pixel_rmse / sqrt(2) * sqrt(|dXY/du|^2 + |dXY/dv|^2)``, the derivatives by central differences over
    ``pixel_rmse`` (at least 0.5 px, at most 16: the footprint at the scale of the error, so that a ridge's edge
    counts), one-sided where a neighbour sees no terrain. It grows with the range and where rays graze the terrain;
    it leaves out the DEM's own error.

    Args:
        uv: (N, 2) pixel positions; pixel_rmse: pixels, one for all or (N,) one per pixel (the camera's σ moves
            near ground more than far: :func:`~monoplot_plugin.core.fit.sigma_shifts`).
    Returns:
        (N,) metres; NaN where the pixel sees no terrain, or no neighbour along one axis does.

    >>> from .camera import Camera
    >>> from .dem import Dem
    >>> dem = Dem.from_array(np.zeros((200, 200)), (0, 10, 0, 2000, 0, -10))
    >>> cam = Camera((1000, 0, 100), heading=0, pitch=-20, roll=0, fov=60, image_size=(640, 480))
    >>> e = ground_error_m([[320, 240], [320, 200], [320, 1]], cam, dem, 2.0)  # centre, farther up, sky
    >>> f, r = 320 / math.tan(math.radians(30)), 100 / math.sin(math.radians(20))  # px; metres to the centre's
    >>> round(float(e[0]), 2), round(2 / math.sqrt(2) * math.hypot(r / f, r / f / math.sin(math.radians(20))), 2)
    (2.31, 2.31)
    >>> bool(e[1] > e[0]), bool(np.isnan(e[2]))
    (True, True)
    >>> e2 = ground_error_m([[320, 240], [320, 200]], cam, dem, np.array([2.0, 4.0]))  # one error per pixel
    >>> round(float(e2[0]), 2), round(float(e2[1] / e[1]), 2)
    (2.31, 2.0)
    >>> float(ground_error_m([[320, 240]], cam, dem, 2.0, vertical=True)[0])  # flat: the height stays
    0.0
    >>> rows = np.arange(200.0)[:, None] + 0.5
    >>> slope = Dem.from_array(0.5 * (2000.0 - 10.0 * rows) * np.ones((1, 200)), (0, 10, 0, 2000, 0, -10))
    >>> up, flat = (ground_error_m([[320, 240]], cam, slope, 2.0, vertical=v)[0] for v in (True, False))
    >>> bool(0.3 * flat < up < 0.5 * flat)  # rising 0.5 m per m ahead: half the error along the view
    True
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    n = len(uv)
    if n == 0:
        return np.zeros(0)
    pixel_rmse = np.broadcast_to(np.asarray(pixel_rmse, dtype=np.float64), (n,))
    h = np.clip(pixel_rmse, 0.5, 16.0)[:, None]  # (N, 1)
    offsets = np.array([[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1]], dtype=np.float64)
    ground, ok = photo_points_to_map((uv[None, :, :] + offsets[:, None, :] * h[None]).reshape(-1, 2), cam, dem)
    width = 1 if vertical else 2
    xy, ok = (ground[:, 2:] if vertical else ground[:, :2]).reshape(5, n, width), ok.reshape(5, n)

    def derivative(plus: int, minus: int) -> np.ndarray:
        both = ok[plus] & ok[minus]
        d = np.full((n, width), np.nan)
        d[both] = (xy[plus][both] - xy[minus][both]) / (2 * h[both])
        for side in (plus, minus):  # one-sided where the other neighbour sees the sky
            one = ~both & ok[side] & ok[0]
            d[one] = (xy[side][one] - xy[0][one]) / h[one]
        return d

    du, dv = derivative(1, 2), derivative(3, 4)
    error = pixel_rmse / math.sqrt(2.0) * np.sqrt(np.sum(du ** 2, axis=1) + np.sum(dv ** 2, axis=1))
    return np.where(ok[0], error, np.nan)


def ground_pieces(xyz: np.ndarray, ok: np.ndarray, origin, jump: float = 0.1) -> Tuple[List[Tuple[int, int]], int]:
    """Where a path of ground points must be cut: at samples that see no terrain, and where the range from the
    camera jumps by more than ``jump`` (relative) between consecutive samples (a silhouette: the path passes from a
    near ridge to a far slope, and joining them would cross hidden ground).

    Args:
        xyz: (N, 3) ground points along the path; ok: (N,) bool, the sample sees terrain; origin: (3,) camera.
    Returns:
        ([(start, stop), ...] index ranges of the pieces, number of cuts at range jumps).

    >>> xyz = np.array([[0, 100.0, 0], [0, 101.0, 0], [0, 300.0, 0], [0, 301.0, 0], [0, 0, 0]])
    >>> ground_pieces(xyz, np.array([True, True, True, True, False]), (0, 0, 0))
    ([(0, 2), (2, 4)], 1)
    """
    rng = np.linalg.norm(xyz - np.asarray(origin, dtype=np.float64), axis=1)
    pieces, jumps = [], 0
    for a, b in true_runs(ok):
        r = rng[a:b]
        big = np.flatnonzero(np.abs(np.diff(r)) > jump * np.minimum(r[:-1], r[1:]))
        jumps += len(big)
        cuts = [a, *(a + big + 1).tolist(), b]
        pieces.extend((int(p), int(q)) for p, q in zip(cuts[:-1], cuts[1:]))
    return pieces, jumps


def silhouette_crossings(ring_xyz: np.ndarray, origin, jump: float = 0.1) -> int:
    """How many times a closed outline of ground points (N, 3), the closing edge included, crosses a silhouette: the
    range from the camera jumps by more than ``jump`` (relative) between consecutive points, as where
    :func:`ground_pieces` cuts a line. A polygon drawn on the photo across a ridge joins a near slope to a far one:
    on the map it encloses the ground the ridge hides, and its area counts it.

    >>> silhouette_crossings(np.array([[0, 100.0, 0], [10, 100.0, 0], [10, 300.0, 0], [0, 300.0, 0]]), (0, 0, 0))
    2
    """
    ring = np.asarray(ring_xyz, dtype=np.float64).reshape(-1, 3)
    if len(ring) < 2:
        return 0
    closed = np.vstack([ring, ring[:1]])
    return ground_pieces(closed, np.ones(len(closed), dtype=bool), origin, jump)[1]


def _pieces(samples_uv: np.ndarray, cam: Camera, dem: Dem, jump: float, report: DropReport):
    xyz, ok = photo_points_to_map(samples_uv, cam, dem)
    report.input_vertices += len(samples_uv)
    report.dropped += int((~ok).sum())
    report.splits_at_sky += max(0, len(true_runs(ok)) - 1)
    pieces, jumps = ground_pieces(xyz, ok, cam.position, jump)
    report.splits_at_jumps += jumps
    return xyz, ok, pieces


def photo_line_to_map(line_uv, cam: Camera, dem: Dem, step_px: float = 1.0, jump: float = 0.1) -> PhotoToMap:
    """A line drawn on the photo as 3-D map pieces following the terrain.

    Args:
        line_uv: (N, 2) pixel vertices.
        step_px: densification step along the pixel path (pixels); 0 = keep the vertices only.
        jump: relative range change between consecutive samples that counts as a silhouette (cut there).
    Returns:
        :class:`PhotoToMap` with ``parts`` = list of (M, 3) pieces (M >= 2), ``closed`` False.
    """
    report = DropReport()
    samples = densify(line_uv, step_px) if step_px > 0 else np.asarray(line_uv, dtype=np.float64).reshape(-1, 2)
    xyz, ok, pieces = _pieces(samples, cam, dem, jump, report)
    parts = []
    for a, b in pieces:
        if b - a >= 2:
            parts.append(xyz[a:b])
        else:
            report.short_pieces += 1
    _messages(report, "line")
    return PhotoToMap(parts, False, report)


def photo_polygon_to_map(rings_uv: Sequence, cam: Camera, dem: Dem, step_px: float = 1.0,
                         jump: float = 0.1) -> PhotoToMap:
    """A polygon drawn on the photo (list of rings, outer first; or a single (N, 2) ring) as map rings.

    When every sample of every ring is on terrain and no ring crosses a silhouette, ``parts`` are the 3-D rings
    (outer first, not closed) and ``closed`` is True. Otherwise the polygon cannot be rebuilt faithfully: ``parts``
    are the open pieces of the outlines that are on terrain, ``closed`` is False, and the report says why.
    """
    if isinstance(rings_uv, np.ndarray) and rings_uv.ndim == 2:
        rings_uv = [rings_uv]
    report = DropReport()
    rings, pieces_all = [], []
    whole = True
    for ring in rings_uv:
        samples = densify(ring, step_px, closed=True) if step_px > 0 else np.asarray(ring, dtype=np.float64)
        closed_samples = np.concatenate([samples, samples[:1]])
        xyz, ok, pieces = _pieces(closed_samples, cam, dem, jump, report)
        if len(pieces) == 1 and pieces[0] == (0, len(closed_samples)):
            rings.append(xyz[:-1])
            pieces_all.append(xyz)
        else:
            whole = False
            for a, b in pieces:
                if b - a >= 2:
                    pieces_all.append(xyz[a:b])
                else:
                    report.short_pieces += 1
    _messages(report, "polygon")
    if whole:
        return PhotoToMap(rings, True, report)
    report.messages.append("the polygon crosses sky or a silhouette: returned as open outline pieces")
    return PhotoToMap(pieces_all, False, report)


def _messages(report: DropReport, what: str) -> None:
    if report.dropped:
        report.messages.append(f"{report.dropped} of {report.input_vertices} {what} samples see no terrain "
                               f"(sky, void or off the DEM) and were dropped")
    if report.splits_at_sky:
        report.messages.append(f"{what} cut in {report.splits_at_sky} place(s) where it crosses sky")
    if report.splits_at_jumps:
        report.messages.append(f"{what} cut in {report.splits_at_jumps} place(s) at a silhouette (range jump)")
    if report.short_pieces:
        report.messages.append(f"{report.short_pieces} piece(s) of a single sample discarded")


def map_to_photo(parts: Sequence, cam: Camera, dem: Dem, densify_m: Optional[float] = None,
                 tolerance_m: float = 1.0, rel_tolerance: float = 1e-4, closed: bool = False) -> List[MapToPhoto]:
    """Map geometry drawn onto the photo, with hidden parts flagged.

    Args:
        parts: list of (N, 2) or (N, 3) map-coordinate arrays (points, line parts or rings). 2-D vertices are
            draped on the DEM mesh (the surface the photo is intersected with); vertices off the DEM keep NaN z and
            are reported as not visible.
        densify_m: insert vertices every ``densify_m`` map units before projecting (None = half a DEM cell;
            0 = keep the vertices only), so that partly hidden segments are split where they disappear.
        tolerance_m, rel_tolerance: a vertex counts as hidden only when terrain meets its line of sight more than
            ``tolerance_m + rel_tolerance * range`` before it.
        closed: the parts are polygon rings (not closed): the closing edge is densified too (the ring stays unclosed).
    Returns:
        one :class:`MapToPhoto` per part. For scattered points use :func:`map_points_to_photo` (no densification).
    """
    step = dem.cell_size * 0.5 if densify_m is None else float(densify_m)
    out = []
    origin = np.asarray(cam.position, dtype=np.float64)
    for part in parts:
        p = np.asarray(part, dtype=np.float64)
        if p.ndim == 1:
            p = p[None]
        if step > 0 and len(p) >= 2:
            p = densify(p, step, closed=closed)
        if p.shape[1] == 2:
            p = np.column_stack([p, dem.sample(p[:, 0], p[:, 1], method="mesh")])
        uv, depth = cam.project_with_depth(p)
        front = depth > 0
        finite = np.isfinite(p).all(axis=1)
        s = segment_first_hit(dem, origin, np.where(finite[:, None], p, origin + 1.0))
        length = np.linalg.norm(p - origin, axis=1)
        with np.errstate(invalid="ignore"):
            blocked = np.isfinite(s) & (s * length < length - (tolerance_m + rel_tolerance * length))
        in_img = cam.in_image(uv) & front
        occluded = front & finite & blocked
        visible = in_img & finite & ~blocked
        out.append(MapToPhoto(uv=uv, xyz=p, visible=visible, occluded=occluded, in_image=in_img))
    return out


def map_points_to_photo(points, cam: Camera, dem: Dem, tolerance_m: float = 1.0,
                        rel_tolerance: float = 1e-4) -> MapToPhoto:
    """Scattered map points ((N, 2) draped on the DEM mesh, or (N, 3)) on the photo, with occlusion flags.

    >>> dem = Dem.from_array(np.zeros((20, 20)), (0, 10, 0, 200, 0, -10))
    >>> cam = Camera((100, -50, 30), heading=0, pitch=-10, roll=0, fov=60, image_size=(64, 48))
    >>> seen = map_points_to_photo([[100.0, 100.0], [100.0, 500.0]], cam, dem)
    >>> seen.visible.tolist(), bool(np.isnan(seen.xyz[1, 2]))   # the second point is off the DEM
    ([True, False], True)
    """
    return map_to_photo([np.asarray(points, dtype=np.float64)], cam, dem, densify_m=0.0, tolerance_m=tolerance_m,
                        rel_tolerance=rel_tolerance)[0]
