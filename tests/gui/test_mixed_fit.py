"""A few pairs among many points without a partner, in the real dock: the pairs check a fit of the other points
(:mod:`monoplot_plugin.workflow.mixed`) instead of leaving them out (a trial's 4 summits and hundreds of accepted
suggestions: the paired fit used the summits only, its camera 28 m off)."""

from __future__ import annotations

import numpy as np
from qgis.core import Qgis

from monoplot_plugin.state import ACCEPTED
from test_dock import add_scene_points, load_inputs


def _curating(dock, scene, qtbot):
    """(controller, photo points, map points): the scene's exact points suggested, its rough camera set, and no
    background refit (the Fit's own verdict only)."""
    load_inputs(dock, scene, qtbot)
    dock.curation_panel.refitCheck.setChecked(False)
    photo, world = add_scene_points(dock, scene)
    dock.controller.set_prior(scene.prior)
    return dock.controller, photo, world


def test_four_pairs_check_the_fit_of_the_accepted_points_without_a_partner(dock, scene, qtbot, qgis_iface):
    c, photo, world = _curating(dock, scene, qtbot)
    for i in range(4):
        c.link(photo[i].id, world[i].id)
    c.set_status([p.id for p in photo[4:44]] + [w.id for w in world[4:44]], ACCEPTED)
    qgis_iface.messageBar().clear_messages()
    assert c.fit()
    qtbot.waitUntil(lambda: c.fitted is not None, timeout=120000)
    info = c.state.fit_info
    assert info["pairs_checked"] == 4 and info["mode"] == "unpaired" and info["status"] == "ok", info["message"]
    assert info["message"].startswith("Your 4 pairs alone left the camera uncertain")
    said = " ".join(qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Success))
    assert "Camera fitted: " in said and "on your 4 pairs, kept out as check points" in said
    assert "Not used by a paired fit" not in said
    assert "4 pairs kept out as check points" in dock.resultLabel.text()
    # the report says it too: the pairs as check points, the matched points as the fit's (a trial's report
    # showed the pairs as the fitted points, "RMSE 4.37 px on 6", and nothing of the 85 points fitted)
    checks, (fitted, _) = c.report_checks(), c.report_inputs()
    assert checks is not None and sorted(checks.uv[:, 0]) == sorted(p.x for p in photo[:4])
    assert fitted is not None and len(fitted.uv) >= 30 and not {p.x for p in photo[:4]} & set(fitted.uv[:, 0])
    # the camera the pairs checked is close to the truth where the points are
    error = np.linalg.norm(c.fitted.project(scene.xyz) - scene.uv, axis=1)
    assert np.sqrt(np.mean(error ** 2)) < 2.0


def test_pairs_the_other_points_contradict_keep_the_paired_fit_and_the_bar_says_so(dock, scene, qtbot, qgis_iface):
    """A trial read "not used: pair them" in the bar above a fit tab saying those points had been fitted."""
    c, photo, world = _curating(dock, scene, qtbot)
    for i in range(5):  # each photo point linked to the next one's map point: wrong pairs
        c.link(photo[i].id, world[(i + 1) % 5].id)
    c.set_status([p.id for p in photo[5:45]] + [w.id for w in world[5:45]], ACCEPTED)
    qgis_iface.messageBar().clear_messages()
    assert c.fit()
    qtbot.waitUntil(lambda: c.fitted is not None, timeout=120000)
    info = c.state.fit_info
    assert info["mode"] == "paired" and info["status"] != "ok" and info["alone_status"] in ("poor", "uncertain")
    assert "so the paired fit is kept" in info["message"]
    said = " ".join(qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Warning))
    assert "were also fitted on their own" in said and "pair them (select one" not in said
    assert "fitted apart" in dock.resultLabel.text()


def test_too_few_pairs_the_bar_asks_for_as_many_more_as_the_fit_tab(dock, scene, qtbot, qgis_iface):
    """A trial's bar said "pair them" of 20 points without a partner while its fit tab said "pair 1 more point"."""
    c, photo, world = _curating(dock, scene, qtbot)
    for i in range(4):
        c.link(photo[i].id, world[i].id)
    qgis_iface.messageBar().clear_messages()
    assert c.fit()
    qtbot.waitUntil(lambda: c.fitted is not None, timeout=120000)
    info = c.state.fit_info
    more = 2 if len(info["free"]) == 7 else 1
    assert info["status"] != "ok" and f"pair {more} more point" in info["message"]
    said = " ".join(qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Warning))
    assert f"Pair {more} more point(s): too few pairs to test the camera." in said
