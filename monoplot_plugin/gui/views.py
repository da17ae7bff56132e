"""Presenters: draw the controller's state on the photo canvas and on the main map canvas (no logic of their own).

PhotoPresenter: photo, overlay, point markers, residual vectors, likely-pair links, outlier rings, the "map cursor"
marker. Both draw only the points on show (``controller.visible``: a few undecided suggestions and the filtered
decided ones), so a click redraws tens of markers, not thousands.
MapPresenter: DEM point markers, prior wedge, fitted footprint, the "photo cursor" marker.
"""

from __future__ import annotations

from typing import Optional, Tuple

from qgis.core import QgsCoordinateReferenceSystem, QgsGeometry, QgsPointXY
from qgis.gui import QgsMapCanvas, QgsVertexMarker
from qgis.PyQt.QtGui import QColor

from ..state import MAP, PHOTO
from . import engine
from .markers import IconBand, LineBand, PointMarkers, PolygonBand
from .photo_canvas import PhotoCanvas, uv_to_map

__all__ = ["PhotoPresenter", "MapPresenter"]


def _cursor_marker(canvas: QgsMapCanvas, color: QColor) -> QgsVertexMarker:
    m = QgsVertexMarker(canvas)
    m.setIconType(QgsVertexMarker.IconType.ICON_CROSS)
    m.setIconSize(26)
    m.setPenWidth(3)
    m.setColor(color)
    m.setZValue(50)
    m.hide()
    return m


class PhotoPresenter:
    def __init__(self, controller, canvas: PhotoCanvas):
        self.c = controller
        self.canvas = canvas
        self.markers = PointMarkers(canvas, to_canvas=uv_to_map)
        self.residuals = LineBand(canvas, QColor(255, 0, 200), width=2, z=30)
        self.check_residuals = LineBand(canvas, QColor(170, 60, 255), width=2, z=31)  # the check points' colour
        self.cursor = _cursor_marker(canvas, QColor(0, 230, 255))
        # a likely partner: from a photo suggestion to where its DEM partner projects under the current camera
        self.links = LineBand(canvas, QColor(0, 230, 255, 200), width=2, z=29)
        self.likely = IconBand(canvas, QColor(0, 230, 255), size=19, width=2, z=28)  # ring: has a likely partner
        self.outliers = IconBand(canvas, QColor(255, 30, 30), size=17, width=3, z=36)
        self.show_residuals = True

    def redraw_photo(self) -> None:
        self.canvas.set_photo(self.c.image)

    def redraw_points(self) -> None:
        self.markers.set_points((p.x, p.y, p.status, p.manual) for p in self.c.visible(PHOTO))
        self.redraw_selection()
        self.redraw_residuals()
        self.redraw_recommendations()

    def redraw_recommendations(self) -> None:
        sl = self.c.shortlist
        self.links.set_segments([(uv_to_map(*a), uv_to_map(*b)) for a, b in sl.links()])
        self.likely.set_points([uv_to_map(p.x, p.y) for p in sl.likely_visible(PHOTO)])
        pts = self.c.state.points
        self.outliers.set_points([uv_to_map(pts[i].x, pts[i].y) for i in sl.current_outliers()])

    def redraw_selection(self) -> None:
        p = self.c.state.points.get(self.c.current[PHOTO])
        self.markers.set_highlight(None if p is None else (p.x, p.y))

    def redraw_residuals(self) -> None:
        segs = self.c.residual_segments() if self.show_residuals else []
        self.residuals.set_segments([(uv_to_map(*a), uv_to_map(*b)) for a, b in segs])
        checks = [(a, b) for _, a, b in self.c.check_residuals()] if self.show_residuals else []
        self.check_residuals.set_segments([(uv_to_map(*a), uv_to_map(*b)) for a, b in checks])

    def redraw_camera(self) -> None:
        self.canvas.set_overlay(self.c.overlay)
        self.redraw_residuals()

    def show_cursor(self, uv: Optional[Tuple[float, float]], hidden: bool = False) -> None:
        if uv is None:
            self.cursor.hide()
            return
        self.cursor.setColor(QColor(150, 150, 150) if hidden else QColor(0, 230, 255))
        self.cursor.setIconType(QgsVertexMarker.IconType.ICON_X if hidden else QgsVertexMarker.IconType.ICON_CROSS)
        self.cursor.setCenter(uv_to_map(*uv))
        self.cursor.show()

    def remove(self) -> None:
        self.markers.remove()
        self.residuals.remove()
        self.check_residuals.remove()
        self.links.remove()
        self.likely.remove()
        self.outliers.remove()
        self.canvas.scene().removeItem(self.cursor)


#: The rough camera's dashed wedge (stroke, fill, width): strong while it is the only camera, faint once a camera is
#: fitted (a trial's wedge, aimed by a guess at the DEM's centre, still pointed 155 deg away from the registered
#: camera and read as where the photo looks).
PRIOR_STYLE = (QColor(255, 170, 0), QColor(255, 170, 0, 40), 2)
PRIOR_STYLE_FITTED = (QColor(255, 170, 0, 110), QColor(255, 170, 0, 0), 1)


class MapPresenter:
    def __init__(self, controller, canvas: QgsMapCanvas):
        self.c = controller
        self.canvas = canvas
        self.markers = PointMarkers(canvas, crs=QgsCoordinateReferenceSystem())
        self.prior_band = PolygonBand(canvas, *PRIOR_STYLE, z=8, dashed=True)
        # outline only: the footprint layer in the project carries the fill
        self.fitted_band = PolygonBand(canvas, QColor(40, 130, 255), QColor(40, 130, 255, 0), width=2, z=9)
        self.camera_marker = _cursor_marker(canvas, QColor(255, 40, 40))
        self.camera_marker.setIconType(QgsVertexMarker.IconType.ICON_CIRCLE)
        self.camera_marker.setIconSize(14)
        self.cursor = _cursor_marker(canvas, QColor(0, 230, 255))
        self.likely = IconBand(canvas, QColor(0, 230, 255), size=19, width=2, z=28)  # ring: has a likely partner
        #: False while the person hides the "Monoplot" layer group: its canvas items go with it (a trial unticked
        #: the group to check exported layers, and the wedge, footprint outline and markers stayed drawn)
        self.shown = True

    @property
    def crs(self) -> QgsCoordinateReferenceSystem:
        return self.c.dem_crs

    def set_shown(self, shown: bool) -> None:
        """Show or hide every Monoplot item on the map (points, links, wedge, footprint outline, camera)."""
        self.shown = bool(shown)
        self._apply_shown()

    def _apply_shown(self) -> None:
        for item in (self.markers, self.likely, self.prior_band, self.fitted_band):
            item.set_visible(self.shown)
        if not self.shown:
            self.camera_marker.hide()
        elif self.c.fitted is not None or self.c.prior is not None:  # where the last redraw put it
            self.camera_marker.show()

    def _to_canvas(self, x: float, y: float) -> QgsPointXY:
        from .tools import SpaceMapping

        return SpaceMapping(self.canvas, MAP, self.crs).to_canvas(x, y)

    def redraw_points(self) -> None:
        self.markers.crs = self.crs
        self.prior_band.crs = self.fitted_band.crs = self.crs
        self.markers.set_points((p.x, p.y, p.status, p.manual) for p in self.c.visible(MAP))
        self.likely.crs = self.crs
        self.likely.set_points([QgsPointXY(p.x, p.y) for p in self.c.shortlist.likely_visible(MAP)])
        self.redraw_selection()
        if not self.shown:
            self._apply_shown()

    def redraw_selection(self) -> None:
        p = self.c.state.points.get(self.c.current[MAP])
        self.markers.set_highlight(None if p is None or not self.shown else (p.x, p.y))

    def reach(self, cx: float, cy: float) -> float:
        """Metres from (cx, cy) to the farthest DEM corner: how far a view wedge is drawn (15 km without DEM)."""
        dem = self.c.dem
        if dem is None:
            return 15000.0
        x0, y0, x1, y1 = dem.bounds()
        return max(((x - cx) ** 2 + (y - cy) ** 2) ** 0.5 for x in (x0, x1) for y in (y0, y1))

    def show_wedge(self, camera) -> None:
        """Draw the horizontal field of view of ``camera`` (DEM CRS) as the dashed prior wedge."""
        self.prior_band.crs = self.crs
        if camera is None:
            self.prior_band.set_geometry(None)
            return
        x, y = camera.position[:2]
        ground = float(self.c.dem.sample(x, y)) if self.c.dem is not None else float("nan")
        reach = engine.wedge_reach(camera, ground, self.reach(x, y))
        self.prior_band.set_geometry(QgsGeometry.fromPolygonXY(
            [[QgsPointXY(px, py) for px, py in engine.view_wedge(camera, reach)]]))

    def redraw_camera(self, fitted_footprint_wkt: str = "") -> None:
        self.prior_band.crs = self.fitted_band.crs = self.crs
        prior, fitted = self.c.prior, self.c.fitted
        self.prior_band.set_style(*(PRIOR_STYLE if fitted is None else PRIOR_STYLE_FITTED))
        self.show_wedge(prior)
        self.fitted_band.set_geometry(QgsGeometry.fromWkt(fitted_footprint_wkt) if fitted_footprint_wkt else None)
        cam = fitted or prior
        if cam is None:
            self.camera_marker.hide()
        else:
            self.camera_marker.setCenter(self._to_canvas(*cam.position[:2]))
            self.camera_marker.show()
        if not self.shown:
            self._apply_shown()

    def show_cursor(self, xy: Optional[Tuple[float, float]]) -> None:
        if xy is None:
            self.cursor.hide()
            return
        self.cursor.setCenter(self._to_canvas(*xy))
        self.cursor.show()

    def remove(self) -> None:
        self.markers.remove()
        self.likely.remove()
        self.prior_band.remove()
        self.fitted_band.remove()
        for item in (self.camera_marker, self.cursor):
            if item.scene() is not None:
                item.scene().removeItem(item)
