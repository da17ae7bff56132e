"""Import and export in the dock: ground-control points (CSV, point layers) and cameras (JSON, KML), both ways.

The readers and writers are the workflow's (one of each, shared with Processing): :mod:`..workflow.points_csv`
and :mod:`..workflow.camera_files`. A map point imported with a height keeps it: the fit and the check points use
that surveyed Z, not the DEM's (``Point.z``; the DEM fills only a missing one).

The functions take the dock's :class:`~.controller.MonoplotController`; :class:`IoActions` puts them in two menus
of the dock (camera tab: "Camera files", points tab: "Import / export").
"""

from __future__ import annotations

import dataclasses
import math
import os
from typing import List, Optional, Tuple

import numpy as np
from qgis.core import (Qgis, QgsCoordinateReferenceSystem, QgsCoordinateTransform, QgsFeature, QgsField,
                       QgsGeometry, QgsPoint, QgsProject, QgsVectorLayer, QgsWkbTypes)
from qgis.PyQt.QtCore import QCoreApplication, Qt, QVariant
from qgis.PyQt.QtWidgets import QFileDialog, QMenu, QSizePolicy, QToolButton

from ..adapters.photo_space import photo_point, pixel_of
from ..state import ACCEPTED, CHECK, MAP, PHOTO, REJECTED, Edit, Point
from ..workflow.inputs import InputError, _transform, is_warning_note, photo_points_in_frame, points_to_dem_crs
from ..workflow.points_csv import read_points_csv, write_points_csv
from .camera_io import load_camera_file, save_camera_file
from .product_exports import writable_folder

__all__ = ["import_points_csv", "export_points_csv", "import_point_layers", "export_point_layers",
           "load_camera_file", "save_camera_file", "IoActions", "PHOTO_LAYER_NAME", "MAP_LAYER_NAME"]

INFO, WARNING, CRITICAL, SUCCESS = (Qgis.MessageLevel.Info, Qgis.MessageLevel.Warning,
                                    Qgis.MessageLevel.Critical, Qgis.MessageLevel.Success)
PHOTO_LAYER_NAME, MAP_LAYER_NAME = "Monoplot photo points", "Monoplot map points"
_FIELDS = (("id", QVariant.String), ("label", QVariant.String), ("status", QVariant.String),
           ("pair", QVariant.Int), ("z", QVariant.Double))


def tr(text: str) -> str:
    return QCoreApplication.translate("MonoplotIo", text)


# --- points ---------------------------------------------------------------------------------------------------
def _add_imported(controller, photo: List[Point], world: List[Point], pairs: List[Tuple[str, str]],
                  text: str, changed: Optional[List[Point]] = None) -> None:
    """One undoable edit: the new points and their pairs, and ``changed``: points already there, as the table
    now gives them."""
    state = controller.state
    new = photo + world
    changed = changed or []
    edit = Edit(text, before={**{p.id: None for p in new}, **{p.id: state.points[p.id] for p in changed}},
                after={p.id: p for p in new + changed},
                pairs_before=list(state.pairs) if pairs else None,
                pairs_after=list(state.pairs) + pairs if pairs else None)
    controller.stack.push(edit)


def _place(xyz) -> Tuple[float, float]:
    """A map point's place, to the millimetre (the key of :func:`_map_points_at`)."""
    return round(float(xyz[0]), 3), round(float(xyz[1]), 3)


def _map_points_at(state) -> dict:
    """{place: map point} of the state's map points (the first at each place)."""
    there: dict = {}
    for p in state.in_space(MAP):
        there.setdefault(_place((p.x, p.y)), p)
    return there


def _status(check: bool) -> str:
    return CHECK if check else ACCEPTED


def import_points_csv(controller, path: str, all_check: bool = False) -> int:
    """Add the points of a CSV table (:func:`~..workflow.points_csv.read_points_csv`): rows with u, v and X, Y, Z
    become pairs (check pairs where the check column says so, or all of them with ``all_check``: independent
    points that measure the camera and stay out of the fit), rows with only one side single accepted points.
    Map coordinates are taken in the DEM file's CRS (converted like Processing's). Returns the number of rows
    imported (0 and a message on failure)."""
    c = controller
    try:
        table = read_points_csv(path)
    except InputError as exc:
        c.message.emit(str(exc), CRITICAL)
        return 0
    uv, xyz, ids = table.get("uv"), table.get("xyz"), table["ids"]
    if (uv is not None and c.image is None) or (xyz is not None and c.dem is None):
        c.message.emit(tr("Load the photo and choose the DEM before importing points."), WARNING)
        return 0
    check = np.ones(len(ids), bool) if all_check else table.get("check", np.zeros(len(ids), bool))
    notes: List[str] = []
    if xyz is not None:
        project_crs = c.project.crs()  # a table in the project's CRS is recognised (and said) when it is not the DEM's
        xyz, notes = points_to_dem_crs(xyz, c.dem, name=os.path.basename(path),
                                       candidates=[project_crs.toWkt()] if project_crs.isValid() else [])
    if uv is not None and c.photo_size is not None:  # u and v the other way round: swapped, said first
        uv, swapped = photo_points_in_frame(uv, c.photo_size, name=os.path.basename(path))
        notes = swapped + notes
    photo, world, pairs = [], [], []
    n = len(ids)
    there = _map_points_at(c.state)
    partner_of = {m: p for p, m in c.state.pairs}
    again = reused = rows = 0
    heights: List[Point] = []
    told: List[str] = []
    for i in range(n):
        has_uv = uv is not None and bool(np.isfinite(uv[i]).all())
        has_xyz = xyz is not None and bool(np.isfinite(xyz[i, :2]).all())
        status = _status(bool(check[i]) and has_uv and has_xyz)  # a check point needs both sides
        if has_uv and _off_photo(c, uv[i]):
            # kept out of the fit (a trial's one typed u of 1720 on a 1500 px photo among 11 exact pairs made the fit
            # "poor", 302 px, its field of view 111°); Processing refuses such a table
            status = REJECTED
        label = str(ids[i])
        a = b = None
        # a map point already there (left by another photo's work, or this table imported before) is used again:
        # a trial's second photo's GCP import put 11 more map points on the first photo's 11 (22, then 33 ...)
        same = there.get(_place(xyz[i])) if has_xyz else None
        if same is not None and same.status == status:
            partner = c.state.points.get(partner_of.get(same.id, ""))
            if partner is None:
                b, reused = same, reused + 1
                del there[_place(xyz[i])]  # paired now: a later row at the same place gets a point of its own
            elif has_uv and abs(partner.x - uv[i, 0]) < 0.01 and abs(partner.y - uv[i, 1]) < 0.01:
                z = float(xyz[i, 2]) if math.isfinite(xyz[i, 2]) else None
                if z is not None and (same.z is None or abs(same.z - z) > 0.005):
                    # the same row with its height corrected: taken (a drone trial re-imported its table with one
                    # GCP's surveyed height fixed, and "left as it is" kept the wrong one without a word)
                    heights.append(dataclasses.replace(same, z=z))
                    told.append(f"{label} {same.z if same.z is not None else float('nan'):.2f} → {z:.2f} m")
                else:
                    again += 1  # the same row imported before: nothing new
                continue
        if has_uv:
            a = Point.new(PHOTO, uv[i, 0], uv[i, 1], status=status, manual=True, label=label)
            photo.append(a)
        if has_xyz and b is None:
            z = float(xyz[i, 2]) if math.isfinite(xyz[i, 2]) else None  # surveyed Z as entered, else the DEM's
            b = Point.new(MAP, xyz[i, 0], xyz[i, 1], z, status=status, manual=True, label=label)
            world.append(b)
        if a is not None and b is not None:
            pairs.append((a.id, b.id))
        rows += a is not None or b is not None
    if photo or world or pairs or heights:  # an undo entry only for a real change
        _add_imported(c, photo, world, pairs, tr("Import {0}").format(os.path.basename(path)), heights)
    n_check = sum(1 for a, _ in pairs if c.state.points[a].status == CHECK)
    text = tr("{0}: {1} photo and {2} map points, {3} pairs ({4} check pairs).").format(
        os.path.basename(path), len(photo), len(world), len(pairs), n_check) if photo or world or pairs else \
        tr("{0}: no new points.").format(os.path.basename(path))  # not "0 photo and 0 map points" (a re-check
    # trial read that as nothing done, before the heights it had changed)
    if reused:
        text += " " + tr("{0} map points were there already and are used again.").format(reused)
    if again:
        text += " " + tr("{0} rows were imported before and are left as they are.").format(again)
    if heights:
        text += " " + tr("Heights changed since the last import, taken (fit again): {0}.").format(
            ", ".join(told[:5]) + (", …" if len(told) > 5 else ""))
    outside = _outside_photo(c, photo)
    if outside:
        text += " " + tr("{0} photo points lie outside the photo ({1}): imported rejected, out of the fit (Show ▾ "
                         "Rejected lists them); is the table for this photo, or a number mistyped?").format(
            len(outside), ", ".join(outside[:5]) + (", …" if len(outside) > 5 else ""))
    if table.get("unused"):  # a photo or map column under a name the reader does not know
        text += " " + tr("Columns not read: {0} (photo pixels are u_px, v_px; map coordinates X, Y, Z).").format(
            ", ".join(table["unused"]))
    for note in notes:
        text += " " + note + ("" if note.endswith("?") else ".")
    off_dem = any(is_warning_note(note) for note in notes)
    c.message.emit(text, WARNING if outside or off_dem or table.get("unused") else INFO)
    return rows


def _outside_photo(c, photo: List[Point]) -> List[str]:
    """The labels of the photo points outside the photo (a trial's typed u of 3350 on a 3000 px photo was counted,
    not named)."""
    return [p.label or f"({p.x:.0f}, {p.y:.0f})" for p in photo if _off_photo(c, (p.x, p.y))]


def _off_photo(c, uv) -> bool:
    """Whether the pixel ``uv`` lies outside the photo (False when no photo is loaded)."""
    if c.photo_size is None:
        return False
    w, h = c.photo_size
    return not (0 <= uv[0] <= w and 0 <= uv[1] <= h)


def export_points_csv(controller, path: str) -> int:
    """Write the pairs (accepted and check pairs) as a CSV table ``id, u_px, v_px, X, Y, Z, check``; the height
    is the point's own (surveyed) Z, else the DEM's; X, Y in the DEM file's CRS. Returns the number of rows
    written."""
    c = controller
    pairs = c.state.valid_pairs() + c.state.check_pairs()
    if not pairs:
        c.message.emit(tr("No pairs to export: pair photo and map points first (Shift+click)."), WARNING)
        return 0
    uv = np.array([(a.x, a.y) for a, _ in pairs], dtype=float)
    xyz = np.array([(b.x, b.y, b.z if b.z is not None else _dem_z(c, b)) for _, b in pairs], dtype=float)
    ids = [a.label or b.label or a.id for a, b in pairs]
    if getattr(c.dem, "source_crs_wkt", ""):  # a DEM in degrees used in UTM: the table in the file's CRS, as it
        xyz = _transform(xyz, c.dem.crs_wkt, c.dem.source_crs_wkt)  # is read back (and as Processing reads it)
    try:
        write_points_csv(path, uv=uv, xyz=xyz, ids=ids, check=[a.status == CHECK for a, _ in pairs])
    except (OSError, ValueError) as exc:
        c.message.emit(tr("Cannot write {0}: {1}").format(path, exc), CRITICAL)
        return 0
    c.message.emit(tr("{0} pairs written to {1}.").format(len(pairs), path), INFO)
    return len(pairs)


def _dem_z(c, p: Point) -> float:
    return float(c.dem.sample(p.x, p.y, to_extent=True)) if c.dem is not None else float("nan")


def _layer_fields():
    return [QgsField(name, kind) for name, kind in _FIELDS]


def export_point_layers(controller, project: Optional[QgsProject] = None) -> Tuple[QgsVectorLayer, QgsVectorLayer]:
    """Two memory layers of every point with its id, label, status and pair number: photo points in photo space
    (x = u, y = -v, no CRS) and map points (PointZ in the DEM's CRS). Added to ``project`` when given."""
    c = controller
    pair_of = {}
    for k, (a, b) in enumerate(c.state.pairs, start=1):
        pair_of[a], pair_of[b] = k, k
    photo_layer = QgsVectorLayer("Point", PHOTO_LAYER_NAME, "memory")
    photo_layer.setCrs(QgsCoordinateReferenceSystem())
    map_layer = QgsVectorLayer("PointZ", MAP_LAYER_NAME, "memory")
    map_layer.setCrs(c.dem_crs)
    for layer, space in ((photo_layer, PHOTO), (map_layer, MAP)):
        provider = layer.dataProvider()
        provider.addAttributes(_layer_fields())
        layer.updateFields()
        features = []
        for p in c.state.in_space(space):
            f = QgsFeature(layer.fields())
            if space == PHOTO:
                f.setGeometry(QgsGeometry.fromPointXY(photo_point(p.x, p.y)))
            else:
                z = p.z if p.z is not None else _dem_z(c, p)
                f.setGeometry(QgsGeometry(QgsPoint(p.x, p.y, z if math.isfinite(z) else 0.0)))
            f.setAttributes([p.id, p.label, p.status, pair_of.get(p.id), p.z])
            features.append(f)
        provider.addFeatures(features)
        layer.updateExtents()
        layer.setCustomProperty("monoplot/points", space)
    if project is not None:
        project.addMapLayers([photo_layer, map_layer])
    c.message.emit(tr("{0} photo and {1} map points exported as layers.").format(
        photo_layer.featureCount(), map_layer.featureCount()), INFO)
    return photo_layer, map_layer


def _is_photo_layer(layer: QgsVectorLayer) -> bool:
    """Photo-space layers have no CRS (or are marked as such by :func:`export_point_layers`)."""
    marked = layer.customProperty("monoplot/points")
    return marked == PHOTO if marked in (PHOTO, MAP) else not layer.crs().isValid()


def import_point_layers(controller, layers, project: Optional[QgsProject] = None) -> int:
    """Add the points of point layers: a layer without CRS holds photo points (x = u, y = -v), one with a CRS map
    points (reprojected to the DEM's CRS; a geometry Z, else a ``z`` field, is the surveyed height). Fields used
    when present: ``status`` (accepted / check; anything else is accepted), ``label`` or ``name`` or ``id``, and
    ``pair``: photo and map points with the same pair number become a pair. Returns the number of points added."""
    c = controller
    project = project or QgsProject.instance()
    photo, world, by_pair = [], [], {}
    for layer in layers:
        if not isinstance(layer, QgsVectorLayer) or layer.geometryType() != QgsWkbTypes.GeometryType.PointGeometry:
            continue
        space = PHOTO if _is_photo_layer(layer) else MAP
        if (space == PHOTO and c.image is None) or (space == MAP and c.dem is None):
            c.message.emit(tr("Load the photo and choose the DEM before importing points."), WARNING)
            return 0
        names = layer.fields().names()
        transform = None
        if space == MAP and c.dem_crs.isValid() and layer.crs() != c.dem_crs:
            transform = QgsCoordinateTransform(layer.crs(), c.dem_crs, project)
        for f in layer.getFeatures():
            geom = f.geometry()
            if geom is None or geom.isEmpty():
                continue
            for vertex in geom.vertices():
                status = str(f["status"]) if "status" in names else ACCEPTED
                status = CHECK if status == CHECK else ACCEPTED
                label = next((str(f[n]) for n in ("label", "name", "id") if n in names and f[n] not in (None, "")),
                             "")
                if space == PHOTO:
                    u, v = pixel_of(vertex)
                    p = Point.new(PHOTO, u, v, status=status, manual=True, label=label)
                    photo.append(p)
                else:
                    z = vertex.z() if QgsWkbTypes.hasZ(geom.wkbType()) else None
                    if z is None and "z" in names and f["z"] not in (None, ""):
                        z = float(f["z"])
                    x, y = vertex.x(), vertex.y()
                    if transform is not None:
                        pt = transform.transform(x, y)
                        x, y = pt.x(), pt.y()
                    z = None if z is None or not math.isfinite(z) else float(z)
                    p = Point.new(MAP, x, y, z, status=status, manual=True, label=label)
                    world.append(p)
                pair = f["pair"] if "pair" in names else None
                if pair not in (None, "") and not (isinstance(pair, QVariant) and pair.isNull()):
                    by_pair.setdefault(str(pair), {})[space] = p
    pairs = [(d[PHOTO].id, d[MAP].id) for d in by_pair.values() if PHOTO in d and MAP in d]
    paired = {i for pr in pairs for i in pr}
    # a check point needs its partner: unpaired ones are ordinary accepted points
    photo, world = ([p if p.id in paired or p.status != CHECK else dataclasses.replace(p, status=ACCEPTED)
                     for p in points] for points in (photo, world))
    _add_imported(c, photo, world, pairs, tr("Import point layers"))
    c.message.emit(tr("{0} photo and {1} map points imported, {2} pairs.").format(len(photo), len(world),
                                                                                   len(pairs)), INFO)
    return len(photo) + len(world)


# --- the dock's menus -----------------------------------------------------------------------------------------
class IoActions:
    """"Camera files" (camera tab) and "Import / export" (points tab) menus of the dock."""

    CAMERA_FILTER = "Monoplot camera (*.json);;KML PhotoOverlay (*.kml)"
    OPEN_CAMERA_FILTER = "Camera (*.json *.kml);;Monoplot camera (*.json);;KML PhotoOverlay (*.kml)"

    def __init__(self, dock):
        self.dock = dock
        c = dock.controller
        self.camera_button = self._menu_button(tr("Camera files"), [
            (tr("Load rough camera (JSON or KML)…"), lambda: self._open_camera(False)),
            (tr("Load fitted camera (JSON or KML)…"), lambda: self._open_camera(True)),
            None,
            (tr("Save fitted camera…"), lambda: self._save_camera("fitted")),
            (tr("Save rough camera…"), lambda: self._save_camera("prior")),
        ])
        dock.cameraButtons.insertWidget(dock.cameraButtons.count() - 1, self.camera_button)
        self.points_button = self._menu_button(tr("Import / export"), [
            # the two differ at the start: a trial's script (a person skimming the menu too) took the first, whose
            # column list ended in "check", for the second
            (tr("Import GCP table as pairs (CSV: u, v, X, Y, Z; optional id, check)…"), self._import_csv),
            (tr("Import GCP table, every row a check point…"), lambda: self._import_csv(all_check=True)),
            (tr("Export pairs as GCP table (CSV)…"), self._export_csv),
            None,
            (tr("Import selected point layers"), self._import_layers),
            (tr("Export points as layers"), lambda: export_point_layers(c, dock.project)),
        ])
        self.points_button.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
        self._place_points_button(dock)

    def _place_points_button(self, dock) -> None:
        """Beside the Suggestions box (which spans two columns of the point buttons' grid in ui/dock.ui): no row
        of its own, the point table keeps its height; else in a row of its own above the counts."""
        grid, spin = dock.pointButtons, dock.suggestCountSpin
        index = grid.indexOf(spin)
        if index >= 0:
            row, column, rows, columns = grid.getItemPosition(index)
            if columns >= 2:
                grid.addWidget(spin, row, column, rows, columns - 1)
                grid.addWidget(self.points_button, row, column + columns - 1, rows, 1)
                return
        layout = dock.pointsTabLayout
        layout.insertWidget(layout.indexOf(dock.countsLabel), self.points_button)

    def _menu_button(self, text: str, entries) -> QToolButton:
        button = QToolButton(self.dock)
        button.setText(text)
        button.setPopupMode(QToolButton.ToolButtonPopupMode.InstantPopup)
        button.setToolButtonStyle(Qt.ToolButtonStyle.ToolButtonTextOnly)
        menu = QMenu(button)
        for entry in entries:
            if entry is None:
                menu.addSeparator()
            else:
                menu.addAction(entry[0]).triggered.connect(entry[1])
        button.setMenu(menu)
        return button

    def _folder(self) -> str:
        path = self.dock.controller.state.photo_path
        return os.path.dirname(path) if path else ""

    def _save_folder(self) -> str:
        """Where a save dialog opens: the photo's folder if one can write there, else the project's, else home."""
        return str(writable_folder([self._folder(), QgsProject.instance().absolutePath()]))

    def _open_camera(self, as_fitted: bool) -> None:
        path, _ = QFileDialog.getOpenFileName(self.dock, tr("Load camera"), self._folder(), self.OPEN_CAMERA_FILTER)
        if path:
            self.open_camera(path, as_fitted)

    def open_camera(self, path: str, as_fitted: bool = False) -> bool:
        """Load a camera file (KML or JSON) as the rough (or fitted) camera; the dock's Import button calls it."""
        # a KML camera without a field of view takes the one in the dock's box (it was refused: "KML has no
        # <leftFov> element", though the box was there)
        return load_camera_file(self.dock.controller, path, as_fitted, self.dock.fovSpin.value()) is not None

    def _save_camera(self, which: str) -> None:
        path, chosen = QFileDialog.getSaveFileName(self.dock, tr("Save camera"), self._save_folder(),
                                                   self.CAMERA_FILTER)
        if path:
            if not os.path.splitext(path)[1]:
                path += ".kml" if "kml" in chosen.lower() else ".json"
            save_camera_file(self.dock.controller, path, which)

    def _import_csv(self, all_check: bool = False) -> None:
        title = tr("Import check points (kept out of the fit)") if all_check else tr("Import ground-control points")
        path, _ = QFileDialog.getOpenFileName(self.dock, title, self._folder(), tr("CSV table (*.csv *.txt)"))
        if path:
            import_points_csv(self.dock.controller, path, all_check=all_check)

    def _export_csv(self) -> None:
        path, _ = QFileDialog.getSaveFileName(self.dock, tr("Export pairs"), self._save_folder(),
                                              tr("CSV table (*.csv)"))
        if path:
            export_points_csv(self.dock.controller, path if path.lower().endswith(".csv") else path + ".csv")

    def _import_layers(self) -> None:
        iface = self.dock.iface
        layers = iface.layerTreeView().selectedLayers() if iface is not None else []
        if not layers and iface is not None and iface.activeLayer() is not None:
            layers = [iface.activeLayer()]
        if not layers:
            self.dock.controller.message.emit(tr("Select one or two point layers in the Layers panel first (a photo "
                                                 "layer without CRS, a map layer)."), WARNING)
            return
        import_point_layers(self.dock.controller, layers, self.dock.project)

