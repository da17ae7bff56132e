"""Point curation of a :class:`~monoplot_plugin.gui.controller.MonoplotController` (a mixin): hit testing,
selection, accept / reject / reset, manual points, moves, deletes and links, all as undoable edits."""

from __future__ import annotations

import math
from typing import Optional, Sequence, Tuple

from qgis.core import Qgis

from ..state import (ACCEPTED, CHECK, MAP, PHOTO, REJECTED, SUGGESTED, Point, add_points, link, move_point,
                     remove_points, set_check, set_status, unlink)

__all__ = ["CurationMixin"]


class CurationMixin:
    """Needs the controller's ``state``, ``stack``, ``dem``, ``current``, ``message`` and ``selectionChanged``."""

    def point_near(self, space: str, x: float, y: float, tolerance: float) -> Optional[str]:
        """Id of the point of ``space`` nearest to (x, y) within ``tolerance`` (same units), or None."""
        best, best_d = None, tolerance
        for p in self.state.in_space(space):
            d = math.hypot(p.x - x, p.y - y)
            if d <= best_d:
                best, best_d = p.id, d
        return best

    def select(self, space: str, pid: Optional[str]) -> None:
        self.current[space] = pid or ""
        self.selectionChanged.emit(space, pid or "")

    def step(self, space: str, step: int = 1, only_suggested: bool = False) -> Optional[str]:
        """Select the next/previous point of ``space`` (only the undecided ones if asked); returns its id."""
        statuses = (SUGGESTED,) if only_suggested else (SUGGESTED, ACCEPTED, REJECTED, CHECK)
        pid = self.state.next_point(space, self.current[space] or None, step, statuses)
        self.select(space, pid)
        return pid

    def set_status(self, ids: Sequence[str], status: str) -> None:
        self.stack.push(set_status(self.state, ids, status))

    def accept(self, pid: str) -> None:
        self.set_status([pid], ACCEPTED)

    def reject(self, pid: str) -> None:
        self.set_status([pid], REJECTED)

    def toggle_check(self, pid: str) -> bool:
        """Make a paired point (and its partner) a check point, kept out of the fit to measure it, or back;
        a point without a partner gets a message instead. Returns whether anything changed."""
        on = self.state.points[pid].status != CHECK
        try:
            edit = set_check(self.state, pid, on)
        except ValueError:
            self.message.emit(self.tr("A check point needs its counterpart: Shift+click to pair it with the "
                                      "selected point of the other view first."), Qgis.MessageLevel.Warning)
            return False
        self.stack.push(edit)
        return True

    def accept_all_in(self, space: str, rect: Tuple[float, float, float, float]) -> int:
        """Accept every *suggested* point of ``space`` within (xmin, ymin, xmax, ymax); returns how many."""
        x0, y0, x1, y1 = rect
        ids = [p.id for p in self.state.in_space(space, (SUGGESTED,)) if x0 <= p.x <= x1 and y0 <= p.y <= y1]
        self.stack.push(set_status(self.state, ids, ACCEPTED, self.tr("Accept {0} points in view").format(len(ids))))
        return len(ids)

    def reset_statuses(self, space: Optional[str] = None) -> None:
        """Every detector suggestion (of one space, or both) back to "suggested"."""
        ids = [p.id for p in self.state.points.values()
               if not p.manual and (space is None or p.space == space) and p.status != SUGGESTED]
        self.stack.push(set_status(self.state, ids, SUGGESTED, self.tr("Reset decisions")))

    def add_manual(self, space: str, x: float, y: float) -> str:
        z = None
        if space == MAP and self.dem is not None:
            zz = float(self.dem.sample(x, y))
            z = zz if math.isfinite(zz) else None
        p = Point.new(space, x, y, z, status=ACCEPTED, manual=True)
        self.stack.push(add_points(self.state, [p], self.tr("Add point")))
        self.select(space, p.id)
        return p.id

    def move(self, pid: str, x: float, y: float) -> None:
        p = self.state.points[pid]
        z = None
        if p.space == MAP and self.dem is not None:
            zz = float(self.dem.sample(x, y))
            z = zz if math.isfinite(zz) else None
        self.stack.push(move_point(self.state, pid, x, y, z))

    def delete(self, ids: Sequence[str]) -> None:
        self.stack.push(remove_points(self.state, ids))
        for space in (PHOTO, MAP):
            if self.current[space] in ids:
                self.select(space, None)

    def link(self, photo_id: str, map_id: str) -> None:
        self.stack.push(link(self.state, photo_id, map_id))

    def unlink(self, pid: str) -> None:
        self.stack.push(unlink(self.state, pid))

    def _on_points_changed(self, changed: set) -> None:
        self.pointsChanged.emit(changed)
        self._changed()

