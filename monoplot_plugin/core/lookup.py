"""What the per-pixel XYZ raster answers: the ground seen through photo positions, whether map points are seen,
and the photo draped onto the DEM grid (the orthophoto). The raster is core's z-buffer
(:func:`~monoplot_plugin.core.xyz.compute_xyz`), or a file read back by the outputs.

Pixel convention (see :mod:`monoplot_plugin.core.camera`): ``u`` = column, ``v`` = row, pixel (row i, column j)
covers ``[j, j+1) x [i, i+1)``, so the lookup of ``(u, v)`` is pixel ``(floor(v), floor(u))``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Callable, Optional, Tuple

import numpy as np

__all__ = ["sample_xyz", "visibility_of_points", "farthest_around", "orthorectify", "OrthoLookup", "ortho_lookup",
           "TurnableLookup", "turnable_lookup", "widened"]


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


def visibility_of_points(camera, points: np.ndarray, xyz: np.ndarray, tolerance: Optional[float] = None,
                         dem=None, far: Optional[Callable[[], np.ndarray]] = None) -> Tuple[np.ndarray, np.ndarray]:
    """Project ground points into the photo and tell which ones the camera sees.

    A point is visible when it projects inside the photo and is not farther from the camera than the ground seen
    through that pixel (the XYZ raster's point), within ``tolerance`` metres (default: 1 % of the distance plus
    the XYZ raster's pixel footprint there, which absorbs the 1-pixel quantisation of the depth buffer).

    Terrain seen at a grazing angle spans far more depth in one pixel than that, and an orthophoto of a low camera
    over flat ground had stripes of its seen cells left out. So with ``dem`` (the terrain the raster was made of), a
    point that fails the test but lies no farther than the farthest ground seen through the neighbouring pixels
    (:func:`farthest_around` of ``xyz``, made only when a point needs it; ``far()`` gives it instead, for a caller
    that tests many blocks of points against one raster) is decided by the exact line of sight
    (:func:`~monoplot_plugin.core.xyz.segment_first_hit`): seen when nothing stops the ray before it, within the
    same tolerance. A point beyond all of them is hidden whatever the angle.

    Returns:
        (uv (N, 2) pixels, NaN behind the camera; visible (N,) bool).
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    uv, depth = camera.project_with_depth(points)
    seen = sample_xyz(xyz, uv, camera.position)
    origin = np.asarray(camera.position, dtype=np.float64)
    d_point = np.linalg.norm(points - origin, axis=1)
    d_seen = np.linalg.norm(seen - origin, axis=1)
    footprint = d_seen / camera.focal_px  # metres per pixel at that distance, face-on
    tol = (0.01 * d_point + 3.0 * footprint) if tolerance is None else tolerance
    tol = np.broadcast_to(np.asarray(tol, dtype=np.float64), d_point.shape)
    with np.errstate(invalid="ignore"):
        candidate = (depth > 0) & camera.in_image(uv) & np.isfinite(d_seen)
        visible = candidate & (d_point <= d_seen + tol)
    if dem is not None:
        failed = np.flatnonzero(candidate & ~visible)
        if failed.size:
            farthest = farthest_around(xyz, origin) if far is None else far()
            r = np.clip(np.floor(uv[failed, 1]).astype(np.int64), 0, xyz.shape[0] - 1)
            c = np.clip(np.floor(uv[failed, 0]).astype(np.int64), 0, xyz.shape[1] - 1)
            unsure = failed[d_point[failed] <= farthest[r, c] + tol[failed]]
            if unsure.size:
                from .xyz import segment_first_hit  # not at import: the xyz package is the heavier one

                s = segment_first_hit(dem, origin, points[unsure])
                with np.errstate(invalid="ignore"):
                    visible[unsure] = ~(s * d_point[unsure] < d_point[unsure] - tol[unsure])  # NaN: no hit, seen
    return uv, visible


def farthest_around(xyz: np.ndarray, origin) -> np.ndarray:
    """(H, W) float32: the largest distance from ``origin`` of the ground seen through each pixel of ``xyz``
    ((H, W, 3)) and its eight neighbours; infinite where one of them sees no ground (sky, void) or lies beyond the
    photo's edge (the ground between a border pixel's centre and the edge is not in the raster).

    >>> xyz = np.zeros((3, 2, 3)); xyz[..., 1] = [[1030.0], [1010.0], [1000.0]]  # rows farther up the photo
    >>> farthest_around(xyz, (0.0, 0.0, 0.0)).tolist()
    [[inf, inf], [inf, inf], [inf, inf]]
    >>> xyz = np.zeros((3, 3, 3)); xyz[..., 1] = [[1030.0], [1010.0], [1000.0]]
    >>> float(farthest_around(xyz, (0.0, 0.0, 0.0))[1, 1])
    1030.0
    """
    height, width = xyz.shape[:2]
    origin = np.asarray(origin, dtype=np.float64)
    dist = np.full((height + 2, width + 2), np.inf, dtype=np.float32)
    for r0 in range(0, height, 256):  # blocks of rows: a 24 MP raster's offsets whole took 576 MB
        offsets = xyz[r0:r0 + 256] - origin
        block = np.sqrt(np.einsum("ijk,ijk->ij", offsets, offsets))
        dist[1 + r0:1 + r0 + len(block), 1:-1] = np.where(np.isnan(block), np.inf, block)
    far = dist[1:-1, 1:-1].copy()
    for dr in (0, 1, 2):
        for dc in (0, 1, 2):
            if (dr, dc) != (1, 1):
                np.maximum(far, dist[dr:dr + height, dc:dc + width], out=far)
    return far


def orthorectify(photo: np.ndarray, camera, dem, xyz: np.ndarray, *,
                 between_chunks: Optional[Callable[[float], None]] = None) -> np.ndarray:
    """The photo draped onto the DEM grid.

    Every DEM cell centre (on the terrain) is projected into the photo; it takes the colour of that photo pixel
    when the camera sees it (:func:`visibility_of_points`). The same as ``ortho_lookup(camera, dem, xyz)
    .apply(photo)``: a time-lapse computes the lookup once per camera and applies it to every frame.

    Args:
        photo: (H, W) or (H, W, bands) uint8 photo.
        camera: the photo's Camera (image_size must match the photo).
        dem: the :class:`~monoplot_plugin.core.dem.Dem` to drape onto (its grid and CRS are the orthophoto's).
        xyz: (H, W, 3) per-pixel map coordinates of the photo (for occlusion).
        between_chunks: see :func:`ortho_lookup`.
    Returns:
        (rows, cols, bands + 1) uint8: photo bands then an alpha band (255 seen, 0 unseen: nodata).
    """
    return ortho_lookup(camera, dem, xyz, between_chunks=between_chunks).apply(photo)


@dataclass(frozen=True)
class OrthoLookup:
    """Which photo pixel colours each DEM cell: what an orthophoto depends on besides the photo (camera, DEM and
    the XYZ raster's occlusion), computed once by :func:`ortho_lookup` and applied to any photo of that camera.

    Attributes:
        shape: (rows, cols) of the DEM grid.
        image_size: (width, height) of the camera's photo.
        cells: (N,) int64 flat indices of the DEM cells the camera sees.
        pixels: (N,) int64 flat photo pixel indices (row * width + column) of those cells.

    >>> lut = OrthoLookup((1, 3), (2, 1), np.array([0, 2]), np.array([1, 0]))
    >>> lut.apply(np.array([[[10, 11, 12], [20, 21, 22]]], dtype=np.uint8))[0].tolist()
    [[20, 21, 22, 255], [0, 0, 0, 0], [10, 11, 12, 255]]
    >>> lut.apply(np.array([[[10, 11, 12], [20, 21, 22]]], dtype=np.uint8), area=np.array([[True, False]]))[0, 0]
    array([0, 0, 0, 0], dtype=uint8)
    """

    shape: Tuple[int, int]
    image_size: Tuple[int, int]
    cells: np.ndarray
    pixels: np.ndarray

    @property
    def seen(self) -> int:
        """How many DEM cells take a colour."""
        return int(self.cells.size)

    def apply(self, photo: np.ndarray, area: Optional[np.ndarray] = None) -> np.ndarray:
        """(rows, cols, bands + 1) uint8 orthophoto of ``photo`` ((H, W) or (H, W, bands) uint8), alpha last;
        ``area`` (H, W) bool: only the pixels where it is True are draped (a print's border and caption are not)."""
        photo = np.asarray(photo)
        if photo.ndim == 2:
            photo = photo[..., None]
        width, height = self.image_size
        if photo.shape[1] != width or photo.shape[0] != height:
            raise ValueError(f"photo is {photo.shape[1]}x{photo.shape[0]} px, camera expects {self.image_size}")
        rows, cols = self.shape
        bands = photo.shape[2]
        out = np.zeros((rows * cols, bands + 1), dtype=np.uint8)
        cells, pixels = self.cells, self.pixels
        if area is not None:
            kept = np.asarray(area, dtype=bool).reshape(-1)[pixels]
            cells, pixels = cells[kept], pixels[kept]
        out[cells, :bands] = photo.reshape(-1, bands)[pixels]
        out[cells, bands] = 255
        return out.reshape(rows, cols, bands + 1)


def ortho_lookup(camera, dem, xyz: np.ndarray, *, between_chunks: Optional[Callable[[float], None]] = None,
                 chunk_cells: int = 1 << 20) -> OrthoLookup:
    """The :class:`OrthoLookup` of ``camera`` over ``dem``'s grid (arguments as :func:`orthorectify`): every DEM
    cell centre projected into the photo, kept when the camera sees it (:func:`visibility_of_points`).

    The cells are taken in blocks of whole rows of at most ``chunk_cells`` (one row when a row has more);
    ``between_chunks(fraction done)`` is called after each chunk (the
    caller's progress, and its cancel: an exception it raises goes through unchanged)."""
    rows, cols = dem.shape
    cells_parts, uv_parts = [], []
    far = functools.cache(lambda: farthest_around(xyz, camera.position))  # once, if a chunk needs it at all
    total = rows * cols
    step = max(1, int(chunk_cells) // max(1, cols))  # whole rows: the cell centres of one block at a time (all of
    for row0 in range(0, rows, step):  # a 10 M-cell grid's took 240 MB, their temporaries more)
        chunk = dem.crop(row0, 0, step, cols).vertices().reshape(-1, 3)
        start = row0 * cols
        finite = np.isfinite(chunk[:, 2])
        uv, visible = visibility_of_points(camera, chunk[finite], xyz, dem=dem, far=far)
        cells_parts.append(start + np.flatnonzero(finite)[visible])
        uv_parts.append(uv[visible])
        if between_chunks is not None:
            between_chunks(min(1.0, (start + len(chunk)) / total))
    cells = np.concatenate(cells_parts) if cells_parts else np.zeros(0, np.int64)
    uv = np.concatenate(uv_parts) if uv_parts else np.zeros((0, 2))
    r = np.clip(np.floor(uv[:, 1]).astype(np.int64), 0, camera.height - 1)
    c = np.clip(np.floor(uv[:, 0]).astype(np.int64), 0, camera.width - 1)
    return OrthoLookup(tuple(dem.elevation.shape), tuple(camera.image_size), cells.astype(np.int64),
                       r * camera.width + c)


@dataclass(frozen=True)
class TurnableLookup:
    """The :class:`OrthoLookup` of one camera centre for any small turn of the camera, without a new z-buffer.

    Turning a camera about its centre changes which pixel sees a DEM cell, not whether the cell is hidden: the
    cells seen through a wider image (``margin`` pixels on each side) and their rays are kept once
    (:func:`turnable_lookup`); :meth:`turned` projects the rays of a turned camera (a re-registered time-lapse
    frame) into its image.

    Attributes:
        shape: (rows, cols) of the DEM grid. margin: pixels added on each side of the image.
        cells: (N,) int64 flat indices of the DEM cells seen by the wider image; rays: (N, 3) their directions in the
        camera frame of ``rotation``. rotation: (3, 3) world-to-camera rotation they were taken in.
    """

    shape: Tuple[int, int]
    margin: int
    cells: np.ndarray
    rays: np.ndarray
    rotation: np.ndarray

    def turned(self, camera) -> Optional[OrthoLookup]:
        """The lookup of ``camera`` (same centre and intrinsics, any rotation), or None when it turned farther than
        the margin covers (the caller then computes :func:`ortho_lookup`)."""
        from .camera import project_points

        delta = camera.rotation @ self.rotation.T
        uv, depth = project_points(self.rays @ delta.T, np.zeros(3), np.eye(3), camera.focal_px, camera.cx,
                                   camera.cy, camera.k1, camera.k2)
        f = camera.focal_px
        corners = np.array([[(u - camera.cx) / f, (v - camera.cy) / f, 1.0]
                            for u in (0.0, camera.width) for v in (0.0, camera.height)])
        back = corners @ delta  # the image's corners among the kept rays (the wider image's frame)
        with np.errstate(divide="ignore", invalid="ignore"):
            u_wide = f * back[:, 0] / back[:, 2] + camera.cx + self.margin
            v_wide = f * back[:, 1] / back[:, 2] + camera.cy + self.margin
        if not ((back[:, 2] > 0).all() and (u_wide >= 0).all() and (u_wide <= camera.width + 2 * self.margin).all()
                and (v_wide >= 0).all() and (v_wide <= camera.height + 2 * self.margin).all()):
            return None
        with np.errstate(invalid="ignore"):
            inside = ((depth > 0) & (uv[:, 0] >= 0) & (uv[:, 0] < camera.width) & (uv[:, 1] >= 0)
                      & (uv[:, 1] < camera.height))
        r = np.floor(uv[inside, 1]).astype(np.int64)
        c = np.floor(uv[inside, 0]).astype(np.int64)
        return OrthoLookup(self.shape, tuple(camera.image_size), self.cells[inside], r * camera.width + c)


def widened(camera, margin: int):
    """``camera`` with ``margin`` pixels more on each side of its image (same centre, focal length and rays).

    >>> from monoplot_plugin.core.camera import Camera
    >>> wide = widened(Camera((0, 0, 0), 0, 0, 0, 60, (100, 80)), 10)
    >>> wide.image_size, wide.principal_point
    ((120, 100), (60.0, 50.0))
    """
    from dataclasses import replace

    from .camera import focal_from_fov, fov_from_focal

    width, height = camera.width + 2 * margin, camera.height + 2 * margin
    fov = fov_from_focal(focal_from_fov(camera.fov, camera.width), width)
    return replace(camera, image_size=(width, height), fov=fov,
                   principal_point=(camera.cx + margin, camera.cy + margin))


def turnable_lookup(camera, dem, xyz_of, max_degrees: float = 3.0) -> TurnableLookup:
    """The :class:`TurnableLookup` of ``camera`` over ``dem`` for turns up to ``max_degrees``; ``xyz_of(camera)``
    computes a z-buffer (core :func:`~monoplot_plugin.core.xyz.compute_xyz`), here of the wider image."""
    import math

    margin = int(math.ceil(camera.focal_px * math.tan(math.radians(max_degrees)) * 1.5)) + 2
    wide = widened(camera, margin)
    xyz = xyz_of(wide)
    pts = dem.vertices().reshape(-1, 3)
    finite = np.isfinite(pts[:, 2])
    _, visible = visibility_of_points(wide, pts[finite], xyz, dem=dem)
    cells = np.flatnonzero(finite)[visible]
    rays = (pts[cells] - np.asarray(wide.position)) @ wide.rotation.T
    return TurnableLookup(tuple(dem.elevation.shape), margin, cells.astype(np.int64), rays, wide.rotation)
