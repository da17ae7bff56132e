"""Minimal-set solvers of the consensus registration (:mod:`.consensus`): from two photo rays and the world
directions of their DEM points, the focal length that gives the rays their angle, and the rotation that takes the
directions onto the rays.

Conventions: pixels, camera frame x right / y down / z forward, see :mod:`~monoplot_plugin.core.camera`.
"""

from __future__ import annotations

import math  # noqa: F401 (the doctests use it)

import numpy as np

__all__ = ["focal_from_ray_angle", "rotation_from_two_rays", "camera_rays", "rotation_between"]


def focal_from_ray_angle(p1: np.ndarray, p2: np.ndarray, cos_world: np.ndarray) -> np.ndarray:
    """Focal lengths (pixels) at which the rays of two pixels make the angle whose cosine is ``cos_world``.

    Args:
        p1, p2: (H, 2) pixel offsets from the principal point.
        cos_world: (H,) cosine of the angle between the two world directions.
    Returns:
        (H,) focal length, NaN where no positive focal length gives that angle.

    >>> f = focal_from_ray_angle(np.array([[-100.0, 0]]), np.array([[100.0, 0]]), np.array([math.cos(math.pi / 2)]))
    >>> round(float(f[0]), 6)   # two rays 90 degrees apart, 100 px either side of the centre
    100.0
    """
    a = np.sum(p1 * p2, axis=1)
    r1 = np.sum(p1 * p1, axis=1)
    r2 = np.sum(p2 * p2, axis=1)
    c2 = cos_world * cos_world
    # (a + F)^2 = c^2 (r1 + F)(r2 + F) with F = f^2, and a + F of the sign of c.
    qa = 1.0 - c2
    qb = 2.0 * a - c2 * (r1 + r2)
    qc = a * a - c2 * r1 * r2
    disc = qb * qb - 4.0 * qa * qc
    out = np.full(len(a), np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        root = np.sqrt(np.where(disc >= 0, disc, np.nan))
        for F in ((-qb + root) / (2.0 * qa), (-qb - root) / (2.0 * qa)):
            # Squaring admitted the supplementary angle too: keep the root whose cosine is the one asked for.
            cos_at = (a + F) / np.sqrt((r1 + F) * (r2 + F))
            good = np.isfinite(F) & (F > 0) & (np.abs(cos_at - cos_world) < 1e-6) & np.isnan(out)
            out[good] = np.sqrt(F[good])
    return out


def rotation_from_two_rays(b1, b2, w1, w2) -> np.ndarray:
    """(H, 3, 3) world-to-camera rotations taking the world directions ``w1, w2`` onto the camera rays ``b1, b2``
    (exactly for the first, in the plane of the two for the second). All inputs (H, 3) unit vectors.

    >>> R = rotation_from_two_rays(np.array([[0.0, 0, 1]]), np.array([[1.0, 0, 0]]),
    ...                            np.array([[0.0, 1, 0]]), np.array([[1.0, 0, 0]]))
    >>> np.round(R[0] @ np.array([0.0, 1, 0]), 6).tolist()
    [0.0, 0.0, 1.0]
    """
    def frame(a, b):
        e2 = np.cross(a, b)
        e2 /= np.linalg.norm(e2, axis=1, keepdims=True)
        e3 = np.cross(a, e2)
        return np.stack([a, e2, e3], axis=2)  # columns

    return frame(b1, b2) @ np.transpose(frame(w1, w2), (0, 2, 1))


def camera_rays(offsets: np.ndarray, focal: np.ndarray) -> np.ndarray:
    """(H, 2) pixel offsets from the principal point and (H,) focal lengths -> (H, 3) unit camera rays."""
    v = np.concatenate([offsets, focal[:, None]], axis=1)
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(3, 3) smallest rotation taking unit vector ``a`` onto unit vector ``b`` (Rodrigues)."""
    v = np.cross(a, b)
    c = float(a @ b)
    vx = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + vx + vx @ vx / (1.0 + c)
