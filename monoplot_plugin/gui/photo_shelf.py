"""Work on a photo put aside when another photo is chosen, and brought back when it is chosen again.

Repeat photography puts two photos of one place (an 1890 print, a modern photo from the same spot) in one project;
a trial switched to the modern photo and back, and the print's 11 pairs and fitted camera were gone ("Not fitted
yet", Undo greyed out). The dock holds one photo's work at a time; the others' wait in the project, one entry per
photo file (keyed by its path as the project writes it: relative when the project stores relative paths)."""

from __future__ import annotations

import hashlib
import os
from typing import Optional

from qgis.core import QgsProject

from ..state import ACCEPTED, CHECK, PHOTO, ProjectState

__all__ = ["put_aside", "take_back", "has_work", "waiting"]

_SCOPE = "monoplot"


def _keys(project: QgsProject, path: str) -> list:
    """Entry keys of ``path``'s work: by its path as the project writes it (relative to a saved project, so that
    a project moved with its photos finds it) and by its absolute path (what an unsaved project writes: a trial
    put work aside before the first Save, and the project reopened did not find it under the relative path)."""
    absolute = os.path.abspath(path)
    names = dict.fromkeys([project.writePath(absolute), absolute])
    return ["/shelf/p_" + hashlib.sha1(name.encode("utf-8")).hexdigest()[:16] for name in names]


def has_work(state: ProjectState) -> bool:
    """The photo carries work worth keeping: decided photo points, pairs or a fitted camera."""
    counts = state.counts()[PHOTO]
    return bool(counts.get(ACCEPTED, 0) or counts.get(CHECK, 0) or state.pairs or state.fitted)


def put_aside(project: QgsProject, state: ProjectState) -> bool:
    """Keep ``state`` (its photo's work) in ``project`` for when its photo is chosen again; True when kept."""
    if not state.photo_path:
        return False
    keys = _keys(project, state.photo_path)
    for key in keys:
        project.removeEntry(_SCOPE, key)
    if not has_work(state):
        return False
    return bool(project.writeEntry(_SCOPE, keys[0], state.to_json()))


def take_back(project: QgsProject, path: str) -> Optional[ProjectState]:
    """The work put aside for the photo at ``path`` (taken out of the project), or None."""
    texts = [project.readEntry(_SCOPE, key, "")[0] for key in _keys(project, path)]
    text = next((t for t in texts if t), "")
    if not text:
        return None
    for key in _keys(project, path):
        project.removeEntry(_SCOPE, key)
    try:
        return ProjectState.from_json(text)
    except ValueError:  # an unknown format (a later version's): nothing to bring back
        return None


def waiting(project: QgsProject, path: str) -> bool:
    """Work put aside for the photo at ``path`` waits in ``project``."""
    return any(project.readEntry(_SCOPE, key, "")[0] for key in _keys(project, path))
