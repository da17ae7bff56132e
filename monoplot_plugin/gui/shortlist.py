"""Which points each view shows: a few undecided suggestions at a time, ranked by :mod:`..core.recommend`.

Pure Python over the :class:`~monoplot_plugin.state.ProjectState` (no Qt): the views, the table and the hit tests
read :meth:`Shortlist.visible` / :meth:`Shortlist.hit`, which cost O(shown), not O(all suggestions).

* Each view shows the best ``per_page`` undecided suggestions (spread over the view, :func:`spread_order`);
  when all of them are decided the next ``per_page`` come; :meth:`more` adds ``per_page`` more.
* Filters: undecided / accepted (with check points) / rejected (hidden by default).
* With a camera (:meth:`set_camera`: the prior, a fit or the background refit) suggestions are re-ranked by
  agreement: a photo suggestion with a DEM suggestion projecting near it comes first, and the other way round.
  The page on show stays as it is (nothing vanishes under the cursor); the next pages follow the new ranking.
  Suggestions that come after the camera (a Suggest run once the rough camera is set) are ranked by it at once.

>>> from monoplot_plugin.state import CommandStack, Point, add_points, set_status
>>> s = ProjectState(); st = CommandStack(s); sl = Shortlist(s, per_page=2); st.add_listener(sl.update)
>>> _ = st.push(add_points(s, [Point(f"p{i}", PHOTO, i * 10.0, 0, score=i) for i in range(5)]))
>>> [p.id for p in sl.visible(PHOTO)]
['p4', 'p1']
>>> _ = st.push(set_status(s, ["p4", "p1"], REJECTED)); [p.id for p in sl.visible(PHOTO)]
['p3', 'p0']
>>> sl.set_filter(REJECTED, True); sorted(p.id for p in sl.visible(PHOTO))
['p0', 'p1', 'p3', 'p4']
"""

from __future__ import annotations

from typing import Dict, List, Optional, Set, Tuple

import numpy as np

from ..core.recommend import agreement, clutter, likely_pairs, priority, spread_order
from ..state import ACCEPTED, CHECK, MAP, PHOTO, REJECTED, SUGGESTED, Point, ProjectState

__all__ = ["Shortlist", "Recommendation", "recommendation", "DEFAULT_PER_PAGE"]

DEFAULT_PER_PAGE = 30
SPACES = (PHOTO, MAP)


class Shortlist:
    """The shown subset of each space's points, kept up to date incrementally from the stack's change sets."""

    def __init__(self, state: ProjectState, per_page: int = DEFAULT_PER_PAGE):
        self.state = state
        self.per_page = per_page
        self.filters = {SUGGESTED: True, ACCEPTED: True, REJECTED: False}
        self.shown: Dict[str, Dict[str, None]] = {s: {} for s in SPACES}  # undecided on show (ordered)
        self.decided: Dict[str, Dict[str, str]] = {s: {} for s in SPACES}  # id -> status of the others
        self._ranking: Dict[str, List[str]] = {s: [] for s in SPACES}
        self._ranked: Dict[str, Set[str]] = {s: set() for s in SPACES}
        self._cursor = {s: 0 for s in SPACES}
        self._cache: Dict[str, Optional[Tuple[List[Point], np.ndarray]]] = {s: None for s in SPACES}
        self.camera = None
        self.sigma = 25.0
        self.distance: Dict[str, float] = {}  # id -> px to the nearest partner under the camera
        self.clutter: Dict[str, float] = {}  # space -> the other view's points per px^2 under the camera
        self.partner: Dict[str, str] = {}  # id -> nearest partner's id (other space)
        self.outliers: Set[str] = set()  # accepted photo ids the current fit calls outliers
        self.threshold = 8.0  # px: how close a likely pair's two ends are under the camera
        self._pairs: List[Tuple[str, str, float, Tuple[float, float]]] = []
        self._pairs_of: Dict[str, List[int]] = {}  # point id -> indices in _pairs of the pairs it is an end of
        self._live: Set[int] = set()  # indices in _pairs of the likely ones (kept up to date by each edit)
        self._likely: Optional[List[Tuple[str, str, float]]] = None  # cache of likely(), per camera and edits
        self._new_page = {s: False for s in SPACES}  # the page on show came with a new run, nothing decided on it
        # the page that came when the one on show was all decided ("Reject the rest"): (its ids, cursor before),
        # taken back when an undo returns the page it replaced (a trial's undo left both on show, 85 points)
        self._refilled: Dict[str, Optional[Tuple[List[str], int]]] = {s: None for s in SPACES}
        self.rebuild()

    # --- following the state ----------------------------------------------------------------------------------
    def rebuild(self) -> None:
        """Everything from the state (a project was opened, or the change set is unknown)."""
        for space in SPACES:
            self.decided[space] = {}
        for p in self.state.points.values():
            if p.status != SUGGESTED:
                self.decided[p.space][p.id] = p.status
        for space in SPACES:
            self._rerank(space, keep=0)
        paired = self._paired_ids()
        self._live = {k for k in range(len(self._pairs)) if self._is_live(k, paired)}
        self._likely = None

    def update(self, changed: set) -> None:
        """Follow an edit: ``changed`` ids (empty: anything may have changed). O(len(changed))."""
        if not changed:
            self.rebuild()
            return
        pts = self.state.points
        paired = self._paired_ids()
        for pid in changed:  # the likely pairs with a changed end, only: O(len(changed)), not O(pairs)
            for k in self._pairs_of.get(pid, ()):
                if self._is_live(k, paired) != (k in self._live):
                    self._live ^= {k}
                    self._likely = None
        fresh = {s: False for s in SPACES}
        touched = set()
        returned = set()
        for pid in changed:
            p = pts.get(pid)
            for space in SPACES:
                if p is None or p.space != space:
                    self.shown[space].pop(pid, None)
                    self.decided[space].pop(pid, None)
            if p is None:
                touched.update(SPACES)
                continue
            touched.add(p.space)
            if p.status == SUGGESTED:
                # back from a decision (undo, U key); not a suggestion run brought back by Redo, though its ids
                # are still ranked (a trial: Redo of Suggest put all 2,000 on show, and "Reject the rest" took them)
                back = self.decided[p.space].pop(pid, None) is not None
                if (back and pid in self._ranked[p.space]) or p.manual:
                    self.shown[p.space][pid] = None
                    returned.add(p.space)
                else:
                    fresh[p.space] = True  # a new suggestion run
            else:
                self.shown[p.space].pop(pid, None)
                self.decided[p.space][pid] = p.status
        if any(fresh.values()) and self.camera is not None:
            # new suggestions: how they agree with the camera on show (it was set before they came), and the
            # pairs they make; the other view's points have new partners too
            self._recommend(self.camera, self.sigma)
        for space in returned - {s for s in SPACES if fresh[s]}:
            self._take_back_refill(space)
        for space in SPACES:
            if fresh[space]:
                self._rerank(space, keep=0)
                self._new_page[space] = True
            elif any(fresh.values()) and self.camera is not None:
                # a page nothing was decided on yet (the photo's, when the DEM's suggestions of the same run
                # come) is ranked again; else the page on show stays and the next pages follow
                self._rerank(space, keep=0, stable=not self._new_page[space])
            elif space in touched:
                self._new_page[space] = False
                self._refill(space)
                self._cache[space] = None

    def _undecided(self, space: str) -> List[Point]:
        return [p for p in self.state.points.values() if p.space == space and p.status == SUGGESTED]

    def _rerank(self, space: str, keep: int, stable: bool = False) -> None:
        """New ranking of the undecided suggestions of ``space``; show the best max(``keep``, per_page), or, when
        ``stable``, keep the ones on show (the next pages follow the new ranking)."""
        cands = self._undecided(space)
        if cands:
            xy = np.array([(p.x, p.y) for p in cands], dtype=np.float64)
            score = np.array([p.score for p in cands], dtype=np.float64)
            dist = None
            if self.camera is not None:
                dist = np.array([self.distance.get(p.id, np.inf) for p in cands], dtype=np.float64)
            order = spread_order(xy, priority(score, dist, self.sigma, self.clutter.get(space, 0.0)),
                                 self.per_page)
            self._ranking[space] = [cands[i].id for i in order]
        else:
            self._ranking[space] = []
        self._ranked[space] = set(self._ranking[space])
        self._cursor[space] = 0
        self._refilled[space] = None
        if stable and self.shown[space]:
            self.shown[space] = {i: None for i in self.shown[space] if i in self._ranked[space]}
        else:
            self.shown[space] = {}
            self._take(space, max(keep, self.per_page))
        self._cache[space] = None

    def _take(self, space: str, n: int) -> int:
        """Show the next ``n`` undecided suggestions of the ranking; returns how many were added."""
        pts, ranking, shown = self.state.points, self._ranking[space], self.shown[space]
        added = 0
        while added < n and self._cursor[space] < len(ranking):
            pid = ranking[self._cursor[space]]
            self._cursor[space] += 1
            p = pts.get(pid)
            if p is not None and p.status == SUGGESTED and pid not in shown:
                shown[pid] = None
                added += 1
        return added

    def _refill(self, space: str) -> None:
        if not self.shown[space]:
            cursor = self._cursor[space]
            self._take(space, self.per_page)
            self._refilled[space] = (list(self.shown[space]), cursor)

    def _take_back_refill(self, space: str) -> None:
        """Suggestions came back on show (an undo): if the page that replaced them is still untouched, hide it
        again and rewind, so that the page before the decision is what is on show, as before it."""
        refilled, self._refilled[space] = self._refilled[space], None
        if refilled is None:
            return
        ids, cursor = refilled
        shown = self.shown[space]
        if len(shown) <= len(ids) or not all(i in shown for i in ids):
            return  # something on the refilled page was decided since: it stays, with what came back
        for pid in ids:
            shown.pop(pid, None)
        self._cursor[space] = min(self._cursor[space], cursor)

    # --- actions ----------------------------------------------------------------------------------------------
    def more(self, space: Optional[str] = None) -> int:
        """Show ``per_page`` more undecided suggestions (of one space, or both); returns how many."""
        n = 0
        for s in (SPACES if space is None else (space,)):
            n += self._take(s, self.per_page)
            self._refilled[s] = None
            self._cache[s] = None
            self._new_page[s] = False
        return n

    def shown_undecided(self, space: Optional[str] = None) -> List[str]:
        """Ids of the undecided suggestions on show (the ones "Reject the rest" rejects)."""
        return [pid for s in (SPACES if space is None else (space,)) for pid in self.shown[s]]

    def remaining(self, space: str) -> int:
        """Undecided suggestions of ``space`` not on show."""
        return max(0, self.state.counts()[space][SUGGESTED] - len(self.shown[space]))

    def set_filter(self, status: str, on: bool) -> None:
        self.filters[status] = bool(on)
        self._cache = {s: None for s in SPACES}

    # --- what is drawn and clicked ----------------------------------------------------------------------------
    def visible(self, space: str) -> List[Point]:
        """Points of ``space`` the filters show: the undecided on show, then the decided ones."""
        return self._arrays(space)[0]

    def _arrays(self, space: str) -> Tuple[List[Point], np.ndarray]:
        cached = self._cache[space]
        if cached is None:
            pts, f = self.state.points, self.filters
            out = [pts[i] for i in self.shown[space]] if f[SUGGESTED] else []
            for pid, status in self.decided[space].items():
                if f[REJECTED if status == REJECTED else ACCEPTED] and pid in pts:
                    out.append(pts[pid])
            xy = np.array([(p.x, p.y) for p in out], dtype=np.float64).reshape(-1, 2)
            cached = self._cache[space] = (out, xy)
        return cached

    def hit(self, space: str, x: float, y: float, tolerance: float) -> Optional[str]:
        """Id of the visible point of ``space`` nearest to (x, y) within ``tolerance`` (space units), or None."""
        out, xy = self._arrays(space)
        if not len(out):
            return None
        d = np.hypot(xy[:, 0] - x, xy[:, 1] - y)
        i = int(np.argmin(d))
        return out[i].id if d[i] <= tolerance else None

    def step(self, space: str, current: Optional[str], step: int = 1, only_undecided: bool = True) -> Optional[str]:
        """The next / previous visible point after ``current`` (only the undecided on show if asked), wrapping."""
        ids = list(self.shown[space]) if only_undecided else [p.id for p in self.visible(space)]
        if not ids:
            return None
        if current not in ids:
            return ids[0] if step > 0 else ids[-1]
        return ids[(ids.index(current) + step) % len(ids)]

    # --- the camera's view of the suggestions -----------------------------------------------------------------
    def snapshot(self):
        """(photo ids, (N, 2) uv, map ids, (M, 3) xyz) of the undecided and accepted suggestions: what
        :func:`recommendation` needs, copied on the main thread so that a task can compute it."""
        keep = (SUGGESTED, ACCEPTED, CHECK)
        photo = [p for p in self.state.points.values() if p.space == PHOTO and p.status in keep]
        world = [p for p in self.state.points.values() if p.space == MAP and p.status in keep and p.z is not None]
        uv = np.array([(p.x, p.y) for p in photo], dtype=np.float64).reshape(-1, 2)
        xyz = np.array([(p.x, p.y, p.z) for p in world], dtype=np.float64).reshape(-1, 3)
        return [p.id for p in photo], uv, [p.id for p in world], xyz

    def set_camera(self, camera, sigma: float = 25.0, rec: Optional["Recommendation"] = None) -> None:
        """Re-rank both views by agreement with ``camera`` (None: by strength only); ``sigma`` (px): how far a
        partner may be under this camera (its uncertainty). ``rec``: :func:`recommendation` already computed
        (in a task) for this camera, sigma and :attr:`threshold`."""
        self._recommend(camera, sigma, rec)
        for space in SPACES:
            # the page on show stays (a suggestion must not vanish under the cursor); the next pages follow
            self._rerank(space, keep=len(self.shown[space]), stable=True)

    def _recommend(self, camera, sigma: float, rec: Optional["Recommendation"] = None) -> None:
        """Agreement, partners and pairs of the suggestions now in the state with ``camera`` (``rec``: already
        computed for it)."""
        self.camera, self.sigma = camera, float(sigma)
        if camera is None:
            rec = Recommendation()
        elif rec is None:
            rec = recommendation(camera, *self.snapshot(), self.sigma, self.threshold)
        self.distance, self.partner, self.clutter = rec.distance, rec.partner, rec.clutter
        self._set_pairs(rec.pairs)

    def set_threshold(self, px: float) -> None:
        self.threshold = float(px)
        self._pairs_from_camera()

    def _pairs_from_camera(self) -> None:
        if self.camera is not None:
            self._set_pairs(recommendation(self.camera, *self.snapshot(), self.sigma, self.threshold).pairs)

    def _set_pairs(self, pairs) -> None:
        self._pairs = list(pairs)
        self._pairs_of = {}
        for k, (a, b, _, _) in enumerate(self._pairs):
            self._pairs_of.setdefault(a, []).append(k)
            self._pairs_of.setdefault(b, []).append(k)
        paired = self._paired_ids()
        self._live = {k for k in range(len(self._pairs)) if self._is_live(k, paired)}
        self._likely = None

    def likely(self) -> List[Tuple[str, str, float]]:
        """(photo id, map id, px) of mutual nearest photo / projected DEM suggestions within :attr:`threshold` px
        under the current camera (and nearer than a chance partner would be for its :attr:`sigma`: none under a
        rough camera over dense suggestions, :func:`~..core.recommend.likely_pairs`), neither rejected and at least
        one end undecided; closest first."""
        if self._likely is None:
            self._likely = [(a, b, d) for k, (a, b, d, _) in enumerate(self._pairs) if k in self._live]
        return self._likely

    def accepted_unpartnered(self) -> List[Tuple[str, str, float]]:
        """(photo id, map id, px) of the current camera's likely pairs whose two ends are both accepted and in no
        pair: points a paired fit leaves out (a trial's curation of 18 DEM points "counted for nothing" once it
        paired 7), which Accept likely links. O(pairs)."""
        pts, paired = self.state.points, self._paired_ids()
        out = []
        for a, b, d, _ in self._pairs:
            pa, pb = pts.get(a), pts.get(b)
            if pa is not None and pb is not None and pa.status == ACCEPTED == pb.status and a not in paired \
                    and b not in paired:
                out.append((a, b, d))
        return out

    def n_likely(self) -> int:
        """len(:meth:`likely`), in O(1) (the dock's counts after every click)."""
        return len(self._live)

    def links(self) -> List[Tuple[Tuple[float, float], Tuple[float, float]]]:
        """(photo pixel, partner's projected pixel) of the likely pairs whose photo end is visible. O(visible)."""
        return [((p.x, p.y), self._pairs[k][3]) for p in self.visible(PHOTO) for k in self._live_of(p.id, 0)]

    def likely_visible(self, space: str) -> List[Point]:
        """The visible points of ``space`` that are one end of a likely pair (ringed in cyan). O(visible)."""
        end = 0 if space == PHOTO else 1
        return [p for p in self.visible(space) if self._live_of(p.id, end)]

    def _live_of(self, pid: str, end: int) -> List[int]:
        """Indices of the likely pairs whose end ``end`` (0 photo, 1 map) is ``pid``."""
        return [k for k in self._pairs_of.get(pid, ()) if k in self._live and self._pairs[k][end] == pid]

    def _paired_ids(self) -> Set[str]:
        """Ids of the points in a pair of the person's. O(pairs), once per pass over the likely pairs."""
        return {i for pr in self.state.pairs for i in pr}

    def _is_live(self, k: int, paired: Set[str]) -> bool:
        """Pair ``k`` is likely: both ends exist, neither rejected nor in ``paired`` (:meth:`_paired_ids`: a trial's
        links drew suggestions to map points already paired), at least one undecided."""
        pts = self.state.points
        a, b = self._pairs[k][0], self._pairs[k][1]
        pa, pb = pts.get(a), pts.get(b)
        return pa is not None and pb is not None and SUGGESTED in (pa.status, pb.status) and \
            REJECTED not in (pa.status, pb.status) and a not in paired and b not in paired

    def set_outliers(self, ids) -> None:
        self.outliers = set(ids)

    def current_outliers(self) -> List[str]:
        """Flagged ids that are still accepted."""
        pts = self.state.points
        return [i for i in self.outliers if i in pts and pts[i].status == ACCEPTED]


class Recommendation:
    """What a camera says about the suggestions: ``distance`` / ``partner`` (id -> px / id of the nearest
    suggestion of the other view within 3 sigma), ``clutter`` (space -> the other view's points per px^2 in the
    picture: how much a near partner says, see :func:`~..core.recommend.priority`) and ``pairs`` [(photo id, map id,
    px, projected (u, v))]."""

    def __init__(self, distance=None, partner=None, pairs=None, clutter=None):
        self.distance: Dict[str, float] = distance or {}
        self.partner: Dict[str, str] = partner or {}
        self.pairs: List[Tuple[str, str, float, Tuple[float, float]]] = pairs or []
        self.clutter: Dict[str, float] = clutter or {}


def recommendation(camera, photo_ids: List[str], uv: np.ndarray, map_ids: List[str], xyz: np.ndarray,
                   sigma: float, threshold: float) -> Recommendation:
    """:class:`Recommendation` of ``camera`` for photo points ``uv`` (N, 2) and DEM points ``xyz`` (M, 3) (no Qt:
    runs in a task). O(N + M)."""
    proj = camera.project(xyz) if len(xyz) else np.zeros((0, 2))
    if len(proj):
        proj[~camera.in_image(proj)] = np.nan
    pi, pd, di, dd = agreement(uv, proj, 3.0 * sigma)
    rec = Recommendation()
    size = camera.image_size
    rec.clutter = {PHOTO: clutter(proj, size), MAP: clutter(uv, size)}
    for k in np.flatnonzero(pi >= 0):
        rec.distance[photo_ids[k]], rec.partner[photo_ids[k]] = float(pd[k]), map_ids[pi[k]]
    for k in np.flatnonzero(di >= 0):
        rec.distance[map_ids[k]], rec.partner[map_ids[k]] = float(dd[k]), photo_ids[di[k]]
    for i, j in likely_pairs(uv, proj, threshold, sigma, max(rec.clutter.values())):
        rec.pairs.append((photo_ids[i], map_ids[j], float(np.hypot(*(uv[i] - proj[j]))),
                          (float(proj[j][0]), float(proj[j][1]))))
    return rec
