"""Issue 12 in the real dock: a few suggestions at a time, bulk actions, clicks that do what they say, messages once,
the background refit, likely pairs and outliers (real QGIS, real clicks on the dock's canvases, real fits)."""

from __future__ import annotations

import numpy as np
from qgis.core import Qgis
from qgis.gui import QgsMessageBar
from qgis.PyQt.QtCore import Qt
from qgis.PyQt.QtGui import QTextDocument

from monoplot_plugin.gui.curation_panel import MessageOnce
from monoplot_plugin.state import (ACCEPTED, CHECK, MAP, PHOTO, REJECTED, SUGGESTED, Point, add_points, link,
                                   replace_suggestions)
from test_dock import add_scene_points, load_inputs, photo_pos


def press(qtbot, button):
    qtbot.mouseClick(button, Qt.MouseButton.LeftButton)


def drawn(markers, status) -> int:
    return markers.bands[status].numberOfVertices()


def test_each_view_shows_a_few_and_the_bulk_actions_page_through(dock, scene, qtbot):
    load_inputs(dock, scene, qtbot)
    c, panel = dock.controller, dock.curation_panel
    add_scene_points(dock, scene)
    n = len(scene.uv)
    per_page = c.shortlist.per_page
    assert n > 2 * per_page
    shown = c.shortlist.shown_undecided(PHOTO)
    assert len(shown) == per_page and drawn(dock.photo_view.markers, SUGGESTED) == per_page
    assert drawn(dock.map_view.markers, SUGGESTED) == per_page
    assert dock.table_proxy.rowCount() == 2 * per_page  # the table lists what the views show
    # the shown ones are spread over the photo, not the strongest corner
    uv = np.array([(c.state.points[i].x, c.state.points[i].y) for i in shown])
    assert np.ptp(uv[:, 0]) > 0.6 * 480 and np.ptp(uv[:, 1]) > 0.5 * 320
    # a click on a hidden suggestion does nothing: only what is drawn can be hit
    hidden = next(p for p in c.state.in_space(PHOTO) if p.id not in shown
                  and min(np.hypot(*(uv - (p.x, p.y)).T)) > 25)
    qtbot.mouseClick(dock.photo_canvas.viewport(), Qt.MouseButton.LeftButton, pos=photo_pos(dock, hidden.x, hidden.y))
    assert c.state.points[hidden.id].status == SUGGESTED
    # accept one, then "Reject the rest": the other shown ones of both views are rejected in one undo entry
    qtbot.mouseClick(dock.photo_canvas.viewport(), Qt.MouseButton.LeftButton,
                     pos=photo_pos(dock, *uv[0]))
    assert c.state.points[shown[0]].status == ACCEPTED
    press(qtbot, panel.rejectRestButton)
    counts = c.state.counts()
    assert counts[PHOTO][REJECTED] == per_page - 1 and counts[MAP][REJECTED] == per_page
    # rejected points are hidden by default; the next few came
    assert drawn(dock.photo_view.markers, REJECTED) == 0
    assert set(c.shortlist.shown_undecided(PHOTO)).isdisjoint(shown)
    assert len(c.shortlist.shown_undecided(PHOTO)) == per_page
    next_page = set(c.shortlist.shown_undecided(PHOTO))
    panel.filter_checks[REJECTED].setChecked(True)
    assert drawn(dock.photo_view.markers, REJECTED) == per_page - 1
    panel.filter_checks[SUGGESTED].setChecked(False)
    assert drawn(dock.photo_view.markers, SUGGESTED) == 0
    panel.filter_checks[SUGGESTED].setChecked(True)
    # one undo takes the whole "Reject the rest" back, and they are on show again
    c.stack.undo()
    assert c.state.counts()[PHOTO][REJECTED] == 0 and c.state.points[shown[0]].status == ACCEPTED
    # ... and only they: the page that came after them goes back to the queue (a desktop trial saw both, 85)
    assert set(c.shortlist.shown_undecided(PHOTO)) == set(shown[1:])
    assert len(c.shortlist.shown_undecided(MAP)) == per_page
    assert drawn(dock.photo_view.markers, SUGGESTED) == per_page - 1
    # "More suggestions" adds the next few
    before = len(c.shortlist.shown_undecided(MAP))
    press(qtbot, panel.moreButton)
    assert len(c.shortlist.shown_undecided(MAP)) == min(before + per_page, n)
    assert next_page <= set(c.shortlist.shown_undecided(PHOTO))  # the same next page as before the undo


def test_ctrl_click_always_adds_and_undo_after_a_no_op_click_keeps_the_edit(dock, scene, qtbot):
    load_inputs(dock, scene, qtbot)
    c = dock.controller
    photo, _ = add_scene_points(dock, scene, n=6)
    viewport = dock.photo_canvas.viewport()
    target = photo[0]
    # Ctrl+click 2 px from a suggestion: a new manual point, the suggestion untouched
    qtbot.mouseClick(viewport, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.ControlModifier,
                     pos=photo_pos(dock, target.x + 2, target.y))
    manual = [p for p in c.state.in_space(PHOTO) if p.manual]
    assert len(manual) == 1 and manual[0].status == ACCEPTED
    assert c.state.points[target.id].status == SUGGESTED
    # accept a suggestion, click it again (changes nothing): the undo after that must not take the accept back
    other = photo[3]
    qtbot.mouseClick(viewport, Qt.MouseButton.LeftButton, pos=photo_pos(dock, other.x, other.y))
    assert c.state.points[other.id].status == ACCEPTED
    qtbot.mouseClick(viewport, Qt.MouseButton.LeftButton, pos=photo_pos(dock, other.x, other.y))
    dock.photo_canvas.setFocus()
    qtbot.keyClick(dock.photo_canvas, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert c.state.points[other.id].status == ACCEPTED
    qtbot.keyClick(dock.photo_canvas, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert c.state.points[other.id].status == SUGGESTED
    assert dock.statusLabel.text().startswith("Undone: ") and "Redo brings it back" in dock.statusLabel.text()
    qtbot.mouseClick(dock.redoButton, Qt.MouseButton.LeftButton)  # the buttons say it too
    assert c.state.points[other.id].status == ACCEPTED and dock.statusLabel.text().startswith("Redone: ")
    qtbot.mouseClick(dock.undoButton, Qt.MouseButton.LeftButton)
    assert c.state.points[other.id].status == SUGGESTED and dock.statusLabel.text().startswith("Undone: ")
    assert len([p for p in c.state.in_space(PHOTO) if p.manual]) == 1  # the Ctrl+click add is the edit before


def test_messages_show_once_and_the_status_line_follows_the_state(dock, scene, qtbot):
    bar = QgsMessageBar()
    once = MessageOnce()
    for text in ("300 photo and 300 DEM suggestions", "2000 photo and 2000 DEM suggestions"):
        once.push(bar, "Monoplot", text, Qgis.MessageLevel.Info, 6)
    assert [item.text() for item in bar.items()] == ["2000 photo and 2000 DEM suggestions"]
    once.clear(bar, older_than_s=60.0)  # a task starting right after its own message keeps it
    assert len(bar.items()) == 1
    once.clear(bar, older_than_s=0.0)  # one pushed before is stale: off the bar
    assert bar.items() == []
    # the bar shows rich text: a KML element's name in a message is shown, not swallowed as a tag (a trial)
    once.push(bar, "Monoplot", "KML has no <leftFov> element & no fov", Qgis.MessageLevel.Critical, 0)
    document = QTextDocument()
    document.setHtml(bar.items()[0].text())
    assert document.toPlainText() == "KML has no <leftFov> element & no fov"
    once.clear(bar)
    # covered by QGIS's "Task complete": a task's result stays under it (a re-check trial: taken off as soon as it
    # was covered, "Automatic registration ended poor..." never showed)...
    once.push(bar, "Monoplot", "2000 photo and 1024 DEM suggestions", Qgis.MessageLevel.Info, 6)
    bar.pushMessage("Task complete", "Suggest points", Qgis.MessageLevel.Success, 2)
    assert [item.text() for item in bar.items()] == ["Suggest points", "2000 photo and 1024 DEM suggestions"]
    bar.clearWidgets()
    # a warning stays under the information messages of the same step (a flood trial's DEM-switch warning was taken
    # off at once by them); it goes with the next warning, or when the state changes
    once.push(bar, "Monoplot", "The DEM changed: 4 points are off it", Qgis.MessageLevel.Warning, 6)
    once.push(bar, "Monoplot", "DEM read: 2,000 x 2,000 cells", Qgis.MessageLevel.Info, 6)
    once.push(bar, "Monoplot", "The rough camera is 12 m above the DEM", Qgis.MessageLevel.Info, 6)
    assert [item.text() for item in bar.items()] == ["The rough camera is 12 m above the DEM",
                                                     "The DEM changed: 4 points are off it"]
    once.push(bar, "Monoplot", "Another warning", Qgis.MessageLevel.Warning, 6)
    assert [item.text() for item in bar.items()] == ["Another warning"]
    once.clear(bar)
    assert bar.items() == []
    # a fit's message leads with its verdict when it is not "ok" (the bar shows one line)
    info = {"status": "poor", "mode": "unpaired", "rmse_px": 3.0, "n_photo": 8, "n_matched": 3}
    poor, level = dock.controller.fit_summary(info)
    assert poor.startswith("Camera fit probably wrong (status poor; see the fit tab for why and what to do): RMSE "
                           "3.0 px on the 3 of 8") and \
        "automatic pairs agree" not in poor and level == Qgis.MessageLevel.Warning
    uncertain, _ = dock.controller.fit_summary(dict(info, status="uncertain"))
    # where to read why, before the figures the status line may cut (a re-check trial lost it at the end)
    assert uncertain.startswith("Camera fitted, uncertain (see the fit tab for why and what to do): RMSE 3.0 px")
    ok, level = dock.controller.fit_summary(dict(info, status="ok"))
    assert ok.startswith("Camera fitted: RMSE") and "fit tab" not in ok and level == Qgis.MessageLevel.Success
    # a paired fit with check points: its pairs, as the fit tab says (a trial's bar said "on 41 photo points")
    paired = {"status": "ok", "mode": "paired", "rmse_px": 11.9, "n_photo": 41, "n_pairs": 6, "check_rmse_px": 4.0,
              "n_check": 3}
    assert "(fit: 11.9 px on 6 pairs)" in dock.controller.fit_summary(paired)[0]
    load_inputs(dock, scene, qtbot)
    photo, _ = add_scene_points(dock, scene, n=6)
    dock.show_message("Camera fitted: 3.1 px")
    assert dock.statusLabel.text() == "Camera fitted: 3.1 px"
    qtbot.mouseClick(dock.photo_canvas.viewport(), Qt.MouseButton.RightButton,
                     pos=photo_pos(dock, photo[1].x, photo[1].y))
    assert dock.statusLabel.text() == ""  # the message was about the state before this edit
    # ... and off the message bar once the state it spoke of changed (an edit, an undo), not to come back when
    # QGIS's own message over it expires (a desktop trial: it came back beside "Undone: ...")
    real = QgsMessageBar()  # the test interface's bar keeps no items: a real one in its place
    mocked_bar = dock.iface.messageBar
    dock.iface.messageBar = lambda: real
    try:
        dock.show_message("2000 photo and 1024 DEM suggestions")
        real.pushMessage("Task complete", "Suggest points", Qgis.MessageLevel.Success, 2)
        dock._messages._pushed_at -= 1.0  # pushed a moment ago, not with the edit
        qtbot.mouseClick(dock.undoButton, Qt.MouseButton.LeftButton)
        assert dock.statusLabel.text().startswith("Undone: ")
        assert [item.text() for item in real.items()] == ["Suggest points"]
    finally:
        dock.iface.messageBar = mocked_bar


def test_accept_likely_waits_for_a_camera_the_verdict_calls_ok(dock, scene, qtbot):
    """Under the rough camera (here the hidden camera itself, given as the prior: every pair is exact) over a few
    suggestions the links show, but the machine does not accept them in bulk until a fit or refit says ok. Over
    many suggestions a partner as near as the rough camera's uncertainty is found by chance: no links at all."""
    load_inputs(dock, scene, qtbot)
    c, panel = dock.controller, dock.curation_panel
    add_scene_points(dock, scene)
    c.set_prior(scene.camera)
    assert c.shortlist.camera is not None and not c.shortlist.likely()
    assert dock.photo_view.links.band.numberOfVertices() == 0
    assert not panel.acceptLikelyButton.isEnabled() and "No linked pairs" in panel.acceptLikelyButton.toolTip()
    # ... said as such: not "within 8 px", which sent a trial looking at the wrong setting
    assert "too dense for the current camera's uncertainty" in panel.acceptLikelyButton.toolTip()
    add_scene_points(dock, scene, n=10)  # a new run of a few suggestions (sparse: a near partner tells)
    qtbot.waitUntil(lambda: len(c.shortlist.likely()) >= 8, timeout=10000)
    assert not panel.acceptLikelyButton.isEnabled()
    assert "not yet ok" in panel.acceptLikelyButton.toolTip()


def scored_suggestions(scene, rng):
    """The scene's correspondences as suggestions of random strength, with as many photo decoys (no partner)."""
    decoys = rng.uniform([5, 5], [475, 315], (len(scene.uv), 2))
    photo = [Point.new(PHOTO, u, v, score=s) for (u, v), s in zip(np.vstack([scene.uv, decoys]),
                                                                  rng.uniform(0, 1, 2 * len(scene.uv)))]
    world = [Point.new(MAP, x, y, z, score=s) for (x, y, z), s in zip(scene.xyz, rng.uniform(0, 1, len(scene.xyz)))]
    return photo, world


def test_suggestions_made_after_the_camera_are_ranked_by_it(dock, scene, qtbot):
    """The usual order: the rough camera first (KML, EXIF, drawn on the map), then Suggest. The new suggestions are
    ranked by their agreement with that camera at once, as they are when the camera comes after them (no waiting
    for a refit that needs accepted points first); a page nothing was decided on follows a later run, a page with a
    decision stays on show. How much the agreement counts follows the rough camera's uncertainty in Fit settings."""
    from monoplot_plugin.gui.shortlist import Shortlist

    load_inputs(dock, scene, qtbot)
    c = dock.controller
    c.set_prior(scene.prior)
    loose = c.shortlist.sigma  # the fit's default uncertainty (5 degrees, 100 m, 10 % fov) through the lens: ~45 px
    c.set_prior(None)
    # the user knows the camera well (here it is the hidden camera itself)
    for name, value in (("angle_sigma_deg", 0.3), ("position_sigma_m", 10.0), ("fov_sigma_deg", 0.3)):
        dock.fit_settings.sigma_spins[name].setValue(value)
    c.set_prior(scene.camera)
    assert c.shortlist.sigma < 0.2 * loose and 30 < loose < 80
    photo, world = scored_suggestions(scene, np.random.default_rng(3))
    c.stack.push(replace_suggestions(c.state, PHOTO, photo))  # as Suggest does: the photo's, then the DEM's
    c.stack.push(replace_suggestions(c.state, MAP, world))
    sl = c.shortlist
    # the same pages as the camera set after the suggestions gives, once the pages on show are ranked again
    after = Shortlist(c.state)
    after.set_camera(c.prior, sl.sigma)
    after.rebuild()
    for space in (PHOTO, MAP):
        assert sl.shown_undecided(space) == after.shown_undecided(space)
    assert sl.likely() == after.likely() and sl.distance == after.distance
    # and not the detectors' pages: the camera ranked them
    plain = Shortlist(c.state)
    assert sl.shown_undecided(PHOTO) != plain.shown_undecided(PHOTO)
    partnered = {p.id for p in photo[:len(scene.uv)]}
    assert sum(i in partnered for i in sl.shown_undecided(PHOTO)) > \
        sum(i in partnered for i in plain.shown_undecided(PHOTO))
    # a decision on the photo's page: a new DEM run re-ranks the DEM's page, the photo's stays on show
    shown = sl.shown_undecided(PHOTO)
    c.set_status([shown[0]], ACCEPTED)
    _, world2 = scored_suggestions(scene, np.random.default_rng(4))
    c.stack.push(replace_suggestions(c.state, MAP, world2))
    assert sl.shown_undecided(PHOTO) == shown[1:]
    assert set(sl.shown_undecided(MAP)) <= {w.id for w in world2}
    assert sl.distance.keys() & {w.id for w in world2}  # the new run's agreement with the camera


def test_likely_pairs_follow_every_edit_as_a_fresh_look_would_find_them(dock, scene, qtbot):
    """The likely pairs, their rings and links are kept up to date edit by edit (O(edit), not O(pairs)): after
    accepts, rejects, undo and a deletion they are what the definition gives from scratch."""
    load_inputs(dock, scene, qtbot)
    c, sl = dock.controller, dock.controller.shortlist
    add_scene_points(dock, scene, n=10)  # few: the prior's links are telling
    c.set_prior(scene.camera)
    qtbot.waitUntil(lambda: len(sl.likely()) >= 8, timeout=10000)

    def from_scratch():
        pts = c.state.points
        return [(a, b, d) for a, b, d, _ in sl._pairs if a in pts and b in pts
                and SUGGESTED in (pts[a].status, pts[b].status) and REJECTED not in (pts[a].status, pts[b].status)]

    def check():
        expected = from_scratch()
        assert sl.likely() == expected and sl.n_likely() == len(expected)
        ends = {a for a, _, _ in expected}
        assert [p.id for p in sl.likely_visible(PHOTO)] == [p.id for p in sl.visible(PHOTO) if p.id in ends]
        shown = {p.id for p in sl.visible(PHOTO)}
        assert sorted(sl.links()) == sorted(((c.state.points[a].x, c.state.points[a].y), q)
                                            for a, b, d, q in sl._pairs if (a, b, d) in expected and a in shown)
        assert dock.photo_view.likely.band.numberOfVertices() == len(sl.likely_visible(PHOTO))

    (a1, b1, _), (a2, b2, _), (a3, b3, _) = sl.likely()[:3]
    check()
    c.set_status([a1], ACCEPTED)  # one end decided: still likely
    check()
    assert (a1, b1) in {(a, b) for a, b, _ in sl.likely()}
    c.set_status([b1], ACCEPTED)  # both ends decided: no longer
    check()
    assert (a1, b1) not in {(a, b) for a, b, _ in sl.likely()}
    c.set_status([b2], REJECTED)
    check()
    c.stack.undo()
    check()
    assert (a2, b2) in {(a, b) for a, b, _ in sl.likely()}
    c.delete([a3])
    check()
    assert (a3, b3) not in {(a, b) for a, b, _ in sl.likely()}


def test_background_refit_links_likely_pairs_and_flags_outliers(dock, scene, qtbot):
    load_inputs(dock, scene, qtbot)
    c, panel = dock.controller, dock.curation_panel
    photo, world = add_scene_points(dock, scene)
    c.set_prior(scene.prior)
    # the person recognised 20 features on each view (any order, not paired)
    rng = np.random.default_rng(0)
    chosen = rng.choice(len(photo), 20, replace=False)
    with qtbot.waitSignal(panel.refitter.refitted, timeout=120000) as blocker:
        c.set_status([photo[i].id for i in chosen] + [world[i].id for i in chosen], ACCEPTED)
    outcome = blocker.args[0]
    assert outcome.status in ("ok", "uncertain") and outcome.rmse_px < 3.0
    # the refit camera re-ranks: likely pairs are linked on the photo, and the shown ones agree with it
    qtbot.waitUntil(lambda: c.shortlist.camera is outcome.camera, timeout=5000)
    likely = c.shortlist.likely()
    truth = {(p.id, w.id) for p, w in zip(photo, world)}
    assert len(likely) >= 30 and sum((a, b) in truth for a, b, _ in likely) >= 0.9 * len(likely)
    assert dock.photo_view.links.band.numberOfVertices() > 0
    ringed = c.shortlist.likely_visible(PHOTO)
    assert ringed and dock.photo_view.likely.band.numberOfVertices() == len(ringed)
    # "Accept likely": both ends of every pair, one undo entry
    n_before = c.state.counts()[PHOTO][ACCEPTED]
    assert panel.acceptLikelyButton.isEnabled()
    # with a pair of the person's own the Fit is paired: the button says the points it takes would wait
    assert "With pairs of your own" not in panel.acceptLikelyButton.toolTip()
    c.stack.push(link(c.state, photo[chosen[0]].id, world[chosen[0]].id))
    assert "With pairs of your own" in panel.acceptLikelyButton.toolTip()
    c.stack.undo()
    assert "With pairs of your own" not in panel.acceptLikelyButton.toolTip()
    with qtbot.waitSignal(panel.refitter.refitted, timeout=120000):
        press(qtbot, panel.acceptLikelyButton)
    gained = c.state.counts()[PHOTO][ACCEPTED] - n_before
    assert gained >= 30 and c.state.counts()[MAP][ACCEPTED] - 20 == gained
    # wrong photo points accepted: the next refit calls them outliers (red rings), one click rejects them all
    wrong = [Point.new(PHOTO, u, v, status=ACCEPTED, manual=True) for u, v in ((30.5, 30.5), (450.5, 25.5),
                                                                                  (240.5, 20.5))]
    with qtbot.waitSignal(panel.refitter.refitted, timeout=120000) as blocker:
        c.stack.push(add_points(c.state, wrong, "Add wrong points"))
    flagged = set(blocker.args[0].outlier_ids)
    assert {p.id for p in wrong} <= flagged
    assert dock.photo_view.outliers.band.numberOfVertices() == len(c.shortlist.current_outliers())
    assert panel.rejectOutliersButton.isEnabled()
    press(qtbot, panel.rejectOutliersButton)
    assert all(c.state.points[p.id].status == REJECTED for p in wrong)
    assert dock.photo_view.outliers.band.numberOfVertices() == 0
    c.stack.undo()
    assert all(c.state.points[p.id].status == ACCEPTED for p in wrong)  # one undo entry


def test_accept_likely_keeps_decided_points_and_links_pairs_when_the_fit_is_paired(dock, scene, qtbot):
    """A desktop trial with pairs of its own: Accept likely turned the map end of a check pair into an ordinary
    point (the check pair left the measurement, silently), drew links to map points already paired, and accepted
    points the paired fit then left out for want of a partner."""
    load_inputs(dock, scene, qtbot)
    c, panel = dock.controller, dock.curation_panel
    photo, world = add_scene_points(dock, scene)
    c.set_prior(scene.prior)
    chosen = np.random.default_rng(1).choice(len(photo), 14, replace=False)
    with qtbot.waitSignal(panel.refitter.refitted, timeout=120000) as blocker:
        for i in chosen:
            c.link(photo[i].id, world[i].id)
        for i in chosen[:3]:
            assert c.toggle_check(photo[i].id)
    assert blocker.args[0].status == "ok"
    assert ", 3\u00a0check" in dock.countsLabel.text()  # counted with the rest (a trial saw them nowhere)
    qtbot.waitUntil(lambda: panel.acceptLikelyButton.isEnabled(), timeout=10000)
    paired = {i for pr in c.state.pairs for i in pr}
    likely = c.shortlist.likely()
    assert len(likely) >= 10 and not paired & {i for a, b, _ in likely for i in (a, b)}
    n_pairs, checks = len(c.state.pairs), [photo[i].id for i in chosen[:3]] + [world[i].id for i in chosen[:3]]
    # points accepted without a partner (a trial's 18 DEM points, left out by its paired fit) are linked too
    loose = [i for i in range(len(photo)) if i not in chosen][:4]
    with qtbot.waitSignal(panel.refitter.refitted, timeout=120000):
        c.set_status([photo[i].id for i in loose] + [world[i].id for i in loose], ACCEPTED)
    qtbot.waitUntil(lambda: panel.acceptLikelyButton.isEnabled(), timeout=10000)
    likely = c.shortlist.likely()
    assert {(photo[i].id, world[i].id) for i in loose} <= {(a, b) for a, b, _ in c.shortlist.accepted_unpartnered()}
    assert f"({len(likely) + len(c.shortlist.accepted_unpartnered())})" in panel.acceptLikelyButton.text()
    press(qtbot, panel.acceptLikelyButton)
    assert dock.statusLabel.text().startswith(f"{len(likely) + len(loose)} likely pairs linked: the next Fit")
    assert {(photo[i].id, world[i].id) for i in loose} <= set(c.state.pairs)
    assert len(c.state.pairs) == n_pairs + len(likely) + len(loose)  # linked, so the paired fit uses them
    assert all(c.state.points[i].status == CHECK for i in checks)
    truth = {(p.id, w.id) for p, w in zip(photo, world)}
    assert all(pr in truth for pr in c.state.pairs)
    c.stack.undo()  # one undo entry
    assert len(c.state.pairs) == n_pairs and c.state.counts()[PHOTO][ACCEPTED] == 11 + len(loose)


def test_a_refit_camera_gives_way_when_an_undo_leaves_too_few_points(dock, scene, qtbot):
    """A trial undid the automatic registration's points: "camera: refit, 2.2 px (uncertain)" stayed with no point
    accepted. With too few points to refit, the rough camera ranks and labels the view again."""
    load_inputs(dock, scene, qtbot)
    c, panel = dock.controller, dock.curation_panel
    photo, world = add_scene_points(dock, scene)
    c.set_prior(scene.prior)
    with qtbot.waitSignal(panel.refitter.refitted, timeout=120000):
        c.set_status([p.id for p in photo[:15]] + [w.id for w in world[:15]], ACCEPTED)
    assert panel.refit_info.startswith("refit") and "camera: refit" in dock.countsLabel.text()
    with qtbot.waitSignal(panel.refitter.unavailable, timeout=10000):
        c.stack.undo()  # the 30 accepts were one edit
    assert panel.refit_info == "rough" and c.shortlist.camera == c.prior
    assert "camera: refit" not in dock.countsLabel.text()


def test_a_change_during_a_refit_cancels_it_and_the_next_refit_uses_the_new_points(dock, scene, qtbot):
    load_inputs(dock, scene, qtbot)
    c, refit = dock.controller, dock.curation_panel.refitter
    photo, world = add_scene_points(dock, scene)
    c.set_prior(scene.prior)
    outcomes, statuses = [], []
    refit.refitted.connect(outcomes.append)
    done = refit._done
    refit._done = lambda result: (statuses.append(result.status), done(result))  # the tasks' callback
    c.set_status([p.id for p in photo[:15]] + [w.id for w in world[:15]], ACCEPTED)
    qtbot.waitUntil(lambda: refit.task is not None, timeout=10000)  # debounced: started after the pause
    c.set_status([p.id for p in photo[15:25]] + [w.id for w in world[15:25]], ACCEPTED)
    refit._run()  # the debounce timer of the second change fires while the first refit runs
    qtbot.waitUntil(lambda: bool(outcomes) and outcomes[-1].n_photo == 25, timeout=120000)
    assert statuses[0] == "canceled"  # the newer change stopped the refit of the older points
    assert all(o.n_photo == 25 for o in outcomes)  # no result of the canceled refit was applied


def test_the_fit_button_flags_its_own_outliers_and_is_not_refitted_again(dock, scene, qtbot):
    load_inputs(dock, scene, qtbot)
    c, panel = dock.controller, dock.curation_panel
    photo, world = add_scene_points(dock, scene)
    c.set_prior(scene.prior)
    panel.refitCheck.setChecked(False)  # no background refit before the Fit: only the Fit's verdict counts
    wrong = [Point.new(PHOTO, u, v, status=ACCEPTED, manual=True) for u, v in ((30.5, 30.5), (450.5, 25.5),
                                                                                  (240.5, 20.5))]
    c.set_status([p.id for p in photo[:20]] + [w.id for w in world[:20]], ACCEPTED)
    c.stack.push(add_points(c.state, wrong, "Add wrong points"))
    panel.refitCheck.setChecked(True)
    panel.refitter.cancel()  # the refit the toggle scheduled: the Fit runs on the same points
    assert c.fit()
    qtbot.waitUntil(lambda: c.fitted is not None, timeout=120000)
    assert {p.id for p in wrong} <= set(c.state.fit_info["outliers"])
    assert {p.id for p in wrong} <= set(c.shortlist.current_outliers())  # red rings from the Fit itself
    assert panel.rejectOutliersButton.isEnabled()
    qtbot.wait(1000)  # longer than the refit's debounce
    assert panel.refitter.task is None  # the same points are not fitted a second time


def scene_without_refit(dock, scene, qtbot):
    """The scene's points as suggestions, its prior set, the background refit off: (controller, panel, photo,
    world)."""
    load_inputs(dock, scene, qtbot)
    c, panel = dock.controller, dock.curation_panel
    photo, world = add_scene_points(dock, scene)
    c.set_prior(scene.prior)
    panel.refitCheck.setChecked(False)
    return c, panel, photo, world


def random_photo_points(c, seed: int, n: int, top_share: float = 1.0):
    """``n`` accepted manual photo points at random over the top ``top_share`` of the photo (partners of nothing)."""
    w, h = c.photo_size
    uv = np.random.default_rng(seed).uniform([0, 0], [w, h * top_share], (n, 2))
    return [Point.new(PHOTO, float(u), float(v), status=ACCEPTED, manual=True) for u, v in uv]


def test_an_uncertain_camera_flags_outliers_but_does_not_reject_them_in_bulk(dock, scene, qtbot):
    """Few true points among wrong ones: the fit is "uncertain" and flags the wrong photo points (red rings), but
    "Reject outliers" stays greyed out, its tool tip says why; the message says to judge them one by one."""
    c, panel, photo, world = scene_without_refit(dock, scene, qtbot)
    wrong = random_photo_points(c, seed=3, n=25, top_share=0.3)
    c.set_status([p.id for p in photo[:12]] + [x.id for x in world[:12]], ACCEPTED)
    c.stack.push(add_points(c.state, wrong, "Add wrong points"))
    assert c.fit()
    qtbot.waitUntil(lambda: c.fitted is not None, timeout=120000)
    info = c.state.fit_info
    assert info["status"] == "uncertain", info["message"]
    assert len(c.shortlist.current_outliers()) >= 10 and "judge them one by one" in info["message"]
    assert not panel.rejectOutliersButton.isEnabled()
    assert "not yet ok (uncertain)" in panel.rejectOutliersButton.toolTip()


def test_a_poor_fit_neither_ranks_the_suggestions_nor_flags_points(dock, scene, qtbot):
    """Photo and map points that are not partners: the Fit is "poor"; the rough camera goes on ranking the
    suggestions, nothing is flagged, and the counts line says so."""
    c, panel, photo, world = scene_without_refit(dock, scene, qtbot)
    lost = random_photo_points(c, seed=5, n=8)
    c.stack.push(add_points(c.state, lost, "Add photo points"))
    c.set_status([x.id for x in world[:7]], ACCEPTED)
    assert c.fit()
    qtbot.waitUntil(lambda: c.fitted is not None, timeout=120000)
    assert c.state.fit_info["status"] == "poor", c.state.fit_info["message"]
    assert c.shortlist.camera.parameters() == c.prior.parameters() and panel.ranking_status == "rough"
    assert not c.shortlist.current_outliers() and not panel.rejectOutliersButton.isEnabled()
    assert "fit poor, ranking by the rough camera" in dock.countsLabel.text()


def test_a_fit_clicked_during_a_refit_of_the_same_points_waits_for_it(dock, scene, qtbot):
    """The Fit button soon after the last accept: the refit of those points under way is awaited, not canceled and
    fitted again; its camera is the Fit's, and the Fit only renders."""
    load_inputs(dock, scene, qtbot)
    c, refit = dock.controller, dock.curation_panel.refitter
    photo, world = add_scene_points(dock, scene)
    c.set_prior(scene.prior)
    statuses = []
    done = refit._done
    refit._done = lambda result: (statuses.append((result.status, result.value)), done(result))
    c.set_status([p.id for p in photo[:20]] + [w.id for w in world[:20]], ACCEPTED)
    qtbot.waitUntil(lambda: refit.task is not None, timeout=10000)  # debounced: started after the pause
    running = refit.current
    assert not running.ended
    assert c.fit()
    assert c.awaited_refit is running and refit.task is not None  # the Fit did not cancel it
    with qtbot.waitSignal(c.taskFinished, timeout=120000) as blocker:
        pass
    assert blocker.args[0].ok
    qtbot.waitUntil(lambda: bool(statuses), timeout=10000)
    status, outcome = statuses[0]
    assert status == "success"  # the refit ran to its end
    assert c.fitted.to_dict() == outcome.camera.to_dict()  # and its camera is the Fit's
    assert c.state.fit_info["elapsed_s"] == outcome.done.result.elapsed_s  # the same fit, not a second one
    assert c.overlay is not None


def test_a_fit_waiting_for_a_refit_that_is_canceled_fits_itself(dock, scene, qtbot):
    load_inputs(dock, scene, qtbot)
    c, refit = dock.controller, dock.curation_panel.refitter
    photo, world = add_scene_points(dock, scene)
    c.set_prior(scene.prior)
    c.set_status([p.id for p in photo[:20]] + [w.id for w in world[:20]], ACCEPTED)
    qtbot.waitUntil(lambda: refit.task is not None, timeout=10000)
    assert c.fit() and c.awaited_refit is not None
    refit.cancel()  # e.g. the refit toggle turned off while the Fit waits
    with qtbot.waitSignal(c.taskFinished, timeout=120000) as blocker:
        pass
    assert blocker.args[0].ok and c.fitted is not None and c.overlay is not None
    assert c.state.fit_info["n_photo"] == 20


def test_many_accepted_points_are_drawn_small_and_hollow(dock, scene, qtbot):
    """An automatic registration accepts about 200 points: drawn as the usual full squares they covered the skyline
    the person judges them by; past a few dozen they are small hollow squares, and full again when fewer."""
    from qgis.gui import QgsRubberBand

    from monoplot_plugin.gui.markers import CROWDED

    load_inputs(dock, scene, qtbot)
    c = dock.controller
    w, h = c.photo_size
    rng = np.random.default_rng(2)
    many = [Point.new(PHOTO, float(u), float(v), status=ACCEPTED) for u, v in rng.uniform([0, 0], [w, h], (90, 2))]
    c.stack.push(add_points(c.state, many, "Add many"))
    qtbot.waitUntil(lambda: drawn(dock.photo_view.markers, ACCEPTED) == 90, timeout=5000)
    band = dock.photo_view.markers.bands[ACCEPTED]
    assert 90 > CROWDED and band.icon() == QgsRubberBand.IconType.ICON_BOX and band.iconSize() == 5
    c.delete([p.id for p in many[10:]])
    qtbot.waitUntil(lambda: drawn(dock.photo_view.markers, ACCEPTED) == 10, timeout=5000)
    assert band.icon() == QgsRubberBand.IconType.ICON_FULL_BOX and band.iconSize() == 7


def test_redo_of_suggest_shows_a_few_again(dock, scene, qtbot):
    """A trial: Undo then Redo of "Suggest points" put every suggestion on show (2,000 per view, a 2.5 s freeze),
    and one "Reject the rest" then rejected all of them."""
    load_inputs(dock, scene, qtbot)
    c = dock.controller
    c.set_prior(scene.prior)
    press(qtbot, dock.suggestButton)
    with qtbot.waitSignal(c.taskFinished, timeout=60000) as blocker:
        pass
    assert blocker.args[0].ok, blocker.args[0].reason
    per_page = c.shortlist.per_page
    before = {s: list(c.shortlist.shown_undecided(s)) for s in (PHOTO, MAP)}
    assert all(len(ids) == per_page for ids in before.values())
    c.stack.undo()
    assert not c.shortlist.shown_undecided(PHOTO)
    c.stack.redo()
    for space in (PHOTO, MAP):
        assert len(c.shortlist.shown_undecided(space)) == per_page, space
    assert drawn(dock.photo_view.markers, SUGGESTED) == per_page
    # and an undone decision still comes back on show
    pid = c.shortlist.shown_undecided(PHOTO)[0]
    c.accept(pid)
    c.stack.undo()
    assert pid in c.shortlist.shown_undecided(PHOTO)


def test_a_refit_that_moved_the_camera_far_beyond_the_stated_position_is_not_ok(dock, scene, qtbot):
    """A re-check trial: the panel said "refit, 5.8 px (ok)", then Fit of the same points "uncertain" at 5.9 px (the
    fit had moved the camera far beyond the Position ± given). The refit weighs that too."""
    load_inputs(dock, scene, qtbot)
    c, panel = dock.controller, dock.curation_panel
    photo, world = add_scene_points(dock, scene)
    dock.fit_settings.sigma_spins["position_sigma_m"].setValue(5.0)  # "I know where it stood" (it did not)
    c.set_prior(scene.prior)  # 144 m from where the photo was taken
    chosen = np.random.default_rng(0).choice(len(photo), 20, replace=False)
    with qtbot.waitSignal(panel.refitter.refitted, timeout=120000) as blocker:
        c.set_status([photo[i].id for i in chosen] + [world[i].id for i in chosen], ACCEPTED)
    outcome = blocker.args[0]
    moved = np.hypot(*np.subtract(outcome.camera.position, scene.prior.position)[:2])
    assert moved > 3 * 5.0 and outcome.status == "uncertain"


def _dem_suggestions_after(dock, scene, qtbot, fitted, info) -> tuple:
    """(DEM suggestions (M, 3), the messages said) of a Suggest with ``fitted`` as the fitted camera (``info`` its
    fit) and the scene's rough camera."""
    load_inputs(dock, scene, qtbot)
    c = dock.controller
    c.set_prior(scene.prior)
    c.set_fitted(fitted, info)
    messages = []
    c.message.connect(lambda text, level: messages.append(text))
    press(qtbot, dock.suggestButton)
    with qtbot.waitSignal(c.taskFinished, timeout=60000) as blocker:
        pass
    assert blocker.args[0].ok, blocker.args[0].reason
    return np.array([(p.x, p.y, p.z) for p in c.state.points.values() if p.space == MAP], dtype=float), messages


def test_suggest_after_a_poor_fit_renders_the_dem_from_the_rough_camera(dock, scene, qtbot):
    """A flood trial's Suggest after a poor automatic run rendered the DEM from that camera, 31 m under the terrain
    (77 DEM suggestions against 159-340 from the rough camera): a camera judged "poor" gives way to the rough one."""
    x, y, z = scene.camera.position
    wrong = scene.camera.with_parameters(heading=scene.camera.heading + 150.0, z=z - 600.0)  # under the terrain
    dem_points, _ = _dem_suggestions_after(dock, scene, qtbot, wrong, {"status": "poor", "message": "Probably wrong"})
    assert len(dem_points) >= 50
    seen = scene.prior.in_image(scene.prior.project(dem_points))
    assert seen.mean() > 0.9, seen.mean()


def test_suggest_after_a_fit_that_sees_the_sky_takes_the_dem_from_the_rough_camera(dock, scene, qtbot):
    """A summit trial's automatic run failed "uncertain" with the camera pitched 35° up: Suggest rendered the DEM
    from it and gave 0 DEM suggestions, with no way on. A fitted camera that sees too little terrain is helped by
    the rough camera's rendering, and the message says so."""
    skyward = scene.camera.with_parameters(pitch=60.0)
    dem_points, messages = _dem_suggestions_after(dock, scene, qtbot, skyward,
                                                  {"status": "uncertain", "message": "Uncertain"})
    assert len(dem_points) >= 50
    assert scene.prior.in_image(scene.prior.project(dem_points)).mean() > 0.9
    assert any("seen from the rough camera were added" in m for m in messages), messages
