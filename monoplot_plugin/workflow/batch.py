"""Many photos at once, without Qt or qgis: a time-lapse folder sharing one camera, or a CSV table of photos each
with its own prior and points. One bad photo is reported and skipped; the others go on.

A job is a list of :class:`PhotoJob`; :func:`run_batch` runs them and returns one :class:`PhotoResult` per photo, in
job order. The frames of one shared camera share what depends only on camera and DEM (computed once, see
:mod:`.frames`), run on every core (threads: decoding, GDAL writes and OpenCV release the GIL), and optionally are
re-registered on a reference frame (``register``). :mod:`.cluster` runs the same frames as Dask tasks.
"""

from __future__ import annotations

import csv
import fnmatch
import json
import os
from dataclasses import dataclass
from typing import Callable, Iterable, List, Optional, Sequence

import numpy as np

from ..core.camera import Camera
from ..outputs.safe_write import write_text
from .batch_threads import Background, threaded
from .camera_files import fit_figures, fitted_on_photo, written_fit, written_verdict
from .files import InputError, read_photo
from .frames import (SHARED_XYZ, FrameTask, PhotoResult, Timelapse, blank_photo, fit_job, process_frame,
                     shared_for)
from .progress import CallerThread, IsCanceled, Progress, SharedBar, never_canceled, no_progress
from .resume import dem_identity, in_task_order, remove_stale, resumable
from .text import cut_at_word

__all__ = ["PhotoJob", "PhotoResult", "folder_jobs", "table_jobs", "run_batch", "output_stems", "fit_shared_camera",
           "fit_job", "write_log", "log_photo_path", "frame_tasks", "fitted_frame", "pick_reference",
           "shared_camera_verdict", "remove_stale", "batch_setup", "other_viewpoints_hint", "IMAGE_PATTERNS"]

IMAGE_PATTERNS = ("*.jpg", "*.jpeg", "*.png", "*.tif", "*.tiff", "*.bmp")

#: ``log(message, error)``: ``error`` True for an error, :data:`WARNING` for a warning, False for information.
Log = Callable[[str, object], None]
WARNING = "warning"

#: The batch log's file name in the output folder (every row's whole message)
LOG_NAME = "batch_log.csv"
#: A row's line in Processing's log is cut to this many characters (the log file keeps all of it)
ROW_LOG_CHARS = 400


@dataclass
class PhotoJob:
    """One photo of a batch: ``camera`` (shared, already fitted) or ``prior`` + point files (fit per photo)."""

    photo: str
    camera: Optional[object] = None
    prior: str = ""
    points: str = ""       # paired GCP CSV (u_px, v_px, X, Y, Z) or photo points CSV
    dem_points: str = ""   # DEM points CSV (unpaired fit)
    label: str = ""        # where the job comes from (table line), for messages about a row without a photo
    # one σ of the prior's position (m) and heading / pitch (degrees) for a row registered automatically; None: the
    # automatic registration's defaults
    position_sigma_m: Optional[float] = None
    angle_sigma_deg: Optional[float] = None
    # for a row with no prior file: (photo path, (width, height), dem, DEM CRS WKT) -> (rough camera, whether its
    # heading is known), e.g. from the photo's EXIF GPS (Processing gives ``adapters.exif.exif_rough_camera``:
    # module-level, so it reaches a Dask worker)
    prior_reader: Optional[Callable] = None


def folder_jobs(folder: str, camera, patterns: str = "", exclude: Sequence[str] = ()) -> List[PhotoJob]:
    """Jobs for every image in ``folder`` (sorted by name), all sharing ``camera``.

    ``patterns``: semicolon-separated globs (default: common image extensions); ``exclude``: files that are not
    photos though they match (the DEM: a trial kept its dem.tif beside the frames, and the batch failed on it as a
    photo)."""
    if not folder or not os.path.isdir(folder):
        raise InputError(f"photo folder not found: {folder}")
    globs = [p.strip() for p in patterns.split(";") if p.strip()] or list(IMAGE_PATTERNS)
    left_out = {os.path.normcase(os.path.realpath(p)) for p in exclude if p}
    names = sorted(n for n in os.listdir(folder)
                   if os.path.isfile(os.path.join(folder, n)) and any(fnmatch.fnmatch(n.lower(), g.lower())
                                                                      for g in globs)
                   and os.path.normcase(os.path.realpath(os.path.join(folder, n))) not in left_out)
    if not names:
        raise InputError(f"no photos matching {';'.join(globs)} in {folder}")
    return [PhotoJob(os.path.join(folder, n), camera=camera) for n in names]


def table_jobs(path: str) -> List[PhotoJob]:
    """Jobs from a CSV table with columns ``photo, prior, points`` and optionally ``dem_points``,
    ``position_sigma`` (m) and ``angle_sigma`` (degrees: the prior's uncertainty, for a row without points,
    registered automatically); relative paths are relative to the table's folder. ``points`` is a paired GCP CSV,
    or photo points when ``dem_points`` is given (unpaired)."""
    if not path or not os.path.isfile(path):
        raise InputError(f"batch table not found: {path}")
    base = os.path.dirname(os.path.abspath(path))
    import io

    from .inputs import read_text

    with io.StringIO(read_text(path), newline="") as fh:  # UTF-8 with or without BOM, UTF-16
        sample = fh.read(4096)
        fh.seek(0)
        try:  # spreadsheets in many locales save CSV with ';' (or tabs)
            dialect = csv.Sniffer().sniff(sample.splitlines()[0] if sample else "", delimiters=",;\t")
        except csv.Error:
            dialect = csv.excel
        reader = csv.DictReader(fh, dialect=dialect)
        rows = []  # (line number in the file, row), blank rows left out
        for row in reader:
            if any(isinstance(v, str) and v.strip() for v in row.values()):
                rows.append((reader.line_num, row))
        header = [k for k in (reader.fieldnames or []) if k]
    if not rows:
        raise InputError(f"{os.path.basename(path)}: no photos listed")
    lowered = {k.strip().lower(): k for k in header}
    missing = [c for c in ("photo", "prior", "points") if c not in lowered]
    if missing:
        raise InputError(f"{os.path.basename(path)}: missing column(s) {', '.join(missing)} (expected photo, prior, "
                         f"points[, dem_points]; found {', '.join(header) or 'no header'})")

    def resolve(row, column):
        value = (row.get(lowered.get(column, ""), "") or "").strip()
        return os.path.join(base, value) if value and not os.path.isabs(value) else value

    def sigma(row, line, column):
        value = (row.get(lowered.get(column, ""), "") or "").strip()
        if not value:
            return None
        try:
            number = float(value.replace(",", "."))  # a decimal comma of a spreadsheet saved with ';'
        except ValueError:
            number = float("nan")
        if not (np.isfinite(number) and number > 0):
            raise InputError(f"{os.path.basename(path)} line {line}: {column} '{value}' is not a positive number "
                             f"(leave it empty for the default)")
        return number

    return [PhotoJob(resolve(r, "photo"), prior=resolve(r, "prior"), points=resolve(r, "points"),
                     dem_points=resolve(r, "dem_points"), label=f"{os.path.basename(path)} line {line}",
                     position_sigma_m=sigma(r, line, "position_sigma"), angle_sigma_deg=sigma(r, line, "angle_sigma"))
            for line, r in rows]


def run_batch(jobs: List[PhotoJob], dem, crs_wkt: str, out_dir: str, write_xyz: bool = True,
              write_ortho: bool = True, resolution: Optional[float] = None,
              log: Log = lambda message, error: None,
              progress: Progress = no_progress, is_canceled: IsCanceled = never_canceled,
              workers: Optional[int] = None, register: bool = False, reference: str = "",
              camera_verdict: tuple = ("ok", ""), resume: bool = False) -> List[PhotoResult]:
    """Run every job; never raises for one photo's problem.

    Outputs per photo ``<stem>_camera.json`` (fitted jobs, and every re-registered frame), ``<stem>_xyz.tif``,
    ``<stem>_ortho.tif``; jobs sharing one camera share one ``xyz.tif`` (the XYZ raster depends only on the camera
    and the DEM). ``log(message, is_error)`` receives one line per photo; ``progress(fraction, message)`` and
    ``is_canceled()`` follow the workflow's protocol; on a cancel the remaining photos are reported as not processed.

    ``workers``: frames processed at once (threads; default: the number of cores). ``register``: match every frame
    of a shared camera to ``reference`` (a photo; default the first usable job's, see :func:`pick_reference`) and
    make its products with the corrected camera; the drift is in the log and the results. All jobs share one camera,
    or none does (a table). ``camera_verdict``: (status, note[, fit figures]) of the shared camera: a status other
    than "ok" is every frame's, the figures go with the cameras of turned frames (see
    :func:`shared_camera_verdict`). ``resume``: the photos an earlier run in ``out_dir``
    finished with the same inputs and settings keep their products and results (see :mod:`.resume`).
    """
    os.makedirs(out_dir, exist_ok=True)
    stems = output_stems(jobs)
    tasks = frame_tasks(jobs, stems, log)
    try:
        setup = batch_setup(jobs, crs_wkt, out_dir, write_xyz, write_ortho, resolution, register, reference,
                            log=log, camera_verdict=camera_verdict)
        journal, keys, earlier = resumable(tasks, setup, dem_identity(dem), resume, log)
        say_replaced(out_dir, jobs, [t for t in tasks if t.index not in earlier], write_xyz, write_ortho, log)
        shared = shared_for(setup, dem) if len(earlier) < len(tasks) else None  # None: nothing left to do
    except InputError as exc:  # no reference frame can serve: nothing can be registered
        results = [PhotoResult(t.photo, False, f"{exc}", index=t.index) for t in tasks]
        log(f"every photo FAILED: {exc}", True)
        return results
    writer = None
    # the shared XYZ raster is written while the frames run
    if setup.camera_json and write_xyz and shared is not None and shared.products.sees_ground:
        writer = Background(shared.products.write_xyz, os.path.join(out_dir, SHARED_XYZ), crs_wkt, "", None,
                            {"status": setup.camera_status, "message": setup.camera_note})
    relay = CallerThread(progress)  # the frames' threads report through this thread (qgis_process)
    bar = SharedBar(relay, len(tasks), len(earlier))

    def work(task: FrameTask) -> PhotoResult:  # a frame under way stops on a cancel too
        own = None
        if not setup.camera_json:  # a row's registration takes seconds: which is under way, and how far (trials'
            # bars sat at 0 % for 17-75 s with no word, and for 216 s with a row done at 89 s); its stages unsaid:
            bar.item(task.index, 0.0, f"processing {task.name}")  # Processing's log prints every progress text
            own = lambda fraction, message="": bar.item(task.index, fraction)  # noqa: E731
        result = None
        try:
            result = process_frame(task, shared, is_canceled, own)
            journal.append(task, keys[task.index], result)  # at once: a run killed later resumes from here
            return result
        finally:
            bar.finished(task.index, counted=result is not None and not result.canceled)

    fresh = threaded([t for t in tasks if t.index not in earlier], work, workers, is_canceled, relay.flush)
    results = collect(in_task_order(tasks, earlier, fresh), tasks, log, bar.forward)
    relay.flush()  # what the frames' threads said after the last wait
    if writer is not None and writer.wait() is not None:
        shared_xyz_failed(results, os.path.join(out_dir, SHARED_XYZ), writer.error, log)
    remove_stale(out_dir, tasks, results, bool(setup.camera_json), log)
    return results


def shared_xyz_failed(results: List[PhotoResult], path: str, error: Exception, log: Log) -> None:
    """The shared ``xyz.tif`` could not be written: said once, and taken off every frame's outputs."""
    log(f"{SHARED_XYZ} FAILED: {error}", True)
    for r in results:
        if path in r.outputs:
            r.outputs.remove(path)
            r.message += f"; {SHARED_XYZ} not written"


def batch_setup(jobs: List[PhotoJob], crs_wkt: str, out_dir: str, write_xyz: bool = True, write_ortho: bool = True,
                resolution: Optional[float] = None, register: bool = False, reference: str = "",
                dem_path: str = "", void_value: Optional[float] = None, log: Log = lambda message, error: None,
                camera_verdict: tuple = ("ok", "")) -> Timelapse:
    """The :class:`~.frames.Timelapse` of a batch: the shared camera of its jobs (all or none), the reference
    (:func:`pick_reference`; an InputError when the one named cannot serve)."""
    cameras = {j.camera.to_json() for j in jobs if j.camera is not None}
    if len(cameras) > 1 or (cameras and any(j.camera is None for j in jobs)):
        raise ValueError("the jobs of one batch share one camera, or each is fitted")
    camera_json = cameras.pop() if cameras else ""
    if register and not camera_json:
        raise InputError("re-registration needs the frames' shared camera (time-lapse mode)")
    if register:
        photos = [j.photo for j in jobs if j.photo]
        fitted = fitted_frame(photos, camera_verdict[2] if len(camera_verdict) > 2 else {})
        if not reference and fitted and not blank_photo(read_photo(fitted)):
            # the frame the camera was fitted on: the others are turned relative to it (the first frame, if the
            # mount moved between it and the fitted one, would pass its turn on to every frame)
            log(f"Reference frame: {os.path.basename(fitted)}, the frame the shared camera was fitted on", False)
            reference = fitted
        else:
            reference = pick_reference(photos, Camera.from_json(camera_json), reference, log)
    return Timelapse(out_dir, crs_wkt, camera_json, write_xyz, write_ortho, resolution, register,
                     reference if register else "", dem_path=dem_path, void_value=void_value,
                     camera_status=camera_verdict[0] or "ok", camera_note=camera_verdict[1],
                     camera_fit_json=json.dumps(camera_verdict[2], sort_keys=True) if len(camera_verdict) > 2
                     and camera_verdict[2] else "")


def pick_reference(photos: List[str], camera, named: str = "", log: Log = lambda message, error: None) -> str:
    """The reference frame of a re-registration: ``named`` (the user's) if it can be read and is not blank, else an
    InputError that names it; without one, the first of ``photos`` that can be read, has the camera's size and is
    not blank (:func:`~.frames.blank_photo`), said in the log with the frames passed over.

    A reference of fog registered itself "ok" and failed every good frame, and an unreadable first frame failed the
    whole folder (a trial): a reference without texture can register nothing."""
    if named:
        try:
            why = blank_photo(read_photo(named))
        except InputError as exc:
            raise InputError(f"the reference frame {os.path.basename(named)} cannot be used: {exc}; choose another "
                             f"frame with REFERENCE") from exc
        if why:
            raise InputError(f"the reference frame {os.path.basename(named)} is blank, nothing can be registered on "
                             f"it: {why} Choose another frame with REFERENCE")
        return named
    for path in photos:
        name = os.path.basename(path)
        try:
            photo = read_photo(path)
        except InputError as exc:
            log(f"{name} is not the reference frame: {exc}", False)
            continue
        why = blank_photo(photo)
        if not why and (photo.shape[1], photo.shape[0]) != tuple(camera.image_size):
            why = (f"it is {photo.shape[1]}x{photo.shape[0]} px, the shared camera {camera.width}x{camera.height} "
                   f"px")
        if why:
            log(f"{name} is not the reference frame: {why}", False)
            continue
        log(f"Reference frame: {name} (the first usable frame; REFERENCE picks another)", False)
        return path
    raise InputError("no frame can be the reference frame (every one is unreadable, blank or of another size than "
                     "the shared camera)")


def shared_camera_verdict(path: str, log: Log = lambda message, error: None) -> tuple:
    """(status, note, fit figures) of a time-lapse's shared camera file for :func:`run_batch`: the verdict of the
    fit that wrote it (:func:`~.camera_files.written_verdict`) and its figures (:func:`~.camera_files.fit_figures`,
    {} without); a camera without one (a rough prior, a KML) is "uncertain: camera
    not fitted", said once in the log. A rough prior taken as the fitted camera gave every frame "ok" and products
    225 m off (a trial)."""
    status, message = written_verdict(path)
    if status in ("ok", "uncertain", "poor"):
        fit = written_fit(path)
        # with the photo it was fitted on, if the file says (see fitted_frame, frames.frame_verdict)
        figures = {**fit_figures(fit), **{k: fit[k] for k in ("photo", "photo_sha256") if fit.get(k)}}
        return status, f"the camera's fit was {status}" if status != "ok" else "", figures
    log(f"The camera {os.path.basename(path)} carries no fit verdict: it is not a fitted camera (a rough prior?). "
        "Its frames are marked \"uncertain: camera not fitted\"; fit it on one frame (Fit camera, or POINTS here) "
        "for products you can trust.", True)
    return "uncertain", "camera not fitted", {}


def fitted_frame(photos: List[str], figures: dict) -> str:
    """The one of ``photos`` a shared camera was fitted on: its file name and bytes those the camera's fit records
    (``figures``' "photo" and "photo_sha256", see :func:`shared_camera_verdict`); "" when none is, or the fit does
    not say. Only the photos of that name are read.

    >>> fitted_frame(["/no/such/a.jpg"], {"photo": "a.jpg", "photo_sha256": "0" * 64}), fitted_frame(["a.jpg"], {})
    ('', '')
    """
    name = str(figures.get("photo") or "")
    return next((path for path in photos if name and os.path.basename(path) == name
                 and fitted_on_photo(figures, path)), "")


def frame_tasks(jobs: List[PhotoJob], stems: List[str], log: Log) -> List[FrameTask]:
    """One :class:`~.frames.FrameTask` per job (a job without camera carries itself, to be fitted)."""
    tasks = []
    for index, (job, stem) in enumerate(zip(jobs, stems)):
        if job.photo and stem != os.path.splitext(os.path.basename(job.photo))[0]:
            log(f"{job.photo}: another photo of the batch has the same name; its outputs are named {stem}_*", False)
        name = os.path.basename(job.photo) or job.label or f"job {index + 1}"
        tasks.append(FrameTask(index, job.photo, stem, name, None if job.camera is not None else job))
    return tasks


def collect(results: Iterable[Optional[PhotoResult]], tasks: List[FrameTask], log: Log,
            progress: Progress) -> List[PhotoResult]:
    """The results in task order (None: canceled before processing), logged one line each, with progress."""
    out: List[PhotoResult] = []
    total, ended = len(tasks), 0
    for task, result in zip(tasks, results):
        if result is None:
            result = PhotoResult(task.photo, False, "canceled before processing", canceled=True, index=task.index)
        else:
            log_result(log, task, total, result)
        out.append(result)
        if not result.canceled:  # a canceled frame is no progress (a trial's bar jumped to 100 % on Cancel)
            ended += 1
            # no message: the log line said which frame ended (Processing's dialog logs every progress text, and a
            # time-lapse trial's log repeated each frame's name on a line of its own)
            progress(ended / max(1, total), "")
    canceled = sum(r.canceled for r in out)
    if canceled:
        log(f"canceled: {canceled} photos not processed", True)
    else:
        progress(1.0, "")
    return out


def log_result(log: Log, task: FrameTask, total: int, result: PhotoResult) -> None:
    """One line of the batch log for a frame: its message, "canceled" (the user canceled while it was processed,
    not a failure), "skipped" (a blank frame) or "FAILED, skipped"."""
    head = f"[{task.index + 1}/{total}] {task.name}"
    if result.ok:
        # at its verdict's level: a trial's "uncertain" rows were plain information lines among the "ok" ones; cut,
        # since a registration's reasons ran to 700-1,800 characters a row (the log file keeps all of it)
        message = cut_at_word(result.message, ROW_LOG_CHARS)
        if message != result.message:
            message += f" (all of it in {LOG_NAME})"
        log(f"{head}: {message}", {"uncertain": WARNING, "poor": True}.get(result.status, False))
    elif result.canceled:
        log(f"{head}: canceled: {result.message}", True)
    elif result.status == "skipped":
        log(f"{head}: skipped: {result.message}", True)
    else:
        log(f"{head}: FAILED, skipped: {result.message}", True)


def output_stems(jobs: List[PhotoJob]) -> List[str]:
    """The name stem of each job's outputs: the photo's name without extension, made unique within the batch
    (case-insensitively, for Windows and macOS file systems) by ``_2``, ``_3``... in job order, so that
    ``frame.jpg`` and ``frame.png``, or two ``frame.jpg`` of different folders, never write the same files.

    >>> output_stems([PhotoJob("a/frame.jpg"), PhotoJob("b/frame.jpg"), PhotoJob("Frame.png"), PhotoJob("x.jpg")])
    ['frame', 'frame_2', 'Frame_3', 'x']
    """
    plain = [os.path.splitext(os.path.basename(j.photo))[0] or "photo" for j in jobs]
    taken = {p.lower() for p in plain}
    seen, stems = set(), []
    for stem in plain:
        unique, n = stem, 1
        while unique.lower() in seen or (n > 1 and unique.lower() in taken):  # nor another photo's own name
            n += 1
            unique = f"{stem}_{n}"
        seen.add(unique.lower())
        stems.append(unique)
    return stems


def say_replaced(out_dir: str, jobs: List[PhotoJob], todo: List[FrameTask], write_xyz: bool, write_ortho: bool,
                 log: Log) -> None:
    """Log that files of an earlier run will be replaced by those of the tasks ``todo`` (of ``jobs``)."""
    names = planned_outputs([jobs[t.index] for t in todo], [t.stem for t in todo], write_xyz, write_ortho)
    existing = [n for n in names if os.path.exists(os.path.join(out_dir, n))]
    if existing:
        log(f"{len(existing)} file(s) of an earlier run in {out_dir} will be replaced or removed as the frames are "
            f"processed (e.g. {existing[0]})", False)


def planned_outputs(jobs: List[PhotoJob], stems: List[str], write_xyz: bool, write_ortho: bool) -> List[str]:
    """File names :func:`run_batch` writes into the output folder."""
    names = []
    for job, stem in zip(jobs, stems):
        if job.camera is None:
            names.append(f"{stem}_camera.json")
        if write_xyz:
            names.append("xyz.tif" if job.camera is not None else f"{stem}_xyz.tif")
        if write_ortho:
            names.append(f"{stem}_ortho.tif")
    return sorted(set(names))


def fit_shared_camera(folder_photos: List[str], prior: str, points: str, dem_points: str, dem, crs_wkt: str,
                      log: Log = lambda message, error: None):
    """Fit one camera for a whole time-lapse on its first readable photo (the frames share the camera).

    Returns (camera, photo used, the fit's verdict: see :func:`~.frames.fit_job`). Raises InputError when no photo
    can be fitted."""
    problems = []
    for path in folder_photos:
        try:
            photo = read_photo(path)
        except InputError as exc:
            problems.append(str(exc))
            log(f"{os.path.basename(path)}: skipped for the shared fit: {exc}", True)
            continue
        job = PhotoJob(path, prior=prior, points=points, dem_points=dem_points)
        camera, verdict = fit_job(job, (photo.shape[1], photo.shape[0]), dem, crs_wkt)
        if verdict["status"] != "ok":
            log(f"{os.path.basename(path)}: the shared camera's fit is {verdict['status']}: {verdict['message']}",
                True)
        return camera, path, verdict
    raise InputError("no photo of the folder could be read for the shared fit: " + "; ".join(problems[:3]))


def other_viewpoints_hint(results: List[PhotoResult]) -> str:
    """A time-lapse batch whose photos mostly differ in size from the shared camera, or turned too far to be
    registered on the reference frame, is probably of photos from different viewpoints: say which mode fits them
    (a trial kept the dialog's default mode for a folder of archive photos and read only "photo is 1200x800 px but
    the shared camera is for 1200x900 px"); "" otherwise.

    >>> bad = PhotoResult("a.jpg", False, "not registered on the reference frame: 2 of 46 matches agree")
    >>> other_viewpoints_hint([bad, bad, PhotoResult("c.jpg", True)]).startswith("2 of 3 photos")
    True
    >>> other_viewpoints_hint([bad, PhotoResult("c.jpg", True), PhotoResult("d.jpg", True)])
    ''
    """
    tried = [r for r in results if not r.canceled]
    misfits = sum(not r.ok and ("but the shared camera is for" in r.message
                                or r.message.startswith("not registered on the reference frame")) for r in tried)
    if misfits < 2 or misfits * 2 < len(tried):
        return ""
    return (f"{misfits} of {len(tried)} photos differ in size from the shared camera or could not be registered on "
            f"the reference frame: a time-lapse folder is one camera that stays put. Photos taken from different "
            f"places need the CSV table mode (one row per photo with its rough camera and, if any, its points).")


def write_log(path: str, results: List[PhotoResult], folder: str = "") -> None:
    """CSV summary: photo (relative to ``folder``, the batch's photo folder or table's, when inside it, else
    absolute: see :func:`log_photo_path`), status (:meth:`~.frames.PhotoResult.verdict`: a fit "uncertain" was
    logged "ok"), message, rmse_px, drift_px, drift_deg, match_px, match_points (re-registered frames), seconds
    (spent on the photo, where it ran; a trial had to time its registrations one by one), outputs
    (semicolon-separated)."""
    import io

    def number(value, digits):
        return "" if not np.isfinite(value) else f"{value:.{digits}f}"

    text = io.StringIO(newline="")
    writer = csv.writer(text)
    writer.writerow(["photo", "status", "message", "rmse_px", "drift_px", "drift_deg", "match_px", "match_points",
                     "seconds", "outputs"])
    for r in results:
        writer.writerow([log_photo_path(r.photo, folder), r.verdict(), r.message, number(r.rmse_px, 3),
                         number(r.drift_px, 3), number(r.drift_deg, 4), number(r.match_px, 3),
                         r.match_points or "", number(r.seconds, 2), ";".join(r.outputs)])
    write_text(path, text.getvalue(), overwrite=True)


def log_photo_path(photo: str, folder: str = "") -> str:
    """``photo`` as the batch log names it: relative to ``folder`` when inside it, else absolute (the table mode
    wrote absolute paths and the time-lapse mode relative ones).

    >>> import os
    >>> log_photo_path("/data/frames/a.jpg", "/data/frames") == os.path.join("a.jpg")
    True
    >>> log_photo_path("/data/other/a.jpg", "/data/frames") == os.path.abspath("/data/other/a.jpg")
    True
    """
    if not photo:
        return photo
    path = os.path.abspath(photo)
    if not folder:
        return path
    try:
        relative = os.path.relpath(path, os.path.abspath(folder))
    except ValueError:  # another drive (Windows)
        return path
    return path if relative.split(os.sep)[0] == os.pardir else relative
