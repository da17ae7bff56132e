"""The DEM of a :class:`~monoplot_plugin.gui.controller.MonoplotController` (a mixin): the layer chosen in the
dock read into a core Dem, a DEM too large to read whole whose overviews are missing opened in a task (progress,
Cancel), the layer added back when the person removed it. Its needs are :class:`DemInputHost`, checked by
``tests/gui/test_controller_interfaces.py``."""

from __future__ import annotations

import os
from typing import Optional, Protocol

from qgis.core import Qgis, QgsCoordinateReferenceSystem, QgsRasterLayer

from ..adapters.dem import DemError, dem_layer_path, read_in_background, read_dem_file
from ..core.dem_large import IMAGE_NOTE
from ..core.dem import DemReadCanceled
from ..state import MAP
from ..workflow.progress import Canceled

__all__ = ["DemInputMixin", "DemInputHost"]

INFO, WARNING, CRITICAL = Qgis.MessageLevel.Info, Qgis.MessageLevel.Warning, Qgis.MessageLevel.Critical


class DemInputHost(Protocol):
    """What :class:`DemInputMixin` uses of the controller."""

    state: object  # ProjectState
    project: object  # QgsProject
    dem: object  # core Dem or None
    dem_layer: Optional[QgsRasterLayer]
    dem_crs: QgsCoordinateReferenceSystem
    _map_work_crs: Optional[QgsCoordinateReferenceSystem]  # the CRS the map points and cameras were placed in
    overlay: object
    xyz: object
    footprint_wkt: str
    message: object  # pyqtSignal(str, level)
    demChanged: object  # pyqtSignal()
    fitted: object  # the fitted Camera or None

    def tr(self, text: str) -> str: ...

    def ensure_products(self, background: bool = True) -> None: ...

    def _start(self, kind: str, description: str, work, on_success) -> bool: ...

    def _changed(self) -> None: ...

    def _maybe_exif_prior(self, fresh: bool = False) -> bool: ...


class DemInputMixin:
    """The DEM layer -> core Dem; needs a :class:`DemInputHost`."""

    def _readd_dem(self, source: str) -> Optional[QgsRasterLayer]:
        """The DEM layer was removed from the project: add its file back (the curation needs it)."""
        # named as QGIS names a file it opens (a trial found "DEM (Monoplot)" where the layer had been "dem")
        name = os.path.splitext(os.path.basename(source.split("|")[0]))[0] or self.tr("DEM")
        layer = QgsRasterLayer(source, name)
        if not layer.isValid():
            self.message.emit(self.tr("The DEM of this Monoplot session is missing: {0}").format(source), WARNING)
            return None
        # at the bottom of the layer tree: on top it hid what the person had left in view (a re-check trial's
        # orthophoto, under the grey DEM once the project was opened again)
        self.project.addMapLayer(layer, False)
        self.project.layerTreeRoot().addLayer(layer)
        self.message.emit(self.tr("The DEM layer was missing from the project; Monoplot added {0} again.")
                          .format(source), INFO)
        return layer

    def _layers_removed(self, layer_ids) -> None:
        """Forget the layer object (not the in-memory DEM) when the user removes the DEM layer."""
        if self.dem_layer is not None and self.state.dem_layer_id in layer_ids:
            self.dem_layer = None

    def set_dem_layer(self, layer: Optional[QgsRasterLayer], void_value: Optional[float] = None) -> bool:
        """Use ``layer`` as the DEM (its file is read into memory now). A DEM too large to read whole whose
        overviews are missing is opened in a task instead (building them takes minutes: progress and Cancel, QGIS
        stays responsive); False until it is ready (``demChanged`` then)."""
        if layer is None:
            self.dem, self.dem_layer = None, None
            self.state.dem_layer_id = ""
            self.demChanged.emit()
            return False
        try:
            path = dem_layer_path(layer)
            if read_in_background(path):
                self._open_dem_in_task(layer, path, void_value)
                return False
            dem, notes = read_dem_file(path, void_value)
        except DemError as exc:
            self.message.emit(str(exc), CRITICAL)
            return False
        self._use_dem(layer, dem, notes)
        return True

    def _open_dem_in_task(self, layer: QgsRasterLayer, path: str, void_value: Optional[float]) -> None:
        def work(progress, is_canceled):
            try:
                return read_dem_file(path, void_value, progress, is_canceled)
            except DemReadCanceled:
                raise Canceled() from None  # nothing kept (a half-built .ovr was removed): the next try starts afresh

        self._start("dem", self.tr("Opening the large DEM {0}").format(layer.name()), work,
                    lambda read: self._use_dem(layer, *read, later=True))

    def _use_dem(self, layer: QgsRasterLayer, dem, notes, later: bool = False) -> None:
        """Use ``dem`` (read from ``layer``'s file); ``later``: read in a task, after the caller went on (a reopened
        project's overlay then waits for it)."""
        self.dem, self.dem_layer = dem, layer
        # The CRS of the in-memory DEM, which all map points and cameras use: a geographic layer was reprojected
        # to UTM metres, so the layer's own CRS (degrees) would put every marker and click in the wrong place.
        crs = QgsCoordinateReferenceSystem.fromWkt(dem.crs_wkt) if dem.crs_wkt else QgsCoordinateReferenceSystem()
        self.dem_crs = crs if crs.isValid() else QgsCoordinateReferenceSystem(layer.crs())
        has_map_work = any(p.space == MAP for p in self.state.points.values()) or bool(
            self.state.prior or self.state.fitted)
        before = self._map_work_crs
        if not has_map_work or before is None or not before.isValid():
            self._map_work_crs = QgsCoordinateReferenceSystem(self.dem_crs)
        elif before != self.dem_crs:
            # a trial switched from an LV03 DEM to one in degrees (used in UTM): the map points and cameras kept
            # their LV03 numbers, vanished from the map, and a refit said "uncertain" 1,700 px off, without a word
            self.message.emit(self.tr("The new DEM is used in {0}, the map points and cameras so far are in {1}: "
                                      "they are not converted, and lie elsewhere on this DEM. Choose the previous "
                                      "DEM again to go on with them, or start afresh with this one.")
                              .format(self.dem_crs.authid() or self.dem_crs.description(),
                                      before.authid() or before.description()), WARNING)
        same = (self.state.dem_layer_id, self.state.dem_source) == (layer.id(), layer.source())
        self.state.dem_layer_id, self.state.dem_source = layer.id(), layer.source()
        for note in notes:
            self.message.emit(self.tr("DEM: {0}").format(note), WARNING if IMAGE_NOTE in note else INFO)
        self.overlay, self.xyz, self.footprint_wkt = None, None, ""
        self.demChanged.emit()
        if not (later and same):  # a reopened project's own DEM, read in a task, changes nothing in it
            self._changed()
        self._maybe_exif_prior()
        if later and self.fitted is not None:  # a reopened project's camera: its overlay and XYZ on this DEM
            self.ensure_products()
