"""Point curation of a :class:`~monoplot_plugin.gui.controller.MonoplotController` (a mixin): hit testing,
selection, accept / reject / reset, manual points, moves, deletes and links, all as undoable edits; the few
suggestions on show (:class:`~monoplot_plugin.gui.shortlist.Shortlist`) and their bulk actions.

Every click and key costs O(shown points), not O(all suggestions): hit tests and stepping use the shortlist, and the
project entry is written debounced (with the autosave, and whenever the project itself is written). Its needs are
:class:`CurationHost`, checked by ``tests/gui/test_controller_interfaces.py``."""

from __future__ import annotations

import math
from typing import Callable, Dict, List, Optional, Protocol, Sequence, Tuple

from qgis.core import Qgis

from ..state import (ACCEPTED, CHECK, MAP, PHOTO, REJECTED, SUGGESTED, Point, add_points, link, link_pairs,
                     move_point, remove_points, set_check, set_status, unlink)
from .shortlist import Shortlist

__all__ = ["CurationMixin", "CurationHost"]


class CurationHost(Protocol):
    """What :class:`CurationMixin` uses of the controller."""

    state: object  # ProjectState
    stack: object  # CommandStack: every edit goes through it
    dem: object  # core Dem or None (heights of map points added or moved)
    current: Dict[str, str]  # selected point id per space
    message: object  # pyqtSignal(str, Qgis.MessageLevel)
    selectionChanged: object  # pyqtSignal(str, str)
    pointsChanged: object  # pyqtSignal(set)
    _changed: Callable[[], None]  # the project is modified: autosave soon (O(1))
    tr: Callable[[str], str]


class CurationMixin:
    """Clicks, keys and bulk actions on the points; needs a :class:`CurationHost`."""

    @property
    def shortlist(self) -> Shortlist:
        """The points each view shows (created on first use; follows every edit)."""
        sl = self.__dict__.get("_shortlist")
        if sl is None:
            sl = self.__dict__["_shortlist"] = Shortlist(self.state)
        return sl

    def visible(self, space: str) -> List[Point]:
        """Points of ``space`` on show (the few undecided suggestions, and the decided ones the filters show)."""
        return self.shortlist.visible(space)

    def visible_ids(self) -> List[str]:
        return [p.id for space in (PHOTO, MAP) for p in self.shortlist.visible(space)]

    def point_near(self, space: str, x: float, y: float, tolerance: float) -> Optional[str]:
        """Id of the *visible* point of ``space`` nearest to (x, y) within ``tolerance`` (same units), or None."""
        return self.shortlist.hit(space, x, y, tolerance)

    def select(self, space: str, pid: Optional[str]) -> None:
        self.current[space] = pid or ""
        self.selectionChanged.emit(space, pid or "")

    def step(self, space: str, step: int = 1, only_suggested: bool = False) -> Optional[str]:
        """Select the next/previous point of ``space`` (only the undecided ones if asked); returns its id."""
        pid = self.shortlist.step(space, self.current[space] or None, step, only_suggested)
        self.select(space, pid)
        return pid

    def set_status(self, ids: Sequence[str], status: str, text: Optional[str] = None) -> bool:
        """Returns whether anything changed (a no-op gets no undo entry)."""
        return self.stack.push(set_status(self.state, ids, status, text))

    def accept(self, pid: str) -> bool:
        return self.set_status([pid], ACCEPTED)

    def reject(self, pid: str) -> bool:
        return self.set_status([pid], REJECTED)

    # --- bulk actions on the shown suggestions ----------------------------------------------------------------
    def more_suggestions(self) -> int:
        """Show the next few undecided suggestions on each view; returns how many came."""
        before = set(self.shortlist.shown_undecided())
        n = self.shortlist.more()
        self.pointsChanged.emit(set(self.shortlist.shown_undecided()) - before)  # the newly shown
        return n

    def reject_rest(self) -> int:
        """Reject the undecided suggestions on show (one undo entry); the next few come. Returns how many."""
        ids = self.shortlist.shown_undecided()
        self.set_status(ids, REJECTED, self.tr("Reject {0} shown suggestions").format(len(ids)))
        return len(ids)

    def accept_likely(self) -> int:
        """Accept the undecided ends of every likely pair (mutual nearest under the current camera within the
        shortlist's threshold), one undo entry; returns how many pairs. Decided points keep their status: a trial's
        check point became an ordinary one this way, silently. With pairs of the person's own the fit is paired and
        would leave points without a partner out, so the likely pairs are linked instead."""
        pairs = self.shortlist.likely()
        if self.state.valid_pairs():  # ... with the accepted points the paired fit leaves out, when they agree
            pairs = pairs + self.shortlist.accepted_unpartnered()
            edit = link_pairs(self.state, [(a, b) for a, b, _ in pairs])
            n = len(edit.pairs_after) - len(edit.pairs_before)
            edit.text = self.tr("Link {0} likely pairs").format(n)
            self.stack.push(edit)
            return n
        pts = self.state.points
        ids = [i for a, b, _ in pairs for i in (a, b) if pts[i].status == SUGGESTED]
        self.set_status(ids, ACCEPTED, self.tr("Accept {0} likely pairs").format(len(pairs)))
        return len(pairs)

    def undo(self) -> str:
        """Take back the last point edit; returns a sentence saying which ("" when nothing changed). Point edits
        only: an Undo after drawing on the photo took back a GCP import, silently (desktop trial)."""
        text = self.stack.undo_text()
        return self.tr("Undone: {0} (Redo brings it back).").format(text) if self.stack.undo() else ""

    def redo(self) -> str:
        """Apply again the last undone point edit; returns a sentence saying which ("" when none)."""
        text = self.stack.redo_text()
        return self.tr("Redone: {0}.").format(text) if self.stack.redo() else ""

    def reject_outliers(self) -> int:
        """Reject the accepted photo points the current fit calls outliers (one undo entry); returns how many."""
        ids = self.shortlist.current_outliers()
        self.set_status(ids, REJECTED, self.tr("Reject {0} outliers").format(len(ids)))
        self.shortlist.set_outliers([])
        return len(ids)

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
        """Accept every *suggested* point of ``space`` on show within (xmin, ymin, xmax, ymax) (the hidden ones
        were never looked at); returns how many."""
        return self.accept_all_in_views({space: rect})

    def accept_all_in_views(self, rects: dict) -> int:
        """:meth:`accept_all_in` for several spaces (space -> rect) as one edit: one Undo takes it back (a trial:
        "Accept all in view" took two, one per view)."""
        pts = self.state.points
        ids = [i for space, (x0, y0, x1, y1) in rects.items() for i in self.shortlist.shown_undecided(space)
               if x0 <= pts[i].x <= x1 and y0 <= pts[i].y <= y1]
        if ids:
            self.stack.push(set_status(self.state, ids, ACCEPTED,
                                       self.tr("Accept {0} points in view").format(len(ids))))
        return len(ids)

    def reset_statuses(self, space: Optional[str] = None) -> None:
        """Every detector suggestion (of one space, or both) back to "suggested"."""
        ids = [p.id for p in self.state.points.values()
               if not p.manual and (space is None or p.space == space) and p.status != SUGGESTED]
        self.stack.push(set_status(self.state, ids, SUGGESTED, self.tr("Reset decisions")))

    def add_manual(self, space: str, x: float, y: float) -> str:
        z = None
        if space == MAP and self.dem is not None:
            zz = float(self.dem.sample(x, y, to_extent=True))
            z = zz if math.isfinite(zz) else None
        p = Point.new(space, x, y, z, status=ACCEPTED, manual=True)
        self.stack.push(add_points(self.state, [p], self.tr("Add point")))
        self.select(space, p.id)
        return p.id

    def move(self, pid: str, x: float, y: float) -> None:
        p = self.state.points[pid]
        z = None
        if p.space == MAP and self.dem is not None:
            zz = float(self.dem.sample(x, y, to_extent=True))
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
        self.shortlist.update(changed)
        self.pointsChanged.emit(changed)
        self._changed()  # O(1): the project marked modified, the autosave debounced (controller._changed)

