"""Check points in the dock: paired points marked with key C stay out of the fit and measure it."""

from __future__ import annotations

import numpy as np
from qgis.PyQt.QtCore import Qt

from monoplot_plugin.state import ACCEPTED, CHECK, MAP, PHOTO, Point, ProjectState, add_points
from test_dock import accept_everything, add_scene_points, load_inputs, start_fit_on_scene


def pair_by_shift_click(dock, qtbot, photo, world):
    from test_dock import photo_pos

    c = dock.controller
    for p, w in zip(photo, world):
        c.select(MAP, w.id)
        qtbot.mouseClick(dock.photo_canvas.viewport(), Qt.MouseButton.LeftButton,
                         Qt.KeyboardModifier.ShiftModifier, pos=photo_pos(dock, p.x, p.y))


def test_key_c_marks_a_pair_as_check_points_and_the_fit_measures_them(dock, scene, qtbot):
    load_inputs(dock, scene, qtbot)
    photo, world = add_scene_points(dock, scene)
    c = dock.controller
    # unpaired set: everything accepted; four pairs linked by the user, then marked as check points
    accept_everything(c)
    checks = list(range(0, 40, 10))
    pair_by_shift_click(dock, qtbot, [photo[i] for i in checks], [world[i] for i in checks])
    assert len(c.state.valid_pairs()) == 4
    for i in checks:
        c.select(PHOTO, photo[i].id)
        dock.photo_canvas.setFocus()
        qtbot.keyClick(dock.photo_canvas, Qt.Key.Key_C)
    assert all(c.state.points[photo[i].id].status == CHECK and c.state.points[world[i].id].status == CHECK
               for i in checks)
    assert len(c.state.check_pairs()) == 4 and not c.state.valid_pairs()
    # a point without a partner cannot be a check point: a message, no change
    lone = photo[5].id
    assert not c.toggle_check(lone) and c.state.points[lone].status == ACCEPTED

    c.set_prior(scene.prior)
    assert c.fit()
    with qtbot.waitSignal(c.taskFinished, timeout=60000) as blocker:
        pass
    assert blocker.args[0].ok, blocker.args[0].reason
    info = c.state.fit_info
    # the check points were not fitted: 4 fewer photo and map points, an unpaired fit
    assert info["n_photo"] == len(photo) - 4 and info["n_map"] == len(world) - 4 and info["mode"] == "unpaired"
    assert info["n_check"] == 4
    # their error is the fitted camera's real error on those points (exact correspondences: small)
    truth = np.hypot(*(c.fitted.project(scene.xyz[checks]) - scene.uv[checks]).T)
    assert np.allclose(sorted(info["check_error_px"].values()), sorted(truth), atol=1e-6)
    assert abs(info["check_rmse_px"] - np.sqrt(np.mean(truth ** 2))) < 1e-6
    assert info["check_rmse_px"] < 10
    # shown first in the summary, drawn as their own residual vectors and in the table
    text = dock.resultLabel.text()
    assert text.index("Check points") < text.index("Fit: ")
    assert dock.photo_view.check_residuals.band.numberOfVertices() == 8
    # and in the report: the four check pairs, drawn and measured there too
    report_checks = c.report_checks()
    assert report_checks is not None and len(report_checks.uv) == 4
    row = dock.table_model.row_of(photo[checks[0]].id)
    assert dock.table_model.index(row, 1).data() == "check" and dock.table_model.index(row, 6).data() != ""
    # C again: back into the fit (both points of the pair), undoable
    c.toggle_check(world[checks[0]].id)
    assert c.state.points[photo[checks[0]].id].status == ACCEPTED
    c.stack.undo()
    assert c.state.points[photo[checks[0]].id].status == CHECK


def test_unpaired_fit_without_check_points_says_its_rmse_is_agreement(dock, scene, qtbot):
    c = start_fit_on_scene(dock, scene, qtbot)
    with qtbot.waitSignal(c.taskFinished, timeout=60000) as blocker:
        pass
    assert blocker.args[0].ok
    assert "check_rmse_px" not in c.state.fit_info or c.state.fit_info["check_rmse_px"] is None
    assert "agreement, not accuracy" in dock.resultLabel.text()


def test_check_points_survive_a_save_and_unlinking_returns_them_to_the_fit():
    from monoplot_plugin.state import CommandStack, link, set_check, unlink

    s = ProjectState()
    stack = CommandStack(s)
    a, b = Point.new(PHOTO, 10.5, 20.5), Point.new(MAP, 1000.0, 2000.0, 300.0)
    stack.push(add_points(s, [a, b]))
    stack.push(link(s, a.id, b.id))
    stack.push(set_check(s, a.id))
    again = ProjectState.from_json(s.to_json())
    assert [(p.id, q.id) for p, q in again.check_pairs()] == [(a.id, b.id)]
    stack.push(unlink(s, b.id))
    assert s.points[a.id].status == ACCEPTED and s.points[b.id].status == ACCEPTED and not s.pairs
    stack.undo()
    assert s.points[a.id].status == CHECK and s.pairs == [(a.id, b.id)]
