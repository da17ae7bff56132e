"""After the z-buffer: the exact float64 intersection of each pixel's ray with the plane of the triangle it sees, and
the per-cell visibility decided against those planes."""

from __future__ import annotations

import math

import numpy as np

from ._jit import njit, prange
from .mesh import _plane_hit, _plane_of, _undistort, _world_rel
from .raster import _project_row


@njit(parallel=True, cache=True)
def _exact_hits(tri, elev, gt, C, R, intr, max_range, nthreads, xyz, dist):
    """Exact float64 ray / triangle-plane intersection for every pixel with a triangle in the buffer. Rows are
    dealt to the threads in turn: the sky, which costs nothing, usually fills the top of the picture."""
    H = tri.shape[0]
    cols = elev.shape[1]
    f, cx, cy, k1, k2 = intr[0], intr[1], intr[2], intr[3], intr[4]
    for k in prange(nthreads):
        for i in range(k, H, nthreads):
            _exact_row(tri, elev, gt, C, R, f, cx, cy, k1, k2, cols, max_range, i, xyz, dist)


@njit(cache=True)
def _exact_row(tri, elev, gt, C, R, f, cx, cy, k1, k2, cols, max_range, i, xyz, dist):
    """One picture row of :func:`_exact_hits`."""
    W = tri.shape[1]
    last = -1  # neighbouring pixels often share a triangle: its plane is computed once for the run
    nx = ny = nz = nd = 0.0
    for j in range(W):
        tid = tri[i, j]
        if tid < 0:
            xyz[i, j, 0] = np.nan
            xyz[i, j, 1] = np.nan
            xyz[i, j, 2] = np.nan
            dist[i, j] = np.nan
            continue
        xn, yn = _undistort((j + 0.5 - cx) / f, (i + 0.5 - cy) / f, k1, k2)
        dx = xn * R[0, 0] + yn * R[1, 0] + R[2, 0]
        dy = xn * R[0, 1] + yn * R[1, 1] + R[2, 1]
        dz = xn * R[0, 2] + yn * R[1, 2] + R[2, 2]
        if tid != last:
            nx, ny, nz, nd = _plane_of(elev, gt, C, cols, tid)
            last = tid
        den = nx * dx + ny * dy + nz * dz
        t = nd / den if den != 0.0 else np.nan
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        if not (t > 0.0) or t * norm > max_range:
            xyz[i, j, 0] = np.nan
            xyz[i, j, 1] = np.nan
            xyz[i, j, 2] = np.nan
            dist[i, j] = np.nan
            tri[i, j] = -1
            continue
        xyz[i, j, 0] = C[0] + t * dx
        xyz[i, j, 1] = C[1] + t * dy
        xyz[i, j, 2] = C[2] + t * dz
        dist[i, j] = t * norm


@njit(parallel=True, cache=True)
def _visibility(tri, elev, gt, C, R, intr, near, rel_tol, abs_tol, vis):
    """Per-vertex visibility: in the image, in front, and not behind the surface seen at its pixel (the plane of
    that pixel's triangle, along the vertex's own ray, within rel_tol * range + abs_tol)."""
    rows, cols = elev.shape
    H, W = tri.shape
    for r in prange(rows):
        proj = np.empty((3, cols), dtype=np.float32)
        _project_row(elev, gt, C, R, intr, near, r, 0, cols, proj[0], proj[1], proj[2])
        for c in range(cols):
            vis[r, c] = False
            if not (proj[2, c] > 0.0):  # void, behind the camera or too close
                continue
            uu = proj[0, c]
            vv = proj[1, c]
            if not (uu >= 0.0 and uu < W and vv >= 0.0 and vv < H):
                continue
            tid = tri[int(vv), int(uu)]
            if tid < 0:
                vis[r, c] = True  # the pixel sees sky: nothing in front of this vertex
                continue
            px, py, pz = _world_rel(elev, gt, C, r, c)
            s = _plane_hit(elev, gt, C, cols, tid, px, py, pz)
            rng = math.sqrt(px * px + py * py + pz * pz)
            if not (s > 0.0) or s * rng >= rng - (rel_tol * rng + abs_tol):
                vis[r, c] = True
