"""The dock's "Find camera automatically": a real registration task on the synthetic scene, then accepted points."""

from __future__ import annotations

from qgis.core import QgsProject

from monoplot_plugin.state import ACCEPTED, MAP, PHOTO


def test_find_camera_automatically_gives_a_camera_and_accepted_points(dock, scene, qtbot):
    dock.photoFile.setFilePath(scene.photo_path)
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    c = dock.controller
    assert c.image is not None and c.dem is not None
    c.set_prior(scene.prior)
    action = dock.auto_panel.action
    assert action.text() == "Find camera automatically"
    action.trigger()
    assert c.busy and dock.cancelButton.isEnabled()
    with qtbot.waitSignal(c.taskFinished, timeout=240000) as blocker:
        pass
    result = blocker.args[0]
    assert result.ok, result.reason
    info = c.state.fit_info
    assert info["status"] in ("ok", "uncertain", "poor") and info["message"]
    assert c.fitted is not None and c.overlay is not None
    # honest: an "ok" camera is the right one (the prior was 3 deg off in heading)
    if info["status"] == "ok":
        assert abs(c.fitted.heading - scene.camera.heading) < 1.0
    photo = c.state.in_space(PHOTO, (ACCEPTED,))
    world = c.state.in_space(MAP, (ACCEPTED,))
    assert len(photo) == info["n_photo"] and len(world) == info["n_map"]
    if info["status"] != "poor":
        assert len(photo) >= 6 and len(world) >= 6
