"""One frame of a batch, and what the frames of one camera share (computed once, reused by every frame).

What depends only on the camera and the DEM is :class:`CameraProducts`: the XYZ raster, whether the camera sees any
ground, and the orthophoto's index map (:class:`~..core.lookup.OrthoLookup`), so a frame of a time-lapse costs a
decode, a gather and a write. With re-registration (:class:`Timelapse` ``register``) each frame is first matched to
the reference frame (:mod:`..core.drift`); a frame that turned gets products of its own corrected camera, a frame
that cannot be registered fails with the reason (it is never given the reference camera).

:func:`process_frame` never raises for one frame's problem: it returns a :class:`PhotoResult`. It runs in threads
(:func:`..workflow.batch.run_batch`) and on Dask workers (:mod:`.cluster`), which rebuild the shared part from a
picklable :class:`Timelapse` (:func:`shared_for`, cached per process).
"""

from __future__ import annotations

import json
import math
import os
import threading
import time
from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np

from ..core.camera import Camera
from ..core.drift import MIN_INLIERS, Reference, corrected_camera, register, stable_mask
from ..core.lookup import ortho_lookup, turnable_lookup
from ..core.suggest_photo import FEATURELESS_CONTRAST, coarse_contrast
from ..outputs.orthophoto import write_orthophoto
from ..outputs.safe_write import write_text
from ..outputs.xyz_raster import write_xyz_raster
from .camera_files import PIXEL_FIGURES, camera_json, fitted_on_photo
from .files import InputError, load_camera, read_photo, read_points_csv
from .fit import fit_points
from .progress import IsCanceled, Progress, check_canceled, never_canceled
from .text import fit_figures_text, name_photo_pixels
from .inputs import load_dem
from .products import blank_outside, centred_on_picture, ortho_grid, picture_area
from .vectors import fill_missing_z
from .xyz import xyz_raster, xyz_uncached

__all__ = ["PhotoResult", "CameraProducts", "Timelapse", "Shared", "shared_for", "process_frame", "FrameTask",
           "fit_job", "blank_photo", "turn_from_previous_frame", "SHARED_XYZ", "DRIFT_TOLERANCE_PX"]

#: file name of the XYZ raster the frames of one shared camera share
SHARED_XYZ = "xyz.tif"
#: a registered frame turned by less than this (pixels) keeps the reference camera's products; its drift is reported
#: all the same. Frames of a camera that never moved registered at 0.05-0.14 px in new light and haze (a trial), and
#: at 0.1 each got a "turned" camera, XYZ raster (8.8 MB) and log line of its own; half a pixel is below what a
#: person can point at, and far below a fitted camera's own error.
DRIFT_TOLERANCE_PX = 0.5

_compute_lock = threading.Lock()  # one z-buffer at a time: it is parallel inside (numba)


def blank_photo(photo: np.ndarray) -> str:
    """Why ``photo`` (H, W[, 3]) shows nothing to georeference (fog, night, a covered lens), or "" when it shows
    something: its contrast at a coarse scale (:func:`~..core.suggest_photo.coarse_contrast`) below
    :data:`~..core.suggest_photo.FEATURELESS_CONTRAST`. Measured on a copy at most 512 px wide: the thumbnail it is
    judged on is 64 px wide anyway, and a full-size frame took 0.2 s.

    >>> blank_photo(np.full((30, 40, 3), 205, np.uint8))[:13]
    'no structure '
    >>> blank_photo(np.random.default_rng(0).integers(0, 255, (30, 40, 3), dtype=np.uint8))
    ''
    """
    import cv2

    photo = np.asarray(photo)
    if photo.shape[1] > 512:
        photo = cv2.resize(photo, (512, max(1, round(photo.shape[0] * 512 / photo.shape[1]))),
                           interpolation=cv2.INTER_AREA)
    contrast = coarse_contrast(photo)
    if contrast >= FEATURELESS_CONTRAST:
        return ""
    return (f"no structure (contrast {contrast:.1f} grey levels at a coarse scale, under "
            f"{FEATURELESS_CONTRAST:.0f}): fog, night or a covered lens?")


@dataclass
class PhotoResult:
    photo: str
    ok: bool
    message: str = ""
    outputs: List[str] = field(default_factory=list)
    rmse_px: float = float("nan")
    canceled: bool = False  # not processed because the user canceled the batch
    drift_px: float = float("nan")  # re-registration: mean image shift from the reference frame
    drift_deg: float = float("nan")  # and the angle of the turn
    #: re-registration's quality: RMS of its matched points' residuals (px) and their number; a frame of a shared
    #: camera has no fit RMSE, and a trial could not tell a well registered turned frame from a doubtful one
    match_px: float = float("nan")
    match_points: int = 0
    index: int = -1  # position in the batch
    seconds: float = float("nan")  # spent processing it (where it ran: a Dask worker's own clock)
    #: the batch log's verdict: ok, uncertain, poor (products written, with that doubt), failed, skipped (a blank
    #: frame: no products) or canceled; "" for a result made without processing (see :meth:`verdict`)
    status: str = ""

    def verdict(self) -> str:
        """:attr:`status`, or what ``ok`` and ``canceled`` say when it was not set."""
        return self.status or ("ok" if self.ok else "canceled" if self.canceled else "failed")


class CameraProducts:
    """What every frame of ``camera`` shares over ``dem``: ``xyz`` (H, W, 3), ``sees_ground``, and the orthophoto
    grid (``resolution`` map units, None: the DEM's, :data:`~.products.AUTO`: the photo's own detail) with its
    ``lookup``."""

    def __init__(self, camera: Camera, dem, resolution: Optional[float] = None, ortho: bool = True,
                 cached: bool = True):
        self.camera = camera
        with _compute_lock:
            self.xyz = xyz_raster(camera, dem) if cached else xyz_uncached(camera, dem)
        self.sees_ground = bool(np.isfinite(self.xyz[..., 2]).any())
        self.grid = self.lookup = None
        if ortho and self.sees_ground:
            self.grid = ortho_grid(camera, dem, resolution)  # of a DEM read by windows: the part it sees
            self.lookup = ortho_lookup(camera, self.grid, self.xyz)

    @classmethod
    def of_lookup(cls, camera: Camera, grid, lookup) -> "CameraProducts":
        """Products of a camera whose orthophoto lookup is known (a turned frame): orthophotos only, no XYZ."""
        products = cls.__new__(cls)
        products.camera, products.grid, products.lookup = camera, grid, lookup
        products.xyz, products.sees_ground = None, True
        return products

    def write_orthophoto(self, path: str, photo: np.ndarray, fit: Optional[dict] = None) -> str:
        """The frame draped, not its print border or caption (:func:`~.products.picture_area`, found per frame:
        an archive's scans each have their own); ``fit``: the row's verdict, in the file's metadata."""
        photo = photo[..., :3] if photo.ndim == 3 and photo.shape[2] > 3 else photo
        image = self.lookup.apply(photo, picture_area(photo))
        return str(write_orthophoto(path, image, self.grid.geotransform, self.grid.crs_wkt, overwrite=True, fit=fit))

    def write_xyz(self, path: str, crs_wkt: str, photo_name: str = "", photo: Optional[np.ndarray] = None,
                  fit: Optional[dict] = None) -> str:
        """The XYZ raster; with ``photo``, nodata over its print border and caption too; ``fit``: the verdict."""
        xyz = self.xyz if photo is None else blank_outside(self.xyz, picture_area(photo))
        return str(write_xyz_raster(path, xyz, crs_wkt, overwrite=True, camera=self.camera, photo_name=photo_name,
                                    fit=fit))


@dataclass(frozen=True)
class Timelapse:
    """What the frames of a batch share, picklable (Dask ships it to workers, which open the DEM themselves).

    ``camera_json``: the shared camera ("" for a table of photos each fitted). ``register``: re-register every
    frame on ``reference`` (a photo path). ``dem_path``/``void_value``: how a worker opens the DEM.
    ``camera_status``/``camera_note``: the shared camera's verdict ("uncertain" for a camera file without one: a
    rough prior is no fitted camera), which every frame of it inherits; ``camera_fit_json``: its fit's figures
    (:func:`~.camera_files.fit_figures`, as JSON: the setup stays hashable), which a turned frame's camera file
    carries with the registration's residual added (:func:`turned_figures`)."""

    out_dir: str
    crs_wkt: str
    camera_json: str = ""
    write_xyz: bool = True
    write_ortho: bool = True
    resolution: Optional[float] = None
    register: bool = False
    reference: str = ""
    near_m: float = 150.0
    dem_path: str = ""
    void_value: Optional[float] = None
    camera_status: str = "ok"
    camera_note: str = ""
    camera_fit_json: str = ""


@dataclass(frozen=True)
class FrameTask:
    """One frame to process: ``index`` in the batch, its ``photo``, output ``stem``, display ``name`` and, for a
    table row, the job itself (prior and points to fit)."""

    index: int
    photo: str
    stem: str
    name: str
    job: object = None


class Shared:
    """The computed side of a :class:`Timelapse`: the DEM, the shared camera's products, the reference frame."""

    def __init__(self, setup: Timelapse, dem=None):
        self.setup = setup
        if dem is None:
            dem, _ = load_dem(setup.dem_path, setup.void_value)
        self.dem = dem
        self.camera = Camera.from_json(setup.camera_json) if setup.camera_json else None
        self.products = None
        self.reference = None
        self.turnable = None  # the orthophoto lookup of any small turn of the camera (re-registration)
        if self.camera is not None:
            self.products = CameraProducts(self.camera, dem, setup.resolution, setup.write_ortho)
            if setup.register and self.products.sees_ground:
                photo = read_photo(setup.reference)
                if (photo.shape[1], photo.shape[0]) != tuple(self.camera.image_size):
                    raise InputError(f"the reference frame {os.path.basename(setup.reference)} is "
                                     f"{photo.shape[1]}x{photo.shape[0]} px but the shared camera is for "
                                     f"{self.camera.width}x{self.camera.height} px")
                self.reference = Reference(photo, self.camera, stable_mask(self.products.xyz, self.camera,
                                                                           setup.near_m))
                if len(self.reference.keypoints) < MIN_INLIERS:  # no frame could ever match enough of them
                    raise InputError(f"the reference frame {os.path.basename(setup.reference)} has too few key "
                                     f"points on the terrain ({len(self.reference.keypoints)}): nothing can be "
                                     f"registered on it; choose another frame with REFERENCE")
                if setup.write_ortho and not setup.write_xyz:  # turned frames need no z-buffer of their own
                    with _compute_lock:
                        self.turnable = turnable_lookup(self.camera, self.products.grid,
                                                        lambda wide: xyz_uncached(wide, dem))


_shared_lock = threading.Lock()
_shared: dict = {}  # per process: {Timelapse: Shared}, the last one only


def shared_for(setup: Timelapse, dem=None) -> Shared:
    """The :class:`Shared` of ``setup``, built once per process (threads wait for the first build)."""
    with _shared_lock:
        found = _shared.get(setup)
        if found is None:
            _shared.clear()
            found = _shared[setup] = Shared(setup, dem)
        return found


def row_status(fit_status: str) -> str:
    """A batch row's status for its fit's verdict: "ok", "uncertain" and "poor" as they are; any other ("refused":
    the fit refused its input, e.g. a registration whose camera left the DEM) is "poor", since its products are
    made of a camera nothing vouches for (a trial's batch logged such a row "ok", its camera 428 m off).

    >>> [row_status(s) for s in ("ok", "uncertain", "poor", "refused")]
    ['ok', 'uncertain', 'poor', 'poor']
    """
    return fit_status if fit_status in ("ok", "uncertain", "poor") else "poor"


def frame_verdict(setup: Timelapse, photo_path: str, registered: bool) -> tuple:
    """(status, note) of a frame of the shared camera: the camera's own, except that an "ok" camera fitted on
    another frame (its fit names the photo, see :func:`~.batch.shared_camera_verdict`) is "uncertain" on a frame
    that was not re-registered: a turn of the mount since does not show in the products (a trial's two frames
    bumped by 0.5 degrees were logged "ok, the shared camera", 32-37 m off on the glacier), as
    :func:`~.camera_files.verdict_on_photo` says for one photo.

    >>> verdict = frame_verdict(Timelapse("out", "", camera_fit_json='{"photo": "f1.jpg", "photo_sha256": "00"}'),
    ...                         "/no/such/f2.jpg", registered=False)
    >>> verdict[0], verdict[1][:45]
    ('uncertain', 'the shared camera was fitted on f1.jpg and th')
    """
    if setup.camera_status != "ok" or registered:
        return setup.camera_status, setup.camera_note
    fit = json.loads(setup.camera_fit_json) if setup.camera_fit_json else {}
    if fitted_on_photo(fit, photo_path) is False:
        return "uncertain", (f"the shared camera was fitted on {fit.get('photo')} and this frame was not "
                             f"re-registered: a turn of the mount since then would not show (re-register every "
                             f"frame to measure it)")
    return setup.camera_status, setup.camera_note


def process_frame(task: FrameTask, shared: Shared, is_canceled: Optional[IsCanceled] = None,
                  progress: Optional[Progress] = None) -> PhotoResult:
    """Read, (re-register,) and write the products of one frame; every problem becomes a failed result.
    ``is_canceled`` (threads on this machine; a Dask task has none): checked inside an automatic registration and
    before the products, so that a cancel stops the frames under way too (a trial's Ctrl+C let two more frames be
    registered and written, 12 s). ``progress``: the fraction of a table row's automatic registration done."""
    is_canceled = is_canceled or never_canceled
    setup = shared.setup
    result = PhotoResult(task.photo, False, index=task.index)
    start = time.perf_counter()
    try:
        photo = read_photo(task.photo)
        blank = blank_photo(photo)
        if blank:  # a frame of fog fitted "uncertain" or draped as the shared camera's was counted processed
            result.status = "skipped"
            raise InputError(f"blank frame, no products written: {blank}")
        size = (photo.shape[1], photo.shape[0])
        camera, products = shared.camera, shared.products
        fit_status, fit_message, verdict = "ok", "", None
        if camera is None:  # a table row: fit this photo's camera
            camera, verdict = fit_job(task.job, size, shared.dem, setup.crs_wkt, photo, is_canceled, progress)
            result.rmse_px, fit_status, fit_message = verdict["rmse_px"], verdict["status"], verdict["message"]
            result.outputs.append(_write_camera(setup, task.stem, camera, verdict, task.photo))  # with its σ
            if verdict.get("prior_kept") and (setup.write_xyz or setup.write_ortho):
                # no camera was found (a trial's indoor photo had its rough camera's XYZ raster and orthophoto
                # written and counted processed): the camera file says so, no products are made of a guess
                result.status = "skipped"
                raise InputError(f"fit {fit_status}: {fit_message} No products written (the camera file keeps the "
                                 f"rough camera and the reasons).")
            if fit_status == "poor" and (setup.write_xyz or setup.write_ortho):
                # probably wrong: a trial's batch wrote the XYZ raster and orthophoto of a registration 93 m off,
                # "poor", and counted the row processed; its camera file is there to look at
                result.status = "skipped"
                raise InputError(f"fit poor: {fit_message} No products written (the camera file keeps the camera "
                                 f"found and the reasons).")
            products = CameraProducts(camera, shared.dem, setup.resolution, setup.write_ortho, cached=False)
        elif tuple(camera.image_size) != size:
            raise InputError(f"photo is {size[0]}x{size[1]} px but the shared camera is for "
                             f"{camera.width}x{camera.height} px")
        own_camera = shared.camera is None
        if shared.reference is not None:
            products, turned = _registered(shared, photo, result)
            if turned:
                camera, own_camera = products.camera, True
            # the shared camera's verdict goes with it: a turned file without one loaded "uncertain" in the dock
            # while the shared camera, 7 px off on that frame, loaded "ok" (a trial). A frame that did not turn gets
            # its file too, for this photo: a trial's phototomap of such a frame with the shared camera's file
            # said "fitted on another photo: its ok does not carry over", as for a frame nobody had checked
            if turned or shared.camera is not None:
                note = (f"the shared camera turned onto this frame ({result.drift_px:.1f} px of drift)" if turned
                        else f"the shared camera, registered on this frame ({result.drift_px:.2f} px of drift)")
                result.outputs.append(_write_camera(setup, task.stem, camera, {
                    "status": setup.camera_status,
                    "message": f"{note}; {setup.camera_note}" if setup.camera_note else note,
                    **turned_figures(setup.camera_fit_json, result.match_px)}, task.photo))
        check_canceled(is_canceled)
        if (setup.write_xyz or setup.write_ortho) and not products.sees_ground:
            raise InputError("the camera sees no cell of the DEM (every pixel is sky): wrong camera or DEM?")
        if shared.camera is not None:  # a frame inherits the doubt of the camera it shares
            fit_status, fit_message = frame_verdict(setup, task.photo, registered=shared.reference is not None)
        # the row's verdict in each product's metadata: an archivist's "uncertain" orthophotos lay beside the good
        # ones, only the log's status column told them apart
        fit = {"status": row_status(fit_status), "message": fit_message,
               "rmse_px": float(result.rmse_px) if np.isfinite(result.rmse_px) else None}
        if setup.write_xyz:
            if own_camera:
                result.outputs.append(products.write_xyz(os.path.join(setup.out_dir, f"{task.stem}_xyz.tif"),
                                                         setup.crs_wkt, task.name, photo, fit))
            else:  # written once before the frames (see batch.run_batch)
                result.outputs.append(os.path.join(setup.out_dir, SHARED_XYZ))
        if setup.write_ortho:
            result.outputs.append(products.write_orthophoto(os.path.join(setup.out_dir, f"{task.stem}_ortho.tif"),
                                                            photo, fit))
        result.ok = True
        result.status = row_status(fit_status)
        # a frame of a shared camera has no fit of its own (its RMSE column stays empty): say whose camera it used
        whose = "the shared camera turned" if own_camera and shared.camera is not None else "the shared camera"
        if shared.camera is not None:
            result.message = f"ok, {whose}" if fit_status == "ok" else f"{fit_status}: {fit_message} ({whose})"
        elif fit_status == "ok":
            result.message = f"ok, fit RMSE {result.rmse_px:.2f} px" + (fit_figures_text(verdict) if verdict else "")
        else:  # products written, but the fitted camera is doubtful ("RMSE nan px" of a camera matched nowhere)
            rmse = f", RMSE {result.rmse_px:.2f} px" if np.isfinite(result.rmse_px) else ""
            result.message = f"fit {fit_status}{rmse}: {fit_message}"
        if np.isfinite(result.drift_px):
            result.message += (f", drift {result.drift_px:.2f} px ({result.drift_deg:.3f} deg), registered on "
                               f"{result.match_points} points within {result.match_px:.2f} px RMS")
        if task.photo and task.stem != os.path.splitext(task.name)[0]:
            result.message += f" (outputs {task.stem}_*)"
    except Exception as exc:  # one photo's failure must not lose the batch
        result.ok = False
        result.canceled = _is_cancel(exc)
        result.status = "canceled" if result.canceled else "skipped" if result.status == "skipped" else "failed"
        if result.canceled:  # the user canceled while this frame was written: its outputs were not put in place
            result.message = "canceled while processing (its outputs not written)"
        else:
            result.message = str(exc) if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
    result.seconds = time.perf_counter() - start
    return result


def _is_cancel(exc: Exception) -> bool:
    from ..outputs.safe_write import OutputCanceled
    from .progress import Canceled

    return isinstance(exc, (Canceled, OutputCanceled))


def _registered(shared: Shared, photo: np.ndarray, result: PhotoResult):
    """(products, turned) of a frame re-registered on the reference; InputError when it cannot be."""
    drift = register(shared.reference, photo)
    if not drift.ok:
        raise InputError(f"not registered on the reference frame: {drift.message}")
    result.drift_px, result.drift_deg = drift.pixels, drift.degrees
    result.match_px, result.match_points = drift.residual_px, drift.inliers
    if drift.pixels < DRIFT_TOLERANCE_PX:
        return shared.products, False
    camera = corrected_camera(shared.camera, drift.rotation)
    if shared.turnable is not None:
        lookup = shared.turnable.turned(camera)
        if lookup is not None:
            return CameraProducts.of_lookup(camera, shared.products.grid, lookup), True
    return CameraProducts(camera, shared.dem, shared.setup.resolution, shared.setup.write_ortho, cached=False), True


def turned_figures(camera_fit_json: str, match_px: float) -> dict:
    """The shared camera's fit figures for a frame it was turned onto: its σ as they are (the turn is known to a
    small part of the shared camera's angular σ), its pixel figures with the turn's registration residual
    ``match_px`` (RMS) added in quadrature, the two errors being independent. A time-lapse trial's turned frames
    carried no figures: loaded in the dock, they showed "ok" with no ± and the fronts drawn on them had no
    xy_error_m.

    >>> turned_figures('{"mode": "paired", "loo_rmse_px": 3.0, "sigma": {"x": 1.0}}', 4.0)
    {'mode': 'paired', 'loo_rmse_px': 5.0, 'sigma': {'x': 1.0}}
    >>> turned_figures("", 0.5)
    {}
    """
    import json

    figures = json.loads(camera_fit_json) if camera_fit_json else {}
    if np.isfinite(match_px):
        for key in PIXEL_FIGURES:
            if key in figures:
                figures[key] = math.hypot(float(figures[key]), float(match_px))
    return figures


def _write_camera(setup: Timelapse, stem: str, camera: Camera, verdict: Optional[dict] = None,
                  photo_path: str = "") -> str:
    path = os.path.join(setup.out_dir, f"{stem}_camera.json")
    write_text(path, camera_json(camera, verdict, photo_path), overwrite=True)
    return path


def headline(camera: Camera, prior: Camera, std: Optional[dict]) -> str:
    """"moved 312 m from the prior; position ± 37 m, heading ± 0.4°. ": what tells the cameras of a batch apart at
    a glance, before the registration's reasoning (a trial's rows were all "uncertain", 6 m or 311 m off, and only
    600-1,400 characters of message said more).

    >>> cam = Camera((100.0, 0.0, 10.0), 0.0, 0.0, 0.0, 60.0, (100, 80))
    >>> headline(cam, cam.with_parameters(x=0.0), {"x": 30.0, "y": 40.0, "heading": 0.25})
    'moved 100 m from the prior; position ± 50 m, heading ± 0.2°. '
    """
    moved = float(np.linalg.norm(np.subtract(camera.position, prior.position)[:2]))
    std = std or {}
    parts = [f"moved {moved:.0f} m from the prior"]
    if "x" in std and "y" in std:
        position = f"position ± {math.hypot(std['x'], std['y']):.0f} m"
        parts.append(position + (f", heading ± {std['heading']:.1f}°" if "heading" in std else ""))
    return "; ".join(parts) + ". "


def fit_job(job, size, dem, crs_wkt: str, photo: Optional[np.ndarray] = None,
            is_canceled: Optional[IsCanceled] = None, progress: Optional[Progress] = None):
    """Fit the camera of a batch job (``prior``, ``points``, ``dem_points`` paths) from its files; returns (camera,
    verdict): the verdict a dict with ``"status"``, ``"message"``, ``"rmse_px"`` (NaN when unknown) and the fit's
    ``"summary"`` (its σ), as :func:`~.camera_files.camera_json` writes it beside the camera. A row without points
    is registered automatically on ``photo`` (the (H, W, 3) picture) from its prior (:func:`~.auto.register`, with
    the job's ``position_sigma_m`` and ``angle_sigma_deg``, None: its defaults): an archive of photos with rough
    cameras only needed autoregister in QGIS's batch dialog, which froze the desktop for 87 s over 7 photos
    (a trial)."""
    reader = getattr(job, "prior_reader", None)
    from_exif = not job.prior and reader is not None
    heading_known = True
    if from_exif:  # as autoregister: an empty prior is the photo's EXIF GPS (a trial made 4 prior files by hand)
        try:
            prior, heading_known = reader(job.photo, size, dem, crs_wkt)
        except ValueError as exc:
            raise InputError(f"no prior camera in this row, and {exc}: give a camera file (Monoplot JSON or "
                             "KML)") from None
    else:
        prior = load_camera(job.prior, size, crs_wkt, rough=True)
    if photo is not None:  # a scanned print's optical axis: its picture's centre, as in the dock
        prior = centred_on_picture(prior, picture_area(photo))
    if not job.points and photo is not None:
        from .auto import DEFAULT_ANGLE_SIGMA_DEG, DEFAULT_POSITION_SIGMA_M, GPS_POSITION_SIGMA_M, register

        position = getattr(job, "position_sigma_m", None) or (GPS_POSITION_SIGMA_M if from_exif else
                                                              DEFAULT_POSITION_SIGMA_M)
        angle = getattr(job, "angle_sigma_deg", None) or DEFAULT_ANGLE_SIGMA_DEG
        done = register(photo, dem, prior, position_sigma_m=position, angle_sigma_deg=angle, is_canceled=is_canceled,
                        heading_known=heading_known, progress=progress)
        camera, r = done.camera, done.result
        camera.crs_wkt = crs_wkt
        rmse = float(r.rmse_px) if r.rmse_px is not None and np.isfinite(r.rmse_px) else float("nan")
        return camera, {"status": r.status, "rmse_px": rmse, "summary": r.summary(),
                        "prior_kept": bool(r.evidence.get("auto_prior_kept")),
                        "message": (f"automatic registration (no points in this row; prior "
                                    f"{'from EXIF GPS, ' if from_exif else ''}σ {position:g} m, {angle:g}°): "
                                    + headline(camera, prior, r.std) + r.message)}
    if not job.points:  # "point file not found: " with no name said nothing
        raise InputError("no points file in this row (the 'points' column is empty)")
    table = read_points_csv(job.points)
    if "uv" not in table:
        raise InputError(f"{os.path.basename(job.points)}: no photo point columns (u_px, v_px)")
    uv = table["uv"]
    if job.dem_points:
        xyz, paired = read_points_csv(job.dem_points).get("xyz"), False
        if xyz is None:
            raise InputError(f"{os.path.basename(job.dem_points)}: no X, Y, Z columns")
    elif "xyz" in table:
        xyz, paired = table["xyz"], True
    else:
        raise InputError(f"{os.path.basename(job.points)}: no map columns (X, Y, Z) and no dem_points file")
    xyz = fill_missing_z(xyz, dem)
    camera, info = fit_points(size, uv, xyz, prior, dem, paired, check=table.get("check") if paired else None)
    camera.crs_wkt = crs_wkt
    if table.get("named"):  # "the pair at photo pixel (662, 262), G6", as fitcamera says (a trial had no name)
        named = [(float(u), float(v), str(name)) for (u, v), name in zip(uv, table["ids"])]
        info["message"] = name_photo_pixels(str(info["message"]), named)
    return camera, {**info, "rmse_px": float(info["rmse_px"])}


def turn_from_previous_frame(previous: np.ndarray, current: np.ndarray, camera: Camera, border_px: int = 8):
    """How far the frame ``current`` of a fixed camera turned from ``previous`` ((H, W, 3) uint8, the same size;
    ``camera``: the previous frame's camera, for its lens), as the batch re-registers a frame
    (:func:`~..core.drift.register`), key points taken anywhere but the picture's border (a dock has no XYZ raster
    of the previous frame at hand). A :class:`~..core.drift.Drift`; never raises for a frame that does not match."""
    from ..core.drift import Drift

    if previous.shape[:2] != current.shape[:2] or tuple(camera.image_size) != (previous.shape[1], previous.shape[0]):
        return Drift(False, np.eye(3), message="the frames or the camera differ in size")
    mask = np.zeros(previous.shape[:2], dtype=np.uint8)
    mask[border_px:-border_px, border_px:-border_px] = 255
    return register(Reference(previous, camera, mask), current)
