"""The products panel's dialogs for drawn features: save them (one file per geometry type, one message), add an
attribute field, open their attribute tables.

A mixin of :class:`~.product_panel.OutputTools`, which provides ``current_session()``, ``ready()``, ``_message``,
``_run``, ``export_features``, ``exports`` (file dialogs) and ``host``.
"""

from __future__ import annotations

from pathlib import Path

from qgis.core import Qgis
from qgis.PyQt.QtWidgets import QMessageBox

from ..outputs.safe_write import OutputError
from .digitising import KINDS


def per_kind_path(path, kind: str) -> Path:
    """The file of one geometry type beside ``path``: ``<stem>_<kind>s<suffix>``.

    >>> per_kind_path("/data/photo_features.gpkg", "polygon").name
    'photo_features_polygons.gpkg'
    """
    path = Path(path)
    return path.with_name(f"{path.stem}_{kind}s{path.suffix or '.gpkg'}")


class FeatureDialogsMixin:
    """Save, add a field to and open the tables of the features drawn on the photo."""

    def _ask_features(self) -> None:
        session = self.current_session()
        if session is None:
            self._message(self.ready() or "", Qgis.MessageLevel.Warning)
            return
        kinds = [k for k in KINDS if k in session.photo_layers and session.photo_layers[k].featureCount()]
        if not kinds:
            self._message(self.tr("Nothing drawn on the photo yet."), Qgis.MessageLevel.Warning)
            return
        # one dialog (a desktop trial: three dialogs in a row for points, lines and polygons): one file per
        # geometry type, named after the one chosen
        filters = "GeoPackage (*.gpkg);;ESRI Shapefile (*.shp)"
        if len(kinds) == 1:
            path = self.exports.ask(self.tr("Save the drawn {0}s").format(kinds[0]), filters, f"{kinds[0]}s.gpkg")
            paths = {kinds[0]: path} if path else {}
        else:
            names = ", ".join(self.tr("{0}s").format(k) for k in kinds)
            path = self.exports.ask(self.tr("Save the drawn features ({0}): one file per geometry type, named after "
                                            "this one").format(names), filters, "features.gpkg")
            paths = {k: per_kind_path(path, k) for k in kinds} if path else {}
            existing = [p for p in paths.values() if p.exists()]
            if existing and QMessageBox.question(
                    self.host.widget, self.tr("Replace files?"),
                    self.tr("Replace {0}?").format(", ".join(self._replaced(p) for p in existing)),
                    QMessageBox.StandardButton.Yes | QMessageBox.StandardButton.No,
                    QMessageBox.StandardButton.No) != QMessageBox.StandardButton.Yes:
                return
        if paths:
            self._export_each(paths)

    def _replaced(self, path: Path) -> str:
        """What writing ``path`` replaces: the file, or of a GeoPackage with other layers its layer of that name."""
        from ..outputs.vectors import other_layers

        if other_layers(path, path.stem):
            return self.tr("the layer {0} of {1} (its other layers are kept)").format(path.stem, path.name)
        return path.name

    def _export_each(self, paths: dict) -> None:
        """Write each geometry type to its file, and say it once (a save of three types gave three messages); a
        failure says which files were written before it."""
        reason = self.ready()
        if reason is not None:
            self._message(reason, Qgis.MessageLevel.Warning)
            return
        from ..outputs.vectors import other_layers

        written = []
        for kind, target in paths.items():
            kept = other_layers(target, Path(target).stem)  # a GeoPackage's other layers stay (only this one goes)
            try:
                path = str(self.export_features(kind, target, overwrite=True))
                written.append(path if not kept else self.tr("{0} (layer {1}; its other layers kept: {2})").format(
                    path, Path(target).stem, ", ".join(kept)))
            except (OutputError, ValueError) as exc:
                text = (self.tr("Nothing was written: {0}").format(exc) if not written else
                        self.tr("Written: {0}; not written: {1}").format(", ".join(written), exc))
                self._message(text, Qgis.MessageLevel.Warning)  # the person's to put right, not a failure
                return
        # and where to find them (a trial opened them again, not seeing them added to the photo's group)
        self._message(self.tr("Features written: {0}; added to the layer group {1}.").format(
            ", ".join(written), Path(self.photo_name()).stem), Qgis.MessageLevel.Success)

    def _ask_field(self) -> None:
        from qgis.PyQt.QtWidgets import QInputDialog

        session = self.current_session()
        if session is None:
            self._message(self.ready() or "", Qgis.MessageLevel.Warning)
            return
        name, ok = QInputDialog.getText(self.host.widget, self.tr("Add attribute field"),
                                        self.tr("Field name (10 characters at most for Shapefiles):"))
        if not ok or not name.strip():
            return
        ftype, ok = QInputDialog.getItem(self.host.widget, self.tr("Add attribute field"), self.tr("Type:"),
                                         ["string", "integer", "real", "date"], 0, False)
        if ok:
            self._run(lambda: session.add_field(name.strip(), ftype) or name.strip(),
                      self.tr("Field {0} added to the drawn layers."))

    def _open_attributes(self) -> None:
        """Open the attribute tables of the photo layers (edits there update the live map layers) and of the map
        layers, whose computed fields (area, length, their errors) a re-check trial could not find."""
        session = self.current_session()
        iface = self.host.iface
        if session is None or iface is None:
            self._message(self.ready() or "", Qgis.MessageLevel.Warning)
            return
        for layer in session.all_photo_layers():
            if layer.featureCount():
                layer.startEditing()
                iface.showAttributeTable(layer)
        measured = [layer for layer in session.map_layers.values() if layer.featureCount()]
        for layer in measured:
            iface.showAttributeTable(layer)
        if measured:
            self._message(self.tr("Edit names and your fields in the photo layers' tables; the \"(map)\" tables "
                                  "show what was measured on the ground (area on the map, area3d along the terrain, "
                                  "length, area_error, xy_error_m, z_error_m)."),
                          Qgis.MessageLevel.Info)
