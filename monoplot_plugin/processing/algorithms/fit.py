"""Fit the camera to photo points and DEM points (paired GCPs or unpaired clouds), starting from a prior."""

import os

import numpy as np
from qgis.core import (
    QgsProcessing,
    QgsProcessingException,
    QgsProcessingOutputNumber,
    QgsProcessingOutputString,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterEnum,
    QgsProcessingParameterFeatureSource,
    QgsProcessingParameterFile,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterNumber,
)

from .. import pipeline
from ...outputs.safe_write import write_text
from ...workflow.camera_files import camera_json
from ...workflow.fit import MIN_PAIRS_WITHOUT_PRIOR, start_above_points
from ...workflow.progress import Canceled
from ...workflow.text import name_photo_pixels
from ..base import (MonoplotAlgorithm, camera_line, cancel_callback, centred_on_print, check_canceled, checked,
                    progress_callback, read_map_points, read_photo_points, report_status)
from ...adapters.layers import crs_from_wkt
from ...workflow.inputs import is_warning_note, photo_points_in_frame, points_to_dem_crs
from ..inputs import InputError, read_photo, read_points_csv

CSV_FILTER = "CSV (*.csv *.txt)"


def pair_points(uv: np.ndarray, xyz: np.ndarray) -> None:
    """Check that paired inputs really pair: same number of rows (row i of one is row i of the other)."""
    if len(uv) != len(xyz):
        raise InputError(f"paired mode needs as many photo points as DEM points (got {len(uv)} and {len(xyz)}); "
                         "switch 'Points are paired' off to fit unpaired point sets")


class FitCamera(MonoplotAlgorithm):
    _name = "fitcamera"
    _display = "Fit camera"
    _help = ("Fits the camera (position, heading, pitch, roll, field of view) so that the DEM points project onto "
             "the photo points, starting from a prior camera (Monoplot JSON or KML PhotoOverlay). With 6 or more "
             "paired ground-control points the prior may be left out: the camera is solved from the pairs "
             "alone.\n\n"
             "Points come from layers (photo points in pixel space, DEM points in the DEM's CRS) or from CSV files "
             "(u_px, v_px and/or X, Y, Z columns); a single CSV with both sets of columns is a list of paired "
             "ground-control points; its optional check column (1/0) marks check points, kept out of the fit and "
             "measured (CHECK_RMSE_PX), as in the dock. Unpaired point sets may have different counts: the fit "
             "matches each photo point to the nearest projected DEM point. Writes the fitted camera as JSON, the "
             "input of every other algorithm.\n\n"
             "Camera height: Automatic (the dock's rule) holds a prior within 20 m of the terrain at its height "
             "above it and leaves a higher one free, and refits on the ground a free camera that ends under the "
             "terrain; On the ground holds it at the height above the ground given (default 1.7 m, hand-held or "
             "tripod); In the air leaves it free (drone, aircraft, tower).")

    #: ON_GROUND's options, in index order; see :func:`on_ground_choice`.
    HEIGHT_OPTIONS = ("Automatic", "On the ground", "In the air")

    def initAlgorithm(self, config=None):
        self.add_photo_parameter()
        self.add_dem_parameter()
        self.add_camera_parameter("PRIOR", optional=True, description="Prior camera (not needed with 6+ pairs)",
                                  explanation=self.tr("A Monoplot camera JSON or a KML PhotoOverlay; not needed with "
                                                      "6 or more paired GCPs"))
        self.addParameter(QgsProcessingParameterFeatureSource("PHOTO_POINTS", self.tr("Photo points (layer)"),
                                                              [QgsProcessing.TypeVectorPoint], optional=True))
        self.addParameter(QgsProcessingParameterFeatureSource("DEM_POINTS", self.tr("DEM points (layer)"),
                                                              [QgsProcessing.TypeVectorPoint], optional=True))
        self.addParameter(QgsProcessingParameterFile("PHOTO_CSV", self.tr("Photo points (CSV, or paired GCP CSV)"),
                                                     QgsProcessingParameterFile.File, optional=True,
                                                     fileFilter=CSV_FILTER))
        self.addParameter(QgsProcessingParameterFile("DEM_CSV", self.tr("DEM points (CSV)"),
                                                     QgsProcessingParameterFile.File, optional=True,
                                                     fileFilter=CSV_FILTER))
        self.addParameter(QgsProcessingParameterBoolean("PAIRED", self.tr("Points are paired (row i <-> row i)"),
                                                        defaultValue=False))
        add_height_parameters(self)
        # the lens, as the dock's fit settings free it (a phone trial's 26 mm lens, k1 -0.06: free in the dock, not
        # here, and a GCP 21 m away left 121 px of leave-one-out error the fit could not model)
        self.addParameter(QgsProcessingParameterEnum(
            "LENS", self.tr("Lens distortion"), [self.tr(option) for option, _ in self.LENS_OPTIONS], defaultValue=0))
        # what the person knows, kept at the prior's values, as the dock's fit settings untick them (a drone trial
        # with 3 GCPs and the lens from EXIF was refused, with no way to fix the field of view here)
        fixed = QgsProcessingParameterEnum("FIXED", self.tr("Known: kept at the prior's values"),
                                           [self.tr(option) for option, _ in self.FIXED_OPTIONS],
                                           allowMultiple=True, optional=True, defaultValue=[])
        fixed.setFlags(fixed.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
        self.addParameter(fixed)
        self.explain({
            "PHOTO_POINTS": "A point layer in photo pixel space (x = column, y = -row), as 'Suggest photo points' "
                            "writes it",
            "DEM_POINTS": "A point layer of terrain points (any CRS, reprojected to the DEM's), as 'Suggest DEM "
                          "points' writes it; a point without Z takes the DEM's height",
            "PHOTO_CSV": "Columns u_px, v_px (photo pixels); with X, Y, Z in the same file it is a paired GCP table "
                         "(surveyed Z kept; an optional check column 1/0 marks check points)",
            "DEM_CSV": "Columns X, Y and optionally Z, in the DEM file's CRS; a missing Z takes the DEM's height",
            "PAIRED": "Ticked: photo point i and DEM point i are the same feature (a paired GCP CSV is always "
                      "paired); unticked: the fit matches each photo point to the nearest projected DEM point",
            "LENS": "Fit the lens's radial distortion (k1), or k1 and the principal point, for wide-angle and "
                    "phone lenses; the first choice keeps the prior camera's lens",
            "FIXED": "Parameters you know (a surveyed position, a lens's field of view): kept at the prior "
                     "camera's values instead of fitted"})
        self.addParameter(QgsProcessingParameterFileDestination("OUTPUT", self.tr("Fitted camera"),
                                                                "Monoplot camera (*.json)"))
        self.addOutput(QgsProcessingOutputNumber("RMSE_PX", self.tr("Reprojection error (px)")))
        self.addOutput(QgsProcessingOutputNumber("N_PHOTO", self.tr("Photo points used")))
        self.addOutput(QgsProcessingOutputNumber("N_DEM", self.tr("DEM points used")))
        self.addOutput(QgsProcessingOutputString("STATUS", self.tr("Fit status (ok / uncertain / poor)")))
        self.addOutput(QgsProcessingOutputNumber("N_CHECK", self.tr("Check points (kept out of the fit)")))
        self.addOutput(QgsProcessingOutputNumber("CHECK_RMSE_PX", self.tr("Check-point error (px)")))
        self.addOutput(QgsProcessingOutputString("MESSAGE", self.tr("What the fit found and, unless ok, what to do")))

    dropped_dem_points = 0
    #: (LENS choice, parameters fitted besides the seven of the pose and the field of view)
    LENS_OPTIONS = (("As the prior camera's (none unless it has some)", ()),
                    ("Fit radial distortion k1 (wide lenses, phones)", ("k1",)),
                    ("Fit k1 and the principal point", ("k1", "cx", "cy")))

    def gather_points(self, parameters, context, dem, crs=None):
        """(uv (N, 2), xyz (M, 3), paired, check) from layers and/or CSV files; Z sampled from the DEM where
        missing; ``check`` (N,) bool: the paired rows a table's ``check`` column marks as check points."""
        uv_parts, xyz_parts, check_parts = [], [], []
        self.photo_names = []  # (u, v, id) of a table's named photo points: the fit's message names them
        feedback = self.feedback_of(context)
        paired = self.parameterAsBool(parameters, "PAIRED", context)
        photo_source = self.parameterAsSource(parameters, "PHOTO_POINTS", context)
        dem_source = self.parameterAsSource(parameters, "DEM_POINTS", context)
        if photo_source is not None:
            uv_parts.append(read_photo_points(photo_source))
            check_parts.append(np.zeros(len(uv_parts[-1]), dtype=bool))
        if dem_source is not None:
            xyz_parts.append(read_map_points(dem_source, crs, context))
        for name in ("PHOTO_CSV", "DEM_CSV"):
            path = self.parameterAsFile(parameters, name, context)
            if not path:
                continue
            table = checked(read_points_csv, path)
            if table.get("unused") and feedback is not None:
                feedback.pushWarning(self.tr("{0}: columns not read: {1} (photo pixels are u_px, v_px; map "
                                             "coordinates X, Y, Z)").format(os.path.basename(path),
                                                                             ", ".join(table["unused"])))
            if "uv" in table and "xyz" in table:
                paired = True  # one table with both: ground-control points
            if "uv" in table:
                uv_parts.append(table["uv"])
                if table.get("named"):
                    self.photo_names += [(u, v, str(i)) for (u, v), i in zip(table["uv"], table["ids"])]
                check_parts.append(table.get("check", np.zeros(len(table["uv"]), dtype=bool)))
            if "xyz" in table:  # in the DEM file's CRS (degrees for a geographic DEM used in UTM)
                project = context.project()
                crs = project.crs() if project is not None else None
                converted, notes = points_to_dem_crs(table["xyz"], dem, name=os.path.basename(path),
                                                     candidates=[crs.toWkt()] if crs is not None and crs.isValid()
                                                     else [])
                for note in notes:
                    if feedback is not None:
                        (feedback.pushWarning if is_warning_note(note) else feedback.pushInfo)(note)
                xyz_parts.append(converted)
        if not uv_parts or not xyz_parts:
            raise QgsProcessingException(self.tr(
                "Fit camera needs photo points and DEM points: give PHOTO_POINTS and DEM_POINTS layers, or "
                "PHOTO_CSV and DEM_CSV files, or one paired CSV (u_px, v_px, X, Y, Z)."))
        uv = np.concatenate(uv_parts)
        xyz = np.concatenate(xyz_parts)
        check = np.concatenate(check_parts)
        no_z = int((np.isfinite(xyz[:, :2]).all(axis=1) & ~np.isfinite(xyz[:, 2])).sum())
        if no_z and feedback is not None:  # said: a misnamed Z column was silently the DEM's
            feedback.pushInfo(self.tr("{0} of the {1} DEM points have no Z: the DEM's height there is "
                                      "used").format(no_z, len(xyz)))
        xyz = pipeline.fill_missing_z(xyz, dem)
        good_xyz = np.isfinite(xyz).all(axis=1)
        self.dropped_dem_points = int((~good_xyz).sum())
        if self.dropped_dem_points and feedback is not None:
            # a GCP table in another CRS than the DEM file's: every point dropped, and "0 DEM points" said nothing
            feedback.pushWarning(self.tr(
                "{0} of the {1} DEM points were left out: they lie outside the DEM, or their X, Y are not in the DEM "
                "file's CRS ({2}), the CRS tables are read in.").format(self.dropped_dem_points, len(xyz),
                                                                     dem_crs_name(dem)))
        if paired:
            checked(pair_points, uv, xyz)
            keep = good_xyz & np.isfinite(uv).all(axis=1)
            uv, xyz, check = uv[keep], xyz[keep], check[keep]
        else:
            uv, xyz = uv[np.isfinite(uv).all(axis=1)], xyz[good_xyz]
            check = np.zeros(len(uv), dtype=bool)  # check points are pairs
        return uv, xyz, paired, check

    #: (FIXED choice, the parameters it keeps at the prior's values)
    FIXED_OPTIONS = (("Position (X, Y)", ("x", "y")), ("Height (Z)", ("z",)), ("Heading", ("heading",)),
                     ("Pitch", ("pitch",)), ("Roll", ("roll",)), ("Field of view", ("fov",)))

    def free(self, parameters, context):
        """The parameters to fit: the default seven less those FIXED, and the lens's of LENS; None for the default
        alone."""
        from ...core.fit import DEFAULT_FREE

        extra = self.LENS_OPTIONS[self.parameterAsEnum(parameters, "LENS", context)][1]
        fixed = {name for i in self.parameterAsEnums(parameters, "FIXED", context)
                 for name in self.FIXED_OPTIONS[i][1]}
        if fixed and not self.parameterAsFile(parameters, "PRIOR", context):
            raise QgsProcessingException(self.tr("Known parameters (FIXED) are kept at the prior camera's values: "
                                                 "give a PRIOR camera with them."))
        free = tuple(name for name in tuple(DEFAULT_FREE) + extra if name not in fixed)
        return free if extra or fixed else None

    def run_algorithm(self, parameters, context, feedback):
        photo = self.photo_path(parameters, context)
        dem, crs = self.dem(parameters, context)
        uv, xyz, paired, check = self.gather_points(parameters, context, dem, crs)
        if self.parameterAsFile(parameters, "PRIOR", context):
            prior = self.camera(parameters, context, "PRIOR", photo=photo, crs=crs, rough=True)
        elif paired and len(uv) >= MIN_PAIRS_WITHOUT_PRIOR:
            prior = start_above_points(xyz, checked(pipeline_photo_size, photo), crs.toWkt())
            feedback.pushInfo(self.tr("No prior camera: the camera is solved from the {0} pairs alone").format(
                len(uv)))
        else:
            raise QgsProcessingException(self.tr(
                "A prior camera is needed (PRIOR: Monoplot JSON or KML) unless the points are {0} or more paired "
                "ground-control points.").format(MIN_PAIRS_WITHOUT_PRIOR))
        prior = centred_on_print(prior, checked(read_photo, photo), feedback)
        free = self.free(parameters, context)
        n_free = len(free) if free is not None else 7
        # paired: an equation a pair, two unknowns at most (the core says more if they are too few); unpaired: six
        minimum = max(2, -(-n_free // 2)) if paired else 6
        n_uv, n_xyz = len(uv) - int(check.sum()), len(xyz) - int(check.sum())  # the check points are not fitted
        if n_uv < minimum or n_xyz < minimum:
            hint = self.tr(" {0} DEM points were left out: outside the DEM, or not in the DEM file's CRS ({1})."
                           ).format(self.dropped_dem_points, dem_crs_name(dem)) if self.dropped_dem_points else ""
            # paired: the pairs that are left ("0 photo and 0 DEM points (at least 4 each pair needed)" read as if
            # the photo points were missing too, a trial)
            text = self.tr("Too few pairs for a {0}-parameter camera: {1} left (at least {2} needed).").format(
                n_free, min(n_uv, n_xyz), minimum) if paired else self.tr(
                "Too few points for a {0}-parameter camera: {1} photo and {2} DEM points (at least {3} of each "
                "needed).").format(n_free, n_uv, n_xyz, minimum)
            raise QgsProcessingException(text + hint)
        uv, swapped = photo_points_in_frame(uv, prior.image_size, name="the points")  # u and v the other way round
        for note in swapped:
            feedback.pushWarning(note)
        outside = ~prior.in_image(uv)
        if outside.any():
            first = ", ".join(f"({u:.1f}, {v:.1f})" for u, v in uv[outside][:3])
            raise QgsProcessingException(self.tr("{0} photo points lie outside the {1}x{2} photo ({3}): are they in "
                                                 "photo pixel space (x = column, y = -row, or columns u_px, "
                                                 "v_px)?").format(int(outside.sum()), prior.width, prior.height,
                                                                  first))
        feedback.pushInfo(self.tr("Fitting with {0} photo points and {1} DEM points ({2})").format(
            len(uv) - int(check.sum()), len(xyz) - int(check.sum()),
            self.tr("paired") if paired else self.tr("unpaired")))
        if check.any():  # the table's check column, as the dock reads it: measured, not fitted
            feedback.pushInfo(self.tr("{0} check points kept out of the fit to measure it").format(int(check.sum())))
        photo_size = checked(pipeline_photo_size, photo)
        try:
            camera, info = checked(pipeline.fit, photo_size, uv, xyz, prior, dem, paired,
                                   progress_callback(feedback, 0, 95), cancel_callback(feedback),
                                   check=check, free=free,
                                   **height_choice(self, parameters, context))
        except Canceled:
            raise QgsProcessingException(self.tr("Fit canceled; no camera written.")) from None
        # a pixel the message quotes, by its id in the person's table (a trial's GCP4, named by its pixel only)
        info["message"] = name_photo_pixels(info["message"], self.photo_names)
        report_status(feedback, self.tr("Fit"), info["status"], info["message"])
        camera.crs_wkt = crs.toWkt()
        out = self.parameterAsFileOutput(parameters, "OUTPUT", context)
        check_canceled(feedback)
        # with its verdict and the photo it is about: products warn of it, and of another photo (a trial ran
        # computexyz with a camera of photo 2 on photo 3, 60 m off, silently)
        write_text(out, camera_json(camera, info, photo), overwrite=True)
        rmse = float(info.get("rmse_px", float("nan")))
        feedback.pushInfo(self.tr("Camera: {0}").format(camera_line(camera)))
        std = info.get("summary", {}).get("std") or {}
        if std and np.isfinite(rmse):  # no σ of a camera no pair could place (a trial read "x ± 4.62e+04")
            feedback.pushInfo(self.tr("One standard deviation: {0}").format(
                ", ".join(f"{k} ± {v:.3g}" for k, v in std.items() if v is not None)))
        feedback.pushInfo(self.tr("Reprojection error {0:.2f} px; written to {1}").format(rmse, out) if
                          np.isfinite(rmse) else self.tr("No camera fits the points: the camera written to {0} is "
                                                         "the start, marked \"{1}\"").format(out, info["status"]))
        if info["n_check"]:
            feedback.pushInfo(self.tr("Check points: {0:.2f} px RMSE on {1} (not fitted)").format(
                info["check_rmse_px"], info["n_check"]))
        feedback.setProgress(100)
        n_fit = len(uv) - info["n_check"]
        return {"OUTPUT": out, "RMSE_PX": rmse, "N_PHOTO": n_fit, "N_DEM": len(xyz) - info["n_check"],
                "STATUS": info["status"], "MESSAGE": info["message"], "N_CHECK": info["n_check"],
                "CHECK_RMSE_PX": info["check_rmse_px"]}


def add_height_parameters(alg) -> None:
    """ON_GROUND and EYE_HEIGHT, the dock's camera height rule (workflow.fit.on_ground_rule): automatic unless the
    person says otherwise, for ``fitcamera`` and ``autoregister``. The index order keeps old scripts meaning what they
    said: ON_GROUND=1 (formerly true) is "on the ground"."""
    alg.addParameter(QgsProcessingParameterEnum(
        "ON_GROUND", alg.tr("Camera height"), [alg.tr(option) for option in FitCamera.HEIGHT_OPTIONS], defaultValue=0))
    alg.addParameter(QgsProcessingParameterNumber(
        "EYE_HEIGHT", alg.tr("Height above the ground (m)"),
        QgsProcessingParameterNumber.Double, None, optional=True, minValue=0.0))
    alg.explain({
        "ON_GROUND": "Automatic: a prior within 20 m of the terrain is held at its height above it, a higher one "
                     "is fitted freely; On the ground: held at 'Height above the ground' (hand-held, tripod); In "
                     "the air: its height fitted freely (drone, aircraft, tower)",
        "EYE_HEIGHT": "The camera's height above the terrain when it is held on the ground; empty: 1.7 m, or under "
                      "Automatic the prior's own height above the terrain"})


def height_choice(alg, parameters, context) -> dict:
    """``on_ground`` and ``eye_height`` for the workflow from ON_GROUND and EYE_HEIGHT (empty: the workflow's
    default for the chosen height)."""
    eye = None if parameters.get("EYE_HEIGHT") in (None, "") else alg.parameterAsDouble(parameters, "EYE_HEIGHT",
                                                                                        context)
    return {"on_ground": on_ground_choice(alg.parameterAsEnum(parameters, "ON_GROUND", context)), "eye_height": eye}


def on_ground_choice(index: int):
    """ON_GROUND's option index -> the workflow's ``on_ground``: None (automatic), True or False.

    >>> [on_ground_choice(i) for i in range(3)]
    [None, True, False]
    """
    return (None, True, False)[int(index)]


def pipeline_photo_size(path):
    from ..inputs import photo_size

    return photo_size(path)


def dem_crs_name(dem) -> str:
    """The DEM file's CRS for a message: its authority id, or the start of its description."""
    crs = crs_from_wkt(getattr(dem, "source_crs_wkt", "") or dem.crs_wkt)
    return crs.authid() or crs.description()[:40] or "none"
