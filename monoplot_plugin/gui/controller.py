"""The dock's brain, without widgets: photo, DEM, curated points, rough camera, background suggest/fit tasks.

Widgets (dock, canvases, map tools) call these methods and listen to the signals; tests drive it directly.
All point edits go through ``self.stack`` (undo/redo); every change is written to the QGIS project and autosaved.
"""

from __future__ import annotations

import logging
import sys
import time
from typing import Callable, List, Optional, Tuple

import numpy as np
from qgis.core import Qgis, QgsCoordinateReferenceSystem, QgsProject, QgsRasterLayer
from qgis.PyQt.QtCore import QObject, QTimer, pyqtSignal
from qgis.PyQt.QtGui import QImage

from ..adapters.photo import PhotoError, array_to_qimage, qimage_to_array, read_photo
from ..core.camera import Camera
from ..state import MAP, PHOTO, CommandStack, ProjectState, replace_in_views
from ..workflow.camera_files import fitted_to_size
from ..workflow.fit import ground_height_sigma
from ..workflow.products import centred_on_picture
from ..workflow.text import lens_advice, name_photo_pixels
from ..workflow import warmup
from . import engine, photo_shelf
from .curation import CurationMixin
from .fitting import FittingMixin
from .dem_input import DemInputMixin
from .fit_settings import fit_arguments
from .photo_change import work_on_photo
from .photo_names import photo_label
from .priors import PriorsMixin
from .project_session import ProjectSessionMixin
from .results import ResultsMixin
from .tasks import CANCELED, FunctionTask, HiddenTask, TaskResult, abandon, start_task

__all__ = ["MonoplotController"]

INFO, WARNING, CRITICAL, SUCCESS = (Qgis.MessageLevel.Info, Qgis.MessageLevel.Warning,
                                    Qgis.MessageLevel.Critical, Qgis.MessageLevel.Success)
#: the plugin's log (QGIS's Log Messages panel, tab "Monoplot", through logging_bridge): every message the dock
#: shows, and what each suggest and fit did
LOG = logging.getLogger(__name__)
_LOG_LEVELS = {WARNING: logging.WARNING, CRITICAL: logging.ERROR}
#: tasks whose result belongs to the photo and DEM they started with (dropped when either changed meanwhile)
INPUT_BOUND = ("suggest", "fit", "auto")


class MonoplotController(DemInputMixin, PriorsMixin, CurationMixin, FittingMixin, ResultsMixin, ProjectSessionMixin,
                         QObject):
    """State holder and workflow of one Monoplot session (one QGIS project).

    Signals:
        pointsChanged(set): ids of changed points (empty set: everything may have changed).
        photoChanged(): a photo was loaded (``image``) or cleared.
        demChanged(): ``dem`` changed.
        cameraChanged(): prior or fitted camera changed (footprints, residuals, overlay follow).
        selectionChanged(str, str): space, current point id ("" for none).
        busyChanged(str): description of the running task, "" when idle.
        progressChanged(float): percent of the running task.
        message(str, object): text and Qgis.MessageLevel for the message bar.
        taskFinished(object): the :class:`~monoplot_plugin.gui.tasks.TaskResult` of a suggest or fit task.
        productsReady(): overlay and per-pixel XYZ of a restored or loaded camera arrived (:meth:`ensure_products`).
    """

    pointsChanged = pyqtSignal(object)
    photoChanged = pyqtSignal()
    demChanged = pyqtSignal()
    cameraChanged = pyqtSignal()
    selectionChanged = pyqtSignal(str, str)
    busyChanged = pyqtSignal(str)
    progressChanged = pyqtSignal(float)
    message = pyqtSignal(str, object)
    taskFinished = pyqtSignal(object)
    productsReady = pyqtSignal()
    #: the fit's summary changed without a new camera (check points measured again: :meth:`remeasure_checks`)
    fitInfoChanged = pyqtSignal()

    #: fewest accepted points on each side before a fit is attempted (7 unknowns)
    MIN_POINTS = 4

    def __init__(self, project: Optional[QgsProject] = None, parent=None, autosave_delay_ms: int = 1500):
        super().__init__(parent)
        self.project = project or QgsProject.instance()
        self.project_generation = 0  # counts closed projects (:meth:`project_closed`)
        self._map_work_crs = None  # DemInputMixin: the CRS of the DEM the map points and cameras were placed on
        self.state = ProjectState()
        self.stack = CommandStack(self.state)
        self.stack.add_listener(self._on_points_changed)
        self.image: Optional[QImage] = None
        self.dem = None  # core Dem
        self.dem_layer: Optional[QgsRasterLayer] = None
        self.dem_crs = QgsCoordinateReferenceSystem()  # a copy: survives the layer's removal
        self.current = {PHOTO: "", MAP: ""}
        self.task: Optional[FunctionTask] = None
        self._products_tasks: List[FunctionTask] = []  # referenced until done: Python must not collect them
        self.task_kind, self.task_description = "", ""
        # counts the photos and DEMs chosen: a Suggest, Fit or registration ending after a change is not applied
        self._inputs_generation = 0
        self.photoChanged.connect(self._inputs_changed)
        self.demChanged.connect(self._inputs_changed)
        self._preparing = None  # the warm-up a Suggest interrupted, finished afterwards (_prepare_fit)
        self.overlay: Optional[QImage] = None
        self.xyz: Optional[np.ndarray] = None  # (H, W, 3) map X, Y, Z of each photo pixel (NaN = sky)
        self.footprint_wkt = ""  # visible area of the fitted camera (DEM CRS)
        self._restoring = False
        self._fit_ids: Tuple[List[str], List[str]] = ([], [])
        self._known_fit: Tuple[tuple, object] = ((), None)  # (inputs key, FitDone) of the last background refit
        #: inputs key -> the background refit under way of those inputs (a ``refit.RunningFit``) or None; set by
        #: the curation panel's refitter
        self.running_refit: Callable[[tuple], Optional[object]] = lambda key: None
        self.awaited_refit = None  # the refit the running Fit waits for (it must not be canceled), or None
        self._sky_rows_of = None  # the photo's skyline, for the rough camera's pitch (PriorsMixin)
        self._autosave_worker = None  # the last autosave's writer (gui/persistence.py), kept referenced
        self._autosave = QTimer(self)
        self._autosave.setSingleShot(True)
        self._autosave.setInterval(autosave_delay_ms)
        self._autosave.timeout.connect(self._autosave_now)
        self.project.layersWillBeRemoved.connect(self._layers_removed)
        # (re)write the entry while the project is being written: paths are made relative to its (new) file
        self.project.writeProject.connect(self._project_writing)
        self.project.projectSaved.connect(self._project_saved)
        self._saved_as_from = ""  # the file a Save As being written leaves (its autosave goes once it is saved)
        self._was_unsaved = False  # the project being written had no file yet (its autosave goes once saved)
        self.restored_source = ""  # where the last restore took the state from (persistence.load_with_source)
        self.message.connect(self._log_message)
        self.pointsChanged.connect(lambda changed: self.remeasure_checks())
        self._project_file = self.project.fileName()  # the file whose autosave this state goes to

    def _inputs_changed(self) -> None:
        self._inputs_generation += 1

    @staticmethod
    def _log_message(text: str, level) -> None:
        LOG.log(_LOG_LEVELS.get(level, logging.INFO), "%s", text)

    def detach(self) -> None:
        """Stop listening to the project (the dock is going away); close a DEM file read by windows while GDAL is
        still there."""
        self._autosave.stop()
        if getattr(self.dem, "source", None) is not None:
            self.dem.source.close()
            self.dem = None
        # the dock's tasks may still run: cut loose, they stop at their next check and touch nothing deleted (QGIS
        # quitting waits for a hidden task's step, gui/tasks.py); waiting here froze an unload during a first fit
        for task in (self.task, self._preparing, *self._products_tasks):
            abandon(task)
        self.task, self._preparing, self._products_tasks = None, None, []
        for signal, slot in ((self.project.layersWillBeRemoved, self._layers_removed),
                             (self.project.writeProject, self._project_writing),
                             (self.project.projectSaved, self._project_saved)):
            try:
                signal.disconnect(slot)
            except (TypeError, RuntimeError):
                pass
        # what Qt may keep alive a while after a reload (a trial: 100 MB more per reload) need not hold the pictures
        self.image, self.overlay, self.xyz, self.dem = None, None, None, None

    # --- inputs -----------------------------------------------------------------------------------------------
    def read_photo(self, path: str) -> Optional[QImage]:
        """The photo at ``path`` (EXIF orientation honoured), or None after a message saying why it is refused."""
        try:
            return read_photo(path)
        except PhotoError as exc:
            self.message.emit(str(exc), CRITICAL)
            return None

    def load_photo(self, path: str, keep_points: bool = False, image: Optional[QImage] = None) -> bool:
        """Read the photo (EXIF orientation honoured; ``image``: already read by :meth:`read_photo`). On failure:
        message, previous photo kept.

        Another photo starts its curation afresh (the photo points, pairs and fit of another picture make no sense)
        unless ``keep_points``: the same picture in another file (a grey or re-touched copy, of the same size).
        A rough camera made for a picture of another size is carried to this one
        (:func:`~..workflow.camera_files.fitted_to_size`: scaled, or its pose kept for a crop)."""
        image = image if image is not None else self.read_photo(path)
        if image is None:
            return False
        new_photo = path != self.state.photo_path
        keep_points = keep_points and self.image is not None and \
            (image.width(), image.height()) == (self.image.width(), self.image.height())
        switch = new_photo and not self._restoring and not keep_points
        back = None
        if switch:  # this photo's work waits in the project; the chosen one's, put aside earlier, comes back
            photo_shelf.put_aside(self.project, self.state)
            back = photo_shelf.take_back(self.project, path)
        previous, self.image = self.image, image
        self.state.photo_path = path
        if switch and back is not None:
            back.photo_path, back.dem_layer_id, back.dem_source = path, self.state.dem_layer_id, self.state.dem_source
            self.stack.reset(back)
        elif switch:
            self.stack.reset(self._without_photo_points())
            self.state.fitted, self.state.fit_info = None, {}
        prior, carried = self.prior, ""
        if prior is not None and tuple(prior.image_size) != self.photo_size and not self._restoring:
            notes = []
            prior = fitted_to_size(prior, self.photo_size, rough=True, notes=notes)
            # a trial's stayed 1758 x 1378 on a 1574 x 1157 photo: Find camera refused it with a traceback
            carried = self.tr("The rough camera: {0}.").format(notes[0])
        if prior is not None and switch and back is None and not self._restoring:
            # another picture, not "the same picture at another resolution" (a trial read that of another photo)
            carried = self.tr("The rough camera of the previous photo is kept for this one ({0} × {1} px): check "
                              "it, take it From EXIF or draw it on the map.").format(*self.photo_size)
        if prior is not None and not self._restoring:
            self.state.prior = centred_on_picture(prior, self._picture_area()).to_dict()
        self.overlay, self.xyz, self.footprint_wkt = None, None, ""
        self.photoChanged.emit()
        self.cameraChanged.emit()
        self._changed()
        fresh = switch and back is None
        if not self._maybe_exif_prior(fresh=fresh) and carried:
            fov = self.exif_fov() if fresh and self.prior is not None else None
            if fov is not None and abs(fov - self.prior.fov) > 0.05:  # another picture, its own lens (a trial's
                # carried camera kept the last photo's 63.4° while the lens box showed this one's 65.3°)
                self.set_prior(self.prior.with_parameters(fov=fov))
                carried += " " + self.tr("Its field of view is this photo's, from EXIF: {0:.1f}°.").format(fov)
            self.message.emit(carried, INFO)  # not said when the photo's own GPS camera replaced it at once
        if keep_points and new_photo and not self._restoring:  # a time-lapse's next frame: its turn followed
            from .frame_turn import follow_the_turn

            follow_the_turn(self, previous)
        if keep_points and not self._restoring:  # a time-lapse's next frame: the kept camera's overlay on it
            self.ensure_products()
        if back is not None:
            self.ensure_products()
            self.message.emit(self.tr("The work on {0} put aside earlier is back: {1}.").format(
                photo_label(self.project, path), work_on_photo(self) or self.tr("its rough camera")), INFO)
        return True

    def _without_photo_points(self) -> ProjectState:
        s = ProjectState.from_dict(self.state.to_dict())
        s.points = {k: p for k, p in s.points.items() if p.space != PHOTO}
        s.pairs = []
        return s

    @property
    def photo_size(self) -> Optional[Tuple[int, int]]:
        return None if self.image is None else (self.image.width(), self.image.height())

    # --- background work --------------------------------------------------------------------------------------
    @property
    def busy(self) -> bool:
        return self.task is not None

    def _start(self, kind: str, description: str, work, on_success) -> bool:
        if self.task is not None:
            self.message.emit(self.tr("Monoplot is busy ({0}); wait or cancel it.").format(self.task_description),
                              WARNING)
            return False

        t0 = time.perf_counter()
        inputs = self._inputs_generation

        def done(result: TaskResult) -> None:
            self.task = None
            # "ran to its end", not "found what it looked for" (a trial read "success" for a search that found none)
            LOG.info("%s: %s in %.2f s", description, {"success": "finished"}.get(result.status, result.status),
                     time.perf_counter() - t0)
            if result.ok and kind in INPUT_BOUND and inputs != self._inputs_generation:
                # another photo or DEM was chosen meanwhile: a camera or points of the old ones would be shown on
                # the new ones (a trial: a registration of the clear photo landed on its fog copy, "98 % skyline")
                self.message.emit(self.tr("{0} finished, but the photo or the DEM changed while it ran: its result "
                                          "is not used. Run it again.").format(description), WARNING)
            elif result.ok:
                try:
                    on_success(result.value)
                    if kind == "suggest":
                        self._prepare_fit()
                except Exception as exc:  # the dock stays usable: a trial's stayed busy at 100 %, Fit greyed out
                    LOG.exception("%s: showing its result failed", description)
                    self.message.emit(self.tr("{0} finished, but showing its result failed: {1} (details in the "
                                              "Monoplot log)").format(description, exc), CRITICAL)
            elif result.status == CANCELED:
                self.message.emit(self.tr("{0} canceled.").format(description), INFO)
            else:
                self.message.emit(self.tr("{0} failed: {1}").format(description, result.reason), CRITICAL)
            self.busyChanged.emit("")
            self.taskFinished.emit(result)
            self.task_kind, self.task_description = "", ""

        warmup.yield_to_work()  # a warm-up still running stops after its step: this work comes first
        self.task = FunctionTask(description, work, done)
        self.task_kind, self.task_description = kind, description
        self.task.progressChanged.connect(self.progressChanged)  # signal to signal: Qt drops it with either object
        self.busyChanged.emit(description)
        start_task(self.task)
        return True

    def run_task(self, kind: str, description: str, work, on_success) -> bool:
        """Run ``work(progress, is_canceled)`` as the dock's task (progress bar, Cancel, busy state); on success
        ``on_success(value)`` in the main thread. False when another task is running."""
        return self._start(kind, description, work, on_success)

    def show_fit(self, outcome: "engine.FitOutcome") -> None:
        """Show a finished fit's camera (overlay, XYZ, status and message) as the fitted camera."""
        self._apply_fit(outcome)

    def _prepare_fit(self) -> None:
        """After a Suggest, finish the warm-up it interrupted (``workflow.warmup``) while the person curates: else
        the first fit imported torch and compiled its kernels itself, 10-20 s at load 5-8 that no Cancel can cut
        short (an import cannot be interrupted; the trial's Cancel of a first fit took 7-20 s)."""
        if "torch" in sys.modules or self._preparing is not None:
            return

        def done(result) -> None:
            self._preparing = None

        self._preparing = HiddenTask("Monoplot: preparing the fit", warmup.warm_up, done)
        start_task(self._preparing)

    def cancel(self) -> None:
        if self.task is not None:
            self.task.cancel()
        for task in self._products_tasks:
            task.cancel()

    def suggest(self, n_photo: int = 300, n_dem: int = 300) -> bool:
        """Detect key points on the photo and on the DEM in a task; untouched old suggestions are replaced."""
        if self.image is None or self.dem is None:
            self.message.emit(self.tr("Load a photo and choose a DEM first."), WARNING)
            return False
        photo = qimage_to_array(self.image)  # copies: the task must not share Qt objects
        dem, camera, rough = self.dem, self.camera(), self.prior
        options = fit_arguments(self.state.settings)[1]  # the prior's position σ, if the person set it
        position_sigma_m = options.position_sigma_m if options is not None else None

        def work(progress, is_canceled):
            return engine.suggest(photo, dem, camera, n_photo, n_dem, progress, is_canceled, position_sigma_m,
                                  rough)

        def apply(value):
            photo_pts, map_pts, near_clip_m, featureless, from_rough = value
            self.stack.push(replace_in_views(self.state, {PHOTO: photo_pts, MAP: map_pts}, self.tr("Suggest points")))
            text = self.tr("{0} photo and {1} DEM suggestions: accept (A / left click) or reject "
                           "(R / right click) them.").format(len(photo_pts), len(map_pts))
            if near_clip_m:
                text += " " + self.tr("Terrain within {0:.0f} m of the rough camera fills its view. Its position is "
                                      "only known to about {0:.0f} m, so that terrain is left out of the DEM "
                                      "suggestions. If the photo does show a slope that close, give the position's "
                                      "uncertainty (Position ± in Fit settings, tab 4) and suggest again; if not, "
                                      "check the camera's position and height.").format(near_clip_m)
            if from_rough:
                text += " " + self.tr("The fitted camera sees little terrain with features (a flat view, or a "
                                      "wrong camera): DEM suggestions seen from the rough camera were added after "
                                      "its own.")
            if featureless:  # first: the message bar shows one line
                text = featureless + " " + text
            self.message.emit(text, WARNING if featureless else INFO)

        return self._start("suggest", self.tr("Suggest points"), work, apply)

    def set_fitted(self, camera: Optional[Camera], info: Optional[dict] = None, background: bool = False) -> None:
        """Use ``camera`` as the fitted camera (e.g. loaded from a file); overlay and XYZ are recomputed here (in a
        task with ``background``)."""
        self.state.fitted = None if camera is None else camera.to_dict()
        self.state.fit_info = dict(info or {})
        self.overlay, self.xyz, self.footprint_wkt = None, None, ""
        self._changed()
        if camera is not None:
            self.ensure_products(background)
        self.cameraChanged.emit()

    def set_setting(self, key: str, value) -> None:
        """A small GUI setting stored with the project (e.g. overlay opacity)."""
        if self.state.settings.get(key) != value:
            self.state.settings[key] = value
            self._changed()

    def _apply_fit(self, outcome: "engine.FitOutcome") -> None:
        i = outcome.info
        # a pixel the message quotes, by the name the person's table gave the point there (a trial's GCP4)
        named = [(p.x, p.y, p.label) for p in self.state.points.values() if p.space == PHOTO and p.manual and p.label]
        if named and i.get("message"):
            i["message"] = name_photo_pixels(str(i["message"]), named)
        LOG.info("Fit (%s): status %s, RMSE %s px, check RMSE %s px on %s, %s photo / %s map points, %s pairs "
                 "given, %s matched, core fit %.2f s; %s", i.get("mode"), i.get("status"), _num(i.get("rmse_px")),
                 _num(i.get("check_rmse_px")), i.get("n_check"), i.get("n_photo"), i.get("n_map"), i.get("n_pairs"),
                 i.get("n_matched"), float(i.get("elapsed_s") or 0.0), i.get("message", ""))
        lens = self.exif_lens() if i.get("status") != "ok" and "fov" in (i.get("free") or ()) else None
        if lens is not None and getattr(lens, "fov", None) and i.get("message"):
            i["message"] = str(i["message"]) + lens_advice(outcome.camera.fov, float(lens.fov), str(i.get("status")),
                                                           i.get("free") or ())
        if i.get("on_ground") and self.dem is not None:
            # held on the ground, its height is the terrain's under it: as sure as its X, Y, taken from the σ as
            # finally shown (a re-check trial: Z ± 0.97 m beside the registration's X, Y ± 75, 58 m, 3.9 m off)
            i["ground_sigma_m"] = ground_height_sigma(outcome.camera, i.get("sigma"), self.dem)
        self.state.fitted = outcome.camera.to_dict()
        self.state.fit_info = outcome.info
        overlay, self.xyz = self.in_picture(outcome.overlay, outcome.xyz)  # not over a print's border
        self.overlay = None if overlay is None else array_to_qimage(overlay)
        self.footprint_wkt = outcome.footprint_wkt
        self.cameraChanged.emit()
        self._changed()
        self.message.emit(*self.fit_summary(outcome.info))
        if self.xyz is not None and not np.isfinite(self.xyz[..., 2]).any():
            # a trial's GCP table in another CRS: the fit agreed with its points ("ok"), 2,200 km from the DEM
            x, y = outcome.camera.position[:2]
            self.message.emit(self.tr("The fitted camera sees no part of the DEM (it stands at X {0:.0f}, Y {1:.0f}): "
                                      "are the map points in the DEM's CRS? No product can be made from it.")
                              .format(x, y), WARNING)

    def ensure_products(self, background: bool = True) -> None:
        """Recompute overlay and per-pixel XYZ of the fitted camera (a project was reopened, a camera loaded).

        In a task by default (a reopened project must not freeze QGIS); ``productsReady`` follows. A newer call
        or camera makes an older result stale: it is dropped."""
        cam = self.fitted
        if cam is None or self.dem is None or self.image is None:
            return
        self._products_generation = generation = getattr(self, "_products_generation", 0) + 1
        dem, key = self.dem, cam.to_dict()

        def apply(value) -> None:
            if generation != self._products_generation or self.state.fitted != key or self.dem is not dem:
                return  # another camera or DEM since: stale
            overlay, xyz, footprint = value
            overlay, self.xyz = self.in_picture(overlay, xyz)
            self.overlay = None if overlay is None else array_to_qimage(overlay)
            self.footprint_wkt = footprint
            self.cameraChanged.emit()
            self.productsReady.emit()

        if not background:
            apply(engine.render_products(cam, dem))
            return

        def done(result: TaskResult) -> None:
            self._products_tasks.remove(task)
            if result.ok:
                apply(result.value)

        task = FunctionTask(self.tr("Monoplot: overlay of the fitted camera"),
                            lambda progress, canceled: engine.render_products(cam, dem, canceled, progress), done)
        for stale in self._products_tasks:  # their results would be dropped: free the cores for this one
            stale.cancel()
        self._products_tasks.append(task)
        start_task(task)

    @property
    def products_pending(self) -> bool:
        """True while :meth:`ensure_products` renders in the background."""
        return bool(self._products_tasks)


def _num(v) -> str:
    return "-" if v is None else f"{float(v):.2f}"
