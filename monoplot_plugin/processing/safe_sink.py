"""Verified feature sinks and signal-driven cancel for the Processing algorithms.

A file destination of a feature sink (``.gpkg``, ``.shp``, ...) is written to a temporary file beside it; when the
algorithm is done, :meth:`SafeSink.commit` closes the writer, checks that every feature reached the file (OGR
feature count) and renames it into place (outputs' :func:`~monoplot_plugin.outputs.safe_write.commit_temporary`).
A failed ``addFeature`` (full disk) raises at once with QGIS's own error. Memory layers and database URIs are
passed through unchanged.
"""

from __future__ import annotations

import os
import signal
import threading
from contextlib import contextmanager
from pathlib import Path

from qgis.core import (QgsCoordinateReferenceSystem, QgsFeatureSink, QgsProcessingException,
                       QgsProcessingLayerPostProcessorInterface, QgsProcessingOutputLayerDefinition)

from ..outputs.safe_write import check_can_write, commit_temporary, incomplete_write, remove_temporary, temporary_path

__all__ = ["SafeSink", "safe_sink", "signals_cancel", "guarded_run", "check_file_destinations"]


_local = threading.local()


def _open_sinks() -> list:
    if not hasattr(_local, "sinks"):
        _local.sinks = []
    return _local.sinks


def _file_destination(dest: str) -> bool:
    """True for a plain file path (not 'memory:', 'ogr:...', 'postgres://...')."""
    if not dest or dest.startswith(("memory:", "ogr:", "postgres", "spatialite:", "TEMPORARY_OUTPUT")):
        return False
    return bool(Path(dest).suffix) and "|" not in dest and os.path.isdir(os.path.dirname(os.path.abspath(dest)))


class SafeSink:
    """A QgsFeatureSink stand-in: ``addFeature`` counts and checks each write; :meth:`commit` verifies and renames.

    Attributes:
        dest: the destination to return from the algorithm (the final path for files).
    """

    def __init__(self, sink, dest: str, final: str = "", tmp: str = "", context=None, crs_valid: bool = True):
        self._sink, self.dest, self._final, self._tmp, self._context = sink, dest, final, tmp, context
        self._crs_valid = crs_valid
        self.count = 0
        if tmp:
            _open_sinks().append(self)

    def addFeature(self, feature, flags=QgsFeatureSink.FastInsert) -> bool:
        if not self._sink.addFeature(feature, flags):
            error = self._sink.lastError() if hasattr(self._sink, "lastError") else ""
            raise incomplete_write(self._final or self.dest, error or "write error")
        self.count += 1
        return True

    def addFeatures(self, features, flags=QgsFeatureSink.FastInsert) -> bool:
        for feature in features:
            self.addFeature(feature, flags)
        return True

    def commit(self) -> str:
        """Close the writer; for a file destination verify the feature count and rename into place."""
        from ..outputs._gdal import vector_verifier

        sink, self._sink = self._sink, None
        if self in _open_sinks():
            _open_sinks().remove(self)
        if sink is not None and hasattr(sink, "flushBuffer"):
            if not sink.flushBuffer():
                raise incomplete_write(self._final or self.dest, sink.lastError())
        del sink  # the writer closes its file when the last reference goes
        if not self._tmp:
            return self.dest
        if not self._crs_valid:
            mark_cartesian(self._tmp)
        commit_temporary(self._tmp, self._final, overwrite=True, verify=vector_verifier(self.count))
        self._retarget_loading()
        if not self._crs_valid:
            keep_pixel_space(self._context, self._final)
        return self.dest

    def discard(self) -> None:
        self._sink = None
        if self in _open_sinks():
            _open_sinks().remove(self)
        if self._tmp:
            remove_temporary(self._tmp, self._final)

    def _retarget_loading(self) -> None:
        context = self._context
        if context is None or not context.willLoadLayerOnCompletion(self._tmp):
            return
        layers = dict(context.layersToLoadOnCompletion())
        details = layers.pop(self._tmp)
        layers[self._final] = details
        context.setLayersToLoadOnCompletion(layers)


class PixelSpaceOnLoad(QgsProcessingLayerPostProcessorInterface):
    """Loaded into the project, a layer in photo pixels keeps no CRS: QGIS gives a layer without one the default
    CRS (EPSG:4326 out of the box), which labelled photo pixels as degrees and reprojected them. It is also left
    unchecked in the Layers panel, as the dock's photo layers are: drawn on the map it stretched the map's full
    extent from the DEM to tens of thousands of kilometres (a desktop trial)."""

    #: the post-processors handed to contexts: a context deletes its post-processor once it has run, and the
    #: Python side must keep the object alive until then
    _alive: list = []

    def postProcessLayer(self, layer, context, feedback):  # noqa: N802 (QGIS API)
        layer.setCrs(QgsCoordinateReferenceSystem())
        project = context.project() if context is not None else None
        node = project.layerTreeRoot().findLayer(layer.id()) if project is not None else None
        if node is not None:
            node.setItemVisibilityChecked(False)

    @classmethod
    def create(cls) -> "PixelSpaceOnLoad":
        cls._alive = cls._alive[-15:] + [cls()]
        return cls._alive[-1]


class XyzRasterOnLoad(PixelSpaceOnLoad):
    """An XYZ raster loaded into the project as the dock adds it: no CRS, unchecked, Z as a colour ramp (a desktop
    trial: Processing's loaded visible and grey, and "zoom full" went to 1:180,000,000)."""

    _alive: list = []

    def postProcessLayer(self, layer, context, feedback):  # noqa: N802 (QGIS API)
        from ..adapters.layers import style_xyz_layer

        style_xyz_layer(layer)
        super().postProcessLayer(layer, context, feedback)


def keep_pixel_space(context, dest: str, xyz_raster: bool = False) -> None:
    """Make ``dest``, an output to be loaded on completion, a layer without a CRS once loaded (photo pixels); an
    XYZ raster (``xyz_raster``) is also styled as the dock styles it."""
    if context is not None and context.willLoadLayerOnCompletion(dest):
        processor = XyzRasterOnLoad.create() if xyz_raster else PixelSpaceOnLoad.create()
        context.layerToLoadOnCompletionDetails(dest).setPostProcessor(processor)
        if dest:  # a file, or the id of a temporary layer
            _PIXEL_FILES[:] = _PIXEL_FILES[-31:] + [_normal(dest) if os.path.isabs(dest) else dest]
            _watch_added_layers()


#: photo-pixel output files about to be loaded (:func:`keep_pixel_space`). The post-processor drops their CRS only
#: after QGIS has added them, and by then the map had asked for a transform from the GeoPackage's "Undefined
#: Cartesian SRS": a red "No transform available between Undefined Cartesian SRS and EPSG:2056" after every Map
#: layer to photo from the toolbox (a trial). :func:`drop_crs_of_pixel_files`, on the project's ``layersAdded``,
#: drops it at once.
_PIXEL_FILES: list = []


def _normal(path: str) -> str:
    return os.path.normcase(os.path.abspath(path))


#: whether :func:`drop_crs_of_pixel_files` listens to the project (connected on the first output to be loaded: never
#: in qgis_process, where QGIS 3.40 crashed on exit with a slot connected at the provider's load)
_WATCHING: list = []


def _watch_added_layers() -> None:
    from qgis.core import QgsProject

    if not _WATCHING:
        QgsProject.instance().layersAdded.connect(drop_crs_of_pixel_files)
        _WATCHING.append(True)


def stop_watching_added_layers() -> None:
    """The plugin unloads: the project's ``layersAdded`` no longer calls into this module."""
    from qgis.core import QgsProject

    if _WATCHING:
        try:
            QgsProject.instance().layersAdded.disconnect(drop_crs_of_pixel_files)
        except (TypeError, RuntimeError):  # already gone
            pass
        _WATCHING.clear()


def drop_crs_of_pixel_files(layers) -> None:
    """Slot of ``QgsProject.layersAdded``: the layers of a photo-pixel output (its file, or its temporary layer's
    id) lose their CRS."""
    for layer in layers:
        path = layer.source().split("|")[0]
        if layer.id() in _PIXEL_FILES or (os.path.isabs(path) and _normal(path) in _PIXEL_FILES):
            layer.setCrs(QgsCoordinateReferenceSystem())


def safe_sink(algorithm, parameters, name, context, fields, wkb, crs) -> SafeSink:
    """``algorithm.parameterAsSink`` through a temporary file when the destination is a file (see module doc).

    An invalid ``crs`` means photo pixels: the layer keeps no CRS once loaded (:class:`PixelSpaceOnLoad`)."""
    loading = set(context.layersToLoadOnCompletion()) if context is not None else set()
    final = algorithm.parameterAsOutputLayer(parameters, name, context)
    if not _file_destination(final):
        # parameterAsOutputLayer put "memory:<name>" on the list of layers to load, beside the layer id that
        # parameterAsSink adds: Processing then said "The following layers were not correctly generated"
        if context is not None and final not in loading and context.willLoadLayerOnCompletion(final):
            layers = dict(context.layersToLoadOnCompletion())
            layers.pop(final)
            context.setLayersToLoadOnCompletion(layers)
        sink, dest = algorithm.parameterAsSink(parameters, name, context, fields, wkb, crs)
        if sink is None:
            raise QgsProcessingException(algorithm.invalidSinkError(parameters, name))
        if not crs.isValid():
            keep_pixel_space(context, dest)
        return SafeSink(sink, dest)
    check_can_write(final, overwrite=True)  # a missing or read-only folder is said in words, before any work
    tmp = str(temporary_path(final))
    layer_name = Path(final).stem
    definition = QgsProcessingOutputLayerDefinition(tmp)
    original = parameters.get(name)
    options = dict(original.createOptions) if isinstance(original, QgsProcessingOutputLayerDefinition) else {}
    options.setdefault("layerName", layer_name)  # not the temporary file's name
    definition.createOptions = options
    redirected = dict(parameters)
    redirected[name] = definition
    try:
        sink, _dest = algorithm.parameterAsSink(redirected, name, context, fields, wkb, crs)
    except QgsProcessingException as exc:  # the folder was writable a moment ago: out of space
        remove_temporary(tmp, final)
        raise incomplete_write(final, str(exc)) from exc
    except Exception:
        remove_temporary(tmp, final)
        raise
    if sink is None:
        remove_temporary(tmp, final)
        raise QgsProcessingException(algorithm.invalidSinkError(parameters, name))
    return SafeSink(sink, final, final, tmp, context, crs_valid=crs.isValid())


def mark_cartesian(path: str) -> None:
    """A GeoPackage written without a CRS says "Undefined Cartesian SRS" (srs_id -1), not GDAL's default "Undefined
    geographic SRS" (srs_id 0), which QGIS reads as a valid geographic CRS and would reproject photo pixels as degrees.
    Other formats are left as they are."""
    from osgeo import ogr

    if Path(path).suffix.lower() != ".gpkg":
        return
    ds = ogr.Open(path, 1)
    if ds is None:
        return
    try:
        for table in ("gpkg_contents", "gpkg_geometry_columns"):
            ds.ExecuteSQL(f"UPDATE {table} SET srs_id = -1 WHERE srs_id = 0")
    finally:
        ds = None


def check_file_destinations(algorithm, parameters, context) -> None:
    """Refuse a missing or read-only output folder in words before any work (file and raster destinations; feature
    sinks are checked by :func:`safe_sink`)."""
    from qgis.core import QgsProcessingParameterFileDestination, QgsProcessingParameterRasterDestination

    for definition in algorithm.destinationParameterDefinitions():
        name = definition.name()
        if parameters.get(name) in (None, "") or not isinstance(
                definition, (QgsProcessingParameterFileDestination, QgsProcessingParameterRasterDestination)):
            continue
        if isinstance(definition, QgsProcessingParameterFileDestination):
            path = algorithm.parameterAsFileOutput(parameters, name, context)
        else:
            # a temporary output gets a new path at every call, queued for loading: the algorithm's own call
            # queues the one it writes, so this one leaves the queue as it was (a re-check trial: "The following
            # layers were not correctly generated: .../OUTPUT.tif" after every temporary XYZ raster)
            loading = dict(context.layersToLoadOnCompletion()) if context is not None else None
            path = algorithm.parameterAsOutputLayer(parameters, name, context)
            if loading is not None and set(context.layersToLoadOnCompletion()) != set(loading):
                context.setLayersToLoadOnCompletion(loading)
        if _file_destination(path) or (path and not os.path.isdir(os.path.dirname(os.path.abspath(path)))):
            check_can_write(path, overwrite=True)


@contextmanager
def guarded_run(feedback):
    """Around an algorithm: SIGINT/SIGTERM cancel it (:func:`signals_cancel`), every write asks for a cancel just
    before its final rename, and the temporary files of sinks that were not committed (an error, a cancel) are
    removed."""
    from ..outputs.safe_write import cancel_before_commit

    before = list(_open_sinks())
    try:
        with signals_cancel(feedback), cancel_before_commit(feedback.isCanceled if feedback else lambda: False):
            yield
    finally:
        for sink in [s for s in _open_sinks() if s not in before]:
            sink.discard()


def signals_cancel(feedback):
    """While the block runs (main thread only), SIGINT and SIGTERM cancel ``feedback`` instead of killing the
    process: the algorithm stops at its next check and the earlier output stays as it was."""
    from ..outputs.safe_write import signal_handlers

    def handler(signum, frame):
        if feedback is not None:
            feedback.reportError(f"signal {signal.Signals(signum).name} received: canceling", False)
            feedback.cancel()

    return signal_handlers(handler, (signal.SIGINT, signal.SIGTERM) if feedback is not None else ())
