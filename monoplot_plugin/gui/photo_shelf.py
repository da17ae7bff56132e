"""Work on a photo put aside when another photo is chosen, and brought back when it is chosen again.

Repeat photography puts two photos of one place (an 1890 print, a modern photo from the same spot) in one project;
a trial switched to the modern photo and back, and the print's 11 pairs and fitted camera were gone ("Not fitted
yet", Undo greyed out). The dock holds one photo's work at a time; the others' wait in the project, one entry per
photo, keyed by the name it goes by in the project (:mod:`.photo_names`)."""

from __future__ import annotations

import hashlib
from typing import Optional

from qgis.core import QgsProject

from ..state import ACCEPTED, CHECK, PHOTO, ProjectState
from .photo_names import claim_photo_label, photo_label

__all__ = ["put_aside", "take_back", "has_work", "waiting"]

_SCOPE = "monoplot"


def _key(name: str) -> str:
    """Entry key of the work on the photo that goes by ``name`` in the project (:mod:`.photo_names`: the name
    knows its photo by the path the project wrote, relative to a saved project; a trial's work put aside before
    the first Save was keyed by the absolute path and not found after reopening)."""
    return "/shelf/p_" + hashlib.sha1(name.encode("utf-8")).hexdigest()[:16]


def has_work(state: ProjectState) -> bool:
    """The photo carries work worth keeping: decided photo points, pairs or a fitted camera."""
    counts = state.counts()[PHOTO]
    return bool(counts.get(ACCEPTED, 0) or counts.get(CHECK, 0) or state.pairs or state.fitted)


def put_aside(project: QgsProject, state: ProjectState) -> bool:
    """Keep ``state`` (its photo's work) in ``project`` for when its photo is chosen again; True when kept."""
    if not state.photo_path:
        return False
    if not has_work(state):
        project.removeEntry(_SCOPE, _key(photo_label(project, state.photo_path)))
        return False
    return bool(project.writeEntry(_SCOPE, _key(claim_photo_label(project, state.photo_path)), state.to_json()))


def take_back(project: QgsProject, path: str) -> Optional[ProjectState]:
    """The work put aside for the photo at ``path`` (taken out of the project), or None."""
    key = _key(photo_label(project, path))
    text = project.readEntry(_SCOPE, key, "")[0]
    if not text:
        return None
    project.removeEntry(_SCOPE, key)
    try:
        return ProjectState.from_json(text)
    except ValueError:  # an unknown format (a later version's): nothing to bring back
        return None


def waiting(project: QgsProject, path: str) -> bool:
    """Work put aside for the photo at ``path`` waits in ``project``."""
    return bool(project.readEntry(_SCOPE, _key(photo_label(project, path)), "")[0])
