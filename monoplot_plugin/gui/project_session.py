"""The controller's life in a QGIS project (a mixin of :class:`~monoplot_plugin.gui.controller.MonoplotController`):
every change marks the project modified and restarts the debounced autosave; the state is written into the project
when QGIS writes it; a project saved under a new name leaves no autosave behind for the old one; a project read back
restores the session (or a newer autosave). Its needs are :class:`ProjectSessionHost`, checked by
``tests/gui/test_controller_interfaces.py``."""

from __future__ import annotations

from typing import Optional, Protocol

from qgis.core import Qgis, QgsCoordinateReferenceSystem, QgsRasterLayer

from ..adapters.layers import mark_modified_later
from ..state import MAP, PHOTO, ProjectState
from . import persistence
from .photo_names import restate_owners

__all__ = ["ProjectSessionMixin", "ProjectSessionHost"]

INFO = Qgis.MessageLevel.Info


class ProjectSessionHost(Protocol):
    """What :class:`ProjectSessionMixin` uses of the controller."""

    project: object  # QgsProject
    state: object  # ProjectState
    stack: object  # CommandStack
    current: dict
    image: object
    dem: object
    dem_layer: Optional[QgsRasterLayer]
    dem_crs: QgsCoordinateReferenceSystem
    overlay: object
    xyz: object
    footprint_wkt: str
    project_generation: int
    _restoring: bool
    _project_file: str  # the file whose autosave this state goes to
    _saved_as_from: str  # the file a Save As being written leaves
    _was_unsaved: bool  # the project being written had no file before
    restored_source: str
    _autosave: object  # QTimer of the debounced autosave
    _autosave_worker: object
    _map_work_crs: Optional[QgsCoordinateReferenceSystem]
    message: object  # pyqtSignal(str, level)
    photoChanged: object
    demChanged: object
    cameraChanged: object
    pointsChanged: object

    def tr(self, text: str) -> str: ...

    def load_photo(self, path: str, keep_points: bool = False, image=None) -> bool: ...

    def set_dem_layer(self, layer, void_value=None) -> bool: ...

    def _readd_dem(self, source: str): ...

    def ensure_products(self, background: bool = True) -> None: ...


class ProjectSessionMixin:
    """Project writing, autosave, Save As and restore; needs a :class:`ProjectSessionHost`."""

    def _project_writing(self, *args) -> None:
        before, self._project_file = self._project_file, self.project.fileName()  # Save As: a new file
        self._was_unsaved = not before
        if before and before != self._project_file:
            self._saved_as_from = before
        if not self._restoring:
            persistence.store_in_project(self.project, self.state)
        restate_owners(self.project)  # photo names claimed before the project had a file: relative to it now

    def _project_saved(self) -> None:
        """Saved under a new name: the old file's autosave holds work that is now in the new file. Left there, the
        old project reopened with the later work "restored" in it (a desktop trial: day 1's file showed day 2).
        Saved for the first time: the autosave of a never-saved project goes (a later empty project took it for
        work a crash left)."""
        if self._saved_as_from:
            persistence.discard_autosave(self._saved_as_from)
            self._saved_as_from = ""
        elif self.project.fileName() and self._was_unsaved:
            persistence.discard_autosave("")
        self._was_unsaved = False

    def _changed(self) -> None:
        """Every change marks the project modified (the state goes into it when it is written) and restarts the
        debounced autosave: no O(points) work on the main thread per change."""
        if not self._restoring:
            self.project.setDirty(True)
            self._autosave.start()

    def _autosave_now(self) -> None:
        """The debounced autosave: a snapshot here, the file written in a worker thread (gui/persistence.py)."""
        self._autosave_worker = persistence.autosave(self.project, self.state)

    def project_closed(self) -> None:
        """QGIS closed the project (``cleared``; a crash never gets here): its autosave files go, since QGIS has
        asked whether to save it and "Discard" must not come back when the project is opened again."""
        self._autosave.stop()
        persistence.discard_autosave(self._project_file)
        self._project_file = ""
        self.project_generation += 1  # what a background export started in it is not added to the next one
        self._map_work_crs = None  # the next project's map points are in its own DEM's CRS (DemInputMixin)

    def save(self) -> None:
        """Write the state into the project and the autosave file now (synchronously)."""
        self._autosave.stop()
        persistence.save(self.project, self.state)

    def hand_over(self) -> None:
        """The plugin unloads (a reload, a disable, QGIS quitting): the state goes into the project, which QGIS asks
        to save, and the autosave files of a saved project go. Left behind, they brought work the person then
        chose to discard back the next time the project was opened (a trial: reload, edit, New project, Discard)."""
        self._autosave.stop()
        persistence.store_in_project(self.project, self.state)
        persistence.discard_autosave(self.project.fileName())

    def restore(self) -> bool:
        """Load the state stored in the project (after projectRead); falls back to a newer autosave."""
        self._autosave.stop()  # a pending autosave of the previous project must not overwrite this one
        self._project_file = self.project.fileName()
        state, source = persistence.load_with_source(self.project)
        self.restored_source = source  # what the dock's status line says came back
        self._restoring = True
        try:
            self.stack.reset(state or ProjectState())
            self.current = {PHOTO: "", MAP: ""}
            self.image, self.dem, self.dem_layer, self.overlay, self.xyz = None, None, None, None, None
            self.footprint_wkt = ""
            self.dem_crs = QgsCoordinateReferenceSystem()
            if state is None:
                self.photoChanged.emit()
                self.demChanged.emit()
                self.cameraChanged.emit()
                return False
            if state.photo_path:
                self.load_photo(state.photo_path)
            layer = self.project.mapLayer(state.dem_layer_id) if state.dem_layer_id else None
            if not isinstance(layer, QgsRasterLayer) and state.dem_source:
                layer = self._readd_dem(state.dem_source)
            if isinstance(layer, QgsRasterLayer):
                self.set_dem_layer(layer)
            self.ensure_products()
            self.cameraChanged.emit()
            self.pointsChanged.emit(set())
            if source == "autosave":
                mark_modified_later(self.project)  # not in the project file: closing must ask to save it
                self.message.emit(self.tr("Restored work done after the project was last saved "
                                          "(autosave)."), INFO)
            elif source == "unsaved autosave":
                mark_modified_later(self.project)
                self.message.emit(self.tr("Restored the work of a session that ended without its project "
                                          "being saved or closed (autosave): save the project to keep it."), INFO)
            return True
        finally:
            self._restoring = False
