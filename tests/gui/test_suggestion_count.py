"""The Points tab's suggestion count: it sets how many points "Suggest points" proposes, and is remembered."""

from __future__ import annotations

import pytest
from qgis.core import QgsSettings
from qgis.PyQt.QtCore import Qt

from monoplot_plugin.gui.dock import SUGGESTION_COUNT_KEY
from monoplot_plugin.state import MAP, PHOTO, SUGGESTED
from test_dock import load_inputs


@pytest.fixture(autouse=True)
def forget_the_count():
    yield
    QgsSettings().remove(SUGGESTION_COUNT_KEY)  # other tests start from the default


def test_suggestion_count_spin_box_sets_the_number_and_is_remembered(dock, scene, qtbot):
    load_inputs(dock, scene, qtbot)
    c = dock.controller
    c.set_prior(scene.prior)
    dock.suggestCountSpin.setValue(40)
    assert QgsSettings().value(SUGGESTION_COUNT_KEY, type=int) == 40
    qtbot.mouseClick(dock.suggestButton, Qt.MouseButton.LeftButton)
    with qtbot.waitSignal(c.taskFinished, timeout=60000) as blocker:
        pass
    assert blocker.args[0].ok, blocker.args[0].reason
    counts = c.state.counts()
    assert counts[PHOTO][SUGGESTED] == 40 and 10 < counts[MAP][SUGGESTED] <= 40
    # spread over the photo: every quarter of the picture has some
    w, h = c.photo_size
    quarters = {(p.x >= w / 2, p.y >= h / 2) for p in c.state.in_space(PHOTO)}
    assert len(quarters) == 4


def test_a_new_dock_starts_with_the_remembered_count(qgis_iface, qtbot, dem_layer):
    from monoplot_plugin.gui.dock import MonoplotDock

    QgsSettings().setValue(SUGGESTION_COUNT_KEY, 750)
    d = MonoplotDock(qgis_iface)
    qtbot.addWidget(d)
    try:
        assert d.suggestCountSpin.value() == 750
    finally:
        d.unload()
