"""Edge alignment: score camera hypotheses by how well the DEM's skyline and occluding contours fall on the
photo's, and search heading, pitch, roll, field of view and position coarse to fine.

The score of a hypothesis (lower is better, 0..about 1.5):

- skyline: in each photo column with a clear skyline, the row of the top-most projected DEM skyline point against
  the photo's skyline row; each difference ``d`` counts ``d^2 / (d^2 + tau^2)`` (a column without DEM skyline counts
  1); the mean over the columns;
- contours (weight :data:`CONTOUR_WEIGHT`): each projected occluding-contour point looks up the distance to the
  nearest photo edge of a similar direction (the oriented chamfer, :mod:`.photo_edges`), counted the same way;
- a weak pull to the prior (``PRIOR_WEIGHT`` times the mean squared offset in σ units), so that near ties go to
  the stated camera.

Hypotheses are offsets ``(heading, pitch, roll, fov, x, y, z)`` from a reference camera, scored in batches by
projecting the same 3-D edge points (:mod:`.dem_edges`): rendering once per stage, not once per hypothesis.

>>> offsets_grid({"angle_deg": 2.0, "fov_deg": 1.0}, step_deg=1.0).shape[1]
7
"""

from __future__ import annotations

import math
from typing import Callable, Optional

import numpy as np

from ..camera import Camera, rotation_matrix
from .photo_edges import PhotoEdges, orientation_bin

__all__ = ["Aligner", "offsets_grid", "CONTOUR_WEIGHT", "PRIOR_WEIGHT", "camera_from_offset"]

CONTOUR_WEIGHT = 0.15
PRIOR_WEIGHT = 0.01
#: Largest gap (working px) between neighbouring projected DEM skyline points bridged by interpolation.
SKY_GAP_PX = 3.0
#: How many σ of the prior the search may go (a steep penalty beyond).
BOUND_SIGMAS = 3.0
#: Offsets vector: heading, pitch, roll, fov (degrees), x, y, z (metres).
NAMES = ("heading", "pitch", "roll", "fov", "x", "y", "z")


def camera_from_offset(ref: Camera, offset, ground=None) -> Camera:
    """``ref`` moved by one offsets vector (see :data:`NAMES`); ``ground``: (DEM, eye height in metres) of a camera
    on the ground, whose height then follows the terrain (the vector's height is not used)."""
    off = np.asarray(offset, dtype=np.float64)[None] if ground is None else \
        grounded_offsets(np.asarray(offset, dtype=np.float64)[None], ref.position, ground)
    dh, dp, dr, df, dx, dy, dz = (float(v) for v in off[0])
    x, y, z = ref.position
    return ref.with_parameters(heading=ref.heading + dh, pitch=ref.pitch + dp, roll=ref.roll + dr,
                               fov=min(170.0, max(2.0, ref.fov + df)), x=x + dx, y=y + dy, z=z + dz)


def ground_heights(ground, x, y, otherwise) -> np.ndarray:
    """(N,) heights ``ground[1]`` metres above the terrain of ``ground[0]`` (a DEM) at map points (x, y), arrays of
    N; ``otherwise`` (N,) where the DEM has no height."""
    dem, eye = ground
    z = np.asarray(dem.sample(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)),
                   dtype=np.float64).reshape(-1) + float(eye)
    return np.where(np.isfinite(z), z, np.asarray(otherwise, dtype=np.float64))


def grounded_offsets(offsets: np.ndarray, origin, ground) -> np.ndarray:
    """(N, 7) ``offsets`` from ``origin`` (x, y, z) with each height set ``ground[1]`` metres above the terrain of
    ``ground[0]`` (a DEM) under its position (:func:`ground_heights`); kept where the DEM has no height."""
    out = offsets.copy()
    out[:, 6] = ground_heights(ground, origin[0] + offsets[:, 4], origin[1] + offsets[:, 5],
                               origin[2] + offsets[:, 6]) - origin[2]
    return out


def offsets_grid(sigmas: dict, step_deg: float, extent: float = 2.5, fov_steps: int = 5,
                 roll_steps: int = 3) -> np.ndarray:
    """(N, 7) offsets on a grid: heading and pitch within ``extent`` σ in steps of ``step_deg``, ``fov_steps``
    fields of view and ``roll_steps`` rolls within the same σ range (position at the reference)."""
    a = extent * sigmas["angle_deg"]
    n = max(1, int(math.floor(a / step_deg)))
    hp = np.arange(-n, n + 1) * step_deg
    fo = np.linspace(-extent * sigmas["fov_deg"], extent * sigmas["fov_deg"], fov_steps) if fov_steps > 1 \
        else np.zeros(1)
    ro = np.linspace(-0.5 * a, 0.5 * a, roll_steps) if roll_steps > 1 else np.zeros(1)
    H, P, R, F = np.meshgrid(hp, hp, ro, fo, indexing="ij")
    out = np.zeros((H.size, 7))
    out[:, 0], out[:, 1], out[:, 2], out[:, 3] = H.ravel(), P.ravel(), R.ravel(), F.ravel()
    return out


def _every(n: int, most: int) -> np.ndarray:
    return np.arange(n) if n <= most else np.linspace(0, n - 1, most).astype(np.int64)


class Aligner:
    """Scores offsets from ``ref`` against one :class:`PhotoEdges` with one set of DEM edge points.

    Args:
        ref: reference camera (full photo size).
        photo: the photo's edges at some working size.
        edges: :class:`~.dem_edges.DemEdges` rendered near ``ref``.
        sigmas: the prior's σ (``angle_deg``, ``fov_deg``, ``position_m``) and ``prior`` offsets of the stated
            camera from ``ref`` (for the pull to the prior).
        tau: the distance scale (working pixels) of a good match.
    """

    def __init__(self, ref: Camera, photo: PhotoEdges, edges, sigmas: dict, tau: float,
                 prior_offset: Optional[np.ndarray] = None, is_canceled: Optional[Callable[[], bool]] = None,
                 max_points: int = 4000):
        self.ref, self.photo, self.tau = ref, photo, float(tau)
        self.origin = np.asarray(ref.position, dtype=np.float64)
        ks = _every(len(edges.sky), max_points)
        kc = _every(len(edges.contour), max_points)
        self.sky = edges.sky[ks] - self.origin
        self.sky_next = edges.sky_next[ks] - self.origin
        self.contour = edges.contour[kc] - self.origin
        self.contour_next = edges.contour_next[kc] - self.origin
        border = getattr(edges, "border", np.zeros((0, 3)))
        self.border = border[_every(len(border), max_points)] - self.origin
        self.scale_vec = np.array([sigmas["angle_deg"]] * 3 + [sigmas["fov_deg"]] + [sigmas["position_m"]] * 3)
        #: (DEM, eye height) of a camera on the ground: every hypothesis's height follows the terrain
        self.ground = sigmas.get("ground")
        self.prior_offset = np.zeros(7) if prior_offset is None else np.asarray(prior_offset, dtype=np.float64)
        self.sky_cols = np.nonzero(photo.sky_valid)[0]
        self.sky_rows = photo.sky_row[self.sky_cols]
        self.use_sky = photo.usable and len(self.sky_cols) > 0 and len(self.sky) > 0
        self.is_canceled = is_canceled
        self.evaluations = 0
        #: False: :meth:`score` is the edges' agreement alone (no pull to the prior, no bound).
        self.with_prior = True

    def _project(self, offsets: np.ndarray, pts: np.ndarray):
        """(N, M) u, v, depth of the points under every hypothesis (working pixels)."""
        if self.ground is not None:
            offsets = grounded_offsets(offsets, self.origin, self.ground)
        h = self.ref.heading + offsets[:, 0]
        p = self.ref.pitch + offsets[:, 1]
        r = self.ref.roll + offsets[:, 2]
        fov = np.clip(self.ref.fov + offsets[:, 3], 2.0, 170.0)
        if len(offsets) == 1:  # numpy collapses one-element angle arrays to scalars
            R = rotation_matrix(float(h[0]), float(p[0]), float(r[0]))[None]
        else:
            R = np.transpose(rotation_matrix(h, p, r), (2, 0, 1))  # (N, 3, 3)
        # R (P - t) for every hypothesis at once: one (3N, 3) x (3, M) product, less R t per hypothesis (a batched
        # (N, M, 3) x (3, 3) product is several times slower).
        cam = (R.reshape(-1, 3) @ pts.T).reshape(len(offsets), 3, -1)
        cam -= np.einsum("nkj,nj->nk", R, offsets[:, 4:7])[:, :, None]
        W = self.photo.width
        f = (W / 2.0) / np.tan(np.radians(fov) / 2.0)
        s = W / self.ref.width
        cx, cy = self.ref.cx * s, self.ref.cy * s
        z = cam[:, 2]
        safe = np.where(z > 1e-6, z, 1.0)
        u = f[:, None] * cam[:, 0] / safe + cx
        v = f[:, None] * cam[:, 1] / safe + cy
        return u, v, z

    def _sky_top(self, u, v, z) -> np.ndarray:
        """(N, W) projected DEM skyline row at each working column's centre (inf where none): linear between the
        two skyline points on either side of the centre, when they lie within :data:`SKY_GAP_PX` of each other.

        The DEM's skyline has one point per rendered column (below a terrain point every lower ray hits the
        terrain too), so neighbours in ``u`` are neighbours along the skyline. Interpolating, not taking the
        top-most point near the column, keeps a sloping skyline where it is: the top-most of the points within a
        pixel lies up to a pixel above it on a slope, a bias in pitch and field of view."""
        N, M = u.shape
        W = self.photo.width
        if M == 0:
            return np.full((N, W), np.inf)
        uu = np.where(z > 0, u, np.inf)
        order = np.argsort(uu, axis=1)
        us = np.take_along_axis(uu, order, axis=1)
        vs = np.take_along_axis(v, order, axis=1)
        span = W + 8.0  # rows of hypotheses laid end to end for one search
        key = (np.clip(us, -2.0, W + 2.0) + np.arange(N)[:, None] * span).ravel()
        centre = np.arange(W) + 0.5
        q = (centre[None, :] + np.arange(N)[:, None] * span).ravel()
        right = np.searchsorted(key, q, side="right")
        left = right - 1
        row = np.repeat(np.arange(N), W)
        ok = (left >= row * M) & (right < (row + 1) * M)
        left, right = np.where(ok, left, 0), np.where(ok, right, 0)
        u0, u1 = us.ravel()[left], us.ravel()[right]
        v0, v1 = vs.ravel()[left], vs.ravel()[right]
        with np.errstate(invalid="ignore"):  # inf - inf where a column has no skyline: not finite, left out below
            gap = u1 - u0
        ok &= np.isfinite(gap) & (gap <= SKY_GAP_PX)
        t = np.where(ok & (gap > 1e-9), (np.tile(centre, N) - u0) / np.where(gap > 1e-9, gap, 1.0), 0.0)
        return np.where(ok, v0 + t * (v1 - v0), np.inf).reshape(N, W)

    def _rho(self, d):
        d2 = d * d
        return d2 / (d2 + self.tau * self.tau)

    def score(self, offsets, done: Optional[Callable[[float], None]] = None) -> np.ndarray:
        """(N,) scores of (N, 7) offsets (lower is better), in batches (polls ``is_canceled`` between them).
        ``done(fraction)``: called after each batch with the share of ``offsets`` scored (a grid of thousands of
        cameras takes half a minute: the bar moves meanwhile)."""
        offsets = np.atleast_2d(np.asarray(offsets, dtype=np.float64))
        out = np.empty(len(offsets))
        batch = max(1, int(2e6 // max(1, len(self.sky) + 2 * len(self.contour))))
        for a in range(0, len(offsets), batch):
            if self.is_canceled is not None and self.is_canceled():
                from ..fit import FitCanceled

                raise FitCanceled()
            out[a:a + batch] = self._score(offsets[a:a + batch])
            if done is not None:
                done(min(len(offsets), a + batch) / len(offsets))
        self.evaluations += len(offsets)
        return out

    def _score(self, off: np.ndarray) -> np.ndarray:
        N = len(off)
        W, H = self.photo.width, self.photo.height
        total = np.zeros(N)
        weight = 0.0
        if self.use_sky:
            top = self._sky_top(*self._project(off, self.sky))[:, self.sky_cols]
            d = np.abs(top - self.sky_rows[None, :])
            cost = np.where(np.isfinite(d), self._rho(np.where(np.isfinite(d), d, 0.0)), 1.0)
            total += cost.mean(axis=1)
            weight += 1.0
        if len(self.contour):
            u, v, z = self._project(off, self.contour)
            un, vn, _ = self._project(off, self.contour_next)
            inside = (z > 0) & (u >= 0) & (u < W) & (v >= 0) & (v < H) & self._in_mask(u, v)
            b = orientation_bin(np.arctan2(vn - v, un - u))
            r = np.clip(v.astype(np.int64), 0, H - 1)
            c = np.clip(u.astype(np.int64), 0, W - 1)
            d = self.photo.oriented_dt[b, r, c]
            cost = np.where(inside, self._rho(d), 0.0).sum(axis=1)
            n_in = inside.sum(axis=1)
            # Few contour points in the picture: the hypothesis looks mostly elsewhere; count them as misses.
            need = max(10.0, 0.2 * len(self.contour))
            cost = (cost + np.maximum(0.0, need - n_in)) / np.maximum(n_in, need)
            w = CONTOUR_WEIGHT if self.use_sky else 1.0
            total += w * cost
            weight += w
        # No edge at all to compare (no skyline, no contour point): no evidence, the worst score.
        total = total / weight if weight > 0 else np.ones(N)
        if not self.with_prior:
            return total
        dev = (off - self.prior_offset[None, :]) / self.scale_vec[None, :]
        # Beyond BOUND_SIGMAS of the prior the score rises steeply: the search stays where the prior allows.
        beyond = np.maximum(np.abs(dev) - BOUND_SIGMAS, 0.0)
        return total + PRIOR_WEIGHT * np.mean(dev * dev, axis=1) + np.sum(beyond * beyond, axis=1)

    def _in_mask(self, u, v):
        r = np.clip(v.astype(np.int64), 0, self.photo.height - 1)
        c = np.clip(u.astype(np.int64), 0, self.photo.width - 1)
        return self.photo.mask[r, c]

    def pattern_search(self, start, steps, min_steps, max_iter: int = 60):
        """Batched compass search from ``start``: all ± steps (and angle-position pairs of steps) scored at once,
        move to the best, halve the steps when nothing improves. Returns (offset, score)."""
        x = np.asarray(start, dtype=np.float64).copy()
        steps = np.asarray(steps, dtype=np.float64).copy()
        min_steps = np.asarray(min_steps, dtype=np.float64)
        best = float(self.score(x[None])[0])
        eye = np.eye(7)
        combos = []  # an angle with a position coordinate: turning while moving keeps far terrain in place
        for i in range(4):
            for j in range(4, 7):
                for si in (-1, 1):
                    for sj in (-1, 1):
                        e = np.zeros(7)
                        e[i], e[j] = si, sj
                        combos.append(e)
        dirs = np.vstack([eye, -eye, np.asarray(combos)])
        for _ in range(max_iter):
            cand = x[None, :] + dirs * steps[None, :]
            s = self.score(cand)
            k = int(np.argmin(s))
            if s[k] < best - 1e-6:
                x, best = cand[k], float(s[k])
            else:
                if np.all(steps <= min_steps):
                    break
                steps = np.maximum(steps * 0.5, min_steps * 0.999)
        return x, best

    def residuals(self, offsets: np.ndarray) -> np.ndarray:
        """(N, R) residuals (working px) of (N, 7) offsets: per clear skyline column the DEM's top row less the
        photo's (0 where the DEM shows no skyline), then per contour point the bilinear distance to the nearest
        photo edge of its direction (0 outside the picture)."""
        N = len(offsets)
        W, H = self.photo.width, self.photo.height
        parts = []
        if self.use_sky:
            d = self._sky_top(*self._project(offsets, self.sky))[:, self.sky_cols] - self.sky_rows[None, :]
            parts.append(np.where(np.isfinite(d), d, 0.0))
        if len(self.contour):
            u, v, z = self._project(offsets, self.contour)
            un, vn, _ = self._project(offsets, self.contour_next)
            b = orientation_bin(np.arctan2(vn - v, un - u))
            x, y = np.clip(u - 0.5, 0, W - 1.001), np.clip(v - 0.5, 0, H - 1.001)
            c0, r0 = x.astype(np.int64), y.astype(np.int64)
            fx, fy = x - c0, y - r0
            dt = self.photo.oriented_dt
            d = ((dt[b, r0, c0] * (1 - fx) + dt[b, r0, c0 + 1] * fx) * (1 - fy)
                 + (dt[b, r0 + 1, c0] * (1 - fx) + dt[b, r0 + 1, c0 + 1] * fx) * fy)
            inside = (z > 0) & (u >= 0) & (u < W) & (v >= 0) & (v < H)
            w = math.sqrt(CONTOUR_WEIGHT * max(1, len(self.sky_cols)) / len(self.contour)) if self.use_sky else 1.0
            parts.append(np.where(inside, d, 0.0) * w)
        return np.concatenate(parts, axis=1) if parts else np.zeros((N, 0))

    def least_squares(self, start, iterations: int = 12):
        """Robust Gauss-Newton (Cauchy weights at ``tau``) on :meth:`residuals` from ``start``; the Jacobian by
        finite differences, all seven perturbations scored in one batch. Returns (offset, score)."""
        x = np.asarray(start, dtype=np.float64).copy()
        h = np.array([0.01, 0.01, 0.01, 0.01, 0.5, 0.5, 0.5])
        lam = 1e-2
        best = float(self.score(x[None])[0])
        for _ in range(iterations):
            if self.is_canceled is not None and self.is_canceled():
                from ..fit import FitCanceled

                raise FitCanceled()
            batch = np.vstack([x[None], x[None] + np.diag(h)])
            r = self.residuals(batch)
            J = (r[1:] - r[0][None, :]).T / h[None, :]  # (R, 7)
            w = 1.0 / (1.0 + (r[0] / self.tau) ** 2)
            A = (J * w[:, None]).T @ J
            g = (J * w[:, None]).T @ r[0]
            scale = self.scale_vec
            A += np.diag(PRIOR_WEIGHT * len(r[0]) / scale ** 2 * 0.1)
            improved = False
            for _ in range(4):
                try:
                    step = -np.linalg.solve(A + lam * np.diag(np.diag(A) + 1e-9), g)
                except np.linalg.LinAlgError:
                    break
                cand = x + step
                s = float(self.score(cand[None])[0])
                if s < best - 1e-7:
                    x, best, lam, improved = cand, s, max(lam / 3.0, 1e-4), True
                    break
                lam *= 4.0
            if not improved or np.all(np.abs(step) < h):
                break
        return x, best

    def edge_spread(self, offset) -> float:
        """How much of the picture the DEM's edges under ``offset`` span: the larger of their width and height
        (5th to 95th percentile of the skyline and contour points inside the picture) over the picture's, 0..1
        (0 with fewer than 10 such points)."""
        off = np.asarray(offset, dtype=np.float64)[None]
        W, H = self.photo.width, self.photo.height
        us, vs = [], []
        for pts in (self.sky, self.contour):
            if len(pts):
                u, v, z = (a[0] for a in self._project(off, pts))
                inside = (z > 0) & (u >= 0) & (u < W) & (v >= 0) & (v < H)
                us.append(u[inside])
                vs.append(v[inside])
        u = np.concatenate(us) if us else np.zeros(0)
        v = np.concatenate(vs) if vs else np.zeros(0)
        if len(u) < 10:
            return 0.0
        (u0, u1), (v0, v1) = np.percentile(u, [5, 95]), np.percentile(v, [5, 95])
        return float(min(1.0, max((u1 - u0) / W, (v1 - v0) / H)))

    def skyline_at_dem_edge(self, offset, within_px: float) -> float:
        """Share of the photo's clear skyline columns where, under ``offset``, the DEM's skyline is its edge (the
        terrain beyond the DEM is missing, :attr:`~.dem_edges.DemEdges.border`) lying higher than ``within_px``
        above any skyline point inside it: there the photo's skyline cannot be compared with the DEM's."""
        if not self.use_sky or not len(self.border):
            return 0.0
        off = np.asarray(offset, dtype=np.float64)[None]
        edge = self._sky_top(*self._project(off, self.border))[0][self.sky_cols]
        inside = self._sky_top(*self._project(off, self.sky))[0][self.sky_cols]
        return float(np.mean(np.isfinite(edge) & ~(inside <= edge + within_px)))

    def skyline_agreement(self, offset, within_px: float) -> float:
        """Share of the photo's clear skyline columns whose DEM skyline lies within ``within_px`` working pixels."""
        if not self.use_sky:
            return 0.0
        off = np.asarray(offset, dtype=np.float64)[None]
        top = self._sky_top(*self._project(off, self.sky))[0]
        d = np.abs(top[self.sky_cols] - self.sky_rows)
        return float(np.mean(d <= within_px))

