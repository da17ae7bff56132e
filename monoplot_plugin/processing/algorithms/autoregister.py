"""Register a photo on the DEM automatically (issue 13): the camera from the photo, the DEM and a rough prior."""

from typing import Tuple

from qgis.core import (
    QgsProcessingException,
    QgsProcessingParameterBoolean,
    QgsProcessingOutputNumber,
    QgsProcessingOutputString,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterNumber,
)

from ...core.camera import Camera
from ...outputs.safe_write import write_text
from ...workflow import auto
from ...workflow.camera_files import camera_json
from ...workflow.progress import Canceled
from ..base import (MonoplotAlgorithm, cancel_callback, centred_on_print, check_canceled, checked, progress_callback,
                    report_status, camera_line)
from ..inputs import read_photo, write_points_csv
from .fit import add_height_parameters, height_choice


def camera_from_exif(path: str, size, dem) -> Tuple[Camera, bool]:
    """(rough camera, heading known) from the photo's EXIF GPS tags (:func:`~...adapters.exif.exif_rough_camera`)."""
    from ...adapters.exif import exif_rough_camera

    try:
        return exif_rough_camera(path, size, dem)
    except ValueError as e:
        raise QgsProcessingException(f"No prior camera given and {e}: give a Monoplot JSON or KML PhotoOverlay "
                                     "camera.") from None


class AutoRegister(MonoplotAlgorithm):
    _name = "autoregister"
    _display = "Register photo automatically"
    _help = ("Finds the camera with no points given: the photo's skyline and terrain edges are aligned with the "
             "DEM's silhouettes seen from camera hypotheses within the prior's uncertainty, then Monoplot's photo "
             "and DEM suggestions consistent with the aligned camera are fitted like any unpaired fit. The prior "
             "is a Monoplot JSON or KML PhotoOverlay camera, or (when none is given) the photo's EXIF GPS "
             "position and direction. Without a direction tag, or with ANY_HEADING (a viewpoint known, its "
             "direction not), every direction of view is searched: three to four times as long. Writes the "
             "camera as JSON; STATUS says whether the evidence supports it (ok / uncertain / poor) and MESSAGE "
             "why. In a batch, give each photo its own prior. Frames of one "
             "fixed camera (a time-lapse) need one camera, not one each: registered one by one, the same camera "
             "came out up to 38 m apart and a glacier front seemed to move 20 m; register one frame here and "
             "give its camera to 'Batch: many photos' (time-lapse mode, REGISTER for a camera that drifts).")

    def initAlgorithm(self, config=None):
        self.add_photo_parameter()
        self.add_dem_parameter()
        self.add_camera_parameter("PRIOR", optional=True, description="Prior camera (empty: EXIF GPS)",
                                  explanation=self.tr("A Monoplot camera JSON or a KML PhotoOverlay; empty: the "
                                                      "position in the photo's EXIF GPS tags"))
        # empty by default: an EXIF GPS position is known to a GPS's usual error, as the dock and the batch take it
        # (a phone trial: 200 m here gave "uncertain" where the dock's 30 m gave "ok" on the same photo)
        self.add_explained(QgsProcessingParameterNumber(
            "POSITION_SIGMA", self.tr("Position uncertainty (m, 1 σ)"),
            QgsProcessingParameterNumber.Double, None, optional=True, minValue=0.1),
            self.tr("Empty: {0:.0f} m for the photo's EXIF GPS position, {1:.0f} m for a prior camera file").format(
                auto.GPS_POSITION_SIGMA_M, auto.DEFAULT_POSITION_SIGMA_M))
        self.addParameter(QgsProcessingParameterNumber(
            "ANGLE_SIGMA", self.tr("Heading and pitch uncertainty (°, 1 σ)"),
            QgsProcessingParameterNumber.Double, auto.DEFAULT_ANGLE_SIGMA_DEG, minValue=0.1, maxValue=30.0))
        self.add_explained(QgsProcessingParameterNumber(
            "FOV_SIGMA", self.tr("Field of view uncertainty (°, 1 σ)"),
            QgsProcessingParameterNumber.Double, optional=True, minValue=0.1, maxValue=40.0),
            self.tr("Empty: 10 % of the prior's field of view"))
        self.add_explained(QgsProcessingParameterBoolean(
            "ANY_HEADING", self.tr("Heading unknown: search every direction"), defaultValue=False),
            self.tr("The prior's heading is not known: the search looks in every direction of view (three to four "
                    "times as long)"))
        # held on the ground as the dock's Find camera holds it (a phone trial: an EXIF altitude 14 m too high, and
        # Processing had no way to say the photo was taken standing on the ground: 40 m off, 20.7 m too high)
        add_height_parameters(self)
        self.explain({"ANGLE_SIGMA": "How far the prior's heading and pitch may be off (degrees, one σ); the search "
                                     "looks about three σ around them. For a heading not known at all, tick "
                                     "'Heading unknown' instead"})
        self.addParameter(QgsProcessingParameterFileDestination("OUTPUT", self.tr("Camera"),
                                                                "Monoplot camera (*.json)"))
        # the message says "check the matched points": an archivist had none to check (only the dock showed them)
        self.add_explained(QgsProcessingParameterFileDestination(
            "MATCHED", self.tr("Matched points"), "CSV (*.csv)", optional=True, createByDefault=False),
            self.tr("The photo / DEM point pairs the camera was fitted on (id, u_px, v_px, X, Y, Z), to check them "
                    "on the photo and the map, or to fit again with Fit camera after removing wrong ones"))
        self.addOutput(QgsProcessingOutputNumber("RMSE_PX", self.tr("Reprojection error of the matched points (px)")))
        self.addOutput(QgsProcessingOutputNumber("N_MATCHED", self.tr("Matched point pairs")))
        self.addOutput(QgsProcessingOutputString("STATUS", self.tr("Status (ok / uncertain / poor)")))
        self.addOutput(QgsProcessingOutputString("MESSAGE", self.tr("What was found and, unless ok, what to do")))

    def run_algorithm(self, parameters, context, feedback):
        photo_path = self.photo_path(parameters, context)
        dem, crs = self.dem(parameters, context)
        image = checked(read_photo, photo_path)
        size = (image.shape[1], image.shape[0])
        heading_known = not self.parameterAsBool(parameters, "ANY_HEADING", context)
        if self.parameterAsFile(parameters, "PRIOR", context):
            prior = self.camera(parameters, context, "PRIOR", crs=crs, image_size=size, rough=True)
        else:
            prior, tagged = camera_from_exif(photo_path, size, dem)
            heading_known = heading_known and tagged
            feedback.pushInfo(self.tr("Prior camera from the photo's EXIF GPS tags.") + (
                "" if heading_known else " " + self.tr("They give no direction of view: every direction is searched "
                                                       "(three to four times as long).")))
        prior = centred_on_print(prior, image, feedback)
        from_exif = not self.parameterAsFile(parameters, "PRIOR", context)
        position_sigma = parameters.get("POSITION_SIGMA")
        if position_sigma in (None, ""):
            position_sigma = auto.GPS_POSITION_SIGMA_M if from_exif else auto.DEFAULT_POSITION_SIGMA_M
            feedback.pushInfo(self.tr("Prior position uncertainty: {0:.0f} m ({1}).").format(
                position_sigma, self.tr("a GPS's usual error") if from_exif else self.tr("the default")))
        else:
            position_sigma = self.parameterAsDouble(parameters, "POSITION_SIGMA", context)
        fov_sigma = parameters.get("FOV_SIGMA")
        fov_sigma = None if fov_sigma in (None, "") else self.parameterAsDouble(parameters, "FOV_SIGMA", context)
        try:
            done = auto.register(image, dem, prior,
                                 position_sigma_m=position_sigma,
                                 angle_sigma_deg=self.parameterAsDouble(parameters, "ANGLE_SIGMA", context),
                                 fov_sigma_deg=fov_sigma, progress=progress_callback(feedback, 0, 95),
                                 is_canceled=cancel_callback(feedback), heading_known=heading_known,
                                 **height_choice(self, parameters, context))
        except Canceled:
            raise QgsProcessingException(self.tr("Registration canceled; no camera written.")) from None
        result = done.result
        report_status(feedback, self.tr("Registration"), result.status, result.message)
        camera = done.camera
        camera.crs_wkt = crs.toWkt()
        out = self.parameterAsFileOutput(parameters, "OUTPUT", context)
        check_canceled(feedback)
        # with its verdict: an uncertain or poor registration's camera (the prior, or the best found) is written
        # all the same, and the products made from it warn of it
        write_text(out, camera_json(camera, {"status": result.status, "message": result.message,
                                             "sigma": result.std, "mode": "automatic"}, photo_path),
                   overwrite=True)
        feedback.pushInfo(self.tr("Camera: {0}").format(camera_line(camera)))
        if result.std:
            feedback.pushInfo(self.tr("One standard deviation: {0}").format(
                ", ".join(f"{k} ± {v:.3g}" for k, v in result.std.items())))
        feedback.setProgress(100)
        uv, xyz = done.matched_points()
        results = {"OUTPUT": out, "RMSE_PX": float(result.rmse_px), "N_MATCHED": int(len(uv)),
                   "STATUS": result.status, "MESSAGE": result.message}
        matched = self.parameterAsFileOutput(parameters, "MATCHED", context)
        if matched:
            write_points_csv(matched, uv=uv, xyz=xyz, ids=[f"m{i + 1}" for i in range(len(uv))])
            feedback.pushInfo(self.tr("{0} matched point pairs: {1}").format(len(uv), matched))
            results["MATCHED"] = matched
        return results
