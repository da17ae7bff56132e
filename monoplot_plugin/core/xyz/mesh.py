"""The terrain mesh as the compiled kernels see it: vertices, triangles and their planes, camera-relative in float64;
interior voids closed by lids (see :mod:`.`, the package docstring, for the surface).

>>> import numpy as np
>>> elev = np.array([[0.0, np.nan, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
>>> bool(_filled_voids(elev, np.isnan(elev))[1].any())   # a void on the edge of the grid stays a hole
False
>>> [int(v) for v in _triangle_vertices(3, 3)]      # triangle 3 = quad (0, 1), second half
[0, 1, 1, 2, 1, 1]
"""

from __future__ import annotations

import numpy as np

from ..distortion import distort, undistort
from ._jit import njit, prange

#: The camera model's own distortion (:mod:`..distortion`), compiled: the kernels have no copy of their own.
_distort = njit(cache=True, error_model="numpy")(distort)
_undistort = njit(cache=True, error_model="numpy")(undistort)


@njit(cache=True)
def _vertex_cam(elev, gt, C, R, r, c):
    """Camera-frame coordinates (float64) of the vertex at cell centre (r, c)."""
    X = gt[0] + (c + 0.5) * gt[1] + (r + 0.5) * gt[2] - C[0]
    Y = gt[3] + (c + 0.5) * gt[4] + (r + 0.5) * gt[5] - C[1]
    Z = elev[r, c] - C[2]
    return (R[0, 0] * X + R[0, 1] * Y + R[0, 2] * Z,
            R[1, 0] * X + R[1, 1] * Y + R[1, 2] * Z,
            R[2, 0] * X + R[2, 1] * Y + R[2, 2] * Z)


@njit(cache=True)
def _triangle_vertices(tid, cols):
    q = tid // 2
    r = q // (cols - 1)
    c = q - r * (cols - 1)
    if tid % 2 == 0:
        return r, c, r, c + 1, r + 1, c + 1
    return r, c, r + 1, c + 1, r + 1, c


@njit(cache=True)
def _world_rel(elev, gt, C, r, c):
    return (gt[0] + (c + 0.5) * gt[1] + (r + 0.5) * gt[2] - C[0],
            gt[3] + (c + 0.5) * gt[4] + (r + 0.5) * gt[5] - C[1],
            elev[r, c] - C[2])


@njit(cache=True, inline="always")
def _triangle_normal(ax, ay, az, bx, by, bz, qx, qy, qz):
    """(b - a) x (q - a): normal of triangle abc (not unit length)."""
    e1x, e1y, e1z = bx - ax, by - ay, bz - az
    e2x, e2y, e2z = qx - ax, qy - ay, qz - az
    return e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x


@njit(cache=True)
def _plane_of(elev, gt, C, cols, tid):
    """Plane of triangle tid, camera-relative: normal (nx, ny, nz) and nd = n . a for its vertex a."""
    ra, ca, rb, cb, rc, cc = _triangle_vertices(tid, cols)
    ax, ay, az = _world_rel(elev, gt, C, ra, ca)
    bx, by, bz = _world_rel(elev, gt, C, rb, cb)
    qx, qy, qz = _world_rel(elev, gt, C, rc, cc)
    nx, ny, nz = _triangle_normal(ax, ay, az, bx, by, bz, qx, qy, qz)
    return nx, ny, nz, nx * ax + ny * ay + nz * az


@njit(cache=True)
def _plane_hit(elev, gt, C, cols, tid, dx, dy, dz):
    """Ray parameter t of the ray t * d (from the camera) hitting the plane of triangle tid (NaN if parallel)."""
    nx, ny, nz, nd = _plane_of(elev, gt, C, cols, tid)
    den = nx * dx + ny * dy + nz * dz
    if den == 0.0:
        return np.nan
    return nd / den


@njit(parallel=True, cache=True)
def _drop_void_hits(tri, void):
    """Pixels whose nearest triangle touches a void vertex see a void: no hit (-1), never the ground behind it."""
    H, W = tri.shape
    cols = void.shape[1]
    for i in prange(H):
        for j in range(W):
            tid = tri[i, j]
            if tid < 0:
                continue
            ra, ca, rb, cb, rc, cc = _triangle_vertices(tid, cols)
            if void[ra, ca] or void[rb, cb] or void[rc, cc]:
                tri[i, j] = -1


@njit(cache=True)
def _spans_have_nan(elev, lo, hi):
    """Whether a void (NaN) lies in the cells [lo[r], hi[r]) of some row r."""
    for r in range(elev.shape[0]):
        for c in range(lo[r], hi[r]):
            if elev[r, c] != elev[r, c]:
                return True
    return False


def _filled_voids(elev: np.ndarray, void: np.ndarray):
    """(elevations with interior voids closed, bool mask of those cells) for the z-buffer.

    An interior void (one that does not touch the edge of the grid: a pit of -9999, a NaN hole, a lake filled with
    0) is closed by a flat lid at the highest height of its rim, so that a ray meeting it stops there and the pixel
    becomes nodata, instead of looking through the hole at ground that the missing terrain may hide. Voids that
    reach the edge of the grid (the nodata surround of a clipped DEM) stay holes, like the world beyond the grid:
    a lid there could cover a camera standing outside the clipped area."""
    from scipy import ndimage

    labels, count = ndimage.label(void)
    edge = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    interior = void & ~np.isin(labels, edge[edge > 0])
    if not interior.any():
        return elev, interior
    index = ndimage.distance_transform_edt(void, return_distances=False, return_indices=True)
    nearest = elev[index[0], index[1]]  # a void cell's nearest valid cell is on its rim
    lids = np.asarray(ndimage.maximum(nearest, labels, np.arange(1, count + 1)), dtype=elev.dtype).reshape(-1)
    filled = elev.copy()
    filled[interior] = lids[labels[interior] - 1]
    return np.ascontiguousarray(filled), interior
