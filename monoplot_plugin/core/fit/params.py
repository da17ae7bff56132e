"""Camera parameter vectors for the fit: which parameters are free, their scaling, and the projection of centred
world points for numpy and torch alike.

The fit works in coordinates centred on the *initial* camera position (``origin``): map coordinates are large
numbers (e.g. 650 000 m) and the projection subtracts nearly equal values. Free parameters are stored as a
dimensionless vector ``u``: ``value = start + scale * u``, with scales chosen so that ``u = 1`` moves the picture
by roughly the same number of pixels for every parameter (about one degree of view). That keeps L-BFGS,
Levenberg-Marquardt and the finite differences well conditioned.

>>> from monoplot_plugin.core.camera import Camera
>>> cam = Camera((1000.0, 2000.0, 300.0), 10.0, -5.0, 0.0, 60.0, (640, 480))
>>> space = ParameterSpace(cam, ("x", "y", "heading"), typical_range=1000.0)
>>> space.camera(space.zero()).position
(1000.0, 2000.0, 300.0)
>>> round(space.camera(np.array([0.0, 0.0, 1.0])).heading, 6)
11.0
"""

from __future__ import annotations

import math
from typing import Callable, Dict, Optional, Sequence

import numpy as np

from ..camera import PARAMETER_NAMES, Camera, project_points, rotation_matrix

__all__ = ["DEFAULT_FREE", "ParameterSpace", "parameter_scales"]

#: The paper's seven unknowns: position, three angles, field of view (principal point at the image centre).
DEFAULT_FREE = ("x", "y", "z", "heading", "pitch", "roll", "fov")


def parameter_scales(camera: Camera, typical_range: float) -> Dict[str, float]:
    """Step of each parameter that shifts the picture by about one degree of view (``focal * pi / 180`` px).

    Args:
        camera: the camera around which the fit works.
        typical_range: typical camera-to-point distance in metres (a position step of ``range * pi / 180`` moves a
            point at that distance by one degree).
    """
    deg = math.pi / 180.0
    f = camera.focal_px
    half_w = camera.width / 2.0
    return {
        "x": typical_range * deg, "y": typical_range * deg, "z": typical_range * deg,
        "heading": 1.0, "pitch": 1.0, "roll": 1.0,
        # At the image edge d(u)/d(fov) = half_w / sin(fov) pixels per radian of fov: the fov step that moves the
        # edge by one degree of view (f * deg pixels) is f * sin(fov) / half_w degrees.
        "fov": max(1e-3, f * math.sin(math.radians(camera.fov)) / half_w),
        "cx": f * deg, "cy": f * deg,
        # k1 moves the image corner (r^2 ~ (half diagonal / f)^2) by f * k1 * r^3 pixels.
        "k1": max(1e-3, deg / max(1e-6, (math.hypot(camera.width, camera.height) / 2 / f) ** 3)),
        "k2": max(1e-3, deg / max(1e-6, (math.hypot(camera.width, camera.height) / 2 / f) ** 5)),
    }


class ParameterSpace:
    """Maps a dimensionless vector of the free parameters to camera values and projections.

    Args:
        start: camera whose values are used for every parameter that is not free (and as the start of free ones).
        free: names among :data:`~monoplot_plugin.core.camera.PARAMETER_NAMES` (order is normalised).
        typical_range: metres, for the scaling of the position (see :func:`parameter_scales`).
        origin: (3,) map coordinates subtracted from every world point and from the camera position; defaults to
            ``start.position``.
        ground: optional callable ``(x, y) -> z`` (numpy arrays of map coordinates, metres) giving the terrain
            height; when given, the camera height is ``ground(x, y) + eye_height`` and "z" is never free.
        eye_height: metres above the ground (with ``ground``).
    """

    def __init__(self, start: Camera, free: Sequence[str], typical_range: float, origin=None,
                 ground: Optional[Callable] = None, eye_height: float = 1.7):
        unknown = set(free) - set(PARAMETER_NAMES)
        if unknown:
            raise KeyError(f"unknown camera parameters: {sorted(unknown)}")
        self.ground = ground
        self.eye_height = float(eye_height)
        self.names = tuple(n for n in PARAMETER_NAMES if n in set(free) and not (ground is not None and n == "z"))
        self.start = start
        self.origin = np.asarray(start.position if origin is None else origin, dtype=np.float64)
        values = start.parameters()
        values["x"] -= self.origin[0]
        values["y"] -= self.origin[1]
        values["z"] -= self.origin[2]
        self.base = values
        self.typical_range = float(typical_range)
        all_scales = parameter_scales(start, typical_range)
        self.scales = np.array([all_scales[n] for n in self.names])
        self.width, self.height = start.image_size

    @property
    def size(self) -> int:
        return len(self.names)

    def zero(self) -> np.ndarray:
        return np.zeros(self.size)

    def from_camera(self, camera: Camera) -> np.ndarray:
        """Vector of ``camera``'s free values in this space's units (inverse of :meth:`camera`)."""
        values = camera.parameters()
        values["x"] -= self.origin[0]
        values["y"] -= self.origin[1]
        values["z"] -= self.origin[2]
        return np.array([(values[n] - self.base[n]) / s for n, s in zip(self.names, self.scales)])

    # --- values ----------------------------------------------------------------------------------------------
    def values(self, u) -> dict:
        """All parameter values (position centred on ``origin``) for vector ``u`` (numpy array or torch tensor)."""
        out = dict(self.base)
        for i, name in enumerate(self.names):
            out[name] = self.base[name] + float(self.scales[i]) * u[i]
        if self.ground is not None:
            out["z"] = self._ground_z(out["x"], out["y"])
        return out

    def _ground_z(self, x, y):
        """Camera height on the ground; for torch inputs its gradient is the local terrain slope."""
        ox, oy, oz = self.origin
        if type(x).__module__.startswith("torch") or type(y).__module__.startswith("torch"):
            import torch

            x = x if torch.is_tensor(x) else torch.tensor(float(x), dtype=torch.float64)
            y = y if torch.is_tensor(y) else torch.tensor(float(y), dtype=torch.float64)
            x0, y0 = float(x.detach()), float(y.detach())
            h, gx, gy = self._height_and_slope(x0, y0)
            return (h + self.eye_height - oz) + gx * (x - x0) + gy * (y - y0)
        h = float(np.asarray(self.ground(np.array([float(x) + ox]), np.array([float(y) + oy]))).ravel()[0])
        return h + self.eye_height - oz

    def _height_and_slope(self, x: float, y: float, step: float = 5.0):
        ox, oy = self.origin[0], self.origin[1]
        xs = np.array([x, x + step, x - step, x, x]) + ox
        ys = np.array([y, y, y, y + step, y - step]) + oy
        h = np.asarray(self.ground(xs, ys), dtype=np.float64).ravel()
        gx = (h[1] - h[2]) / (2 * step) if np.isfinite(h[1:3]).all() else 0.0
        gy = (h[3] - h[4]) / (2 * step) if np.isfinite(h[3:5]).all() else 0.0
        return float(h[0]), float(gx), float(gy)

    def ground_height_ok(self, u) -> bool:
        """False when the ground constraint is on and the terrain height is unknown (void, outside the DEM)."""
        if self.ground is None:
            return True
        v = self.values(np.asarray(u, dtype=np.float64))
        return bool(np.isfinite(v["z"]))

    # --- projection ------------------------------------------------------------------------------------------
    def project(self, u, points_c):
        """Project centred world points (N, 3) with parameters ``u``; numpy or torch (differentiable).

        Returns:
            (uv (N, 2) pixels, depth (N,) metres along the optical axis).
        """
        if type(points_c).__module__.startswith("torch") or type(u).__module__.startswith("torch"):
            return self._project_torch(u, points_c)
        v = self.values(u)
        position = np.array([v["x"], v["y"], v["z"]], dtype=np.float64)
        rotation = rotation_matrix(v["heading"], v["pitch"], v["roll"])
        focal = (self.width / 2.0) / math.tan(math.radians(float(v["fov"])) / 2.0)
        return project_points(points_c, position, rotation, focal, v["cx"], v["cy"], v["k1"], v["k2"])

    def _project_torch(self, u, points_c):
        """:meth:`project` for torch: every value in one tensor (base + scales * u at the free places), so that
        the graph the fit differentiates hundreds of times stays short; fixed intrinsics stay plain floats."""
        import torch

        if not torch.is_tensor(u):
            u = torch.as_tensor(np.asarray(u, dtype=np.float64), dtype=points_c.dtype)
        if not torch.is_tensor(points_c):
            points_c = torch.as_tensor(points_c, dtype=u.dtype)
        base, index, scales = self._torch_constants(u.dtype)
        full = base.index_add(0, index, scales * u)  # (11,) in PARAMETER_NAMES order, centred position
        if self.ground is not None:
            position = torch.stack([full[0], full[1], self._ground_z(full[0], full[1])])
        else:
            position = full[0:3]
        rotation = rotation_matrix(full[3], full[4], full[5])
        focal = (self.width / 2.0) / torch.tan(torch.deg2rad(full[6]) / 2.0)
        cx, cy, k1, k2 = (full[i] if name in self.names else float(self.base[name])
                          for i, name in zip(range(7, 11), PARAMETER_NAMES[7:11]))
        return project_points(points_c, position, rotation, focal, cx, cy, k1, k2)

    def _torch_constants(self, dtype):
        """(base values (11,), indices of the free names (n,), their scales (n,)) as tensors of ``dtype``."""
        cache = self.__dict__.setdefault("_torch_cache", {})
        if dtype not in cache:
            import torch

            cache[dtype] = (torch.tensor([float(self.base[n]) for n in PARAMETER_NAMES], dtype=dtype),
                            torch.tensor([PARAMETER_NAMES.index(n) for n in self.names], dtype=torch.int64),
                            torch.as_tensor(self.scales, dtype=dtype))
        return cache[dtype]

    def camera(self, u) -> Camera:
        """The :class:`Camera` (map coordinates) for vector ``u``."""
        v = {k: float(val) for k, val in self.values(np.asarray(u, dtype=np.float64)).items()}
        v["x"] += self.origin[0]
        v["y"] += self.origin[1]
        v["z"] += self.origin[2]
        if not ("cx" in self.names or "cy" in self.names):
            v.pop("cx")
            v.pop("cy")
        return self.start.with_parameters(**v)

    def valid(self, u) -> bool:
        """Physically meaningful parameters (field of view strictly between 0.5 and 175 degrees, finite)."""
        v = self.values(np.asarray(u, dtype=np.float64))
        return bool(0.5 < float(v["fov"]) < 175.0 and all(np.isfinite(float(x)) for x in v.values()))
