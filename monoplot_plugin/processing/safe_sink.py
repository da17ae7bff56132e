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

from qgis.core import QgsFeatureSink, QgsProcessingException, QgsProcessingOutputLayerDefinition

from ..outputs.safe_write import OutputError, commit_temporary, remove_temporary, temporary_path

__all__ = ["SafeSink", "safe_sink", "signals_cancel"]


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

    def __init__(self, sink, dest: str, final: str = "", tmp: str = "", context=None):
        self._sink, self.dest, self._final, self._tmp, self._context = sink, dest, final, tmp, context
        self.count = 0

    def addFeature(self, feature, flags=QgsFeatureSink.FastInsert) -> bool:
        if not self._sink.addFeature(feature, flags):
            error = self._sink.lastError() if hasattr(self._sink, "lastError") else ""
            raise OutputError(f"cannot write {os.path.basename(self._final or self.dest)}: {error or 'write error'}"
                              f" (is the disk full?)")
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
        if sink is not None and hasattr(sink, "flushBuffer"):
            if not sink.flushBuffer():
                raise OutputError(f"cannot write {os.path.basename(self._final)}: {sink.lastError()}")
        del sink  # the writer closes its file when the last reference goes
        if not self._tmp:
            return self.dest
        commit_temporary(self._tmp, self._final, overwrite=True, verify=vector_verifier(self.count))
        self._retarget_loading()
        return self.dest

    def discard(self) -> None:
        self._sink = None
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


def safe_sink(algorithm, parameters, name, context, fields, wkb, crs) -> SafeSink:
    """``algorithm.parameterAsSink`` through a temporary file when the destination is a file (see module doc)."""
    final = algorithm.parameterAsOutputLayer(parameters, name, context)
    if not _file_destination(final):
        sink, dest = algorithm.parameterAsSink(parameters, name, context, fields, wkb, crs)
        if sink is None:
            raise QgsProcessingException(algorithm.invalidSinkError(parameters, name))
        return SafeSink(sink, dest)
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
    except Exception:
        remove_temporary(tmp, final)
        raise
    if sink is None:
        remove_temporary(tmp, final)
        raise QgsProcessingException(algorithm.invalidSinkError(parameters, name))
    return SafeSink(sink, final, final, tmp, context)


@contextmanager
def signals_cancel(feedback):
    """While the block runs (main thread only), SIGINT and SIGTERM cancel ``feedback`` instead of killing the
    process: the algorithm stops at its next check and the earlier output stays as it was."""
    installed = []
    if feedback is not None and threading.current_thread() is threading.main_thread():
        def handler(signum, frame):
            feedback.reportError(f"signal {signal.Signals(signum).name} received: canceling", False)
            feedback.cancel()

        for signum in (signal.SIGINT, signal.SIGTERM):
            try:
                installed.append((signum, signal.signal(signum, handler)))
            except (ValueError, OSError, TypeError):
                pass
    try:
        yield
    finally:
        for signum, previous in installed:
            try:
                signal.signal(signum, previous if previous is not None else signal.SIG_DFL)
            except (ValueError, OSError, TypeError):
                pass
