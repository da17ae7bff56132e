"""Choosing another photo when the current one carries work: ask before it is discarded.

A desktop trial set the Photo box to a grey copy of the same print: its 16 accepted photo points, 6 pairs, 5 check
points and the fitted camera were gone at once, Undo greyed out, no question asked. Now the dock asks, and for a
picture of the same size offers to keep the points (the same picture in another file).
"""

from __future__ import annotations

from typing import Optional

from qgis.PyQt.QtCore import QCoreApplication
from qgis.PyQt.QtGui import QImageIOHandler, QImageReader
from qgis.PyQt.QtWidgets import QMessageBox

from ..state import ACCEPTED, CHECK, PHOTO

KEEP, AFRESH = "keep", "afresh"


def tr(text: str) -> str:
    return QCoreApplication.translate("Monoplot", text)


def work_on_photo(controller) -> str:
    """What would be lost with the current photo, in words ("16 photo points, 6 pairs, the fitted camera"), or ""
    when nothing (no decided photo point, no pair, no fit)."""
    state = controller.state
    counts = state.counts()[PHOTO]
    parts = []
    if counts.get(ACCEPTED, 0):
        parts.append(tr("{0} accepted photo points").format(counts[ACCEPTED]))
    if counts.get(CHECK, 0):  # said apart: "27 accepted" for 16 accepted and 11 check points read wrong (a trial)
        parts.append(tr("{0} check points").format(counts[CHECK]))
    if state.pairs:
        parts.append(tr("{0} pairs").format(len(state.pairs)))
    if state.fitted:
        parts.append(tr("the fitted camera"))
    return ", ".join(parts)


def same_size(path: str, controller) -> bool:
    """The file at ``path`` is a picture of the current photo's size as shown (read from its header only; its
    EXIF orientation applied, as the dock loads it): the size :meth:`load_photo` keeps the points for."""
    reader = QImageReader(path)
    size = reader.size()
    if not size.isValid() or controller.photo_size is None:
        return False
    turned = bool(reader.transformation() & QImageIOHandler.Transformation.TransformationRotate90)
    shown = (size.height(), size.width()) if turned else (size.width(), size.height())
    return shown == tuple(controller.photo_size)


def ask_photo_change(parent, name: str, work: str, offer_keep: bool, comes_back: bool = False) -> Optional[str]:
    """:data:`KEEP` (the same picture: keep the points), :data:`AFRESH` (put them aside) or None (keep the
    current photo). Asked only when ``work`` (:func:`work_on_photo`) is not empty; ``comes_back``: work on the
    chosen photo was put aside earlier (:mod:`.photo_shelf`)."""
    box = QMessageBox(parent)
    box.setIcon(QMessageBox.Icon.Question)
    box.setWindowTitle(tr("Monoplot: another photo"))
    text = tr("Load {0}? The current photo carries {1}: they belong to that picture.").format(name, work)
    if offer_keep:
        text += " " + tr("The new file has the same size: if it is the same picture (a grey, re-touched or "
                         "re-saved copy) or another frame of the same fixed camera (a time-lapse), keep them, "
                         "and the camera with them: the new frame is matched to this one, and if the camera has "
                         "turned a little, the points and the camera follow the turn (Undo takes it back).")
    else:
        text += " " + tr("They are put aside in the project and come back when you choose that photo again (the "
                         "map points stay).")
    if comes_back:
        text += " " + tr("The work on {0} put aside earlier comes back with it.").format(name)
    box.setText(text)
    keep = box.addButton(tr("Keep the points"), QMessageBox.ButtonRole.AcceptRole) if offer_keep else None
    afresh = box.addButton(tr("Start afresh"), QMessageBox.ButtonRole.DestructiveRole)
    cancel = box.addButton(QMessageBox.StandardButton.Cancel)
    box.setDefaultButton(cancel)
    box.exec()
    clicked = box.clickedButton()
    return KEEP if keep is not None and clicked is keep else AFRESH if clicked is afresh else None
