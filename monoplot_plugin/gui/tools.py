"""Map tools: curate points (photo canvas and main map) and draw the rough camera on the main map.

CurationTool, on either canvas:
    left click on a point ........ select it and accept it
    right click on a point ....... select it and reject it
    Ctrl+click ................... add a manual point (accepted), even on top of an existing one
    drag a point ................. move it (manual points; suggestions become manual once moved)
    Shift+click on a point ....... link it to the selected point of the other canvas (a pair)
    keys: N / Space next undecided, P previous, A accept, R reject, U undecide, Delete delete,
          Ctrl+Z / Ctrl+Shift+Z undo / redo, Home whole photo (photo canvas)
RoughCameraTool (main map): press at the camera position, drag towards the view direction, release.
"""

from __future__ import annotations

import math
from typing import Optional, Tuple

from qgis.core import Qgis, QgsCoordinateReferenceSystem, QgsCoordinateTransform, QgsPointXY, QgsProject
from qgis.gui import QgsMapCanvas, QgsMapMouseEvent, QgsMapTool
from qgis.PyQt.QtCore import Qt, pyqtSignal

from ..state import MAP, PHOTO, SUGGESTED
from .photo_canvas import map_to_uv, uv_to_map

__all__ = ["CurationTool", "RoughCameraTool", "SpaceMapping"]


class SpaceMapping:
    """Converts between a canvas's map coordinates and a point space's coordinates.

    Photo canvas: space coordinates are pixels (u, v), canvas (u, -v). Main map: space coordinates are in the
    DEM CRS, the canvas may use another CRS.
    """

    def __init__(self, canvas: QgsMapCanvas, space: str, crs: Optional[QgsCoordinateReferenceSystem] = None):
        self.canvas, self.space, self.crs = canvas, space, crs

    def _transform(self) -> Optional[QgsCoordinateTransform]:
        dest = self.canvas.mapSettings().destinationCrs()
        if self.space == PHOTO or self.crs is None or not self.crs.isValid() or not dest.isValid() or dest == self.crs:
            return None
        return QgsCoordinateTransform(self.crs, dest, QgsProject.instance())

    def to_space(self, point: QgsPointXY) -> Tuple[float, float]:
        if self.space == PHOTO:
            return map_to_uv(point)
        t = self._transform()
        p = t.transform(point, Qgis.TransformDirection.Reverse) if t else point
        return p.x(), p.y()

    def to_canvas(self, x: float, y: float) -> QgsPointXY:
        if self.space == PHOTO:
            return uv_to_map(x, y)
        t = self._transform()
        return t.transform(QgsPointXY(x, y)) if t else QgsPointXY(x, y)

    def tolerance(self, pixels: float = 8.0) -> float:
        """``pixels`` screen pixels in space units (approximately, at the canvas centre)."""
        mupp = self.canvas.mapUnitsPerPixel()
        if self.space == PHOTO:
            return pixels * mupp
        c = self.canvas.extent().center()
        a = self.to_space(c)
        b = self.to_space(QgsPointXY(c.x() + pixels * mupp, c.y()))
        return math.hypot(b[0] - a[0], b[1] - a[1])


class CurationTool(QgsMapTool):
    """Accept / reject / add / move / delete / link points of one space on one canvas (see module docstring)."""

    def __init__(self, canvas: QgsMapCanvas, controller, mapping: SpaceMapping):
        super().__init__(canvas)
        self.controller = controller
        self.mapping = mapping
        self.space = mapping.space
        self._drag_id: Optional[str] = None
        self._dragged = False
        self._press_pos = None
        #: called with the sentence of an undo or redo done by Ctrl+Z / Ctrl+Shift+Z here (the dock shows it)
        self.on_undo = None
        self.setCursor(Qt.CursorShape.CrossCursor)

    def _hit(self, event: QgsMapMouseEvent) -> Tuple[Optional[str], Tuple[float, float]]:
        xy = self.mapping.to_space(event.mapPoint())
        return self.controller.point_near(self.space, xy[0], xy[1], self.mapping.tolerance()), xy

    def canvasPressEvent(self, event: QgsMapMouseEvent) -> None:  # noqa: N802 (QGIS API)
        mods = event.modifiers()
        if event.button() == Qt.MouseButton.LeftButton and mods & Qt.KeyboardModifier.ControlModifier:
            # always a new point: selecting or accepting a suggestion 8 px away put pairs 14-88 m off (issue 12)
            self.controller.add_manual(self.space, *self.mapping.to_space(event.mapPoint()))
            return
        pid, xy = self._hit(event)
        if event.button() == Qt.MouseButton.LeftButton:
            if pid is not None:
                self._drag_id, self._dragged = pid, False
                self._press_pos = event.pos()
        elif event.button() == Qt.MouseButton.RightButton and pid is not None:
            self.controller.select(self.space, pid)
            self.controller.reject(pid)

    def canvasMoveEvent(self, event: QgsMapMouseEvent) -> None:  # noqa: N802
        # between press and release the button is held: a move of more than 3 screen pixels is a drag
        if self._drag_id is not None and not self._dragged and \
                (event.pos() - self._press_pos).manhattanLength() > 3:
            self._dragged = True
            self.controller.select(self.space, self._drag_id)

    def canvasReleaseEvent(self, event: QgsMapMouseEvent) -> None:  # noqa: N802
        if event.button() != Qt.MouseButton.LeftButton or self._drag_id is None:
            return
        pid, self._drag_id = self._drag_id, None
        if self._dragged:
            xy = self.mapping.to_space(event.mapPoint())
            self.controller.move(pid, *xy)
            return
        self.controller.select(self.space, pid)
        if event.modifiers() & Qt.KeyboardModifier.ShiftModifier:
            other = self.controller.current[MAP if self.space == PHOTO else PHOTO]
            if other:
                pair = (pid, other) if self.space == PHOTO else (other, pid)
                self.controller.link(*pair)
            return
        self.controller.accept(pid)

    def keyPressEvent(self, event) -> None:  # noqa: N802
        key, mods = event.key(), event.modifiers()
        c = self.controller
        pid = c.current[self.space]
        if key == Qt.Key.Key_Z and mods & Qt.KeyboardModifier.ControlModifier:
            said = c.redo() if mods & Qt.KeyboardModifier.ShiftModifier else c.undo()
            if said and self.on_undo is not None:
                self.on_undo(said)
        elif key in (Qt.Key.Key_N, Qt.Key.Key_Space):
            c.step(self.space, 1, only_suggested=True) or c.step(self.space, 1)
        elif key == Qt.Key.Key_P:
            c.step(self.space, -1)
        elif key == Qt.Key.Key_A and pid:
            c.accept(pid)
            c.step(self.space, 1, only_suggested=True)
        elif key == Qt.Key.Key_R and pid:
            c.reject(pid)
            c.step(self.space, 1, only_suggested=True)
        elif key == Qt.Key.Key_U and pid:
            c.set_status([pid], SUGGESTED)
        elif key == Qt.Key.Key_C and pid:
            c.toggle_check(pid)
        elif key in (Qt.Key.Key_Delete, Qt.Key.Key_Backspace) and pid:
            c.delete([pid])
        else:
            event.ignore()
            return
        event.accept()


class RoughCameraTool(QgsMapTool):
    """Press at the camera position, drag towards what the photo shows, release: emits the rough camera.

    Signals:
        cameraDrawn(x, y, heading): position in the DEM CRS and heading in degrees from grid north.
        dragging(x, y, heading): live feedback while dragging (same units).
    """

    cameraDrawn = pyqtSignal(float, float, float)
    dragging = pyqtSignal(float, float, float)

    def __init__(self, canvas: QgsMapCanvas, mapping: SpaceMapping):
        super().__init__(canvas)
        self.mapping = mapping
        self._start: Optional[Tuple[float, float]] = None
        self.setCursor(Qt.CursorShape.CrossCursor)

    @staticmethod
    def heading(start: Tuple[float, float], end: Tuple[float, float]) -> float:
        """Azimuth from ``start`` to ``end``, degrees clockwise from north (+Y).

        >>> RoughCameraTool.heading((0, 0), (1, 0)), RoughCameraTool.heading((0, 0), (0, -1))
        (90.0, 180.0)
        """
        return math.degrees(math.atan2(end[0] - start[0], end[1] - start[1])) % 360.0

    def canvasPressEvent(self, event: QgsMapMouseEvent) -> None:  # noqa: N802
        if event.button() == Qt.MouseButton.LeftButton:
            self._start = self.mapping.to_space(event.mapPoint())

    def canvasMoveEvent(self, event: QgsMapMouseEvent) -> None:  # noqa: N802
        if self._start is not None:
            end = self.mapping.to_space(event.mapPoint())
            if end != self._start:
                self.dragging.emit(self._start[0], self._start[1], self.heading(self._start, end))

    def canvasReleaseEvent(self, event: QgsMapMouseEvent) -> None:  # noqa: N802
        if self._start is None or event.button() != Qt.MouseButton.LeftButton:
            return
        start, self._start = self._start, None
        end = self.mapping.to_space(event.mapPoint())
        if math.hypot(end[0] - start[0], end[1] - start[1]) < self.mapping.tolerance(3):
            return  # a click without a drag gives no direction
        self.cameraDrawn.emit(start[0], start[1], self.heading(start, end))
