"""Suggest photo points and DEM points (candidate ground-control points for the user to curate)."""

from qgis.core import (
    QgsCoordinateReferenceSystem,
    QgsProcessing,
    QgsProcessingOutputNumber,
    QgsProcessingParameterFeatureSink,
    QgsProcessingParameterNumber,
    QgsWkbTypes,
)

from .. import pipeline
from ..safe_sink import safe_sink
from ..base import (MonoplotAlgorithm, check_canceled, checked, map_point_fields, photo_point_fields,
                    write_map_points, write_photo_points)
from ..inputs import read_photo


class SuggestPhotoPoints(MonoplotAlgorithm):
    _name = "suggestphotopoints"
    _display = "Suggest photo points"
    _help = ("Detects distinctive points (ORB key points, summits and ridge corners) on the photo and writes them "
             "as a point layer in photo pixel space (x = column, y = -row; fields u_px, v_px, score). Accept or "
             "delete points in that layer, then use it in 'Fit camera'.")

    def initAlgorithm(self, config=None):
        self.add_photo_parameter()
        self.addParameter(QgsProcessingParameterNumber("MAX_POINTS", self.tr("Maximum number of points"),
                                                       QgsProcessingParameterNumber.Integer, 60, minValue=1,
                                                       maxValue=10000))
        self.explain({"MAX_POINTS": "At most this many points, the most distinctive first, spread over the photo"})
        self.addParameter(QgsProcessingParameterFeatureSink("OUTPUT", self.tr("Suggested photo points"),
                                                            QgsProcessing.TypeVectorPoint))
        self.addOutput(QgsProcessingOutputNumber("COUNT", self.tr("Number of points")))

    def run_algorithm(self, parameters, context, feedback):
        photo = checked(read_photo, self.photo_path(parameters, context))
        count = self.parameterAsInt(parameters, "MAX_POINTS", context)
        feedback.pushInfo(self.tr("Photo {0}x{1} px; detecting up to {2} points").format(
            photo.shape[1], photo.shape[0], count))
        feedback.setProgress(10)
        uv, scores, warning = pipeline.suggest_photo(photo, count)
        check_canceled(feedback)
        if warning:
            feedback.pushWarning(warning)
        sink = safe_sink(self, parameters, "OUTPUT", context, photo_point_fields(), QgsWkbTypes.Point,
                         QgsCoordinateReferenceSystem())
        write_photo_points(sink, uv, scores)
        dest = sink.commit()
        feedback.pushInfo(self.tr("{0} photo points suggested").format(len(uv)))
        feedback.setProgress(100)
        return {"OUTPUT": dest, "COUNT": len(uv)}


class SuggestDemPoints(MonoplotAlgorithm):
    _name = "suggestdempoints"
    _display = "Suggest DEM points"
    _help = ("Detects terrain landmarks on the DEM (summits, and ORB key points on a shaded rendering of it) and "
             "writes them as a 3-D point layer in the DEM's CRS (fields X, Y, Z, score, label). With a prior "
             "camera, only points visible from that camera (in view and not hidden by terrain) are kept.")

    def initAlgorithm(self, config=None):
        self.add_dem_parameter()
        self.add_camera_parameter("CAMERA", optional=True,
                                  description="Prior camera (keeps the points it sees)")
        self.add_photo_parameter("PHOTO", optional=True, description="Photo (needed only for a KML camera)")
        self.addParameter(QgsProcessingParameterNumber("MAX_POINTS", self.tr("Maximum number of points"),
                                                       QgsProcessingParameterNumber.Integer, 60, minValue=1,
                                                       maxValue=10000))
        self.add_explained(QgsProcessingParameterNumber(
            "POSITION_SIGMA", self.tr("Position uncertainty (m, 1 σ)"),
            QgsProcessingParameterNumber.Double, None, optional=True, minValue=0.0),
            self.tr("Of the prior camera's position; empty: 100 m. Terrain nearer than this that fills the camera's "
                    "view is left out"))
        self.explain({"MAX_POINTS": "At most this many points, summits and the most distinctive key points first"})
        self.addParameter(QgsProcessingParameterFeatureSink("OUTPUT", self.tr("Suggested DEM points"),
                                                            QgsProcessing.TypeVectorPoint))
        self.addOutput(QgsProcessingOutputNumber("COUNT", self.tr("Number of points")))

    def run_algorithm(self, parameters, context, feedback):
        dem, crs = self.dem(parameters, context)
        camera = None
        if self.parameterAsFile(parameters, "CAMERA", context):
            photo = self.parameterAsFile(parameters, "PHOTO", context) or None
            camera = self.camera(parameters, context, photo=photo, crs=crs, rough=True)
        count = self.parameterAsInt(parameters, "MAX_POINTS", context)
        feedback.setProgress(10)
        sigma = parameters.get("POSITION_SIGMA")
        sigma = None if sigma in (None, "") else self.parameterAsDouble(parameters, "POSITION_SIGMA", context)
        xyz, scores, labels, near_clip_m = pipeline.suggest_dem(dem, count, camera, sigma, feedback.isCanceled)
        check_canceled(feedback)
        sink = safe_sink(self, parameters, "OUTPUT", context, map_point_fields(), QgsWkbTypes.PointZ, crs)
        write_map_points(sink, xyz, scores, labels)
        dest = sink.commit()
        feedback.pushInfo(self.tr("{0} DEM points suggested").format(len(xyz)))
        if near_clip_m:
            feedback.pushWarning(self.tr("Terrain within {0:.0f} m of the prior camera fills its view. Its position "
                                         "is only known to about {0:.0f} m, so that terrain is left out of the "
                                         "suggestions. If the photo does show a slope that close, give a smaller "
                                         "POSITION_SIGMA; if not, check the camera's position and height."
                                         ).format(near_clip_m))
        feedback.setProgress(100)
        return {"OUTPUT": dest, "COUNT": len(xyz)}
