"""Per-frame re-registration of a fixed camera: how far each time-lapse frame has turned from the reference frame.

A camera on a mast turns a little (wind, heat, maintenance) but does not move: between two frames the image changes
by a rotation about the camera centre, ``b = dR a`` for the ray ``a`` of a pixel in the reference frame and ``b`` in
the frame (both in camera coordinates, the same intrinsics). :func:`register` finds ``dR`` from the photos alone:

1. key points of the reference on *stable terrain* only (:func:`stable_mask`: no sky, whose clouds move, no
   foreground nearer than ``near_m``, whose parallax and vegetation move, no frame border), computed once
   (:class:`Reference`);
2. ORB on both photos at reduced size (contrast-equalised, for lighting changes), matched, and a robust rotation
   (RANSAC on 2-ray samples, then least squares on the inliers, :func:`fit_rotation`);
3. sub-pixel refinement: the reference's corners tracked into the frame by pyramidal Lucas-Kanade from the positions
   the coarse rotation predicts, and the rotation fitted again on the tracks that agree with it.

The corrected camera (:func:`corrected_camera`) keeps position and intrinsics and turns by ``dR``. A frame that
cannot be registered (too few consistent matches: fog, night, a covered lens) has ``Drift.ok`` False and a message;
the caller reports it rather than silently giving the frame the reference camera.

>>> cam = Camera((0, 0, 0), heading=10, pitch=-5, roll=0, fov=60, image_size=(640, 480))
>>> turned = cam.with_parameters(heading=10.5, roll=0.2)
>>> rays = cam.pixel_to_camera_ray(cam.pixel_centres(40).reshape(-1, 2))
>>> true = turned.rotation @ cam.rotation.T
>>> estimate, inliers = fit_rotation(rays, rays @ true.T, threshold=1e-4)
>>> bool(inliers.all()), round(rotation_angle_deg(estimate), 3)
(True, 0.554)
>>> new = corrected_camera(cam, estimate)
>>> round(new.heading, 6), round(new.roll, 6)
(10.5, 0.2)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from .camera import Camera, angles_from_rotation, project_points

__all__ = ["Drift", "Reference", "stable_mask", "register", "fit_rotation", "corrected_camera",
           "rotation_angle_deg", "pixel_shift", "turned_pixels", "MIN_INLIERS"]

#: fewer consistent matches than this and a frame is not registered
MIN_INLIERS = 12
#: pixels: what is coarser than this is shading (removed before matching), finer is texture
HIGH_PASS_SIGMA = 3.0
#: standard deviation of the texture image (grey levels)
TEXTURE_CONTRAST = 32.0


@dataclass
class Drift:
    """The turn of one frame from the reference.

    Attributes:
        ok: registered (``rotation`` is trustworthy).
        rotation: (3, 3) ``dR``, reference camera frame -> this frame's camera frame (identity when not ok).
        degrees: angle of ``dR``.
        pixels: mean displacement of the image's pixels by ``dR`` (a 5 x 5 grid).
        matches: ORB matches tried; inliers: tracks the final rotation explains.
        residual_px: RMS of the inliers' residuals, pixels.
        message: why a frame is not registered, else "".
    """

    ok: bool
    rotation: np.ndarray
    degrees: float = float("nan")
    pixels: float = float("nan")
    matches: int = 0
    inliers: int = 0
    residual_px: float = float("nan")
    message: str = ""


def stable_mask(xyz: np.ndarray, camera: Camera, near_m: float = 150.0, border_px: int = 8) -> np.ndarray:
    """(H, W) uint8, 255 where a pixel sees terrain farther than ``near_m`` from the camera and lies more than
    ``border_px`` from the edge of the image: where key points of a fixed camera stay put.

    >>> cam = Camera((0, 0, 0), heading=0, pitch=0, roll=0, fov=60, image_size=(40, 30))
    >>> xyz = np.full((30, 40, 3), np.nan); xyz[20:, :] = (0.0, 1000.0, -50.0); xyz[28:, :] = (0.0, 20.0, -5.0)
    >>> m = stable_mask(xyz, cam, border_px=2)
    >>> int(m[10, 20]), int(m[24, 20]), int(m[29, 20]), int(m[24, 0])
    (0, 255, 0, 0)
    """
    with np.errstate(invalid="ignore"):
        distance = np.linalg.norm(xyz - np.asarray(camera.position), axis=-1)
        mask = np.isfinite(distance) & (distance >= near_m)
    if border_px > 0:
        mask[:border_px] = mask[-border_px:] = False
        mask[:, :border_px] = mask[:, -border_px:] = False
    return mask.astype(np.uint8) * 255


def _grey(photo: np.ndarray) -> np.ndarray:
    """The photo's texture as a grey uint8 image: grey minus its blur (shading by the sun varies from frame to frame,
    the texture of the ground does not), scaled to a fixed contrast (exposure varies too), around 128."""
    import cv2

    photo = np.asarray(photo)
    grey = photo if photo.ndim == 2 else cv2.cvtColor(np.ascontiguousarray(photo[..., :3]), cv2.COLOR_RGB2GRAY)
    grey = np.ascontiguousarray(grey, dtype=np.uint8)
    size = 2 * int(round(HIGH_PASS_SIGMA * 3)) + 1
    blur = cv2.stackBlur(grey, (size, size))
    sample = grey[::4, ::4].astype(np.float32) - blur[::4, ::4]
    gain = TEXTURE_CONTRAST / max(float(sample.std()), 1.0)
    return cv2.addWeighted(grey, gain, blur, -gain, 128.0)  # saturated to uint8


class Reference:
    """The reference frame's key points on stable terrain, computed once per time-lapse.

    Args:
        photo: (H, W, 3) or (H, W) uint8 reference frame. camera: its (fitted) camera.
        mask: (H, W) uint8 stable terrain (:func:`stable_mask`).
        features: ORB key points at most; scale: size of the ORB images (coarse step).
        corners: corners tracked for the sub-pixel step.
    """

    def __init__(self, photo: np.ndarray, camera: Camera, mask: np.ndarray, features: int = 1500,
                 scale: Optional[float] = None, corners: int = 400):
        import cv2

        if tuple(camera.image_size) != (photo.shape[1], photo.shape[0]):
            raise ValueError(f"the reference photo is {photo.shape[1]}x{photo.shape[0]} px, its camera "
                             f"{camera.width}x{camera.height} px")
        self.camera = camera
        self.scale = scale if scale is not None else min(1.0, 1000.0 / max(camera.width, camera.height))
        self.grey = _grey(photo)
        self.orb = cv2.ORB_create(nfeatures=features, nlevels=3, fastThreshold=10)  # no zoom between frames
        small_mask = _resized(mask, self.scale, cv2.INTER_NEAREST)
        small = _resized(self.grey, self.scale, cv2.INTER_AREA)
        self.keypoints, self.descriptors = self.orb.detectAndCompute(small, small_mask)
        self.uv = _uv_of(self.keypoints, self.scale)
        found = cv2.goodFeaturesToTrack(self.grey, corners, 0.01, 12, mask=mask, blockSize=7)
        self.corners = (found.reshape(-1, 2).astype(np.float32) if found is not None
                        else np.zeros((0, 2), np.float32))  # OpenCV pixel convention (centres on integers)
        self.corner_rays = camera.pixel_to_camera_ray(self.corners.astype(np.float64) + 0.5)


def _resized(image: np.ndarray, scale: float, interpolation) -> np.ndarray:
    import cv2

    if scale == 1.0:
        return image
    size = (max(8, int(round(image.shape[1] * scale))), max(8, int(round(image.shape[0] * scale))))
    return cv2.resize(image, size, interpolation=interpolation)


def _uv_of(keypoints, scale: float) -> np.ndarray:
    """Key point positions in full-size pixels of the module convention (u, v)."""
    pts = np.array([k.pt for k in keypoints], dtype=np.float64).reshape(-1, 2)
    return (pts + 0.5) / scale


def register(reference: Reference, photo: np.ndarray, threshold_px: float = 2.0,
             min_inliers: int = MIN_INLIERS, max_degrees: float = 5.0) -> Drift:
    """The rotation of ``photo`` from the reference (see the module docstring); never raises for a bad frame.

    ``max_degrees``: the largest turn looked for (matches are searched within the shift it makes)."""
    import cv2

    cam = reference.camera
    if (photo.shape[1], photo.shape[0]) != tuple(cam.image_size):
        return _failed(f"the frame is {photo.shape[1]}x{photo.shape[0]} px, the reference {cam.width}x"
                       f"{cam.height} px")
    grey = _grey(photo)
    keypoints, descriptors = reference.orb.detectAndCompute(_resized(grey, reference.scale, cv2.INTER_AREA), None)
    if descriptors is None or reference.descriptors is None or len(keypoints) < min_inliers:
        return _failed(f"too few key points in the frame ({len(keypoints)}): fog, night or a covered lens?")
    uv = _uv_of(keypoints, reference.scale)
    radius = cam.focal_px * math.tan(math.radians(max_degrees)) + 8.0  # pixels
    ra, rb = reference.uv.astype(np.float32), uv.astype(np.float32)
    d2 = (ra * ra).sum(axis=1)[:, None] + (rb * rb).sum(axis=1)[None, :] - 2.0 * (ra @ rb.T)
    near = (d2 <= radius * radius).view(np.uint8)
    ia, ib = _mutual_matches(reference.descriptors, descriptors, near)
    pairs = ia
    if len(pairs) < min_inliers:
        return _failed(f"too few matches with the reference ({len(pairs)})", matches=len(pairs))
    a = cam.pixel_to_camera_ray(reference.uv[ia])
    b = cam.pixel_to_camera_ray(uv[ib])
    coarse_px = threshold_px / reference.scale
    rotation, inliers = fit_rotation(a, b, threshold=coarse_px / cam.focal_px)
    if rotation is None or inliers.sum() < min_inliers:
        return _failed(f"no rotation agrees with enough matches ({int(inliers.sum()) if rotation is not None else 0}"
                       f" of {len(pairs)})", matches=len(pairs))
    refined = _refine(reference, grey, rotation, threshold_px)
    count = int(inliers.sum())
    if refined is not None and refined[1].sum() >= min_inliers:
        rotation, inliers, a, b = refined
        count = int(inliers.sum())
    residual = _residual_px(cam, a[inliers], b[inliers], rotation)
    return Drift(True, rotation, rotation_angle_deg(rotation), pixel_shift(cam, rotation), len(pairs), count,
                 residual)


def _mutual_matches(a: np.ndarray, b: np.ndarray, allowed: np.ndarray, ratio: float = 0.85
                    ) -> Tuple[np.ndarray, np.ndarray]:
    """Indices (into ``a``, into ``b``) of distinctive descriptor pairs among those ``allowed`` ((len(a), len(b))
    uint8): the nearest (Hamming) clearly nearer than the second (``ratio``), each ``b`` used once."""
    import cv2

    pairs = {}
    for found in cv2.BFMatcher(cv2.NORM_HAMMING).knnMatch(a, b, k=2, mask=allowed):
        if not found or (len(found) == 2 and found[0].distance > ratio * found[1].distance):
            continue
        best = found[0]
        if best.trainIdx in pairs:  # two reference points want this one: neither is sure
            pairs[best.trainIdx] = None
        else:
            pairs[best.trainIdx] = best.queryIdx
    kept = [(i, j) for j, i in pairs.items() if i is not None]
    if not kept:
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    ia, ib = np.array(kept).T
    return ia, ib


def _failed(message: str, matches: int = 0) -> Drift:
    return Drift(False, np.eye(3), matches=matches, message=message)


def _refine(reference: Reference, grey: np.ndarray, rotation: np.ndarray, threshold_px: float):
    """Sub-pixel: corners tracked (Lucas-Kanade) from the predicted positions; rotation fitted on those that agree."""
    import cv2

    cam = reference.camera
    if len(reference.corners) < MIN_INLIERS:
        return None
    predicted = _project_rays(cam, reference.corner_rays @ rotation.T) - 0.5
    start = np.ascontiguousarray(predicted, dtype=np.float32).reshape(-1, 1, 2)
    tracked, status, _ = cv2.calcOpticalFlowPyrLK(
        reference.grey, grey, reference.corners.reshape(-1, 1, 2), start, winSize=(15, 15), maxLevel=2,
        flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
        criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01))
    good = status.reshape(-1) == 1
    tracked = tracked.reshape(-1, 2).astype(np.float64)
    good &= cam.in_image(tracked + 0.5, margin=-2.0)
    if good.sum() < MIN_INLIERS:
        return None
    a = reference.corner_rays[good]
    b = cam.pixel_to_camera_ray(tracked[good] + 0.5)
    threshold = min(threshold_px, 1.0) / cam.focal_px
    inliers = np.ones(len(a), dtype=bool)
    for _ in range(3):  # least squares, drop what disagrees, again
        rotation = _kabsch(a[inliers], b[inliers])
        error = np.linalg.norm(b - a @ rotation.T, axis=1)
        inliers = error <= max(threshold, 3.0 * float(np.median(error)))
    return rotation, inliers, a, b


def fit_rotation(a: np.ndarray, b: np.ndarray, threshold: float, iterations: int = 150, seed: int = 0
                 ) -> Tuple[Optional[np.ndarray], np.ndarray]:
    """Robust ``dR`` with ``b ~ dR a`` for (N, 3) unit rays: RANSAC on pairs of rays, then least squares (Kabsch)
    on the inliers. ``threshold``: largest ray difference of an inlier (radians, ~ pixels / focal).

    Returns (rotation (3, 3) or None when N < 2, inliers (N,) bool)."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 3)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 3)
    n = len(a)
    if n < 2:
        return None, np.zeros(n, dtype=bool)
    rng = np.random.default_rng(seed)
    i = rng.integers(0, n, iterations)
    j = (i + rng.integers(1, n, iterations)) % n  # a different ray
    pa, pb = np.stack([a[i], a[j]], axis=1), np.stack([b[i], b[j]], axis=1)  # (iterations, 2, 3)
    rotations = _kabsch_batch(pa, pb)
    moved = rotations @ a.T  # (iterations, 3, N)
    errors = ((moved - b.T[None]) ** 2).sum(axis=1)  # squared, (iterations, N)
    best = int(np.argmax((errors <= threshold * threshold).sum(axis=1)))
    inliers = errors[best] <= threshold * threshold
    rotation = rotations[best]
    for _ in range(3):
        if inliers.sum() < 2:
            break
        rotation = _kabsch(a[inliers], b[inliers])
        inliers = np.linalg.norm(b - a @ rotation.T, axis=1) <= threshold
    return rotation, inliers


def _kabsch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return _kabsch_batch(a[None], b[None])[0]


def _kabsch_batch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(K, 3, 3) rotations minimising sum |b - R a|^2 over each of K sets of (n, 3) rays."""
    m = np.einsum("kni,knj->kij", b, a)
    u, _, vt = np.linalg.svd(m)
    d = np.sign(np.linalg.det(u @ vt))
    u[:, :, 2] *= d[:, None]
    return u @ vt


def _project_rays(cam: Camera, rays: np.ndarray) -> np.ndarray:
    """(N, 3) camera-frame rays -> (N, 2) pixels of ``cam`` (with its distortion)."""
    uv, _ = project_points(rays, np.zeros(3), np.eye(3), cam.focal_px, cam.cx, cam.cy, cam.k1, cam.k2)
    return uv


def _grid_rays(cam: Camera, n: int = 5) -> Tuple[np.ndarray, np.ndarray]:
    us = np.linspace(0.5, cam.width - 0.5, n)
    vs = np.linspace(0.5, cam.height - 0.5, n)
    uv = np.stack(np.meshgrid(us, vs), axis=-1).reshape(-1, 2)
    return uv, cam.pixel_to_camera_ray(uv)


def pixel_shift(cam: Camera, rotation: np.ndarray, other: Optional[np.ndarray] = None) -> float:
    """Mean displacement in pixels, over a 5 x 5 grid of the image, between turning the view by ``rotation`` and by
    ``other`` (default: not turning): the drift of a frame, or the error of an estimated drift."""
    uv, rays = _grid_rays(cam)
    moved = _project_rays(cam, rays @ np.asarray(rotation).T)
    base = uv if other is None else _project_rays(cam, rays @ np.asarray(other).T)
    return float(np.mean(np.linalg.norm(moved - base, axis=1)))


def _residual_px(cam: Camera, a: np.ndarray, b: np.ndarray, rotation: np.ndarray) -> float:
    if len(a) == 0:
        return float("nan")
    diff = _project_rays(cam, a @ rotation.T) - _project_rays(cam, b)
    return float(np.sqrt(np.mean(np.sum(diff * diff, axis=1))))


def rotation_angle_deg(rotation: np.ndarray) -> float:
    """Angle of a rotation matrix, degrees.

    >>> round(rotation_angle_deg(np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])), 6)
    90.0
    """
    cos = (float(np.trace(rotation)) - 1.0) / 2.0
    return math.degrees(math.acos(max(-1.0, min(1.0, cos))))


def corrected_camera(camera: Camera, rotation: np.ndarray) -> Camera:
    """``camera`` turned by ``dR`` (reference camera frame -> frame's camera frame): same centre and intrinsics."""
    heading, pitch, roll = angles_from_rotation(np.asarray(rotation) @ camera.rotation)
    return camera.with_parameters(heading=heading, pitch=pitch, roll=roll)


def turned_pixels(camera: Camera, rotation: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """(N, 2) where the pixels ``uv`` (N, 2) of ``camera``'s picture lie after the view turned by ``dR`` (reference
    camera frame -> frame's camera frame): the same rays, seen by :func:`corrected_camera`.

    >>> cam = Camera((0, 0, 0), heading=0, pitch=0, roll=0, fov=60, image_size=(640, 480))
    >>> turn = cam.with_parameters(heading=1.0).rotation @ cam.rotation.T
    >>> moved = turned_pixels(cam, turn, np.array([[320.0, 240.0]]))
    >>> round(float(moved[0, 0] - 320.0), 2), round(float(moved[0, 1] - 240.0), 2)  # turned right: points go left
    (-9.67, 0.0)
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    if not len(uv):
        return uv.copy()
    return _project_rays(camera, camera.pixel_to_camera_ray(uv) @ np.asarray(rotation).T)
