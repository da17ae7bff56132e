"""Monoplot state in the QGIS project file, plus an autosave file so that a crash loses no curation work.

* Project: ``QgsProject.writeEntry("monoplot", "/state", json)``; saved with the .qgz when the user saves.
* Autosave: ``<project>.monoplot-autosave.json`` next to a saved project, else
  ``<profile>/monoplot/autosave-unsaved-project.json``. On reopening, the autosave wins when it is newer than the
  project file (the user curated points, then QGIS crashed before saving).

The debounced autosave (:func:`autosave`) costs the main thread a snapshot only (the small fields encoded, the
points referenced); the points are encoded and the file written in a worker thread, the newest snapshot last.
The project entry is written when the project is (``writeProject``) and by :func:`save`.
"""

from __future__ import annotations

import json
import os
import threading
from typing import Callable, Optional, Tuple

from qgis.core import QgsApplication, QgsMessageLog, QgsProject, Qgis

from ..state import ProjectState

__all__ = ["SCOPE", "KEY", "store_in_project", "save", "autosave", "load", "load_with_source", "autosave_path",
           "read_autosave"]

SCOPE, KEY = "monoplot", "/state"


def autosave_path(project: QgsProject) -> str:
    """Where the autosave of ``project`` goes (the folder exists)."""
    name = project.fileName()
    if name:
        base, _ = os.path.splitext(name)
        return base + ".monoplot-autosave.json"
    folder = os.path.join(QgsApplication.qgisSettingsDirPath(), "monoplot")
    os.makedirs(folder, exist_ok=True)
    return os.path.join(folder, "autosave-unsaved-project.json")


def _for_project(project: QgsProject, state: ProjectState) -> str:
    """JSON for the project file: the photo path written the way the project writes its layer paths (relative to
    the project when it is saved with relative paths, the default), so a moved project folder keeps its photo."""
    return state.snapshot(photo_path=project.writePath(state.photo_path) if state.photo_path else "")()


def store_in_project(project: QgsProject, state: ProjectState) -> str:
    """Store ``state`` in the project's properties (marks the project modified); returns the JSON text."""
    text = _for_project(project, state)
    text_before, _ = project.readEntry(SCOPE, KEY, "")
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
    """(state, "project" | "autosave" | "") — the autosave wins when it is newer than the project file."""
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
    name = project.fileName()
    if name:
        path = autosave_path(project)
        if os.path.exists(path) and os.path.exists(name) and os.path.getmtime(path) > os.path.getmtime(name) + 1:
            newer = read_autosave(path)
            # an autosave written after the save with the same content (a pending autosave that fired after
            # Save) is not "work done after the project was last saved"
            if newer is not None and (state is None or newer.to_dict() != state.to_dict()):
                state, source = newer, "autosave"
    return state, source
