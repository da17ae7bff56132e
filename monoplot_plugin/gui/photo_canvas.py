"""The photo canvas: a QgsMapCanvas whose "map" is the photo in pixel space.

Map coordinates on this canvas are ``(x, y) = (u, -v)``: column to the right, row downwards, the photo spanning
``x in [0, W]`` and ``y in [-H, 0]``. Because it is a real QgsMapCanvas, QGIS map tools (capture tools, rubber bands,
vertex markers, snapping-free digitising) work on it unchanged; use :func:`uv_to_map` / :func:`map_to_uv` to convert.

The photo itself is drawn by :class:`ImageItem` (a canvas item holding an EXIF-oriented QImage), not by a raster
layer: GDAL ignores EXIF orientation, and no temporary file is needed. Vector layers (e.g. an outputs engineer's
digitising layer, CRS left invalid) can still be put on top with :meth:`PhotoCanvas.set_extra_layers`.
"""

from __future__ import annotations

from typing import List, Optional, Tuple

from qgis.core import QgsCoordinateReferenceSystem, QgsMapLayer, QgsRectangle
from qgis.gui import QgsMapCanvas, QgsMapCanvasItem
from qgis.PyQt.QtCore import QRectF, Qt, QTimer, pyqtSignal
from qgis.PyQt.QtGui import QBrush, QColor, QImage, QPainter
from qgis.PyQt.QtWidgets import QLabel, QWidget

from ..adapters.photo_space import photo_point, pixel_of

__all__ = ["PhotoCanvas", "ImageItem", "uv_to_map", "map_to_uv"]


uv_to_map = photo_point  # photo pixel (u, v) -> photo-canvas map point (u, -v)
map_to_uv = pixel_of  # photo-canvas map point -> photo pixel (u, v)


class ImageItem(QgsMapCanvasItem):
    """A QImage stretched over the rectangle ``[0, W] x [-H, 0]`` of a photo canvas, with an opacity."""

    #: levels of the image pyramid stop at this width (pixels)
    PYRAMID_MIN_WIDTH = 512

    def __init__(self, canvas: QgsMapCanvas, z_value: float = -10.0):
        super().__init__(canvas)
        self._image: Optional[QImage] = None
        self._levels: List[QImage] = []
        self._opacity = 1.0
        self.setZValue(z_value)

    def set_image(self, image: Optional[QImage], size: Optional[Tuple[int, int]] = None) -> None:
        """Show ``image`` stretched to ``size`` = (W, H) photo pixels (default: the image's own size)."""
        self._image = image
        self._levels = self._pyramid(image)
        if image is not None and not image.isNull():
            w, h = size or (image.width(), image.height())
            self.setRect(QgsRectangle(0.0, -float(h), float(w), 0.0))
        self.setVisible(image is not None and not image.isNull())
        self.update()

    def set_opacity(self, opacity: float) -> None:
        self._opacity = max(0.0, min(1.0, float(opacity)))
        self.update()

    @classmethod
    def _pyramid(cls, image: Optional[QImage]) -> List[QImage]:
        """The image and halved copies down to :attr:`PYRAMID_MIN_WIDTH`: zoomed-out views of a 24 MP photo paint
        from a small copy instead of resampling every pixel on each repaint."""
        if image is None or image.isNull():
            return []
        levels = [image]
        while levels[-1].width() > 2 * cls.PYRAMID_MIN_WIDTH:
            last = levels[-1]
            levels.append(last.scaled(last.width() // 2, last.height() // 2, Qt.AspectRatioMode.IgnoreAspectRatio,
                                      Qt.TransformationMode.SmoothTransformation))
        return levels

    def level_for(self, device_width: float) -> QImage:
        """The smallest pyramid level at least ``device_width`` pixels wide (the full image when zoomed in)."""
        for level in reversed(self._levels):
            if level.width() >= device_width:
                return level
        return self._levels[0]

    def paint(self, painter: QPainter, option=None, widget=None) -> None:  # QGraphicsItem.paint
        if not self._levels or self._opacity <= 0:
            return
        target = self.boundingRect()
        device_width = target.width() * painter.deviceTransform().m11()
        image = self.level_for(device_width)
        painter.setOpacity(self._opacity)
        painter.setRenderHint(QPainter.RenderHint.SmoothPixmapTransform, True)
        painter.drawImage(target, image, QRectF(image.rect()))


class PhotoCanvas(QgsMapCanvas):
    """Map canvas in photo pixel space: wheel zoom, middle/space-drag pan (QgsMapCanvas defaults), photo + overlay.

    Signals:
        cursorMoved(u, v): mouse over the canvas, in photo pixels (also outside the photo).
        cursorLeft(): the mouse left the canvas.

    :meth:`set_readout` shows a line of text over the canvas's bottom edge (what the cursor points at): QGIS's
    status bar leaves a message about 110 px beside its coordinate and scale boxes on a 1280 px window, and the
    readout there was cut to "Monoplot: photo pixel".
    """

    cursorMoved = pyqtSignal(float, float)
    cursorLeft = pyqtSignal()

    def __init__(self, parent=None):
        super().__init__(parent)
        self.setObjectName("monoplotPhotoCanvas")
        self.setDestinationCrs(QgsCoordinateReferenceSystem())  # pixel space: no CRS, no reprojection
        # Layers render transparently over the photo (which sits below the map item); the view paints the frame.
        self.setCanvasColor(QColor(0, 0, 0, 0))
        self.setBackgroundBrush(QBrush(QColor(40, 40, 40)))
        self.enableAntiAliasing(True)
        self.setPreviewJobsEnabled(False)
        self.photo_item = ImageItem(self, z_value=-20.0)
        self.overlay_item = ImageItem(self, z_value=-10.0)
        self.overlay_item.set_opacity(0.5)
        self._size: Optional[Tuple[int, int]] = None
        self._extra_layers: List[QgsMapLayer] = []
        self.xyCoordinates.connect(lambda p: self.cursorMoved.emit(*map_to_uv(p)))
        self.readout = QLabel(self)
        self.readout.setObjectName("monoplotPhotoReadout")
        self.readout.setWordWrap(True)
        self.readout.setAttribute(Qt.WidgetAttribute.WA_TransparentForMouseEvents, True)
        self.readout.setStyleSheet("QLabel { background: rgba(255, 255, 255, 215); color: black; padding: 1px 4px; }")
        self.readout.hide()
        self._cursor_y = -1

    # --- content ----------------------------------------------------------------------------------------------
    @property
    def photo_size(self) -> Optional[Tuple[int, int]]:
        """(W, H) of the shown photo in pixels, or None."""
        return self._size

    def set_photo(self, image: Optional[QImage]) -> None:
        """Show ``image`` (already EXIF-oriented) and zoom to it; None clears the canvas."""
        self._size = None if image is None or image.isNull() else (image.width(), image.height())
        self.photo_item.set_image(image)
        self.overlay_item.set_image(None)
        self.zoom_to_photo()

    def set_overlay(self, image: Optional[QImage]) -> None:
        """Show ``image`` (e.g. the DEM rendered from the fitted camera) over the photo, stretched to its size."""
        self.overlay_item.set_image(image, self._size)

    def set_overlay_opacity(self, opacity: float) -> None:
        self.overlay_item.set_opacity(opacity)

    def set_extra_layers(self, layers: List[QgsMapLayer]) -> None:
        """Draw these map layers (pixel-space vector layers, x = u, y = -v) over the photo."""
        self._extra_layers = list(layers)
        self.setLayers(self._extra_layers)
        self.refresh()

    # --- navigation -------------------------------------------------------------------------------------------
    def zoom_to_photo(self) -> None:
        if self._size is None:
            self.setExtent(QgsRectangle(0, -100, 100, 0))
        else:
            w, h = self._size
            self.setExtent(QgsRectangle(0, -h, w, 0).buffered(0.02 * max(w, h)))
        self.refresh()

    def center_on(self, u: float, v: float) -> None:
        """Pan (keeping the scale) so that photo pixel (u, v) is in the middle of the view."""
        self.setCenter(uv_to_map(u, v))
        self.refresh()

    def visible_uv_rect(self) -> Tuple[float, float, float, float]:
        """(u_min, v_min, u_max, v_max) of the visible part of the photo plane."""
        e = self.extent()
        return e.xMinimum(), -e.yMaximum(), e.xMaximum(), -e.yMinimum()

    def set_readout(self, text: str) -> None:
        """Show ``text`` over the bottom edge of the canvas, wrapped to its width; hidden when empty."""
        self.readout.setText(text)
        self.readout.setVisible(bool(text))
        self._place_readout()

    def _place_readout(self) -> None:
        if not self.readout.isVisible():
            return
        before = (self.readout.y(), self.readout.height())
        width = max(50, self.width() - 8)
        self.readout.setFixedWidth(width)
        height = self.readout.heightForWidth(width)
        self.readout.setFixedHeight(height if height > 0 else self.readout.sizeHint().height())
        bottom = self.height() - self.readout.height() - 4
        # at the top while the cursor is on the bottom strip: never over what the cursor points at
        y = 4 if self._cursor_y >= bottom - 8 else bottom
        self.readout.move(4, y)
        self.readout.raise_()
        if (self.readout.y(), self.readout.height()) != before:  # the pair chips float here too: clear of the line
            for chips in self.findChildren(QWidget, "MonoplotChips"):
                chips.keep_clear()

    def mouseMoveEvent(self, event):  # noqa: N802 (Qt API)
        self._cursor_y = event.pos().y()
        super().mouseMoveEvent(event)

    def resizeEvent(self, event):  # noqa: N802 (Qt API)
        """Keep showing the whole photo across resizes (dock floated, splitter moved) unless the user zoomed in."""
        showing_all = self._size is not None and self.extent().contains(
            QgsRectangle(0, -self._size[1], self._size[0], 0))
        super().resizeEvent(event)
        self._place_readout()
        if showing_all:
            QTimer.singleShot(0, self.zoom_to_photo)

    def leaveEvent(self, event):  # noqa: N802 (Qt API)
        self.set_readout("")
        self.cursorLeft.emit()
        super().leaveEvent(event)

    def keyPressEvent(self, event):  # noqa: N802
        if event.key() == Qt.Key.Key_Home:
            self.zoom_to_photo()
            return
        super().keyPressEvent(event)
