"""The dock's raster and report products (XYZ raster, orthophoto, report): the save dialogs, the work copied on the
main thread and run in a QgsTask, the layer added and the user told when it is done.

Owned by :class:`~.product_panel.OutputTools` (which keeps the public ``export_*`` / ``start_export`` methods and
the ``exported`` signal); what it needs of the panel is passed in: the :class:`~.product_panel.ProductHost`, the
``ready()`` check, the photo's name, the message line and the signal's ``emit``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Optional

from qgis.core import Qgis
from qgis.PyQt.QtCore import QCoreApplication
from qgis.PyQt.QtWidgets import QFileDialog

from ..adapters.exif import read_photo_taken
from ..outputs.safe_write import OutputError, check_can_write
from ..workflow import products as product_step
from .map_layers import add_orthophoto_layer, add_xyz_layer, photo_group

__all__ = ["ProductExports", "LAST_FOLDER_KEY"]

#: QgsSettings key of the folder the last product was saved to (the next save dialog opens there).
LAST_FOLDER_KEY = "monoplot/last_output_folder"


def writable_folder(candidates) -> Path:
    """The first of ``candidates`` (paths, "" skipped) that is a folder one can write to, else the home folder: a
    save dialog opened in a trial's read-only data folder (the photo's), and the first save failed there."""
    import os

    for folder in candidates:
        if folder and Path(folder).is_dir() and os.access(folder, os.W_OK):
            return Path(folder)
    return Path.home()


class ProductExports:
    """XYZ raster, orthophoto and report of the fitted camera, for one dock."""

    def __init__(self, host, ready: Callable[[], Optional[str]], photo_name: Callable[[], str],
                 message: Callable, exported: Callable[[str, str], None]):
        self.host = host
        self.controller = host.controller
        self.project = host.project
        self.ready, self.photo_name, self.message, self.exported = ready, photo_name, message, exported
        self._tasks: list = []  # running export tasks (kept referenced until done)

    def tr(self, text: str) -> str:
        return QCoreApplication.translate("OutputTools", text)

    # --- paths given (scripts, tests) -------------------------------------------------------------------------
    def export_xyz(self, path, overwrite: bool = False, distance: bool = False):
        """The product card's 3-band X, Y, Z raster (a distance band when asked), added to the photo's group."""
        written = self._work("xyz", path, overwrite, distance=distance)()
        return add_xyz_layer(written, self.project, photo_group(self.project, self.photo_name()))

    def export_orthophoto(self, path, overwrite: bool = False):
        written = self._work("ortho", path, overwrite)()
        return add_orthophoto_layer(written, self.project, photo_group(self.project, self.photo_name()))

    def export_report(self, path, overwrite: bool = False):
        return self._work("report", path, overwrite)()

    def _work(self, what: str, path, overwrite: bool, distance: bool = False):
        """``work(progress=None, is_canceled=None) -> written path`` of the product ``what`` ("xyz", "ortho",
        "report", :mod:`..workflow.products`), with everything it needs copied now (main thread), so that it can
        run in a task: it touches no Qt object and no layer."""
        from ..adapters.photo import qimage_to_array

        c = self.controller
        camera, dem, name = c.fitted, c.dem, self.photo_name()
        photo = qimage_to_array(c.image)  # the XYZ raster too: a print's border and caption get no coordinates
        points, sigmas = (self.controller.report_inputs() if what == "report" else (None, None))
        checks = self.controller.report_checks() if what == "report" else None
        info = self.controller.state.fit_info if isinstance(self.controller.state.fit_info, dict) else {}
        verdict = f"{info.get('status', '')}: {info.get('message', '')}" if info.get("status") else ""
        accuracy = self.controller.ground_accuracy_text().strip(" ()") if what == "report" else ""
        if what == "report" and verdict and c.fit_points_changed():
            # a trial's report drew the points of after an edit ("RMSE 7.94 px on 6 points") under the figures of
            # the fit before it ("paired fit on 7 pairs: RMSE 7.5 px"), and nothing said the two differ
            stale = self.tr("The accepted points changed after this fit: the points drawn are the current ones, "
                            "the figures the fit's. Fit again for a report whose figures match them.")
            verdict = f"{info.get('status', '')}: {stale} {info.get('message', '')}"
            c.message.emit(stale, Qgis.MessageLevel.Warning)

        taken = (read_photo_taken(c.state.photo_path or "") or "") if what == "report" else ""  # not in the task

        def work(progress=None, is_canceled=None):
            if what == "xyz":
                return product_step.write_xyz(path, camera, dem, photo_name=name, distance=distance,
                                          overwrite=overwrite, progress=progress, is_canceled=is_canceled,
                                          fit=dict(info), photo=photo, allow_empty=False)
            if what == "ortho":
                return product_step.orthophoto(path, photo, camera, dem, product_step.AUTO, overwrite=overwrite,
                                               progress=progress, is_canceled=is_canceled, allow_empty=False,
                                               fit=dict(info))
            return product_step.report(path, photo, camera, dem, points=points, sigmas=sigmas, title=Path(name).stem,
                                       overwrite=overwrite, progress=progress, is_canceled=is_canceled,
                                       verdict=verdict, checks=checks, accuracy=accuracy,
                                       photo_taken=taken)

        return work

    def output_folder(self) -> Path:
        """Where the save dialogs open: the folder of the last product saved, else the saved project's folder,
        else the photo's folder: the first of them one can write to (see :func:`writable_folder`)."""
        from qgis.core import QgsSettings

        last = QgsSettings().value(LAST_FOLDER_KEY, "", type=str)
        photo_folder = str(Path(self.controller.state.photo_path or ".").parent)
        return writable_folder([last, self.project.absolutePath(), photo_folder])

    def ask(self, title: str, filters: str, suffix: str) -> Optional[str]:
        from qgis.core import QgsSettings

        stem = Path(self.photo_name()).stem
        start = str(self.output_folder() / f"{stem}_{suffix}")
        path, _ = QFileDialog.getSaveFileName(self.host.widget, title, start, filters)
        if path:
            QgsSettings().setValue(LAST_FOLDER_KEY, str(Path(path).parent))
        return path or None

    def ask_xyz(self) -> None:
        path = self.ask(self.tr("Save the XYZ raster"), "GeoTIFF (*.tif)", "xyz.tif")
        if path:  # the dialog already asked before replacing a file
            self.start_export("xyz", path, overwrite=True)

    def ask_ortho(self) -> None:
        path = self.ask(self.tr("Save the orthophoto"), "GeoTIFF (*.tif)", "ortho.tif")
        if path:
            self.start_export("ortho", path, overwrite=True)

    def ask_report(self) -> None:
        path = self.ask(self.tr("Save the report"), "PDF (*.pdf);;PNG (*.png)", "report.pdf")
        if path:
            self.start_export("report", path, overwrite=True)

    # --- background exports -----------------------------------------------------------------------------------
    def abandon(self) -> None:
        """The dock is going away: cancel the running exports, which then tell nobody (:func:`.tasks.abandon`)."""
        from .tasks import abandon

        for task in self._tasks:
            abandon(task)
        self._tasks = []

    def start_export(self, what: str, path, overwrite: bool = False):
        """Compute and write the XYZ raster ("xyz"), orthophoto ("ortho") or report ("report") in a QgsTask;
        the layer is added and the user told on the main thread when it is done. Returns the task (None when
        the inputs are missing: the reason is shown)."""
        from .tasks import FunctionTask, start_task

        reason = self.ready()
        if reason is not None:
            self.message(reason, Qgis.MessageLevel.Warning)
            return None
        try:  # before minutes of work (a trial's orthophoto into a missing folder failed after 7 s)
            check_can_write(path, overwrite)
        except OutputError as exc:
            self.message(self.tr("Nothing was written: {0}").format(exc), Qgis.MessageLevel.Warning)
            return None
        name = self.photo_name()
        work = self._work(what, path, overwrite)  # copies what the worker needs, now
        generation = self.controller.project_generation

        def done(result):
            self._tasks = [t for t in self._tasks if t is not task]
            # canceled after the file was renamed into place: it is written, complete, and said so
            late = result.status == "canceled" and result.value is not None
            if (not result.ok and not late) or result.value is None:
                if result.status == "canceled":
                    self.message(self.tr("Export canceled; nothing was replaced."), Qgis.MessageLevel.Info)
                else:
                    self.message(self.tr("Nothing was written: {0}").format(result.reason),
                                  Qgis.MessageLevel.Critical)
                return
            written = result.value
            if self.controller.project_generation != generation:
                # its project was closed meanwhile (a trial: the orthophoto of the closed project was added to
                # the new, empty one)
                self.message(self.tr("Written: {0}; not added to this project: it was made for the project closed "
                                     "since.").format(written), Qgis.MessageLevel.Info)
                return
            shown = str(written)
            if what == "xyz":  # a raster in photo pixels: its X, Y, Z are in the DEM's CRS, which a trial in a
                # Web Mercator project found nowhere but in the file's metadata
                crs = self.controller.dem_crs
                shown += self.tr(" (X, Y, Z in {0}; the raster itself lies in photo pixels, without a CRS)").format(
                    crs.authid() or crs.description() or self.tr("the DEM's CRS"))
            group = photo_group(self.project, name)
            if what == "xyz":
                add_xyz_layer(written, self.project, group)
            elif what == "ortho":
                add_orthophoto_layer(written, self.project, group)
            status = (self.controller.state.fit_info or {}).get("status", "ok")
            if status in ("uncertain", "poor"):  # the product inherits the camera's errors: say so once, here
                self.message(self.tr("Written: {0}, from a camera whose fit is \"{1}\": every position in it "
                                      "inherits the camera's errors. Check the fit (pairs, check points) before "
                                      "using it.").format(shown, self.tr(status)), Qgis.MessageLevel.Warning)
            elif late:
                self.message(self.tr("Written: {0} (the cancel came after the file was complete).").format(
                    shown), Qgis.MessageLevel.Info)
            else:
                self.message(self.tr("Written: {0}").format(shown) + self.controller.ground_accuracy_text(),
                              Qgis.MessageLevel.Success)
            self.exported(what, str(written))

        labels = {"xyz": self.tr("XYZ raster"), "ortho": self.tr("Orthophoto"), "report": self.tr("Report")}
        task = FunctionTask(self.tr("Monoplot: {0}").format(labels[what]), work, done)
        self._tasks.append(task)
        # said in the dock's status line (not the message bar, where it would pile up under "Written"): the task
        # bar's progress is easy to miss, and the dock gave no sign for seconds
        self.host.show_status(self.tr("{0}: computing {1}… (progress and Cancel in QGIS's task bar)")
                                      .format(labels[what], Path(str(path)).name))
        return start_task(task)
