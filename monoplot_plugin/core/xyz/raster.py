"""Z-buffer kernels: mesh vertices projected row by row, each quad's two triangles rasterised into per-thread depth
buffers of inverse depths and triangle ids (clipped at the near plane, back faces culled), the buffers merged.

With lens distortion whose polynomial stops growing at some radius (barrel, ``k1 < 0``), a vertex beyond that
radius has no pixel; a triangle with one is clipped to a pyramid inside the valid radius that holds the whole picture
(:data:`OUTSIDE_CONE`, :func:`_raster_clipped`) rather than dropped: the ground at the feet of a camera 1.7 m up,
seen at the bottom of a phone photo (k1 -0.06), lies in triangles whose far corners are beyond it, and the bottom
third of such a photo had no ground (a desktop trial).

>>> import numpy as np
>>> zbuf = np.zeros((1, 4, 4), dtype=np.float32); tbuf = np.full((1, 4, 4), -1, dtype=np.int32)
>>> _raster_triangle(0.0, 0.0, 1.0, 4.0, 0.0, 1.0, 0.0, 4.0, 1.0, 7, zbuf[0], tbuf[0], 0.0)
>>> int((tbuf[0] == 7).sum())        # pixel centres on or above the diagonal u + v = 4: 4 + 3 + 2 + 1
10
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import njit, prange
from .mesh import _distort, _vertex_cam

#: DEM rows per block of :func:`_rasterise`: a block projects its rows once each, plus one shared row.
RASTER_BLOCK_ROWS = 16
#: ``w`` of a vertex in front of the camera but beyond the distortion's valid radius (:func:`_project_row`): its
#: triangles are clipped (:func:`_raster_clipped`), not drawn from their corners nor dropped as voids (NaN).
OUTSIDE_CONE = -0.5


@njit(cache=True)
def _project_row(elev, gt, C, R, intr, near, r, c0, c1, u, v, w):
    """Project the mesh vertices of DEM row r, columns [c0, c1), into (cols,) float32 u, v (pixels; NaN if not in
    front) and w: inverse camera depth 1/z for vertices more than ``near`` in front, -1 for the others, NaN for voids,
    :data:`OUTSIDE_CONE` for vertices in front but outside the distortion's valid radius."""
    f, cx, cy, k1, k2, r2max = intr[0], intr[1], intr[2], intr[3], intr[4], intr[5]
    for c in range(c0, c1):
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
                    w[c] = OUTSIDE_CONE
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
def _clip_polygon(Q, n, nx, ny, nz, d, out):
    """Sutherland-Hodgman: the part of the convex polygon ``Q[:n]`` (camera frame) where ``nx x + ny y + nz z + d``
    is >= 0, into ``out``; returns its vertex count."""
    m = 0
    for k in range(n):
        a = Q[k]
        b = Q[(k + 1) % n]
        sa = nx * a[0] + ny * a[1] + nz * a[2] + d
        sb = nx * b[0] + ny * b[1] + nz * b[2] + d
        if sa >= 0.0:
            out[m] = a
            m += 1
        if (sa >= 0.0) != (sb >= 0.0):
            t = sa / (sa - sb)
            out[m] = a + t * (b - a)
            m += 1
    return m


@njit(cache=True)
def _raster_clipped(elev, gt, C, R, intr, near, ra, ca, rb, cb, rc, cc, tid, zbuf, tbuf, cull):
    """Clip a triangle that crosses the near plane, or (with distortion) has a corner beyond its valid radius, to
    the part in front and inside the pyramid ``|x| <= a z``, ``|y| <= b z`` (``intr[6]``, ``intr[7]``: inside the
    valid radius, holding the picture), then rasterise that polygon as a fan."""
    f, cx, cy, k1, k2, r2max = intr[0], intr[1], intr[2], intr[3], intr[4], intr[5]
    P = np.empty((3, 3))
    P[0, 0], P[0, 1], P[0, 2] = _vertex_cam(elev, gt, C, R, ra, ca)
    P[1, 0], P[1, 1], P[1, 2] = _vertex_cam(elev, gt, C, R, rb, cb)
    P[2, 0], P[2, 1], P[2, 2] = _vertex_cam(elev, gt, C, R, rc, cc)
    Q = np.empty((8, 3))
    Q2 = np.empty((8, 3))
    n = _clip_polygon(P, 3, 0.0, 0.0, 1.0, -near, Q)
    distorted = k1 != 0.0 or k2 != 0.0
    if distorted and r2max < np.inf:
        a, b = intr[6], intr[7]
        n = _clip_polygon(Q, n, -1.0, 0.0, a, 0.0, Q2)
        n = _clip_polygon(Q2, n, 1.0, 0.0, a, 0.0, Q)
        n = _clip_polygon(Q, n, 0.0, -1.0, b, 0.0, Q2)
        n = _clip_polygon(Q2, n, 0.0, 1.0, b, 0.0, Q)
    if n < 3:
        return
    U = np.empty(8)
    V = np.empty(8)
    Wd = np.empty(8)
    for k in range(n):
        xn = Q[k, 0] / Q[k, 2]
        yn = Q[k, 1] / Q[k, 2]
        if distorted:
            if xn * xn + yn * yn > r2max * 1.000001:
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


@njit(cache=True, inline="always")
def _all_done(done, shift, i0, i1, j0, j1):
    """Every tile of ``done`` (of 2 ** shift pixels a side) that the pixel box [i0, i1] x [j0, j1] touches is done."""
    for ti in range(i0 >> shift, (i1 >> shift) + 1):
        for tj in range(j0 >> shift, (j1 >> shift) + 1):
            if done[ti, tj] == 0:
                return False
    return True


@njit(cache=True)
def _raster_quad_row(ut, vt, wt, ub, vb, wb, r, c0, c1, elev, gt, C, R, intr, near, cull, zbuf, tbuf, done, shift):
    """Z-buffer the two triangles of every quad between DEM rows r (projected into ut, vt, wt) and r + 1 (ub, vb,
    wb), for the quads of columns [c0, c1 - 1); quads whose pixels all lie in tiles of ``done`` are skipped."""
    cols = elev.shape[1]
    H, W = zbuf.shape
    for c in range(c0, c1 - 1):
        w00 = wt[c]
        w01 = wt[c + 1]
        w10 = wb[c]
        w11 = wb[c + 1]
        if w00 > 0.0 and w01 > 0.0 and w10 > 0.0 and w11 > 0.0:
            # fast path (most quads): skip quads whose bounding box holds no pixel centre
            u00, u01, u10, u11 = ut[c], ut[c + 1], ub[c], ub[c + 1]
            v00, v01, v10, v11 = vt[c], vt[c + 1], vb[c], vb[c + 1]
            if cull != 0.0:  # both triangles back-facing (the signs _raster_quad and _raster_triangle test): skip
                acu = u11 - u00  # the quad before its pixel box is worked out (about half the quads of a view)
                acv = v11 - v00
                if (cull * (acu * (v01 - v00) - acv * (u01 - u00)) > 0.0
                        and cull * (acu * (v10 - v00) - acv * (u10 - u00)) < 0.0):
                    continue
            umin = min(min(u00, u01), min(u10, u11))
            umax = max(max(u00, u01), max(u10, u11))
            if math.floor(umax - 0.5) < math.ceil(umin - 0.5) or umax < 0.5 or umin > W - 0.5:
                continue
            vmin = min(min(v00, v01), min(v10, v11))
            vmax = max(max(v00, v01), max(v10, v11))
            if math.floor(vmax - 0.5) < math.ceil(vmin - 0.5) or vmax < 0.5 or vmin > H - 0.5:
                continue
            base = 2 * (r * (cols - 1) + c)
            j0 = max(0, int(math.ceil(umin - 0.5)))
            j1 = min(W - 1, int(math.floor(umax - 0.5)))
            i0 = max(0, int(math.ceil(vmin - 0.5)))
            i1 = min(H - 1, int(math.floor(vmax - 0.5)))
            if _all_done(done, shift, i0, i1, j0, j1):
                continue
            if not _raster_quad(u00, v00, w00, u01, v01, w01, u11, v11, w11, u10, v10, w10,
                                i0, i1, j0, j1, base, zbuf, tbuf, cull):
                _raster_triangle(u00, v00, w00, u01, v01, w01, u11, v11, w11, base, zbuf, tbuf, cull)
                _raster_triangle(u00, v00, w00, u11, v11, w11, u10, v10, w10, base + 1, zbuf, tbuf, cull)
            continue
        if not (w00 > 0.0 or w01 > 0.0 or w10 > 0.0 or w11 > 0.0 or w00 == OUTSIDE_CONE or w01 == OUTSIDE_CONE
                or w10 == OUTSIDE_CONE or w11 == OUTSIDE_CONE):
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
            elif wa > 0.0 or wb_ > 0.0 or wc > 0.0 or wa == OUTSIDE_CONE or wb_ == OUTSIDE_CONE \
                    or wc == OUTSIDE_CONE:
                _raster_clipped(elev, gt, C, R, intr, near, ra, ca, rb, cb, rc, cc, base + t, zbuf, tbuf, cull)


@njit(parallel=True, cache=True)
def _rasterise(elev, gt, C, R, intr, near, cull, zbufs, tbufs, lo, hi, done, tile):
    """Z-buffer all mesh triangles. Chunk k handles the blocks of RASTER_BLOCK_ROWS DEM rows b = k, k + nchunks, ...
    into its own buffers (no write races, balanced load); the caller merges the chunks. Vertices are projected
    row by row as the block goes (two rows held, no DEM-sized arrays). Only the columns [lo[r], hi[r]) of each row
    r are drawn (the span of the grid a level-of-detail band needs; 0 and cols for a whole grid). ``done``: (Ht, Wt)
    uint8 per tile of ``tile`` x ``tile`` pixels (a power of two), 1 where every pixel already has its answer (a
    nearer band's), so that terrain hidden there is not drawn (a (1, 1) zero array and a huge tile: draw
    everything)."""
    rows, cols = elev.shape
    nchunks = zbufs.shape[0]
    shift = 0  # tile = 2 ** shift (a power of two: tile indices by shifts, not divisions)
    while (1 << shift) < tile:
        shift += 1
    nblocks = (rows - 1 + RASTER_BLOCK_ROWS - 1) // RASTER_BLOCK_ROWS
    for k in prange(nchunks):
        zbuf = zbufs[k]
        tbuf = tbufs[k]
        top = np.empty((3, cols), dtype=np.float32)
        bottom = np.empty((3, cols), dtype=np.float32)
        for b in range(k, nblocks, nchunks):
            r0 = b * RASTER_BLOCK_ROWS
            r1 = min(r0 + RASTER_BLOCK_ROWS, rows - 1)
            _project_row(elev, gt, C, R, intr, near, r0, lo[r0], hi[r0], top[0], top[1], top[2])
            for r in range(r0, r1):
                _project_row(elev, gt, C, R, intr, near, r + 1, lo[r + 1], hi[r + 1], bottom[0], bottom[1],
                             bottom[2])
                _raster_quad_row(top[0], top[1], top[2], bottom[0], bottom[1], bottom[2], r,
                                 max(lo[r], lo[r + 1]), min(hi[r], hi[r + 1]), elev, gt, C, R, intr, near, cull,
                                 zbuf, tbuf, done, shift)
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
