"""How far off the fitted camera may put the ground at each pixel: its σ and their correlations, where the ground is.

A fit's pixel error (:func:`~.features.pixel_error`: check points, residuals, or σ over the points it matched) is
measured where its points are, mostly far. A camera fixed by far points can slide along its view and turn: right
there, and far off on the near ground (a desktop trial's phone photo: a flood line at 20-300 m said "± 6 m" and was
73 m off). So each ground point's own share of the camera's uncertainty (:func:`~..core.fit.sigma_shifts`, with the
correlations and, for a camera held on the ground, its height following the terrain) is carried to the ground
too: a product's error is the larger of the two.

>>> from ..core.camera import Camera
>>> cam = Camera((0.0, 0.0, 0.0), 0.0, 0.0, 0.0, 60.0, (1000, 700))
>>> spread = CameraSpread({"x": 10.0, "heading": 0.573}, {"x": {"heading": -1.0}, "heading": {"x": -1.0}})
>>> pixel_errors(2.0, spread, cam, np.array([[0.0, 100.0, -5.0], [0.0, 1000.0, -5.0]])).round(1).tolist()
[77.9, 2.0]
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Dict, Optional

import numpy as np

from ..core.fit import combine_moves, sigma_cameras, sigma_shifts

__all__ = ["CameraSpread", "camera_spread", "plain_correlation", "pixel_errors", "ground_errors_m"]


@dataclass(frozen=True)
class CameraSpread:
    """The fitted camera's uncertainty: σ per parameter (metres, degrees, pixels), their correlations
    ``{name: {other: r}}`` (empty: counted as independent) and, for a camera held on the ground, the terrain
    ``(x, y) -> z`` its height follows."""

    std: Dict[str, float]
    correlation: Dict[str, Dict[str, float]] = field(default_factory=dict)
    ground: Optional[Callable] = None

    def pixels(self, camera, xyz: np.ndarray) -> np.ndarray:
        """(N,) pixels the σ may move each of the (N, 3) map points ``xyz`` in the picture; the picture's diagonal
        where a move by σ puts a point behind the camera (it may be anywhere)."""
        shifts = sigma_shifts(camera, self.std, xyz, self.correlation, self.ground)
        return np.where(np.isfinite(shifts), shifts, float(np.hypot(*camera.image_size)))

    def ground_m(self, camera, dem, uv: np.ndarray, vertical: bool = False) -> np.ndarray:
        """(N,) metres the ground seen at each of the (N, 2) pixels ``uv`` moves horizontally (with ``vertical``:
        up or down) when the camera moves by its σ (each parameter's move: the pixel's ray from the moved camera on
        ``dem``; combined with the correlations); NaN where no ground is seen, or a moved camera's ray there meets
        none.

        Not a pixel error carried by the footprint: on ground seen at a grazing angle that footprint is long along
        the view and short across it, and the camera's moves shift it mostly one way (a near line said ± 40-270 m
        that way where the camera put it 5-47 m off)."""
        from ..core.transforms import photo_points_to_map

        uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        ahead = sigma_cameras(camera, self.std, self.ground)
        back = sigma_cameras(camera, {k: -v for k, v in self.std.items()}, self.ground)
        if not len(uv) or not ahead or set(ahead) != set(back):
            return np.full(len(uv), np.nan)
        axes = slice(2, 3) if vertical else slice(0, 2)
        here = photo_points_to_map(uv, camera, dem)[0][:, axes]
        moves, lost = {}, np.isnan(here).any(axis=1)
        for name in ahead:
            # the larger of the moves by +σ and -σ (as a move by +σ): ground seen at a grazing angle moves more
            # away from the camera than towards it (a near line: +σ alone said half of the camera's real error)
            plus = photo_points_to_map(uv, ahead[name], dem)[0][:, axes] - here
            minus = here - photo_points_to_map(uv, back[name], dem)[0][:, axes]
            larger = np.linalg.norm(minus, axis=1) > np.linalg.norm(plus, axis=1)
            moves[name] = np.nan_to_num(np.where(larger[:, None], minus, plus))
            lost |= np.isnan(plus).any(axis=1) | np.isnan(minus).any(axis=1)
        return np.where(lost, np.nan, combine_moves(moves, self.correlation))


def camera_spread(info: Optional[dict], dem=None) -> Optional[CameraSpread]:
    """The :class:`CameraSpread` of a fit record (the dock's fit info, a camera file's ``"fit"``): None without σ,
    with one undetermined, or when its σ are the rough camera's own (``sigma_is_prior``: no data narrowed them).
    ``dem``: the terrain of a camera that was held on the ground (``info["on_ground"]``).

    >>> camera_spread({"sigma": {"x": 2.0}, "on_ground": True}, None).std, camera_spread({"sigma": {}})
    ({'x': 2.0}, None)
    """
    info = info or {}
    std = {str(k): float(v) for k, v in (info.get("sigma") or {}).items()
           if isinstance(v, (int, float)) and np.isfinite(v) and v > 0}
    if not std or info.get("sigma_is_prior"):
        return None
    correlation = plain_correlation(info.get("correlation"))
    ground = dem.sample if info.get("on_ground") and dem is not None and "z" not in std else None
    return CameraSpread(std, correlation, ground)


def plain_correlation(correlation) -> Dict[str, Dict[str, float]]:
    """Parameter correlations ``{name: {other: r}}`` (a fit's, or as read from a fit record or camera file) as plain
    finite floats, for a record, a JSON file or a :class:`CameraSpread`; what is not a number is left out.

    >>> plain_correlation({"x": {"y": 0.5, "z": None, "w": float("nan")}, "bad": 3})
    {'x': {'y': 0.5}}
    """
    return {str(a): {str(b): float(r) for b, r in row.items()
                     if isinstance(r, (int, float, np.floating)) and np.isfinite(r)}
            for a, row in (correlation or {}).items() if isinstance(row, dict)}


def pixel_errors(figure: Optional[float], spread: Optional[CameraSpread], camera, xyz: np.ndarray) -> np.ndarray:
    """(N,) pixel error at each of the (N, 3) ground points ``xyz``: the fit's ``figure`` (pixels, one for the whole
    picture) or the camera's σ there (``spread``), whichever is larger; the figure alone without a spread, NaN
    without a figure."""
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    base = np.full(len(xyz), np.nan if figure is None else float(figure))
    if figure is None or spread is None or not len(xyz):
        return base
    return np.fmax(base, spread.pixels(camera, xyz))


def ground_errors_m(figure: Optional[float], spread: Optional[CameraSpread], camera, dem, uv: np.ndarray,
                    vertical: bool = False) -> np.ndarray:
    """(N,) horizontal error (metres) of the ground seen at each of the (N, 2) pixels ``uv``: the fit's pixel error
    ``figure`` carried by the footprint (:func:`~..core.transforms.ground_error_m`) or the camera's σ moving that
    ground (:meth:`CameraSpread.ground_m`), whichever is larger. Where a move by σ takes the pixel's ray off the
    terrain, its pixel shift there is carried by the footprint instead. NaN without a figure or where no ground is
    seen. ``vertical``: the error of the ground's height instead (a flood analyst's marks, 3-6 m too high, had
    none said)."""
    from ..core.transforms import ground_error_m, photo_points_to_map

    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    if figure is None or not len(uv):
        return np.full(len(uv), np.nan)
    base = ground_error_m(uv, camera, dem, float(figure), vertical)
    if spread is None:
        return base
    here = spread.ground_m(camera, dem, uv, vertical)
    lost = np.isnan(here) & np.isfinite(base)
    if lost.any():
        ground = photo_points_to_map(uv[lost], camera, dem)[0]
        here[lost] = ground_error_m(uv[lost], camera, dem, spread.pixels(camera, ground), vertical)
    return np.fmax(base, here)
