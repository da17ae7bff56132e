"""Table of curated points (view, status, coordinates, residual, pair) for a sortable QTableView."""

from __future__ import annotations

from typing import Callable, Dict, List, Optional

from qgis.PyQt.QtCore import QAbstractTableModel, QModelIndex, QSortFilterProxyModel, Qt
from qgis.PyQt.QtGui import QBrush, QColor

from ..state import ACCEPTED, CHECK, PHOTO, REJECTED, ProjectState

__all__ = ["PointTableModel", "make_proxy", "ID_ROLE"]

ID_ROLE = Qt.ItemDataRole.UserRole + 1
#: "Name" third: a GCP table's ids were only in "Source" ("manual (GCP4)"), scrolled out of sight, while the
#: column "Id" showed internal keys such as p3-d248e2 (a time-lapse trial)
_COLUMNS = ("View", "Status", "Name", "X / u", "Y / v", "Z (m)", "Residual (px)", "Pair", "Source", "Id")
_STATUS_COLORS = {ACCEPTED: QColor(0, 150, 60), REJECTED: QColor(200, 40, 40), CHECK: QColor(140, 40, 220)}


class PointTableModel(QAbstractTableModel):
    """One row per point of a :class:`ProjectState` (or per id :attr:`ids` returns: the points on show); call
    :meth:`refresh` after the state changed."""

    def __init__(self, state: ProjectState, parent=None, ids: Optional[Callable[[], List[str]]] = None):
        super().__init__(parent)
        self.state = state
        self.ids = ids or (lambda: list(self.state.points))
        self._ids: List[str] = []
        self._rows: Dict[str, int] = {}
        self.residuals: Dict[str, float] = {}

    def refresh(self, residuals: Optional[Dict[str, float]] = None) -> None:
        """Follow the state. When the same points are still there (status changes, moves), the rows are updated in
        place so the view keeps its scroll position and selection; otherwise the model is reset."""
        if residuals is not None:
            self.residuals = dict(residuals)
        ids = self.ids()
        if ids == self._ids and ids:
            self.dataChanged.emit(self.index(0, 0), self.index(len(ids) - 1, len(_COLUMNS) - 1))
            return
        self.beginResetModel()
        self._ids = ids
        self._rows = {pid: i for i, pid in enumerate(ids)}
        self.endResetModel()

    def point_id(self, row: int) -> str:
        return self._ids[row]

    def row_of(self, pid: str) -> int:
        return self._rows.get(pid, -1)

    def rowCount(self, parent=QModelIndex()) -> int:  # noqa: N802 (Qt API)
        return 0 if parent.isValid() else len(self._ids)

    def columnCount(self, parent=QModelIndex()) -> int:  # noqa: N802
        return 0 if parent.isValid() else len(_COLUMNS)

    def headerData(self, section, orientation, role=Qt.ItemDataRole.DisplayRole):  # noqa: N802
        if role == Qt.ItemDataRole.DisplayRole and orientation == Qt.Orientation.Horizontal:
            return self.tr(_COLUMNS[section])
        return None

    def data(self, index: QModelIndex, role=Qt.ItemDataRole.DisplayRole):
        if not index.isValid():
            return None
        pid = self._ids[index.row()]
        p = self.state.points.get(pid)
        if p is None:
            return None
        col = index.column()
        if role == ID_ROLE:
            return pid
        if role == Qt.ItemDataRole.ForegroundRole and col == 1 and p.status in _STATUS_COLORS:
            return QBrush(_STATUS_COLORS[p.status])
        if role == Qt.ItemDataRole.TextAlignmentRole and col in (3, 4, 5, 6):
            return int(Qt.AlignmentFlag.AlignRight | Qt.AlignmentFlag.AlignVCenter)
        if role not in (Qt.ItemDataRole.DisplayRole, Qt.ItemDataRole.EditRole):
            return None
        sort = role == Qt.ItemDataRole.EditRole  # numbers for sorting, text for display
        digits = 1 if p.space == PHOTO else 0
        if col == 0:
            return self.tr("photo") if p.space == PHOTO else self.tr("map")
        if col == 1:
            return self.tr(p.status)
        if col == 2:
            return p.label
        if col == 3:
            return p.x if sort else f"{p.x:.{digits}f}"
        if col == 4:
            return p.y if sort else f"{p.y:.{digits}f}"
        if col == 5:
            return (p.z if p.z is not None else -1e9) if sort else ("" if p.z is None else f"{p.z:.0f}")
        if col == 6:
            r = self.residuals.get(pid)
            return (r if r is not None else -1.0) if sort else ("" if r is None else f"{r:.1f}")
        if col == 7:  # the partner by its name when it has one, else by its key (the "Id" column)
            partner = self.state.partner(pid)
            other = self.state.points.get(partner) if partner is not None else None
            return "" if partner is None else (other.label if other is not None and other.label else partner)
        if col == 8:
            return self.tr("manual") if p.manual else self.tr("detector")
        if col == 9:
            return pid
        return None


def make_proxy(model: PointTableModel, parent=None) -> QSortFilterProxyModel:
    """Sorting proxy that compares numbers as numbers (EditRole)."""
    proxy = QSortFilterProxyModel(parent)
    proxy.setSourceModel(model)
    proxy.setSortRole(Qt.ItemDataRole.EditRole)
    return proxy
