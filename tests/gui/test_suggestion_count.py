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


def test_a_camera_facing_a_near_slope_is_told_the_slope_is_left_out(dock, scene, qtbot, qgis_iface):
    """A rough camera put 5 m above the ground, looking level into rising terrain: the DEM suggestions come from
    beyond 100 m and the message bar says why and what to check."""
    import numpy as np
    from qgis.core import Qgis

    from monoplot_plugin.core.suggest import blocked_view
    from monoplot_plugin.core.xyz import compute_xyz_full

    load_inputs(dock, scene, qtbot)
    c = dock.controller
    x, y, _ = scene.camera.position
    blocked = None
    for step in range(1, 40):  # walk north, into the terrain the photo looks at, until a slope fills the view
        yy = y + 50.0 * step
        cam = scene.camera.with_parameters(y=yy, z=float(scene.dem.sample(x, yy)) + 5.0, pitch=0.0)
        if blocked_view(compute_xyz_full(cam, scene.dem, visibility=False), cam, scene.dem):
            blocked = cam
            break
    assert blocked is not None
    c.set_prior(blocked)
    qtbot.mouseClick(dock.suggestButton, Qt.MouseButton.LeftButton)
    with qtbot.waitSignal(c.taskFinished, timeout=60000) as finished:
        pass
    assert finished.args[0].ok, finished.args[0].reason
    infos = " ".join(m[1] if isinstance(m, tuple) else str(m)
                     for m in qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Info))
    assert "Terrain within 100 m of the rough camera fills its view" in infos
    depth = blocked.project_with_depth(np.array([[p.x, p.y, p.z] for p in c.state.in_space(MAP)]))[1]
    assert len(depth) and (depth > 100.0).all()
    # The person knows the position to 2 m (Fit settings, Position ±): the slope is what the camera sees.
    dock.fit_settings.sigma_spins["position_sigma_m"].setValue(2.0)
    qgis_iface.messageBar().clear_messages()
    qtbot.mouseClick(dock.suggestButton, Qt.MouseButton.LeftButton)
    with qtbot.waitSignal(c.taskFinished, timeout=60000) as finished:
        pass
    assert finished.args[0].ok, finished.args[0].reason
    infos = " ".join(str(m) for m in qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Info))
    assert "DEM suggestions" in infos and "fills its view" not in infos
    depth = blocked.project_with_depth(np.array([[p.x, p.y, p.z] for p in c.state.in_space(MAP)]))[1]
    assert (depth < 100.0).sum() >= 5  # the near slope is back among the suggestions


def test_a_photo_of_noise_is_warned_that_its_suggestions_mean_nothing(dock, scene, qtbot, qgis_iface, tmp_path):
    """A grey frame of sensor noise (fog, a blank exposure, the wrong file) still yields key points; the dock says
    they are on noise, as a warning, first in the message. The scene's own photo gets no such warning."""
    import cv2
    import numpy as np
    from qgis.core import Qgis

    load_inputs(dock, scene, qtbot)
    c = dock.controller
    c.set_prior(scene.prior)
    dock.suggestCountSpin.setValue(200)

    def suggest():
        qgis_iface.messageBar().clear_messages()
        qtbot.mouseClick(dock.suggestButton, Qt.MouseButton.LeftButton)
        with qtbot.waitSignal(c.taskFinished, timeout=60000) as finished:
            pass
        assert finished.args[0].ok, finished.args[0].reason
        return " ".join(str(m) for m in qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Warning))

    assert "almost no structure" not in suggest()
    w, h = c.photo_size
    noise = np.random.default_rng(4).normal(128, 9, (h, w, 3)).clip(0, 255).astype(np.uint8)
    cv2.imwrite(str(tmp_path / "fog.png"), noise)
    dock.photoFile.setFilePath(str(tmp_path / "fog.png"))
    assert c.state.photo_path == str(tmp_path / "fog.png")
    warnings = suggest()
    assert warnings.index("almost no structure") < warnings.index("photo and")
    assert c.state.counts()[PHOTO][SUGGESTED] > 0  # the suggestions are still there, for whoever wants them
    # the status line under the dock keeps to about three lines; the whole message is in its tool tip
    line, tip = dock.statusLabel.text(), dock.statusLabel.toolTip()
    assert line.startswith("The photo shows almost no structure") and line.endswith(" …") and len(line) <= 302
    assert tip.startswith(line[:-2]) and "accept (A / left click)" in tip
    label = dock.statusLabel  # cut to three lines of its own width, not to a fixed count of characters
    assert label.heightForWidth(label.width()) <= 3 * label.fontMetrics().lineSpacing() + 4
