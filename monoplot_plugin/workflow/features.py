"""Features between the photo and the map for the vector products: a feature drawn on the photo as a 3-D map
feature (the dock's digitising), map lines and rings drawn on the photo with their hidden parts.

Ground points come from core's exact ray-terrain intersection or from the per-pixel XYZ raster
(:func:`~monoplot_plugin.core.lookup.sample_xyz`). Pixel convention (see :mod:`monoplot_plugin.core.camera`):
``u`` = column, ``v`` = row.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np

from ..core.fit import check_bound_px
from ..core.lookup import sample_xyz
from ..core.transforms import densify, ground_pieces, silhouette_crossings, true_runs
from ..outputs.vectors import MapFeature
from .spread import CameraSpread, ground_errors_m

__all__ = ["photo_to_map_feature", "PhotoPath", "map_to_photo", "pixel_error", "checks_measure", "feature_error_m",
           "feature_errors", "ground_per_pixel", "area_error_m2", "surface_factor"]

#: Check points from which a fit's pixel error is theirs (:func:`pixel_error`), not its σ's or its leave-one-out
#: error's: with 3 or more drawn at random, the bound they give covered the camera's error in 98-100 % of the
#: synthetic suite's "ok" fits (:func:`~..core.fit.check_bound_px`); with fewer, the larger is said.
CHECKS_OVER_SIGMA = 3

#: Most ground samples of a feature at which its position error is evaluated (evenly along it).
ERROR_SAMPLES = 64


def checks_measure(check_rmse_px: Optional[float], n_check: int) -> Optional[float]:
    """What ``n_check`` check points of RMSE ``check_rmse_px`` vouch for (:func:`~..core.fit.check_bound_px`) when
    they are :data:`CHECKS_OVER_SIGMA` or more, and so measure the camera alone; None when fewer or none.

    >>> round(checks_measure(4.2, 4), 1), checks_measure(4.2, 2), checks_measure(None, 5)
    (7.2, None, None)
    """
    if check_rmse_px is None or n_check < CHECKS_OVER_SIGMA:
        return None
    bound = check_bound_px(check_rmse_px, n_check)
    return bound if np.isfinite(bound) else None


def pixel_error(info: Optional[dict], only_ok: bool = True) -> Tuple[Optional[float], str]:
    """(the photo's pixel error a fit vouches for, RMS pixels; where it comes from): the independent check points'
    RMSE raised to what that many points vouch for (``"check"``, :func:`~..core.fit.check_bound_px`: 1.9 times it
    with 3 points, 1.3 times with 11) when there are :data:`CHECKS_OVER_SIGMA` or more; else for a paired fit the
    largest of that, its RMSE ("fit") and its leave-one-out RMSE ("loo"). An unpaired fit or an automatic
    registration: their residuals measure how well their automatic pairs agree, not their accuracy (Aletsch,
    simulated curation: leave-one-out 3.8 px, the GCPs 9.5 px off; on the ground the GCPs 2.2 times the error
    predicted from 3.8 px), so their camera's σ as a pixel error (``sigma_px``, :func:`~.fit.sigma_px`: 11.1 px
    there) is said ("sigma"), or the check points' when larger or enough (σ counted as independent is an upper
    estimate: a desktop trial's 11 check points said 16.1 px where it said 90.3 px); ``(None, "unpaired")`` without
    either.
    ``(None, "")`` without a fit (a camera loaded from a file), and with ``only_ok`` when the fit is not "ok": its
    residuals would understate a camera the evidence does not support. Carried to the ground as ``xy_error_m``
    (:func:`feature_error_m`) and said with every written product.

    >>> pixel_error({"status": "ok", "rmse_px": 7.7, "loo_rmse_px": 11.4}), pixel_error({"status": "uncertain"})
    ((11.4, 'loo'), (None, ''))
    >>> error, source = pixel_error({"status": "ok", "rmse_px": 2.0, "check_rmse_px": 6.5, "n_check": 11})
    >>> round(error, 1), source
    (8.7, 'check')

    A paired fit's leave-one-out error is a second measure, said when larger than what fewer check points vouch for.
    With 3 or more, theirs: a desktop trial's 11 pairs had a leave-one-out error of 27.7 px, made of the pairs on the
    near ground that each steer the camera alone, where its 4 check points said 4.2 px and the camera was 1.6 m
    off; its drawn flood marks, 7-96 m off, were said to be 42-2065 m off. (Another trial's 3 check points, on flat
    ground at mid range, said 2.4 px, 4.6 px for so few; its camera was 5.3 px off.)

    >>> pixel_error({"status": "ok", "rmse_px": 2.7, "loo_rmse_px": 5.0, "check_rmse_px": 1.8, "n_check": 2})
    (5.0, 'loo')
    >>> error, source = pixel_error({"status": "ok", "rmse_px": 2.3, "loo_rmse_px": 27.7, "check_rmse_px": 4.2,
    ...                              "n_check": 4})
    >>> round(error, 1), source
    (7.2, 'check')
    >>> pixel_error({"status": "ok", "mode": "unpaired", "rmse_px": 2.9, "loo_rmse_px": 3.8})
    (None, 'unpaired')
    >>> pixel_error({"status": "ok", "mode": "unpaired", "rmse_px": 2.9, "sigma_px": 11.1})
    (11.1, 'sigma')
    >>> error, source = pixel_error({"status": "ok", "mode": "unpaired", "sigma_px": 90.3, "check_rmse_px": 16.1,
    ...                              "n_check": 11})
    >>> round(error, 1), source
    (21.5, 'check')
    >>> pixel_error({"status": "ok", "mode": "unpaired", "sigma_px": 11.1, "check_rmse_px": 4.0, "n_check": 2})
    (11.1, 'sigma')
    >>> pixel_error({"status": "ok", "mode": "automatic", "rmse_px": 2.2})  # its pairs were drawn near its camera
    (None, 'unpaired')
    """
    info = info or {}
    if only_ok and info.get("status") != "ok":
        return None, ""

    def finite(key):
        value = info.get(key)
        return float(value) if value is not None and np.isfinite(value) else None

    n_check = int(info.get("n_check") or 0)
    measured = checks_measure(finite("check_rmse_px"), n_check)
    if measured is not None:  # enough check points measure the camera
        return measured, "check"
    check = check_bound_px(finite("check_rmse_px"), n_check)
    check = check if np.isfinite(check) else None
    unpaired = info.get("mode") in ("unpaired", "automatic")  # the registration's matched pairs: agreement too
    # fewer: the larger of them and the fit's own figure, or the one there is
    own = (("sigma", finite("sigma_px")),) if unpaired else (("fit", finite("rmse_px")), ("loo", finite("loo_rmse_px")))
    candidates = [(v, k) for k, v in (("check", check),) + own if v is not None]
    return max(candidates) if candidates else (None, "unpaired" if unpaired else "")


def feature_error_m(ground_uv: np.ndarray, camera, dem, pixel_rmse: Optional[float],
                    spread: Optional[CameraSpread] = None, vertical: bool = False) -> Optional[float]:
    """RMS of :func:`~.spread.ground_errors_m` (metres) over up to :data:`ERROR_SAMPLES` of a feature's
    ground samples (pixels, evenly along it); None without a pixel error or where none of them is finite.
    ``vertical``: the error of the ground's height instead (``z_error_m``: a flood analyst's marks were 3-6 m too
    high, and only the cursor said a ± on heights). With the
    camera's ``spread``, each sample's error is at least the camera's σ there (:func:`~.spread.ground_errors_m`:
    a flood line on the near ground of a phone photo said ± 6 m from its far points' 5.6 px and was 73 m off).

    RMS, not the median: a trial's flood line ran from 10 m to 700 m from the camera, its far end hundreds of metres
    off while the median said 2.3 m (the footprint model at each vertex was within 0.1-1.4 times the real error)."""
    if pixel_rmse is None or camera is None or dem is None or len(ground_uv) == 0:
        return None
    pick = np.unique(np.linspace(0, len(ground_uv) - 1, min(len(ground_uv), ERROR_SAMPLES)).round().astype(int))
    uv = np.asarray(ground_uv, dtype=np.float64).reshape(-1, 2)[pick]
    errors = ground_errors_m(float(pixel_rmse), spread, camera, dem, uv, vertical)
    errors = errors[np.isfinite(errors)]
    return float(np.sqrt(np.mean(errors ** 2))) if len(errors) else None


def area_error_m2(ring_uv: np.ndarray, lookup, camera, pixel_rmse: Optional[float]) -> Optional[float]:
    """How much a polygon's ground area changes when the camera is off by its pixel error (m²): the outline
    ``ring_uv`` (N, 2) pixels, without its closing point, moved by ``pixel_rmse`` either way along u and along v (a
    camera turned), scaled and rotated by it at the picture's corners (a field of view or a roll off), and mapped to
    the ground again by ``lookup``; half of each pair's difference, added in quadrature. None without a pixel error.

    The camera's error moves the whole outline together, not each piece outward as the glacier inventories' buffer
    (perimeter x error) assumes: a trial's 0.30 km² outline had a buffer of 0.26 km² (87 %) where cameras as far off
    moved it by 2 %; Aletsch's cameras fitted without one GCP each move its lower glacier by at most 0.051 km², against
    a buffer of 0.49 km² and 0.067 km² from here."""
    if pixel_rmse is None or not np.isfinite(pixel_rmse) or camera is None or len(ring_uv) < 3:
        return None
    from ..outputs.vectors import polygon_area

    uv = np.asarray(ring_uv, dtype=np.float64)
    w, h = camera.image_size
    centre = np.asarray(camera.principal_point or (w / 2.0, h / 2.0), dtype=np.float64)
    e = float(pixel_rmse)
    turn = e / max(1.0, float(np.hypot(w, h)) / 2.0)  # radians (and scale) moving a corner by e pixels
    rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])

    def moved(sign: float):
        yield uv + (sign * e, 0.0)
        yield uv + (0.0, sign * e)
        yield centre + (uv - centre) * (1.0 + sign * turn)
        yield centre + (uv - centre) @ (rotation if sign > 0 else rotation.T).T

    def area_of(points):
        ground = lookup(points)
        ring = _drop_repeats(ground[np.isfinite(ground).all(axis=1)])
        return polygon_area(ring[:, :2]) if len(ring) >= 3 else 0.0

    changes = [0.5 * (area_of(a) - area_of(b)) for a, b in zip(moved(1.0), moved(-1.0))]
    return float(np.sqrt(np.sum(np.square(changes))))


def surface_factor(ring_xy: np.ndarray, dem) -> Optional[float]:
    """How much larger the terrain's surface is than its map area inside a ring (N, 2) of map X, Y: the mean of
    sqrt(1 + (dz/dx)² + (dz/dy)²) over the DEM cells whose centres lie inside (the cell nearest its centroid for a
    ring smaller than a cell); None off the DEM. A rockfall scar on a 45° slope, 9908 m² on the map, is 14184 m²
    of rock face: a drone trial's geomorphologist had only the map area, and no word that it was one.

    >>> from ..core.dem import Dem
    >>> ramp = Dem.from_array(np.tile(np.arange(40.0) * 10.0, (40, 1)), (0, 10, 0, 400, 0, -10))  # 45 degrees
    >>> round(surface_factor(np.array([[50.0, 50], [300, 50], [300, 300], [50, 300]]), ramp), 4)
    1.4142
    """
    import cv2

    xy = np.asarray(ring_xy, dtype=np.float64).reshape(-1, 2)
    if dem is None or len(xy) < 3:
        return None
    col, row = dem.map_to_cell(xy[:, 0], xy[:, 1])
    c0, r0 = max(int(np.floor(np.min(col))) - 1, 0), max(int(np.floor(np.min(row))) - 1, 0)
    c1, r1 = min(int(np.ceil(np.max(col))) + 2, dem.cols), min(int(np.ceil(np.max(row))) + 2, dem.rows)
    if c1 - c0 < 2 or r1 - r0 < 2:
        return None
    g = dem.geotransform
    window = type(dem).from_array(dem.elevation[r0:r1, c0:c1], (g[0] + c0 * g[1] + r0 * g[2], g[1], g[2],
                                                                 g[3] + c0 * g[4] + r0 * g[5], g[4], g[5]))
    dzdx, dzdy = window.gradient()
    factor = np.sqrt(1.0 + dzdx ** 2 + dzdy ** 2)
    inside = np.zeros(factor.shape, np.uint8)
    # cell (c, r) covers [c, c + 1): its centre at c + 0.5 is pixel c's centre for fillPoly
    ring = np.round(np.column_stack([col - c0 - 0.5, row - r0 - 0.5]) * 16).astype(np.int32)
    cv2.fillPoly(inside, [ring], 1, lineType=cv2.LINE_8, shift=4)
    values = factor[inside.astype(bool) & np.isfinite(factor)]
    if not len(values):
        cc, rr = int(np.clip(np.mean(col) - c0, 0, factor.shape[1] - 1)), int(np.clip(np.mean(row) - r0, 0,
                                                                                     factor.shape[0] - 1))
        values = factor[rr:rr + 1, cc:cc + 1].ravel()
        values = values[np.isfinite(values)]
    return float(np.mean(values)) if len(values) else None


def ground_per_pixel(ground_uv: np.ndarray, camera, dem) -> Tuple[Optional[float], Optional[float]]:
    """(median, largest) horizontal shift (metres, RMS) one pixel of photo error causes on the ground, over up to
    :data:`ERROR_SAMPLES` of a feature's ground samples (pixels, evenly along it): how far a click one pixel off
    moves the feature, whatever the camera's verdict. (None, None) without camera and DEM or where none is
    finite."""
    if camera is None or dem is None or len(ground_uv) == 0:
        return None, None
    from ..core.transforms import ground_error_m

    pick = np.unique(np.linspace(0, len(ground_uv) - 1, min(len(ground_uv), ERROR_SAMPLES)).round().astype(int))
    spans = ground_error_m(np.asarray(ground_uv)[pick], camera, dem, 1.0)
    spans = spans[np.isfinite(spans)]
    return (float(np.median(spans)), float(np.max(spans))) if len(spans) else (None, None)


def photo_to_map_feature(kind: str, vertices, xyz: Optional[np.ndarray] = None, attributes: Optional[dict] = None,
                         step_px: float = 1.0, origin=None, *, camera=None, dem=None,
                         jump: float = 0.1, pixel_rmse: Optional[float] = None,
                         area: Optional[np.ndarray] = None,
                         spread: Optional[CameraSpread] = None) -> Optional[MapFeature]:
    """A feature digitised on the photo as a 3-D map feature.

    Lines and polygon outlines are densified to ``step_px`` pixels first, so they follow the terrain. Pieces over
    sky (or off the DEM) are split off and counted in ``sky_parts``:

    - point: None when it is over sky;
    - line: one part per run of ground samples of at least 2 points, also cut where the range jumps by more than
      ``jump`` (a silhouette: the line passes from a near ridge to a far slope);
    - polygon: the ring keeps its ground samples (it closes across a gap); None when fewer than 3 remain; the
      times it crosses a silhouette (where it encloses hidden ground) are counted in ``silhouettes``.

    Ground points come from core's exact ray-terrain intersection
    (:func:`monoplot_plugin.core.transforms.photo_points_to_map`) when ``camera`` and ``dem`` are given, else from
    the per-pixel XYZ raster ``xyz`` (:func:`sample_xyz`, sub-pixel when ``origin`` is given).

    Args:
        kind: "point", "line" or "polygon".
        vertices: (N, 2) photo vertices (pixels).
        xyz: (H, W, 3) per-pixel map coordinates, NaN for sky (needed without camera and dem).
        attributes: user field values.
        step_px: densification step along lines and outlines (pixels).
        origin: the camera centre, for sub-pixel XYZ lookups and the silhouette test.
        camera, dem: the fitted Camera and core Dem, for exact intersections.
        jump: relative range jump between consecutive samples that cuts a line.
        pixel_rmse: the fit's pixel error (:func:`pixel_error`); with ``camera`` and ``dem`` the feature gets
            ``xy_error_m`` (:func:`feature_error_m` over its ground samples). With them it always gets
            ``m_per_px`` and ``m_px_max`` (:func:`ground_per_pixel`).
        spread: the fitted camera's uncertainty (:func:`~.spread.camera_spread`): ``xy_error_m`` then counts the
            camera's σ where the feature is (near ground of a camera placed by far points).
        area: (H, W) bool, a scanned print's picture (:func:`~.products.picture_area`): samples outside it (the
            paper, the caption) are no ground, as sky is not.
    Returns:
        a :class:`MapFeature`, or None when nothing of the feature is on the ground.
    """
    attributes = dict(attributes or {})
    verts = np.asarray(vertices, dtype=np.float64).reshape(-1, 2)
    if camera is not None and dem is not None:
        from ..core.transforms import photo_points_to_map

        origin = camera.position

        def lookup(uv):
            return photo_points_to_map(uv, camera, dem)[0]
    elif xyz is not None:
        def lookup(uv):
            return sample_xyz(xyz, uv, origin)
    else:
        raise ValueError("give camera and dem, or the XYZ raster")
    if area is not None:
        from .products import in_picture

        on_ground = lookup

        def lookup(uv):
            ground = on_ground(uv)
            ground[~in_picture(uv, area)] = np.nan
            return ground
    if kind == "point":
        ground = lookup(verts[:1])
        if not np.isfinite(ground).all():
            return None
        return MapFeature("point", [ground], attributes,
                          **feature_errors(verts[:1], camera, dem, pixel_rmse, spread),
                          **_spans(verts[:1], camera, dem))
    if kind not in ("line", "polygon"):
        raise ValueError(f"kind must be point, line or polygon, got {kind!r}")
    if kind == "polygon":
        if len(verts) > 1 and np.array_equal(verts[0], verts[-1]):
            verts = verts[:-1]
        # densified along the closing edge too; the last point repeats the first
        dense = np.vstack([densify(verts, step_px, closed=True), verts[:1]])
    else:
        dense = densify(verts, step_px)
    ground = lookup(dense)
    valid = np.isfinite(ground).all(axis=1)
    # the person's own vertices stay; between them one ground point per half DEM cell is all the terrain has (a
    # flood trial's 26-vertex line came out with 2,109 vertices, 3.6 mm apart near the camera)
    clicked = (dense[:, None, :] == verts[None, :, :]).all(axis=2).any(axis=1)
    gap = 0.5 * dem.cell_size if dem is not None else 0.0
    if kind == "polygon":
        ring_valid = valid[:-1]  # the closing point repeats the first
        sky = len(true_runs(~ring_valid))
        if sky > 1 and not ring_valid[0] and not ring_valid[-1]:
            sky -= 1  # a sky run across the ring's start is one piece
        ring = _thinned(ground[:-1][ring_valid], clicked[:-1][ring_valid], gap)
        if len(ring) < 3:
            return None
        crossings = silhouette_crossings(ring, origin, jump) if origin is not None else 0
        factor = surface_factor(ring[:, :2], dem)
        return MapFeature("polygon", [ring], attributes, sky_parts=sky, silhouettes=crossings,
                          surface_factor=factor,
                          **feature_errors(dense[:-1][ring_valid], camera, dem, pixel_rmse, spread),
                          area_error_m2=area_error_m2(dense[:-1], lookup, camera, pixel_rmse) if dem is not None
                          else None,
                          **_spans(dense[:-1][ring_valid], camera, dem))
    pieces = ground_pieces(ground, valid, origin, jump)[0] if origin is not None else true_runs(valid)
    parts = [_thinned(ground[p:q], clicked[p:q], gap) for p, q in pieces]
    parts = [p for p in parts if len(p) >= 2]
    sky = len(true_runs(~valid))
    if not parts:
        return None
    return MapFeature("line", parts, attributes, sky_parts=sky,
                      **feature_errors(dense[valid], camera, dem, pixel_rmse, spread),
                      **_spans(dense[valid], camera, dem))


def feature_errors(ground_uv: np.ndarray, camera, dem, pixel_rmse: Optional[float],
                   spread: Optional[CameraSpread] = None) -> dict:
    """A feature's ``xy_error_m`` and ``z_error_m`` (:func:`feature_error_m` along and across the vertical), as
    :class:`~..outputs.vectors.MapFeature` takes them."""
    return {"xy_error_m": feature_error_m(ground_uv, camera, dem, pixel_rmse, spread),
            "z_error_m": feature_error_m(ground_uv, camera, dem, pixel_rmse, spread, vertical=True)}



def _spans(ground_uv: np.ndarray, camera, dem) -> dict:
    median, largest = ground_per_pixel(ground_uv, camera, dem)
    return {"m_per_px": median, "m_px_max": largest}


def _thinned(points: np.ndarray, keep: np.ndarray, gap: float) -> np.ndarray:
    """``points`` (N, 3) without consecutive duplicates, and without the points closer than ``gap`` (map units, in
    X, Y) to the last one kept, except those ``keep`` marks and the last.

    >>> pts = np.array([[0.0, 0, 0], [0.001, 0, 0], [0.002, 0, 0], [1.5, 0, 0], [1.6, 0, 0], [3.0, 0, 0]])
    >>> _thinned(pts, np.array([True, False, False, False, True, False]), 1.0)[:, 0].tolist()
    [0.0, 1.5, 1.6, 3.0]
    """
    if gap <= 0 or len(points) < 3:
        return _drop_repeats(points)
    chosen, last = [0], points[0, :2]
    for i in range(1, len(points) - 1):
        if keep[i] or float(np.hypot(*(points[i, :2] - last))) >= gap:
            chosen.append(i)
            last = points[i, :2]
    chosen.append(len(points) - 1)
    return _drop_repeats(points[chosen])


def _drop_repeats(points: np.ndarray) -> np.ndarray:
    """Remove consecutive duplicates (several densified points fall in one pixel)."""
    if len(points) < 2:
        return points
    keep = np.concatenate([[True], np.any(np.diff(points, axis=0) != 0, axis=1)])
    return points[keep]


@dataclass
class PhotoPath:
    """A map line drawn on the photo: (M, 2) pixel vertices, each visible, hidden behind terrain, or neither
    (behind the camera, outside the photo, off the DEM)."""

    uv: np.ndarray
    visible: np.ndarray
    occluded: np.ndarray

    def pieces(self) -> List[Tuple[np.ndarray, bool]]:
        """Consecutive drawable runs as (uv (k, 2), visible) pieces: visible ones solid, hidden ones dashed. Pieces
        share their end points, so a dashed piece joins the solid ones; the rest is left out."""
        drawable = (self.visible | self.occluded) & np.isfinite(self.uv).all(axis=1)
        out = []
        for a, b in true_runs(drawable):
            vis = self.visible[a:b]
            change = np.flatnonzero(np.diff(vis.astype(np.int8))) + 1
            bounds = [0, *change.tolist(), b - a]
            for s, e in zip(bounds[:-1], bounds[1:]):
                piece = self.uv[a + s: a + min(e + 1, b - a)]
                if len(piece) >= 2:
                    out.append((piece, bool(vis[s])))
        return out


def map_to_photo(parts_xy: Sequence[np.ndarray], camera, dem, step: Optional[float] = None) -> List[PhotoPath]:
    """Map lines or polygon rings drawn onto the photo, each vertex flagged visible or hidden.

    Core's :func:`monoplot_plugin.core.transforms.map_to_photo` does the work (exact line of sight to every
    vertex); this wraps its result for drawing.

    Args:
        parts_xy: list of (N, 2) or (N, 3) map coordinate arrays (rings should repeat their first vertex). 2-D
            outlines are draped on the terrain.
        camera: the photo's Camera.
        dem: the :class:`~monoplot_plugin.core.dem.Dem` (same CRS as the layer: reproject the layer first).
        step: densification in map units (default: half a DEM cell) so the drawn line follows the terrain and
            hidden runs are found.
    Returns:
        one :class:`PhotoPath` per input part.
    """
    from ..core.transforms import map_to_photo as core_map_to_photo

    parts = [np.asarray(p, dtype=np.float64) for p in parts_xy]
    return [PhotoPath(r.uv, r.visible, r.occluded & r.in_image)
            for r in core_map_to_photo(parts, camera, dem, densify_m=step)]
