"""What a new user saw in the real desktop (issue 12): background refits in QGIS's task list and message bar, the
product buttons enabled before a fit, an empty "Monoplot" log tab, the lens row's button over its check box at a
narrow dock. Real dock, real clicks, real fits."""

from __future__ import annotations

import numpy as np
import pytest
from qgis.core import QgsApplication
from qgis.PyQt.QtCore import QPoint, Qt
from qgis.PyQt.QtWidgets import QToolButton, QWidget

from monoplot_plugin import logging_bridge
from monoplot_plugin.gui.product_panel import NEEDS_FIT
from monoplot_plugin.state import ACCEPTED
from test_dock import accept_everything, add_scene_points, load_inputs


def product_buttons(dock):
    """{action name: its button in the fit tab} of the products that need a fitted camera."""
    tools = dock.output_tools
    buttons = {b.defaultAction(): b for b in dock.findChildren(QToolButton) if b.defaultAction() is not None}
    return {name: buttons[tools.actions[name]] for name in NEEDS_FIT}


def test_background_refit_is_silent_and_the_fit_button_is_not(dock, scene, qtbot):
    """The refit runs outside QGIS's task manager (no status-bar entry, no "Task complete" in the message bar on
    every refit); the Fit the person clicked is a task of the task manager as before."""
    load_inputs(dock, scene, qtbot)
    photo, world = add_scene_points(dock, scene)
    dock.controller.set_prior(scene.prior)
    added = []
    manager = QgsApplication.taskManager()

    def task_added(tid):
        task = manager.task(tid)
        added.append(task.description() if task is not None else "?")

    manager.taskAdded.connect(task_added)
    try:
        _fit_after_refit(dock, scene, qtbot, photo, world, added)
    finally:
        manager.taskAdded.disconnect(task_added)  # the task manager outlives this test


def _fit_after_refit(dock, scene, qtbot, photo, world, added):
    c, panel = dock.controller, dock.curation_panel
    chosen = np.random.default_rng(0).choice(len(photo), 20, replace=False)
    with qtbot.waitSignal(panel.refitter.refitted, timeout=120000) as blocker:
        c.set_status([photo[i].id for i in chosen] + [world[i].id for i in chosen], ACCEPTED)
    outcome = blocker.args[0]
    assert outcome.status in ("ok", "uncertain")
    assert added == []  # neither the refit nor the chips' DEM view went to the task manager
    # Fit on the same points: the refit's fit is reused (only the overlay is rendered), in a visible task
    qtbot.mouseClick(dock.fitButton, Qt.MouseButton.LeftButton)
    with qtbot.waitSignal(c.taskFinished, timeout=60000) as done:
        pass
    assert done.args[0].ok and added == ["Fit camera (already fitted in the background)"]
    assert c.fitted == outcome.camera and c.overlay is not None
    assert c.state.fit_info["n_photo"] == 20 and len(c.state.fit_info["matched"]) >= 15
    # more points: a fit of its own, and no background refit beside it
    accept_everything(c)
    qtbot.mouseClick(dock.fitButton, Qt.MouseButton.LeftButton)
    assert panel.refitter.task is None
    with qtbot.waitSignal(c.taskFinished, timeout=60000):
        pass
    assert added[-1] == "Fit camera" and c.state.fit_info["n_photo"] == len(photo)


def test_products_wait_for_a_fit_and_the_log_tab_tells_what_happened(dock, scene, qtbot):
    """Before a fit the XYZ / orthophoto / report buttons are disabled and say why; a fit enables them. The fit, the
    refusal before it and the messages go to QGIS's Log Messages panel, tab "Monoplot"."""
    logged = []
    log = QgsApplication.messageLog()

    def received(message, tag, level):
        if tag == logging_bridge.TAB:
            logged.append((message, level))

    log.messageReceived.connect(received)
    logging_bridge.install()
    try:
        load_inputs(dock, scene, qtbot)
        buttons = product_buttons(dock)
        for name, button in buttons.items():
            assert not button.isEnabled(), name
            assert "Needs a fitted camera" in button.toolTip() and "Fit the camera first" in button.toolTip()
        c = dock.controller
        dock.curation_panel.refitCheck.setChecked(False)
        qtbot.mouseClick(dock.fitButton, Qt.MouseButton.LeftButton)  # no camera yet: refused, with a warning
        add_scene_points(dock, scene)
        accept_everything(c)
        c.set_prior(scene.prior)
        qtbot.mouseClick(dock.fitButton, Qt.MouseButton.LeftButton)
        with qtbot.waitSignal(c.taskFinished, timeout=60000) as blocker:
            pass
        assert blocker.args[0].ok
        for name, button in buttons.items():
            assert button.isEnabled(), name
            assert "Needs a fitted camera" not in button.toolTip() and button.toolTip()
        qtbot.waitUntil(lambda: any("Camera fitted" in m for m, _ in logged), timeout=5000)
        texts = [m for m, _ in logged]
        assert any("Give a rough camera first" in m for m in texts)  # the warning of the refused click
        assert any("Fit (" in m and "RMSE" in m and "core fit" in m for m in texts)  # what the fit did
        assert any("Fit camera" in m and ": finished in" in m for m in texts)  # and how long it took
        # an unpaired fit's RMSE is agreement, not accuracy: the message says how to pair points to measure it
        assert any("Camera fitted" in m and "Shift+click a point then its partner" in m for m in texts)
        # the camera dropped: the products are disabled again
        c.set_fitted(None)
        assert all(not b.isEnabled() for b in buttons.values())
    finally:
        logging_bridge.uninstall()
        log.messageReceived.disconnect(received)


@pytest.mark.parametrize("width", [440, 580, 900])
def test_lens_row_never_overlaps_and_its_button_works(dock, scene, qtbot, width):
    """At a narrow dock "Set field of view" was drawn over the "35 mm equiv." box: the row wraps instead, and the
    box and the button stay clickable at every width."""
    load_inputs(dock, scene, qtbot)
    dock.resize(width, 800)
    dock.stepTabs.setCurrentWidget(dock.cameraTab)
    qtbot.wait(50)
    lens = dock.lens_panel
    widgets = lens.row.findChildren(QWidget)
    shown = [w for w in widgets if w.isVisible() and w.parent() is lens.row]
    assert len(shown) == 6
    assert lens.row.one_line == (width >= 900)  # one line when wide, two when narrow
    for i, a in enumerate(shown):
        assert lens.row.rect().contains(a.geometry()), a
        assert a.width() >= a.minimumSizeHint().width(), a
        for b in shown[i + 1:]:
            assert not a.geometry().intersects(b.geometry()), (a, b)
    qtbot.mouseClick(lens.equivalent_check, Qt.MouseButton.LeftButton, pos=QPoint(6, lens.equivalent_check.height() // 2))
    assert lens.equivalent_check.isChecked()
    lens.focal_spin.setValue(35.0)
    qtbot.mouseClick(lens.apply_button, Qt.MouseButton.LeftButton)
    assert abs(dock.fovSpin.value() - 54.4) < 0.2  # 35 mm equivalent on a landscape photo: 2 atan(18 / 35)
