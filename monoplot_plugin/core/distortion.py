"""The one radial distortion model of Monoplot (OpenCV's k1, k2), for numpy, torch and the compiled z-buffer alike.

Normalised image coordinates ``(x, y) = (X / Z, Y / Z)`` in the camera frame are distorted as

    x_d = x (1 + k1 r^2 + k2 r^4),   y_d = y (1 + k1 r^2 + k2 r^4),   r^2 = x^2 + y^2

and undistorted by Newton's method on the radius (:func:`undistort`), which converges quadratically wherever the
polynomial ``r (1 + k1 r^2 + k2 r^4)`` keeps growing, i.e. below :func:`valid_radius2`. Beyond that radius the model
folds back on itself (two radii give the same distorted one): the z-buffer does not project such points at all.

The functions use plain arithmetic only, so the same code runs on floats, numpy arrays, torch tensors and, compiled
by numba, inside the kernels of :mod:`.xyz` (which compile these very functions: there is no second copy).

>>> xd, yd = distort(0.3, -0.2, -0.1, 0.01)
>>> [round(float(v), 12) for v in undistort(xd, yd, -0.1, 0.01)]
[0.3, -0.2]
>>> round(valid_radius2(-0.2, 0.0), 6)       # 1 + 3 k1 r^2 = 0 -> r^2 = 1 / 0.6, kept 0.1 % inside
1.665
"""

from __future__ import annotations

import math

__all__ = ["distort", "undistort", "valid_radius2", "UNDISTORT_ITERATIONS"]

#: Newton steps of :func:`undistort` (quadratic convergence: far more than any usable lens needs).
UNDISTORT_ITERATIONS = 30


def distort(xn, yn, k1, k2):
    """Distorted normalised coordinates ``(x_d, y_d)`` of undistorted ones (floats, arrays or tensors)."""
    r2 = xn * xn + yn * yn
    s = 1.0 + k1 * r2 + k2 * r2 * r2
    return xn * s, yn * s


def undistort(xd, yd, k1, k2, iterations=UNDISTORT_ITERATIONS):
    """Undistorted normalised coordinates of distorted ones (inverse of :func:`distort`); exact when k1 = k2 = 0.

    Newton's method on the radius, written for the ratio ``s = r / r_d`` (the same iterates, without a division by
    ``r_d``, so the centre needs no special case): ``s (1 + k1 s^2 r_d^2 + k2 s^4 r_d^4) = 1`` from ``s = 1``.
    Beyond the valid radius (:func:`valid_radius2`) the result is meaningless or not finite; callers only use radii
    inside it.
    """
    if k1 == 0.0 and k2 == 0.0:
        return xd, yd
    rd2 = xd * xd + yd * yd
    s = 1.0 + 0.0 * rd2
    for _ in range(iterations):
        q = s * s * rd2
        residual = s * (1.0 + k1 * q + k2 * q * q) - 1.0
        slope = 1.0 + 3.0 * k1 * q + 5.0 * k2 * q * q
        s = s - residual / slope
    return xd * s, yd * s


def valid_radius2(k1: float, k2: float) -> float:
    """Largest r^2 (times 0.999) below which the distortion polynomial keeps growing: the smallest positive root of
    ``d/dr [r (1 + k1 r^2 + k2 r^4)] = 1 + 3 k1 r^2 + 5 k2 r^4``; infinity when it has none.

    >>> valid_radius2(0.0, 0.0), valid_radius2(0.1, 0.0)
    (inf, inf)
    """
    if k2 == 0.0:
        return -1.0 / (3.0 * k1) * 0.999 if k1 < 0.0 else math.inf
    disc = 9.0 * k1 * k1 - 20.0 * k2
    if disc < 0.0:
        return math.inf
    roots = [(-3.0 * k1 + sign * math.sqrt(disc)) / (10.0 * k2) for sign in (-1.0, 1.0)]
    positive = [x for x in roots if x > 0.0]
    return min(positive) * 0.999 if positive else math.inf
