"""Many photos at once, without qgis: a time-lapse folder sharing one camera, or a CSV table of photos each with
its own prior and points. One bad photo is reported and skipped; the others go on.

A job is a list of :class:`PhotoJob`; :func:`run_batch` runs them and returns one :class:`PhotoResult` per photo.
"""

from __future__ import annotations

import csv
import fnmatch
import os
from dataclasses import dataclass, field
from typing import Callable, List, Optional

import numpy as np

from ..outputs.safe_write import write_text
from ..workflow.progress import IsCanceled, Progress, never_canceled, no_progress
from . import pipeline
from .inputs import InputError, load_camera, read_photo, read_points_csv

IMAGE_PATTERNS = ("*.jpg", "*.jpeg", "*.png", "*.tif", "*.tiff", "*.bmp")


@dataclass
class PhotoJob:
    """One photo of a batch: ``camera`` (shared, already fitted) or ``prior`` + point files (fit per photo)."""

    photo: str
    camera: Optional[object] = None
    prior: str = ""
    points: str = ""       # paired GCP CSV (u_px, v_px, X, Y, Z) or photo points CSV
    dem_points: str = ""   # DEM points CSV (unpaired fit)
    label: str = ""        # where the job comes from (table line), for messages about a row without a photo


@dataclass
class PhotoResult:
    photo: str
    ok: bool
    message: str = ""
    outputs: List[str] = field(default_factory=list)
    rmse_px: float = float("nan")
    canceled: bool = False  # not processed because the user canceled the batch


def folder_jobs(folder: str, camera, patterns: str = "") -> List[PhotoJob]:
    """Jobs for every image in ``folder`` (sorted by name), all sharing ``camera``.

    ``patterns``: semicolon-separated globs (default: common image extensions)."""
    if not folder or not os.path.isdir(folder):
        raise InputError(f"photo folder not found: {folder}")
    globs = [p.strip() for p in patterns.split(";") if p.strip()] or list(IMAGE_PATTERNS)
    names = sorted(n for n in os.listdir(folder)
                   if os.path.isfile(os.path.join(folder, n)) and any(fnmatch.fnmatch(n.lower(), g.lower())
                                                                      for g in globs))
    if not names:
        raise InputError(f"no photos matching {';'.join(globs)} in {folder}")
    return [PhotoJob(os.path.join(folder, n), camera=camera) for n in names]


def table_jobs(path: str) -> List[PhotoJob]:
    """Jobs from a CSV table with columns ``photo, prior, points`` and optionally ``dem_points``; relative paths
    are relative to the table's folder. ``points`` is a paired GCP CSV, or photo points when ``dem_points`` is
    given (unpaired)."""
    if not path or not os.path.isfile(path):
        raise InputError(f"batch table not found: {path}")
    base = os.path.dirname(os.path.abspath(path))
    import io

    from ..workflow.inputs import read_text

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

    return [PhotoJob(resolve(r, "photo"), prior=resolve(r, "prior"), points=resolve(r, "points"),
                     dem_points=resolve(r, "dem_points"), label=f"{os.path.basename(path)} line {line}")
            for line, r in rows]


def run_batch(jobs: List[PhotoJob], dem, crs_wkt: str, out_dir: str, write_xyz: bool = True,
              write_ortho: bool = True, resolution: Optional[float] = None,
              log: Callable[[str, bool], None] = lambda message, error: None,
              progress: Progress = no_progress, is_canceled: IsCanceled = never_canceled) -> List[PhotoResult]:
    """Run every job; never raises for one photo's problem.

    Outputs per photo ``<stem>_camera.json`` (fitted jobs), ``<stem>_xyz.tif``, ``<stem>_ortho.tif``; jobs sharing
    one camera share one ``xyz.tif`` (the XYZ raster depends only on the camera and the DEM). ``log(message,
    is_error)`` receives one line per photo; ``progress(fraction, message)`` and ``is_canceled()`` follow the
    workflow's protocol; on a cancel the remaining photos are reported as not processed.
    """
    os.makedirs(out_dir, exist_ok=True)
    stems = output_stems(jobs)
    for job, stem in zip(jobs, stems):
        if job.photo and stem != os.path.splitext(os.path.basename(job.photo))[0]:
            log(f"{job.photo}: another photo of the batch has the same name; its outputs are named {stem}_*", False)
    existing = [n for n in _planned_outputs(jobs, stems, write_xyz, write_ortho)
                if os.path.exists(os.path.join(out_dir, n))]
    if existing:
        log(f"{len(existing)} file(s) of an earlier run in {out_dir} are replaced (e.g. {existing[0]})", False)
    results: List[PhotoResult] = []
    shared_xyz_written = set()
    for index, job in enumerate(jobs):
        name = os.path.basename(job.photo) or job.label or f"job {index + 1}"
        stem = stems[index]
        progress(index / max(1, len(jobs)), name)
        if is_canceled():
            results.extend(PhotoResult(j.photo, False, "canceled before processing", canceled=True)
                           for j in jobs[index:])
            log(f"canceled: {len(jobs) - index} photos not processed", True)
            break
        result = PhotoResult(job.photo, False)
        try:
            photo = read_photo(job.photo)
            size = (photo.shape[1], photo.shape[0])
            camera = job.camera
            fit_status, fit_message = "ok", ""
            if camera is None:
                camera, result.rmse_px, fit_status, fit_message = _fit_job(job, size, dem, crs_wkt)
                camera_path = os.path.join(out_dir, f"{stem}_camera.json")
                write_text(camera_path, camera.to_json(), overwrite=True)
                result.outputs.append(camera_path)
            elif tuple(camera.image_size) != size:
                raise InputError(f"photo is {size[0]}x{size[1]} px but the shared camera is for "
                                 f"{camera.width}x{camera.height} px")
            if (write_xyz or write_ortho) and not np.isfinite(pipeline.xyz_raster(camera, dem)[..., 2]).any():
                raise InputError("the camera sees no cell of the DEM (every pixel is sky): wrong camera or DEM?")
            if write_xyz:
                if job.camera is not None:
                    xyz_path = os.path.join(out_dir, "xyz.tif")
                    if camera.to_json() not in shared_xyz_written:
                        pipeline.write_xyz(xyz_path, camera, dem, crs_wkt)
                        shared_xyz_written.add(camera.to_json())
                else:
                    xyz_path = os.path.join(out_dir, f"{stem}_xyz.tif")
                    pipeline.write_xyz(xyz_path, camera, dem, crs_wkt, name)
                result.outputs.append(xyz_path)
            if write_ortho:
                ortho_path = os.path.join(out_dir, f"{stem}_ortho.tif")
                pipeline.orthophoto(ortho_path, photo, camera, dem, resolution)
                result.outputs.append(ortho_path)
            result.ok = True
            result.message = "ok" if np.isnan(result.rmse_px) else f"ok, fit RMSE {result.rmse_px:.2f} px"
            if fit_status != "ok":  # products written, but the fitted camera is doubtful
                result.message = f"fit {fit_status}, RMSE {result.rmse_px:.2f} px: {fit_message}"
            if job.photo and stem != os.path.splitext(name)[0]:
                result.message += f" (outputs {stem}_*)"
            log(f"[{index + 1}/{len(jobs)}] {name}: {result.message}", False)
        except Exception as exc:  # one photo's failure must not lose the batch
            result.message = str(exc) if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
            log(f"[{index + 1}/{len(jobs)}] {name}: FAILED, skipped: {result.message}", True)
        results.append(result)
    progress(1.0, "")
    return results


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


def _planned_outputs(jobs: List[PhotoJob], stems: List[str], write_xyz: bool, write_ortho: bool) -> List[str]:
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
                      log: Callable[[str, bool], None] = lambda message, error: None):
    """Fit one camera for a whole time-lapse on its first readable photo (the frames share the camera).

    Returns (camera, photo used, rmse px). Raises InputError when no photo can be fitted."""
    problems = []
    for path in folder_photos:
        try:
            photo = read_photo(path)
        except InputError as exc:
            problems.append(str(exc))
            log(f"{os.path.basename(path)}: skipped for the shared fit: {exc}", True)
            continue
        job = PhotoJob(path, prior=prior, points=points, dem_points=dem_points)
        camera, rmse, status, message = _fit_job(job, (photo.shape[1], photo.shape[0]), dem, crs_wkt)
        if status != "ok":
            log(f"{os.path.basename(path)}: the shared camera's fit is {status}: {message}", True)
        return camera, path, rmse
    raise InputError("no photo of the folder could be read for the shared fit: " + "; ".join(problems[:3]))


def _fit_job(job: PhotoJob, size, dem, crs_wkt: str):
    """Fit one job's camera from its prior and point files; returns (camera, rmse in px, fit status, message)."""
    prior = load_camera(job.prior, size, crs_wkt)
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
    xyz = pipeline.fill_missing_z(xyz, dem)
    camera, info = pipeline.fit(size, uv, xyz, prior, dem, paired)
    camera.crs_wkt = crs_wkt
    return camera, float(info["rmse_px"]), info["status"], info["message"]


def write_log(path: str, results: List[PhotoResult]) -> None:
    """CSV summary: photo, status (ok, failed or canceled), message, rmse_px, outputs (semicolon-separated)."""
    import io

    text = io.StringIO(newline="")
    writer = csv.writer(text)
    writer.writerow(["photo", "status", "message", "rmse_px", "outputs"])
    for r in results:
        writer.writerow([r.photo, "ok" if r.ok else "canceled" if r.canceled else "failed", r.message,
                         "" if np.isnan(r.rmse_px) else f"{r.rmse_px:.3f}", ";".join(r.outputs)])
    write_text(path, text.getvalue(), overwrite=True)
