"""The products of a fitted camera, each written once for the dock and Processing: the XYZ raster, the
orthophoto and the report (vectors: :mod:`.features`, :mod:`.vectors` and :mod:`..outputs.vectors`).

Every product reads the per-pixel XYZ from :mod:`.xyz` (one cache), writes through the writers of
:mod:`..outputs` (temporary file renamed into place, ``overwrite`` as asked) and returns the written path.
"""

from __future__ import annotations

import os
from dataclasses import replace

from pathlib import Path
from typing import Dict, Optional, Tuple

import numpy as np

from ..core.camera import Camera
from ..core.dem import Dem
from ..core.fit import check_bound_px
from .progress import IsCanceled, Progress, check_canceled, part
from .xyz import xyz_result


def _committed(is_canceled: Optional[IsCanceled]):
    """A cancel up to the final rename of the written file leaves the earlier file as it was
    (:func:`~..outputs.safe_write.cancel_before_commit`, adding to a caller's own); after it, the product is
    written and says so."""
    from contextlib import nullcontext

    from ..outputs.safe_write import cancel_before_commit

    return nullcontext() if is_canceled is None else cancel_before_commit(is_canceled, also_outer=True)

__all__ = ["ProductError", "write_xyz", "orthophoto", "report", "ortho_grid", "dem_at_resolution", "auto_resolution",
           "ground_error", "picture_area", "NO_GROUND", "blank_outside", "area_at", "MAX_ORTHO_CELLS", "AUTO"]

#: an orthophoto grid larger than this many cells is refused (memory)
MAX_ORTHO_CELLS = 50_000_000
#: ``resolution`` of :func:`orthophoto` / :func:`ortho_grid`: the photo's own detail (:func:`auto_resolution`)
AUTO = "auto"
#: at most this many cells in an automatic orthophoto (about 40 MB of RGBA, seconds to make)
AUTO_ORTHO_CELLS = 10_000_000


class ProductError(ValueError):
    """A product cannot be made from these inputs; the message says why."""


#: Why an XYZ raster or orthophoto would be empty.
NO_GROUND = "no pixel of the photo sees the DEM (the camera looks at the sky, or past the DEM)"


def _check_ground(xyz: np.ndarray, allow_empty: bool) -> None:
    """A product with no ground pixel is an error unless ``allow_empty`` (a trial: a camera fitted to GCPs in
    another CRS stood 2,200 km from the DEM, and the dock said "Written" of an XYZ raster with no valid pixel)."""
    if not allow_empty and not np.isfinite(xyz[..., 2]).any():
        raise ProductError(f"{NO_GROUND}. Are the camera and its map points in the DEM's CRS?")


def picture_area(photo: np.ndarray, work_size: int = 2000) -> Optional[np.ndarray]:
    """(H, W) bool, where ``photo`` shows the scene: not a print's paper border, frame line or printed caption (the
    photo suggestions' :func:`~..core.suggest_photo.picture_mask`, found on a copy at most ``work_size`` px on its
    long side); None when that is the whole photo. A photo that fills its frame loses no edge pixels.

    A scanned print's caption was draped onto the terrain of the orthophoto, and its border got map coordinates in
    the XYZ raster (a desktop trial on a generated print): the products leave them out.
    """
    import cv2

    from ..core.suggest_photo import picture_mask, to_gray

    h, w = photo.shape[:2]
    scale = min(1.0, float(work_size) / max(h, w))
    # shrunk before it is made grey: the grey of a 24 MP scan took 2 s on the main thread (a trial's KML import)
    small = cv2.resize(np.ascontiguousarray(photo), (max(1, round(w * scale)), max(1, round(h * scale))),
                       interpolation=cv2.INTER_AREA) if scale < 1.0 else photo
    mask = picture_mask(to_gray(small), beyond_captions=True)
    if mask.all():
        return None
    if scale < 1.0:
        mask = cv2.resize(mask.astype(np.uint8), (w, h), interpolation=cv2.INTER_NEAREST).astype(bool)
    return mask


#: A picture whose centre is this share of the width or more off the file's centre has its own principal point.
PICTURE_CENTRE_SHIFT = 0.005
#: ... when the picture covers at least this share of the file: a print's picture fills most of its scan (the
#: trial's 75 %, Aletsch's 92 %), and a false "border" found on a photo that fills its frame (10 of the 50 rendered
#: scenes of eval.auto kept 9-86 % before paper had to be flat and on every side) must not move its principal point.
PICTURE_CENTRE_MIN_SHARE = 0.5


def centred_on_picture(camera: Camera, area: Optional[np.ndarray]) -> Camera:
    """``camera`` with its principal point at the centre of the picture ``area`` ((H, W) bool,
    :func:`picture_area`) when it has none of its own and that centre is :data:`PICTURE_CENTRE_SHIFT` of the width
    or more off the file's centre: a scanned print's paper border, caption and scanner strips are uneven, and the
    optical axis goes through the picture's centre, not the scan's. (A generated Aletsch print with GCPs: paired
    fit 13.5 px with the scan's centre, 12.4 px with the picture's, 12.35 px with the true one.)

    >>> cam = Camera((0.0, 0.0, 100.0), 0.0, 0.0, 0.0, 60.0, (200, 100))
    >>> area = np.zeros((100, 200), bool); area[5:75, 5:195] = True  # a caption strip under the picture
    >>> centred_on_picture(cam, area).principal_point, centred_on_picture(cam, None).principal_point
    ((100.0, 40.0), None)
    >>> area[:] = False; area[40:60, 150:190] = True  # 4 % of the file: a false border, not a print
    >>> centred_on_picture(cam, area).principal_point is None
    True
    """
    if area is None or camera.principal_point is not None or area.mean() < PICTURE_CENTRE_MIN_SHARE:
        return camera
    area = area_at(area, (camera.height, camera.width))
    rows, cols = np.flatnonzero(area.any(axis=1)), np.flatnonzero(area.any(axis=0))
    cx, cy = 0.5 * (cols[0] + cols[-1] + 1), 0.5 * (rows[0] + rows[-1] + 1)
    if max(abs(cx - camera.cx), abs(cy - camera.cy)) < PICTURE_CENTRE_SHIFT * camera.width:
        return camera
    return replace(camera, principal_point=(float(cx), float(cy)))


def in_picture(uv: np.ndarray, area: Optional[np.ndarray]) -> np.ndarray:
    """(N,) bool: photo positions ``uv`` (N, 2) pixels inside the picture ``area`` ((H, W) bool of the photo,
    :func:`picture_area`; None: everywhere in it, and positions off the photo are "inside" then too, left to the
    caller). A feature drawn on a print's paper or caption gets no ground there (a trial: a line drawn on the
    caption became a 27 m map line).

    >>> area = np.zeros((4, 6), bool); area[1:3, 1:5] = True
    >>> in_picture(np.array([[2.5, 1.5], [0.5, 1.5], [9.0, 1.0], [np.nan, 1.0]]), area).tolist()
    [True, False, False, False]
    """
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    if area is None:
        return np.ones(len(uv), dtype=bool)
    h, w = area.shape
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(uv).all(axis=1) & (uv[:, 0] >= 0) & (uv[:, 0] < w) & (uv[:, 1] >= 0) & (uv[:, 1] < h)
    inside = np.zeros(len(uv), dtype=bool)
    cols, rows = uv[ok, 0].astype(int), uv[ok, 1].astype(int)
    inside[ok] = area[rows, cols]
    return inside


def blank_outside(values: np.ndarray, area: Optional[np.ndarray]) -> np.ndarray:
    """``values`` ((H, W) or (H, W, k) per pixel), or a float copy with NaN outside ``area`` (:func:`picture_area`,
    resized to the values' grid when it is another size, as the dock's reduced XYZ); ``area`` None: ``values``.

    >>> blank_outside(np.ones((2, 2)), np.array([[True, False], [True, True]])).tolist()
    [[1.0, nan], [1.0, 1.0]]
    """
    if area is None:
        return values
    out = np.array(values, dtype=np.float64, copy=True)
    out[~area_at(area, out.shape[:2])] = np.nan
    return out


def area_at(area: np.ndarray, shape) -> np.ndarray:
    """``area`` resized (nearest) to ``shape`` (rows, cols)."""
    if area.shape == tuple(shape):
        return area
    import cv2

    return cv2.resize(area.astype(np.uint8), (shape[1], shape[0]), interpolation=cv2.INTER_NEAREST) > 0


def write_xyz(path, camera: Camera, dem, crs_wkt: Optional[str] = None, photo_name: str = "",
              distance: bool = False, overwrite: bool = False, progress: Optional[Progress] = None,
              is_canceled: Optional[IsCanceled] = None, fit: Optional[dict] = None,
              photo: Optional[np.ndarray] = None, area: Optional[np.ndarray] = None,
              allow_empty: bool = True) -> Path:
    """The 3-band X, Y, Z GeoTIFF of the photo's pixels (nodata for the sky); a 4th band of distances from the
    camera only when ``distance`` is asked; ``fit``: the camera's verdict and errors, kept in the metadata;
    ``photo`` (H, W, 3): when given, its print border and caption are nodata too (:func:`picture_area`); ``area``:
    that picture area when the caller has found it already; ``allow_empty=False``: no ground pixel is a
    :class:`ProductError` (Processing checks it itself, with its ALLOW_EMPTY)."""
    from ..outputs.xyz_raster import write_xyz_raster

    result = xyz_result(camera, dem, visibility=False, progress=part(progress, 0.0, 0.8), is_canceled=is_canceled)
    check_canceled(is_canceled)
    if area is None and photo is not None:
        area = picture_area(photo)
    xyz = blank_outside(result.xyz, area)
    _check_ground(xyz, allow_empty)
    dist = blank_outside(result.distance, area) if distance else None
    with _committed(is_canceled):
        written = write_xyz_raster(path, xyz, crs_wkt if crs_wkt is not None else dem.crs_wkt, dist,
                                   overwrite=overwrite, camera=camera, photo_name=photo_name, fit=fit,
                                   progress=part(progress, 0.8, 1.0))
    if progress is not None:
        progress(1.0, "")
    return written


def orthophoto(path, photo: np.ndarray, camera: Camera, dem, resolution=None,
               overwrite: bool = False, progress: Optional[Progress] = None,
               is_canceled: Optional[IsCanceled] = None, grid=None, allow_empty: bool = True,
               fit: Optional[dict] = None) -> Path:
    """The photo (H, W, 3) draped on the DEM (not its print border or caption, :func:`picture_area`): a north-up RGBA
    GeoTIFF on the DEM's grid, or on a grid of cell size
    ``resolution`` over the same extent (elevations resampled bilinearly), or (:data:`AUTO`) at the photo's own
    detail over the part the camera sees (:func:`auto_resolution`); ``grid``: :func:`ortho_grid` when the caller has
    it already; ``allow_empty=False``: no ground pixel is a :class:`ProductError`; ``fit``: the camera's verdict,
    kept in the metadata as the XYZ raster keeps it."""
    from ..outputs.orthophoto import orthophoto_from_camera

    if (photo.shape[1], photo.shape[0]) != tuple(camera.image_size):
        raise ProductError(f"the photo is {photo.shape[1]}x{photo.shape[0]} px but the camera is for "
                           f"{camera.width}x{camera.height} px")
    xyz = xyz_result(camera, dem, visibility=False, progress=part(progress, 0.0, 0.5), is_canceled=is_canceled).xyz
    check_canceled(is_canceled)
    xyz = blank_outside(xyz, picture_area(photo))  # no print border or caption draped on the terrain
    _check_ground(xyz, allow_empty)
    grid = ortho_grid(camera, dem, resolution, xyz) if grid is None else grid
    check_canceled(is_canceled)
    def between_chunks(fraction: float) -> None:  # the lookup of a large grid takes a while: report, stop early
        if progress is not None:
            progress(0.5 + 0.45 * fraction, "")
        check_canceled(is_canceled)

    with _committed(is_canceled):
        written = orthophoto_from_camera(path, photo, camera, grid, xyz, overwrite=overwrite,
                                         between_chunks=between_chunks, fit=fit)
    if progress is not None:
        progress(1.0, "")
    return written


def report(path, photo: np.ndarray, camera: Camera, dem, points=None, points_csv=None,
           sigmas: Optional[Dict[str, float]] = None, title: str = "", overwrite: bool = False,
           progress: Optional[Progress] = None, is_canceled: Optional[IsCanceled] = None, verdict: str = "",
           checks=None, accuracy: Optional[str] = None, photo_taken: str = "") -> Path:
    """The one-page report (PNG or PDF by the suffix of ``path``) of a fitted camera; ``points``: the control
    points to show (outputs' ``ReportPoints``), or ``points_csv``, a paired CSV; ``verdict``: the fit's status and
    message, printed on the page; ``checks``: independent check points (``ReportPoints``), drawn and measured;
    ``accuracy``: what the camera is worth on the ground, in words (None: from the check points when there are
    some, else from the paired points' residuals, :func:`ground_error`); ``photo_taken``: the photo's EXIF date."""
    from ..outputs.report import write_report

    if points is None and points_csv:
        points, table_checks = report_points(points_csv, dem, split_checks=True)
        checks = table_checks if checks is None else checks
    result = xyz_result(camera, dem, visibility=True, progress=part(progress, 0.0, 0.6), is_canceled=is_canceled)
    check_canceled(is_canceled)
    area = picture_area(photo)
    if accuracy is None:  # over the picture's ground only (a print's paper put the median 2.3 km for 2.8 km)
        accuracy = points_accuracy(camera, dem, blank_outside(result.xyz, area), points, checks)
    with _committed(is_canceled):
        written = write_report(path, photo, camera, dem, points=points, xyz=result.xyz, picture=area,
                               visible=result.visible, sigmas=sigmas, title=title, overwrite=overwrite,
                               verdict=verdict, checks=checks, accuracy=accuracy, photo_taken=photo_taken or "")
    if progress is not None:
        progress(1.0, "")
    return written


def report_points(path, dem, split_checks: bool = False):
    """The paired points of a CSV table (:func:`~.points_csv.read_points_csv`) as the report's ``ReportPoints``;
    its map points in the DEM's working CRS as ``fitcamera`` reads them (:func:`~.inputs.points_to_dem_crs`: a
    longitude/latitude table gave "RMSE nan px" and no check points in a trial's report, where ``fitcamera`` had
    fitted the same table); a missing Z is the DEM's. ``split_checks``: (fitted points, check points or None) by
    the table's check column.

    Raises:
        InputError: the table is not paired (it needs u, v and X, Y columns on each row).
    """
    from ..outputs.report import ReportPoints
    from .inputs import InputError, points_to_dem_crs
    from .points_csv import read_points_csv
    from .vectors import fill_missing_z

    table = read_points_csv(str(path))
    if "uv" not in table or "xyz" not in table:
        raise InputError(f"{os.path.basename(str(path))}: the report needs paired points (u_px, v_px and X, Y, Z "
                         f"on each row)")
    converted = points_to_dem_crs(table["xyz"], dem, name=os.path.basename(str(path)))[0]
    xyz, names = fill_missing_z(converted, dem), [str(i) for i in table["ids"]]
    if not split_checks:
        return ReportPoints(table["uv"], xyz, names)
    check = np.asarray(table.get("check", np.zeros(len(xyz), dtype=bool)), dtype=bool)
    fitted = ReportPoints(table["uv"][~check], xyz[~check], [n for n, c in zip(names, check) if not c])
    return fitted, (ReportPoints(table["uv"][check], xyz[check], [n for n, c in zip(names, check) if c])
                    if check.any() else None)


def ortho_grid(camera: Camera, dem, resolution=None, xyz: Optional[np.ndarray] = None):
    """The grid of the orthophoto: the DEM's, or one of cell size ``resolution`` over the part of the DEM the camera
    sees, or (:data:`AUTO`) one of :func:`auto_resolution` over that part. For a DEM file read by windows (core
    :class:`~..core.dem_large.LargeDem`) the part of it the camera sees, at the finest level of at most half
    :data:`MAX_ORTHO_CELLS` cells and the cells read whole (``in_memory_limit``); ``resolution`` then resamples
    that part. ``xyz``: the camera's per-pixel XYZ when the caller has it (for :data:`AUTO`)."""
    from ..core.dem_large import in_memory_limit, is_large

    if resolution == AUTO and is_large(dem):  # read by windows: the part it sees, at its finest level that fits
        resolution = None
    if resolution == AUTO:
        seen = xyz_result(camera, dem, visibility=False).xyz if xyz is None else xyz
        cell, bounds = auto_resolution(camera, dem, seen)
        return dem_at_resolution(dem, cell, bounds)

    if is_large(dem):
        try:
            dem = dem.source.view_dem(camera, max_cells=min(MAX_ORTHO_CELLS // 2, in_memory_limit()))
        except ValueError as exc:
            raise ProductError(str(exc)) from None
    if not resolution:
        return dem
    # over the part the camera sees, as AUTO (a desktop trial: 10 m cells over the whole DEM, 2200 x 2200 of which
    # 3.5 % had data, 7.7 s)
    pts = _seen_sample(xyz_result(camera, dem, visibility=False).xyz if xyz is None else xyz)
    if not len(pts):
        raise ProductError("the camera sees no terrain of the DEM: no orthophoto")
    return dem_at_resolution(dem, resolution, seen_bounds(dem, pts, float(resolution)))


def auto_resolution(camera: Camera, dem, xyz: np.ndarray):
    """(cell size, (xmin, ymin, xmax, ymax)) of an orthophoto that keeps the photo's detail: the ground footprint of
    one pixel at the median distance of the terrain it sees (``xyz`` (H, W, 3) per-pixel map coordinates, NaN for
    sky), never coarser than the DEM's cell unless :data:`AUTO_ORTHO_CELLS` cells over the seen area (the extent, one
    cell of margin) need it, never finer than they allow.

    Raises:
        ProductError: the camera sees no terrain.
    """
    pts = _seen_sample(xyz)
    if not len(pts):
        raise ProductError("the camera sees no terrain of the DEM: no orthophoto")
    distance = _median_distance(camera, pts)
    lo, hi = pts[:, :2].min(axis=0), pts[:, :2].max(axis=0)
    area = float(np.prod(np.maximum(hi - lo, dem.cell_size)))
    budget = (area / AUTO_ORTHO_CELLS) ** 0.5
    # the cell budget first: over a 1 m DEM, the DEM's cells made 54 M of them, refused with no way round (a trial)
    cell = max(budget, min(float(dem.cell_size), max(distance / camera.focal_px, budget)))
    return cell, seen_bounds(dem, pts, cell)


def seen_bounds(dem, pts: np.ndarray, margin: float) -> Tuple[float, float, float, float]:
    """(xmin, ymin, xmax, ymax) of the terrain points ``pts`` (N, 3) the camera sees, ``margin`` map units wider
    on every side, within the DEM's extent."""
    lo, hi = pts[:, :2].min(axis=0), pts[:, :2].max(axis=0)
    bx0, by0, bx1, by1 = dem.bounds()
    return (max(bx0, lo[0] - margin), max(by0, lo[1] - margin), min(bx1, hi[0] + margin), min(by1, hi[1] + margin))


def _seen_sample(xyz: np.ndarray) -> np.ndarray:
    """(N, 3) finite points of a per-pixel XYZ raster, at most about 200,000 of them (evenly taken)."""
    pts = np.asarray(xyz).reshape(-1, 3)
    pts = pts[::max(1, len(pts) // 200_000)]
    return pts[np.isfinite(pts).all(axis=1)]


def _median_distance(camera: Camera, pts: np.ndarray) -> float:
    return float(np.median(np.linalg.norm(pts - np.asarray(camera.position), axis=1)))


def ground_error(camera: Camera, xyz: np.ndarray, error_px: float, dem=None,
                 samples: int = 400) -> Tuple[float, float]:
    """(median distance to the terrain the camera sees, the median horizontal error ``error_px`` pixels make on that
    terrain), both in map units: an image error said on the ground. With ``dem``, the error is the footprint's
    (:func:`~..core.transforms.ground_error_m` at up to ``samples`` pixels that see terrain, evenly taken: it counts
    terrain seen at a grazing angle, where a pixel spans far more along the view); without, face-on at the median
    distance (a lower bound). NaN, NaN when the camera sees no terrain (``xyz`` (H, W, 3), any size: its cells are
    taken as the photo's pixels scaled).

    >>> from monoplot_plugin.core.camera import Camera
    >>> cam = Camera((0.0, 0.0, 0.0), 0.0, 0.0, 0.0, 90.0, (1000, 800))  # focal 500 px
    >>> [round(v, 6) for v in ground_error(cam, np.array([[[0.0, 5000.0, 0.0]]]), 2.0)]
    [5000.0, 20.0]
    """
    spread = ground_error_spread(camera, xyz, error_px, dem, samples)
    return spread["distance"], spread["median"]


def ground_error_spread(camera: Camera, xyz: np.ndarray, error_px: float, dem=None, samples: int = 400) -> dict:
    """:func:`ground_error` with its spread: ``distance`` (median, map units), ``median``, ``low`` and ``high``
    (10th and 90th percentiles of the error over the terrain seen; without ``dem`` all three face-on at the median
    distance). NaN everywhere when the camera sees no terrain."""
    nan = float("nan")
    out = {"distance": nan, "median": nan, "low": nan, "high": nan}
    pts = _seen_sample(xyz)
    if not len(pts) or not np.isfinite(error_px):
        return out
    out["distance"] = distance = _median_distance(camera, pts)
    if dem is None:
        face_on = distance * float(error_px) / camera.focal_px
        return {**out, "median": face_on, "low": face_on, "high": face_on}
    from ..core.transforms import ground_error_m

    rows, cols = np.nonzero(np.isfinite(np.asarray(xyz)).all(axis=2))
    pick = np.unique(np.linspace(0, len(rows) - 1, min(len(rows), samples)).round().astype(int))
    scale_u, scale_v = camera.width / xyz.shape[1], camera.height / xyz.shape[0]
    uv = np.column_stack([(cols[pick] + 0.5) * scale_u, (rows[pick] + 0.5) * scale_v])
    errors = ground_error_m(uv, camera, dem, float(error_px))
    errors = errors[np.isfinite(errors)]
    if len(errors):
        out["low"], out["median"], out["high"] = (float(v) for v in np.percentile(errors, [10, 50, 90]))
    return out


def metres_words(value: float) -> str:
    """A length in words, two significant figures: "0.34 m", "1.8 m", "27 m", "1.5 km".

    >>> [metres_words(v) for v in (0.342, 1.83, 27.4, 268.0, 1530.0)]
    ['0.34 m', '1.8 m', '27 m', '268 m', '1.5 km']
    """
    if value >= 1000.0:
        return f"{value / 1000.0:.1f} km"
    return f"{value:.0f} m" if value >= 10.0 else f"{value:.1f} m" if value >= 1.0 else f"{value:.2f} m"


def ground_error_words(spread: dict) -> str:
    """"about 1.8 m on the ground, the median over the terrain seen, 272 m away at the median; 0.6 m to 19 m over
    80 % of it" from :func:`ground_error_spread`; "" when not finite. (A trial's near-range flood photo read "about
    0 m on the ground, ... 0.0 km away": the near slope at the camera's feet was most of the picture.)"""
    if not np.isfinite(spread.get("median", float("nan"))):
        return ""
    text = (f"about {metres_words(spread['median'])} on the ground, the median over the terrain seen, "
            f"{metres_words(spread['distance'])} away at the median")
    low, high = spread.get("low", float("nan")), spread.get("high", float("nan"))
    if np.isfinite(low) and np.isfinite(high) and high > 1.5 * low:
        text += f"; {metres_words(low)} to {metres_words(high)} over 80 % of it"
    return text


def points_accuracy(camera: Camera, dem, xyz: np.ndarray, points=None, checks=None) -> str:
    """"check points 7.7 px on 5, at most 12.2 px at 95 %: about 40 m on the ground, ...": what the check points
    vouch for (:func:`~..core.fit.check_bound_px`), or the larger of the
    paired points' RMSE and their leave-one-out error (:func:`leave_one_out_px`: the residuals of the points a
    camera was fitted to understate its error, as :func:`~.features.pixel_error` says) when that is larger or there
    are no check points (a few check points on flat ground at mid range said half a trial's error), carried to the
    terrain seen (:func:`ground_error`); "" without either. ``points``, ``checks``: objects with ``uv`` (N, 2) and
    ``xyz`` (N, 3) (outputs' ``ReportPoints``). (A trial: "7.7 px on 11: about 32 m" where the GCPs were 10-151 m off,
    median 53 m; from the leave-one-out 11.4 px it says about 48 m.)"""
    measures = []  # (pixels, words) of the check points, then of the paired points
    for kind, pts in (("check", checks), ("paired", points)):
        if pts is None or not len(pts.uv):
            continue
        residual = camera.project(pts.xyz) - pts.uv
        rmse = float(np.sqrt(np.nanmean(np.sum(residual ** 2, axis=1))))
        if kind == "check":  # what so many vouch for (features.pixel_error)
            bound = check_bound_px(rmse, len(pts.uv))
            measures.append((bound, f"check points {rmse:.1f} px on {len(pts.uv)}, at most {bound:.1f} px at 95 %"))
            continue
        loo = leave_one_out_px(camera, pts.uv, pts.xyz)
        pixels = max(rmse, loo) if np.isfinite(loo) else rmse
        what = (f"{len(pts.uv)} paired points, RMSE {rmse:.1f} px"
                + (f", leave-one-out {loo:.1f} px" if np.isfinite(loo) else ""))
        if not measures:
            measures.append((pixels, "no check points; " + what))
        elif pixels > measures[0][0]:  # the larger of two independent measures (:func:`.features.pixel_error`)
            measures[0] = (pixels, f"{what}, more than the {measures[0][1]}")
    for pixels, what in measures[:1]:
        words = ground_error_words(ground_error_spread(camera, xyz, pixels, dem))
        if words:
            return f"{what}: {words}"
    return ""


def leave_one_out_px(camera: Camera, uv: np.ndarray, xyz: np.ndarray) -> float:
    """Leave-one-out RMSE (pixels) of the paired points ``uv`` (N, 2) / ``xyz`` (N, 3): each predicted by a paired
    fit, from ``camera``, of the others (:func:`~..core.fit.fit_camera`); NaN when too few or refused."""
    from ..core.fit import fit_camera

    uv, xyz = np.asarray(uv, dtype=float).reshape(-1, 2), np.asarray(xyz, dtype=float).reshape(-1, 3)
    pairs = np.column_stack([np.arange(len(uv))] * 2)
    try:
        return float(fit_camera(uv, xyz, camera, pairs=pairs).loo_rmse_px)
    except ValueError:  # degenerate points
        return float("nan")


def dem_at_resolution(dem, resolution: float, bounds=None):
    """A north-up copy of ``dem`` with square cells of ``resolution`` map units over the same extent (or over
    ``bounds`` = (xmin, ymin, xmax, ymax)).

    >>> d = Dem.from_array(np.arange(16.0).reshape(4, 4), (0, 10, 0, 40, 0, -10))
    >>> dem_at_resolution(d, 20).elevation.shape
    (2, 2)
    >>> dem_at_resolution(d, 5, (0, 0, 20, 10)).elevation.shape
    (2, 4)
    """
    xmin, ymin, xmax, ymax = dem.bounds() if bounds is None else bounds
    cols = max(2, int(round((xmax - xmin) / resolution)))
    rows = max(2, int(round((ymax - ymin) / resolution)))
    if rows * cols > MAX_ORTHO_CELLS:
        raise ProductError(f"orthophoto of {cols}x{rows} cells at {resolution} map units is too large")
    xs = xmin + (np.arange(cols) + 0.5) * resolution
    ys = ymax - (np.arange(rows) + 0.5) * resolution
    elevation = np.empty((rows, cols))
    step = max(1, SAMPLE_CELLS // cols)  # a block of rows at a time: sampling 10 M cells at once took 1.3 GB more
    for r0 in range(0, rows, step):
        gx, gy = np.meshgrid(xs, ys[r0:r0 + step])
        elevation[r0:r0 + step] = np.asarray(dem.sample(gx.ravel(), gy.ravel()), dtype=float).reshape(gx.shape)
    return Dem.from_array(elevation, (xmin, resolution, 0.0, ymax, 0.0, -resolution), crs_wkt=dem.crs_wkt)


#: DEM cells resampled at a time by :func:`dem_at_resolution`.
SAMPLE_CELLS = 1 << 20
