"""The name a photo goes by in a project (:mod:`monoplot_plugin.gui.photo_names`), through a real project that is
written, moved and read again with the dock listening."""

from __future__ import annotations

import shutil

import cv2
import numpy as np
from qgis.core import QgsProject

from monoplot_plugin.gui.photo_names import claim_photo_label, photo_label


def test_a_name_claimed_before_the_first_save_follows_the_project_when_its_folder_moves(dock, tmp_path):
    """A trial drew on a photo of a new project, then saved it: the name's owner had been stored as an absolute path
    (the project had no file yet). The project folder, moved with its photos, came back with the photo renamed
    "drone (scene)", none of its drawn features shown, new drawings under another name."""
    first = tmp_path / "first"
    (first / "scene").mkdir(parents=True)
    photo = first / "scene" / "drone.jpg"
    cv2.imwrite(str(photo), np.full((40, 60, 3), 128, np.uint8))
    project = QgsProject.instance()
    project.clear()
    assert not project.fileName()
    assert claim_photo_label(project, str(photo)) == "drone.jpg"  # drawn on before the first save
    assert project.write(str(first / "survey.qgz"))
    moved = tmp_path / "moved"
    shutil.copytree(first, moved)
    shutil.rmtree(first)
    project.clear()
    assert project.read(str(moved / "survey.qgz"))
    assert photo_label(project, str(moved / "scene" / "drone.jpg")) == "drone.jpg"
    # another photo of the same name is still told apart
    (moved / "other").mkdir()
    assert photo_label(project, str(moved / "other" / "drone.jpg")) == "drone (other).jpg"
    project.clear()
