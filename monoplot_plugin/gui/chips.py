"""Judge a pair at a glance: for the selected point, a zoomed chip of the photo and a chip of the DEM rendered from
the current camera, side by side, over the same photo pixels, with the partner's position marked.

A photo point is shown where it is; a map point where the current camera projects it. On the DEM chip the map
points (suggestions small, the partner large) are drawn where the camera projects them; on the photo chip the
partner of a map point. The DEM view is the fitted camera's overlay when there is one, else a rendering of the rough
camera made once per camera in a task (a selection never waits for a z-buffer).
"""

from __future__ import annotations

import math
from typing import List, Optional, Tuple

import numpy as np
from qgis.PyQt.QtCore import QCoreApplication, QEvent, QPointF, QRectF, Qt, QTimer
from qgis.PyQt.QtGui import QColor, QImage, QPainter, QPen, QPixmap
from qgis.PyQt.QtWidgets import QHBoxLayout, QLabel, QVBoxLayout, QWidget

from ..adapters.photo import array_to_qimage
from ..core.camera import Camera
from ..state import MAP, PHOTO
from .tasks import HiddenTask, abandon, start_task

__all__ = ["ChipView", "chip_radius", "chip_side", "render_view"]

#: largest side of each chip on screen (pixels)
CHIP_PX = 120
#: smallest side of each chip on screen (pixels): the chips are a zoom, not a thumbnail
CHIP_MIN_PX = 72
#: most pixels of the rough camera's rendering (chips need detail, not a full-size z-buffer)
VIEW_MAX_PIXELS = 600_000


def tr(text: str) -> str:
    return QCoreApplication.translate("MonoplotChips", text)


def chip_radius(width: int) -> float:
    """Half the side (photo pixels) of the region a chip shows: a 24th of the photo width, at least 32 px.

    >>> chip_radius(1024), chip_radius(4290)
    (42.666666666666664, 178.75)
    """
    return max(32.0, width / 24.0)


def chip_side(canvas_width: int, canvas_height: int) -> int:
    """Side (screen pixels) of each chip over a photo canvas of this size: a quarter of its shorter side in steps of
    8 px (a status line that comes and goes resizes the canvas a little: the chips stay), within
    :data:`CHIP_MIN_PX` .. :data:`CHIP_PX`. At 120 px the two chips covered a quarter of the docked photo canvas
    (546 x 333 at 1600 x 1000); a floated, larger canvas gets larger chips.

    >>> chip_side(546, 333), chip_side(546, 310), chip_side(1380, 800), chip_side(300, 200)
    (80, 72, 120, 72)
    """
    return int(min(CHIP_PX, max(CHIP_MIN_PX, min(canvas_width, canvas_height) // 32 * 8)))


def render_view(camera: Camera, dem) -> np.ndarray:
    """(h, w, 4) uint8 shaded relief of ``dem`` seen by ``camera`` at up to :data:`VIEW_MAX_PIXELS` (the dock's
    overlay colours, :func:`.engine.colorize_relief`)."""
    from ..core.render import render_dem
    from ..core.xyz import compute_xyz_full
    from .engine import colorize_relief

    w, h = camera.image_size
    small = camera.scaled(min(1.0, math.sqrt(VIEW_MAX_PIXELS / float(w * h))))
    res = compute_xyz_full(small, dem, visibility=False)
    return colorize_relief(np.asarray(render_dem(small, dem, result=res).shade), res.xyz)


class ChipView(QWidget):
    """Two chips (photo | DEM from the camera) of the selected point, floating in the corner of ``parent`` (the photo
    canvas) away from the point, shown while a point is selected and :attr:`wanted` (the photo bar's "Chips")."""

    def __init__(self, controller, parent=None):
        super().__init__(parent)
        self.controller = c = controller
        #: the person's choice (the photo bar's "Chips" box): off, the chips never show
        self.wanted = True
        self.paused = False  # a drawing tool is on: the chips would cover what is being traced
        #: side of each chip (screen pixels, :func:`chip_side` of the canvas)
        self.side = CHIP_PX
        self._at: Optional[Tuple[float, float]] = None  # photo pixel of the selected point (where not to be)
        self.setObjectName("MonoplotChips")
        self.setAttribute(Qt.WidgetAttribute.WA_StyledBackground, True)
        self.setStyleSheet("#MonoplotChips { background: rgba(20, 20, 20, 215); border-radius: 4px; }"
                           "#MonoplotChips QLabel { color: #eee; }")
        outer = QVBoxLayout(self)
        outer.setContentsMargins(4, 4, 4, 4)
        outer.setSpacing(3)
        row = QHBoxLayout()
        row.setSpacing(4)
        self.photo_chip, self.dem_chip = QLabel(), QLabel()
        for label, tip in ((self.photo_chip, tr("The photo around the selected point")),
                           (self.dem_chip, tr("The DEM rendered from the current camera, same pixels"))):
            label.setAlignment(Qt.AlignmentFlag.AlignCenter)
            label.setToolTip(tip)
            label.setStyleSheet("background: #222; color: #ccc;")
            row.addWidget(label)
        outer.addLayout(row)
        # wrapped, not cut at one line (the whole text in its tool tip too): at the smallest chips the camera's word
        # was cut off ("Photo point · paired (cya…", a trial)
        self.caption = QLabel()
        self.caption.setWordWrap(True)
        outer.addWidget(self.caption)
        self._resize_chips(CHIP_PX)
        self._view: Optional[Tuple[dict, QImage]] = None  # (camera dict, rendering) of the rough camera
        self._tasks: List[HiddenTask] = []
        self._selected: Tuple[str, str] = ("", "")
        self._drawn: Optional[tuple] = None  # what the chips show now (see refresh): the same is not drawn again
        c.selectionChanged.connect(self.show_point)
        c.cameraChanged.connect(self._camera_changed)
        # an edit redraws the chips once the event is handled: a click that edits and then selects (most do)
        # draws them once, for the selection
        self._pending = QTimer(self)
        self._pending.setSingleShot(True)
        self._pending.setInterval(0)
        self._pending.timeout.connect(self.refresh)
        c.pointsChanged.connect(lambda changed: self._pending.start())
        if parent is not None:  # floats over the photo canvas: no room taken from the table
            parent.installEventFilter(self)
            # the canvas pans and zooms: the corner away from the selected point changes with it
            extents = getattr(parent, "extentsChanged", None)
            if extents is not None:
                extents.connect(self._place)
        self.setVisible(False)

    def set_wanted(self, on: bool) -> None:
        """Show the chips of the selected point (on) or never (off)."""
        self.wanted = bool(on)
        self._drawn = None
        self.refresh()

    def set_paused(self, on: bool) -> None:
        """Hide the chips while a drawing tool is on the photo canvas (a trial: they covered a third of a small
        dock's canvas where the snow line was being traced), and show them again after."""
        self.paused = bool(on)
        self._drawn = None
        self.refresh()

    def eventFilter(self, watched, event) -> bool:  # noqa: N802
        if watched is self.parent() and event.type() == QEvent.Type.Resize:
            parent = self.parentWidget()
            side = chip_side(parent.width(), parent.height())
            if side != self.side:
                self._resize_chips(side)
                self._drawn = None
                if not self.isHidden():
                    self._pending.start()  # drawn again at the new size
            self._place()
        return False

    def _resize_chips(self, side: int) -> None:
        self.side = side
        for label in (self.photo_chip, self.dem_chip):
            label.setFixedSize(side, side)
        self.caption.setFixedWidth(2 * side + 4)
        self._set_caption(self.caption.toolTip())

    def _set_caption(self, text: str) -> None:
        self.caption.setToolTip(text)
        metrics = self.caption.fontMetrics()
        width = self.caption.width()
        # at most three lines (the captions are short; elided beyond that)
        text = metrics.elidedText(text, Qt.TextElideMode.ElideRight, int(2.6 * width))
        self.caption.setText(text)
        wrapped = metrics.boundingRect(0, 0, width, 10 * metrics.lineSpacing(), int(Qt.TextFlag.TextWordWrap), text)
        self.caption.setFixedHeight(max(metrics.lineSpacing(), wrapped.height()) + 2)

    def _place(self) -> None:
        """In the corner of the canvas diagonally away from the selected point: it is never under its own chips
        (in the lower left corner they hid the photo points there)."""
        parent = self.parentWidget()
        if parent is None or self.isHidden():
            return
        self.adjustSize()
        left, top = True, False  # lower left while the point is not on the canvas
        if self._at is not None and hasattr(parent, "getCoordinateTransform"):
            from qgis.core import QgsPointXY

            at = parent.getCoordinateTransform().transform(QgsPointXY(self._at[0], -self._at[1]))  # x = u, y = -v
            left, top = at.x() > parent.width() / 2.0, at.y() > parent.height() / 2.0
        # clear of the canvas's readout line where it is (its wrapped second line hid the chips' caption, a trial)
        readout = getattr(parent, "readout", None)
        shown = readout is not None and readout.isVisible()
        below = readout.height() + 2 if shown and readout.y() > parent.height() / 2.0 else 0
        above = readout.y() + readout.height() + 2 if shown and readout.y() <= parent.height() / 2.0 else 0
        x = 6 if left else max(0, parent.width() - self.width() - 6)
        y = max(6, above) if top else max(0, parent.height() - self.height() - 6 - below)
        self.move(x, y)
        self.raise_()

    def keep_clear(self) -> None:
        """Placed again when the canvas's readout line moves or grows (:meth:`.photo_canvas.PhotoCanvas`)."""
        if not self.isHidden():
            self._place()

    # --- what to show -------------------------------------------------------------------------------------------
    def show_point(self, space: str, pid: str) -> None:
        self._selected = (space, pid)
        self.refresh()

    def refresh(self) -> None:
        self._pending.stop()
        space, pid = self._selected
        c = self.controller
        p = c.state.points.get(pid) if pid else None
        if p is None or c.image is None or not self.wanted or self.paused:
            self.setVisible(False)
            self._drawn = None
            return
        self.setVisible(True)
        # A click selects a point and then edits it (accepts, rejects): the edit's refresh would draw the same
        # chips again (a third of a click's time at 10,000 suggestions). What they depend on, compared first; the
        # camera by its stored dict and the DEM view by identity (both replaced, never changed in place).
        partner_id = c.state.partner(pid) or ""
        key, which = self._camera_key()
        drawn = ((space, pid, p.x, p.y, p.z, p.label, partner_id, c.image.cacheKey(),
                  tuple((q.id, q.status) for q in c.visible(MAP))), key, c.overlay, self._view)
        if self._drawn is not None and drawn[0] == self._drawn[0] and \
                all(a is b for a, b in zip(drawn[1:], self._drawn[1:])):
            return
        self._drawn = drawn
        camera = key if isinstance(key, Camera) else (Camera.from_dict(key) if key else None)
        centre = self._centre(p, camera)
        self._at = centre
        if centre is None:
            if camera is None:
                self.photo_chip.setText(tr("No camera:\nnot in the photo"))
                self.dem_chip.setText(tr("Give a rough\ncamera first"))
                self._set_caption(tr("A map point shows on the photo once there is a camera."))
            elif p.z is None and not np.isfinite(self._project_height(p)):
                # a trial's lake point, on a void, read "Give a rough camera first" beside a fitted camera
                self.photo_chip.setText(tr("No height"))
                self.dem_chip.setText(tr("DEM void\nor edge"))
                self._set_caption(tr("Map point with no height (DEM void or off it): not used."))
            else:
                self.photo_chip.setText(tr("Behind the\ncamera"))
                self.dem_chip.setText(tr("Not in view"))
                self._set_caption(tr("This map point lies behind the camera: it is not in the photo."))
            self._place()
            return
        partner = c.state.points.get(partner_id)
        photo_marks, dem_marks = self._marks(p, partner, camera)
        radius = chip_radius(c.image.width())
        self.photo_chip.setPixmap(self._chip(c.image, 1.0, centre, radius, photo_marks, self.side))
        view = self._dem_view(camera)
        if view is None:
            self.dem_chip.setText(tr("Rendering…") if camera is not None else tr("No camera yet"))
        else:
            self.dem_chip.setPixmap(self._chip(view, view.width() / float(c.image.width()), centre, radius,
                                               dem_marks, self.side))
        kind = tr("Photo point") if space == PHOTO else tr("Map point")
        text = tr("{0} {1}").format(kind, p.label or "").strip()
        if partner is not None:
            text += tr(" · paired (cyan)")
        if camera is None:
            text += tr(" · no camera: no DEM view")
        else:  # short: one line under the chips
            text += tr(" · {0} camera").format(which)
        self._set_caption(text)
        self._place()

    def _camera_key(self) -> Tuple[object, str]:
        """(what identifies the camera the chips show the point under, its word for the caption): the fitted
        camera's stored dict, else the Camera ranking the suggestions and drawing the links when a background refit
        gave it (a desktop trial's chips stayed on the rough camera, 64 px off, beside links drawn by an "ok"
        refit), else the rough camera's stored dict (None without one). Stored objects are replaced, never changed
        in place: compared by identity, a click that changes no camera draws no chip again."""
        c = self.controller
        if c.state.fitted:
            return c.state.fitted, tr("fitted")
        ranking = getattr(c.shortlist, "camera", None)
        if ranking is not None and c.state.prior and ranking.to_dict() != c.state.prior:
            return ranking, tr("refit")
        return c.state.prior, tr("rough")

    def _centre(self, p, camera) -> Optional[Tuple[float, float]]:
        if p.space == PHOTO:
            return p.x, p.y
        if camera is None:
            return None
        uv = self._project(camera, [p])
        return None if uv is None or not np.isfinite(uv[0]).all() else (float(uv[0, 0]), float(uv[0, 1]))

    def _project_height(self, q) -> float:
        """The height a map point is projected at: its own, else the DEM's there (NaN on a void or off the DEM)."""
        c = self.controller
        if q.z is not None:
            return float(q.z)
        return float(c.dem.sample(q.x, q.y, to_extent=True)) if c.dem is not None else np.nan

    def _project(self, camera: Camera, points) -> Optional[np.ndarray]:
        xyz = np.array([(q.x, q.y, self._project_height(q)) for q in points], dtype=float)
        if not len(xyz):
            return None
        uv, depth = camera.project_with_depth(xyz)
        uv = np.asarray(uv, dtype=float)
        uv[~(np.asarray(depth) > 0)] = np.nan
        return uv

    def _marks(self, p, partner, camera):
        """(photo chip marks, DEM chip marks): lists of (u, v, kind) with kind "self", "partner" or "point"."""
        photo, dem = [], []
        if p.space == PHOTO:
            photo.append((p.x, p.y, "self"))
            dem.append((p.x, p.y, "self"))
        else:
            uv = self._project(camera, [p])
            photo.append((uv[0, 0], uv[0, 1], "self"))
            dem.append((uv[0, 0], uv[0, 1], "self"))
        if partner is not None:
            if partner.space == PHOTO:
                photo.append((partner.x, partner.y, "partner"))
            elif camera is not None:
                uv = self._project(camera, [partner])
                dem.append((uv[0, 0], uv[0, 1], "partner"))
        if camera is not None:  # the map points on show near it, where the camera sees them: O(shown) per click
            near = [q for q in self.controller.visible(MAP) if q.id != p.id and
                    (partner is None or q.id != partner.id) and q.status != "rejected"]
            uv = self._project(camera, near) if near else None
            if uv is not None:
                dem.extend((u, v, "point") for u, v in uv if np.isfinite(u) and np.isfinite(v))
        return photo, dem

    # --- the DEM view -----------------------------------------------------------------------------------------
    def _dem_view(self, camera: Optional[Camera]) -> Optional[QImage]:
        c = self.controller
        if camera is None or c.dem is None:
            return None
        if c.fitted is not None and c.overlay is not None:
            return c.overlay
        key = camera.to_dict()
        if self._view is not None and self._view[0] == key:
            return self._view[1]
        if not any(getattr(t, "monoplot_key", None) == key for t in self._tasks):
            self._start_render(camera, c.dem, key)
        return None

    def _start_render(self, camera: Camera, dem, key: dict) -> None:
        def done(result) -> None:
            self._tasks.remove(task)
            if result.ok:
                self._view = (key, array_to_qimage(result.value))
                self.refresh()

        task = HiddenTask(tr("Monoplot: DEM view for the chips"),
                            lambda progress, is_canceled: render_view(camera, dem), done)
        task.monoplot_key = key
        self._tasks.append(task)
        start_task(task)

    def _camera_changed(self) -> None:
        if not self.isHidden():
            self.refresh()

    # --- drawing ----------------------------------------------------------------------------------------------
    @staticmethod
    def _chip(image: QImage, scale: float, centre, radius: float, marks, side: int = CHIP_PX) -> QPixmap:
        """The square of ``image`` (``scale`` image pixels per photo pixel) around photo pixel ``centre``, zoomed to
        a chip of ``side`` screen pixels, with the marks (photo pixels) drawn on it."""
        u, v = centre
        src = QRectF((u - radius) * scale, (v - radius) * scale, 2 * radius * scale, 2 * radius * scale)
        pixmap = QPixmap(side, side)
        pixmap.fill(QColor(34, 34, 34))
        painter = QPainter(pixmap)
        painter.setRenderHint(QPainter.RenderHint.SmoothPixmapTransform)
        painter.drawImage(QRectF(0, 0, side, side), image, src)
        zoom = side / (2.0 * radius)

        def at(pu, pv) -> QPointF:
            return QPointF((pu - (u - radius)) * zoom, (pv - (v - radius)) * zoom)

        for pu, pv, kind in sorted(marks, key=lambda m: m[2] != "point"):  # small ones below
            if not (np.isfinite(pu) and np.isfinite(pv)):
                continue
            q = at(pu, pv)
            if not (-10 <= q.x() <= side + 10 and -10 <= q.y() <= side + 10):
                continue
            if kind == "point":
                painter.setPen(QPen(QColor(255, 220, 0), 1.5))
                painter.drawEllipse(q, 2.5, 2.5)
                continue
            colour = QColor(255, 60, 60) if kind == "self" else QColor(0, 230, 255)
            painter.setPen(QPen(QColor(0, 0, 0, 160), 4.0))
            painter.drawLine(q + QPointF(-9, 0), q + QPointF(9, 0))
            painter.drawLine(q + QPointF(0, -9), q + QPointF(0, 9))
            painter.setPen(QPen(colour, 2.0))
            painter.drawLine(q + QPointF(-9, 0), q + QPointF(9, 0))
            painter.drawLine(q + QPointF(0, -9), q + QPointF(0, 9))
            if kind == "partner":
                painter.drawEllipse(q, 6.0, 6.0)
        painter.end()
        return pixmap

    def unload(self) -> None:
        for task in self._tasks:  # ends touching nothing of the dock; QGIS quitting waits for it (gui/tasks.py)
            abandon(task)
