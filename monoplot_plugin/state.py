"""Monoplot project state: photo, DEM, curated points, pairs, prior and fitted camera, with undo/redo.

Pure Python (no Qt, no qgis): the dock and its controller edit the state only through :class:`CommandStack`, so every
point edit can be undone, and listeners (the canvases, the table, the autosave) hear about every change.

Coordinates: photo points are pixels ``(u, v)`` (column, row; origin at the top-left corner, see
:mod:`monoplot_plugin.core.camera`); map points are ``(x, y)`` in the DEM's CRS (metres), ``z`` optional.

>>> state = ProjectState()
>>> stack = CommandStack(state)
>>> _ = stack.push(add_points(state, [Point.new("photo", 10.5, 20.5)], "Suggest"))
>>> pid = next(iter(state.points))
>>> _ = stack.push(set_status(state, [pid], ACCEPTED))
>>> state.points[pid].status
'accepted'
>>> _ = stack.undo(); state.points[pid].status
'suggested'
>>> ProjectState.from_json(state.to_json()) == state
True
"""

from __future__ import annotations

import base64
import itertools
import json
import math
import sys
import uuid
from array import array
from operator import attrgetter
from dataclasses import dataclass, field, replace
from typing import Callable, Dict, Iterable, List, Optional, Sequence, Tuple

__all__ = [
    "SUGGESTED", "ACCEPTED", "REJECTED", "CHECK", "STATUSES", "PHOTO", "MAP",
    "Point", "ProjectState", "Edit", "CommandStack",
    "add_points", "remove_points", "set_status", "move_point", "replace_suggestions", "replace_in_views", "link",
    "link_pairs", "unlink", "set_check",
    "points_table", "points_from_table",
]

SUGGESTED, ACCEPTED, REJECTED = "suggested", "accepted", "rejected"
#: A check point: one point of a photo-map pair kept out of the fit, to measure the fitted camera's real accuracy
#: (the fit's own RMSE only says how well the points it used agree).
CHECK = "check"
STATUSES = (SUGGESTED, ACCEPTED, REJECTED, CHECK)
PHOTO, MAP = "photo", "map"
#: format 2 stores the points as columns (their numbers as one base64 block: 20,000 points in ~0.05 s, not 0.4);
#: format 1 (a list of point objects) is still read
FORMAT, FORMATS = "monoplot-state/2", ("monoplot-state/1", "monoplot-state/2")
_TEXT_FIELDS = ("id", "space", "status", "label")
_NUMBER_FIELDS = ("x", "y", "z", "score")  # z: NaN for None

_counter = itertools.count(1)


@dataclass(frozen=True)
class Point:
    """One control point on the photo (pixels) or on the map (DEM CRS).

    Attributes:
        id: unique key (stable across save/load).
        space: ``"photo"`` or ``"map"``.
        x, y: ``u, v`` pixels for the photo; map X, Y (metres) for the map.
        z: ground height for map points when known (metres), else None.
        status: suggested / accepted / rejected / check (paired, held out of the fit to measure it).
        manual: True when the user placed it (False for detector suggestions).
        score: detector strength (larger = more distinctive), 0 for manual points.
        label: optional name (e.g. a summit).
    """

    id: str
    space: str
    x: float
    y: float
    z: Optional[float] = None
    status: str = SUGGESTED
    manual: bool = False
    score: float = 0.0
    label: str = ""

    @staticmethod
    def new(space: str, x: float, y: float, z: Optional[float] = None, status: str = SUGGESTED,
            manual: bool = False, score: float = 0.0, label: str = "") -> "Point":
        """A point with a fresh unique id (``"p1"``-like prefix + random suffix so merged states never clash)."""
        if space not in (PHOTO, MAP):
            raise ValueError(f"space must be 'photo' or 'map', got {space!r}")
        if status not in STATUSES:
            raise ValueError(f"unknown status {status!r}")
        pid = f"{space[0]}{next(_counter)}-{uuid.uuid4().hex[:6]}"
        return Point(pid, space, float(x), float(y), None if z is None else float(z), status, bool(manual),
                     float(score), label)


@dataclass
class ProjectState:
    """Everything Monoplot stores with a QGIS project (JSON-serialisable).

    Attributes:
        photo_path: absolute path of the photo file.
        dem_layer_id: id of the DEM raster layer in the QGIS project; dem_source: its file (fallback on reopen).
        points: id -> :class:`Point`, in insertion order.
        pairs: list of (photo point id, map point id) links; the fit uses them when present.
        prior: rough camera (``Camera.to_dict()``) or None; fitted: fitted camera dict or None.
        fit_info: summary of the last fit (rmse_px, sigma, n_points, message...).
        settings: small GUI settings worth restoring (overlay opacity...).
    """

    photo_path: str = ""
    dem_layer_id: str = ""
    dem_source: str = ""
    points: Dict[str, Point] = field(default_factory=dict)
    pairs: List[Tuple[str, str]] = field(default_factory=list)
    prior: Optional[dict] = None
    fitted: Optional[dict] = None
    fit_info: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)

    # --- queries ----------------------------------------------------------------------------------------------
    def in_space(self, space: str, statuses: Iterable[str] = STATUSES) -> List[Point]:
        """Points of one space (``"photo"``/``"map"``) whose status is in ``statuses``, in insertion order."""
        wanted = set(statuses)
        return [p for p in self.points.values() if p.space == space and p.status in wanted]

    def accepted_xy(self, space: str) -> List[Tuple[float, float]]:
        """(N, 2) list of accepted point coordinates of one space (suggested and rejected ones excluded)."""
        return [(p.x, p.y) for p in self.in_space(space, (ACCEPTED,))]

    #: bumped by every :class:`Edit` applied (the cache key of :meth:`counts`; not a field, not saved)
    _version = 0

    def counts(self) -> Dict[str, Dict[str, int]]:
        """{space: {status: count}}; cached until the next edit (the dock asks after every click).

        >>> s = ProjectState(); s.counts()["photo"]["accepted"]
        0
        >>> Edit("add", after={"a": Point("a", "photo", 1, 2, status=ACCEPTED)}).redo(s)
        >>> s.counts()["photo"]["accepted"]
        1
        """
        key = self._counts_key()
        cached = self.__dict__.get("_counts")
        if cached is None or cached[0] != key:
            out = {s: {st: 0 for st in STATUSES} for s in (PHOTO, MAP)}
            for p in self.points.values():
                out[p.space][p.status] += 1
            cached = self.__dict__["_counts"] = (key, out)
        return {s: dict(v) for s, v in cached[1].items()}

    def _counts_key(self):
        return id(self.points), len(self.points), self._version

    def pairs_with_status(self, status: str) -> List[Tuple[Point, Point]]:
        """Pairs whose two points exist and both have ``status``, as (photo point, map point)."""
        out = []
        for a, b in self.pairs:
            pa, pb = self.points.get(a), self.points.get(b)
            if pa and pb and pa.status == status and pb.status == status:
                out.append((pa, pb))
        return out

    def valid_pairs(self) -> List[Tuple[Point, Point]]:
        """Pairs whose two points are both accepted: the ones a paired fit uses."""
        return self.pairs_with_status(ACCEPTED)

    def check_pairs(self) -> List[Tuple[Point, Point]]:
        """Pairs whose two points are both check points: kept out of the fit, they measure it.

        >>> s = ProjectState(points={"a": Point("a", "photo", 1, 2, status=CHECK),
        ...                          "b": Point("b", "map", 3, 4, 5, status=CHECK)}, pairs=[("a", "b")])
        >>> [(a.id, b.id) for a, b in s.check_pairs()], s.valid_pairs()
        ([('a', 'b')], [])
        """
        return self.pairs_with_status(CHECK)

    def partner(self, pid: str) -> Optional[str]:
        """Id of the point linked to ``pid``, or None."""
        for a, b in self.pairs:
            if a == pid:
                return b
            if b == pid:
                return a
        return None

    def next_point(self, space: str, current: Optional[str], step: int = 1,
                   statuses: Iterable[str] = STATUSES) -> Optional[str]:
        """Id of the next (``step=1``) or previous (``-1``) point of ``space`` after ``current``, wrapping around.

        >>> s = ProjectState(); _ = [s.points.__setitem__(p.id, p) for p in (Point("a", "photo", 0, 0),
        ...     Point("b", "photo", 1, 1), Point("c", "map", 1, 1))]
        >>> s.next_point("photo", "b"), s.next_point("photo", None), s.next_point("photo", "a", -1)
        ('a', 'a', 'b')
        """
        ids = [p.id for p in self.in_space(space, statuses)]
        if not ids:
            return None
        if current not in ids:
            return ids[0] if step > 0 else ids[-1]
        return ids[(ids.index(current) + step) % len(ids)]

    def is_blank(self) -> bool:
        """Nothing worth keeping: no photo, DEM, point, camera or setting (a fresh dock's state).

        >>> ProjectState().is_blank(), ProjectState(photo_path="a.jpg").is_blank()
        (True, False)
        """
        return self.to_dict() == ProjectState().to_dict()

    # --- serialisation ----------------------------------------------------------------------------------------
    def _header(self) -> dict:
        return {"format": FORMAT, "photo_path": self.photo_path, "dem_layer_id": self.dem_layer_id,
                "dem_source": self.dem_source, "pairs": [list(p) for p in self.pairs], "prior": self.prior,
                "fitted": self.fitted, "fit_info": self.fit_info, "settings": self.settings}

    def to_dict(self) -> dict:
        return {**self._header(), "points": points_table(self.points.values())}

    @classmethod
    def from_dict(cls, d: dict) -> "ProjectState":
        if d.get("format", FORMAT) not in FORMATS:
            raise ValueError(f"unsupported Monoplot state format {d.get('format')!r}")
        raw = d.get("points", [])
        points = {}
        for p in (points_from_table(raw) if isinstance(raw, dict) else (Point(**pd) for pd in raw)):
            points[p.id] = p
        return cls(photo_path=d.get("photo_path", ""), dem_layer_id=d.get("dem_layer_id", ""),
                   dem_source=d.get("dem_source", ""), points=points,
                   pairs=[(str(a), str(b)) for a, b in d.get("pairs", [])], prior=d.get("prior"),
                   fitted=d.get("fitted"), fit_info=dict(d.get("fit_info") or {}),
                   settings=dict(d.get("settings") or {}))

    def to_json(self) -> str:
        return self.snapshot()()

    def snapshot(self, **header) -> Callable[[], str]:
        """``to_json`` of the state as it is now, as a function that another thread may call later: the small
        fields are encoded now (``header`` replaces some, e.g. a relative photo path), the points (immutable) are
        only referenced, and encoded when the function is called (O(points), off the main thread)."""
        head = json.dumps({**self._header(), **header}, separators=(",", ":"))  # compact: json's C encoder
        points = list(self.points.values())

        def text() -> str:
            return head[:-1] + ',"points":' + json.dumps(points_table(points), separators=(",", ":")) + "}"

        return text

    @classmethod
    def from_json(cls, text: str) -> "ProjectState":
        return cls.from_dict(json.loads(text))

    def copy_from(self, other: "ProjectState") -> None:
        """Replace every field by those of ``other`` (keeps this object's identity for listeners)."""
        for name in self.__dataclass_fields__:
            setattr(self, name, getattr(other, name))
        self._version += 1


def points_table(points: Iterable[Point]) -> dict:
    """The points as columns: ``id``, ``space``, ``status``, ``label`` lists, ``manual`` 0/1 list, and ``numbers``:
    base64 of little-endian float64 (x, y, z, score) per point (z NaN = None).

    >>> pts = [Point("a", PHOTO, 1.5, 2.0, score=0.5), Point("b", MAP, 3.0, 4.0, 1800.25, ACCEPTED, True)]
    >>> points_from_table(points_table(pts)) == pts
    True
    """
    pts = list(points)
    table = {f: list(map(attrgetter(f), pts)) for f in _TEXT_FIELDS}
    table["manual"] = [1 if p.manual else 0 for p in pts]
    numbers = array("d", [v for p in pts for v in (p.x, p.y, math.nan if p.z is None else p.z, p.score)])
    if sys.byteorder == "big":
        numbers.byteswap()
    table["numbers"] = base64.b64encode(numbers.tobytes()).decode("ascii")
    return table


def points_from_table(table: dict) -> List[Point]:
    """The points of :func:`points_table`."""
    numbers = array("d")
    numbers.frombytes(base64.b64decode(table.get("numbers", "")))
    if sys.byteorder == "big":
        numbers.byteswap()
    ids, spaces, statuses, labels = (table[f] for f in _TEXT_FIELDS)
    manual = table["manual"]
    if not (len(ids) == len(spaces) == len(statuses) == len(labels) == len(manual) == len(numbers) // 4):
        raise ValueError("inconsistent point table")
    return [Point(str(ids[i]), str(spaces[i]), numbers[4 * i], numbers[4 * i + 1],
                  None if math.isnan(numbers[4 * i + 2]) else numbers[4 * i + 2], str(statuses[i]), bool(manual[i]),
                  numbers[4 * i + 3], str(labels[i])) for i in range(len(ids))]


# --- edits (undoable) -----------------------------------------------------------------------------------------

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
