"""Point markers, residual vectors and footprints drawn as rubber bands on any QgsMapCanvas.

One rubber band per visual style (suggested / accepted / rejected / manual / check) keeps hundreds of points cheap
to draw; a redraw rebuilds only the bands whose points changed (a click changes one or two).
Coordinates are given in a source CRS (the DEM's for the main map) or, for the photo canvas, already in canvas
coordinates (``crs=None``).
"""

from __future__ import annotations

from typing import Dict, Iterable, Optional, Sequence, Tuple

from qgis.core import (QgsCoordinateReferenceSystem, QgsGeometry, QgsPointXY, QgsProject, QgsWkbTypes)
from qgis.gui import QgsMapCanvas, QgsRubberBand, QgsVertexMarker
from qgis.PyQt.QtCore import Qt
from qgis.PyQt.QtGui import QColor

from ..state import ACCEPTED, CHECK, REJECTED, SUGGESTED

__all__ = ["PointMarkers", "LineBand", "IconBand", "PolygonBand", "STYLE_COLORS"]

Icon = QgsRubberBand.IconType
#: style key -> (icon, size, stroke colour, fill colour, halo colour)
_STYLES = {
    SUGGESTED: (Icon.ICON_CIRCLE, 9, QColor(255, 214, 0), QColor(255, 214, 0, 60), QColor(0, 0, 0, 200)),
    ACCEPTED: (Icon.ICON_FULL_BOX, 7, QColor(0, 200, 80), QColor(0, 200, 80), QColor(255, 255, 255, 230)),
    "manual": (Icon.ICON_FULL_DIAMOND, 11, QColor(0, 170, 255), QColor(0, 170, 255), QColor(255, 255, 255, 230)),
    # faint: after a curation most suggestions are rejected, and they must not hide the accepted ones
    REJECTED: (Icon.ICON_X, 5, QColor(230, 40, 40, 110), QColor(230, 40, 40, 0), QColor(0, 0, 0, 0)),
    CHECK: (Icon.ICON_CROSS, 13, QColor(170, 60, 255), QColor(170, 60, 255), QColor(255, 255, 255, 230)),
}
STYLE_COLORS = {key: style[2] for key, style in _STYLES.items()}
#: More accepted points than this in one view (an automatic registration's 200) are drawn as small hollow squares:
#: the full ones covered the skyline and the silhouettes the person had to judge them by.
CROWDED = 60


def _style_key(status: str, manual: bool) -> str:
    return "manual" if manual and status == ACCEPTED else status


class PointMarkers:
    """Curated points of one space on one canvas, styled by status, plus a highlight for the current point."""

    def __init__(self, canvas: QgsMapCanvas, crs: Optional[QgsCoordinateReferenceSystem] = None,
                 to_canvas=None):
        """``crs``: CRS of the coordinates passed to :meth:`set_points` (None = canvas coordinates).
        ``to_canvas(x, y) -> QgsPointXY``: optional conversion applied first (the photo canvas's ``uv_to_map``)."""
        self.canvas = canvas
        self.crs = crs
        self.to_canvas = to_canvas or (lambda x, y: QgsPointXY(x, y))
        self.bands: Dict[str, QgsRubberBand] = {}
        self._drawn: Dict[str, tuple] = {}  # style key -> the (x, y) tuple drawn, to skip unchanged bands
        # rejected below suggested below accepted: the decisions the user made stay readable
        for z, key in enumerate((REJECTED, SUGGESTED, ACCEPTED, "manual", CHECK)):
            icon, size, stroke, fill, halo = _STYLES[key]
            band = QgsRubberBand(canvas, QgsWkbTypes.GeometryType.PointGeometry)
            band.setIcon(icon)
            band.setIconSize(size)
            band.setColor(stroke)
            band.setFillColor(fill)
            band.setStrokeColor(stroke)
            band.setSecondaryStrokeColor(halo)
            band.setWidth(2)
            band.setZValue(20 + z)
            self.bands[key] = band
        self.highlight = QgsVertexMarker(canvas)
        self.highlight.setIconType(QgsVertexMarker.IconType.ICON_BOX)
        self.highlight.setIconSize(22)
        self.highlight.setPenWidth(3)
        self.highlight.setColor(QColor(0, 230, 255))
        self.highlight.setZValue(40)
        self.highlight.hide()

    def set_points(self, points: Iterable[Tuple[float, float, str, bool]]) -> None:
        """Redraw from ``(x, y, status, manual)`` tuples."""
        groups: Dict[str, list] = {key: [] for key in self.bands}
        for x, y, status, manual in points:
            groups[_style_key(status, manual)].append((x, y))
        # the canvas's CRS too: a rubber band is transformed once, when set (a trial changed the project's CRS and
        # every point marker stayed at its old canvas coordinates, 5,000 km off, while the camera was redrawn)
        crs_key = (self.crs.authid() if self.crs is not None else "",
                   self.canvas.mapSettings().destinationCrs().toWkt())
        for key, band in self.bands.items():
            drawn = (crs_key, tuple(groups[key]))
            if self._drawn.get(key) == drawn:
                continue
            self._drawn[key] = drawn
            if key == ACCEPTED:
                crowded = len(groups[key]) > CROWDED
                band.setIcon(Icon.ICON_BOX if crowded else _STYLES[key][0])
                band.setIconSize(5 if crowded else _STYLES[key][1])
            pts = [self.to_canvas(x, y) for x, y in groups[key]]
            if not pts:
                band.reset(QgsWkbTypes.GeometryType.PointGeometry)
                continue
            geom = QgsGeometry.fromMultiPointXY(pts)
            band.setToGeometry(geom, self.crs or QgsCoordinateReferenceSystem())

    def set_highlight(self, xy: Optional[Tuple[float, float]]) -> None:
        if xy is None:
            self.highlight.hide()
            return
        pt = self.to_canvas(*xy)
        if self.crs is not None:
            pt = _transform(pt, self.crs, self.canvas)
        self.highlight.setCenter(pt)
        self.highlight.show()

    def set_visible(self, visible: bool) -> None:
        for band in self.bands.values():
            band.setVisible(visible)
        if not visible:
            self.highlight.hide()

    def remove(self) -> None:
        """Take every item off the canvas (plugin unload)."""
        scene = self.canvas.scene()
        for item in list(self.bands.values()) + [self.highlight]:
            if scene is not None and item.scene() is scene:
                scene.removeItem(item)
        self.bands.clear()


def _transform(pt: QgsPointXY, crs: QgsCoordinateReferenceSystem, canvas: QgsMapCanvas) -> QgsPointXY:
    from qgis.core import QgsCoordinateTransform

    dest = canvas.mapSettings().destinationCrs()
    if not crs.isValid() or not dest.isValid() or crs == dest:
        return pt
    return QgsCoordinateTransform(crs, dest, QgsProject.instance()).transform(pt)


class _Band:
    def __init__(self, canvas: QgsMapCanvas, kind, color: QColor, width: float, z: float,
                 crs: Optional[QgsCoordinateReferenceSystem] = None, fill: Optional[QColor] = None,
                 dashed: bool = False):
        self.canvas = canvas
        self.kind = kind
        self.crs = crs
        self.band = QgsRubberBand(canvas, kind)
        self.band.setColor(color)
        self.band.setStrokeColor(color)
        self.band.setFillColor(fill if fill is not None else QColor(0, 0, 0, 0))
        self.band.setWidth(int(round(width)))
        self.band.setZValue(z)
        if dashed:
            self.band.setLineStyle(Qt.PenStyle.DashLine)

    def set_geometry(self, geom: Optional[QgsGeometry]) -> None:
        if geom is None or geom.isEmpty():
            self.band.reset(self.kind)
        else:
            self.band.setToGeometry(geom, self.crs or QgsCoordinateReferenceSystem())

    def set_visible(self, visible: bool) -> None:
        self.band.setVisible(visible)

    def set_style(self, color: QColor, fill: Optional[QColor] = None, width: Optional[float] = None) -> None:
        """Restroke (and refill) the band: the same geometry drawn stronger or fainter."""
        self.band.setColor(color)
        self.band.setStrokeColor(color)
        if fill is not None:
            self.band.setFillColor(fill)
        if width is not None:
            self.band.setWidth(int(round(width)))

    def remove(self) -> None:
        scene = self.canvas.scene()
        if scene is not None and self.band.scene() is scene:
            scene.removeItem(self.band)


class LineBand(_Band):
    """Line segments (residual vectors, view rays) on a canvas."""

    def __init__(self, canvas, color: QColor, width: float = 2, z: float = 15, crs=None, dashed=False):
        super().__init__(canvas, QgsWkbTypes.GeometryType.LineGeometry, color, width, z, crs, dashed=dashed)

    def set_segments(self, segments: Sequence[Tuple[QgsPointXY, QgsPointXY]]) -> None:
        self.set_geometry(QgsGeometry.fromMultiPolylineXY([[a, b] for a, b in segments]) if segments else None)


class IconBand(_Band):
    """Points drawn with one icon (e.g. the red rings of the fit's outliers) on a canvas."""

    def __init__(self, canvas, color: QColor, icon=Icon.ICON_CIRCLE, size: int = 15, width: float = 3,
                 z: float = 35, crs=None):
        super().__init__(canvas, QgsWkbTypes.GeometryType.PointGeometry, color, width, z, crs)
        self.band.setIcon(icon)
        self.band.setIconSize(size)

    def set_points(self, points: Sequence[QgsPointXY]) -> None:
        self.set_geometry(QgsGeometry.fromMultiPointXY(list(points)) if points else None)


class PolygonBand(_Band):
    """A translucent polygon (view footprint) on a canvas."""

    def __init__(self, canvas, color: QColor, fill: QColor, width: float = 2, z: float = 10, crs=None,
                 dashed=False):
        super().__init__(canvas, QgsWkbTypes.GeometryType.PolygonGeometry, color, width, z, crs, fill, dashed)
