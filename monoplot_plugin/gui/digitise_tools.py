"""Digitising on the photo canvas: capture (point, line, polygon) and edit/delete map tools.

The photo canvas is a QgsMapCanvas in pixel space (x = u, y = -v; see :mod:`monoplot_plugin.gui.photo_canvas`).
The tools write into a :class:`~.digitising.DigitisingSession`, whose live map layers follow every change.

Capture, QGIS-like: left click adds a vertex (a point is done at once), right click finishes a line (2+ vertices) or
polygon (3+ vertices), Backspace removes the last vertex, Esc cancels. Vertices snap to the vertices of everything
already drawn on the photo within :data:`SNAP_PIXELS` screen pixels and :data:`SNAP_MAX_PHOTO_PX` photo pixels (a
marker shows the snap), and a polygon's or line's last click onto its own first vertex once it has three (within
the same limits).

Edit: drag a vertex to move it; right click on a feature (or press Delete with the mouse over it) deletes it.

Ctrl+Z in either tool takes back the last drawing edit (:meth:`~.digitising.DigitisingSession.undo`), Ctrl+Shift+Z
(or Ctrl+Y) does it again (:meth:`~.digitising.DigitisingSession.redo`).
"""

from __future__ import annotations

from typing import Callable, List, Optional, Tuple

import numpy as np
from qgis.core import QgsGeometry, QgsPointXY, QgsWkbTypes
from qgis.gui import QgsMapCanvas, QgsMapMouseEvent, QgsMapTool, QgsRubberBand, QgsVertexMarker
from qgis.PyQt.QtCore import Qt, pyqtSignal
from qgis.PyQt.QtGui import QColor

from ..adapters.photo_space import pixel_of

__all__ = ["PhotoCaptureTool", "PhotoEditTool", "SNAP_PIXELS"]

#: Snapping and picking tolerance in screen pixels.
SNAP_PIXELS = 10.0
#: ... and, for snapping onto another feature's vertex, in photo pixels at most: on a photo shown small (4.5 photo px
#: per screen px in the dock) 10 screen px moved a new line's vertices up to 45 photo px onto a neighbouring line
#: (a trial: 8 of 16 vertices of a snow line pulled onto the previous one)
SNAP_MAX_PHOTO_PX = 8.0
_GEOMETRY = {"point": QgsWkbTypes.GeometryType.PointGeometry, "line": QgsWkbTypes.GeometryType.LineGeometry,
             "polygon": QgsWkbTypes.GeometryType.PolygonGeometry}


def _tolerance(canvas: QgsMapCanvas) -> float:
    """:data:`SNAP_PIXELS` in photo-canvas map units (photo pixels at the current zoom)."""
    return SNAP_PIXELS * canvas.mapUnitsPerPixel()


def _nearest_vertex(session, point: QgsPointXY, tolerance: float):
    """(kind, fid, vertex index, QgsPointXY) of the nearest drawn vertex within ``tolerance``, or None."""
    best, best_d = None, tolerance
    for kind, layer in list(session.photo_layers.items()):
        for feature in layer.getFeatures():
            geom = feature.geometry()
            vertex, index, _, _, sq = geom.closestVertex(point)
            if index >= 0 and sq ** 0.5 <= best_d:
                best, best_d = (kind, feature.id(), index, QgsPointXY(vertex)), sq ** 0.5
    return best


def _history_key(event) -> str:
    """"undo" for Ctrl+Z, "redo" for Ctrl+Shift+Z or Ctrl+Y, "" for any other key."""
    modifiers = event.modifiers()
    if not modifiers & Qt.KeyboardModifier.ControlModifier:
        return ""
    if event.key() == Qt.Key.Key_Z:
        return "redo" if modifiers & Qt.KeyboardModifier.ShiftModifier else "undo"
    return "redo" if event.key() == Qt.Key.Key_Y else ""


def _undo_drawing(tool, direction: str = "undo") -> None:
    """Ctrl+Z (Ctrl+Shift+Z) while drawing or editing on the photo: the last drawing edit is taken back (done
    again), and said on ``tool``'s ``undone`` signal (Ctrl+Z did nothing there, and the Points tab's Undo took back
    point edits instead)."""
    session = tool.session_getter()
    if direction == "redo":
        what = session.redo() if session is not None else ""
        tool.undone.emit(tool.tr("Redone: {0}.").format(what) if what else tool.tr("Nothing drawn to redo."))
        return
    what = session.undo() if session is not None else ""
    tool.undone.emit(tool.tr("Undone: {0} (Ctrl+Shift+Z brings it back).").format(what) if what else
                     tool.tr("Nothing drawn to undo (the Points tab's Undo takes back point edits)."))


class PhotoCaptureTool(QgsMapTool):
    """Capture points, lines or polygons on the photo canvas into the session returned by ``session_getter``.

    Signals:
        captured(str kind, int fid): a feature was added.
        message(str): something the user should know (e.g. no fitted camera yet).
        undone(str): Ctrl+Z (Ctrl+Shift+Z) took back (did again) a drawing edit (what, in words), or found none.
        editing(): a feature is about to be added.
    """

    captured = pyqtSignal(str, int)
    message = pyqtSignal(str)
    undone = pyqtSignal(str)
    editing = pyqtSignal()  # what the dock said before is about the old state

    def __init__(self, canvas: QgsMapCanvas, session_getter: Callable[[], object], kind: str):
        super().__init__(canvas)
        if kind not in _GEOMETRY:
            raise ValueError(f"kind must be point, line or polygon, got {kind!r}")
        self.kind = kind
        self.session_getter = session_getter
        self.vertices: List[QgsPointXY] = []
        self.band = QgsRubberBand(canvas, _GEOMETRY[kind])
        self.band.setColor(QColor(0, 200, 255, 160))
        self.band.setWidth(2)
        self.snap_marker = QgsVertexMarker(canvas)
        self.snap_marker.setIconType(QgsVertexMarker.ICON_BOX)
        self.snap_marker.setColor(QColor(255, 0, 255))
        self.snap_marker.setVisible(False)
        self.setCursor(Qt.CursorShape.CrossCursor)

    def snapped(self, point: QgsPointXY) -> Tuple[QgsPointXY, bool]:
        """``point`` moved onto a drawn vertex within the tolerance (or, to close it, onto the first vertex of the
        feature being drawn once it has three); the flag tells whether it snapped."""
        tolerance = _tolerance(self.canvas())
        others = min(tolerance, SNAP_MAX_PHOTO_PX)
        # Not onto its own start before that: on a photo shown small (1200 px in a 445 px canvas) a line's second
        # click 27 photo px from its first snapped onto it, and the line lost its second vertex (a trial).
        candidates = list(self.vertices[:1]) if len(self.vertices) >= 3 else []
        session = self.session_getter()
        hit = _nearest_vertex(session, point, others) if session is not None else None
        if hit is not None:
            candidates.append(hit[3])
        best = min(candidates, key=lambda p: p.distance(point), default=None)
        # its own start within the photo-pixel limit too: 10 screen px are 37 photo px in the dock, and a glacier
        # outline's 13th click, 32 photo px from its start, snapped onto it and was lost (a trial)
        if best is not None and best.distance(point) <= others:
            return QgsPointXY(best), True
        return point, False

    def _redraw(self, cursor: Optional[QgsPointXY] = None) -> None:
        self.band.reset(_GEOMETRY[self.kind])
        for p in self.vertices + ([cursor] if cursor is not None else []):
            self.band.addPoint(p, False)
        self.band.show()
        self.band.updatePosition()
        self.band.update()

    def canvasMoveEvent(self, event: QgsMapMouseEvent) -> None:  # noqa: N802 (QGIS API)
        point, snapped = self.snapped(event.mapPoint())
        self.snap_marker.setCenter(point)
        self.snap_marker.setVisible(snapped)
        if self.vertices:
            self._redraw(point)

    def canvasReleaseEvent(self, event: QgsMapMouseEvent) -> None:  # noqa: N802
        if event.button() == Qt.MouseButton.RightButton:
            self.finish()
            return
        if event.button() != Qt.MouseButton.LeftButton:
            return
        point, _ = self.snapped(event.mapPoint())
        if self.vertices and point == self.vertices[-1] and self.kind != "point":
            return  # the same place twice (snapped onto the same vertex): no zero-length segment
        self.vertices.append(point)
        if self.kind == "point":
            self.finish()
        else:
            self._redraw()

    def keyPressEvent(self, event) -> None:  # noqa: N802
        if _history_key(event) and not self.vertices:
            _undo_drawing(self, _history_key(event))
            event.accept()
        elif event.key() == Qt.Key.Key_Escape:
            self.cancel()
            event.accept()
        elif event.key() in (Qt.Key.Key_Backspace, Qt.Key.Key_Delete) and self.vertices:
            self.vertices.pop()
            self._redraw()
            event.accept()
        elif event.key() in (Qt.Key.Key_Return, Qt.Key.Key_Enter):
            self.finish()
            event.accept()
        else:
            event.ignore()

    def finish(self) -> Optional[int]:
        """Add the feature being drawn (if it has enough vertices) to the session; returns its fid."""
        needed = {"point": 1, "line": 2, "polygon": 3}[self.kind]
        vertices = self.vertices
        # A polygon closed by snapping onto its first vertex: drop the duplicate.
        if self.kind == "polygon" and len(vertices) > 3 and vertices[-1] == vertices[0]:
            vertices = vertices[:-1]
        self.cancel()
        if len(vertices) < needed:
            return None
        session = self.session_getter()
        if session is None:
            self.message.emit(self.tr("Fit the camera first: features drawn on the photo need it to reach the map."))
            return None
        uv = np.array([pixel_of(p) for p in vertices])
        self.editing.emit()
        fid = session.add_feature(self.kind, uv)
        self.captured.emit(self.kind, fid)
        return fid

    def cancel(self) -> None:
        self.vertices = []
        self.band.reset(_GEOMETRY[self.kind])

    def deactivate(self) -> None:
        self.cancel()
        self.snap_marker.setVisible(False)
        super().deactivate()

    def remove_items(self) -> None:
        """Remove the rubber band and marker from the canvas (plugin unload)."""
        for item in (self.band, self.snap_marker):
            self.canvas().scene().removeItem(item)


class PhotoEditTool(QgsMapTool):
    """Move vertices of features drawn on the photo (drag), delete features (right click, or Delete key)."""

    edited = pyqtSignal(str, int)
    deleted = pyqtSignal(str, int)
    undone = pyqtSignal(str)
    editing = pyqtSignal()  # a vertex is about to move or a feature to go

    def __init__(self, canvas: QgsMapCanvas, session_getter: Callable[[], object]):
        super().__init__(canvas)
        self.session_getter = session_getter
        self.dragging = None  # (kind, fid, index)
        self.last_point: Optional[QgsPointXY] = None
        self.marker = QgsVertexMarker(canvas)
        self.marker.setIconType(QgsVertexMarker.ICON_CIRCLE)
        self.marker.setColor(QColor(255, 200, 0))
        self.marker.setVisible(False)

    def feature_at(self, point: QgsPointXY):
        """(kind, fid) of the drawn feature under ``point`` (within the tolerance), or None. A point, a line or a
        polygon's outline within the tolerance comes first, the nearest of them; a polygon whose inside holds
        ``point`` only when none is, the smallest such (a trial's right click on a boulder drawn inside a slide's
        outline deleted the outline: every polygon is at distance 0 from a point inside it)."""
        session = self.session_getter()
        if session is None:
            return None
        tolerance = _tolerance(self.canvas())
        probe = QgsGeometry.fromPointXY(point)
        best, best_d, inside = None, tolerance, []
        for kind, layer in session.photo_layers.items():
            for feature in layer.getFeatures():
                geometry = feature.geometry()
                d = geometry.distance(probe)
                if kind == "polygon" and d == 0.0:
                    inside.append((geometry.area(), feature.id()))
                    d = QgsGeometry(geometry.constGet().boundary()).distance(probe)
                if d <= best_d:
                    best, best_d = (kind, feature.id()), d
        return best or (("polygon", min(inside)[1]) if inside else None)

    def canvasPressEvent(self, event: QgsMapMouseEvent) -> None:  # noqa: N802
        session = self.session_getter()
        if session is None or event.button() != Qt.MouseButton.LeftButton:
            return
        hit = _nearest_vertex(session, event.mapPoint(), _tolerance(self.canvas()))
        self.dragging = hit[:3] if hit is not None else None

    def canvasMoveEvent(self, event: QgsMapMouseEvent) -> None:  # noqa: N802
        self.last_point = event.mapPoint()
        self.marker.setCenter(self.last_point)
        self.marker.setVisible(self.dragging is not None)

    def canvasReleaseEvent(self, event: QgsMapMouseEvent) -> None:  # noqa: N802
        session = self.session_getter()
        if session is None:
            return
        if event.button() == Qt.MouseButton.RightButton:
            self.delete_at(event.mapPoint())
            return
        if self.dragging is not None and event.button() == Qt.MouseButton.LeftButton:
            kind, fid, index = self.dragging
            self.dragging = None
            self.marker.setVisible(False)
            p = event.mapPoint()
            self.editing.emit()
            session.move_vertex(kind, fid, index, *pixel_of(p))
            self.edited.emit(kind, fid)

    def delete_at(self, point: QgsPointXY) -> bool:
        hit = self.feature_at(point)
        if hit is None:
            return False
        self.editing.emit()
        self.session_getter().delete_feature(*hit)
        self.deleted.emit(*hit)
        return True

    def keyPressEvent(self, event) -> None:  # noqa: N802
        if _history_key(event):
            _undo_drawing(self, _history_key(event))
            event.accept()
        elif event.key() == Qt.Key.Key_Delete and self.last_point is not None and self.delete_at(self.last_point):
            event.accept()
        else:
            event.ignore()

    def remove_items(self) -> None:
        self.canvas().scene().removeItem(self.marker)
