"""Shared pieces of the Monoplot algorithms: base class, parameter helpers, QGIS <-> numpy conversions.

Photo-space layers: features drawn on (or suggested for) the photo are stored with pixel coordinates as geometry,
``x = u`` (column) and ``y = -v`` (minus the row), like QGIS's Georeferencer, so that a layer shows the right way
up on a canvas with the image at x in [0, W], y in [-H, 0]. Point layers also carry fields ``u_px`` and ``v_px``,
which win over the geometry when present. Photo-space layers have no CRS (the convention: ..adapters.photo_space).
"""

from __future__ import annotations

import os
import re
from typing import Callable, Dict, Optional, Tuple

import numpy as np
from qgis.core import (
    QgsCoordinateReferenceSystem,
    QgsFeature,
    QgsFeatureSink,
    QgsField,
    QgsFields,
    QgsGeometry,
    QgsPoint,
    QgsProcessingAlgorithm,
    QgsProject,
    QgsProcessingException,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterFile,
    QgsProcessingParameterNumber,
    QgsProcessingParameterRasterLayer,
    QgsWkbTypes,
)
from qgis.PyQt.QtCore import QCoreApplication, QVariant

from ..workflow.inputs import check_dem_file, check_photo_path, check_view
from ..core.camera import azimuth
from ..core.dem_large import IMAGE_NOTE
from ..workflow.inputs import load_dem as load_checked_dem
from ..adapters.photo_space import PHOTO_Y_SIGN  # noqa: F401 (algorithms import it from here)
from ..adapters.layers import crs_from_wkt
from ..workflow.camera_files import verdict_on_photo
from ..workflow.progress import Canceled
from .inputs import InputError, load_camera, photo_size


IMAGE_FILTER = "Images (*.jpg *.jpeg *.png *.tif *.tiff *.bmp *.JPG *.JPEG *.PNG *.TIF *.TIFF)"
CAMERA_FILTER = "Camera (*.json *.kml);;Monoplot camera (*.json);;KML PhotoOverlay (*.kml)"


def wrong_file_kind(path: str, file_filter: str, description: str) -> str:
    """Why ``path`` does not suit a file parameter with ``file_filter`` (its suffix is none of the filter's), or "".

    >>> wrong_file_kind("/d/camera.json", IMAGE_FILTER, "Photo")
    'Photo: camera.json is a .json file, expected one of .jpg, .jpeg, .png, .tif, .tiff, .bmp'
    >>> wrong_file_kind("/d/photo.JPG", IMAGE_FILTER, "Photo")
    ''
    """
    import re

    suffixes = sorted({s.lower() for s in re.findall(r"\*(\.[A-Za-z0-9]+)", file_filter)},
                      key=lambda s: file_filter.lower().index(s))
    suffix = os.path.splitext(path)[1].lower()
    if not suffixes or suffix in suffixes:
        return ""
    kind = f"a {suffix} file" if suffix else "a file without a suffix"
    return f"{description}: {os.path.basename(path)} is {kind}, expected one of {', '.join(suffixes)}"


def not_a_number(definitions, parameters) -> Optional[Tuple[bool, str]]:
    """(False, why) for a number parameter given as text that is no number, None when all are numbers. QGIS lets
    an optional one through: ``EYE_HEIGHT=1,7`` from qgis_process was read as 0 (a German-locale trial), with no
    word; a decimal comma is refused with what to write instead, never guessed (1,700 may be a thousand)."""
    for definition in definitions:
        value = parameters.get(definition.name())
        if not isinstance(definition, QgsProcessingParameterNumber) or not isinstance(value, str) or \
                not value.strip():
            continue
        try:
            float(value)
        except ValueError:
            hint = f" (write {value.strip().replace(',', '.')} with a decimal point)" \
                if value.count(",") == 1 and value.replace(",", "", 1).strip().lstrip("-").isdigit() else ""
            return False, f"{definition.name()} \"{value}\" is not a number{hint}"
    return None


class MonoplotAlgorithm(QgsProcessingAlgorithm):
    """Base class: group, translation, instance creation, and conversion of input errors to clear messages."""

    _name = ""
    _display = ""
    _group = "camera"  #: the toolbox group's id (:data:`_GROUPS`)
    _help = ""

    def tr(self, text: str) -> str:
        return QCoreApplication.translate("MonoplotProcessing", text)

    def createInstance(self):
        return type(self)()

    def name(self) -> str:
        return self._name

    def displayName(self) -> str:
        return self.tr(self._display)

    def group(self) -> str:
        return self.tr(_GROUPS[self.groupId()])

    def groupId(self) -> str:
        # the steps in the order of the work (the toolbox showed "Monoplot ▸ Monoplot" and "Batch" first, a trial)
        return self._group

    def shortHelpString(self) -> str:
        # the parameters as the dialog labels them (outputs keep their names: the results show those)
        return labelled_help(self.tr(self._help), [(p.name(), p.description()) for p in self.parameterDefinitions()])

    def processAlgorithm(self, parameters, context, feedback):
        """Run :meth:`run_algorithm`; a cancel (the button, SIGINT, SIGTERM) becomes a clean "Canceled" error with
        every earlier output untouched, write and input errors become their readable message, and the cached XYZ
        raster (large) is released when the algorithm ends."""
        from ..core.xyz_strips import MemoryBudgetError
        from ..outputs.safe_write import OutputCanceled, OutputError
        from . import pipeline
        from .safe_sink import check_file_destinations, guarded_run

        self._feedback = feedback  # feedback_of(): qgis_process leaves the context's feedback unset
        try:
            with guarded_run(feedback):
                check_file_destinations(self, parameters, context)
                return self.run_algorithm(parameters, context, feedback)
        except (Canceled, OutputCanceled):
            raise QgsProcessingException(self.tr("Canceled; earlier outputs were left as they were.")) from None
        except (OutputError, InputError, MemoryBudgetError) as exc:  # readable messages, not tracebacks
            raise QgsProcessingException(str(exc)) from exc
        finally:
            pipeline.clear_cache()

    def feedback_of(self, context):
        """The run's feedback: the context's, else the one :meth:`processAlgorithm` was given (``qgis_process``
        3.22 sets none on the context: the warnings sent there, e.g. of a camera an "uncertain" fit wrote, were
        lost on the command line). None outside a run."""
        feedback = context.feedback() if hasattr(context, "feedback") else None
        return feedback if feedback is not None else getattr(self, "_feedback", None)

    def checkParameterValues(self, parameters, context):
        """QGIS's own checks, but a DEM path it refuses ("Incorrect parameter value") gets the workflow's reason
        (a folder, a text file, no georeferencing...)."""
        ok, message = super().checkParameterValues(parameters, context)
        if ok:
            return not_a_number(self.parameterDefinitions(), parameters) or (ok, message)
        names = [p.name() for p in self.parameterDefinitions()]
        value = parameters.get("DEM") if "DEM" in names else None
        if isinstance(value, str) and value:
            try:
                check_dem_file(value)
            except InputError as exc:
                return False, str(exc)
        for definition in self.parameterDefinitions():  # a file of the wrong kind: say which and what is expected
            value = parameters.get(definition.name())
            if isinstance(definition, QgsProcessingParameterFile) and isinstance(value, str) and value:
                reason = wrong_file_kind(value, definition.fileFilter(), definition.description())
                if reason:
                    return False, reason
        return ok, message

    def run_algorithm(self, parameters, context, feedback):  # pragma: no cover - every algorithm overrides it
        raise NotImplementedError

    # --- parameter helpers --------------------------------------------------------------------------------------
    def add_explained(self, param: QgsProcessingParameterDefinition, explanation: str = "") -> None:
        """Add ``param``, its ``explanation`` in its tool tip: the dialog's labels stay short (a trial saw a
        127-character label cut at "empty =", the rest of it out of sight)."""
        if explanation:
            param.setHelp(explanation)
        self.addParameter(param)

    def explain(self, texts: Dict[str, str]) -> None:
        """Each named parameter's tool tip (its help), where it has none yet: what its short label leaves out (a
        re-check trial hovered over labels such as "Mode", "Points CSV for the shared fit" and found nothing)."""
        for name, text in texts.items():
            param = self.parameterDefinition(name)
            if param is not None and not param.help():
                param.setHelp(self.tr(text))

    def add_photo_parameter(self, name: str = "PHOTO", optional: bool = False, description: str = "Photo",
                            explanation: str = ""):
        self.add_explained(QgsProcessingParameterFile(name, self.tr(description), QgsProcessingParameterFile.File,
                                                      optional=optional, fileFilter=IMAGE_FILTER),
                           explanation or self.tr("The photograph's file (JPEG, PNG, TIFF, ...)"))

    def add_camera_parameter(self, name: str = "CAMERA", optional: bool = False,
                             description: str = "Camera (Monoplot JSON, or KML PhotoOverlay)",
                             explanation: str = ""):
        self.add_explained(QgsProcessingParameterFile(name, self.tr(description), QgsProcessingParameterFile.File,
                                                      optional=optional, fileFilter=CAMERA_FILTER),
                           explanation or self.tr("A camera JSON written by 'Fit camera', 'Register automatically' "
                                                  "or the dock, or a KML PhotoOverlay (Google Earth)"))

    def add_dem_parameter(self, name: str = "DEM", optional: bool = False):
        dem = QgsProcessingParameterRasterLayer(name, self.tr("DEM (elevation in metres)"), optional=optional)
        dem.setHelp(self.tr("Elevation raster in metres; a DEM in geographic coordinates is used in the UTM zone "
                            "of its centre."))
        self.addParameter(dem)
        void = QgsProcessingParameterNumber("VOID_VALUE", self.tr("DEM void value (e.g. 0; empty = none)"),
                                            QgsProcessingParameterNumber.Double, optional=True)
        void.setFlags(void.flags() | QgsProcessingParameterDefinition.FlagAdvanced)
        void.setHelp(self.tr("DEM cells of this value are holes (e.g. 0 or -9999 in a file that does not mark its "
                             "no-data value); empty: only the file's own no-data value"))
        self.addParameter(void)

    # --- input readers ------------------------------------------------------------------------------------------
    def dem_path(self, parameters, context) -> Tuple[str, QgsCoordinateReferenceSystem]:
        """File path and CRS of the DEM parameter, checked: a GDAL-readable file."""
        value = parameters.get("DEM")
        is_text = isinstance(value, str) and bool(value) and not value.startswith(("memory:", "ogr:"))
        if is_text and os.path.exists(value):
            # a path: the workflow's checks say what is wrong with it (a folder, text, no CRS...), not "not found"
            return value, crs_from_wkt(checked(check_dem_file, value))
        # a layer of the project, by its id or name (the dialog passes a project layer's id, even for a typed path)
        layer = self.parameterAsRasterLayer(parameters, "DEM", context)
        if layer is None or not layer.isValid():
            if is_text:  # neither a layer nor a file: say so in the workflow's words
                return value, crs_from_wkt(checked(check_dem_file, value))
            raise QgsProcessingException(self.tr("The DEM could not be loaded as a raster layer."))
        path = layer.source().split("|")[0]
        if not os.path.isfile(path):
            raise QgsProcessingException(self.tr("The DEM must be a raster file on disk (got '{0}').").format(path))
        return path, layer.crs()

    def void_value(self, parameters, context) -> Optional[float]:
        value = parameters.get("VOID_VALUE")
        if value is None or value == "":
            return None
        return self.parameterAsDouble(parameters, "VOID_VALUE", context)

    def dem(self, parameters, context):
        """(core Dem, QgsCoordinateReferenceSystem of its values) of the DEM parameter (voids as NaN).

        A DEM in geographic coordinates is reprojected to the UTM zone of its centre (core :meth:`Dem.open`); the
        CRS returned is then that UTM CRS: cameras, points and products are in metres."""
        path, crs = self.dem_path(parameters, context)
        # the workflow's one set of DEM checks (as the dock): CRS, size, voids from nodata, NaN and sentinels
        feedback = self.feedback_of(context)

        def building(fraction: float, message: str = "") -> None:  # a large DEM's overviews, built once
            # only they say what they do: the plain reading (seconds) would run the bar to 90 % before the
            # algorithm's own progress starts again from its first step
            if feedback is not None and message:
                feedback.setProgressText(message)
                feedback.setProgress(100.0 * fraction)

        dem, notes = checked(load_checked_dem, path, self.void_value(parameters, context), building)
        for note in notes:
            if feedback is not None:
                (feedback.pushWarning if IMAGE_NOTE in note else feedback.pushInfo)(note)
        if (crs.isGeographic() or not crs.isValid()) and dem.crs_wkt:
            crs = crs_from_wkt(dem.crs_wkt)
        if not crs.isValid():  # never an output without a CRS
            raise QgsProcessingException(self.tr("QGIS could not read the DEM's coordinate reference system ({0}): "
                                                 "check it in the layer's properties.").format(dem.crs_wkt[:80]))
        return dem, crs

    def photo_path(self, parameters, context, name: str = "PHOTO") -> str:
        return checked(check_photo_path, self.parameterAsFile(parameters, name, context))

    def camera(self, parameters, context, name: str = "CAMERA", photo: Optional[str] = None,
               crs: Optional[QgsCoordinateReferenceSystem] = None, image_size=None, dem=None,
               only_if_moved: bool = False, rough: bool = False):
        """The camera of a file parameter; KML needs the photo (size) and the DEM CRS. With ``dem``, a camera that
        sees no part of it is refused (:func:`~..workflow.inputs.check_view`); ``only_if_moved``: only a camera
        transformed from another CRS (the batch reports a blind camera per photo); ``rough``: a start for a fit (a
        camera of a photo of another shape is kept as a rough start, see :func:`~..workflow.camera_files.
        fitted_to_size`)."""
        path = self.parameterAsFile(parameters, name, context)
        if image_size is None and photo:
            image_size = checked(photo_size, photo)
        notes = []
        camera = checked(load_camera, path, image_size, crs.toWkt() if crs is not None and crs.isValid() else "",
                         notes, rough)
        feedback = self.feedback_of(context)
        for note in notes:  # a camera transformed into the DEM's CRS
            if feedback is not None:
                feedback.pushInfo(note)
        status, message = verdict_on_photo(path, photo or "")
        if message.startswith("fitted on another photo") and not rough and feedback is not None:
            # a time-lapse trial's frame 1 camera on frame 5 (a 4 degree remount): products 168 m off, said "ok"
            feedback.pushWarning(self.tr("The camera {0} was {1}").format(os.path.basename(path), message[:600]))
        elif status and status != "ok" and not rough and feedback is not None:
            # written by an "uncertain" or "poor" fit or registration: what is made from it inherits its error
            feedback.pushWarning(self.tr("The camera {0} was written by a fit whose verdict was \"{1}\": the "
                                         "products made from it are no better than it. Its message: {2}").format(
                os.path.basename(path), status, message[:400] + ("…" if len(message) > 400 else "")))
        if dem is not None and (notes or not only_if_moved):
            try:
                check_view(camera, dem)
            except InputError as exc:
                # transformed from another CRS and then off the DEM: most likely its numbers were in the DEM's CRS
                # already and its CRS label is wrong
                hint = "".join(f" The {note}: if its numbers are in the DEM's CRS already, its CRS label is wrong."
                               for note in notes)
                raise QgsProcessingException(str(exc) + hint) from exc
        return camera


def camera_line(camera) -> str:
    """The camera's parameters for the log, rounded, the heading as the dock and the report show it (clockwise from
    grid north, 0-360: the log said -63.61 where they said 296.39).

    >>> from monoplot_plugin.core.camera import Camera
    >>> camera_line(Camera((1.0, 2.0, 3.0), -63.61, -8.5, 0.1, 56.1, (100, 80)))[:60]
    'x 1.0 m, y 2.0 m, z 3.0 m, heading 296.39°, pitch -8.50°, ro'
    """
    p = camera.parameters()
    text = (f"x {p['x']:.1f} m, y {p['y']:.1f} m, z {p['z']:.1f} m, heading {azimuth(p['heading']):.2f}°, "
            f"pitch {p['pitch']:.2f}°, roll {p['roll']:.2f}°, field of view {p['fov']:.2f}°")
    if p.get("k1"):
        text += f", k1 {p['k1']:.4f}"
    return text


def report_status(feedback, what: str, status: str, message: str) -> None:
    """A fit's or registration's verdict in the log: "ok" as information, "uncertain" as a warning, "poor" (and
    worse) as an error; the status first, so that the first line says it (an "uncertain" was a block of red)."""
    text = f"{what} {status}: {message}"
    if status == "ok":
        feedback.pushInfo(text)
    elif status == "uncertain":
        feedback.pushWarning(text)
    else:
        feedback.reportError(text, False)


def checked(function: Callable, *args, **kwargs):
    """Call ``function``; turn an :class:`InputError` into a ``QgsProcessingException`` with the same message."""
    try:
        return function(*args, **kwargs)
    except InputError as exc:
        raise QgsProcessingException(str(exc)) from exc


#: the toolbox's groups of Monoplot's algorithms (id -> shown name), numbered in the order of the work
_GROUPS = {"camera": "1 · Points and camera", "products": "2 · Products", "batch": "3 · Many photos"}


def labelled_help(text: str, names) -> str:
    """The help ``text`` with each parameter name (``names``: (name, label) pairs) as the dialog shows it:
    the label, with the name in brackets the first time (what ``processing.run`` and qgis_process take). A trial
    read "FOLDER", "CAMERA", "REGISTER" in the help beside fields labelled "Photo folder", "Shared camera"... Names
    that are also words of the text ("DEM", "PHOTO" labelled so; "XYZ" of "XYZ raster") stay as they are.

    >>> labelled_help("Give CAMERA and DEM. A CAMERA_STATUS output; CAMERA again.",
    ...               [("CAMERA", "Shared camera (JSON)"), ("DEM", "DEM (metres)")])
    'Give “Shared camera” (CAMERA) and DEM. A CAMERA_STATUS output; “Shared camera” again.'
    """
    labels = {}
    for name, label in names:
        label = str(label).split(" (")[0].strip()  # "Camera (Monoplot JSON, or KML)": its first words
        if label and label.lower() != name.lower() and name not in _WORD_NAMES:
            labels.setdefault(name, label)
    if not labels:
        return text
    seen = set()

    def shown(match) -> str:
        name = match.group(0)
        first = name not in seen
        seen.add(name)
        return f"“{labels[name]}” ({name})" if first else f"“{labels[name]}”"

    names_first = sorted(labels, key=len, reverse=True)  # CAMERA_STATUS before CAMERA
    pattern = "(?<![A-Za-z0-9_])(" + "|".join(re.escape(n) for n in names_first) + ")(?![A-Za-z0-9_])"
    return re.sub(pattern, shown, text)


#: parameter names that are also ordinary words of the help texts
_WORD_NAMES = {"XYZ"}


def progress_callback(feedback, start: float = 0.0, end: float = 100.0) -> Callable[..., None]:
    """The workflow's ``progress(fraction in [0, 1], message="")`` on ``feedback``: the progress bar between
    ``start`` and ``end`` percent, and the stage's words when they change (the dialog's label and one log line
    each: a trial's automatic registration ran 24 s saying nothing of what it did, the dock said each stage)."""
    said = [""]

    def callback(fraction: float, message: str = "") -> None:
        if feedback is not None:
            if message and message != said[0]:
                said[0] = message
                feedback.setProgressText(message[:1].upper() + message[1:])
            feedback.setProgress(start + (end - start) * max(0.0, min(1.0, float(fraction))))

    return callback


def cancel_callback(feedback) -> Callable[[], bool]:
    """The workflow's ``is_canceled()`` on ``feedback``."""
    return (lambda: False) if feedback is None else feedback.isCanceled


def check_canceled(feedback) -> None:
    if feedback is not None and feedback.isCanceled():
        raise Canceled()


# --- photo-space and map-space point layers ---------------------------------------------------------------------
def photo_point_fields() -> QgsFields:
    fields = QgsFields()
    fields.append(QgsField("id", QVariant.Int))
    fields.append(QgsField("u_px", QVariant.Double))
    fields.append(QgsField("v_px", QVariant.Double))
    fields.append(QgsField("score", QVariant.Double))
    return fields


def map_point_fields() -> QgsFields:
    fields = QgsFields()
    fields.append(QgsField("id", QVariant.Int))
    fields.append(QgsField("X", QVariant.Double))
    fields.append(QgsField("Y", QVariant.Double))
    fields.append(QgsField("Z", QVariant.Double))
    fields.append(QgsField("score", QVariant.Double))
    fields.append(QgsField("label", QVariant.String))
    return fields


def write_photo_points(sink, uv: np.ndarray, scores=None, feedback=None) -> int:
    """Add (N, 2) pixel points to a sink made with :func:`photo_point_fields`; returns N."""
    for i, (u, v) in enumerate(np.asarray(uv, dtype=float).reshape(-1, 2)):
        feature = QgsFeature(photo_point_fields())
        feature.setGeometry(QgsGeometry(QgsPoint(float(u), PHOTO_Y_SIGN * float(v))))
        feature.setAttributes([i + 1, float(u), float(v), float(scores[i]) if scores is not None else 0.0])
        sink.addFeature(feature, QgsFeatureSink.FastInsert)
    return len(uv)


def write_map_points(sink, xyz: np.ndarray, scores=None, labels=None) -> int:
    """Add (N, 3) map points (PointZ) to a sink made with :func:`map_point_fields`; returns N."""
    for i, (x, y, z) in enumerate(np.asarray(xyz, dtype=float).reshape(-1, 3)):
        feature = QgsFeature(map_point_fields())
        feature.setGeometry(QgsGeometry(QgsPoint(float(x), float(y), float(z))))
        feature.setAttributes([i + 1, float(x), float(y), float(z), float(scores[i]) if scores is not None else 0.0,
                               str(labels[i]) if labels is not None else ""])
        sink.addFeature(feature, QgsFeatureSink.FastInsert)
    return len(xyz)


def _field_index(fields: QgsFields, names) -> int:
    lowered = [f.name().lower() for f in fields]
    for name in names:
        if name in lowered:
            return lowered.index(name)
    return -1


def read_photo_points(source) -> np.ndarray:
    """(N, 2) pixels (u, v) of a point source in photo space (fields u_px/v_px, else geometry x, -y)."""
    iu, iv = _field_index(source.fields(), ("u_px", "u")), _field_index(source.fields(), ("v_px", "v"))
    points = []
    for feature in source.getFeatures():
        attributes = feature.attributes()
        if iu >= 0 and iv >= 0 and attributes[iu] is not None and attributes[iv] is not None:
            try:
                points.append((float(attributes[iu]), float(attributes[iv])))
                continue
            except (TypeError, ValueError):
                pass
        geometry = feature.geometry()
        if geometry.isNull():
            continue
        for vertex in geometry.vertices():
            points.append((vertex.x(), PHOTO_Y_SIGN * vertex.y()))
    return np.array(points, dtype=float).reshape(-1, 2)


def read_map_points(source, crs=None, context=None) -> np.ndarray:
    """(N, 3) map points of a point source: geometry x, y (transformed to ``crs`` when given and different); Z from
    the geometry, else a Z field, else NaN (the caller samples the DEM)."""
    from qgis.core import QgsFeatureRequest

    iz = _field_index(source.fields(), ("z", "z_m", "elevation", "elev", "alt", "height"))
    request = QgsFeatureRequest()
    if crs is not None and crs.isValid() and source.sourceCrs().isValid() and source.sourceCrs() != crs:
        request.setDestinationCrs(crs, context.transformContext() if context is not None else
                                  QgsProject.instance().transformContext())
    points = []
    for feature in source.getFeatures(request):
        geometry = feature.geometry()
        if geometry.isNull():
            continue
        for vertex in geometry.vertices():
            z = vertex.z() if QgsWkbTypes.hasZ(geometry.wkbType()) else float("nan")
            if (z != z) and iz >= 0:
                try:
                    z = float(feature.attributes()[iz])
                except (TypeError, ValueError):
                    z = float("nan")
            points.append((vertex.x(), vertex.y(), z))
    return np.array(points, dtype=float).reshape(-1, 3)


def centred_on_print(prior, image, feedback=None):
    """``prior`` with its principal point at the centre of a scanned print's picture (its paper border, caption
    and scanner strips left out: :func:`~..workflow.products.centred_on_picture`), said in the log when moved; the
    dock does the same with every rough camera. ``image``: (H, W, 3) photo."""
    from ..workflow.products import centred_on_picture, picture_area

    moved = centred_on_picture(prior, picture_area(image))
    if moved is not prior and feedback is not None:
        feedback.pushInfo(QCoreApplication.translate("Monoplot", "Principal point at the picture's centre ({0:.0f}, "
                                                     "{1:.0f}), not the file's: the photo has a print's border")
                          .format(moved.cx, moved.cy))
    return moved

