"""The undoable edits of a :class:`~.points.ProjectState` (each an :class:`Edit`: points and pairs before and
after) and the :class:`CommandStack` that applies, undoes and redoes them and tells its listeners. Pure Python."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable, Dict, Iterable, List, Optional, Sequence, Tuple

from .points import ACCEPTED, CHECK, MAP, PHOTO, STATUSES, SUGGESTED, Point, ProjectState

__all__ = ["Edit", "CommandStack", "add_points", "remove_points", "set_status", "move_point", "replace_suggestions",
           "replace_in_views", "link", "link_pairs", "unlink", "set_check"]


@dataclass
class Edit:
    """One undoable change: points before/after (None = absent) and optionally the pair list before/after."""

    text: str
    before: Dict[str, Optional[Point]] = field(default_factory=dict)
    after: Dict[str, Optional[Point]] = field(default_factory=dict)
    pairs_before: Optional[List[Tuple[str, str]]] = None
    pairs_after: Optional[List[Tuple[str, str]]] = None

    def is_empty(self) -> bool:
        return self.before == self.after and self.pairs_before == self.pairs_after

    @staticmethod
    def _apply(state: ProjectState, points: Dict[str, Optional[Point]], pairs) -> None:
        cached = state.__dict__.get("_counts")
        counts = cached[1] if cached is not None and cached[0] == state._counts_key() else None
        state._version += 1
        for pid, p in points.items():
            old = state.points.get(pid)
            if counts is not None and old is not None:  # the counts follow the edit: O(edited), not O(points)
                counts[old.space][old.status] -= 1
            if p is None:
                state.points.pop(pid, None)
            else:
                state.points[pid] = p
                if counts is not None:
                    counts[p.space][p.status] += 1
        if counts is not None:
            state.__dict__["_counts"] = (state._counts_key(), counts)
        if pairs is not None:
            state.pairs = list(pairs)

    def redo(self, state: ProjectState) -> None:
        self._apply(state, self.after, self.pairs_after)

    def undo(self, state: ProjectState) -> None:
        self._apply(state, self.before, self.pairs_before)


def _pairs_without(state: ProjectState, removed: Iterable[str]) -> Optional[List[Tuple[str, str]]]:
    removed = set(removed)
    kept = [pr for pr in state.pairs if pr[0] not in removed and pr[1] not in removed]
    return kept if len(kept) != len(state.pairs) else None


def add_points(state: ProjectState, points: Sequence[Point], text: str = "Add point") -> Edit:
    return Edit(text, before={p.id: None for p in points}, after={p.id: p for p in points})


def remove_points(state: ProjectState, ids: Iterable[str], text: str = "Delete point") -> Edit:
    ids = [i for i in ids if i in state.points]
    pairs_after = _pairs_without(state, ids)
    return Edit(text, before={i: state.points[i] for i in ids}, after={i: None for i in ids},
                pairs_before=list(state.pairs) if pairs_after is not None else None, pairs_after=pairs_after)


def set_status(state: ProjectState, ids: Iterable[str], status: str, text: Optional[str] = None) -> Edit:
    if status not in STATUSES:
        raise ValueError(f"unknown status {status!r}")
    ids = [i for i in ids if i in state.points and state.points[i].status != status]
    return Edit(text or f"Mark {len(ids)} point(s) {status}", before={i: state.points[i] for i in ids},
                after={i: replace(state.points[i], status=status) for i in ids})


def move_point(state: ProjectState, pid: str, x: float, y: float, z: Optional[float] = None,
               text: str = "Move point") -> Edit:
    old = state.points[pid]
    return Edit(text, before={pid: old}, after={pid: replace(old, x=float(x), y=float(y),
                                                              z=None if z is None else float(z))})


def replace_suggestions(state: ProjectState, space: str, points: Sequence[Point],
                        text: str = "Suggest points", machine_label: Optional[str] = None) -> Edit:
    """Drop the untouched (still ``suggested``, not manual) points of ``space`` and add ``points``.

    Accepted/rejected decisions and manual points survive a new suggestion run. ``machine_label``: also drop the
    points with this label that a machine accepted and nobody touched since (still accepted, not manual, in no
    pair): the automatic registration's matches of an earlier run, which a new run replaces rather than adds to.
    """
    return replace_in_views(state, {space: points}, text, machine_label)


def replace_in_views(state: ProjectState, points_by_space: Dict[str, Sequence[Point]], text: str = "Suggest points",
                     machine_label: Optional[str] = None) -> Edit:
    """:func:`replace_suggestions` in several views at once: one edit, so one Undo takes back a whole Suggest or
    automatic registration (it took two, the photo's and the DEM's, and the first left half of it in place).

    >>> s = ProjectState()
    >>> e = replace_in_views(s, {PHOTO: [Point("a", PHOTO, 1, 2)], MAP: [Point("b", MAP, 3, 4, 5)]}); e.redo(s)
    >>> sorted(s.points), e.text
    (['a', 'b'], 'Suggest points')
    """
    paired = {i for pair in state.pairs for i in pair}
    old: List[Point] = []
    for space in points_by_space:
        old += [p for p in state.in_space(space, (SUGGESTED,)) if not p.manual]
        if machine_label is not None:
            old += [p for p in state.in_space(space, (ACCEPTED,)) if p.label == machine_label and not p.manual
                    and p.id not in paired]
    before: Dict[str, Optional[Point]] = {p.id: p for p in old}
    after: Dict[str, Optional[Point]] = {p.id: None for p in old}
    for points in points_by_space.values():
        for p in points:
            before[p.id] = None
            after[p.id] = p
    pairs_after = _pairs_without(state, [p.id for p in old])
    return Edit(text, before=before, after=after,
                pairs_before=list(state.pairs) if pairs_after is not None else None, pairs_after=pairs_after)


def link(state: ProjectState, photo_id: str, map_id: str) -> Edit:
    """Pair a photo point with a map point (each point in at most one pair; both become accepted)."""
    if state.points[photo_id].space != PHOTO or state.points[map_id].space != MAP:
        raise ValueError("a pair links one photo point to one map point")
    pairs = [pr for pr in state.pairs if photo_id not in pr and map_id not in pr] + [(photo_id, map_id)]
    before = {i: state.points[i] for i in (photo_id, map_id)}
    after = {i: replace(state.points[i], status=ACCEPTED) for i in (photo_id, map_id)}
    return Edit("Link points", before, after, list(state.pairs), pairs)


def link_pairs(state: ProjectState, pairs: Iterable[Tuple[str, str]], text: str = "Link points") -> Edit:
    """Pair each (photo id, map id) of ``pairs`` whose two points are in no pair yet (nor twice in ``pairs``), as
    one edit; both ends become accepted. Points already paired, check points among them, keep their pairs.

    >>> s = ProjectState(points={i: Point(i, sp, 1, 2) for i, sp in (("a", PHOTO), ("b", MAP), ("c", PHOTO))})
    >>> stack = CommandStack(s); _ = stack.push(link_pairs(s, [("a", "b"), ("c", "b")]))
    >>> s.pairs, s.points["c"].status
    ([('a', 'b')], 'suggested')
    """
    taken = {i for pr in state.pairs for i in pr}
    new: List[Tuple[str, str]] = []
    for a, b in pairs:
        if a in taken or b in taken or state.points[a].space != PHOTO or state.points[b].space != MAP:
            continue
        taken.update((a, b))
        new.append((a, b))
    ids = [i for pr in new for i in pr]
    return Edit(text, before={i: state.points[i] for i in ids},
                after={i: replace(state.points[i], status=ACCEPTED) for i in ids},
                pairs_before=list(state.pairs), pairs_after=list(state.pairs) + new)


def set_check(state: ProjectState, pid: str, on: bool = True) -> Edit:
    """Make a paired point and its partner check points (``on``), or ordinary accepted points again.

    Raises:
        ValueError: ``pid`` has no partner (a check point is measured against its counterpart on the other view).

    >>> s = ProjectState(points={"a": Point("a", "photo", 1, 2), "b": Point("b", "map", 3, 4, 5)})
    >>> stack = CommandStack(s); _ = stack.push(link(s, "a", "b")); _ = stack.push(set_check(s, "b"))
    >>> s.points["a"].status, s.points["b"].status
    ('check', 'check')
    >>> _ = stack.push(set_check(s, "a", on=False)); s.points["b"].status
    'accepted'
    """
    partner = state.partner(pid)
    if partner is None:
        raise ValueError("a check point must be paired with its counterpart on the other view first")
    status = CHECK if on else ACCEPTED
    ids = [i for i in (pid, partner) if state.points[i].status != status]
    return Edit("Mark check point" if on else "Use point in the fit", before={i: state.points[i] for i in ids},
                after={i: replace(state.points[i], status=status) for i in ids})


def unlink(state: ProjectState, pid: str) -> Edit:
    """Remove the pair of ``pid``; check points of that pair become ordinary accepted points again."""
    pairs = [pr for pr in state.pairs if pid not in pr]
    ids = [i for pr in state.pairs if pid in pr for i in pr if state.points.get(i) and state.points[i].status == CHECK]
    return Edit("Unlink point", before={i: state.points[i] for i in ids},
                after={i: replace(state.points[i], status=ACCEPTED) for i in ids},
                pairs_before=list(state.pairs), pairs_after=pairs)


class CommandStack:
    """Undo/redo of :class:`Edit` objects on one :class:`ProjectState`; listeners are called after every change.

    Listeners receive the set of point ids that changed (empty set = "everything may have changed", e.g. after
    :meth:`reset`).
    """

    def __init__(self, state: ProjectState, limit: int = 500):
        self.state = state
        self.limit = limit
        self._done: List[Edit] = []
        self._undone: List[Edit] = []
        self._listeners: List[Callable[[set], None]] = []
        self._noop = False  # the last edit asked for changed nothing: the next undo undoes nothing

    def add_listener(self, fn: Callable[[set], None]) -> None:
        self._listeners.append(fn)

    def remove_listener(self, fn: Callable[[set], None]) -> None:
        if fn in self._listeners:
            self._listeners.remove(fn)

    def notify(self, changed: Optional[set] = None) -> None:
        for fn in list(self._listeners):
            fn(set() if changed is None else changed)

    def push(self, edit: Edit) -> bool:
        """Apply ``edit`` and record it; returns whether anything changed.

        A no-op edit (e.g. accepting an accepted point) gets no undo entry, and the next :meth:`undo` does nothing:
        undo after a click that changed nothing must not take back the edit before it.

        >>> s = ProjectState(points={"a": Point("a", "photo", 1, 2)}); st = CommandStack(s)
        >>> st.push(set_status(s, ["a"], ACCEPTED)), st.push(set_status(s, ["a"], ACCEPTED))
        (True, False)
        >>> st.undo(), s.points["a"].status, st.undo(), s.points["a"].status
        (False, 'accepted', True, 'suggested')
        """
        if edit.is_empty():
            self._noop = True
            return False
        self._noop = False
        edit.redo(self.state)
        self._done.append(edit)
        del self._done[:-self.limit]
        self._undone.clear()
        self.notify(set(edit.after) | set(edit.before))
        return True

    def can_undo(self) -> bool:
        return bool(self._done)

    def is_applied(self, edit: Edit) -> bool:
        """``edit`` (this very object) was pushed or redone and is not undone."""
        return any(e is edit for e in self._done)

    def knows(self, edit: Edit) -> bool:
        """``edit`` (this very object) is in the history, applied or undone (False after :meth:`reset`)."""
        return any(e is edit for e in self._done) or any(e is edit for e in self._undone)

    def can_redo(self) -> bool:
        return bool(self._undone)

    def undo_text(self) -> str:
        return self._done[-1].text if self._done else ""

    def redo_text(self) -> str:
        return self._undone[-1].text if self._undone else ""

    def undo(self) -> bool:
        """Take back the last edit; returns whether anything changed (False right after a no-op edit)."""
        if self._noop:
            self._noop = False
            return False
        if self._done:
            edit = self._done.pop()
            edit.undo(self.state)
            self._undone.append(edit)
            self.notify(set(edit.after) | set(edit.before))
            return True
        return False

    def redo(self) -> bool:
        """Apply again the last undone edit; returns whether there was one."""
        self._noop = False
        if self._undone:
            edit = self._undone.pop()
            edit.redo(self.state)
            self._done.append(edit)
            self.notify(set(edit.after) | set(edit.before))
            return True
        return False

    def reset(self, state: Optional[ProjectState] = None) -> None:
        """Forget the history; optionally replace the whole state (e.g. a project was opened)."""
        if state is not None:
            self.state.copy_from(state)
        self._done.clear()
        self._undone.clear()
        self._noop = False
        self.notify(set())
