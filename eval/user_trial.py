"""`make eval`: a scripted user trial of the real dock on Aletsch (issue 12); one JSON line.

A real dock in an offscreen QgsApplication (``eval/headless_dock.py``): the photo and the DEM of
``../shared/data/aletsch``, the rough camera from ``prior_pose.kml`` through the dock's KML import, Suggest points
with ``--suggestions`` per view. Then a simulated person, who knows the 11 GCPs only as "features I recognise":

* accepts a suggestion *on show* with one click only if it lies within 10 px of a GCP pixel (photo) or 75 m
  horizontally of a GCP position (main map);
* otherwise uses the dock's own bulk actions, when the dock enables them: "Reject outliers" when the background
  refit flags some, "Accept likely" once the refit camera is good enough to link pairs, and "Reject the rest" to
  see the next few;
* once the refit is sure enough (sigma <= ``--good-sigma`` px) and links pairs: "Accept likely", then "Reject
  outliers" as the next refit flags them, ``--likely-rounds`` times; then clicks Fit camera.

Printed: the check-point RMSE (the 11 GCPs projected by the fitted camera, never given to the fit; target <= 9 px),
the number of clicks (target <= 60), the wall time, and how the clicks were spent.

    .venv/bin/python -m eval.user_trial [--data DIR] [--suggestions 2000] [--threshold 4] [--judge-first]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from eval.aletsch import DEM_GATE_M, PHOTO_GATE_PX, gcp_errors  # noqa: E402
from eval.headless_dock import click, map_pos, open_dock, photo_pos, start_qgis, wait, wait_until  # noqa: E402

TARGET_PX, TARGET_CLICKS = 9.0, 60


class Person:
    """The simulated user: what it sees is what the dock shows; every action is a real click."""

    def __init__(self, dock, gcps: np.ndarray):
        self.dock, self.c, self.gcps = dock, dock.controller, gcps
        self.clicks = {"accept_photo": 0, "accept_map": 0, "reject_the_rest": 0, "more": 0, "accept_likely": 0,
                       "reject_outliers": 0, "suggest": 0, "fit": 0, "import_kml": 0}

    @property
    def total(self) -> int:
        return sum(self.clicks.values())

    def press(self, button, what: str) -> None:
        click(button, button.rect().center())
        self.clicks[what] += 1
        wait(0)

    def recognises(self, p) -> bool:
        from monoplot_plugin.state import PHOTO

        if p.space == PHOTO:
            return float(np.hypot(*(self.gcps[:, :2] - (p.x, p.y)).T).min()) <= PHOTO_GATE_PX
        return float(np.hypot(*(self.gcps[:, 2:4] - (p.x, p.y)).T).min()) <= DEM_GATE_M

    def look_and_accept(self) -> int:
        """Accept, one click each, the shown suggestions the person recognises; returns how many."""
        from monoplot_plugin.state import ACCEPTED, MAP, PHOTO

        n = 0
        for space in (PHOTO, MAP):
            for pid in list(self.c.shortlist.shown_undecided(space)):
                p = self.c.state.points.get(pid)
                if p is None or not self.recognises(p):
                    continue
                if space == PHOTO:
                    click(self.dock.photo_canvas.viewport(), photo_pos(self.dock, p.x, p.y))
                    self.clicks["accept_photo"] += 1
                else:
                    click(self.dock.map_canvas.viewport(), map_pos(self.dock, p.x, p.y))
                    self.clicks["accept_map"] += 1
                wait(0)
                n += self.c.state.points[pid].status == ACCEPTED
        return n

    def settle(self, timeout_s: float = 60.0) -> None:
        """The person looks at the screen while the background refit finishes (at most ``timeout_s``)."""
        refit = self.dock.curation_panel.refitter
        wait(700)  # the refit's debounce
        wait_until(lambda: refit.task is None and not refit._timer.isActive(), timeout_s)
        wait(0)


def accepted(c, space: str) -> int:
    from monoplot_plugin.state import ACCEPTED

    return c.state.counts()[space][ACCEPTED]


def run(data: Path, n_suggest: int, max_clicks: int, good_sigma: float, likely_rounds: int,
        threshold: float, per_page: int, judge_first: bool = False) -> dict:
    from qgis.PyQt.QtWidgets import QFileDialog

    from monoplot_plugin.state import MAP, PHOTO

    t_start = time.perf_counter()
    app, iface = start_qgis()
    gcps = np.loadtxt(data / "gcps.csv", delimiter=",", skiprows=1)
    dock = open_dock(iface, data / "photo.jpg", data / "dem.tif", "Aletsch DEM")
    c = dock.controller
    person = Person(dock, gcps)
    panel = dock.curation_panel
    panel.thresholdSpin.setValue(threshold)
    if per_page != panel.perPageSpin.value():
        panel.perPageSpin.setValue(per_page)
        person.clicks["settings"] = 1  # typed into "Per view" (counted as one click)
    # the dock's own KML import (the file dialog answered with the prior's path)
    QFileDialog.getOpenFileName = staticmethod(lambda *a, **k: (str(data / "prior_pose.kml"), ""))
    person.press(dock.kmlButton, "import_kml")
    assert c.prior is not None, "KML import failed"
    dock.suggestCountSpin.setValue(n_suggest)
    person.press(dock.suggestButton, "suggest")
    assert wait_until(lambda: c.task is None, 600), "Suggest did not finish"
    dock.photo_canvas.zoom_to_photo()
    dock.map_canvas.setExtent(dock.map_canvas.layers()[0].extent())
    dock.map_canvas.refresh()
    wait(100)
    log = []

    def note(what: str, got: int = 0) -> None:
        sl = c.shortlist
        cam = sl.camera
        log.append({"after": what, "clicks": person.total, "accepted_now": got, "photo": accepted(c, PHOTO),
                    "map": accepted(c, MAP), "camera": panel.refit_info, "outliers": len(sl.current_outliers()),
                    "likely": len(sl.likely()),
                    # for the reader only (the person never sees it): how good the ranking camera is
                    "camera_gcp_px": None if cam is None else gcp_errors(cam, gcps, c.dem)["gcp_rmse_px"]})

    # 1. judge the few on show, next page, until the background refit is good enough to link pairs
    while person.total < max_clicks:
        person.settle()
        got = person.look_and_accept()
        person.settle()
        note("look", got)
        sl = c.shortlist
        if sl.current_outliers() and panel.rejectOutliersButton.isEnabled():
            person.press(panel.rejectOutliersButton, "reject_outliers")
            continue
        # a person presses "Accept likely" only when the dock offers it (enabled: a refit the verdict calls ok)
        if likely_rounds and not judge_first and panel.acceptLikelyButton.isEnabled() and \
                sl.sigma <= good_sigma and len(sl.likely()) >= 10:
            break
        if not sl.shown_undecided():
            break  # nothing left to judge
        person.press(panel.rejectRestButton, "reject_the_rest")
    # 2. take the linked pairs, reject what the refit then calls outliers; twice (the camera improves)
    for _ in range(likely_rounds):
        if not c.shortlist.likely() or not panel.acceptLikelyButton.isEnabled():
            break  # a person does not press a greyed-out button
        person.press(panel.acceptLikelyButton, "accept_likely")
        person.settle()
        note("accept likely")
        for _ in range(3):
            if not c.shortlist.current_outliers() or not panel.rejectOutliersButton.isEnabled():
                break
            person.press(panel.rejectOutliersButton, "reject_outliers")
            person.settle()
            note("reject outliers")
    person.press(dock.fitButton, "fit")
    assert wait_until(lambda: c.task is None, 600), "Fit did not finish"
    wall = time.perf_counter() - t_start
    cam = c.fitted
    errors = gcp_errors(cam, gcps, c.dem) if cam is not None else {"gcp_rmse_px": None}
    rmse = errors["gcp_rmse_px"]
    line = {"case": "user_trial_aletsch", "strategy": {"likely_rounds": likely_rounds, "threshold_px": threshold,
                                                       "judging_clicks": max_clicks, "per_view": per_page,
                                                       "judge_first": judge_first},
            "check_rmse_px": rmse, "target_px": TARGET_PX,
            "clicks": person.total, "target_clicks": TARGET_CLICKS,
            "pass": bool(rmse is not None and rmse <= TARGET_PX and person.total <= TARGET_CLICKS),
            "status": c.state.fit_info.get("status"), "fit_rmse_px": c.state.fit_info.get("rmse_px"),
            "fit_message": c.state.fit_info.get("message"),
            "photo_accepted": accepted(c, PHOTO), "map_accepted": accepted(c, MAP),
            "suggestions_per_view": n_suggest, "per_page": c.shortlist.per_page, "click_kinds": person.clicks,
            "prior_rmse_px": gcp_errors(c.prior, gcps, c.dem)["gcp_rmse_px"], **{k: v for k, v in errors.items()
                                                                                  if k != "gcp_rmse_px"},
            "wall_s": round(wall, 1), "load_1min": round(os.getloadavg()[0], 2), "rounds": log}
    dock.unload()
    return line


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", type=Path, default=REPO.parent / "shared" / "data" / "aletsch")
    ap.add_argument("--suggestions", type=int, default=2000)
    ap.add_argument("--max-clicks", type=int, default=55, help="clicks for judging before the bulk phase")
    ap.add_argument("--good-sigma", type=float, default=12.0, help="px: a refit this sure links pairs")
    ap.add_argument("--likely-rounds", type=int, default=1)
    ap.add_argument("--threshold", type=float, default=4.0, help="px: the dock's 'pairs within'")
    ap.add_argument("--per-page", type=int, default=30, help="the dock's 'per view'")
    ap.add_argument("--judge-first", action="store_true", help="judge pages for all --max-clicks, then bulk")
    args = ap.parse_args(argv)
    if not (args.data / "dem.tif").is_file():
        print(json.dumps({"case": "user_trial_aletsch", "error": f"no data at {args.data}"}))
        return 1
    print(json.dumps(run(args.data, args.suggestions, args.max_clicks, args.good_sigma, args.likely_rounds,
                         args.threshold, args.per_page, args.judge_first)), flush=True)
    sys.stderr.flush()
    os._exit(0)  # QGIS's own teardown at interpreter exit can crash after a session; the line is written


if __name__ == "__main__":
    sys.exit(main())
