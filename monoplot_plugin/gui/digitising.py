"""The dock's digitising session: photo-space layers and their live 3-D map layers.

:class:`DigitisingSession` holds the photo-space digitising layers (one per kind: point, line, polygon; memory
layers in pixel space x = u, y = -v, no CRS, shown on the photo canvas) and, for each, a *live* 3-D map layer in the
DEM's CRS that is rebuilt whenever the photo layer changes (tools of :mod:`.digitise_tools`, QGIS's own editing,
undo). Files are written by :mod:`..outputs.vectors`; layers of written files are added by :mod:`.map_layers`.
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import replace
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
from qgis.core import (QgsCoordinateReferenceSystem, QgsFeature, QgsField, QgsGeometry, QgsProject, QgsSymbol,
                       QgsVectorLayer)
from qgis.PyQt.QtCore import QObject, Qt, QVariant, pyqtSignal
from qgis.PyQt.QtGui import QColor

from ..adapters.layers import crs_from_wkt as _crs
from ..adapters.layers import derived_layers_only, rebuilt_on_reopen
from ..adapters.photo_space import (computed_fields, photo_geometry, photo_point, photo_vertices, pixel_of,
                                   qgs_geometry)
from ..workflow.features import photo_to_map_feature
from ..outputs.vectors import FIT_STATUS_FIELD, MapFeature, write_vector_layer
from .map_layers import add_layer, add_vector_file_layer, photo_group
from . import persistence
from .drawn_copies import DRAWN_ROOT, map_copies
from .drawn_history import DrawnHistoryMixin

__all__ = ["DigitisingSession", "drawn_entry_key", "KINDS"]

KINDS = ("point", "line", "polygon")
_PHOTO_TYPES = {"point": "Point", "line": "LineString", "polygon": "Polygon"}
_MAP_TYPES = {"point": "PointZ", "line": "MultiLineStringZ", "polygon": "MultiPolygonZ"}
_QVARIANT = {"string": QVariant.Type.String, "integer": QVariant.Type.Int, "real": QVariant.Type.Double,
             "date": QVariant.Type.Date}
_KIND_LABEL = {"point": "points", "line": "lines", "polygon": "polygons"}
#: The field of the map layers (live and exported) holding the id of the drawn feature in its photo layer.
PHOTO_FID = "photo_fid"
#: ... and the name of the photo it was drawn on (a season of time-lapse frames merged into one layer said no more
#: which frame a line came from, a trial); a field of the person's own of that name wins
PHOTO_NAME = "photo"
#: ... and when it was taken (EXIF, ISO 8601; empty when the photo has no date): a time-lapse trial's outlines of ten
#: dated frames said no date, and the frames' names were all it had to order them by
PHOTO_TAKEN = "photo_date"  # 10 characters: a Shapefile field name
#: ... and the verdict of the camera the feature was mapped with (:data:`~..outputs.vectors.FIT_STATUS_FIELD`)
FIT_STATUS = FIT_STATUS_FIELD


class DigitisingSession(DrawnHistoryMixin, QObject):
    """Photo-space digitising layers and their live 3-D map layers, for one photo, camera and DEM.

    Args:
        project: the QGIS project. camera: fitted Camera. dem: core Dem (CRS of the map layers).
        xyz: optional per-pixel XYZ raster of the photo; not needed (features are intersected with the DEM
            exactly) and may be None.
        photo_name: photo file name (names the layer group and the layers).
        pixel_rmse: the fit's pixel error (:func:`~..workflow.features.pixel_error`), None unknown; ``spread``: the
            camera's σ and correlations (:func:`~..workflow.spread.camera_spread`), None: the pixel error alone.
        fit_status: the camera's verdict, written in each map feature's :data:`FIT_STATUS` field (None: unknown).
        fields: user attribute fields, (name, type) with type in string, integer, real, date.

    Signals:
        mapLayerUpdated(str kind, int sky_pieces, int dropped): a live map layer was rebuilt; ``sky_pieces``
            pieces over sky were split off, ``dropped`` features were entirely over sky.
        closedByLayers(): the session closed itself because one of its layers is being deleted.
    """

    mapLayerUpdated = pyqtSignal(str, int, int)
    closedByLayers = pyqtSignal()

    def __init__(self, project: QgsProject, camera, dem, xyz: Optional[np.ndarray], photo_name: str,
                 fields: Sequence[Tuple[str, str]] = (("name", "string"),), parent=None,
                 pixel_rmse: Optional[float] = None, area: Optional[np.ndarray] = None,
                 photo_taken: Optional[str] = None, spread=None, fit_status: Optional[str] = None):
        super().__init__(parent)
        self.fit_status = fit_status  # the camera's verdict, a field of every map feature (None: unknown)
        self.photo_taken = photo_taken  # ISO 8601 date and time of the photo (EXIF), or None
        self.project = project
        self.camera, self.dem, self.xyz = camera, dem, xyz
        self.area = area  # a scanned print's picture: drawn on its paper or caption, no ground
        self.pixel_rmse = pixel_rmse  # the fit's pixel error, carried to the ground as xy_error_m (None: unknown)
        self.spread = spread  # the camera's σ where each feature is (workflow.spread.CameraSpread), or None
        self.photo_name = photo_name
        self.fields: List[Tuple[str, str]] = list(fields)
        self.group = photo_group(project, photo_name)
        self.photo_layers: Dict[str, QgsVectorLayer] = {}
        self.map_layers: Dict[str, QgsVectorLayer] = {}
        self.last_report: Dict[str, Tuple[int, int]] = {}
        self.last_silhouettes: Dict[str, int] = {}  # polygons' silhouette crossings, by kind (for the message)
        # (photo fid, median, largest ground metres per photo pixel) of each feature, by kind (for the message)
        self.last_spans: Dict[str, list] = {}
        # photo pixel (u, v) where each feature left off the map layer starts, by kind: the message says where
        self.last_dropped: Dict[str, List[Tuple[float, float]]] = {}
        self._mapped: Dict[Tuple[str, int], tuple] = {}  # (kind, fid) -> (photo geometry WKB, MapFeature or None)
        self._restoring = False
        self.closed = False  # set when one of its layers is being deleted (project cleared, QGIS closing)
        self.restored_from_autosave = False
        #: what :meth:`undo` takes back, last first: ("add", kind, fid), ("move", kind, fid, index, (u, v)) or
        #: ("delete", kind, geometry, attributes, fid); :meth:`redo` takes ``_redo``'s entries, of the same form
        self._history: List[tuple] = []
        self._redo: List[tuple] = []
        self.project.writeProject.connect(self._write_copies)
        self.restore_drawn()

    # --- layers -----------------------------------------------------------------------------------------------
    def photo_layer(self, kind: str) -> QgsVectorLayer:
        """The pixel-space layer of ``kind`` (created on first use; drawn on the photo canvas, and in the photo's
        layer group unchecked)."""
        if kind not in self.photo_layers:
            name = f"{Path(self.photo_name).stem} {_KIND_LABEL[kind]} (photo pixels)"
            layer = self._reusable(name)  # left in a reopened project (memory layers come back empty)
            if layer is None:
                layer = QgsVectorLayer(f"{_PHOTO_TYPES[kind]}", name, "memory")
            else:
                layer.dataProvider().truncate()
            layer.setCrs(QgsCoordinateReferenceSystem())
            rebuilt_on_reopen(layer)  # its features are a project entry (save_drawn)
            missing = [QgsField(n, _QVARIANT[t]) for n, t in self.fields if layer.fields().indexFromName(n) < 0]
            layer.dataProvider().addAttributes(missing)
            layer.updateFields()
            _style_drawn_layer(layer, kind)
            # Edits through QGIS's own tools (edit buffer, undo, rollback) rebuild the live map layer too.
            for signal in (layer.featureAdded, layer.featuresDeleted, layer.geometryChanged,
                           layer.attributeValueChanged, layer.afterRollBack, layer.afterCommitChanges):
                signal.connect(lambda *args, k=kind: self.sync(k))
            layer.willBeDeleted.connect(self.close)
            if self.project.mapLayer(layer.id()) is None:
                self.project.addMapLayer(layer, False)
            # In the photo's group beside its map layer, unchecked: it lies in photo pixel space (like the XYZ
            # raster) and must not stretch the map's extent; the Layers panel gives its attribute table.
            if self.group.findLayer(layer.id()) is None:
                self.group.addLayer(layer).setItemVisibilityChecked(False)
            self.photo_layers[kind] = layer
        return self.photo_layers[kind]

    def map_layer(self, kind: str) -> QgsVectorLayer:
        """The live 3-D map layer of ``kind`` in the photo's layer group (DEM CRS)."""
        if kind not in self.map_layers:
            uri = f"{_MAP_TYPES[kind]}?crs={_crs(self.dem.crs_wkt).authid() or 'EPSG:4326'}"
            name = f"{Path(self.photo_name).stem} {_KIND_LABEL[kind]} (map)"
            layer = self._reusable(name)
            reused = layer is not None
            if not reused:
                layer = QgsVectorLayer(uri, name, "memory")
            layer.setCrs(_crs(self.dem.crs_wkt))
            rebuilt_on_reopen(layer)  # computed from the photo layer
            attrs = [QgsField(n, _QVARIANT[t]) for n, t in self.fields]
            attrs += computed_fields(kind)
            attrs.append(QgsField(PHOTO_FID, QVariant.Type.LongLong))
            attrs += [QgsField(name, QVariant.Type.String) for name, _ in self._photo_fields()]
            layer.dataProvider().addAttributes([a for a in attrs if layer.fields().indexFromName(a.name()) < 0])
            layer.updateFields()
            if not reused:  # drawn as on the photo (QGIS's random default was a thin pale line: a trial)
                _style_drawn_layer(layer, kind)
                add_layer(self.project, layer, self.group)
            layer.willBeDeleted.connect(self.close)
            self.map_layers[kind] = layer
        return self.map_layers[kind]

    def _reusable(self, name: str) -> Optional[QgsVectorLayer]:
        for layer in self.project.mapLayersByName(name):
            if isinstance(layer, QgsVectorLayer) and layer.providerType() == "memory":
                return layer
        return None

    # --- persistence: what was drawn on the photo is kept in the project file --------------------------------
    def _entry(self) -> str:
        return drawn_entry_key(self.photo_name)

    def save_drawn(self, copies: bool = False) -> None:
        """Store the photo-space features (pixel vertices + attributes) in the project (memory layers are not
        saved with a project; this is). ``copies``: with a copy of the map layers as they are, which a reopened
        project shows while another photo is current (:mod:`.drawn_copies`); written when the project is and when
        the photo is put aside, not on every edit (80,000 map vertices took 50 ms)."""
        if self.closed:
            return
        data = {"fields": self.fields, "features": {}}
        for kind, layer in self.photo_layers.items():
            data["features"][kind] = [
                {"uv": photo_vertices(f.geometry()).tolist(),
                 "attributes": {n: _jsonable(_plain(f[n])) for n, _ in self.fields}}
                for f in layer.getFeatures() if not f.geometry().isNull()]
        if copies:
            data["map"] = map_copies(self.map_layers, lambda value: _jsonable(_plain(value)))
        data["photo_layers"] = {kind: layer.name() for kind, layer in self.photo_layers.items()}
        text = json.dumps(data)
        self.project.writeEntry("monoplot", self._entry(), text)
        persistence.autosave_entry(self.project, self._entry(), text)  # a crash before Save keeps them too

    def _write_copies(self, *args) -> None:
        self.save_drawn(copies=True)

    def restore_drawn(self) -> int:
        """Bring back the features stored by :meth:`save_drawn` for this photo; returns how many."""
        text, ok = self.project.readEntry("monoplot", self._entry(), "")
        newer = persistence.autosaved_entry(self.project, self._entry())  # drawn after the last Save, then a crash
        #: True when the features came from the autosave (not in the saved project): the caller says so
        self.restored_from_autosave = newer is not None and newer != (text if ok else "")
        text = newer if newer is not None else (text if ok else "")
        if not text:
            return 0
        data = json.loads(text)
        for name, ftype in data.get("fields", []):
            if not any(n.lower() == name.lower() for n, _ in self.fields):
                self.fields.append((name, ftype))
        count = 0
        self._restoring = True
        try:
            for kind, features in data.get("features", {}).items():
                layer = self.photo_layer(kind)
                new = []
                for item in features:
                    f = QgsFeature(layer.fields())
                    f.setGeometry(photo_geometry(kind, item["uv"]))
                    for n, v in item.get("attributes", {}).items():
                        if layer.fields().indexFromName(n) >= 0 and v is not None:
                            f[n] = _qvalue(v, dict(self.fields).get(n))
                    new.append(f)
                layer.dataProvider().addFeatures(new)
                count += len(new)
        finally:
            self._restoring = False
        with derived_layers_only(self.project):  # features read back are not a change (the caller says otherwise)
            for kind, features in data.get("features", {}).items():
                if features:  # no empty "photo points (map)" layer for a kind nothing was drawn of
                    self.sync(kind)
        return count

    def all_photo_layers(self) -> List[QgsVectorLayer]:
        return [self.photo_layers[k] for k in KINDS if k in self.photo_layers]

    def close(self) -> None:
        """Stop following the layers (one of them is being deleted: project cleared or QGIS closing); a closed
        session never creates or touches layers again."""
        if self.closed:
            return
        self.closed = True  # the layers' signals may still fire while they go: sync() and save_drawn() no-op
        try:
            self.project.writeProject.disconnect(self._write_copies)
        except (TypeError, RuntimeError):
            pass
        self.photo_layers.clear()
        self.map_layers.clear()
        self.closedByLayers.emit()

    def update_camera(self, camera, dem, xyz: Optional[np.ndarray] = None,
                      pixel_rmse: Optional[float] = None, spread=None, fit_status: Optional[str] = None) -> None:
        """A new fit (or DEM): keep what was drawn on the photo, recompute every live map layer."""
        if self.closed:
            return
        same = (camera == self.camera and dem is self.dem and xyz is self.xyz and pixel_rmse == self.pixel_rmse
                and spread == self.spread)
        self.fit_status = fit_status
        self.camera, self.dem, self.xyz, self.pixel_rmse, self.spread = camera, dem, xyz, pixel_rmse, spread
        if not same:  # the same camera and DEM again (the dock says "camera changed" for an overlay too): the
            # features mapped stay valid; tracing each again froze a trial's QGIS 4.6 s over a 100 M-cell DEM
            self._mapped.clear()
        with derived_layers_only(self.project):  # the drawing is unchanged: a clean project stays clean
            for kind in list(self.map_layers):
                self.map_layers[kind].setCrs(_crs(dem.crs_wkt))
                self.sync(kind)

    # --- editing ----------------------------------------------------------------------------------------------
    def add_feature(self, kind: str, vertices_uv, attributes: Optional[dict] = None) -> int:
        """Add a feature drawn on the photo: (N, 2) pixel vertices (u, v). Returns its feature id."""
        layer = self.photo_layer(kind)
        feature = QgsFeature(layer.fields())
        feature.setGeometry(photo_geometry(kind, vertices_uv))
        for name, value in (attributes or {}).items():
            if layer.fields().indexFromName(name) >= 0:
                feature[name] = _qvalue(value, dict(self.fields).get(name))
        ok, added = layer.dataProvider().addFeatures([feature])
        if not ok:
            raise RuntimeError("the feature could not be added to the photo layer")
        layer.triggerRepaint()
        self.sync(kind)
        self._record(("add", kind, added[0].id()))
        return added[0].id()

    def move_vertex(self, kind: str, fid: int, index: int, u: float, v: float) -> None:
        layer = self.photo_layer(kind)
        geom = QgsGeometry(layer.getFeature(fid).geometry())
        if not self._history or self._history[-1][:4] != ("move", kind, fid, index):  # a drag: one entry
            old = geom.vertexAt(index)
            self._record(("move", kind, fid, index, pixel_of(old)))
        point = photo_point(u, v)
        geom.moveVertex(point.x(), point.y(), index)
        layer.dataProvider().changeGeometryValues({fid: geom})
        layer.triggerRepaint()
        self.sync(kind)

    def delete_feature(self, kind: str, fid: int) -> None:
        layer = self.photo_layer(kind)
        feature = layer.getFeature(fid)
        self._record(("delete", kind, QgsGeometry(feature.geometry()),
                      {f.name(): feature[f.name()] for f in layer.fields()}, fid))
        layer.dataProvider().deleteFeatures([fid])
        layer.triggerRepaint()
        self.sync(kind)

    def add_field(self, name: str, ftype: str) -> None:
        """A new user field, on every photo and map layer."""
        if ftype not in _QVARIANT:
            raise ValueError(f"field type must be one of {sorted(_QVARIANT)}")
        if any(n.lower() == name.lower() for n, _ in self.fields):
            raise ValueError(f"field {name!r} exists")
        self.fields.append((name, ftype))
        for layer in [*self.photo_layers.values(), *self.map_layers.values()]:
            layer.dataProvider().addAttributes([QgsField(name, _QVARIANT[ftype])])
            layer.updateFields()
        self.save_drawn()  # the field is part of what the project keeps, even before a feature uses it

    # --- photo -> map -----------------------------------------------------------------------------------------
    def map_features(self, kind: str) -> Tuple[List[MapFeature], List[int], int]:
        """The photo layer's features in map coordinates: (features, their photo fids, features dropped as sky)."""
        layer = self.photo_layer(kind)
        out, fids, dropped = [], [], 0
        self.last_dropped[kind] = []
        for feature in layer.getFeatures():
            vertices = photo_vertices(feature.geometry())
            if len(vertices) == 0:
                continue
            attrs = {n: _plain(feature[n]) for n, _ in self.fields}
            # Only features whose photo geometry changed are intersected again (editing one vertex of one
            # polygon must not redo every outline); attributes are cheap and always taken fresh.
            key = (kind, feature.id())
            wkb = bytes(feature.geometry().asWkb())
            cached = self._mapped.get(key)
            if cached is not None and cached[0] == wkb:
                mapped = cached[1]
            else:
                mapped = photo_to_map_feature(kind, vertices, self.xyz, camera=self.camera, dem=self.dem,
                                              pixel_rmse=self.pixel_rmse, area=self.area, spread=self.spread)
                self._mapped[key] = (wkb, mapped)
            if mapped is not None:
                mapped = replace(mapped, attributes=attrs)
            if mapped is None:
                dropped += 1
                self.last_dropped[kind].append((float(vertices[0][0]), float(vertices[0][1])))
                continue
            out.append(mapped)
            fids.append(feature.id())
        return out, fids, dropped

    def sync(self, kind: str) -> None:
        """Rebuild the live map layer of ``kind`` from the photo layer (called on every photo-layer change)."""
        if self.closed:
            return
        features, fids, dropped = self.map_features(kind)
        layer = self.map_layer(kind)
        provider = layer.dataProvider()
        provider.truncate()
        new = []
        for mapped, fid in zip(features, fids):
            f = QgsFeature(layer.fields())
            f.setGeometry(QgsGeometry(qgs_geometry(mapped)))
            for name, value in {**mapped.attributes, **mapped.measures()}.items():
                if layer.fields().indexFromName(name) >= 0 and value is not None:
                    f[name] = _qvalue(value, dict(self.fields).get(name))
            f[PHOTO_FID] = int(fid)
            for name, value in self._photo_values().items():
                f[name] = value
            new.append(f)
        ok, _ = provider.addFeatures(new)
        if not ok:  # never silently: a feature missing from the map layer is data the user would lose
            from qgis.core import Qgis, QgsMessageLog

            QgsMessageLog.logMessage(f"{layer.name()}: {provider.lastError()}", "Monoplot", Qgis.MessageLevel.Warning)
        layer.updateExtents()
        layer.triggerRepaint()
        sky = sum(m.sky_parts for m in features)
        self.last_report[kind] = (sky, dropped)
        self.last_silhouettes[kind] = sum(m.silhouettes for m in features)
        self.last_spans[kind] = [(fid, m.m_per_px, m.m_px_max) for m, fid in zip(features, fids)]
        self.mapLayerUpdated.emit(kind, sky, dropped)
        if not self._restoring:
            self.save_drawn()

    def export(self, kind: str, path, overwrite: bool = False, add_to_project: bool = True) -> Path:
        """Write the features of ``kind`` as a GeoPackage or Shapefile (by suffix) and add it to the group."""
        features, fids, dropped = self.map_features(kind)
        if not features:
            # a file of no features was said "written" (a flood trial's edge, drawn under a camera below the terrain)
            from ..outputs import OutputError

            raise OutputError(f"none of the {dropped} drawn {kind}s reaches the terrain under the fitted camera (over "
                              f"the sky, a DEM void, off the DEM, or the camera is wrong): there is nothing to map.")
        # which drawn feature each row is (a trial's file had 6 rows for 8 points drawn, and nothing to tell them
        # apart): its id in the photo layer, as the live map layer has it
        for feature, fid in zip(features, fids):
            feature.attributes = {**feature.attributes, PHOTO_FID: int(fid), **self._photo_values()}
        extra = [(PHOTO_FID, "integer"), *self._photo_fields()]
        written = write_vector_layer(path, features, self.dem.crs_wkt, fields=[*self.fields, *extra],
                                     kind=kind, overwrite=overwrite)
        if add_to_project:
            add_vector_file_layer(written, self.project, self.group)
        return written

    def _photo_fields(self) -> List[Tuple[str, str]]:
        """The photo's name and date and the camera's verdict, fields the map layers add, but not over a field of
        the person's own."""
        own = {n.lower() for n, _ in self.fields}
        return [(name, "string") for name in (PHOTO_NAME, PHOTO_TAKEN, FIT_STATUS) if name not in own]

    def _photo_values(self) -> dict:
        values = {PHOTO_NAME: self.photo_name, PHOTO_TAKEN: self.photo_taken, FIT_STATUS: self.fit_status}
        return {name: values[name] for name, _ in self._photo_fields() if values[name] is not None}


def drawn_entry_key(photo_name: str) -> str:
    """Project entry key (scope "monoplot") of the features drawn on a photo. Project entries are XML element
    names (ASCII letters, digits, _), so the photo's name is reduced to those plus a hash of the full name.

    >>> drawn_entry_key("Aletsch 1890.jpg").startswith("/outputs/drawn/p_Aletsch_1890_")
    True
    """
    stem = Path(photo_name).stem
    safe = re.sub(r"[^A-Za-z0-9_]", "_", stem)[:40]
    return f"{DRAWN_ROOT}/p_{safe}_{hashlib.sha1(stem.encode('utf-8')).hexdigest()[:10]}"


def _qvalue(value, ftype: Optional[str]):
    """A Python value as QGIS stores it: dates (date objects or ISO text) as QDate, the rest unchanged.

    Without this a memory layer refuses the whole feature ("could not convert value")."""
    from qgis.PyQt.QtCore import QDate

    if value is None:
        return None
    if ftype == "date" or hasattr(value, "isoformat"):
        if isinstance(value, QDate):
            return value
        if hasattr(value, "year"):
            return QDate(value.year, value.month, value.day)
        return QDate.fromString(str(value)[:10], Qt.DateFormat.ISODate)
    return value


def _jsonable(value):
    return value.isoformat() if hasattr(value, "isoformat") else value


def _plain(value):
    """QVariant/QDate -> plain Python for the writers."""
    if value is None or (hasattr(value, "isNull") and value.isNull()):
        return None
    if hasattr(value, "toPyDate"):
        return value.toPyDate()
    return value


def _style_drawn_layer(layer: QgsVectorLayer, kind: str) -> None:
    symbol = QgsSymbol.defaultSymbol(layer.geometryType())
    symbol.setColor(QColor(0, 200, 255))
    if kind == "polygon":
        symbol.setOpacity(0.6)
    elif kind == "line":
        symbol.symbolLayer(0).setWidth(0.8)
    layer.renderer().setSymbol(symbol)
