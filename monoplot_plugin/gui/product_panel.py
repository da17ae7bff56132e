"""The product panel of the Monoplot dock: digitising tools on the photo canvas and the export buttons.

The dock calls :func:`install_output_tools` once (end of its ``__init__``) and :meth:`OutputTools.unload` in its
``unload``; everything else lives here. What the panel needs of the dock is one small explicit interface,
:class:`ProductHost` (the controller, the project, the photo canvas, the extension points ``add_photo_tool`` and
``add_output_action``, the message and status lines): the panel never reaches into the dock's widgets.
The products that need a fitted camera are disabled until there is one, with the reason as their tooltip.
Each export asks for a file with the standard save dialog (which asks before replacing a
file; only then is ``overwrite=True`` passed) and reports success or the reason of a failure in the message bar;
the ``export_*`` methods take the path directly for scripts and tests. The rasters and the report are made by
:mod:`.product_exports`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, List, Optional

from qgis.core import Qgis, QgsMapLayer, QgsProject, QgsVectorLayer
from qgis.PyQt.QtCore import QObject, pyqtSignal
from qgis.PyQt.QtWidgets import QAction, QWidget

from . import persistence
from .digitise_tools import PhotoCaptureTool, PhotoEditTool
from ..outputs.safe_write import OutputError
from ..workflow import xyz as xyz_step
from ..workflow.features import pixel_error
from .digitising import KINDS, DigitisingSession, drawn_entry_key
from .drawn_copies import refill_map_layers
from .drawing_notes import doubt_note, kind_names, sky_text, spread_note
from .feature_dialogs import FeatureDialogsMixin
from .photo_names import claim_photo_label, photo_label
from ..adapters.exif import read_photo_taken
from ..adapters.layers import derived_layers_only, mark_modified_later
from .map_layers import map_layer_on_photo, overlay_outcome
from .product_exports import LAST_FOLDER_KEY, ProductExports

__all__ = ["install_output_tools", "OutputTools", "ProductHost", "LAST_FOLDER_KEY", "NEEDS_FIT"]

#: the actions that need a fitted camera (disabled before the first fit, the reason in their tooltip)
NEEDS_FIT = ("xyz", "ortho", "report", "features", "overlay", "field", "attributes")


@dataclass
class ProductHost:
    """What the product panel uses of the dock, passed in explicitly.

    Attributes:
        controller: the :class:`~.controller.MonoplotController` (fitted camera, DEM, photo, state, its signals).
        project: the QgsProject the layers go into.
        photo_canvas: the dock's photo canvas (the digitising tools draw on it; ``set_extra_layers``).
        widget: parent of the actions and the file dialogs.
        add_photo_tool: ``(QAction, map tool)`` -> a checkable tool in the photo bar.
        add_output_action: ``QAction`` -> a button in the "Fit and results" tab.
        show_message: ``(text, Qgis.MessageLevel)`` -> the dock's status line and QGIS's message bar.
        show_status: ``text`` -> the dock's status line only.
        iface: QGIS's interface (attribute tables, the active layer), or None.
        status_is_stale: called before a drawing edit: the last message spoke of the state before it.
    """

    controller: Any
    project: QgsProject
    photo_canvas: Any
    widget: QWidget
    add_photo_tool: Callable[[QAction, Any], Any]
    add_output_action: Callable[[QAction], Any]
    show_message: Callable[[str, Any], None]
    show_status: Callable[[str], None]
    iface: Any = None
    status_is_stale: Callable[[], None] = lambda: None

    @classmethod
    def of_dock(cls, dock) -> "ProductHost":
        return cls(dock.controller, dock.project, dock.photo_canvas, dock, dock.add_photo_tool,
                   dock.add_output_action, dock.show_message, dock.statusLabel.setText, getattr(dock, "iface", None),
                   dock.message_is_stale)


def install_output_tools(dock) -> "OutputTools":
    """Add the digitising tools and export actions to ``dock`` (a MonoplotDock); returns their owner."""
    return OutputTools(ProductHost.of_dock(dock))


class OutputTools(FeatureDialogsMixin, QObject):
    """Digitising session, tools and export actions of one dock.

    Signals:
        exported(str what, str path): a background export ("xyz", "ortho", "report") was written.
    """

    exported = pyqtSignal(str, str)

    def __init__(self, host: ProductHost):
        super().__init__(host.widget)
        self.host = host
        self.controller = host.controller
        self.project = host.project
        self.canvas = host.photo_canvas
        parent = host.widget
        self.session: Optional[DigitisingSession] = None
        self.overlays: List[QgsVectorLayer] = []
        self._overlay_ids: List[str] = []  # the map layers drawn on the photo, redrawn after a refit or a reopen
        self._sky_told: dict = {}  # kind -> (sky pieces, dropped features, silhouette crossings) last reported
        self._spread_told: set = set()  # ((kind, fid), metres) of the wide ground per pixel told (drawing_notes)
        #: kind -> (camera, features on its photo layer not news, told): drawings on a doubtful camera said once
        self._doubt_told: dict = {}
        self.exports = ProductExports(host, self.ready, lambda: self.photo_name(claim=True), self._message,
                                      self.exported.emit)
        canvas = self.canvas
        self.capture_tools = {kind: PhotoCaptureTool(canvas, self.current_session, kind) for kind in KINDS}
        self.edit_tool = PhotoEditTool(canvas, self.current_session)
        # short button texts: all four tools must fit the photo bar of a 440 px dock (longer ones went into the
        # toolbar's overflow menu, hiding the polygon tool); the tooltip says "on the photo"
        labels = {"point": self.tr("Draw points"), "line": self.tr("Draw lines"), "polygon": self.tr("Draw polygons")}
        self.actions = {}
        for kind, tool in self.capture_tools.items():
            action = QAction(labels[kind], parent)
            action.setToolTip(labels[kind] + self.tr(" on the photo: click vertices, right click to finish, "
                                                     "Backspace undoes a vertex, Esc cancels, Ctrl+Z undoes the "
                                                     "last drawing edit"))
            host.add_photo_tool(action, tool)
            tool.message.connect(lambda text: self._message(text, Qgis.MessageLevel.Warning))
            tool.undone.connect(self.host.show_status)
            tool.editing.connect(self.host.status_is_stale)
            self.actions[kind] = action
        self.edit_tool.undone.connect(self.host.show_status)
        # a delete said as a drawing undo is (a re-check trial found the status line empty after one)
        self.edit_tool.deleted.connect(lambda kind, fid: self.host.show_status(self.tr(
            "Deleted a {0} drawn on the photo (Ctrl+Z brings it back).").format(self.tr(kind))))
        self.edit_tool.editing.connect(self.host.status_is_stale)  # "session restored" stayed after an edit (trial)
        self.actions["edit"] = QAction(self.tr("Edit drawn features"), parent)
        self.actions["edit"].setToolTip(self.tr("Drag a vertex to move it; right click a feature to delete it; "
                                                "Ctrl+Z undoes the last drawing edit"))
        host.add_photo_tool(self.actions["edit"], self.edit_tool)
        # the products first: at the default dock height the fit tab scrolls and its last row is out of sight
        # (it used to be "Active map layer on photo"); the attribute helpers are also in the Layers panel
        tr = self.tr
        for name, label, slot, tip in (
                ("xyz", tr("XYZ raster…"), self.exports.ask_xyz,
                 tr("The X, Y, Z of every photo pixel (3-band GeoTIFF)")),
                ("ortho", tr("Orthophoto…"), self.exports.ask_ortho,
                 tr("The photo draped on the DEM (map GeoTIFF), over what the camera sees, at the photo's own detail "
                    "(a pixel's footprint at the median distance, never coarser than the DEM)")),
                ("report", tr("Report…"), self.exports.ask_report, tr("Camera, residuals, check points (PDF or PNG)")),
                ("features", tr("Save drawn features…"), self._ask_features, tr("The drawn features as map layers")),
                ("overlay", tr("Active map layer on photo"), self._overlay_active_layer,
                 tr("Draw the layer selected in the Layers panel on the photo")),
                ("field", tr("Add attribute field…"), self._ask_field, tr("A new field of the drawn layers")),
                ("attributes", tr("Attributes of drawn features"), self._open_attributes,
                 tr("The attribute tables of the drawn layers"))):
            action = QAction(label, parent)
            action.triggered.connect(slot)
            action.setProperty("monoplot_tip", tip)
            host.add_output_action(action)
            self.actions[name] = action
        self.controller.cameraChanged.connect(self._camera_changed)
        self.controller.demChanged.connect(self._camera_changed)
        self.controller.photoChanged.connect(self._forget)
        self.project.cleared.connect(self._forget)
        self.project.readProject.connect(self.refill_other_photos)
        self._update_enabled()

    # --- state ------------------------------------------------------------------------------------------------
    def ready(self) -> Optional[str]:
        """None when outputs can be made, else the reason for the user."""
        c = self.controller
        if c.image is None:
            return self.tr("Load a photo first.")
        if c.dem is None:
            return self.tr("Choose a DEM first.")
        if c.fitted is None:
            return self.tr("Fit the camera first.")
        return None

    def _update_enabled(self) -> None:
        """Products need a fitted camera: disabled before, the reason in the tooltip (a disabled button still
        shows it); enabled with their own tooltip after a fit."""
        reason = self.ready()
        for name in NEEDS_FIT:
            action = self.actions[name]
            action.setEnabled(reason is None)
            tip = action.property("monoplot_tip") or ""
            action.setToolTip(tip if reason is None else self.tr("Needs a fitted camera: {0}").format(reason))

    def photo_name(self, claim: bool = False) -> str:
        """The name the photo goes by in the project (:mod:`.photo_names`); ``claim``: it is now used (something
        is drawn or exported under it)."""
        path = self.controller.state.photo_path or ""
        return claim_photo_label(self.project, path) if claim else photo_label(self.project, path)

    def current_session(self) -> Optional[DigitisingSession]:
        """The digitising session of the fitted camera (created on first use), or None without a fit."""
        if self.ready() is not None:
            return None
        if self.session is not None and self.session.closed:  # its layers were deleted (project cleared)
            self._forget_session()
        # The session intersects rays with the DEM exactly: no full-resolution XYZ raster needed (fast start).
        camera, dem, xyz = self.controller.fitted, self.controller.dem, None
        if self.session is None:
            self.session = DigitisingSession(self.project, camera, dem, xyz, self.photo_name(claim=True), parent=self,
                                             pixel_rmse=pixel_error(self.controller.state.fit_info)[0],
                                             spread=self.controller.camera_spread(),
                                             area=self.controller._picture_area(),
                                             photo_taken=read_photo_taken(self.controller.state.photo_path or ""),
                                             fit_status=self._fit_status())
            self.session.mapLayerUpdated.connect(self._report_sky)
            # what the restored features already had is old news: told again on every reopening (desktop trial)
            self._sky_told.update({kind: (*counts, self.session.last_silhouettes.get(kind, 0))
                                   for kind, counts in self.session.last_report.items()})
            # restored features are old news: only a feature drawn now tells
            self._doubt_told = {kind: (self.controller.state.fitted, self._drawn(kind), False) for kind in KINDS}
            self._spread_told = {((kind, fid), round(big)) for kind in KINDS
                                 for fid, _, big in self.session.last_spans.get(kind, []) if big is not None}
            # Layers deleted under us (project cleared, QGIS closing): the photo canvas must drop them at once.
            self.session.closedByLayers.connect(lambda: self.canvas.set_extra_layers([]))
            with derived_layers_only(self.project):
                for kind in KINDS:
                    self.session.photo_layer(kind)
            self._show_on_photo()
            if self.session.restored_from_autosave:  # drawn after the last Save, then QGIS crashed
                # (a project never saved has no last save: a re-check trial read that it had)
                self._message(self.tr("Drawing on the photo done after the project was last saved (features drawn, "
                                      "moved or deleted) was restored from the autosave.") if self.project.fileName()
                              else self.tr("The features drawn on the photo were restored from the autosave."),
                              Qgis.MessageLevel.Info)
                mark_modified_later(self.project)
        return self.session

    def _fit_status(self) -> Optional[str]:
        """The fitted camera's verdict (ok, uncertain, poor), None when the dock has none (a camera loaded without
        one)."""
        return (self.controller.state.fit_info or {}).get("status") or None

    def _camera_changed(self) -> None:
        self._update_enabled()
        if self.ready() is not None:
            return
        if self.session is not None and self.session.closed:
            self._forget_session()
        if self.session is not None:
            self.session.update_camera(self.controller.fitted, self.controller.dem, None,
                                       pixel_error(self.controller.state.fit_info)[0], self.controller.camera_spread(),
                                       fit_status=self._fit_status())
        elif (self.project.readEntry("monoplot", drawn_entry_key(self.photo_name()), "")[0]
              or persistence.autosaved_entry(self.project, drawn_entry_key(self.photo_name()))):
            # a reopened project with features drawn on this photo, saved or only autosaved (drawn after the last
            # Save, then a crash): show them again, at once
            self.current_session()
        self._redraw_overlays()

    def _overlay_entry(self) -> str:
        return drawn_entry_key(self.photo_name()).replace("/drawn/", "/overlays/")

    def _redraw_overlays(self) -> None:
        """Draw the map layers shown on the photo again with the current camera (they were left where the previous
        fit put them), or, in a reopened project, the ones stored with it; layers removed since are dropped."""
        ids = list(self._overlay_ids)
        if not ids:
            text = self.project.readEntry("monoplot", self._overlay_entry(), "")[0]
            try:
                ids = [str(i) for i in json.loads(text)] if text else []
            except ValueError:
                ids = []
        self.overlays, self._overlay_ids = [], []
        for layer_id in ids:
            layer = self.project.mapLayer(layer_id)
            if isinstance(layer, QgsVectorLayer) and layer.isValid():
                try:
                    self.draw_layer_on_photo(layer)
                except (OutputError, ValueError) as exc:
                    self._message(self.tr("{0} could not be drawn on the photo: {1}").format(layer.name(), exc),
                                  Qgis.MessageLevel.Warning)
        self._show_on_photo()

    def refill_other_photos(self, *args) -> None:
        """A project read (or a dock opened on one: the plugin opens it when the read is over): the layers of what
        was drawn on the other photos come back as they were saved (the current photo's session rebuilds its own)."""
        session = self.session if self.session is not None and not self.session.closed else None
        live = [*session.map_layers.values(), *session.photo_layers.values()] if session else []
        refill_map_layers(self.project, [layer.id() for layer in live])

    def _forget_session(self) -> None:
        if self.session is not None:
            self.session.save_drawn(copies=True)  # another photo: its map layers stay on the map (no-op if closed)
            self.session.close()
            self.session.deleteLater()
        self.session = None
        self.overlays = []
        self._overlay_ids = []
        self.canvas.set_extra_layers([])

    def _forget(self) -> None:
        """Another photo or project: drop the session (its layers belong to the old one; the drawn features are
        in the project file and come back with it)."""
        self._forget_session()
        # its drawing tools too: the new photo starts with point curation (a trial's "Draw polygons" stayed pressed
        # over a photo without a camera)
        for action in self.actions.values():
            if action.isCheckable() and action.isChecked():
                action.setChecked(False)
        xyz_step.clear_cache()
        self._sky_told, self._doubt_told, self._spread_told = {}, {}, set()
        self.canvas.set_extra_layers([])
        self._camera_changed()

    def _report_sky(self, kind: str, sky: int, dropped: int) -> None:
        # Tell once per change, not on every edit of an unrelated feature.
        crossings = self.session.last_silhouettes.get(kind, 0) if self.session is not None else 0
        previous = self._sky_told.get(kind, (0, 0, 0))
        self._sky_told[kind] = (sky, dropped, crossings)
        doubt = self._doubt_text(kind)
        spans = [((kind, fid), med, big) for fid, med, big in self.session.last_spans.get(kind, [])] \
            if self.session is not None else []
        spread = spread_note(self.sky_names().get(kind, kind), spans, self._spread_told, self.tr)
        doubt = (" " + spread if spread else "") + doubt  # first: the status line keeps three lines
        if (sky or dropped or crossings) and (sky, dropped, crossings) != previous:
            self._message(self.sky_text(kind, sky, dropped, crossings) + doubt, Qgis.MessageLevel.Warning)
        elif doubt:
            self._message(doubt.strip(), Qgis.MessageLevel.Warning)

    def _drawn(self, kind: str) -> int:
        return self.session.photo_layer(kind).featureCount() if self.session is not None else 0

    def _doubt_text(self, kind: str) -> str:
        """:func:`.drawing_notes.doubt_note` for the drawings of ``kind`` under the current camera."""
        return doubt_note(self._doubt_told, kind, self.controller.state.fitted, self._drawn(kind),
                          (self.controller.state.fit_info or {}).get("status", "ok"), self.tr)

    def sky_names(self) -> dict:
        return kind_names(self.tr)

    def sky_text(self, kind: str, sky: int, dropped: int, crossings: int = 0) -> str:
        """:func:`.drawing_notes.sky_text` for this session's drawings."""
        session = self.session
        return sky_text(kind, sky, dropped, crossings, paper=session is not None and session.area is not None,
                        dropped_at=session.last_dropped.get(kind, []) if session is not None else [], tr=self.tr)

    def _show_on_photo(self) -> None:
        layers: List[QgsMapLayer] = list(self.overlays)
        if self.session is not None:
            layers = self.session.all_photo_layers() + layers
        self.canvas.set_extra_layers(layers)

    def _message(self, text: str, level=Qgis.MessageLevel.Info) -> None:
        # through the controller: the dock's status line, QGIS's message bar and the Monoplot log tab (a direct
        # call of the dock left "Written: ..." out of the log)
        self.controller.message.emit(text, level)

    # --- rasters and report (:mod:`.product_exports`) ------------------------------------------------------
    def export_xyz(self, path, overwrite: bool = False, distance: bool = False):
        return self.exports.export_xyz(path, overwrite, distance)

    def export_orthophoto(self, path, overwrite: bool = False):
        return self.exports.export_orthophoto(path, overwrite)

    def export_report(self, path, overwrite: bool = False):
        return self.exports.export_report(path, overwrite)

    def start_export(self, what: str, path, overwrite: bool = False):
        return self.exports.start_export(what, path, overwrite)

    def output_folder(self) -> Path:
        return self.exports.output_folder()

    def export_features(self, kind: str, path, overwrite: bool = False):
        session = self.current_session()
        if session is None:
            raise OutputError(self.ready() or "no digitising session")
        return session.export(kind, path, overwrite=overwrite)

    def draw_layer_on_photo(self, layer: QgsVectorLayer) -> QgsVectorLayer:
        """Project ``layer`` onto the photo (hidden parts dashed) and show it on the photo canvas."""
        camera, dem = self.controller.fitted, self.controller.dem  # exact line of sight: no XYZ raster needed
        overlay = map_layer_on_photo(layer, camera, dem, self.project)
        seen = overlay.featureCount() > 0  # one the camera does not see is not kept in the list (nor the project)
        self.overlays = [o for o in self.overlays if o.name() != overlay.name()] + ([overlay] if seen else [])
        self._overlay_ids = [i for i in self._overlay_ids if i != layer.id()] + ([layer.id()] if seen else [])
        text = json.dumps(self._overlay_ids)
        if self.project.readEntry("monoplot", self._overlay_entry(), "")[0] != text:
            self.project.writeEntry("monoplot", self._overlay_entry(), text)  # kept with the project
        self._show_on_photo()
        return overlay

    # --- dialogs ----------------------------------------------------------------------------------------------
    def _run(self, work, done_text: str) -> None:
        reason = self.ready()
        if reason is not None:
            self._message(reason, Qgis.MessageLevel.Warning)
            return
        try:
            result = work()
        except (OutputError, ValueError) as exc:
            # what the person can put right (a folder, a name, a feature off the terrain): a warning, as QGIS's own
            self._message(self.tr("Nothing was written: {0}").format(exc), Qgis.MessageLevel.Warning)
            return
        self._message(done_text.format(result), Qgis.MessageLevel.Success)

    def _overlay_active_layer(self) -> None:
        iface = self.host.iface
        layer = iface.activeLayer() if iface is not None else None
        if not isinstance(layer, QgsVectorLayer):
            self._message(self.tr("Select a vector layer in the Layers panel first."), Qgis.MessageLevel.Warning)
            return
        if layer.featureCount() == 0:  # "Drawn on the photo" for an empty layer read as a success (desktop trial)
            self._message(self.tr("{0} has no features: nothing to draw on the photo.").format(layer.name()),
                          Qgis.MessageLevel.Warning)
            return
        reason = self.ready()
        if reason is not None:
            self._message(reason, Qgis.MessageLevel.Warning)
            return
        text, doubtful = overlay_outcome(layer, self.draw_layer_on_photo(layer), self.tr)
        self._message(text, Qgis.MessageLevel.Warning if doubtful else Qgis.MessageLevel.Success)

    # --- life cycle -------------------------------------------------------------------------------------------
    def unload(self) -> None:
        """Undo the installation: tools off the canvas, canvas items removed, signals disconnected, exports still
        running canceled (nothing is replaced: the files are renamed into place only when complete)."""
        self.exports.abandon()
        canvas = self.canvas
        for tool in [*self.capture_tools.values(), self.edit_tool]:
            if canvas.mapTool() is tool:
                canvas.unsetMapTool(tool)
            tool.remove_items()
        for signal, slot in ((self.controller.cameraChanged, self._camera_changed),
                             (self.controller.demChanged, self._camera_changed),
                             (self.controller.photoChanged, self._forget),
                             (self.project.cleared, self._forget),
                             (self.project.readProject, self.refill_other_photos)):
            try:
                signal.disconnect(slot)
            except TypeError:
                pass

