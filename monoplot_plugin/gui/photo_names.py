"""The name a photo goes by in a project: its layer group, its layers, its exported files' stems and the project
entry of the features drawn on it all take it. Two photos of the same file name (``1890/aletsch.jpg`` and
``2023/aletsch.jpg``, or any two ``photo.jpg``) must not share it: a trial's modern photo took over the 1890
print's drawn glacier front, traced it through the modern camera 745 m away, silently, and its XYZ export was
proposed over the print's.

The first photo to draw or export under a name owns it (the project remembers its path, relative when the project
stores relative paths); another photo of that name goes by ``stem (its folder).suffix``."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from qgis.core import QgsProject

__all__ = ["photo_label", "claim_photo_label"]

_SCOPE = "monoplot"


def _owner_key(name: str) -> str:
    """Project entry key of the path owning ``name`` (entry keys are XML names: a hash, not the name)."""
    return "/outputs/photo_names/n_" + hashlib.sha1(name.encode("utf-8")).hexdigest()[:16]


def _same_file(project: QgsProject, stored: str, path: str) -> bool:
    def norm(p: str) -> str:
        return os.path.normcase(os.path.abspath(p))

    return norm(project.readPath(stored)) == norm(path)


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
        if not owner or _same_file(project, owner, path):
            return name
        last = name
    return last


def claim_photo_label(project: QgsProject, path: str) -> str:
    """:func:`photo_label`, and the project remembers that ``path`` owns it (once, when something is drawn or
    exported under it)."""
    name = photo_label(project, path)
    if path and not project.readEntry(_SCOPE, _owner_key(name), "")[0]:
        project.writeEntry(_SCOPE, _owner_key(name), project.writePath(os.path.abspath(path)))
    return name
