"""State shared by the stages of one fit: the points centred on the initial camera, the free parameters, the
callbacks (progress, cancel) and the best camera seen so far.

Every stage module (:mod:`.paired`, :mod:`.descent`, :mod:`.pairing`, :mod:`.consensus`) is a set of functions of
a :class:`FitContext`.
"""

from __future__ import annotations

import math
import time
from typing import Callable, List, Optional, Tuple

import numpy as np

from ..camera import PARAMETER_NAMES, Camera
from .options import FitOptions
from .params import DEFAULT_FREE, ParameterSpace

__all__ = ["FitCanceled", "FitContext"]


class FitCanceled(Exception):
    """Raised inside the optimisers when ``is_canceled()`` turns true."""


def ground_callable(ground):
    """``None``, a callable ``(x, y) -> z``, or an object with ``sample(x, y)`` (a Dem) -> callable or None."""
    if ground is None or callable(ground) and not hasattr(ground, "sample"):
        return ground
    if hasattr(ground, "sample"):
        return lambda x, y: ground.sample(x, y)
    raise TypeError("ground must be a callable (x, y) -> z or an object with a sample(x, y) method (Dem)")


class FitContext:
    """One fit's inputs, options and bookkeeping.

    Attributes:
        q: (N, 2) photo points (pixels). world: (M, 3) DEM points (map coordinates).
        origin: (3,) the initial camera's position; ``P = world - origin`` (M, 3) is what the stages project.
        free: the fitted parameter names (``z`` dropped when the camera is tied to the ground).
        diag: image diagonal (pixels). typical_range: median distance (m) of the DEM points in front of the camera.
    """

    def __init__(self, image_points, world_points, initial: Camera, free, ground, eye_height: float,
                 options: FitOptions, progress: Optional[Callable[[float, str], None]] = None,
                 is_canceled: Optional[Callable[[], bool]] = None):
        self.q = np.asarray(image_points, dtype=np.float64).reshape(-1, 2)
        self.world = np.asarray(world_points, dtype=np.float64).reshape(-1, 3)
        self.initial = initial
        self.options = options
        self.origin = np.asarray(initial.position, dtype=np.float64)
        self.P = self.world - self.origin
        self.requested_free = tuple(DEFAULT_FREE if free is None else free)
        self.ground = ground_callable(ground)
        self.eye_height = float(eye_height)
        self.free = tuple(n for n in PARAMETER_NAMES if n in set(self.requested_free)
                          and not (self.ground is not None and n == "z"))
        self.view_margin = float(options.view_margin)
        width, height = initial.image_size
        self.diag = math.hypot(width, height)
        self.robust_px = options.robust_px(self.diag)
        self.two_sided_cap = 0.025
        self.rng = np.random.default_rng(options.seed)
        self.progress = progress
        self.is_canceled = is_canceled
        self.history: List[float] = []
        self.starts_tried = 0
        self._best: Optional[Tuple[float, Camera]] = None
        self._last_poll = 0.0
        depth = self.P @ initial.rotation[2] if len(self.P) else np.zeros(0)
        front = depth > 0
        dist = np.linalg.norm(self.P[front] if front.any() else self.P, axis=1)
        self.typical_range = max(float(np.median(dist)) if len(dist) else 1000.0, 1.0)

    # --- bookkeeping -----------------------------------------------------------------------------------------
    def report(self, fraction: float, message: str) -> None:
        if self.progress is not None:
            self.progress(float(min(1.0, max(0.0, fraction))), message)

    def poll(self) -> None:
        """Raise :class:`FitCanceled` when the caller asked to stop (polled at most every millisecond)."""
        if self.is_canceled is None:
            return
        now = time.perf_counter()
        if now - self._last_poll < 1e-3:
            return
        self._last_poll = now
        if self.is_canceled():
            raise FitCanceled()

    def remember(self, score: float, camera: Camera) -> None:
        if np.isfinite(score) and (self._best is None or score < self._best[0]):
            self._best = (score, camera)

    def best_camera(self) -> Camera:
        return self.initial if self._best is None else self._best[1]

    def space(self, start: Camera) -> ParameterSpace:
        return ParameterSpace(start, self.free, self.typical_range, origin=self.origin, ground=self.ground,
                              eye_height=self.eye_height)

    # --- projection helpers ----------------------------------------------------------------------------------
    def usable(self, uv, depth, margin: float):
        """(M,) bool (numpy or torch): in front of the camera and inside the image widened by ``margin``."""
        w, h = self.initial.image_size
        mw, mh = margin * w, margin * h
        near = 1e-3 * self.typical_range
        ok = (depth > near) & (uv[:, 0] >= -mw) & (uv[:, 0] <= w + mw) & (uv[:, 1] >= -mh) & (uv[:, 1] <= h + mh)
        if isinstance(uv, np.ndarray):
            ok &= np.isfinite(uv).all(axis=1)
        return ok

    def project_usable(self, space: ParameterSpace, u) -> Tuple[np.ndarray, np.ndarray]:
        """(M, 2) projections of all DEM points by ``space.camera(u)`` and their (M,) usable mask."""
        uv, depth = space.project(np.asarray(u, dtype=np.float64), self.P)
        return uv, self.usable(uv, depth, self.view_margin)

    def restrict_to_free(self, camera: Camera) -> Camera:
        """``camera`` with every parameter that is not free put back to the initial value."""
        fixed = {n: v for n, v in self.initial.parameters().items() if n not in self.free}
        if self.ground is not None:
            fixed.pop("z", None)
        if "cx" not in self.free and "cy" not in self.free:
            fixed.pop("cx")
            fixed.pop("cy")
        return camera.with_parameters(**fixed)
