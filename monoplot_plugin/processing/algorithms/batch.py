"""Batch algorithm: a time-lapse folder sharing one camera, or a CSV table of photos with their own priors."""

import os

from qgis.core import (
    QgsProcessingException,
    QgsProcessingOutputFile,
    QgsProcessingOutputNumber,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFile,
    QgsProcessingParameterFolderDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterString,
)

from ...outputs.safe_write import cancel_before_commit, write_text
from ...workflow.auto import DEFAULT_ANGLE_SIGMA_DEG, DEFAULT_POSITION_SIGMA_M, GPS_POSITION_SIGMA_M
from ...workflow.camera_files import camera_json, fit_figures, fitted_photo
from ...workflow.products import AUTO
from .. import batch
from ..base import MonoplotAlgorithm, checked


class BatchPhotos(MonoplotAlgorithm):
    _name = "batch"
    _group = "batch"
    _display = "Batch: many photos"
    _help = ("Processes many photos at once.\n\n"
             "Time-lapse folder: every image in FOLDER shares one fitted CAMERA; the XYZ raster is computed once "
             "(xyz.tif) and an orthophoto is written per photo (frame_ortho.tif for frame.jpg). With POINTS (a GCP "
             "CSV, or a photo points CSV with DEM_POINTS for unpaired points), CAMERA is the prior and the shared "
             "camera is fitted once on the first readable photo (camera.json). A CAMERA without a fit verdict (a "
             "rough prior, a KML; cameras written by the fit carry one) is used, but its frames are logged "
             "\"uncertain: camera not fitted\".\n\n"
             "CSV table: TABLE lists photos with their own prior camera and points (columns photo, prior, points "
             "and optionally dem_points; paths relative to the table); each photo is fitted (frame_camera.json, "
             "with the fit's verdict) and gets its own XYZ raster and orthophoto. A row whose points cell is empty is "
             "registered automatically from its prior, as monoplot:autoregister does, with the prior's uncertainty "
             "POSITION_SIGMA and ANGLE_SIGMA, or the row's own in optional columns position_sigma (m) and "
             "angle_sigma (degrees). A row whose prior cell is empty starts from the photo's EXIF GPS position and "
             "direction, as autoregister does, with a position uncertainty of 30 m unless POSITION_SIGMA is set "
             "or the row gives its own (a camera file's rows: 200 m; a photo without GPS tags fails, with the "
             "reason; one "
             "without a direction tag is registered over every direction of view, three to four times as long).\n\n"
             "A KML camera (a rough prior) takes its image size from the first readable photo.\n\n"
             "Progress is reported per photo. A photo that cannot be read (damaged, truncated, not an image) or "
             "fitted, or whose size differs from the shared camera's, is reported and skipped; so is a blank photo "
             "(fog, night, a covered lens: no structure), without products. The others are processed. "
             "batch_log.csv in the output folder lists every photo's status (ok, uncertain, poor, failed, skipped "
             "or canceled; photos relative to FOLDER or to the table's folder when inside it). Photos with the "
             "same name "
             "(frame.jpg and frame.png, or in different folders) get numbered outputs (frame_2_ortho.tif); files of "
             "an earlier run in the output folder are replaced, and the log says so; those of a frame this run does "
             "not make again (failed, skipped) are removed.\n\n"
             "RESUME: a photo an earlier run into the same output folder finished (with products) is not processed "
             "again when nothing it depends on changed: the photo, its prior and point files, the camera, the DEM "
             "and the settings (batch_journal.jsonl in the output folder records them as each photo ends, so a "
             "canceled or killed run resumes where it stopped); the log says which photos were kept.\n\n"
             "Time-lapse speed: what depends only on the camera and the DEM (XYZ raster, sky, the orthophoto's "
             "lookup) is computed once; WORKERS frames are processed at once (0 = one per core).\n\n"
             "REGISTER (time-lapse mode, on by default; a table's photos are each fitted): every frame is matched "
             "to REFERENCE (default: the frame the shared camera was fitted on, when its file names it and it is "
             "in the folder; else the first frame that can be read and is not blank: fog, night) on "
             "stable terrain (no sky, no foreground) and the camera is turned by the drift found; the drift (pixels "
             "and degrees) is in the log, a frame that turned gets its own frame_camera.json and frame_xyz.tif, and "
             "a frame that cannot be registered is reported as failed (never given the reference camera). Without "
             "REGISTER, an \"ok\" camera fitted on one frame is \"uncertain\" on the others: a bump of the mount "
             "would not show.\n\n"
             "SCHEDULER: the address of a Dask scheduler (tcp://host:8786) whose workers process the frames (each "
             "frame a task; a worker that dies has its frames retried elsewhere); the workers must see the photo "
             "folder, the DEM and the output folder at the same paths. Empty: this machine.")

    MODES = ["Time-lapse folder (one shared camera)", "CSV table (each photo with its prior and points)"]
    #: under the dialog's "Advanced parameters": what has a sensible default
    ADVANCED = ("PATTERN", "DEM_POINTS", "POSITION_SIGMA", "ANGLE_SIGMA", "RESOLUTION", "REFERENCE", "WORKERS",
                "SCHEDULER")

    def initAlgorithm(self, config=None):
        self.addParameter(QgsProcessingParameterEnum("MODE", self.tr("Mode"), [self.tr(m) for m in self.MODES],
                                                     defaultValue=0))
        self.add_dem_parameter()
        self.addParameter(QgsProcessingParameterFile("FOLDER", self.tr("Photo folder (time-lapse mode)"),
                                                     QgsProcessingParameterFile.Folder, optional=True))
        self.addParameter(QgsProcessingParameterString("PATTERN", self.tr("File patterns (time-lapse mode)"),
                                                       defaultValue="*.jpg;*.jpeg;*.png;*.tif;*.tiff",
                                                       optional=True))
        self.add_camera_parameter("CAMERA", optional=True,
                                  description="Shared camera (prior if POINTS given)")
        self.addParameter(QgsProcessingParameterFile("POINTS",
                                                     self.tr("Points CSV for the shared fit"),
                                                     QgsProcessingParameterFile.File, optional=True,
                                                     fileFilter="CSV (*.csv *.txt)"))
        self.addParameter(QgsProcessingParameterFile("DEM_POINTS", self.tr("DEM points CSV (unpaired shared fit)"),
                                                     QgsProcessingParameterFile.File, optional=True,
                                                     fileFilter="CSV (*.csv *.txt)"))
        self.addParameter(QgsProcessingParameterFile("TABLE", self.tr("Photo table CSV (table mode)"),
                                                     QgsProcessingParameterFile.File, optional=True,
                                                     fileFilter="CSV (*.csv)"))
        self.add_explained(QgsProcessingParameterNumber(
            "POSITION_SIGMA", self.tr("Priors' position uncertainty (m, 1 σ)"),
            QgsProcessingParameterNumber.Double, None, optional=True, minValue=0.1),
            self.tr("For table rows without points. Empty: {0:.0f} m for EXIF GPS, {1:.0f} m for a camera "
                    "file").format(GPS_POSITION_SIGMA_M, DEFAULT_POSITION_SIGMA_M))
        self.add_explained(QgsProcessingParameterNumber(
            "ANGLE_SIGMA", self.tr("Priors' angle uncertainty (°, 1 σ)"),
            QgsProcessingParameterNumber.Double, DEFAULT_ANGLE_SIGMA_DEG, optional=True, minValue=0.1,
            maxValue=30.0), self.tr("Of the heading and pitch, for table rows without points"))
        self.addParameter(QgsProcessingParameterBoolean("XYZ", self.tr("Write XYZ rasters"), defaultValue=True))
        self.addParameter(QgsProcessingParameterBoolean("ORTHO", self.tr("Write orthophotos"), defaultValue=True))
        self.add_explained(QgsProcessingParameterNumber(
            "RESOLUTION", self.tr("Orthophoto cell size (0 = the photo's detail)"),
            QgsProcessingParameterNumber.Double, 0.0, minValue=0.0),
            self.tr("In map units; 0: the photo's own detail over the part of the DEM the camera sees"))
        self.addParameter(QgsProcessingParameterBoolean("REGISTER",
                                                        self.tr("Re-register every frame (time-lapse mode)"),
                                                        defaultValue=True))
        self.add_explained(QgsProcessingParameterFile("REFERENCE", self.tr("Reference frame (empty = automatic)"),
                                                      QgsProcessingParameterFile.File, optional=True),
                           self.tr("Empty: the frame the camera was fitted on, else the first usable frame"))
        self.addParameter(QgsProcessingParameterNumber("WORKERS", self.tr("Frames at once (0 = one per core)"),
                                                       QgsProcessingParameterNumber.Integer, 0, minValue=0))
        self.add_explained(QgsProcessingParameterString("SCHEDULER", self.tr("Dask scheduler (empty = this machine)"),
                                                        defaultValue="", optional=True),
                           self.tr("The address of a Dask scheduler, e.g. tcp://host:8786"))
        self.add_explained(QgsProcessingParameterBoolean(
            "RESUME", self.tr("Resume: keep photos an earlier run finished"), defaultValue=True),
            self.tr("Photos an earlier run in the output folder finished with the same inputs and settings are kept: "
                    "a canceled or interrupted run goes on where it stopped"))
        self.addParameter(QgsProcessingParameterFolderDestination("OUTPUT", self.tr("Output folder")))
        self.explain({
            "MODE": "Time-lapse folder: every photo in the folder shares one camera (CAMERA, fitted once when "
                    "POINTS are given). CSV table: each photo listed in TABLE has its own prior and points",
            "FOLDER": "Time-lapse mode: the folder of frames (not its sub-folders)",
            "PATTERN": "Time-lapse mode: which files of the folder are frames, patterns separated by ';'",
            "CAMERA": "Time-lapse mode: the one camera of every frame (a camera JSON or KML); with POINTS it is the "
                      "prior of a fit made once",
            "POINTS": "Time-lapse mode: a paired GCP CSV (u_px, v_px, X, Y, Z), or a photo points CSV with DEM "
                      "points CSV: the shared camera is fitted on them once",
            "DEM_POINTS": "Time-lapse mode: DEM points (X, Y, Z) for an unpaired shared fit with a photo points "
                          "CSV in POINTS",
            "TABLE": "Table mode: a CSV with columns photo, prior and points (optionally dem_points, "
                     "position_sigma, angle_sigma), paths relative to the table; a row without points is "
                     "registered automatically",
            "XYZ": "Write each camera's XYZ raster (X, Y, Z of every photo pixel)",
            "ORTHO": "Write each photo's orthophoto",
            "REGISTER": "Time-lapse mode: match every frame to the reference frame on stable terrain and turn the "
                        "camera by the drift found (a camera mount that moves); unticked: every frame gets the "
                        "shared camera as it is",
            "WORKERS": "How many frames are processed at the same time on this machine; 0: one per processor "
                       "core"})
        for name in self.ADVANCED:  # folded away: the dialog showed 16 parameters of both modes at once (a trial)
            param = self.parameterDefinition(name)
            param.setFlags(param.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
        self.addOutput(QgsProcessingOutputNumber("SUCCEEDED", self.tr("Photos processed")))
        self.addOutput(QgsProcessingOutputNumber("NOT_OK", self.tr("Photos processed whose camera is not \"ok\" "
                                                                   "(uncertain or poor)")))
        self.addOutput(QgsProcessingOutputNumber("FAILED", self.tr("Photos skipped")))
        self.addOutput(QgsProcessingOutputFile("LOG", self.tr("Batch log (CSV)")))

    def run_algorithm(self, parameters, context, feedback):
        mode = self.parameterAsEnum(parameters, "MODE", context)
        dem, crs = self.dem(parameters, context)
        out_dir = self.parameterAsString(parameters, "OUTPUT", context)
        if mode == 0:
            if not self.parameterAsFile(parameters, "CAMERA", context):
                raise QgsProcessingException(self.tr("Time-lapse mode needs the shared CAMERA (fitted with 'Fit "
                                                     "camera' on one photo, or a prior with POINTS to fit it here)."))
            if not self.parameterAsFile(parameters, "FOLDER", context):
                raise QgsProcessingException(self.tr("Time-lapse mode needs the photo FOLDER (or choose the CSV "
                                                     "table mode and give TABLE)."))
            photo_folder = self.parameterAsFile(parameters, "FOLDER", context)
            jobs = checked(batch.folder_jobs, photo_folder, None,
                           self.parameterAsString(parameters, "PATTERN", context),
                           [self.dem_path(parameters, context)[0]])  # a DEM kept beside the frames is no frame
            points = self.parameterAsFile(parameters, "POINTS", context)
            if points:  # fit once, on the first readable frame; every frame shares the camera
                camera, used, verdict = checked(batch.fit_shared_camera, [j.photo for j in jobs],
                                                self.parameterAsFile(parameters, "CAMERA", context), points,
                                                self.parameterAsFile(parameters, "DEM_POINTS", context),
                                                dem, crs.toWkt(), lambda m, e: feedback.reportError(m, False))
                camera_verdict = (verdict["status"], verdict["message"],
                                  {**fit_figures(verdict), **fitted_photo(used)})
                os.makedirs(out_dir, exist_ok=True)
                if os.path.exists(os.path.join(out_dir, "camera.json")):
                    feedback.pushInfo(self.tr("camera.json of an earlier run in {0} is replaced").format(out_dir))
                # with its verdict and σ: a later run given this camera knows it was fitted (or how doubtful it is)
                write_text(os.path.join(out_dir, "camera.json"), camera_json(camera, verdict, used), overwrite=True)
                feedback.pushInfo(self.tr("Shared camera fitted on {0}: RMSE {1:.2f} px; written to {2}").format(
                    os.path.basename(used), verdict["rmse_px"], os.path.join(out_dir, 'camera.json')))
            else:
                size = None
                if self.parameterAsFile(parameters, "CAMERA", context).lower().endswith(".kml"):
                    size = self.first_photo_size([j.photo for j in jobs], feedback)  # KML has no image size
                camera = self.camera(parameters, context, "CAMERA", crs=crs, image_size=size, dem=dem,
                                     only_if_moved=True)
                camera_verdict = batch.shared_camera_verdict(self.parameterAsFile(parameters, "CAMERA", context),
                                                             lambda m, e: feedback.pushWarning(m))
            for job in jobs:
                job.camera = camera
        else:
            if not self.parameterAsFile(parameters, "TABLE", context):
                raise QgsProcessingException(self.tr("CSV table mode needs the photo TABLE (or choose the "
                                                     "time-lapse mode and give FOLDER and CAMERA)."))
            photo_folder = os.path.dirname(os.path.abspath(self.parameterAsFile(parameters, "TABLE", context)))
            jobs = checked(batch.table_jobs, self.parameterAsFile(parameters, "TABLE", context))
            # empty: each row's own default (a trial's 200 typed in, the old default, silently meant 30 m for its
            # EXIF rows)
            position = (None if parameters.get("POSITION_SIGMA") in (None, "") else
                        self.parameterAsDouble(parameters, "POSITION_SIGMA", context) or None)
            angle = self.parameterAsDouble(parameters, "ANGLE_SIGMA", context) or DEFAULT_ANGLE_SIGMA_DEG
            from ...adapters.exif import exif_rough_camera

            for job in jobs:  # a row's own columns first
                if not job.prior:  # the photo's EXIF GPS, with a GPS's uncertainty unless one was asked for
                    job.prior_reader = exif_rough_camera
                job.position_sigma_m = job.position_sigma_m or position  # None: the row's default (fit_job)
                job.angle_sigma_deg = job.angle_sigma_deg or angle
            camera_verdict = ("ok", "")  # each row's own fit says
        feedback.pushInfo(self.tr("{0} photos to process").format(len(jobs)))

        def log(message, error):
            (feedback.pushWarning if error == batch.WARNING else feedback.reportError if error else
             feedback.pushInfo)(message)

        def progress(fraction, message=""):
            feedback.setProgress(100.0 * fraction)
            if message:  # the photo under way, or the last one done
                feedback.setProgressText(message)

        # a table's photos are each fitted on their own: nothing to re-register (on by default for a time-lapse)
        register = self.parameterAsBool(parameters, "REGISTER", context) and mode == 0
        options = dict(write_xyz=self.parameterAsBool(parameters, "XYZ", context),
                       write_ortho=self.parameterAsBool(parameters, "ORTHO", context),
                       # 0: the photo's own detail, as the Orthophoto algorithm's 0 (an archivist's batch gave 20 m
                       # cells over the whole DEM, 0.5 % of it covered, where Orthophoto gave 1.06 m over the view)
                       resolution=self.parameterAsDouble(parameters, "RESOLUTION", context) or AUTO,
                       log=log, progress=progress, is_canceled=feedback.isCanceled, register=register,
                       reference=self.parameterAsFile(parameters, "REFERENCE", context) or "",
                       camera_verdict=camera_verdict, resume=self.parameterAsBool(parameters, "RESUME", context))
        scheduler = (self.parameterAsString(parameters, "SCHEDULER", context) or "").strip()
        if scheduler:
            path, _ = self.dem_path(parameters, context)
            results = checked(batch.run_batch_dask, jobs, path, crs.toWkt(), out_dir, address=scheduler,
                              void_value=self.void_value(parameters, context), **options)
        else:
            results = checked(batch.run_batch, jobs, dem, crs.toWkt(), out_dir,
                              workers=self.parameterAsInt(parameters, "WORKERS", context) or None, **options)
        log_path = os.path.join(out_dir, batch.LOG_NAME)
        with cancel_before_commit(lambda: False):  # the log says what was done, canceled or not
            batch.write_log(log_path, results, photo_folder)
        succeeded = sum(r.ok for r in results)
        failed = len(results) - succeeded
        canceled = sum(r.canceled for r in results)
        if canceled:
            feedback.pushInfo(self.tr("{0} photos processed, {1} skipped, {2} not processed (canceled); "
                                      "log: {3}").format(succeeded, failed - canceled, canceled, log_path))
        else:
            feedback.pushInfo(self.tr("{0} photos processed, {1} skipped; log: {2}").format(succeeded, failed,
                                                                                            log_path))
        hint = batch.other_viewpoints_hint(results) if mode == 0 else ""
        if hint:
            feedback.pushWarning(self.tr(hint))
        doubtful = sum(r.ok and r.verdict() != "ok" for r in results)
        if doubtful:  # processed is not right: their cameras are doubtful
            feedback.pushWarning(self.tr("{0} of the photos processed have a camera whose verdict is not \"ok\" "
                                         "(uncertain or poor): check them before use (status column of the "
                                         "log).").format(doubtful))
        if canceled:  # a run cut short is not a success (qgis_process said 0 after Ctrl+C, a trial)
            raise QgsProcessingException(self.tr("Canceled: {0} photos processed, {1} not processed; see {2}").format(
                succeeded, canceled, log_path))
        if succeeded == 0:
            raise QgsProcessingException(self.tr("No photo could be processed; see {0}").format(log_path))
        return {"OUTPUT": out_dir, "SUCCEEDED": succeeded, "FAILED": failed, "LOG": log_path, "NOT_OK": doubtful}

    def first_photo_size(self, photos, feedback):
        """(width, height) of the first readable photo (a KML camera takes the frames' size from it)."""
        from ..inputs import InputError, photo_size

        for path in photos:
            try:
                size = photo_size(path)
            except InputError:
                continue
            feedback.pushInfo(self.tr("KML camera: image size {0}x{1} px taken from {2}").format(
                size[0], size[1], os.path.basename(path)))
            return size
        raise QgsProcessingException(self.tr("No photo of the folder could be read (a KML camera takes its image "
                                             "size from the first readable photo)."))
