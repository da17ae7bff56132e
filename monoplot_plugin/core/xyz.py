"""Per-pixel terrain intersection: the map coordinates (X, Y, Z) of the first terrain point each pixel sees.

Surface: the DEM's triangle mesh (vertices at cell centres, two triangles per square of four centres, split along the
diagonal from (row, col) to (row + 1, col + 1); see :mod:`.dem`). Interior voids are not holes to look through: they
are closed by a lid at the height of their rim, and a pixel whose nearest triangle touches a void vertex is
nodata (NaN), never the ground behind the void (see :func:`_filled_voids`).

Method (a z-buffer, not ray marching):

1. every mesh vertex is projected into the photo (coordinates recentred on the camera in float64 first, then
   kept as float32 pixels and depths: UTM northings would lose half a metre in float32), row by row as step 2
   goes, so that only two rows per thread are held;
2. every triangle is rasterised into a depth buffer of inverse depths that keeps, per pixel centre, the id of the
   nearest triangle. The two triangles of a quad are drawn in one pass over its pixel box (the side of the diagonal
   picks the triangle); triangles crossing the camera plane are clipped 1 cm in front of it; back faces are skipped
   when the camera is above the terrain (a ray from above meets the surface first from its top side);
3. each pixel's ray is then intersected *exactly* (float64) with the plane of the triangle in the buffer, so the
   result does not depend on interpolation in the buffer: only which triangle wins can differ from a brute-force
   search, on silhouettes.

The loops are compiled with numba (``cache=True``, in a folder per import name, see :func:`_numba_cache_dir`; parallel
over the available cores, each thread with its own depth buffer over interleaved blocks of DEM rows, merged at the
end; up to three such buffers live in the memory of the output array, see :func:`_depth_buffers`).
Without numba the same code runs as plain Python, which is only practical for tiny grids.

Radial distortion: vertices are projected with it (triangle edges are straight between distorted vertices, a
sub-pixel approximation for small triangles); the exact step undistorts each pixel's ray. Points beyond the radius
where the distortion polynomial stops growing are not projected.

>>> import numpy as np
>>> from .camera import Camera
>>> from .dem import Dem
>>> flat = Dem.from_array(np.full((50, 50), 100.0), (0, 10, 0, 500, 0, -10))
>>> cam = Camera(position=(250, 0, 200), heading=0, pitch=-30, roll=0, fov=60, image_size=(64, 48))
>>> xyz = compute_xyz(cam, flat)
>>> xyz.shape, bool(np.allclose(xyz[40, :, 2], 100.0))
((48, 64, 3), True)
>>> bool(np.isnan(xyz[0, 0]).all())     # above the horizon of a finite grid: sky
True
"""

from __future__ import annotations

import logging
import math
import os
import tempfile
from dataclasses import dataclass
from typing import Optional

import numpy as np

from .camera import Camera
from .dem import Dem

__all__ = ["compute_xyz", "compute_xyz_full", "XyzResult", "segment_first_hit", "HAVE_NUMBA", "NEAR_PLANE_M"]

logger = logging.getLogger("monoplot")

#: Terrain closer than this to the camera plane (metres) is clipped away.
NEAR_PLANE_M = 0.01


def _numba_cache_dir() -> str:
    """Where this module's compiled kernels are cached: a folder per import name (numba's cache records the module
    name, so the same file imported as ``monoplot_plugin.core.xyz`` by tests and as ``monoplot.monoplot_plugin...``
    by QGIS must not share a cache), under ``NUMBA_CACHE_DIR`` if set, else in the package's ``__pycache__``, else
    (read-only plugin folder) in a temporary folder."""
    base = os.environ.get("NUMBA_CACHE_DIR", "")
    if not base:
        base = os.path.join(os.path.dirname(os.path.abspath(__file__)), "__pycache__", "numba")
        try:
            os.makedirs(base, exist_ok=True)
            writable = os.access(base, os.W_OK)
        except OSError:
            writable = False
        if not writable:
            base = os.path.join(tempfile.gettempdir(), "monoplot-numba-cache")
    return os.path.join(base, __name__)


try:
    import numba
    from numba import njit, prange

    HAVE_NUMBA = True
    # numba picks a function's cache folder when it is decorated: point it at ours for the kernels below only
    _saved_cache_dir = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = _numba_cache_dir()
except ImportError:  # pragma: no cover - exercised only where numba is missing
    HAVE_NUMBA = False
    prange = range

    def njit(*args, **kwargs):
        if args and callable(args[0]):
            return args[0]
        return lambda f: f


# ----------------------------------------------------------------------------------------------------------------
# compiled kernels (camera-relative float64 arithmetic; float32 only for stored per-vertex pixels and depths)
# ----------------------------------------------------------------------------------------------------------------

@njit(cache=True)
def _distort(xn, yn, k1, k2):
    r2 = xn * xn + yn * yn
    s = 1.0 + k1 * r2 + k2 * r2 * r2
    return xn * s, yn * s


@njit(cache=True)
def _undistort(xd, yd, k1, k2):
    x, y = xd, yd
    if k1 == 0.0 and k2 == 0.0:
        return x, y
    for _ in range(20):
        r2 = x * x + y * y
        s = 1.0 + k1 * r2 + k2 * r2 * r2
        x, y = xd / s, yd / s
    return x, y


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
def _project_row(elev, gt, C, R, intr, near, r, u, v, w):
    """Project the mesh vertices of DEM row r into (cols,) float32 u, v (pixels; NaN if not in front) and w: inverse
    camera depth 1/z for vertices more than ``near`` in front, -1 for the others, NaN for voids and for vertices
    outside the distortion's valid radius."""
    cols = elev.shape[1]
    f, cx, cy, k1, k2, r2max = intr[0], intr[1], intr[2], intr[3], intr[4], intr[5]
    for c in range(cols):
        if elev[r, c] != elev[r, c]:
            u[c] = np.nan
            v[c] = np.nan
            w[c] = np.nan
            continue
        xc, yc, zc = _vertex_cam(elev, gt, C, R, r, c)
        w[c] = 1.0 / zc if zc > near else -1.0
        if zc > near:
            xn = xc / zc
            yn = yc / zc
            if k1 != 0.0 or k2 != 0.0:
                if xn * xn + yn * yn > r2max:
                    u[c] = np.nan
                    v[c] = np.nan
                    w[c] = np.nan
                    continue
                xn, yn = _distort(xn, yn, k1, k2)
            u[c] = f * xn + cx
            v[c] = f * yn + cy
        else:
            u[c] = np.nan
            v[c] = np.nan


@njit(cache=True, inline="always")
def _raster_triangle(u0, v0, w0, u1, v1, w1, u2, v2, w2, tid, zbuf, tbuf, cull):
    """Rasterise one screen triangle (pixels; w = inverse depth) into zbuf (keep the largest w) and tbuf.
    ``cull`` = sign of the screen area of a front-facing triangle (0: draw both faces)."""
    H, W = zbuf.shape
    umin = min(u0, min(u1, u2))
    umax = max(u0, max(u1, u2))
    vmin = min(v0, min(v1, v2))
    vmax = max(v0, max(v1, v2))
    j0 = max(0, int(math.ceil(umin - 0.5)))
    j1 = min(W - 1, int(math.floor(umax - 0.5)))
    if j0 > j1:
        return
    i0 = max(0, int(math.ceil(vmin - 0.5)))
    i1 = min(H - 1, int(math.floor(vmax - 0.5)))
    if i0 > i1:
        return
    area = (u1 - u0) * (v2 - v0) - (u2 - u0) * (v1 - v0)
    if abs(area) < 1e-12 or cull * area < 0.0:
        return
    inv = 1.0 / area
    eps = -1e-7
    for i in range(i0, i1 + 1):
        py = i + 0.5
        for j in range(j0, j1 + 1):
            px = j + 0.5
            b0 = ((u1 - px) * (v2 - py) - (u2 - px) * (v1 - py)) * inv
            if b0 < eps:
                continue
            b1 = ((u2 - px) * (v0 - py) - (u0 - px) * (v2 - py)) * inv
            if b1 < eps:
                continue
            b2 = 1.0 - b0 - b1
            if b2 < eps:
                continue
            w = b0 * w0 + b1 * w1 + b2 * w2
            if w > zbuf[i, j]:
                zbuf[i, j] = w
                tbuf[i, j] = tid


@njit(cache=True, inline="always")
def _raster_quad(ua, va, wa, ub, vb, wb, uc, vc, wc, ud, vd, wd, i0, i1, j0, j1, tid, zbuf, tbuf, cull):
    """Rasterise the quad A B C D (A = (r, c), B = (r, c+1), C = (r+1, c+1), D = (r+1, c)) as its two triangles
    ABC (id tid) and ACD (id tid + 1) in one pass over the quad's pixel box: the side of the diagonal AC picks the
    triangle. Returns False (nothing drawn) when B and D are not on opposite sides of AC (a folded quad), for the
    caller to draw the two triangles separately."""
    acu = uc - ua
    acv = vc - va
    eb = acu * (vb - va) - acv * (ub - ua)
    ed = acu * (vd - va) - acv * (ud - ua)
    if not (eb * ed < 0.0):
        return False
    if cull * eb > 0.0:  # the screen area of ABC is -eb: a back-facing quad, hidden behind the terrain's top side
        return True
    inv_b = 1.0 / eb
    inv_d = 1.0 / ed
    abu = ub - ua
    abv = vb - va
    adu = ud - ua
    adv = vd - va
    eps = -1e-7
    for i in range(i0, i1 + 1):
        py = i + 0.5
        for j in range(j0, j1 + 1):
            px = j + 0.5
            e = acu * (py - va) - acv * (px - ua)  # side of AC
            if e * eb >= 0.0:
                # triangle A B C: weight of B = e / eb; weight of C from edge AB; weight of A the rest
                bb = e * inv_b
                bc = (abu * (py - va) - abv * (px - ua)) * (-inv_b)
                if bc < eps:
                    continue
                ba = 1.0 - bb - bc
                if ba < eps:
                    continue
                w = ba * wa + bb * wb + bc * wc
                t = tid
            else:
                # triangle A C D: weight of D = e / ed; weight of C from edge AD; weight of A the rest
                bd = e * inv_d
                bc = (adu * (py - va) - adv * (px - ua)) * (-inv_d)
                if bc < eps:
                    continue
                ba = 1.0 - bd - bc
                if ba < eps:
                    continue
                w = ba * wa + bc * wc + bd * wd
                t = tid + 1
            if w > zbuf[i, j]:
                zbuf[i, j] = w
                tbuf[i, j] = t
    return True


@njit(cache=True)
def _raster_clipped(elev, gt, C, R, intr, near, ra, ca, rb, cb, rc, cc, tid, zbuf, tbuf, cull):
    """Clip a triangle that crosses the near plane (camera frame, float64) and rasterise the part in front."""
    f, cx, cy, k1, k2, r2max = intr[0], intr[1], intr[2], intr[3], intr[4], intr[5]
    P = np.empty((3, 3))
    P[0, 0], P[0, 1], P[0, 2] = _vertex_cam(elev, gt, C, R, ra, ca)
    P[1, 0], P[1, 1], P[1, 2] = _vertex_cam(elev, gt, C, R, rb, cb)
    P[2, 0], P[2, 1], P[2, 2] = _vertex_cam(elev, gt, C, R, rc, cc)
    Q = np.empty((4, 3))
    n = 0
    for k in range(3):
        a = P[k]
        b = P[(k + 1) % 3]
        a_in = a[2] >= near
        b_in = b[2] >= near
        if a_in:
            Q[n] = a
            n += 1
        if a_in != b_in:
            t = (near - a[2]) / (b[2] - a[2])
            Q[n] = a + t * (b - a)
            n += 1
    if n < 3:
        return
    U = np.empty(4)
    V = np.empty(4)
    Wd = np.empty(4)
    for k in range(n):
        xn = Q[k, 0] / Q[k, 2]
        yn = Q[k, 1] / Q[k, 2]
        if k1 != 0.0 or k2 != 0.0:
            if xn * xn + yn * yn > r2max:
                return
            xn, yn = _distort(xn, yn, k1, k2)
        U[k] = f * xn + cx
        V[k] = f * yn + cy
        Wd[k] = 1.0 / Q[k, 2]
    for k in range(1, n - 1):
        _raster_triangle(U[0], V[0], Wd[0], U[k], V[k], Wd[k], U[k + 1], V[k + 1], Wd[k + 1], tid, zbuf, tbuf,
                         cull)


@njit(cache=True, inline="always")
def _row_pick(top, bottom, r, rr, c):
    return top[c] if rr == r else bottom[c]


@njit(cache=True)
def _raster_quad_row(ut, vt, wt, ub, vb, wb, r, elev, gt, C, R, intr, near, cull, zbuf, tbuf):
    """Z-buffer the two triangles of every quad between DEM rows r (projected into ut, vt, wt) and r + 1 (ub, vb,
    wb)."""
    cols = elev.shape[1]
    H, W = zbuf.shape
    for c in range(cols - 1):
        w00 = wt[c]
        w01 = wt[c + 1]
        w10 = wb[c]
        w11 = wb[c + 1]
        if w00 > 0.0 and w01 > 0.0 and w10 > 0.0 and w11 > 0.0:
            # fast path (most quads): skip quads whose bounding box holds no pixel centre
            u00, u01, u10, u11 = ut[c], ut[c + 1], ub[c], ub[c + 1]
            umin = min(min(u00, u01), min(u10, u11))
            umax = max(max(u00, u01), max(u10, u11))
            if math.floor(umax - 0.5) < math.ceil(umin - 0.5) or umax < 0.5 or umin > W - 0.5:
                continue
            v00, v01, v10, v11 = vt[c], vt[c + 1], vb[c], vb[c + 1]
            vmin = min(min(v00, v01), min(v10, v11))
            vmax = max(max(v00, v01), max(v10, v11))
            if math.floor(vmax - 0.5) < math.ceil(vmin - 0.5) or vmax < 0.5 or vmin > H - 0.5:
                continue
            base = 2 * (r * (cols - 1) + c)
            j0 = max(0, int(math.ceil(umin - 0.5)))
            j1 = min(W - 1, int(math.floor(umax - 0.5)))
            i0 = max(0, int(math.ceil(vmin - 0.5)))
            i1 = min(H - 1, int(math.floor(vmax - 0.5)))
            if not _raster_quad(u00, v00, w00, u01, v01, w01, u11, v11, w11, u10, v10, w10,
                                i0, i1, j0, j1, base, zbuf, tbuf, cull):
                _raster_triangle(u00, v00, w00, u01, v01, w01, u11, v11, w11, base, zbuf, tbuf, cull)
                _raster_triangle(u00, v00, w00, u11, v11, w11, u10, v10, w10, base + 1, zbuf, tbuf, cull)
            continue
        if not (w00 > 0.0 or w01 > 0.0 or w10 > 0.0 or w11 > 0.0):
            continue  # behind the camera, or voids (NaN compares false)
        base = 2 * (r * (cols - 1) + c)
        for t in range(2):
            if t == 0:  # (r, c), (r, c+1), (r+1, c+1)
                ra, ca, rb, cb, rc, cc = r, c, r, c + 1, r + 1, c + 1
            else:  # (r, c), (r+1, c+1), (r+1, c)
                ra, ca, rb, cb, rc, cc = r, c, r + 1, c + 1, r + 1, c
            wa = _row_pick(wt, wb, r, ra, ca)
            wb_ = _row_pick(wt, wb, r, rb, cb)
            wc = _row_pick(wt, wb, r, rc, cc)
            if wa != wa or wb_ != wb_ or wc != wc:
                continue
            if wa > 0.0 and wb_ > 0.0 and wc > 0.0:
                _raster_triangle(_row_pick(ut, ub, r, ra, ca), _row_pick(vt, vb, r, ra, ca), wa,
                                 _row_pick(ut, ub, r, rb, cb), _row_pick(vt, vb, r, rb, cb), wb_,
                                 _row_pick(ut, ub, r, rc, cc), _row_pick(vt, vb, r, rc, cc), wc,
                                 base + t, zbuf, tbuf, cull)
            elif wa > 0.0 or wb_ > 0.0 or wc > 0.0:
                _raster_clipped(elev, gt, C, R, intr, near, ra, ca, rb, cb, rc, cc, base + t, zbuf, tbuf, cull)


#: DEM rows per block of :func:`_rasterise`: a block projects its rows once each, plus one shared row.
RASTER_BLOCK_ROWS = 16


@njit(parallel=True, cache=True)
def _rasterise(elev, gt, C, R, intr, near, cull, zbufs, tbufs):
    """Z-buffer all mesh triangles. Chunk k handles the blocks of RASTER_BLOCK_ROWS DEM rows b = k, k + nchunks, ...
    into its own buffers (no write races, balanced load); the caller merges the chunks. Vertices are projected
    row by row as the block goes (two rows held, no DEM-sized arrays)."""
    rows, cols = elev.shape
    nchunks = zbufs.shape[0]
    nblocks = (rows - 1 + RASTER_BLOCK_ROWS - 1) // RASTER_BLOCK_ROWS
    for k in prange(nchunks):
        zbuf = zbufs[k]
        tbuf = tbufs[k]
        top = np.empty((3, cols), dtype=np.float32)
        bottom = np.empty((3, cols), dtype=np.float32)
        for b in range(k, nblocks, nchunks):
            r0 = b * RASTER_BLOCK_ROWS
            r1 = min(r0 + RASTER_BLOCK_ROWS, rows - 1)
            _project_row(elev, gt, C, R, intr, near, r0, top[0], top[1], top[2])
            for r in range(r0, r1):
                _project_row(elev, gt, C, R, intr, near, r + 1, bottom[0], bottom[1], bottom[2])
                _raster_quad_row(top[0], top[1], top[2], bottom[0], bottom[1], bottom[2], r, elev, gt, C, R, intr,
                                 near, cull, zbuf, tbuf)
                top, bottom = bottom, top


@njit(parallel=True, cache=True)
def _clear_buffers(zbufs, tbufs):
    n, H, W = zbufs.shape
    for i in prange(H):
        for k in range(n):
            for j in range(W):
                zbufs[k, i, j] = 0.0
                tbufs[k, i, j] = -1


@njit(parallel=True, cache=True)
def _merge(zbufs, tbufs, tri):
    n, H, W = zbufs.shape
    for i in prange(H):
        for j in range(W):
            best = zbufs[0, i, j]
            tid = tbufs[0, i, j]
            for k in range(1, n):
                if zbufs[k, i, j] > best:
                    best = zbufs[k, i, j]
                    tid = tbufs[k, i, j]
            tri[i, j] = tid


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
        _project_row(elev, gt, C, R, intr, near, r, proj[0], proj[1], proj[2])
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


@njit(cache=True)
def _ray_triangle(ox, oy, oz, dx, dy, dz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Moller-Trumbore: parameter t of o + t d on triangle abc, or inf when it misses."""
    e1x, e1y, e1z = bx - ax, by - ay, bz - az
    e2x, e2y, e2z = cx - ax, cy - ay, cz - az
    px = dy * e2z - dz * e2y
    py = dz * e2x - dx * e2z
    pz = dx * e2y - dy * e2x
    det = e1x * px + e1y * py + e1z * pz
    if abs(det) < 1e-300:
        return np.inf
    inv = 1.0 / det
    tx, ty, tz = ox - ax, oy - ay, oz - az
    uu = (tx * px + ty * py + tz * pz) * inv
    if uu < -1e-12 or uu > 1.0 + 1e-12:
        return np.inf
    qx = ty * e1z - tz * e1y
    qy = tz * e1x - tx * e1z
    qz = tx * e1y - ty * e1x
    vv = (dx * qx + dy * qy + dz * qz) * inv
    if vv < -1e-12 or uu + vv > 1.0 + 1e-12:
        return np.inf
    return (e2x * qx + e2y * qy + e2z * qz) * inv


@njit(cache=True)
def _cell_first_hit(elev, gt, origin, d, r, c, smin, smax):
    """First hit parameter in [smin, smax] of origin + s d on the two triangles of quad (r, c); inf if none."""
    best = np.inf
    for t in range(2):
        if t == 0:
            ra, ca, rb, cb, rc, cc = r, c, r, c + 1, r + 1, c + 1
        else:
            ra, ca, rb, cb, rc, cc = r, c, r + 1, c + 1, r + 1, c
        if elev[ra, ca] != elev[ra, ca] or elev[rb, cb] != elev[rb, cb] or elev[rc, cc] != elev[rc, cc]:
            continue
        ax, ay, az = _world_rel(elev, gt, origin, ra, ca)
        bx, by, bz = _world_rel(elev, gt, origin, rb, cb)
        qx, qy, qz = _world_rel(elev, gt, origin, rc, cc)
        s = _ray_triangle(0.0, 0.0, 0.0, d[0], d[1], d[2], ax, ay, az, bx, by, bz, qx, qy, qz)
        if s >= smin and s <= smax and s < best and _enters_from_above(d, ax, ay, az, bx, by, bz, qx, qy, qz):
            best = s
    return best


@njit(cache=True, inline="always")
def _enters_from_above(d, ax, ay, az, bx, by, bz, qx, qy, qz):
    """The direction d crosses triangle abc from its upper side (against its upward normal); a crossing from
    below (a segment leaving the ground, e.g. from a camera a few metres under a coarse DEM) is not a hit."""
    nx, ny, nz = _triangle_normal(ax, ay, az, bx, by, bz, qx, qy, qz)
    if nz < 0.0:
        nx, ny, nz = -nx, -ny, -nz
    return nx * d[0] + ny * d[1] + nz * d[2] < 0.0


@njit(parallel=True, cache=True)
def _segments_first_hit(elev, gt, inv, origins, targets, smax, out):
    """For each segment origin -> target: the smallest s in (1e-9, smax] where origin + s (target - origin) meets
    the mesh (NaN if none). Cells are walked in order along the segment (2-D DDA in the grid of cell centres)."""
    rows, cols = elev.shape
    for k in prange(origins.shape[0]):
        out[k] = np.nan
        o = origins[k]
        d = targets[k] - o
        # positions in "centre grid" coordinates: fc = col - 0.5, fr = row - 0.5
        ax = o[0] - gt[0]
        ay = o[1] - gt[3]
        fc0 = inv[0] * ax + inv[1] * ay - 0.5
        fr0 = inv[2] * ax + inv[3] * ay - 0.5
        dfc = inv[0] * d[0] + inv[1] * d[1]
        dfr = inv[2] * d[0] + inv[3] * d[1]
        # clip s to the mesh's extent [0, cols-1] x [0, rows-1]
        s0 = 1e-9
        s1 = smax
        ok = True
        for axis in range(2):
            p0 = fc0 if axis == 0 else fr0
            dp = dfc if axis == 0 else dfr
            hi = (cols - 1.0) if axis == 0 else (rows - 1.0)
            if dp == 0.0:
                if p0 < 0.0 or p0 > hi:
                    ok = False
            else:
                ta = (0.0 - p0) / dp
                tb = (hi - p0) / dp
                if ta > tb:
                    ta, tb = tb, ta
                s0 = max(s0, ta)
                s1 = min(s1, tb)
        if not ok or s0 > s1:
            continue
        sm = s0
        pc = fc0 + sm * dfc
        pr = fr0 + sm * dfr
        c = min(max(int(math.floor(pc)), 0), cols - 2)
        r = min(max(int(math.floor(pr)), 0), rows - 2)
        stepc = 1 if dfc > 0 else -1
        stepr = 1 if dfr > 0 else -1
        if dfc != 0.0:
            nextc = ((c + (1 if dfc > 0 else 0)) - fc0) / dfc
            deltac = abs(1.0 / dfc)
        else:
            nextc = np.inf
            deltac = np.inf
        if dfr != 0.0:
            nextr = ((r + (1 if dfr > 0 else 0)) - fr0) / dfr
            deltar = abs(1.0 / dfr)
        else:
            nextr = np.inf
            deltar = np.inf
        while True:
            s = _cell_first_hit(elev, gt, o, d, r, c, s0, s1)
            if s < np.inf:
                out[k] = s
                break
            if nextc < nextr:
                if nextc > s1:
                    break
                c += stepc
                nextc += deltac
            else:
                if nextr > s1:
                    break
                r += stepr
                nextr += deltar
            if c < 0 or r < 0 or c > cols - 2 or r > rows - 2:
                break


if HAVE_NUMBA:
    numba.config.CACHE_DIR = _saved_cache_dir


# ----------------------------------------------------------------------------------------------------------------
# public API
# ----------------------------------------------------------------------------------------------------------------

@dataclass
class XyzResult:
    """Everything the z-buffer knows about one camera over one DEM.

    Attributes:
        xyz: (H, W, 3) float64 map coordinates of each pixel's first terrain hit (centre of the pixel); NaN = none.
        distance: (H, W) float32 metres from the camera centre to that hit; NaN = none.
        triangle: (H, W) int32 id of the hit triangle in ``dem`` (``2 * (row * (cols - 1) + col) + k``, k = 0 for
            (r, c), (r, c+1), (r+1, c+1) and 1 for (r, c), (r+1, c+1), (r+1, c)); -1 = none.
        visible: (rows, cols) bool over the DEM that was *passed in*: the camera sees that cell's centre.
        dem: the grid actually intersected (a crop of the input when ``crop=True``; ``dem.window`` says where).
        camera: the camera.
    """

    xyz: np.ndarray
    distance: np.ndarray
    triangle: np.ndarray
    visible: np.ndarray
    dem: Dem
    camera: Camera

    @property
    def hit(self) -> np.ndarray:
        """(H, W) bool: the pixel sees terrain."""
        return self.triangle >= 0

    def depth(self) -> np.ndarray:
        """(H, W) float64 depth along the optical axis (metres), NaN for sky."""
        rel = self.xyz - np.asarray(self.camera.position)
        return rel @ self.camera.forward


def _intrinsics(cam: Camera) -> np.ndarray:
    r2max = np.inf
    if cam.k1 != 0.0 or cam.k2 != 0.0:
        # the distortion polynomial r (1 + k1 r^2 + k2 r^4) must keep growing: d/dr > 0
        # 1 + 3 k1 r^2 + 5 k2 r^4 = 0 -> smallest positive root in r^2
        roots = np.roots([5 * cam.k2, 3 * cam.k1, 1.0]) if cam.k2 != 0 else np.array([-1.0 / (3 * cam.k1)])
        real = [float(x.real) for x in np.atleast_1d(roots) if abs(complex(x).imag) < 1e-12 and x.real > 0]
        r2max = min(real) * 0.999 if real else np.inf
    return np.array([cam.focal_px, cam.cx, cam.cy, cam.k1, cam.k2, r2max], dtype=np.float64)


def _cull_sign(cam: Camera, dem: Dem) -> float:
    """Screen-area sign of front-facing triangles: only the terrain's upper side is drawn.

    A ray that starts above the terrain meets it first from its upper side, so triangles seen from below (back
    faces) can never be its first hit. A camera *below* the surface at its own position is a DEM that is too coarse
    or a fit that ended a few metres low (a photographer on a summit that a 25 m DEM rounds off): drawing the
    underside would fill the whole picture with the slope above the camera. Culling it instead lets the rays leave
    the ground and see the terrain beyond, as the photo does; the log says the camera is below the DEM.
    """
    x, y, z = cam.position
    ground = dem.sample(x, y, method="mesh")
    if not math.isnan(ground) and z <= ground:
        logger.warning("camera %.1f m below the DEM surface at its position: the terrain is seen from above only",
                       ground - z)
    g = dem.geotransform
    # triangle (r, c), (r, c+1), (r+1, c+1) is counter-clockwise in (col, row); the map flips it when the affine's
    # determinant is negative (north-up), and the image's downward v axis flips it once more
    return -1.0 if g[1] * g[5] - g[2] * g[4] > 0 else 1.0


def _depth_buffers(xyz: np.ndarray, n: int):
    """Cleared per-chunk buffers for :func:`_rasterise`: (n, H, W) float32 inverse depths and int32 triangle ids.

    They live inside the memory of the (H, W, 3) float64 output, which has room for three chunks (24 bytes per
    pixel) and is written only after the chunks are merged. Fresh memory is slow here: the first touch of each
    page is a fault, zeroed by the kernel, so a 24 MP call that reuses the output saves 384 MB of it (and what it
    faults in, it faults in once, for both uses). More chunks than fit get arrays of their own."""
    H, W, _ = xyz.shape
    if n <= 3:
        flat = xyz.reshape(-1).view(np.float32)
        zbufs = flat[:n * H * W].reshape(n, H, W)
        tbufs = flat[n * H * W:2 * n * H * W].view(np.int32).reshape(n, H, W)
    else:
        zbufs = np.empty((n, H, W), dtype=np.float32)
        tbufs = np.empty((n, H, W), dtype=np.int32)
    _clear_buffers(zbufs, tbufs)
    return zbufs, tbufs


def _threads() -> int:
    return numba.get_num_threads() if HAVE_NUMBA else 1


def _chunk_count(H: int, W: int) -> int:
    threads = _threads()
    budget = int(1.2e9 // max(1, H * W * 8))  # bytes of per-chunk buffers we allow
    return max(1, min(threads, budget))


def compute_xyz_full(cam: Camera, dem: Dem, max_range: Optional[float] = None, crop: bool = True,
                     visibility: bool = True, rel_tol: float = 0.005, abs_tol: Optional[float] = None) -> XyzResult:
    """Z-buffer ``dem`` from ``cam``: per-pixel XYZ and distance, and per-cell visibility.

    Args:
        cam: camera in the DEM's CRS.
        dem: the terrain.
        max_range: ignore terrain farther than this (metres); None = no limit.
        crop: first cut the DEM to the rectangle the camera can see (saves time on large DEMs).
        visibility: compute :attr:`XyzResult.visible` (else all False).
        rel_tol, abs_tol: a cell centre counts as visible when the surface seen at its pixel is no nearer than its
            own range minus ``rel_tol * range + abs_tol`` (abs_tol defaults to one cell). Decided at pixel
            resolution: cells that project within a pixel of an occluding ridge can be misjudged; for exact
            line-of-sight tests use :func:`segment_first_hit` (``transforms.orthorectify(exact=True)`` does).
    Returns:
        :class:`XyzResult`.
    """
    if dem.is_geographic:
        raise ValueError("the DEM is in geographic degrees: use Dem.open (reprojects to UTM) or dem.reprojected_to_utm()"
                         " and a camera in that CRS")
    W, H = cam.width, cam.height
    full_shape = dem.shape
    work = dem.crop_to_view(cam, max_range) if crop else dem
    elev = np.ascontiguousarray(work.elevation)
    rows, cols = elev.shape
    visible = np.zeros(full_shape, dtype=bool)
    has_voids = elev.size > 0 and bool(np.isnan(np.min(elev)))  # one pass, no mask for a DEM without voids
    void = np.isnan(elev) if has_voids else None
    if has_voids and not void.all() and rows >= 2 and cols >= 2:
        elev, void = _filled_voids(elev, void)
        has_voids = bool(void.any())
    if rows < 2 or cols < 2 or (void is not None and np.isnan(elev).all()):
        return XyzResult(np.full((H, W, 3), np.nan), np.full((H, W), np.nan, dtype=np.float32),
                         np.full((H, W), -1, dtype=np.int32), visible, work, cam)
    if 2 * (rows - 1) * (cols - 1) >= 2 ** 31 - 1:
        raise ValueError(f"DEM of {rows} x {cols} cells is too large for one pass: crop it or use max_range")
    gt = np.asarray(work.geotransform, dtype=np.float64)
    C = np.asarray(cam.position, dtype=np.float64)
    R = np.ascontiguousarray(cam.rotation, dtype=np.float64)
    intr = _intrinsics(cam)
    near = NEAR_PLANE_M
    n = _chunk_count(H, W)
    xyz = np.empty((H, W, 3))  # scratch for the depth buffers first; every pixel is written by _exact_hits
    zbufs, tbufs = _depth_buffers(xyz, n)
    _rasterise(elev, gt, C, R, intr, near, _cull_sign(cam, work), zbufs, tbufs)
    tri = np.empty((H, W), dtype=np.int32)
    _merge(zbufs, tbufs, tri)
    del zbufs, tbufs
    if has_voids:
        _drop_void_hits(tri, void)
    limit = np.inf if max_range is None else float(max_range)
    dist = np.empty((H, W), dtype=np.float32)
    _exact_hits(tri, elev, gt, C, R, intr, limit, _threads(), xyz, dist)
    if visibility:
        vis = np.empty((rows, cols), dtype=np.bool_)
        _visibility(tri, elev, gt, C, R, intr, near, float(rel_tol),
                    float(work.cell_size if abs_tol is None else abs_tol), vis)
        if has_voids:
            vis &= ~void
        if max_range is not None:
            X, Y = work.cell_centres()
            rng = np.sqrt((X - C[0]) ** 2 + (Y - C[1]) ** 2 + (elev - C[2]) ** 2)
            vis &= rng <= max_range
        r0 = work.window[0] - dem.window[0]
        c0 = work.window[1] - dem.window[1]
        visible[r0:r0 + rows, c0:c0 + cols] = vis
    return XyzResult(xyz, dist, tri, visible, work, cam)


def compute_xyz(cam: Camera, dem: Dem, max_range: Optional[float] = None, crop: bool = True) -> np.ndarray:
    """(H, W, 3) float64 map coordinates of the first terrain point seen by each pixel centre; NaN where the ray
    meets no terrain (sky, voids, beyond the DEM or ``max_range``). See :func:`compute_xyz_full` for more."""
    return compute_xyz_full(cam, dem, max_range=max_range, crop=crop, visibility=False).xyz


def segment_first_hit(dem: Dem, origins, targets, smax: float = 1.0, voids_stop: bool = False) -> np.ndarray:
    """Exact line of sight: where each segment ``origin -> target`` first enters the terrain mesh from above.

    Crossings from below do not count, so a segment from a camera a few metres under a coarse DEM leaves the
    ground and is stopped only where it goes into the terrain again (as the z-buffer of :func:`compute_xyz_full`
    draws only the terrain's upper side).

    Args:
        dem: the terrain.
        origins, targets: (N, 3) or (3,) map coordinates.
        smax: search ``s`` in (0, smax] (1 = up to the target).
        voids_stop: a segment that meets an interior void (closed by a lid at its rim height) stops there with
            NaN, as a pixel of :func:`compute_xyz` does; default False: voids are holes it passes through.
    Returns:
        (N,) float64 parameter ``s`` of the first hit (point = origin + s (target - origin)); NaN where none.
        A target on the surface returns about 1; a target hidden behind terrain returns s < 1.

    >>> dem = Dem.from_array(np.zeros((5, 5)), (0, 1, 0, 5, 0, -1))
    >>> segment_first_hit(dem, [[2.5, 2.5, 10.0]], [[2.5, 2.5, -10.0]]).round(9).tolist()
    [0.5]
    >>> segment_first_hit(dem, [[2.5, 2.5, -10.0]], [[2.5, 2.5, 10.0]]).tolist()  # from below: no hit
    [nan]
    """
    origins = np.atleast_2d(np.asarray(origins, dtype=np.float64))
    targets = np.atleast_2d(np.asarray(targets, dtype=np.float64))
    origins = np.ascontiguousarray(np.broadcast_to(origins, targets.shape))
    out = np.full(len(targets), np.nan)
    if dem.rows < 2 or dem.cols < 2 or len(targets) == 0:
        return out
    g = dem.geotransform
    det = g[1] * g[5] - g[2] * g[4]
    inv = np.array([g[5] / det, -g[2] / det, -g[4] / det, g[1] / det])
    elev = np.ascontiguousarray(dem.elevation, dtype=np.float64)
    void = np.isnan(elev) if voids_stop else None
    if void is not None and void.any() and not void.all():
        elev, void = _filled_voids(elev, void)
    if void is not None and not void.any():
        void = None
    _segments_first_hit(elev, np.asarray(g, dtype=np.float64), inv, origins, np.ascontiguousarray(targets),
                        float(smax), out)
    if void is not None:
        hit = np.flatnonzero(np.isfinite(out))
        p = origins[hit] + out[hit, None] * (targets[hit] - origins[hit])
        col, row = dem.map_to_cell(p[:, 0], p[:, 1])
        c = np.clip(np.floor(np.asarray(col) - 0.5).astype(np.int64), 0, dem.cols - 2)
        r = np.clip(np.floor(np.asarray(row) - 0.5).astype(np.int64), 0, dem.rows - 2)
        in_void = void[r, c] | void[r, c + 1] | void[r + 1, c] | void[r + 1, c + 1]
        out[hit[in_void]] = np.nan
    return out
