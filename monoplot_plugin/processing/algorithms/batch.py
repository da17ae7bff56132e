"""Batch algorithm: a time-lapse folder sharing one camera, or a CSV table of photos with their own priors."""

import os

from qgis.core import (
    QgsProcessingException,
    QgsProcessingOutputFile,
    QgsProcessingOutputNumber,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFile,
    QgsProcessingParameterFolderDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterString,
)

from .. import batch
from ..base import MonoplotAlgorithm, checked


class BatchPhotos(MonoplotAlgorithm):
    _name = "batch"
    _display = "Batch: many photos"
    _help = ("Processes many photos at once.\n\n"
             "Time-lapse folder: every image in FOLDER shares one fitted CAMERA; the XYZ raster is computed once "
             "(xyz.tif) and an orthophoto is written per photo (<name>_ortho.tif). With POINTS (and DEM_POINTS "
             "for unpaired points), CAMERA is the prior and the shared camera is fitted once on the first readable "
             "photo (camera.json).\n\n"
             "CSV table: TABLE lists photos with their own prior camera and points (columns photo, prior, points "
             "and optionally dem_points; paths relative to the table); each photo is fitted (<name>_camera.json) "
             "and gets its own XYZ raster and orthophoto.\n\n"
             "Progress is reported per photo. A photo that cannot be read or fitted is reported and skipped; the "
             "others are processed. batch_log.csv in the output folder lists every photo's status.")

    MODES = ["Time-lapse folder (one shared camera)", "CSV table (each photo with its prior and points)"]

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
                                  description="Shared camera, or its prior when POINTS is given (time-lapse mode)")
        self.addParameter(QgsProcessingParameterFile("POINTS", self.tr("Points to fit the shared camera on the first "
                                                                       "photo: paired GCP CSV or photo points CSV "
                                                                       "(time-lapse mode, optional)"),
                                                     QgsProcessingParameterFile.File, optional=True,
                                                     fileFilter="CSV (*.csv *.txt)"))
        self.addParameter(QgsProcessingParameterFile("DEM_POINTS", self.tr("DEM points CSV for an unpaired shared fit "
                                                                           "(time-lapse mode, optional)"),
                                                     QgsProcessingParameterFile.File, optional=True,
                                                     fileFilter="CSV (*.csv *.txt)"))
        self.addParameter(QgsProcessingParameterFile("TABLE", self.tr("Photo table CSV (table mode)"),
                                                     QgsProcessingParameterFile.File, optional=True,
                                                     fileFilter="CSV (*.csv)"))
        self.addParameter(QgsProcessingParameterBoolean("XYZ", self.tr("Write XYZ rasters"), defaultValue=True))
        self.addParameter(QgsProcessingParameterBoolean("ORTHO", self.tr("Write orthophotos"), defaultValue=True))
        self.addParameter(QgsProcessingParameterNumber("RESOLUTION",
                                                       self.tr("Orthophoto cell size (map units, 0 = DEM's)"),
                                                       QgsProcessingParameterNumber.Double, 0.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterFolderDestination("OUTPUT", self.tr("Output folder")))
        self.addOutput(QgsProcessingOutputNumber("SUCCEEDED", self.tr("Photos processed")))
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
            jobs = checked(batch.folder_jobs, self.parameterAsFile(parameters, "FOLDER", context), None,
                           self.parameterAsString(parameters, "PATTERN", context))
            points = self.parameterAsFile(parameters, "POINTS", context)
            if points:  # fit once, on the first readable frame; every frame shares the camera
                camera, used, rmse = checked(batch.fit_shared_camera, [j.photo for j in jobs],
                                             self.parameterAsFile(parameters, "CAMERA", context), points,
                                             self.parameterAsFile(parameters, "DEM_POINTS", context), dem,
                                             crs.toWkt(), lambda m, e: feedback.reportError(m, False))
                os.makedirs(out_dir, exist_ok=True)
                camera.save(os.path.join(out_dir, "camera.json"))
                feedback.pushInfo(self.tr("Shared camera fitted on {0}: RMSE {1:.2f} px; written to {2}").format(
                    os.path.basename(used), rmse, os.path.join(out_dir, 'camera.json')))
            else:
                camera = self.camera(parameters, context, "CAMERA")
            for job in jobs:
                job.camera = camera
        else:
            jobs = checked(batch.table_jobs, self.parameterAsFile(parameters, "TABLE", context))
        feedback.pushInfo(self.tr("{0} photos to process").format(len(jobs)))

        def log(message, error):
            (feedback.reportError if error else feedback.pushInfo)(message)

        def progress(fraction):
            feedback.setProgress(100.0 * fraction)
            return feedback.isCanceled()

        results = batch.run_batch(jobs, dem, crs.toWkt(), out_dir,
                                  write_xyz=self.parameterAsBool(parameters, "XYZ", context),
                                  write_ortho=self.parameterAsBool(parameters, "ORTHO", context),
                                  resolution=self.parameterAsDouble(parameters, "RESOLUTION", context) or None,
                                  log=log, progress=progress)
        log_path = os.path.join(out_dir, "batch_log.csv")
        batch.write_log(log_path, results)
        succeeded = sum(r.ok for r in results)
        failed = len(results) - succeeded
        feedback.pushInfo(self.tr("{0} photos processed, {1} skipped; log: {2}").format(succeeded, failed, log_path))
        if succeeded == 0:
            raise QgsProcessingException(self.tr("No photo could be processed; see {0}").format(log_path))
        return {"OUTPUT": out_dir, "SUCCEEDED": succeeded, "FAILED": failed, "LOG": log_path}
