"""Monoplot state in the QGIS project file, plus an autosave file so that a crash loses no curation work.

* Project: ``QgsProject.writeEntry("monoplot", "/state", json)``; saved with the .qgz when the user saves.
* Autosave: ``<project>.monoplot-autosave.json`` next to a saved project, else
  ``<profile>/monoplot/autosave-unsaved-project.json``. On reopening, the autosave wins when it is newer than the
  project file (the user curated points, then QGIS crashed before saving). Other project entries (the features
  drawn on the photo) go to ``<project>.monoplot-autosave-entries.json`` the same way (:func:`autosave_entry`).
* A project closed by QGIS (not a crash) discards its autosave files (:func:`discard_autosave`): QGIS asked whether
  to save, and "Discard" must not come back the next time the project is opened.

The debounced autosave (:func:`autosave`) costs the main thread a snapshot only (the small fields encoded, the
points referenced); the points are encoded and the file written in a worker thread, the newest snapshot last.
The project entry is written when the project is (``writeProject``) and by :func:`save`.
"""

from __future__ import annotations

import json
import os
import threading
import time
from typing import Callable, Optional, Tuple

from qgis.core import QgsApplication, QgsMessageLog, QgsProject, Qgis

from ..state import ProjectState

__all__ = ["SCOPE", "KEY", "store_in_project", "save", "autosave", "load", "load_with_source", "autosave_path",
           "read_autosave", "autosave_entry", "autosaved_entry", "discard_autosave", "unsaved_work_left"]

SCOPE, KEY = "monoplot", "/state"


def autosave_path(project: QgsProject) -> str:
    """Where the autosave of ``project`` goes (the folder exists)."""
    name = project.fileName()
    return _beside(name) if name else _unsaved_path()


def _unsaved_path() -> str:
    """The state autosave of a project never saved: in the profile."""
    folder = os.path.join(QgsApplication.qgisSettingsDirPath(), "monoplot")
    os.makedirs(folder, exist_ok=True)
    return os.path.join(folder, "autosave-unsaved-project.json")


#: when this QGIS session loaded the plugin: an autosave of a never-saved project written since is this session's
SESSION_START = time.time()


def unsaved_work_left(project: QgsProject) -> bool:
    """True when ``project`` was never saved and holds no Monoplot state, and the autosave of a never-saved
    project is there, written before this session began: a session that ended without QGIS closing its project (a
    crash) left that work. One written since is this session's own (another dock's, another QGIS's), not taken: a
    test's dock took an earlier test's and stopped at "keep the points?"."""
    path = _unsaved_path()
    return not project.fileName() and not project.readEntry(SCOPE, KEY, "")[1] and os.path.exists(path) and \
        os.path.getmtime(path) < SESSION_START


def _beside(project_file: str) -> str:
    """The state autosave of the project saved as ``project_file``: beside it."""
    return os.path.splitext(project_file)[0] + ".monoplot-autosave.json"


def _entries_path(state_path: str) -> str:
    return state_path[:-len(".json")] + "-entries.json"


def _newer_than_project(project: QgsProject, path: str) -> bool:
    """True when ``path`` was written after ``project``'s file was last saved (1 s of slack for coarse clocks)."""
    name = project.fileName()
    return bool(name) and os.path.exists(path) and os.path.exists(name) and \
        os.path.getmtime(path) > os.path.getmtime(name) + 1


def autosave_entry(project: QgsProject, key: str, text: str) -> None:
    """Keep the project entry ``key`` (a small JSON text, e.g. the features drawn on one photo) in the entries
    autosave file too, so that a crash before Save does not lose it (atomic replace)."""
    path = _entries_path(autosave_path(project))
    entries = _read_entries(path)
    if entries.get(key) == text:
        return
    entries[key] = text
    _write(path, lambda: json.dumps(entries), _next_ticket())


def autosaved_entry(project: QgsProject, key: str) -> Optional[str]:
    """The entry ``key`` from the entries autosave when that file is newer than the project file, else None. For a
    project never saved: from the one a session before this one left (a crash: the rule of
    :func:`unsaved_work_left`), since its points came back and the features drawn on the photo did not."""
    path = _entries_path(autosave_path(project))
    if not project.fileName():
        left = os.path.exists(path) and os.path.getmtime(path) < SESSION_START
        return _read_entries(path).get(key) if left else None
    return _read_entries(path).get(key) if _newer_than_project(project, path) else None


def _read_entries(path: str) -> dict:
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
        return data if isinstance(data, dict) else {}
    except (OSError, ValueError):
        return {}


def discard_autosave(project_file: str) -> None:
    """Remove the autosave files of the project saved as ``project_file`` (QGIS closed it: saved, or the person
    chose not to), "" for a project never saved (its work is in the project QGIS asked about, or discarded)."""
    state_path = _beside(project_file) if project_file else _unsaved_path()
    with _LOCK:
        for path in (state_path, _entries_path(state_path)):
            # a snapshot taken before this (a worker still writing) must not bring the file back
            _TICKETS["written"][path] = _TICKETS["issued"] + 1
            try:
                os.remove(path)
            except OSError:
                pass


def _for_project(project: QgsProject, state: ProjectState) -> str:
    """JSON for the project file: the photo path written the way the project writes its layer paths (relative to
    the project when it is saved with relative paths, the default), so a moved project folder keeps its photo."""
    return state.snapshot(photo_path=project.writePath(state.photo_path) if state.photo_path else "")()


def store_in_project(project: QgsProject, state: ProjectState) -> str:
    """Store ``state`` in the project's properties (marks the project modified when it changes it); returns the
    JSON text. A blank state is not written into a project that has no Monoplot entry: opening the dock and
    unloading the plugin made an empty project "modified", and quitting QGIS then asked to save it."""
    text = _for_project(project, state)
    text_before, found = project.readEntry(SCOPE, KEY, "")
    if not found and state.is_blank():
        return text
    if text != text_before:
        project.writeEntry(SCOPE, KEY, text)
    return text


def save(project: QgsProject, state: ProjectState) -> None:
    """Store ``state`` in the project and in the autosave file now (atomic replace; absolute paths)."""
    store_in_project(project, state)
    _write(autosave_path(project), state.snapshot(), _next_ticket())


_LOCK = threading.Lock()
_TICKETS = {"issued": 0, "written": {}}  # the last snapshot number written, per autosave file


def _next_ticket() -> int:
    with _LOCK:
        _TICKETS["issued"] += 1
        return _TICKETS["issued"]


def _write(path: str, text: Callable[[], str], ticket: int) -> None:
    """Write the snapshot ``text()`` to ``path`` unless a newer snapshot was written there already."""
    with _LOCK:  # one writer at a time: an older snapshot never replaces a newer one
        if _TICKETS["written"].get(path, 0) > ticket:
            return
        try:
            tmp = path + ".tmp"
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(text())
            os.replace(tmp, path)
            _TICKETS["written"][path] = ticket
        except OSError as exc:  # read-only folder: the project entry still holds the state
            QgsMessageLog.logMessage(f"Monoplot autosave failed: {exc}", "Monoplot", Qgis.MessageLevel.Warning)


def autosave(project: QgsProject, state: ProjectState) -> threading.Thread:
    """Write the autosave file of ``state`` as it is now, in a worker thread (returned, already started): the main
    thread only takes the snapshot."""
    worker = threading.Thread(target=_write, args=(autosave_path(project), state.snapshot(), _next_ticket()),
                              name="Monoplot autosave", daemon=True)
    worker.start()
    return worker


def read_autosave(path: str) -> Optional[ProjectState]:
    try:
        with open(path, encoding="utf-8") as fh:
            return ProjectState.from_json(fh.read())
    except (OSError, ValueError, TypeError, KeyError):
        return None


def load(project: QgsProject) -> Optional[ProjectState]:
    """The state stored in ``project``, or a newer autosave of it, or None (see :func:`load_with_source`)."""
    return load_with_source(project)[0]


def load_with_source(project: QgsProject) -> Tuple[Optional[ProjectState], str]:
    """(state, "project" | "autosave" | "unsaved autosave" | "") — the autosave wins when it is newer than the project
    file; a never-saved project with no state takes the autosave a crash left (:func:`unsaved_work_left`)."""
    text, found = project.readEntry(SCOPE, KEY, "")
    state, source = None, ""
    if found and text:
        try:
            state, source = ProjectState.from_json(text), "project"
            if state.photo_path:
                state.photo_path = project.readPath(state.photo_path)
        except (ValueError, TypeError, KeyError, json.JSONDecodeError) as exc:
            QgsMessageLog.logMessage(f"Monoplot state in the project is unreadable: {exc}", "Monoplot",
                                     Qgis.MessageLevel.Warning)
    if state is None and unsaved_work_left(project):
        # a never-saved project's work after a crash: nothing else holds it (a flood trial's 8 pairs and fit sat
        # in this file, the dock opened empty, and choosing the photo again overwrote it)
        left = read_autosave(_unsaved_path())
        if left is not None and left.to_dict() != ProjectState().to_dict():
            state, source = left, "unsaved autosave"
    elif project.fileName():
        path = autosave_path(project)
        if _newer_than_project(project, path):
            newer = read_autosave(path)
            # an autosave written after the save with the same content (a pending autosave that fired after
            # Save) is not "work done after the project was last saved"
            if newer is not None and (state is None or newer.to_dict() != state.to_dict()):
                state, source = newer, "autosave"
    return state, source
