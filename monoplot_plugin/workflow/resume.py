"""A batch's earlier runs into the same output folder: resuming one, and its files this run replaces or removes.

The photos an earlier run finished with the same inputs and settings are not processed again (``resume``).

Every photo a batch processes appends one line to :data:`JOURNAL` in the output folder as soon as it ends: its output
stem, a key of everything its products depend on (:func:`frame_key`: the photo and its prior and point files as
path, size and modification time, the shared camera, the batch's settings, the DEM, the plugin's version) and its
result. A rerun with ``resume`` takes a photo's result from the journal when its last line there has the same key,
ended with products, and those products are all still in the folder; the others are processed. The journal is
appended to as the photos end, so a run that was killed (QGIS closed, the machine rebooted) resumes too, not only
one that was canceled.

What an earlier run wrote and this one does not make again, where it would contradict the log, is removed
(:func:`remove_stale`).

>>> import tempfile
>>> from .frames import FrameTask, PhotoResult, Timelapse
>>> folder = tempfile.mkdtemp()
>>> task = FrameTask(0, os.path.join(folder, "a.jpg"), "a", "a.jpg")
>>> key = frame_key(task, Timelapse(folder, "", camera_json="{}"), "dem")
>>> open(os.path.join(folder, "a_ortho.tif"), "w").close()
>>> Journal(folder).append(task, key, PhotoResult(task.photo, True, "written", [os.path.join(folder, "a_ortho.tif")]))
>>> earlier_results([task], {0: key}, Journal(folder))[0].message
'done by an earlier run (resumed): written'
>>> earlier_results([task], {0: "another key"}, Journal(folder))
{}
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import threading
from typing import Callable, Dict, Iterable, Iterator, List, Optional

import numpy as np

from .. import plugin_version
from .frames import FrameTask, PhotoResult, Timelapse
from ..outputs.xyz_style import style_path

__all__ = ["JOURNAL", "Journal", "frame_key", "dem_identity", "earlier_results", "in_task_order", "resumable",
           "remove_stale"]

Log = Callable[[str, bool], None]

#: the journal's name in the output folder
JOURNAL = "batch_journal.jsonl"
#: what the message of a photo taken from the journal starts with
RESUMED = "done by an earlier run (resumed)"


def _stamp(path: str) -> list:
    """[absolute path, size, modification time in ns] of a file; [path] when there is none (a changed file: another
    stamp)."""
    if not path:
        return []
    path = os.path.abspath(path)
    try:
        status = os.stat(path)
    except OSError:
        return [path]
    return [path, status.st_size, status.st_mtime_ns]


def dem_identity(dem=None, dem_path: str = "", void_value: Optional[float] = None) -> str:
    """What a DEM is, for :func:`frame_key`: its file's stamp (a cluster's workers open it by path), else a digest of
    its heights, grid and CRS (about 0.1 s per 100 MB); a DEM too large to be read whole (its preview in memory):
    its file's ``key``."""
    if dem_path:
        return json.dumps([_stamp(dem_path), void_value])
    if getattr(dem, "source", None) is not None:
        return json.dumps([list(dem.key), dem.level, dem.crs_wkt], default=str)
    digest = hashlib.sha1(np.ascontiguousarray(dem.elevation).view(np.uint8))
    digest.update(json.dumps([list(dem.geotransform), dem.crs_wkt, str(dem.elevation.dtype),
                              list(dem.elevation.shape)]).encode())
    return digest.hexdigest()


def frame_key(task: FrameTask, setup: Timelapse, dem_id: str) -> str:
    """A digest of what ``task``'s products depend on: its photo; for a table row its prior, point files and
    uncertainties (or that its prior comes from the photo's EXIF); the batch's settings (``setup`` but its output
    folder); the DEM (:func:`dem_identity`); the plugin's version."""
    job = task.job
    row = None
    if job is not None:
        reader = getattr(job, "prior_reader", None)
        row = [_stamp(job.prior), _stamp(job.points), _stamp(job.dem_points), job.position_sigma_m,
               job.angle_sigma_deg, getattr(reader, "__qualname__", None) if reader else None]
    settings = dataclasses.asdict(setup)
    settings.pop("out_dir")
    settings["reference"] = _stamp(settings["reference"])
    text = json.dumps([plugin_version(), _stamp(task.photo), task.stem, row, settings, dem_id], sort_keys=True,
                      default=str)
    return hashlib.sha1(text.encode()).hexdigest()


class Journal:
    """The output folder's :data:`JOURNAL`: one JSON line per photo processed (the last line of a stem counts)."""

    def __init__(self, out_dir: str):
        self.path = os.path.join(out_dir, JOURNAL)
        self._lock = threading.Lock()  # the frames end on several threads
        self._line_start = False  # known: the file ends with a whole line

    def append(self, task: FrameTask, key: str, result: PhotoResult) -> None:
        """Record ``result`` (not a canceled one: that photo was not processed to its end)."""
        if result.canceled:
            return
        line = {"stem": task.stem, "key": key, "ok": bool(result.ok), "status": result.verdict(),
                "message": result.message, "outputs": [os.path.basename(p) for p in result.outputs],
                "rmse_px": _number(result.rmse_px), "drift_px": _number(result.drift_px),
                "drift_deg": _number(result.drift_deg), "match_px": _number(result.match_px),
                "match_points": int(result.match_points), "seconds": _number(result.seconds)}
        with self._lock, open(self.path, "a+b") as journal:
            if not self._line_start:  # a run killed while writing left half a line: this one starts on its own
                end = journal.seek(0, os.SEEK_END)
                if end:
                    journal.seek(end - 1)
                    if journal.read(1) != b"\n":
                        journal.write(b"\n")
                self._line_start = True
            journal.write((json.dumps(line) + "\n").encode("utf-8"))
            journal.flush()

    def last_lines(self) -> Dict[str, dict]:
        """The last line of each stem; a line cut short (a run killed while writing it) is passed over."""
        lines: Dict[str, dict] = {}
        try:
            with open(self.path, encoding="utf-8") as journal:
                for text in journal:
                    try:
                        line = json.loads(text)
                        lines[line["stem"]] = line
                    except (ValueError, KeyError, TypeError):
                        continue
        except OSError:
            pass
        return lines


def _number(value: float) -> Optional[float]:
    return float(value) if np.isfinite(value) else None


def earlier_results(tasks: List[FrameTask], keys: Dict[int, str], journal: Journal) -> Dict[int, PhotoResult]:
    """The results, by task index, of the photos an earlier run finished with products under the same key, whose
    products are all still in the folder."""
    folder = os.path.dirname(journal.path)
    lines = journal.last_lines()
    found: Dict[int, PhotoResult] = {}
    for task in tasks:
        line = lines.get(task.stem)
        if not line or line.get("key") != keys[task.index] or not line.get("ok") or not line.get("outputs"):
            continue
        outputs = [os.path.join(folder, name) for name in line["outputs"]]
        if not all(os.path.isfile(p) for p in outputs):
            continue

        def number(name):
            value = line.get(name)
            return float("nan") if value is None else float(value)

        found[task.index] = PhotoResult(task.photo, True, f"{RESUMED}: {line.get('message', '')}", outputs,
                                        rmse_px=number("rmse_px"), drift_px=number("drift_px"),
                                        drift_deg=number("drift_deg"), match_px=number("match_px"),
                                        match_points=int(line.get("match_points") or 0), index=task.index,
                                        seconds=number("seconds"), status=line.get("status", ""))
    return found


def in_task_order(tasks: List[FrameTask], earlier: Dict[int, PhotoResult],
                  fresh: Iterable[Optional[PhotoResult]]) -> Iterator[Optional[PhotoResult]]:
    """Every task's result in task order: the earlier run's where there is one, else the next of ``fresh`` (the
    results of the other tasks, in their order)."""
    fresh = iter(fresh)
    for task in tasks:
        yield earlier[task.index] if task.index in earlier else next(fresh)


def resumable(tasks: List[FrameTask], setup: Timelapse, dem_id: str, resume: bool, log: Log):
    """(journal, key of each task by index, results of the tasks an earlier run did: only if ``resume``)."""
    journal = Journal(setup.out_dir)
    keys = {t.index: frame_key(t, setup, dem_id) for t in tasks}
    earlier = earlier_results(tasks, keys, journal) if resume else {}
    if earlier:
        log(f"{len(earlier)} of {len(tasks)} photos were done by an earlier run with the same inputs and settings: "
            f"their products are kept, not made again", False)
    return journal, keys, earlier


def remove_stale(out_dir: str, tasks: List[FrameTask], results: List[PhotoResult], shared_camera: bool,
                 log: Log) -> List[str]:
    """Remove the products of an earlier run this run did not rewrite, where they would contradict the log: every
    ``<stem>_camera.json``, ``_xyz.tif``, ``_ortho.tif`` of a frame that failed or was skipped, and the own camera
    and XYZ raster of a frame that now has the shared camera's (it turned in an earlier run). Only these names of
    the batch's own frames; a canceled frame's of an earlier run are left (it was not processed), and its message
    names them, while what this run wrote of it before the cancel goes. Returns the paths removed.

    A frame that failed on a rerun kept its orthophoto of the earlier run beside a log saying "failed" (a trial)."""
    removed, kept = [], []
    of_failed: List[str] = []  # a failed or skipped frame's, named first: what contradicts the log most

    partial: List[str] = []

    def remove(path: str, into: List[str]) -> None:
        try:
            os.remove(path)
            into.append(path)
        except OSError as exc:
            kept.append(f"{os.path.basename(path)} ({exc})")
            return
        if path.endswith("_xyz.tif"):  # its QGIS style file goes with it (a convenience, not a product)
            try:
                style_path(path).unlink()
            except OSError:
                pass

    for task, result in zip(tasks, results):
        own = [os.path.join(out_dir, task.stem + suffix) for suffix in ("_camera.json", "_xyz.tif", "_ortho.tif")]
        written = {os.path.normcase(os.path.abspath(p)) for p in result.outputs}
        if result.canceled:
            # what this run wrote of the frame before the cancel is half of its products: it goes (a trial found a
            # turned frame's camera file without its rasters, named as an earlier run's); the log says which files
            # are an earlier run's (a trial read them as this run's)
            for path in own:
                if os.path.normcase(os.path.abspath(path)) in written and os.path.isfile(path):
                    remove(path, partial)
            result.outputs = []
            earlier = [os.path.basename(p) for p in own if os.path.isfile(p)]
            if earlier:
                result.message += "; files of an earlier run left as they were: " + ", ".join(earlier)
            continue
        suffixes = ("_camera.json", "_xyz.tif", "_ortho.tif") if not result.ok else \
            ("_camera.json", "_xyz.tif") if shared_camera else ()
        for suffix in suffixes:
            path = os.path.join(out_dir, task.stem + suffix)
            if os.path.normcase(os.path.abspath(path)) in written or not os.path.isfile(path):
                continue
            remove(path, removed if result.ok else of_failed)
    removed[:0] = of_failed
    if partial:
        log(f"{len(partial)} file(s) of frames canceled while they were written removed (a frame's products come "
            f"whole or not at all): {', '.join(os.path.basename(p) for p in partial)}", False)
    if removed:
        names = ", ".join(os.path.basename(p) for p in removed[:5]) + (", ..." if len(removed) > 5 else "")
        log(f"{len(removed)} file(s) of an earlier run removed, not made again by this run (frames failed, skipped "
            f"or now with the shared camera): {names}", False)
    if kept:
        log(f"{len(kept)} file(s) of an earlier run could not be removed and are NOT of this run: "
            + "; ".join(kept[:5]), True)
    return removed
