"""The project's points and its state (photo, DEM, curated points, pairs, cameras) and how it is saved; the
undoable edits of it are :mod:`.edits`. Pure Python."""

from __future__ import annotations

import base64
import itertools
import json
import math
import sys
import uuid
from array import array
from operator import attrgetter
from dataclasses import dataclass, field
from typing import Callable, Dict, Iterable, List, Optional, Tuple

__all__ = [
    "SUGGESTED", "ACCEPTED", "REJECTED", "CHECK", "STATUSES", "PHOTO", "MAP",
    "Point", "ProjectState", "points_table", "points_from_table",
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
        >>> from monoplot_plugin.state.edits import Edit
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
