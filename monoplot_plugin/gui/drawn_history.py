"""Undo and redo of the drawing edits on the photo (an added feature, a moved vertex, a deleted feature).

A mixin of :class:`~.digitising.DigitisingSession`, which records each edit (:meth:`DrawnHistoryMixin._record`) in
``_history`` and keeps ``photo_layers`` and ``sync(kind)``. The point edits have their own undo (the Points tab's).
Entries: ("add", kind, fid), ("move", kind, fid, index, (u, v)) or ("delete", kind, geometry, attributes, fid).
"""

from __future__ import annotations

from typing import List, Optional

from qgis.core import QgsFeature, QgsGeometry, QgsVectorLayer

from ..adapters.photo_space import photo_point, pixel_of


class DrawnHistoryMixin:
    """:meth:`undo` and :meth:`redo` of a digitising session's drawing edits."""

    _history: List[tuple]
    _redo: List[tuple]

    def undo(self) -> str:
        """Take back the last drawing edit (an added feature, a moved vertex, a deleted feature); returns what was
        undone in words ("" when there is nothing). :meth:`redo` brings it back. The point edits have their own
        undo (the Points tab's)."""
        return self._step(self._history, self._redo, "undo")

    def redo(self) -> str:
        """Do again the drawing edit :meth:`undo` took back last; returns what in words ("" when there is none).
        A new edit empties the redo list, as in every editor."""
        return self._step(self._redo, self._history, "redo")

    def _record(self, entry: tuple) -> None:
        self._history.append(entry)
        self._redo.clear()

    def _step(self, source: List[tuple], target: List[tuple], direction: str) -> str:
        """Revert the last live entry of ``source`` and push its inverse onto ``target``; its words, or ""."""
        while source:
            entry = source.pop()
            layer = self.photo_layers.get(entry[1])
            inverse = self._revert(layer, entry) if layer is not None else None
            if inverse is None:
                continue  # its feature is gone already
            target.append(inverse)
            layer.triggerRepaint()
            self.sync(entry[1])
            return _edit_words(entry if direction == "undo" else inverse, entry[1])
        return ""

    def _revert(self, layer: QgsVectorLayer, entry: tuple) -> Optional[tuple]:
        """Apply the opposite of ``entry`` to ``layer``; returns the entry that reverts that, None if stale."""
        op, kind = entry[0], entry[1]
        if op == "add":
            feature = layer.getFeature(entry[2])
            if not feature.hasGeometry():
                return None
            inverse = ("delete", kind, QgsGeometry(feature.geometry()),
                       {f.name(): feature[f.name()] for f in layer.fields()}, entry[2])
            layer.dataProvider().deleteFeatures([entry[2]])
            return inverse
        if op == "move":
            feature = layer.getFeature(entry[2])
            if not feature.hasGeometry():
                return None
            geom = QgsGeometry(feature.geometry())
            inverse = ("move", kind, entry[2], entry[3], pixel_of(geom.vertexAt(entry[3])))
            point = photo_point(*entry[4])
            geom.moveVertex(point.x(), point.y(), entry[3])
            layer.dataProvider().changeGeometryValues({entry[2]: geom})
            return inverse
        feature = QgsFeature(layer.fields())
        feature.setGeometry(entry[2])
        for name, value in entry[3].items():
            feature[name] = value
        _, added = layer.dataProvider().addFeatures([feature])
        # back under a new id: the entries about it, both ways, follow
        old_fid, new_fid = entry[4], added[0].id()
        for stack in (self._history, self._redo):
            stack[:] = [e[:2] + (new_fid,) + e[3:] if e[0] != "delete" and e[1] == kind and e[2] == old_fid
                        else e[:4] + (new_fid,) if e[0] == "delete" and e[1] == kind and e[4] == old_fid
                        else e for e in stack]
        return ("add", kind, new_fid)


def _edit_words(entry: tuple, kind: str) -> str:
    """What an edit entry of :class:`DigitisingSession` did, in words, as undo and redo report it.

    >>> _edit_words(("add", "polygon", 3), "polygon"), _edit_words(("delete", "line", None, {}, 2), "line")
    ('the polygon drawn last', 'the deletion of a line')
    """
    return {"add": f"the {kind} drawn last", "move": f"the move of a {kind}'s vertex"}.get(
        entry[0], f"the deletion of a {kind}")
