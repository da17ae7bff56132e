"""Photo <-> map geometry for the outputs, driven by the per-pixel XYZ raster.

The XYZ raster (core's depth-buffer rasteriser, or a file read with :func:`.xyz_raster.read_xyz_raster`) already
answers "which ground point does this pixel see" for every pixel, including occlusion, so digitised features are
looked up in it rather than re-intersected with the DEM: a feature written to a map layer always agrees with the XYZ
raster the user can identify-click.

Pixel convention (see :mod:`monoplot_plugin.core.camera`): ``u`` = column, ``v`` = row, pixel (row i, column j)
covers ``[j, j+1) x [i, i+1)``, so the lookup of ``(u, v)`` is pixel ``(floor(v), floor(u))``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..core.transforms import ground_pieces, true_runs
from .vectors import MapFeature

__all__ = ["sample_xyz", "densify", "photo_to_map_feature", "PhotoPath", "map_to_photo",
           "visibility_of_points", "orthorectify"]


def sample_xyz(xyz: np.ndarray, uv, origin=None, max_jump: float = 0.05) -> np.ndarray:
    """Ground points seen through photo positions.

    Without ``origin``: the value of the pixel that contains each position (nearest). With ``origin`` (the camera
    centre): bilinear between the four surrounding pixel centres where they lie on one continuous surface (their
    distances to the camera differ by at most ``max_jump`` of the nearest one), nearest elsewhere, so points are
    sub-pixel accurate on slopes and never smeared across an occluding ridge or into the sky.

    Args:
        xyz: (H, W, 3) per-pixel map coordinates, NaN for sky.
        uv: (N, 2) photo positions (pixels, module convention).
        origin: optional (3,) camera centre in map coordinates.
    Returns:
        (N, 3) map coordinates; NaN rows for sky, no DEM, or outside the photo.

    >>> xyz = np.arange(2 * 3 * 3, dtype=float).reshape(2, 3, 3)
    >>> sample_xyz(xyz, [[2.9, 1.0], [5.0, 0.0]]).tolist()[0], bool(np.isnan(sample_xyz(xyz, [[5.0, 0.0]])).all())
    ([15.0, 16.0, 17.0], True)
    >>> sample_xyz(xyz, [[1.0, 1.0]], origin=(1e3, 0.0, 0.0)).tolist()  # between four pixel centres
    [[6.0, 7.0, 8.0]]
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    height, width = xyz.shape[:2]
    out = np.full((len(uv), 3), np.nan)
    with np.errstate(invalid="ignore"):
        cols = np.floor(uv[:, 0])
        rows = np.floor(uv[:, 1])
        inside = (cols >= 0) & (cols < width) & (rows >= 0) & (rows < height)
    out[inside] = xyz[rows[inside].astype(int), cols[inside].astype(int)]
    if origin is None or height < 2 or width < 2 or not inside.any():
        return out
    idx = np.flatnonzero(inside)
    fc = np.clip(uv[idx, 0] - 0.5, 0, width - 1)  # pixel centres on integers
    fr = np.clip(uv[idx, 1] - 0.5, 0, height - 1)
    c0 = np.minimum(np.floor(fc).astype(int), width - 2)
    r0 = np.minimum(np.floor(fr).astype(int), height - 2)
    s, t = (fc - c0)[:, None], (fr - r0)[:, None]
    corners = [xyz[r0, c0], xyz[r0, c0 + 1], xyz[r0 + 1, c0], xyz[r0 + 1, c0 + 1]]
    dist = np.stack([np.linalg.norm(p - np.asarray(origin, dtype=np.float64), axis=1) for p in corners], axis=1)
    with np.errstate(invalid="ignore"):
        smooth = np.isfinite(dist).all(axis=1) & (dist.max(axis=1) - dist.min(axis=1) <= max_jump * dist.min(axis=1))
        smooth &= np.isfinite(out[idx]).all(axis=1)
    blend = (corners[0] * (1 - s) * (1 - t) + corners[1] * s * (1 - t) + corners[2] * (1 - s) * t
             + corners[3] * s * t)
    out[idx[smooth]] = blend[smooth]
    return out


def densify(vertices, step: float, closed: bool = False) -> np.ndarray:
    """Insert points so that consecutive points are at most ``step`` apart (any dimension); ``step <= 0`` keeps
    the vertices (a ring is still closed).

    >>> densify([[0, 0], [3, 0]], 1.0).tolist()
    [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]]
    """
    pts = np.asarray(vertices, dtype=np.float64)
    if closed and len(pts) > 1 and not np.array_equal(pts[0], pts[-1]):
        pts = np.vstack([pts, pts[:1]])
    if len(pts) < 2 or step <= 0:
        return pts.copy()
    out = [pts[:1]]
    for a, b in zip(pts[:-1], pts[1:]):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        t = np.arange(1, n + 1)[:, None] / n
        out.append(a + (b - a) * t)
    return np.vstack(out)


def photo_to_map_feature(kind: str, vertices, xyz: Optional[np.ndarray] = None, attributes: Optional[dict] = None,
                         step_px: float = 1.0, origin=None, *, camera=None, dem=None,
                         jump: float = 0.1) -> Optional[MapFeature]:
    """A feature digitised on the photo as a 3-D map feature.

    Lines and polygon outlines are densified to ``step_px`` pixels first, so they follow the terrain. Pieces over
    sky (or off the DEM) are split off and counted in ``sky_parts``:

    - point: None when it is over sky;
    - line: one part per run of ground samples of at least 2 points, also cut where the range jumps by more than
      ``jump`` (a silhouette: the line passes from a near ridge to a far slope);
    - polygon: the ring keeps its ground samples (it closes across a gap); None when fewer than 3 remain.

    Ground points come from core's exact ray-terrain intersection
    (:func:`monoplot_plugin.core.transforms.photo_points_to_map`) when ``camera`` and ``dem`` are given, else from
    the per-pixel XYZ raster ``xyz`` (:func:`sample_xyz`, sub-pixel when ``origin`` is given).

    Args:
        kind: "point", "line" or "polygon".
        vertices: (N, 2) photo vertices (pixels).
        xyz: (H, W, 3) per-pixel map coordinates, NaN for sky (needed without camera and dem).
        attributes: user field values.
        step_px: densification step along lines and outlines (pixels).
        origin: the camera centre, for sub-pixel XYZ lookups and the silhouette test.
        camera, dem: the fitted Camera and core Dem, for exact intersections.
        jump: relative range jump between consecutive samples that cuts a line.
    Returns:
        a :class:`MapFeature`, or None when nothing of the feature is on the ground.
    """
    attributes = dict(attributes or {})
    verts = np.asarray(vertices, dtype=np.float64).reshape(-1, 2)
    if camera is not None and dem is not None:
        from ..core.transforms import photo_points_to_map

        origin = camera.position

        def lookup(uv):
            return photo_points_to_map(uv, camera, dem)[0]
    elif xyz is not None:
        def lookup(uv):
            return sample_xyz(xyz, uv, origin)
    else:
        raise ValueError("give camera and dem, or the XYZ raster")
    if kind == "point":
        ground = lookup(verts[:1])
        if not np.isfinite(ground).all():
            return None
        return MapFeature("point", [ground], attributes)
    if kind not in ("line", "polygon"):
        raise ValueError(f"kind must be point, line or polygon, got {kind!r}")
    dense = densify(verts, step_px, closed=(kind == "polygon"))
    ground = lookup(dense)
    valid = np.isfinite(ground).all(axis=1)
    if kind == "polygon":
        ring_valid = valid[:-1]  # the closing point repeats the first
        sky = len(true_runs(~ring_valid))
        if sky > 1 and not ring_valid[0] and not ring_valid[-1]:
            sky -= 1  # a sky run across the ring's start is one piece
        ring = _drop_repeats(ground[:-1][ring_valid])
        if len(ring) < 3:
            return None
        return MapFeature("polygon", [ring], attributes, sky_parts=sky)
    pieces = ground_pieces(ground, valid, origin, jump)[0] if origin is not None else true_runs(valid)
    parts = [_drop_repeats(ground[p:q]) for p, q in pieces]
    parts = [p for p in parts if len(p) >= 2]
    sky = len(true_runs(~valid))
    if not parts:
        return None
    return MapFeature("line", parts, attributes, sky_parts=sky)


def _drop_repeats(points: np.ndarray) -> np.ndarray:
    """Remove consecutive duplicates (several densified points fall in one pixel)."""
    if len(points) < 2:
        return points
    keep = np.concatenate([[True], np.any(np.diff(points, axis=0) != 0, axis=1)])
    return points[keep]


def visibility_of_points(camera, points: np.ndarray, xyz: np.ndarray, tolerance: Optional[float] = None
                         ) -> Tuple[np.ndarray, np.ndarray]:
    """Project ground points into the photo and tell which ones the camera sees.

    A point is visible when it projects inside the photo and is not farther from the camera than the ground seen
    through that pixel (the XYZ raster's point), within ``tolerance`` metres (default: 1 % of the distance plus
    the XYZ raster's pixel footprint there, which absorbs the 1-pixel quantisation of the depth buffer).

    Returns:
        (uv (N, 2) pixels, NaN behind the camera; visible (N,) bool).
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    uv, depth = camera.project_with_depth(points)
    seen = sample_xyz(xyz, uv, camera.position)
    origin = np.asarray(camera.position)
    d_point = np.linalg.norm(points - origin, axis=1)
    d_seen = np.linalg.norm(seen - origin, axis=1)
    footprint = d_seen / camera.focal_px  # metres per pixel at that distance, face-on
    tol = (0.01 * d_point + 3.0 * footprint) if tolerance is None else tolerance
    with np.errstate(invalid="ignore"):
        visible = (depth > 0) & camera.in_image(uv) & np.isfinite(d_seen) & (d_point <= d_seen + tol)
    return uv, visible


@dataclass
class PhotoPath:
    """A map line drawn on the photo: (M, 2) pixel vertices, each visible, hidden behind terrain, or neither
    (behind the camera, outside the photo, off the DEM)."""

    uv: np.ndarray
    visible: np.ndarray
    occluded: np.ndarray

    def pieces(self) -> List[Tuple[np.ndarray, bool]]:
        """Consecutive drawable runs as (uv (k, 2), visible) pieces: visible ones solid, hidden ones dashed. Pieces
        share their end points, so a dashed piece joins the solid ones; the rest is left out."""
        drawable = (self.visible | self.occluded) & np.isfinite(self.uv).all(axis=1)
        out = []
        for a, b in true_runs(drawable):
            vis = self.visible[a:b]
            change = np.flatnonzero(np.diff(vis.astype(np.int8))) + 1
            bounds = [0, *change.tolist(), b - a]
            for s, e in zip(bounds[:-1], bounds[1:]):
                piece = self.uv[a + s: a + min(e + 1, b - a)]
                if len(piece) >= 2:
                    out.append((piece, bool(vis[s])))
        return out


def map_to_photo(parts_xy: Sequence[np.ndarray], camera, dem, step: Optional[float] = None) -> List[PhotoPath]:
    """Map lines or polygon rings drawn onto the photo, each vertex flagged visible or hidden.

    Core's :func:`monoplot_plugin.core.transforms.map_to_photo` does the work (exact line of sight to every
    vertex); this wraps its result for drawing.

    Args:
        parts_xy: list of (N, 2) or (N, 3) map coordinate arrays (rings should repeat their first vertex). 2-D
            outlines are draped on the terrain.
        camera: the photo's Camera.
        dem: the :class:`~monoplot_plugin.core.dem.Dem` (same CRS as the layer: reproject the layer first).
        step: densification in map units (default: half a DEM cell) so the drawn line follows the terrain and
            hidden runs are found.
    Returns:
        one :class:`PhotoPath` per input part.
    """
    from ..core.transforms import map_to_photo as core_map_to_photo

    parts = [np.asarray(p, dtype=np.float64) for p in parts_xy]
    return [PhotoPath(r.uv, r.visible, r.occluded & r.in_image)
            for r in core_map_to_photo(parts, camera, dem, densify_m=step)]


def orthorectify(photo: np.ndarray, camera, dem, xyz: np.ndarray) -> np.ndarray:
    """The photo draped onto the DEM grid.

    Every DEM cell centre (on the terrain) is projected into the photo; it takes the colour of that photo pixel
    when the camera sees it (:func:`visibility_of_points`).

    Args:
        photo: (H, W) or (H, W, bands) uint8 photo.
        camera: the photo's Camera (image_size must match the photo).
        dem: the :class:`~monoplot_plugin.core.dem.Dem` to drape onto (its grid and CRS are the orthophoto's).
        xyz: (H, W, 3) per-pixel map coordinates of the photo (for occlusion).
    Returns:
        (rows, cols, bands + 1) uint8: photo bands then an alpha band (255 seen, 0 unseen: nodata).
    """
    photo = np.asarray(photo)
    if photo.ndim == 2:
        photo = photo[..., None]
    if photo.shape[1] != camera.width or photo.shape[0] != camera.height:
        raise ValueError(f"photo is {photo.shape[1]}x{photo.shape[0]} px, camera expects {camera.image_size}")
    rows, cols = dem.elevation.shape
    pts = dem.vertices().reshape(-1, 3)
    out = np.zeros((rows * cols, photo.shape[2] + 1), dtype=np.uint8)
    finite = np.isfinite(pts[:, 2])
    uv, visible = visibility_of_points(camera, pts[finite], xyz)
    idx = np.flatnonzero(finite)[visible]
    uv = uv[visible]
    r = np.clip(np.floor(uv[:, 1]).astype(int), 0, camera.height - 1)
    c = np.clip(np.floor(uv[:, 0]).astype(int), 0, camera.width - 1)
    out[idx, :-1] = photo[r, c]
    out[idx, -1] = 255
    return out.reshape(rows, cols, -1)
