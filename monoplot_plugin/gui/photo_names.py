"""The name a photo goes by in a project: its layer group, its layers, its exported files' stems and the project
entry of the features drawn on it all take it. Two photos of the same file name (``1890/aletsch.jpg`` and
``2023/aletsch.jpg``, or any two ``photo.jpg``) must not share it: a trial's modern photo took over the 1890
print's drawn glacier front, traced it through the modern camera 745 m away, silently, and its XYZ export was
proposed over the print's.

The first photo to draw or export under a name owns it (the project remembers its path, relative when the project
stores relative paths, and absolute beside it); another photo of that name goes by ``stem (its folder).suffix``.
A name claimed before the project had a file could only be stored absolute: :func:`restate_owners`, called as the
project is written, stores it relative to the file (a trial moved a project folder with its photos: the photo came
back as "drone (scene)", and none of its drawn features showed)."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from qgis.core import QgsProject

__all__ = ["photo_label", "claim_photo_label", "restate_owners"]

_SCOPE = "monoplot"
_FOLDER = "/outputs/photo_names"  # the owners' entries
_ABSOLUTE = "_abs"  # suffix of the entry keeping an owner's absolute path


def _owner_key(name: str) -> str:
    """Project entry key of the path owning ``name`` (entry keys are XML names: a hash, not the name)."""
    return f"{_FOLDER}/n_" + hashlib.sha1(name.encode("utf-8")).hexdigest()[:16]


def _norm(p: str) -> str:
    return os.path.normcase(os.path.abspath(p))


def _same_file(project: QgsProject, key: str, stored: str, path: str) -> bool:
    """Whether the owner stored under ``key`` (as the project stores paths: ``stored``) is the file ``path``, found
    relative to the project file or at its absolute path (a project moved with its photos, or not)."""
    absolute = project.readEntry(_SCOPE, key + _ABSOLUTE, "")[0]
    return _norm(project.readPath(stored)) == _norm(path) or bool(absolute) and _norm(absolute) == _norm(path)


def _candidates(path: str):
    p = Path(path)
    yield p.name
    yield f"{p.stem} ({p.parent.name or 'photo'}){p.suffix}"
    digest = hashlib.sha1(os.path.abspath(path).encode("utf-8")).hexdigest()[:8]
    yield f"{p.stem} ({digest}){p.suffix}"


def photo_label(project: QgsProject, path: str) -> str:
    """The name ``path`` goes by in ``project``: its file name unless another photo owns that name.

    Only reads the project (see :func:`claim_photo_label`)."""
    if not path:
        return "photo"
    last = ""
    for name in _candidates(path):
        owner = project.readEntry(_SCOPE, _owner_key(name), "")[0]
        if not owner or _same_file(project, _owner_key(name), owner, path):
            return name
        last = name
    return last


def claim_photo_label(project: QgsProject, path: str) -> str:
    """:func:`photo_label`, and the project remembers that ``path`` owns it (once, when something is drawn or
    exported under it)."""
    name = photo_label(project, path)
    if path and not project.readEntry(_SCOPE, _owner_key(name), "")[0]:
        project.writeEntry(_SCOPE, _owner_key(name), project.writePath(os.path.abspath(path)))
        project.writeEntry(_SCOPE, _owner_key(name) + _ABSOLUTE, os.path.abspath(path))
    return name


def restate_owners(project: QgsProject) -> None:
    """Store every owner's path as the project stores paths now, from its absolute path (as the project is written:
    relative to its file when it stores relative paths). An owner known only by a relative path is left as it is."""
    for entry in project.entryList(_SCOPE, _FOLDER):
        if entry.endswith(_ABSOLUTE):
            continue
        key = f"{_FOLDER}/{entry}"
        stored = project.readEntry(_SCOPE, key, "")[0]
        absolute = project.readEntry(_SCOPE, key + _ABSOLUTE, "")[0]
        if not absolute and os.path.isabs(stored):  # claimed before the absolute path was kept beside it
            absolute = stored
            project.writeEntry(_SCOPE, key + _ABSOLUTE, absolute)
        if absolute:
            project.writeEntry(_SCOPE, key, project.writePath(absolute))
