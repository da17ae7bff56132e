"""Pinhole camera with optional radial distortion: one definition for numpy and torch.

Conventions (used everywhere in Monoplot)
-----------------------------------------
World: the DEM's projected CRS, X east, Y north (grid north), Z up, metres.

Pixels: ``u`` = column, ``v`` = row, origin at the top-left *corner* of the top-left pixel, so the centre of pixel
(row i, column j) is ``(u, v) = (j + 0.5, i + 0.5)``. OpenCV puts pixel centres on integers: ``u_cv = u - 0.5``.

Camera frame: OpenCV style, x right, y down, z forward (the optical axis).

Angles, in degrees:

- ``heading``: azimuth of the optical axis, clockwise from grid north (+Y); east = 90.
- ``pitch``: elevation of the optical axis above the horizontal; negative looks down.
- ``roll``: rotation about the optical axis; positive turns the camera clockwise as seen by the photographer (its
  right side goes down), so the landscape appears rotated counter-clockwise in the picture.

Intrinsics: ``fov`` is the horizontal field of view; the focal length in pixels is
``f = (width / 2) / tan(fov / 2)``. ``principal_point = (cx, cy)`` in pixels (None = image centre ``(W/2, H/2)``).
``k1``, ``k2``: radial distortion as in OpenCV, applied to normalised coordinates:
``x_d = x (1 + k1 r^2 + k2 r^4)`` (:mod:`.distortion`, the one model, shared with the z-buffer's kernels).

Projection: ``p_cam = R (P - C)`` with ``R`` the world-to-camera rotation (rows = camera x, y, z axes in world
coordinates) and ``C`` the camera position; ``T = -C`` gives the paper's ``p = K R (P + T)``.

The array functions below (:func:`rotation_matrix`, :func:`project_points`) take numpy arrays or torch tensors and
return the same kind, so the camera fit differentiates exactly the projection that the rest of the code uses.

>>> cam = Camera(position=(0, 0, 100), heading=0, pitch=0, roll=0, fov=90, image_size=(200, 100))
>>> round(cam.focal_px, 9)
100.0
>>> cam.project([[0.0, 1000.0, 100.0], [10.0, 1000.0, 90.0]]).round(6).tolist()
[[100.0, 50.0], [101.0, 51.0]]
>>> np.allclose(cam.project(cam.pixel_to_world_ray([[30.5, 70.25]])[1] * 50 + cam.position), [[30.5, 70.25]])
True
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, replace
from typing import Optional, Tuple

import numpy as np

from .distortion import distort, undistort

__all__ = [
    "Camera",
    "azimuth",
    "rotation_matrix",
    "project_points",
    "focal_from_fov",
    "fov_from_focal",
    "PARAMETER_NAMES",
]

#: Names of the camera parameters, in the order used by parameter vectors (fit, JSON).
PARAMETER_NAMES = ("x", "y", "z", "heading", "pitch", "roll", "fov", "cx", "cy", "k1", "k2")


def _is_torch(value) -> bool:
    return type(value).__module__.startswith("torch")


def _stack(items, axis, like):
    if _is_torch(like):
        import torch

        return torch.stack(items, dim=axis)
    return np.stack(items, axis=axis)


def _sin_cos_deg(angle):
    """sin and cos of degrees, for floats, numpy arrays or torch tensors."""
    if _is_torch(angle):
        import torch

        rad = torch.deg2rad(angle)
        return torch.sin(rad), torch.cos(rad)
    rad = np.deg2rad(angle)
    return np.sin(rad), np.cos(rad)


def azimuth(heading: float) -> float:
    """A heading as the azimuth people read: degrees clockwise from grid north in [0, 360).

    >>> azimuth(-135.0), azimuth(725.5), azimuth(-1e-17)
    (225.0, 5.5, 0.0)
    """
    value = float(heading) % 360.0
    return 0.0 if value >= 360.0 else value  # -1e-17 % 360 rounds to 360.0


def rotation_matrix(heading, pitch, roll):
    """World-to-camera rotation for the angles of this module (degrees).

    Rows are the camera's x (right), y (down) and z (forward) axes in world coordinates.

    Args:
        heading, pitch, roll: floats, numpy scalars or 0-d torch tensors (degrees).
    Returns:
        (3, 3) numpy array or torch tensor (differentiable with respect to the angles).

    >>> np.round(rotation_matrix(90.0, 0.0, 0.0), 6).tolist()   # looking east: right = south, down = -Z
    [[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]
    """
    like = heading if _is_torch(heading) else (pitch if _is_torch(pitch) else roll)
    if _is_torch(like):
        if all(not _is_torch(a) or a.dim() == 0 for a in (heading, pitch, roll)):
            return _rotation_torch(heading, pitch, roll, like)
    elif all(np.ndim(a) == 0 for a in (heading, pitch, roll)):
        return _rotation_scalar(float(heading), float(pitch), float(roll))
    else:
        heading, pitch, roll = (np.float64(a) for a in (heading, pitch, roll))
    sh, ch = _sin_cos_deg(heading)
    sp, cp = _sin_cos_deg(pitch)
    sr, cr = _sin_cos_deg(roll)
    zero = sh * 0.0
    forward = _stack([sh * cp, ch * cp, sp], 0, like)
    right0 = _stack([ch, -sh, zero], 0, like)
    down0 = _stack([sh * sp, ch * sp, -cp], 0, like)  # forward x right0
    right = cr * right0 + sr * down0
    down = cr * down0 - sr * right0
    return _stack([right, down, forward], 0, like)


def _rotation_scalar(heading: float, pitch: float, roll: float) -> np.ndarray:
    """:func:`rotation_matrix` of three floats (the fit's numpy projections: math on floats, one array)."""
    h, p, r = math.radians(heading), math.radians(pitch), math.radians(roll)
    sh, ch, sp, cp, sr, cr = math.sin(h), math.cos(h), math.sin(p), math.cos(p), math.sin(r), math.cos(r)
    # the terms of the general case, in its order (the same floats but for sin/cos ulps, signed zeros included)
    return np.array([[cr * ch + sr * (sh * sp), cr * -sh + sr * (ch * sp), cr * 0.0 + sr * -cp],
                     [cr * (sh * sp) - sr * ch, cr * (ch * sp) - sr * -sh, cr * -cp - sr * 0.0],
                     [sh * cp, ch * cp, sp]])


def _rotation_torch(heading, pitch, roll, like):
    """:func:`rotation_matrix` of 0-d tensors (or floats beside them), in a third of the autograd graph: the
    products (sh, ch, 1) x (sp, cp, 1) map to the rows right0 = (ch, -sh, 0), down0 = (sh sp, ch sp, -cp), forward
    = (sh cp, ch cp, sp), then (cr, sr, 1) to the roll within the image plane (right = cr right0 + sr down0, down =
    cr down0 - sr right0), both by constant matrices (:data:`_TORCH_MAPS`)."""
    import torch

    angles = torch.stack([a if _is_torch(a) else torch.tensor(float(a), dtype=like.dtype)
                          for a in (heading, pitch, roll)])
    rad = torch.deg2rad(angles)
    sc = torch.cat([torch.sin(rad), torch.cos(rad), torch.ones(1, dtype=rad.dtype)])  # sh sp sr ch cp cr 1
    h, p, r = sc[[0, 3, 6]], sc[[1, 4, 6]], sc[[5, 2, 6]]
    if rad.dtype not in _TORCH_MAPS:  # made once: a fit projects thousands of times
        to_frame = np.zeros((9, 9))  # product index (3 h + p) -> frame entry, with its sign
        for entry, (product, sign) in enumerate([(5, 1), (2, -1), (0, 0), (0, 1), (3, 1), (7, -1), (1, 1), (4, 1),
                                                 (6, 1)]):
            to_frame[product, entry] = sign
        roll_map = np.zeros((3, 9))
        roll_map[0, [0, 4]] = roll_map[1, 1] = roll_map[2, 8] = 1.0
        roll_map[1, 3] = -1.0
        _TORCH_MAPS[rad.dtype] = tuple(torch.as_tensor(m, dtype=rad.dtype) for m in (to_frame, roll_map))
    to_frame, roll_map = _TORCH_MAPS[rad.dtype]
    frame = ((h[:, None] * p[None, :]).reshape(9) @ to_frame).reshape(3, 3)
    return (r @ roll_map).reshape(3, 3) @ frame


_TORCH_MAPS: dict = {}


def project_points(points, position, rotation, focal, cx, cy, k1=0.0, k2=0.0):
    """Project world points to pixels; differentiable for torch inputs.

    Args:
        points: (N, 3) world coordinates (metres). For precision, pass coordinates already centred near the camera
            (subtract the same offset from ``points`` and ``position``) when working in float32.
        position: (3,) camera centre.
        rotation: (3, 3) world-to-camera rotation (:func:`rotation_matrix`).
        focal: focal length in pixels; cx, cy: principal point in pixels; k1, k2: radial distortion.
    Returns:
        (uv, depth): (N, 2) pixels and (N,) depth along the optical axis (metres). Points with ``depth <= 0`` are
        behind the camera; their ``uv`` is finite but meaningless (the caller masks them, which keeps gradients
        free of NaN).
    """
    cam = (points - position) @ rotation.T
    depth = cam[:, 2]
    if _is_torch(depth):
        import torch

        safe = torch.where(depth > 1e-9, depth, torch.ones_like(depth))
    else:
        safe = np.where(depth > 1e-9, depth, 1.0)
    if isinstance(k1, float) and isinstance(k2, float) and k1 == 0.0 and k2 == 0.0:
        xd, yd = cam[:, 0] / safe, cam[:, 1] / safe  # no distortion: the same values, a shorter torch graph
    else:
        xd, yd = distort(cam[:, 0] / safe, cam[:, 1] / safe, k1, k2)
    uv = _stack([focal * xd + cx, focal * yd + cy], 1, xd)
    return uv, depth


def focal_from_fov(fov_deg: float, width: float) -> float:
    """Focal length in pixels from a horizontal field of view in degrees.

    >>> round(focal_from_fov(90.0, 1000), 6)
    500.0
    """
    return (width / 2.0) / math.tan(math.radians(fov_deg) / 2.0)


def fov_from_focal(focal_px: float, width: float) -> float:
    """Horizontal field of view in degrees from a focal length in pixels (inverse of :func:`focal_from_fov`)."""
    return math.degrees(2.0 * math.atan((width / 2.0) / focal_px))


@dataclass
class Camera:
    """A pinhole camera in the DEM's CRS. See the module docstring for every convention.

    Attributes:
        position: (x, y, z) camera centre in map units (metres).
        heading, pitch, roll: degrees.
        fov: horizontal field of view, degrees.
        image_size: (width, height) in pixels.
        principal_point: (cx, cy) pixels, or None for the image centre.
        k1, k2: radial distortion coefficients (OpenCV model, normalised coordinates).
        crs_wkt: optional WKT of the CRS of ``position`` (informative; stored in JSON).
    """

    position: Tuple[float, float, float]
    heading: float
    pitch: float
    roll: float
    fov: float
    image_size: Tuple[int, int]
    principal_point: Optional[Tuple[float, float]] = None
    k1: float = 0.0
    k2: float = 0.0
    crs_wkt: str = field(default="", repr=False)

    def __post_init__(self):
        self.position = tuple(float(c) for c in self.position)
        self.image_size = (int(self.image_size[0]), int(self.image_size[1]))
        if self.principal_point is not None:
            self.principal_point = (float(self.principal_point[0]), float(self.principal_point[1]))
        for name in ("heading", "pitch", "roll", "fov", "k1", "k2"):
            setattr(self, name, float(getattr(self, name)))
        if not 0.0 < self.fov < 180.0:
            raise ValueError(f"fov must be between 0 and 180 degrees, got {self.fov}")
        if self.image_size[0] <= 0 or self.image_size[1] <= 0:
            raise ValueError(f"image_size must be positive, got {self.image_size}")

    # --- intrinsics -------------------------------------------------------------------------------------------
    @property
    def width(self) -> int:
        return self.image_size[0]

    @property
    def height(self) -> int:
        return self.image_size[1]

    @property
    def focal_px(self) -> float:
        """Focal length in pixels."""
        return focal_from_fov(self.fov, self.width)

    @property
    def cx(self) -> float:
        return self.width / 2.0 if self.principal_point is None else self.principal_point[0]

    @property
    def cy(self) -> float:
        return self.height / 2.0 if self.principal_point is None else self.principal_point[1]

    @property
    def vertical_fov(self) -> float:
        """Vertical field of view in degrees (principal point at the centre)."""
        return math.degrees(2.0 * math.atan((self.height / 2.0) / self.focal_px))

    @property
    def K(self) -> np.ndarray:
        """(3, 3) intrinsic matrix in this module's pixel convention (centres at +0.5)."""
        f = self.focal_px
        return np.array([[f, 0.0, self.cx], [0.0, f, self.cy], [0.0, 0.0, 1.0]])

    # --- extrinsics -------------------------------------------------------------------------------------------
    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) world-to-camera rotation (rows: camera right, down, forward in world coordinates)."""
        return rotation_matrix(self.heading, self.pitch, self.roll)

    @property
    def forward(self) -> np.ndarray:
        """(3,) unit vector of the optical axis in world coordinates."""
        return self.rotation[2].copy()

    # --- projection -------------------------------------------------------------------------------------------
    def project_with_depth(self, xyz) -> Tuple[np.ndarray, np.ndarray]:
        """(N, 3) world points -> ((N, 2) pixels, (N,) depth in metres); NaN pixels where depth <= 0."""
        pts = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        origin = np.asarray(self.position)
        # Centre on the camera before any arithmetic: map coordinates are large numbers.
        uv, depth = project_points(pts - origin, np.zeros(3), self.rotation, self.focal_px, self.cx, self.cy,
                                   self.k1, self.k2)
        uv = np.where((depth > 0)[:, None], uv, np.nan)
        return uv, depth

    def project(self, xyz) -> np.ndarray:
        """(N, 3) map coordinates -> (N, 2) pixels (u, v); NaN rows for points behind the camera."""
        return self.project_with_depth(xyz)[0]

    def pixel_to_camera_ray(self, uv) -> np.ndarray:
        """(N, 2) pixels -> (N, 3) unit ray directions in the camera frame (distortion removed)."""
        uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        xd = (uv[:, 0] - self.cx) / self.focal_px
        yd = (uv[:, 1] - self.cy) / self.focal_px
        with np.errstate(invalid="ignore", divide="ignore"):  # beyond the valid radius: not finite
            x, y = undistort(xd, yd, self.k1, self.k2)
        rays = np.stack([x, y, np.ones_like(x)], axis=1)
        return rays / np.linalg.norm(rays, axis=1, keepdims=True)

    def pixel_to_world_ray(self, uv) -> Tuple[np.ndarray, np.ndarray]:
        """(N, 2) pixels -> (origin (3,), directions (N, 3) unit vectors in world coordinates)."""
        return np.asarray(self.position), self.pixel_to_camera_ray(uv) @ self.rotation

    def pixel_centres(self, step: int = 1) -> np.ndarray:
        """(H', W', 2) pixel-centre coordinates for every ``step``-th pixel (u, v)."""
        us = np.arange(self.width, step=step, dtype=np.float64) + 0.5
        vs = np.arange(self.height, step=step, dtype=np.float64) + 0.5
        uu, vv = np.meshgrid(us, vs)
        return np.stack([uu, vv], axis=-1)

    def in_image(self, uv, margin: float = 0.0) -> np.ndarray:
        """(N,) bool: pixel coordinates inside the image (widened by ``margin`` pixels); False for NaN."""
        uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        with np.errstate(invalid="ignore"):
            return ((uv[:, 0] >= -margin) & (uv[:, 0] <= self.width + margin)
                    & (uv[:, 1] >= -margin) & (uv[:, 1] <= self.height + margin))

    # --- parameter vectors ------------------------------------------------------------------------------------
    def parameters(self) -> dict:
        """Every parameter by the names of :data:`PARAMETER_NAMES` (x y z heading pitch roll fov cx cy k1 k2)."""
        x, y, z = self.position
        return dict(x=x, y=y, z=z, heading=self.heading, pitch=self.pitch, roll=self.roll, fov=self.fov,
                    cx=self.cx, cy=self.cy, k1=self.k1, k2=self.k2)

    def with_parameters(self, **values) -> "Camera":
        """A copy with some parameters (names of :data:`PARAMETER_NAMES`) replaced.

        >>> Camera((0, 0, 0), 10, 0, 0, 60, (100, 80)).with_parameters(x=5, heading=20).position
        (5.0, 0.0, 0.0)
        """
        unknown = set(values) - set(PARAMETER_NAMES)
        if unknown:
            raise KeyError(f"unknown camera parameters: {sorted(unknown)}")
        p = self.parameters()
        p.update({k: float(v) for k, v in values.items()})
        principal = self.principal_point
        if "cx" in values or "cy" in values:
            principal = (p["cx"], p["cy"])
        return replace(self, position=(p["x"], p["y"], p["z"]), heading=p["heading"], pitch=p["pitch"],
                       roll=p["roll"], fov=p["fov"], principal_point=principal, k1=p["k1"], k2=p["k2"])

    def scaled(self, factor: float) -> "Camera":
        """The same view through an image scaled by ``factor`` (at least 2 x 2 pixels; principal point scaled with
        it; the field of view unchanged), e.g. to render or z-buffer a preview of a large photo.

        >>> small = Camera((0, 0, 0), 0, 0, 0, 60, (1000, 800), principal_point=(510, 400)).scaled(0.25)
        >>> small.image_size, small.principal_point
        ((250, 200), (127.5, 100.0))
        """
        if factor == 1.0:
            return self
        size = (max(2, int(round(self.width * factor))), max(2, int(round(self.height * factor))))
        principal = None if self.principal_point is None else (self.cx * factor, self.cy * factor)
        return replace(self, image_size=size, principal_point=principal)

    # --- serialisation ----------------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        d = asdict(self)
        d["position"] = list(self.position)
        d["image_size"] = list(self.image_size)
        d["principal_point"] = None if self.principal_point is None else list(self.principal_point)
        d["focal_px"] = self.focal_px  # informative, ignored on reading
        d["format"] = "monoplot-camera/1"
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "Camera":
        keys = ("position", "heading", "pitch", "roll", "fov", "image_size", "principal_point", "k1", "k2",
                "crs_wkt")
        missing = [k for k in ("position", "heading", "pitch", "roll", "fov", "image_size") if k not in d]
        if missing:
            raise ValueError(f"camera description lacks {', '.join(missing)}")
        return cls(**{k: d[k] for k in keys if k in d})

    def to_json(self, indent: int = 2) -> str:
        """JSON text (round-trips through :meth:`from_json`).

        >>> c = Camera((1, 2, 3), 4, 5, 6, 50, (640, 480), k1=0.01)
        >>> Camera.from_json(c.to_json()) == c
        True
        """
        return json.dumps(self.to_dict(), indent=indent)

    @classmethod
    def from_json(cls, text: str) -> "Camera":
        return cls.from_dict(json.loads(text))

    def save(self, path) -> None:
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(self.to_json())

    @classmethod
    def load(cls, path) -> "Camera":
        with open(path, encoding="utf-8") as fh:
            return cls.from_json(fh.read())

    # --- OpenCV -----------------------------------------------------------------------------------------------
    def to_opencv(self) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(rvec (3,), tvec (3,), K (3, 3), dist (5,)) for ``cv2.projectPoints``.

        OpenCV's pixel centres are on integers, so its principal point is ours minus 0.5. The translation is that
        of the raw world coordinates; for large map coordinates subtract an offset from the points and from
        ``position`` first (``replace(cam, position=...)``) to keep float precision.
        """
        import cv2

        R = self.rotation
        rvec, _ = cv2.Rodrigues(R)
        tvec = -R @ np.asarray(self.position)
        K = self.K.copy()
        K[0, 2] -= 0.5
        K[1, 2] -= 0.5
        return rvec.ravel(), tvec, K, np.array([self.k1, self.k2, 0.0, 0.0, 0.0])

    @classmethod
    def from_opencv(cls, rvec, tvec, K, dist, image_size, crs_wkt: str = "") -> "Camera":
        """Inverse of :meth:`to_opencv` (square pixels and zero skew assumed; fx and fy averaged)."""
        import cv2

        R, _ = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64).reshape(3, 1))
        position = -R.T @ np.asarray(tvec, dtype=np.float64).ravel()
        heading, pitch, roll = angles_from_rotation(R)
        K = np.asarray(K, dtype=np.float64)
        focal = 0.5 * (K[0, 0] + K[1, 1])
        dist = np.zeros(2) if dist is None else np.asarray(dist, dtype=np.float64).ravel()
        width, height = image_size
        principal = (K[0, 2] + 0.5, K[1, 2] + 0.5)
        if np.allclose(principal, (width / 2.0, height / 2.0), atol=1e-9):
            principal = None
        return cls(position=tuple(position), heading=heading, pitch=pitch, roll=roll,
                   fov=fov_from_focal(focal, width), image_size=(width, height), principal_point=principal,
                   k1=float(dist[0]) if dist.size > 0 else 0.0, k2=float(dist[1]) if dist.size > 1 else 0.0,
                   crs_wkt=crs_wkt)

    # --- KML PhotoOverlay -------------------------------------------------------------------------------------
    @classmethod
    def from_kml(cls, kml, image_size, dst_crs_wkt: str, use_overlay_rotation: bool = True,
                 default_fov: Optional[float] = None, notes: Optional[list] = None) -> "Camera":
        """A camera from a KML PhotoOverlay (Google Earth), reprojected to ``dst_crs_wkt``
        (:func:`~monoplot_plugin.core.kml.camera_from_kml`, which says how KML's angles are read)."""
        from .kml import camera_from_kml

        return camera_from_kml(kml, image_size, dst_crs_wkt, use_overlay_rotation, default_fov, notes)


def angles_from_rotation(R: np.ndarray) -> Tuple[float, float, float]:
    """(heading, pitch, roll) in degrees from a world-to-camera rotation (inverse of :func:`rotation_matrix`).

    >>> [round(a, 9) for a in angles_from_rotation(rotation_matrix(-120.0, -20.0, 7.5))]
    [-120.0, -20.0, 7.5]
    """
    R = np.asarray(R, dtype=np.float64)
    fwd = R[2]
    pitch = math.degrees(math.asin(max(-1.0, min(1.0, fwd[2]))))
    heading = math.degrees(math.atan2(fwd[0], fwd[1]))
    sh, ch = math.sin(math.radians(heading)), math.cos(math.radians(heading))
    sp, cp = math.sin(math.radians(pitch)), math.cos(math.radians(pitch))
    right0 = np.array([ch, -sh, 0.0])
    down0 = np.array([sh * sp, ch * sp, -cp])
    roll = math.degrees(math.atan2(float(R[0] @ down0), float(R[0] @ right0)))
    return heading, pitch, roll
