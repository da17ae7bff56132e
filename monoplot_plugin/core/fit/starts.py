"""Where the searches start: the unpaired descent's pattern of starts and random jumps around the initial camera,
and the paired mode's PnP and DLT solutions."""

from __future__ import annotations

from typing import List

import numpy as np

from ..camera import Camera, angles_from_rotation, fov_from_focal
from .params import ParameterSpace

__all__ = ["start_vectors", "jump", "pnp_starts", "dlt_start"]


def start_vectors(ctx, space: ParameterSpace, n: int) -> List[np.ndarray]:
    """The initial camera first, then a deterministic pattern of rotated / zoomed / moved starts."""
    cam = ctx.initial
    offsets = []
    h, v = cam.fov, cam.vertical_fov
    for dh, dp, zoom in [(0.25, 0, 1), (-0.25, 0, 1), (0, 0, 0.8), (0, 0, 1.25), (0, 0.25, 1), (0, -0.25, 1),
                         (0.5, 0, 1), (-0.5, 0, 1), (0.25, 0.2, 0.9), (-0.25, -0.2, 1.1), (0.25, -0.2, 1.1),
                         (-0.25, 0.2, 0.9)]:
        offsets.append(dict(heading=cam.heading + dh * h, pitch=cam.pitch + dp * v,
                            fov=min(170.0, cam.fov * zoom)))
    vectors = [space.zero()]
    for o in offsets:
        if len(vectors) >= n:
            break
        values = {k: val for k, val in o.items() if k in space.names}
        if not values:
            continue
        vectors.append(space.from_camera(cam.with_parameters(**values)))
    while len(vectors) < n:
        vectors.append(jump(ctx, space, 1.0))
    return vectors


def jump(ctx, space: ParameterSpace, size: float) -> np.ndarray:
    """Random perturbation: about ``size`` x (a quarter of the field of view, 10 % zoom, 3 % of the range)."""
    u = np.zeros(space.size)
    cam = ctx.initial
    for i, name in enumerate(space.names):
        if name in ("heading", "pitch", "roll"):
            span = {"heading": 0.25 * cam.fov, "pitch": 0.25 * cam.vertical_fov, "roll": 3.0}[name]
        elif name == "fov":
            span = 0.1 * cam.fov
        elif name in ("x", "y", "z"):
            span = 0.03 * ctx.typical_range
        else:
            span = 0.0
        u[i] = size * span * ctx.rng.uniform(-1, 1) / space.scales[i]
    return u


def pnp_starts(q: np.ndarray, P: np.ndarray, origin: np.ndarray, initial: Camera) -> List[Camera]:
    """Cameras from OpenCV PnP on centred points, for the initial field of view and a sweep around it."""
    if len(q) < 4:
        return []
    import cv2

    out = []
    for zoom in (1.0, 0.6, 0.8, 1.25, 1.6):
        fov = min(150.0, initial.fov * zoom)
        cam = initial.with_parameters(fov=fov)
        K = cam.K.copy()
        K[0, 2] -= 0.5
        K[1, 2] -= 0.5
        dist = np.array([cam.k1, cam.k2, 0.0, 0.0, 0.0])
        for flag in (cv2.SOLVEPNP_SQPNP, cv2.SOLVEPNP_ITERATIVE):
            try:
                ok, rvec, tvec = cv2.solvePnP(P.astype(np.float64), q.astype(np.float64), K, dist, flags=flag)
            except cv2.error:
                continue
            if not ok or not np.isfinite(rvec).all() or not np.isfinite(tvec).all():
                continue
            found = Camera.from_opencv(rvec, tvec, K, dist[:2], cam.image_size)
            found = found.with_parameters(x=found.position[0] + origin[0], y=found.position[1] + origin[1],
                                          z=found.position[2] + origin[2], cx=cam.cx, cy=cam.cy)
            out.append(found)
            break
    return out


def dlt_start(q: np.ndarray, P: np.ndarray, origin: np.ndarray, initial: Camera) -> List[Camera]:
    """Camera from the direct linear transform (6+ non-coplanar points), decomposed into K, R, C."""
    if len(q) < 6:
        return []
    import cv2

    scale = max(1.0, float(np.abs(P).max()))
    Pn = P / scale
    rows = []
    for (u, v), (x, y, z) in zip(q - 0.5, Pn):  # OpenCV pixel centres on integers
        rows.append([x, y, z, 1, 0, 0, 0, 0, -u * x, -u * y, -u * z, -u])
        rows.append([0, 0, 0, 0, x, y, z, 1, -v * x, -v * y, -v * z, -v])
    A = np.asarray(rows)
    try:
        _, s, vt = np.linalg.svd(A)
    except np.linalg.LinAlgError:
        return []
    if s[-2] < 1e-12 * s[0]:
        return []
    M = vt[-1].reshape(3, 4)
    try:
        K, R, C, *_ = cv2.decomposeProjectionMatrix(M)
    except cv2.error:
        return []
    C = (C[:3] / C[3]).ravel() * scale
    K = K / K[2, 2]
    if K[0, 0] < 0 or K[1, 1] < 0:
        return []
    if np.linalg.det(R) < 0:
        return []
    # The camera must look at the points (a DLT can return the solution mirrored through the camera centre).
    if np.mean((P - C) @ R[2]) < 0:
        return []
    heading, pitch, roll = angles_from_rotation(R)
    focal = 0.5 * (abs(K[0, 0]) + abs(K[1, 1]))
    fov = fov_from_focal(focal, initial.width)
    if not 0.5 < fov < 175:
        return []
    return [initial.with_parameters(x=C[0] + origin[0], y=C[1] + origin[1], z=C[2] + origin[2], heading=heading,
                                    pitch=pitch, roll=roll, fov=fov)]
