"""Products of a fitted camera: XYZ raster, photo features -> map, map -> photo, orthophoto, report."""

import numpy as np
from qgis.core import (
    QgsCoordinateReferenceSystem,
    QgsCoordinateTransform,
    QgsFeature,
    QgsFeatureRequest,
    QgsFeatureSink,
    QgsField,
    QgsFields,
    QgsProcessingException,
    QgsProcessingFeatureSource,
    QgsProcessingOutputNumber,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterFeatureSink,
    QgsProcessingParameterFeatureSource,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterDestination,
    QgsWkbTypes,
)
from qgis.PyQt.QtCore import QVariant

from .. import geometry as geo
from .. import pipeline
from ..base import (PHOTO_Y_SIGN, MonoplotAlgorithm, camera_line, cancel_callback, check_canceled, checked,
                    progress_callback)
from ..inputs import read_photo
from ...adapters.exif import read_photo_taken
from ...core.xyz_strips import plan_strips
from ...workflow.camera_files import verdict_on_photo, written_fit
from ...outputs.vectors import FIT_STATUS_FIELD
from ...workflow.products import AUTO, NO_GROUND, ProductError, blank_outside, ortho_grid, picture_area
from ...workflow.inputs import check_not_empty
from ..safe_sink import keep_pixel_space, safe_sink

#: Features are read without QGIS's geometry validity check: a self-intersecting outline drawn on the photo is
#: mapped (with a warning) as the dock maps it, and the check's abort, thrown from inside the feature iterator,
#: left Python 3.11 broken ("SystemError: unknown opcode" at the next import) and a temporary file behind (a trial).
SKIP_VALIDITY = QgsProcessingFeatureSource.FlagSkipGeometryValidityChecks


class _CameraDemAlgorithm(MonoplotAlgorithm):
    """Algorithms that need a camera and a DEM (and optionally the photo, for a KML camera's size)."""

    _group = "products"

    def add_camera_dem(self, photo_optional=True):
        self.add_camera_parameter()
        self.add_dem_parameter()
        self.add_photo_parameter("PHOTO", optional=photo_optional,
                                 description="Photo" if not photo_optional else "Photo (KML camera, print border)",
                                 explanation=self.tr("Needed for a KML camera; with it, a scanned print's border is "
                                                     "left out") if photo_optional else "")

    def add_allow_empty(self):
        param = QgsProcessingParameterBoolean("ALLOW_EMPTY", self.tr("Write an empty output (else an error)"),
                                              defaultValue=False, optional=True)
        param.setFlags(param.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
        param.setHelp(self.tr("Ticked: a result with nothing in it (the camera sees no terrain, no feature in view) "
                              "is written empty and the run succeeds, as a script over many inputs may want; "
                              "unticked: the run stops with an error that says why"))
        self.addParameter(param)

    def check_not_empty(self, parameters, context, count, what, hint):
        checked(check_not_empty, count, what, self.parameterAsBool(parameters, "ALLOW_EMPTY", context), hint)

    def camera_and_dem(self, parameters, context, feedback):
        dem, crs = self.dem(parameters, context)
        photo = self.parameterAsFile(parameters, "PHOTO", context) or None
        camera = self.camera(parameters, context, "CAMERA", photo=photo, crs=crs, dem=dem)
        # the heading as fitcamera's log, the dock and the report give it (0-360; it said -63.61 for 296.39)
        feedback.pushInfo(self.tr("Camera: {0}; image {1}x{2}").format(camera_line(camera), camera.width,
                                                                       camera.height))
        return camera, dem, crs


class ComputeXyz(_CameraDemAlgorithm):
    _name = "computexyz"
    _display = "Compute XYZ raster"
    _help = ("Intersects the ray of every photo pixel with the DEM and writes a 3-band GeoTIFF of the photo's size "
             "(bands X, Y, Z in the DEM's CRS; nodata where the ray sees the sky). With it, every pixel of the photo "
             "has map coordinates. Given the photo, the paper border, frame and printed caption of a scanned print "
             "get no coordinates (nodata).")

    def initAlgorithm(self, config=None):
        self.add_camera_dem()
        self.addParameter(QgsProcessingParameterRasterDestination("OUTPUT", self.tr("XYZ raster")))
        self.addOutput(QgsProcessingOutputNumber("GROUND_FRACTION", self.tr("Fraction of pixels on the ground")))
        self.add_allow_empty()

    def run_algorithm(self, parameters, context, feedback):
        camera, dem, crs = self.camera_and_dem(parameters, context, feedback)
        out = self.parameterAsOutputLayer(parameters, "OUTPUT", context)
        keep_pixel_space(context, out, xyz_raster=True)  # loaded unchecked and styled, as the dock adds it
        rows = plan_strips(camera, fixed=3 * dem.elevation.nbytes)
        if rows < camera.height:  # does not fit in the free memory at once: strip by strip into the file
            return self.xyz_in_strips(parameters, context, feedback, camera, dem, crs, out, rows)
        xyz = pipeline.xyz_raster(camera, dem)  # cached: written below without computing again
        check_canceled(feedback)
        # with the photo, a scanned print's border and caption get no coordinates: the share said is the file's
        # (it said 83.8 % where the file had 71.9 %)
        path = self.parameterAsFile(parameters, "PHOTO", context)
        photo = checked(read_photo, path) if path else None
        area = None if photo is None else picture_area(photo)
        ground = float(np.isfinite(blank_outside(xyz[..., 2], area)).mean())
        self.check_not_empty(parameters, context, int(ground > 0), "XYZ raster", NO_GROUND)
        status, message = verdict_on_photo(self.parameterAsFile(parameters, "CAMERA", context), path)
        pipeline.write_xyz(out, camera, dem, crs.toWkt(), progress=progress_callback(feedback, 80, 95),
                           is_canceled=cancel_callback(feedback), area=area,  # found once, above
                           fit={"status": status, "message": message} if status else None)
        feedback.pushInfo(self.tr("{0:.1f}% of the pixels hit the DEM; written to {1}").format(100 * ground, out))
        feedback.setProgress(100)
        return {"OUTPUT": out, "GROUND_FRACTION": ground}


    def xyz_in_strips(self, parameters, context, feedback, camera, dem, crs, out, rows):
        from ...core.xyz_strips import available_memory, xyz_memory, xyz_strips
        from ...outputs.xyz_raster import storage_dtype_for_range, write_xyz_raster_strips

        feedback.pushInfo(self.tr("The XYZ raster needs {0:.2f} GB at once, {1:.2f} GB can be used: computed in "
                                  "strips of {2} rows").format(xyz_memory(camera) / 1e9, available_memory() / 1e9,
                                                               rows))
        counts = {"ground": 0}

        def strips():
            for row0, xyz, distance in xyz_strips(camera, dem, rows_per_strip=rows):
                check_canceled(feedback)
                counts["ground"] += int(np.isfinite(xyz[..., 2]).sum())
                feedback.setProgress(95.0 * (row0 + xyz.shape[0]) / camera.height)
                yield row0, xyz, distance
            self.check_not_empty(parameters, context, counts["ground"], "XYZ raster", NO_GROUND)

        xmin, ymin, xmax, ymax = dem.bounds()
        z = dem.elevation[np.isfinite(dem.elevation)]
        dtype = storage_dtype_for_range(min(xmin, ymin, float(z.min())), max(xmax, ymax, float(z.max())))
        write_xyz_raster_strips(out, strips(), camera.width, camera.height, crs.toWkt(), dtype, overwrite=True)
        ground = counts["ground"] / float(camera.width * camera.height)
        feedback.pushInfo(self.tr("{0:.1f}% of the pixels hit the DEM; written to {1}").format(100 * ground, out))
        feedback.setProgress(100)
        return {"OUTPUT": out, "GROUND_FRACTION": ground}


#: The field maptophoto adds: the share of a feature's densified vertices the camera sees.
VISIBLE_SHARE = "visible_share"


class PhotoToMap(_CameraDemAlgorithm):
    _name = "phototomap"
    _display = "Photo features to map layer"
    _help = ("Turns points, lines and polygons drawn on the photo (photo pixel space: x = column, y = -row) into a "
             "layer in the DEM's CRS with Z, by intersecting each vertex's ray with the DEM. Lines are densified "
             "every STEP pixels first, since a straight line on the photo is not straight on the terrain. Vertices "
             "that see the sky are dropped (and reported). With a photo pixel error (the fit's check-point RMSE, "
             "else its leave-one-out RMSE), each feature gets xy_error_m and z_error_m: the expected horizontal and "
             "vertical error (m, RMS) of its ground points, from the terrain's footprint of that error; it grows "
             "with range and where rays graze "
             "the terrain, and leaves out the DEM's own error. Each feature also gets fit_status, the verdict the "
             "camera file carries (ok, uncertain, poor; uncertain for an ok fitted on another photo than PHOTO; "
             "empty when the file has none); xy_error_m and z_error_m stay empty under an uncertain or poor one.")

    def initAlgorithm(self, config=None):
        self.addParameter(QgsProcessingParameterFeatureSource("INPUT", self.tr("Features drawn on the photo")))
        self.add_camera_dem()
        self.addParameter(QgsProcessingParameterNumber("STEP", self.tr("Densify every (pixels)"),
                                                       QgsProcessingParameterNumber.Double, 2.0, minValue=0.0))
        self.add_explained(QgsProcessingParameterNumber(
            "PIXEL_ERROR", self.tr("Pixel error for xy_error_m (px RMS)"),
            QgsProcessingParameterNumber.Double, 0.0, minValue=0.0, optional=True),
            self.tr("The photo's pixel error, for example the fit's check-point RMSE; 0 leaves xy_error_m "
                    "empty"))
        self.addParameter(QgsProcessingParameterFeatureSink("OUTPUT", self.tr("Map features")))
        self.addOutput(QgsProcessingOutputNumber("DROPPED", self.tr("Vertices dropped (sky)")))
        self.add_allow_empty()
        self.explain({
            "INPUT": "Points, lines or polygons drawn in photo pixel space (x = column, y = -row), as the dock "
                     "draws them and 'Map layer to photo' writes them",
            "STEP": "Lines and outlines get a vertex every STEP pixels before their rays meet the DEM, since a "
                    "straight line on the photo is not straight on the terrain; 0: the drawn vertices only"})

    def run_algorithm(self, parameters, context, feedback):
        source = self.parameterAsSource(parameters, "INPUT", context)
        if source is None:
            raise QgsProcessingException(self.invalidSourceError(parameters, "INPUT"))
        camera, dem, crs = self.camera_and_dem(parameters, context, feedback)
        step = self.parameterAsDouble(parameters, "STEP", context)
        pixel_rmse = self.parameterAsDouble(parameters, "PIXEL_ERROR", context) or None
        # with the photo, what is drawn on a scanned print's paper or caption gets no ground (a trial: a line on
        # the caption became a 27 m map line)
        path = self.parameterAsFile(parameters, "PHOTO", context)
        area = picture_area(checked(read_photo, path)) if path else None
        wkb = QgsWkbTypes.addZ(QgsWkbTypes.multiType(source.wkbType()))
        # the measures the dock's drawings get (area, length, length3d, sky_parts), beside the input's fields
        fields, measured = geo.measured_fields(source.fields(), QgsWkbTypes.geometryType(source.wkbType()))
        # and, as the dock's, the camera's verdict on this photo (empty when its file has none)
        status = verdict_on_photo(self.parameterAsFile(parameters, "CAMERA", context), path)[0] or None
        if pixel_rmse is not None and status in ("uncertain", "poor"):
            # as the dock: no ± on a camera the evidence does not support (a trial's frame, turned 0.6° since the
            # camera was fitted on another frame, had its line 58 m off with xy_error_m 6.0 m)
            feedback.pushWarning(self.tr("The camera is {0} on this photo: xy_error_m and z_error_m are left empty "
                                         "(PIXEL_ERROR would understate its error).").format(status))
            pixel_rmse = None
        if fields.indexFromName(FIT_STATUS_FIELD) < 0:
            fields.append(QgsField(FIT_STATUS_FIELD, QVariant.Type.String))
            measured.append(FIT_STATUS_FIELD)
        sink = safe_sink(self, parameters, "OUTPUT", context, fields, wkb, crs)
        total = max(1, source.featureCount())
        dropped = 0
        for i, feature in enumerate(source.getFeatures(QgsFeatureRequest(), SKIP_VALIDITY)):
            check_canceled(feedback)
            if feature.hasGeometry() and not feature.geometry().isGeosValid():
                feedback.pushWarning(self.tr("Feature {0}: its outline crosses itself; mapped as drawn, its area may "
                                             "be wrong").format(feature.id()))
            geometry, lost, measures = geo.photo_to_map_geometry(feature.geometry(), camera, dem, step, PHOTO_Y_SIGN,
                                                                 pixel_rmse, area)
            dropped += lost
            if geometry is None:
                feedback.pushWarning(self.tr("Feature {0} is entirely in the sky or outside the DEM; skipped").format(
                    feature.id()))
                continue
            out = QgsFeature(fields)
            measures[FIT_STATUS_FIELD] = status
            out.setAttributes(feature.attributes() + [measures.get(name) for name in measured])
            out.setGeometry(geometry)
            sink.addFeature(out, QgsFeatureSink.FastInsert)
            feedback.setProgress(100.0 * (i + 1) / total)
        if dropped:
            feedback.pushInfo(self.tr("{0} vertices saw the sky or left the DEM and were dropped").format(dropped))
        check_canceled(feedback)
        self.check_not_empty(parameters, context, sink.count, "map layer",
                             "every feature is in the sky or outside the DEM")
        dest = sink.commit()
        return {"OUTPUT": dest, "DROPPED": dropped}


class MapToPhoto(_CameraDemAlgorithm):
    _name = "maptophoto"
    _display = "Map layer to photo"
    _help = ("Draws a map layer onto the photo: every vertex is projected with the camera into photo pixel space "
             "(x = column, y = -row). Lines and polygon outlines are densified every STEP map units first (0: the "
             "DEM's cell size, so that an edge crossing the view between two far-apart corners is not lost). With "
             "'Drop hidden parts', vertices hidden behind terrain (depth test against the DEM rendered from the "
             "camera) or outside the image are removed, splitting lines where they disappear; features with no "
             "visible vertex are skipped and reported. Polygons are drawn whole (their outline on the photo may fold "
             "over itself where it passes behind a ridge). Every feature gets visible_share: the share of its "
             "(densified) vertices the camera sees, 0 to 1.")

    def initAlgorithm(self, config=None):
        self.addParameter(QgsProcessingParameterFeatureSource("INPUT", self.tr("Map layer")))
        self.add_camera_dem()
        self.addParameter(QgsProcessingParameterNumber("STEP", self.tr("Densify every (map units, 0 = DEM cell size)"),
                                                       QgsProcessingParameterNumber.Double, 0.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterBoolean("HIDDEN", self.tr("Drop hidden parts"), defaultValue=True))
        self.addParameter(QgsProcessingParameterFeatureSink("OUTPUT", self.tr("Features on the photo")))
        self.add_allow_empty()
        self.explain({
            "INPUT": "Lines, polygons or points in any CRS (reprojected to the DEM's); their vertices are projected "
                     "onto the photo",
            "STEP": "Lines and outlines get a vertex every STEP map units before they are projected, so an edge "
                    "between far-apart corners follows the terrain; 0: the DEM's cell size",
            "HIDDEN": "Ticked: vertices hidden behind terrain or outside the photo are removed, lines split where "
                      "they disappear; unticked: every vertex is kept"})

    def run_algorithm(self, parameters, context, feedback):
        source = self.parameterAsSource(parameters, "INPUT", context)
        if source is None:
            raise QgsProcessingException(self.invalidSourceError(parameters, "INPUT"))
        camera, dem, crs = self.camera_and_dem(parameters, context, feedback)
        # 0: the DEM's cell size; corners alone miss a polygon whose edges cross the view (silently empty output)
        step = self.parameterAsDouble(parameters, "STEP", context) or float(dem.cell_size)
        drop_hidden = self.parameterAsBool(parameters, "HIDDEN", context)
        transform = None
        if source.sourceCrs().isValid() and crs.isValid() and source.sourceCrs() != crs:
            transform = QgsCoordinateTransform(source.sourceCrs(), crs, context.transformContext())
        visible = pipeline.visibility(camera, dem)  # also without dropping: visible_share says what is seen
        wkb = QgsWkbTypes.flatType(QgsWkbTypes.multiType(source.wkbType()))
        fields = QgsFields(source.fields())
        if fields.indexFromName(VISIBLE_SHARE) < 0:
            fields.append(QgsField(VISIBLE_SHARE, QVariant.Type.Double))
        share_index = fields.indexFromName(VISIBLE_SHARE)
        sink = safe_sink(self, parameters, "OUTPUT", context, fields, wkb, QgsCoordinateReferenceSystem())
        total = max(1, source.featureCount())
        skipped = 0
        for i, feature in enumerate(source.getFeatures(QgsFeatureRequest(), SKIP_VALIDITY)):
            check_canceled(feedback)
            feedback.setProgress(100.0 * (i + 1) / total)
            geometry = feature.geometry()
            if transform is not None:
                geometry.transform(transform)
            projected, share = geo.map_to_photo_geometry(geometry, camera, dem, step, visible, PHOTO_Y_SIGN,
                                                         drop_hidden)
            if projected is None:
                skipped += 1
                continue
            out = QgsFeature(fields)
            attributes = list(feature.attributes()) + [None] * (fields.count() - len(feature.attributes()))
            attributes[share_index] = round(share, 4) if np.isfinite(share) else None
            out.setAttributes(attributes)
            out.setGeometry(projected)
            sink.addFeature(out, QgsFeatureSink.FastInsert)
        if skipped:
            feedback.pushWarning(self.tr("{0} of {1} feature(s) are not visible in the photo (hidden behind "
                                         "terrain or outside the image); skipped").format(skipped, total))
        check_canceled(feedback)
        self.check_not_empty(parameters, context, sink.count, "photo layer",
                             "no feature is visible in the photo (hidden behind terrain or outside the image)")
        dest = sink.commit()
        return {"OUTPUT": dest}


class Orthophoto(_CameraDemAlgorithm):
    _name = "orthophoto"
    _display = "Orthophoto"
    _help = ("Drapes the photo on the DEM and writes it as a north-up RGBA GeoTIFF in the DEM's CRS: each ground "
             "cell seen by the camera gets the colour of its pixel; cells hidden by terrain or outside the photo "
             "are transparent. Cell size 0 keeps the photo's own detail (the ground footprint of a pixel at the "
             "median distance, never coarser than the DEM's cells unless 10 million cells need it) over the part "
             "of the DEM the camera sees, as the dock's orthophoto; give a cell size for another grid.")

    def initAlgorithm(self, config=None):
        self.add_camera_dem(photo_optional=False)
        # 0: the photo's own detail over what the camera sees, as the dock's (a drone trial's 5 cm pixels were
        # written on the DEM's 1 m cells over all of it, mostly transparent)
        self.addParameter(QgsProcessingParameterNumber(
            "RESOLUTION", self.tr("Cell size (map units, 0 = the photo's own detail)"),
            QgsProcessingParameterNumber.Double, 0.0, minValue=0.0))
        self.addParameter(QgsProcessingParameterRasterDestination("OUTPUT", self.tr("Orthophoto")))
        self.add_allow_empty()
        self.explain({"RESOLUTION": "The orthophoto's cell size in the DEM's map units; 0: the ground size of a "
                                    "photo pixel at the median distance, over the part of the DEM the camera sees"})

    def run_algorithm(self, parameters, context, feedback):
        camera, dem, crs = self.camera_and_dem(parameters, context, feedback)
        photo = checked(read_photo, self.photo_path(parameters, context))
        if (photo.shape[1], photo.shape[0]) != tuple(camera.image_size):
            raise QgsProcessingException(self.tr("The photo is {0}x{1} px but the camera is for {2}x{3} px.").format(
                photo.shape[1], photo.shape[0], camera.width, camera.height))
        # 0: the photo's own detail (a DEM read by windows: the part of it the camera sees, at its finest level that
        # fits: workflow.products.ortho_grid)
        resolution = self.parameterAsDouble(parameters, "RESOLUTION", context) or AUTO
        out = self.parameterAsOutputLayer(parameters, "OUTPUT", context)
        try:  # of a DEM read by windows: the part the camera sees
            try:
                grid = ortho_grid(camera, dem, resolution)
            except ProductError:
                if resolution != AUTO:
                    raise
                # no terrain seen, no detail to keep: the DEM's grid, and the empty-product check below says why
                # (or writes it, ALLOW_EMPTY)
                grid = ortho_grid(camera, dem, None)
        except ProductError as exc:
            raise QgsProcessingException(str(exc)) from exc
        status, message = verdict_on_photo(self.parameterAsFile(parameters, "CAMERA", context),
                                           self.photo_path(parameters, context))
        fit = {"status": status, "message": message} if status else None  # kept in the file's metadata
        rows = plan_strips(camera, extra_per_row=3 * camera.width,
                           fixed=grid.elevation.size * 40 + 3 * dem.elevation.nbytes, what="orthophoto")
        if rows < camera.height:  # the XYZ raster does not fit at once: the photo is draped strip by strip
            from ...outputs.orthophoto import orthophoto_from_camera

            feedback.pushInfo(self.tr("Orthophoto computed in strips of {0} photo rows (memory)").format(rows))
            orthophoto_from_camera(out, photo, camera, grid, None, overwrite=True, rows_per_strip=rows,
                                   allow_empty=self.parameterAsBool(parameters, "ALLOW_EMPTY", context), fit=fit)
            feedback.setProgress(100)
            return {"OUTPUT": out}
        ground = int(np.isfinite(pipeline.xyz_raster(camera, dem)[..., 2]).any())
        self.check_not_empty(parameters, context, ground, "orthophoto", NO_GROUND)
        checked(pipeline.orthophoto, out, photo, camera, dem, resolution, progress_callback(feedback, 0, 95),
                cancel_callback(feedback), grid, fit)
        feedback.setProgress(100)
        return {"OUTPUT": out}


class Report(_CameraDemAlgorithm):
    _name = "report"
    _display = "Camera report (PNG/PDF)"
    _help = ("Writes a one-page report of a fitted camera: the photo with the DEM rendered from the camera "
             "overlaid, the control points and their residuals, and the camera parameters. PNG or PDF by the "
             "output's extension.")

    def initAlgorithm(self, config=None):
        self.add_camera_dem(photo_optional=False)
        self.addParameter(QgsProcessingParameterFile("POINTS_CSV", self.tr("Control points (paired CSV)"),
                                                     QgsProcessingParameterFile.File, optional=True,
                                                     fileFilter="CSV (*.csv *.txt)"))
        self.explain({"POINTS_CSV": "A paired GCP CSV (u_px, v_px, X, Y, Z; optional check column): the report "
                                    "draws these points and their residuals under the camera"})
        self.addParameter(QgsProcessingParameterFileDestination("OUTPUT", self.tr("Report"),
                                                                "PNG image (*.png);;PDF (*.pdf)"))

    def run_algorithm(self, parameters, context, feedback):
        camera, dem, crs = self.camera_and_dem(parameters, context, feedback)
        photo_path = self.photo_path(parameters, context)
        photo = checked(read_photo, photo_path)
        points = self.parameterAsFile(parameters, "POINTS_CSV", context) or None
        out = self.parameterAsFileOutput(parameters, "OUTPUT", context)
        status, message = verdict_on_photo(self.parameterAsFile(parameters, "CAMERA", context), photo_path)
        # the σ the camera's own fit wrote (the demo's page had none once its table held check points only)
        sigma = written_fit(self.parameterAsFile(parameters, "CAMERA", context)).get("sigma") or None
        checked(pipeline.report, out, photo, camera, dem, points, f"{status}: {message}" if status else "", sigma,
                read_photo_taken(photo_path) or "")
        feedback.setProgress(100)
        return {"OUTPUT": out}

