"""What the dock shows beside its points (a mixin of :class:`~.dock.MonoplotDock`): the fitted camera's layers on
the main map, the overlay's opacity, residuals and chips on the photo, the linked cursor (a photo pixel's ground on
the map and a map point's pixel on the photo, both also in QGIS's status bar), the dock floated or docked. The dock
provides ``controller``, ``project``, ``iface``, ``photo_canvas``, ``photo_view``, ``map_view``, ``map_mapping``,
``chips``, ``overlayValue`` and ``_unloaded``."""

from __future__ import annotations

import math

from qgis.core import QgsSettings
from qgis.PyQt.QtCore import QTimer

from ..adapters import layers as camera_layers
from .dock_layout import place_floating

__all__ = ["DockViewMixin", "SHOW_CHIPS_KEY"]

#: QgsSettings key: whether the photo shows the chips of the selected point.
SHOW_CHIPS_KEY = "monoplot/show_chips"


class DockViewMixin:
    """Slots of the dock's view widgets and the linked cursor."""

    def _rebuild_camera_layers_later(self) -> None:
        """Replace the camera layers once the event loop runs again: while QGIS is still reading the project
        (``readProject``), removing the layers it has just read leaves a dangling layer in the project's snapping
        settings, and the next Save crashed QGIS (QgsSnappingConfig::writeProject, seen in a desktop trial)."""
        QTimer.singleShot(0, self._camera_layers_reopened)

    def _camera_layers_reopened(self) -> None:
        if self._unloaded:
            return
        # a set-aside automatic camera is not part of the project's state: its layers came back empty (a trial)
        with camera_layers.derived_layers_only(self.project):
            camera_layers.remove_camera_layers(self.project, other=True)
        self._update_camera_layers()

    def _update_camera_layers(self) -> None:
        c = self.controller
        if self._unloaded:
            return
        if c.fitted is None:
            with camera_layers.derived_layers_only(self.project):
                camera_layers.remove_camera_layers(self.project)
            self.map_canvas.refresh()  # else the canvas kept drawing the removed star and footprint (a screenshot)
            return
        if c.dem is None:
            return
        with camera_layers.derived_layers_only(self.project):
            camera_layers.show_camera_layers(self.project, c.fitted, c.footprint_wkt, c.dem_crs)

    def _overlay_opacity(self, value: int) -> None:
        self.overlayValue.setText(f"{value} %")
        self.photo_canvas.set_overlay_opacity(value / 100.0)
        self.controller.set_setting("overlay_opacity", value)

    def _residuals_toggled(self, on: bool) -> None:
        self.photo_view.show_residuals = on
        self.photo_view.redraw_residuals()

    def _chips_toggled(self, on: bool) -> None:
        QgsSettings().setValue(SHOW_CHIPS_KEY, on)
        self.chips.set_wanted(on)

    def _float(self, on: bool) -> None:
        if self.isFloating() != on:
            self.setFloating(on)
            if on:
                place_floating(self)

    def _connect_photo_cursor(self) -> None:
        """The photo's cursor readout and the map's linked cursor; the readout is read again when the camera, its
        verdict or its per-pixel coordinates change under a cursor at rest (a trial's readout still said the
        previous fit's "σ 194.8 px" after a refit to 6.2 px, until the mouse moved)."""
        self._cursor_uv = None
        self.photo_canvas.cursorMoved.connect(self._photo_cursor)
        self.photo_canvas.cursorLeft.connect(self._photo_cursor_left)
        c = self.controller
        for signal in (c.cameraChanged, c.fitInfoChanged, c.productsReady):
            signal.connect(self._reread_photo_cursor)

    def _photo_cursor_left(self) -> None:
        self._cursor_uv = None
        self.map_view.show_cursor(None)

    def _reread_photo_cursor(self) -> None:
        if self._cursor_uv is not None and self.photo_canvas.readout.isVisible():
            self._photo_cursor(*self._cursor_uv)

    def _photo_cursor(self, u: float, v: float) -> None:
        self._cursor_uv = (u, v)
        c = self.controller
        ground = c.ground_at_pixel(u, v)
        self.map_view.show_cursor(None if ground is None else ground[:2])
        # the pixel's column and row (it covers [j, j+1) x [i, i+1)), not the position rounded: a trial read 2994
        # for pixel 2993
        u, v = math.floor(u), math.floor(v)
        if c.fitted is None:
            text = self.tr("photo pixel ({0}, {1})").format(u, v) if c.photo_size else ""
        elif ground is not None:
            # the DEM's CRS named: QGIS's own coordinate box beside it shows the project's (a trial's 3857 project)
            crs = c.dem_crs.authid() if c.dem_crs.isValid() else ""
            text = self.tr("photo pixel ({0}, {1}) → X {2:.1f}  Y {3:.1f}  Z {4:.1f} m").format(
                u, v, *ground) + (f" ({crs})" if crs else "") + self._cursor_error(u + 0.5, v + 0.5)
        elif c.xyz is None:  # just after a fit or a reopen: the per-pixel coordinates are being computed
            text = self.tr("photo pixel ({0}, {1}) → ground coordinates not ready yet").format(u, v)
        else:  # said, not the last ground reading left on show (a trial read it over the sky)
            text = self.tr("photo pixel ({0}, {1}) → no ground (sky, outside the picture or off the DEM)").format(
                u, v)
        self.photo_canvas.set_readout(text)
        if self.iface is not None and c.fitted is not None:
            self.iface.statusBarIface().showMessage("Monoplot: " + text, 4000)

    def _cursor_error(self, u: float, v: float) -> str:
        """"; X, Y ± 56 m, Z ± 4.1 m (check points, at most 10.3 px)" for the cursor readout, "" where the error is not
        known."""
        from ..workflow.products import metres_words

        error = self.controller.ground_error_at_pixel(u, v)
        if error is None:
            return ""
        error_m, error_px, source, height_m = error
        # the height's too (a flood trial's marks were 3-6 m too high with nothing said); not the DEM's own error
        xy = self.tr("X, Y ± {0}").format(metres_words(error_m)) + (
            self.tr(", Z ± {0}").format(metres_words(height_m)) if math.isfinite(height_m) else "")
        # the check points' figure is what so many vouch for, not their RMSE the fit tab shows (features.pixel_error)
        what = {"check": self.tr("check points, at most"), "sigma": self.tr("the camera's σ"),
                "sigma_here": self.tr("the camera's σ here"),
                # a trial read "(fit 23.8 px)" for the leave-one-out error of a fit whose RMSE was 4 px
                "loo": self.tr("fit, each pair left out")}.get(source, self.tr("fit"))
        status = (self.controller.state.fit_info or {}).get("status")
        # a doubtful camera's figure may be far too small: a trial read "± 0.83 m (fit 0.4 px)" 77 m off
        doubt = self.tr("; the camera is {0}: it may be far more").format(status) \
            if status in ("uncertain", "poor") else ""
        fitted = self.controller.fitted
        if fitted is not None and error_px >= math.hypot(*fitted.image_size) - 0.5:
            # an error the picture's size or more, or a move by σ that puts this ground behind the camera: it may be
            # anywhere, and no figure in metres means anything (a trial read "σ here 5000.0 px"; a re-check "± 6.4 m
            # (check points, at most 4561.5 px)" where the ground was 0.5-2.2 km off)
            why = self.tr("check points") if source == "check" else what
            return self.tr("; X, Y, Z not known here ({0}: anywhere in the picture{1})").format(why, doubt)
        return self.tr("; {0} ({1} {2:.1f} px{3})").format(xy, what, error_px, doubt)

    def _map_cursor(self, point) -> None:
        if self.controller.fitted is None or self.controller.dem is None:
            return
        x, y = self.map_mapping.to_space(point)
        uv, where = self.controller.pixel_of_ground(x, y)
        self.photo_view.show_cursor(uv, hidden=(where == "hidden"))
        if self.iface is not None and where:
            text = {"visible": self.tr("visible in the photo at ({0:.0f}, {1:.0f})"),
                    "hidden": self.tr("hidden behind terrain (would be at {0:.0f}, {1:.0f})"),
                    "outside": self.tr("outside the photo")}[where]
            self.iface.statusBarIface().showMessage("Monoplot: " + (text.format(*uv) if uv else text), 4000)

    def _group_visibility(self, *args) -> None:
        """The "Monoplot" layer group unticked hides the dock's items on the map too (points, links, wedge,
        footprint outline, camera), ticked shows them again."""
        group = self.project.layerTreeRoot().findGroup(camera_layers.GROUP_NAME)
        shown = group is None or group.isVisible()
        if shown != self.map_view.shown:
            self.map_view.set_shown(shown)

    def _restored_text(self) -> str:
        c = self.controller
        text = self.tr("Monoplot session restored from the project.")
        if c.restored_source == "unsaved autosave":
            text = self.tr("Monoplot restored the work of a session that ended without its project being saved or "
                           "closed (autosave): save the project to keep it.")
        info = c.state.fit_info or {}
        if c.fitted is not None:
            check, rmse = info.get("check_rmse_px"), info.get("rmse_px")
            figure = self.tr(", check points {0:.1f} px").format(check) if check is not None else \
                self.tr(", RMSE {0:.1f} px").format(rmse) if rmse is not None else ""
            text += " " + self.tr("Fitted camera: {0}{1} (see the fit tab).").format(
                self.tr(str(info.get("status") or "not judged")), figure)
        session = getattr(getattr(self, "output_tools", None), "session", None)
        if session is not None and session.restored_from_autosave:  # its own notice came first: kept in view
            text += " " + (self.tr("The features drawn on the photo came back too.")
                           if c.restored_source == "unsaved autosave" else
                           self.tr("Drawing on the photo done after the project was last saved came back from the "
                                   "autosave."))
        return text
