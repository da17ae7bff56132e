"""Monoplot's dock: wires the widgets of ``ui/dock.ui`` to :class:`MonoplotController` and the presenters.

Extension points (used by the outputs issue):
    dock.controller ............ state, photo, DEM, fitted camera, per-pixel XYZ (``controller.xyz``), signals
    dock.photo_canvas .......... QgsMapCanvas in pixel space (x = u, y = -v; see photo_canvas.uv_to_map)
    dock.add_photo_tool(action, map_tool)   a checkable action in the photo bar that switches the photo canvas
                                            to ``map_tool``; unchecking returns to point curation
    dock.add_output_action(action)          a button in the "Fit and results" tab (e.g. "Export XYZ raster")
"""

from __future__ import annotations

import math
import os
from typing import Optional

from qgis.core import Qgis, QgsApplication, QgsMapLayerProxyModel, QgsProject, QgsRasterLayer, QgsSettings
from qgis.PyQt import uic
from qgis.PyQt.QtCore import QItemSelectionModel, QTimer
from qgis.PyQt.QtWidgets import QDockWidget, QToolBar

from .. import PLUGIN_DIR
from ..core.camera import azimuth
from ..state import MAP, PHOTO
from .chips import ChipView
from .controller import MonoplotController
from .auto_panel import install_auto_panel
from .curation_panel import MessageOnce, install_curation_panel
from .dock_layout import (fit_minimum_width, lay_out, narrow_tabs, scroll_camera_tab, scroll_points_tab,
                          show_status, split_photo_and_tabs)
from .fit_settings import FitSettingsPanel, LensPanel
from . import persistence, photo_change, photo_shelf
from .photo_names import photo_label
from .io_actions import IoActions
from .number_entry import accept_both_separators
from .undo_keys import install_undo_keys
from .photo_canvas import PhotoCanvas
from .point_table import ID_ROLE, PointTableModel, make_proxy
from .rough_camera import RoughCameraMixin
from .dock_extensions import DockExtensionsMixin
from .dock_view import SHOW_CHIPS_KEY, DockViewMixin
from .summary import fit_summary_html
from .tools import CurationTool, RoughCameraTool, SpaceMapping
from .views import MapPresenter, PhotoPresenter

FORM_CLASS, _ = uic.loadUiType(str(PLUGIN_DIR / "ui" / "dock.ui"))
#: QgsSettings key (the plugin's "monoplot/" prefix) of the number of suggestions per view.
SUGGESTION_COUNT_KEY = "monoplot/suggestions_per_view"
#: The DEM overlay's opacity in a project that has none: three desktop trials found the photo grey and flat at 50 %
#: (a flood line's colour washed out while it was drawn); the rendered relief still shows over it at 35 %.
DEFAULT_OVERLAY_PERCENT = 35


class MonoplotDock(RoughCameraMixin, DockViewMixin, DockExtensionsMixin, QDockWidget, FORM_CLASS):
    """The plugin's main panel, docked on the right of the QGIS window."""

    def __init__(self, iface, parent=None, project: Optional[QgsProject] = None):
        super().__init__(parent)
        self.iface = iface
        self.setupUi(self)
        self.setObjectName("MonoplotDock")  # QMainWindow.saveState() needs a stable name
        self.project = project or QgsProject.instance()
        self.controller = c = MonoplotController(self.project, self)
        self.map_canvas = iface.mapCanvas()

        # photo canvas and its default tool
        self.photo_canvas = PhotoCanvas(self.photoHolder)
        self.photoHolder.layout().addWidget(self.photo_canvas)
        self.photo_tool = CurationTool(self.photo_canvas, c, SpaceMapping(self.photo_canvas, PHOTO))
        self.photo_canvas.setMapTool(self.photo_tool)
        self.photo_view = PhotoPresenter(c, self.photo_canvas)
        self.map_view = MapPresenter(c, self.map_canvas)
        self.map_mapping = SpaceMapping(self.map_canvas, MAP)
        self.map_tool = CurationTool(self.map_canvas, c, self.map_mapping)
        self.camera_tool = RoughCameraTool(self.map_canvas, self.map_mapping)
        self._photo_tools = []
        self._photo_toolbar: Optional[QToolBar] = None

        # inputs
        self.demCombo.setFilters(QgsMapLayerProxyModel.Filter.RasterLayer)
        self.demCombo.setAllowEmptyLayer(True)
        self.demCombo.setLayer(None)
        self.photoFile.fileChanged.connect(self._photo_chosen)
        self.photoFile.lineEdit().editingFinished.connect(self._photo_path_typed)
        self.demCombo.layerChanged.connect(self._dem_chosen)

        self._connect_camera_widgets(c)  # gui/rough_camera.py

        # points
        # how many suggestions: a user preference (QgsSettings), not part of the project
        count = QgsSettings().value(SUGGESTION_COUNT_KEY, self.suggestCountSpin.value(), type=int)
        self.suggestCountSpin.setValue(count)
        self.suggestCountSpin.valueChanged.connect(lambda n: QgsSettings().setValue(SUGGESTION_COUNT_KEY, n))
        self.suggestButton.clicked.connect(
            lambda: c.suggest(self.suggestCountSpin.value(), self.suggestCountSpin.value()))
        self.mapToolButton.toggled.connect(self._toggle_map_tool)
        self.acceptViewButton.clicked.connect(self.accept_all_in_view)
        self.resetButton.clicked.connect(lambda: c.reset_statuses())
        # what an undo took back is said in the status line: the stack holds point edits only, and an Undo pressed
        # after drawing took back a GCP import without a word
        self.undoButton.clicked.connect(lambda: self._said(c.undo()))
        self.redoButton.clicked.connect(lambda: self._said(c.redo()))
        # Ctrl+Z / Ctrl+Shift+Z (Ctrl+Y) with the focus in the tabs too, not only on the photo (a keyboard trial's
        # Ctrl+Z in the point table did nothing); a box being typed in keeps its own undo (gui/undo_keys.py)
        self._undo_keys = install_undo_keys(self.stepTabs, self.undoButton, self.redoButton)
        self.photo_tool.on_undo = self.map_tool.on_undo = self._said
        # the Points tab's clicks curate: a drawing tool left on would take them (gui/dock_extensions.py)
        self.stepTabs.currentChanged.connect(
            lambda index: self.stepTabs.widget(index) is self.pointsTab and self.end_photo_tools())
        self.table_model = PointTableModel(c.state, self)
        self.table_proxy = make_proxy(self.table_model, self)
        self.pointTable.setModel(self.table_proxy)
        self.pointTable.clicked.connect(self._table_clicked)
        lay_out(self)  # table, size policies, stretches, minimum sizes (gui/dock_layout.py)
        self._sized = False

        # fit and view
        self.fitButton.clicked.connect(lambda: c.fit())
        self.cancelButton.clicked.connect(c.cancel)
        self.overlaySlider.valueChanged.connect(self._overlay_opacity)
        self.residualsCheck.toggled.connect(self._residuals_toggled)
        self.zoomPhotoButton.clicked.connect(self.photo_canvas.zoom_to_photo)
        self.floatButton.toggled.connect(self._float)
        self.topLevelChanged.connect(self.floatButton.setChecked)
        # the button says what it does next: "Dock" while the window floats
        self.topLevelChanged.connect(lambda floating: self.floatButton.setText(
            self.tr("Dock") if floating else self.tr("Float")))

        # controller -> widgets
        c.photoChanged.connect(self._on_photo)
        c.demChanged.connect(self._on_dem)
        c.pointsChanged.connect(self._on_points)
        c.selectionChanged.connect(self._on_selection)
        c.cameraChanged.connect(self._on_camera)
        c.busyChanged.connect(self._on_busy)
        c.progressChanged.connect(lambda p: self.progressBar.setValue(int(p)))
        c.message.connect(self.show_message)
        c.taskFinished.connect(self._on_task_finished)
        c.productsReady.connect(self._update_camera_layers)  # a reopened project's footprint, rendered in a task
        c.fitInfoChanged.connect(lambda: self.resultLabel.setText(self._result_text()))  # check points measured

        # linked cursors
        self._connect_photo_cursor()  # gui/dock_view.py
        self.map_canvas.xyCoordinates.connect(self._map_cursor)
        # canvas items keep map coordinates of the CRS they were drawn in: draw them again when it changes (QGIS
        # takes the project's CRS from the first layer added a moment later: a wedge drawn in between was lost)
        self.map_canvas.destinationCrsChanged.connect(self._map_crs_changed)

        # project life cycle
        self.project.readProject.connect(self._project_read)
        self.project.cleared.connect(self._project_cleared)
        self.project.projectSaved.connect(self._project_saved_status)
        self.project.layersRemoved.connect(self._dem_layer_removed)
        self.project.removeAll.connect(self._all_layers_removed)
        self._removing_all = False
        self.project.layerTreeRoot().visibilityChanged.connect(self._group_visibility)
        self._unloaded = False
        QgsApplication.instance().aboutToQuit.connect(self.unload)
        self.output_tools = self._install_outputs()
        self.auto_panel = install_auto_panel(self)  # issue 13: "Find camera automatically"
        self.curation_panel = install_curation_panel(self)  # few at a time, bulk actions, live refit
        self.io_actions = IoActions(self)  # camera files, GCP tables and point layers (gui/io_actions.py)
        self.lens_panel = LensPanel(c, self.fovSpin, self.cameraTab)  # what the user knows (gui/fit_settings.py)
        self.cameraTabLayout.insertWidget(self.cameraTabLayout.indexOf(self.cameraSummary), self.lens_panel)
        self.fit_settings = FitSettingsPanel(c, self.fitScrollContents)
        self.chips = ChipView(c, self.photo_canvas)  # photo | DEM chips of the selected point (gui/chips.py)
        # the chips on or off: a user preference (QgsSettings), not part of the project
        self.chipsCheck.setChecked(QgsSettings().value(SHOW_CHIPS_KEY, True, type=bool))
        self.chips.set_wanted(self.chipsCheck.isChecked())
        self.chipsCheck.toggled.connect(self._chips_toggled)
        self.fitTabLayout.insertWidget(self.fitTabLayout.indexOf(self.resultLabel) + 1, self.fit_settings)
        scroll_points_tab(self)
        narrow_tabs(self)
        scroll_camera_tab(self)
        self._decimal_keys = accept_both_separators(self)  # "63.25" typed in a German locale gave 63
        fit_minimum_width(self)
        restored = (bool(self.project.readEntry("monoplot", "/state", "")[1]) or
                    persistence.unsaved_work_left(self.project)) and c.restore()
        if restored and self.output_tools is not None:  # opened by the project's read: its signal came before us
            self.output_tools.refill_other_photos()
        if restored and c.fitted is not None:
            # a dock opened on an already open project (or while one is read): its camera layers came back empty
            # from the file
            self._rebuild_camera_layers_later()
        self._apply_settings()  # a dock opened on an already open project shows its saved overlay opacity
        self._on_points(set())
        self._on_busy("")
        self._on_camera()
        if restored:  # the plugin opens the dock when a project with Monoplot work is read: say what came back
            show_status(self.statusLabel, self._restored_text())

    def _install_outputs(self):
        """Digitising tools and export buttons of the outputs package (optional: a failure is logged, not fatal)."""
        try:
            from .product_panel import install_output_tools

            return install_output_tools(self)
        except Exception:  # noqa: BLE001 — the curation and fit must stay usable
            import traceback

            from qgis.core import QgsMessageLog

            QgsMessageLog.logMessage(traceback.format_exc(), "Monoplot", Qgis.MessageLevel.Warning)
            return None

    # --- messages ---------------------------------------------------------------------------------------------
    def show_message(self, text: str, level=Qgis.MessageLevel.Info) -> None:
        """Message bar (never a traceback); also the dock's status line, cut to about three lines there (the
        whole text in its tool tip and in the message log)."""
        show_status(self.statusLabel, text)
        bar = self.iface.messageBar() if self.iface is not None else None
        if bar is not None:  # once: the previous Monoplot message leaves the bar (no replay of old ones)
            duration = 0 if level == Qgis.MessageLevel.Critical else 6
            self.__dict__.setdefault("_messages", MessageOnce()).push(bar, self.tr("Monoplot"), text, level, duration)

    def _said(self, text: str) -> None:
        """``text`` in the status line only (no message bar for every undo); the last message in the bar spoke of
        the state before, so it goes."""
        if text:
            self.message_is_stale()
            self.statusLabel.setText(text)

    def message_is_stale(self) -> None:
        """The state the last message spoke of has changed (an edit, an undo): off the status line, and off the
        message bar unless it came just now (the edit's own)."""
        self.statusLabel.clear()
        bar = self.iface.messageBar() if self.iface is not None else None
        if bar is not None and "_messages" in self.__dict__:
            self._messages.clear(bar, older_than_s=0.5)

    # --- inputs -----------------------------------------------------------------------------------------------
    def _photo_chosen(self, path: str) -> None:
        # the file widget reports every keystroke of a typed path: act once it names an existing file
        c = self.controller
        if path and path != c.state.photo_path and os.path.isfile(path):
            work = photo_change.work_on_photo(c) if c.image is not None else ""
            # read before asking: a truncated JPEG was offered "Keep the points", then refused (a trial)
            image = c.read_photo(path) if work else None
            answer = None if work and image is None else photo_change.ask_photo_change(
                self, photo_label(c.project, path), work, photo_change.same_size(path, c),
                photo_shelf.waiting(c.project, path)) if work else photo_change.AFRESH
            if answer is None:  # keep the current photo: the box shows it again
                self.photoFile.blockSignals(True)
                self.photoFile.setFilePath(c.state.photo_path or "")
                self.photoFile.blockSignals(False)
                return
            c.load_photo(path, keep_points=answer == photo_change.KEEP, image=image)

    def _photo_path_typed(self) -> None:
        """Enter (or leaving the box) on a typed path that names no file: say so instead of doing nothing."""
        path = self.photoFile.filePath().strip()
        if path and not os.path.isfile(path):
            self.show_message(self.tr("No photo file at {0}").format(path), Qgis.MessageLevel.Warning)

    def _dem_chosen(self, layer) -> None:
        if isinstance(layer, QgsRasterLayer) and (self.controller.dem_layer is None
                                                 or layer.id() != self.controller.dem_layer.id()):
            if layer.crs().isGeographic():
                self.show_message(self.tr("The DEM is in degrees: Monoplot reprojects it to UTM metres."),
                                  Qgis.MessageLevel.Info)
            if not self.controller.set_dem_layer(layer) and not self.controller.busy:
                # refused (the message says why): the box shows the DEM still in use again, not the refused layer
                # (a trial's box showed a photo refused as DEM while the previous DEM was used)
                self._on_dem()

    def _on_photo(self) -> None:
        self.photo_view.redraw_photo()
        fov = self.controller.exif_fov()
        if fov is not None and self.controller.prior is None:
            self.fovSpin.setValue(fov)
        path = self.controller.state.photo_path
        if self.photoFile.filePath() != path:  # also cleared with the project: no stale path in the box
            self.photoFile.blockSignals(True)
            self.photoFile.setFilePath(path)
            self.photoFile.blockSignals(False)
        size = self.controller.photo_size
        if size is not None:  # replaces e.g. the error of a previous, unreadable file
            self.statusLabel.setText(self.tr("Photo: {0} ({1} × {2} px)").format(os.path.basename(path), *size))

    def _on_dem(self) -> None:
        layer = self.controller.dem_layer
        if self.demCombo.currentLayer() is not layer:
            self.demCombo.blockSignals(True)
            self.demCombo.setLayer(layer)
            self.demCombo.blockSignals(False)
        self.map_mapping.crs = self.controller.dem_crs
        self.map_view.redraw_points()

    # --- camera -----------------------------------------------------------------------------------------------
    def _on_camera(self) -> None:
        c = self.controller
        prior, fitted = c.prior, c.fitted
        shown = prior if prior is not None else fitted  # a fitted camera alone: its lens and pitch, not 60° and 0°
        if shown is not None:
            for spin, value in ((self.fovSpin, shown.fov), (self.pitchSpin, shown.pitch),
                                (self.headingSpin, azimuth(shown.heading))):
                spin.blockSignals(True)
                spin.setValue(value)
                spin.blockSignals(False)
        if prior is not None:
            x, y, z = prior.position
            self.cameraSummary.setText(self.tr(
                "Rough camera: X {0:.0f}  Y {1:.0f}  Z {2:.0f} m, heading {3:.1f}°, pitch {4:.1f}°, "
                "field of view {5:.1f}°").format(x, y, z, azimuth(prior.heading), prior.pitch, prior.fov))
        elif fitted is not None:  # a fitted camera loaded from a file or a project: said, not "no camera"
            self.cameraSummary.setText(self.tr(
                "A fitted camera is loaded (see the fit tab); no rough camera. Draw or import one only to suggest "
                "points from it."))
        else:
            self.cameraSummary.setText(self.tr("No rough camera yet: draw it on the map, import a KML, or take it "
                                               "From EXIF (a photo with GPS tags)."))
        self.map_view.redraw_camera(c.footprint_wkt if fitted is not None else "")
        self.photo_view.redraw_camera()
        self.photo_view.canvas.set_overlay_opacity(self.overlaySlider.value() / 100.0)
        self.resultLabel.setText(self._result_text())
        self.table_model.refresh(self._residual_by_id())

    def _result_text(self) -> str:
        c = self.controller
        return fit_summary_html(c.fitted, c.state.fit_info, self.tr, points_changed=c.fit_points_changed())

    def _residual_by_id(self):
        """Residual length (px) per matched photo point id and per check point, for the table."""
        c = self.controller
        return {pid: math.hypot(b[0] - a[0], b[1] - a[1]) for pid, a, b in c.residuals() + c.check_residuals()}

    # --- points -----------------------------------------------------------------------------------------------
    def _toggle_map_tool(self, on: bool) -> None:
        if on:
            self.drawCameraButton.setChecked(False)
            self.map_canvas.setMapTool(self.map_tool)
        elif self.map_canvas.mapTool() is self.map_tool:
            self.map_canvas.unsetMapTool(self.map_tool)

    def accept_all_in_view(self) -> int:
        """Accept every suggestion visible on the photo canvas and on the main map."""
        from qgis.core import QgsPointXY

        e = self.map_canvas.extent()
        corners = [self.map_mapping.to_space(QgsPointXY(x, y)) for x in (e.xMinimum(), e.xMaximum())
                   for y in (e.yMinimum(), e.yMaximum())]
        xs, ys = [p[0] for p in corners], [p[1] for p in corners]
        n = self.controller.accept_all_in_views({PHOTO: self.photo_canvas.visible_uv_rect(),
                                                 MAP: (min(xs), min(ys), max(xs), max(ys))})
        self.show_message(self.tr("{0} suggestions accepted.").format(n))
        return n

    def _on_points(self, changed) -> None:
        self.photo_view.redraw_points()
        self.map_view.redraw_points()
        self.table_model.refresh(self._residual_by_id())  # the counts: the curation panel's (curation_panel.py)
        st = self.controller.stack
        self.undoButton.setEnabled(st.can_undo())
        self.redoButton.setEnabled(st.can_redo())
        self.undoButton.setToolTip(" ".join(self.tr("Undo {0} (Ctrl+Z)").format(st.undo_text()).split()))
        if self.controller.fitted is not None:  # "the points changed since this fit", or no longer
            self.resultLabel.setText(self._result_text())

    def _on_selection(self, space: str, pid: str) -> None:
        view = self.photo_view if space == PHOTO else self.map_view
        view.redraw_selection()
        partner = self.controller.state.partner(pid) if pid else None
        if partner:  # a paired point brings its partner along on the other canvas
            other = MAP if space == PHOTO else PHOTO
            self.controller.current[other] = partner
            (self.map_view if other == MAP else self.photo_view).redraw_selection()
        p = self.controller.state.points.get(pid)
        if p is not None and space == PHOTO:
            u0, v0, u1, v1 = self.photo_canvas.visible_uv_rect()
            if not (u0 <= p.x <= u1 and v0 <= p.y <= v1):
                self.photo_canvas.center_on(p.x, p.y)
        row = self.table_model.row_of(pid)
        if row >= 0:
            index = self.table_proxy.mapFromSource(self.table_model.index(row, 0))
            self.pointTable.selectionModel().select(
                index, QItemSelectionModel.SelectionFlag.ClearAndSelect | QItemSelectionModel.SelectionFlag.Rows)
            self.pointTable.scrollTo(index)

    def _table_clicked(self, index) -> None:
        pid = self.table_proxy.data(index, ID_ROLE)
        p = self.controller.state.points.get(pid)
        if p is None:
            return
        self.controller.select(p.space, pid)
        if p.space == PHOTO:
            self.photo_canvas.center_on(p.x, p.y)
        else:
            self.map_canvas.setCenter(self.map_mapping.to_canvas(p.x, p.y))
            self.map_canvas.refresh()

    # --- task -------------------------------------------------------------------------------------------------
    def _on_busy(self, description: str) -> None:
        busy = bool(description)
        for w in (self.suggestButton, self.fitButton):
            w.setEnabled(not busy)
        if getattr(self, "auto_panel", None) is not None:  # a second click said "busy (auto)" over the progress
            self.auto_panel.action.setEnabled(not busy)
        self.cancelButton.setEnabled(busy)
        # the task row sits under the tabs (ui/dock.ui), visible while a task runs whichever tab is open: in the
        # fit tab, the progress and Cancel of "Suggest points" were out of sight on the points tab
        self.progressBar.setVisible(busy)
        self.cancelButton.setVisible(busy)
        if busy:
            self.statusLabel.setText(self.tr("{0}…").format(description))  # not a stale message of before
            bar = self.iface.messageBar() if self.iface is not None else None
            if bar is not None and "_messages" in self.__dict__:  # nor in the message bar, during the task
                self._messages.clear(bar, older_than_s=0.5)
            # then what the step is doing, as it goes (a registration sat at 0 % for seconds with no word)
            self.controller.task.stageChanged.connect(lambda stage, d=description: self.controller.busy and
                                                      self.statusLabel.setText(self.tr("{0}: {1}…").format(d, stage)))
            self.progressBar.setValue(0)
            self.progressBar.setFormat(description + " %p%")
            if self.controller.task_kind in ("fit", "auto"):  # Find camera ends with a camera too (a trial: the
                # dock stayed on the Camera tab, the result out of sight)
                self.stepTabs.setCurrentWidget(self.fitTab)
        else:
            self.progressBar.setFormat("%p%")

    def _on_task_finished(self, result) -> None:
        if result.ok and self.controller.task_kind in ("fit", "auto"):  # a camera found either way
            self._update_camera_layers()
            # the verdict in sight: after a fit from the open Fit settings, the tab stayed scrolled down with
            # the status and the camera out of view (a re-check trial)
            self.fitScroll.verticalScrollBar().setValue(0)
        elif result.ok and self.controller.task_kind == "suggest":
            self.mapToolButton.setChecked(True)  # DEM suggestions are curated on the main map

    # --- project life cycle -----------------------------------------------------------------------------------
    def _apply_settings(self) -> None:
        """Widgets that show a setting stored with the project (default when the project has none)."""
        self.overlaySlider.setValue(int(self.controller.state.settings.get("overlay_opacity",
                                                                           DEFAULT_OVERLAY_PERCENT)))

    def _project_read(self, *args) -> None:
        c = self.controller
        if c.restore():
            self._apply_settings()
            if c.fitted is not None:
                self._rebuild_camera_layers_later()  # memory layers come back empty from a project file
            # the status line says what came back (a trial found it empty after reopening, the fit's verdict
            # only in the fit tab); the message bar stays quiet: nothing happened
            show_status(self.statusLabel, self._restored_text())

    def _all_layers_removed(self) -> None:
        """A project closed or cleared removes every layer: not the person removing the DEM (the removal runs
        before the event loop turns again)."""
        self._removing_all = True
        QTimer.singleShot(0, lambda: setattr(self, "_removing_all", False))

    def _dem_layer_removed(self, layer_ids) -> None:
        """The DEM layer removed: the DEM box moves on to another raster by itself, without a signal (a re-check
        trial's showed the XYZ raster written earlier while the DEM read went on in use): empty, and said, also
        when it was the only raster and the box emptied itself (a re-check trial got no word then)."""
        if self._removing_all:
            return
        if self.controller.state.dem_layer_id in layer_ids and self.controller.dem_layer is None:
            self.demCombo.blockSignals(True)
            self.demCombo.setLayer(None)
            self.demCombo.blockSignals(False)
            show_status(self.statusLabel, self.tr(
                "The DEM layer was removed from the project: Monoplot goes on with the DEM it read, and adds the "
                "layer back when the project is opened again. Choose another DEM in the DEM box to change it."))

    def _project_saved_status(self) -> None:
        """Work restored from a never-saved project's autosave is in a project file now: the status line stops
        asking to save it (a trial saw "save the project to keep it" after saving)."""
        c = self.controller
        if c.restored_source == "unsaved autosave" and self.project.fileName():
            c.restored_source = "project"
            show_status(self.statusLabel, self.tr("The restored work is saved in {0}.").format(
                os.path.basename(self.project.fileName())))

    def _project_cleared(self) -> None:
        self.end_photo_tools()
        self.controller.cancel()
        self.controller.project_closed()
        self.controller.restore()
        for spin, value in self._camera_box_defaults.items():
            spin.blockSignals(True)
            spin.setValue(value)
            spin.blockSignals(False)
        self._apply_settings()
        self.statusLabel.clear()  # the last message was about the closed project

    def unload(self) -> None:
        """Remove canvas items and map tools from the main map, disconnect from the project, save the state.

        Called by the plugin's unload() and when QGIS quits (before QgsProject's destructor emits ``cleared``);
        a second call does nothing."""
        if self._unloaded:
            return
        self._unloaded = True
        c = self.controller
        c.cancel()
        self.curation_panel.unload()
        self.chips.unload()
        c.hand_over()
        c.detach()
        if self.output_tools is not None:
            self.output_tools.unload()
        for tool in (self.map_tool, self.camera_tool):
            if self.map_canvas.mapTool() is tool:
                self.map_canvas.unsetMapTool(tool)
                pan = getattr(self.iface, "actionPan", None)  # the map is not left without a tool (a trial)
                if pan is not None and pan() is not None:
                    pan().trigger()
        self.map_view.remove()
        for signal, slot in ((self.map_canvas.xyCoordinates, self._map_cursor),
                             (self.map_canvas.destinationCrsChanged, self._map_crs_changed),
                             (self.project.readProject, self._project_read),
                             (self.project.cleared, self._project_cleared),
                             (self.project.projectSaved, self._project_saved_status),
                             (self.project.layersRemoved, self._dem_layer_removed),
                             (self.project.removeAll, self._all_layers_removed),
                             (self.project.layerTreeRoot().visibilityChanged, self._group_visibility),
                             (QgsApplication.instance().aboutToQuit, self.unload)):
            try:
                signal.disconnect(slot)
            except (TypeError, RuntimeError):
                pass

    def _map_crs_changed(self) -> None:
        c = self.controller
        self.map_view.redraw_camera(c.footprint_wkt if c.fitted is not None else "")
        self.map_view.redraw_points()

    def showEvent(self, event) -> None:  # noqa: N802
        super().showEvent(event)
        if not self._sized:  # first show: the photo the most, the Points tab its buttons and a few table rows
            self._sized = True
            split_photo_and_tabs(self, max(self.splitter.height(), 600))

    def closeEvent(self, event) -> None:  # noqa: N802
        if self.mapToolButton.isChecked():
            self.mapToolButton.setChecked(False)
        self.drawCameraButton.setChecked(False)
        super().closeEvent(event)
