"""The map layers of what was drawn on *other* photos, filled again when a project is reopened.

The live map layers of drawn features are memory layers: a reopened project brings them back empty, and only the
current photo's session rebuilds its own (through its camera). A repeat-photography trial drew a glacier front on
an 1890 print and on a modern photo: after reopening, the print's front was an empty layer on the map until the print
was chosen again, so the two fronts could not be compared. Each photo's drawn-features entry therefore also keeps a
copy of its map layers as they were (geometry as WKT, attribute values), and :func:`refill_map_layers` puts those
copies back into the layers of the same name that came back empty. The current photo's session rebuilds its own
layers from its camera when it starts (it empties them first), so a copy never stands in for a live layer.
"""

from __future__ import annotations

import json
from typing import Dict, Iterable

from qgis.core import QgsCoordinateReferenceSystem, QgsFeature, QgsGeometry, QgsProject, QgsVectorLayer
from qgis.PyQt.QtCore import QDate, Qt, QVariant

from ..adapters.layers import derived_layers_only
from ..adapters.photo_space import photo_geometry
from . import persistence

__all__ = ["map_copies", "refill_map_layers", "DRAWN_ROOT"]

#: project entries (scope "monoplot") of the features drawn on each photo: ``DRAWN_ROOT/p_<name>_<hash>``
DRAWN_ROOT = "/outputs/drawn"
#: metres: the copies' coordinates are written to the millimetre
_DECIMALS = 3


def map_copies(layers: Dict[str, QgsVectorLayer], jsonable) -> dict:
    """``{kind: {"layer": name, "features": [{"wkt", "attributes"}]}}`` of the live map layers ``layers`` (by kind);
    ``jsonable(value)`` turns a field value into JSON (dates as ISO text)."""
    copies = {}
    for kind, layer in layers.items():
        names = layer.fields().names()
        copies[kind] = {"layer": layer.name(), "features": [
            {"wkt": f.geometry().asWkt(_DECIMALS), "attributes": {n: jsonable(f[n]) for n in names}}
            for f in layer.getFeatures() if not f.geometry().isNull()]}
    return copies


def refill_map_layers(project: QgsProject, live: Iterable[str] = ()) -> int:
    """Fill each drawn map layer (and pixel-space layer) of ``project`` that came back empty from its photo's entry
    (the autosave's when it is newer than the project file); ``live``: ids of layers a session rebuilds itself, left
    alone. Returns how many map features were put back.

    Only memory layers of the stored name that hold nothing are filled: a layer the person has since edited or a
    file layer of that name is never touched."""
    live = set(live)
    count = 0
    with derived_layers_only(project):  # copies read back are not a change: a clean project stays clean
        for name in project.entryList("monoplot", DRAWN_ROOT):
            key = f"{DRAWN_ROOT}/{name}"
            text = persistence.autosaved_entry(project, key) or project.readEntry("monoplot", key, "")[0]
            try:
                data = json.loads(text) if text else {}
                copies, photo_layers, drawn = data.get("map", {}), data.get("photo_layers", {}), data["features"]
            except (ValueError, AttributeError, KeyError, TypeError):  # not ours, or a later version's
                continue
            for copy in copies.values():
                for layer in _empty_memory_layers(project, copy.get("layer"), live):
                    count += _fill(layer, copy.get("features", []), lambda item: QgsGeometry.fromWkt(
                        str(item.get("wkt", ""))))
            for kind, name in photo_layers.items():
                for layer in _empty_memory_layers(project, name, live):
                    # QGIS gave the pixel layer a CRS on reading it (EPSG:4326, a trial): it has none
                    layer.setCrs(QgsCoordinateReferenceSystem())
                    _fill(layer, drawn.get(kind, []), lambda item, k=kind: photo_geometry(k, item["uv"]))
    return count


def _empty_memory_layers(project: QgsProject, name, live: set):
    """The memory layers named ``name`` that hold nothing and that no session rebuilds."""
    for layer in project.mapLayersByName(str(name or "")):
        if isinstance(layer, QgsVectorLayer) and layer.providerType() == "memory" and layer.id() not in live \
                and layer.featureCount() == 0:
            yield layer


def _fill(layer: QgsVectorLayer, features: list, geometry) -> int:
    new = []
    for item in features:
        feature = QgsFeature(layer.fields())
        feature.setGeometry(geometry(item))
        for name, value in item.get("attributes", {}).items():
            index = layer.fields().indexFromName(name)
            if value is None or index < 0:
                continue
            if layer.fields().at(index).type() == QVariant.Type.Date:  # stored as ISO text: a memory layer
                value = QDate.fromString(str(value)[:10], Qt.DateFormat.ISODate)  # refuses the feature otherwise
            feature[name] = value
        new.append(feature)
    ok, _ = layer.dataProvider().addFeatures(new)
    layer.updateExtents()
    layer.triggerRepaint()
    return len(new) if ok else 0
