"""Heights of the map points a person places: on the DEM's edge cells, and said when there is none."""

from __future__ import annotations

import math

from qgis.core import Qgis

from monoplot_plugin.state import MAP, PHOTO

from test_dock import accept_everything, add_scene_points, load_inputs


def test_a_map_point_on_the_dems_last_half_cell_gets_a_height(dock, scene, qtbot):
    """A trial's summit clicked inside the DEM's last half cell got no height and its pair was left out."""
    load_inputs(dock, scene, qtbot)
    c = dock.controller
    x0, y0, x1, y1 = c.dem.bounds()
    cell = c.dem.cell_size
    pid = c.add_manual(MAP, x1 - 0.25 * cell, 0.5 * (y0 + y1))
    z = c.state.points[pid].z
    assert z is not None and math.isfinite(z)
    assert abs(z - float(c.dem.sample(x1 - 0.5 * cell, 0.5 * (y0 + y1)))) < 1e-6  # the edge's height
    c.move(pid, x0 + 0.1 * cell, y1 - 0.1 * cell)  # moved into the opposite corner's outer half cell
    assert math.isfinite(c.state.points[pid].z)


def test_a_pair_whose_map_point_has_no_height_is_said_to_be_left_out(dock, scene, qtbot, qgis_iface):
    load_inputs(dock, scene, qtbot)
    photo, world = add_scene_points(dock, scene, n=12)
    c = dock.controller
    accept_everything(c)
    for a, b in zip(photo[:8], world[:8]):
        c.link(a.id, b.id)
    x0, y0, x1, y1 = c.dem.bounds()
    off = c.add_manual(MAP, x1 + 500.0, 0.5 * (y0 + y1))  # off the DEM: no height
    extra = c.add_manual(PHOTO, 100.0, 100.0)
    c.link(extra, off)
    assert c.state.points[off].z is None
    assert "1 accepted DEM point has no height" in c.heightless_text()
    assert "with its pair" in c.heightless_text()
    c.set_prior(scene.prior)
    with qtbot.waitSignal(c.taskFinished, timeout=60000):
        assert c.fit()
    warnings = qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Warning)
    assert any("has no height" in m and "with its pair" in m for m in warnings)
    assert "has no height (off the DEM or on a void) and is left out, with its pair" in c.state.fit_info["message"]
    assert c.state.fit_info["n_pairs"] == 8


def test_a_check_point_with_no_height_is_said_and_its_chips_say_why(dock, scene, qtbot):
    """A trial's lake check point, on a void of the DEM: "7.3 px RMSE on 3" left it out without a word, and its
    chips read "Give a rough camera first" beside a fitted camera."""
    load_inputs(dock, scene, qtbot)
    c = dock.controller
    x0, y0, x1, y1 = c.dem.bounds()
    off = c.add_manual(MAP, x1 + 500.0, 0.5 * (y0 + y1))  # off the DEM: no height
    extra = c.add_manual(PHOTO, 100.0, 100.0)
    c.link(extra, off)
    assert c.toggle_check(extra) and len(c.state.check_pairs()) == 1
    assert "1 check point's map point has no height" in c.heightless_text() and "not measured" in \
        c.heightless_text()
    c.set_fitted(scene.camera, {"status": "ok", "message": "fitted"}, background=False)
    dock.chips.set_wanted(True)
    c.select(MAP, off)
    qtbot.waitUntil(lambda: "No height" in dock.chips.photo_chip.text(), timeout=5000)
    assert "void" in dock.chips.dem_chip.text() and "camera" not in dock.chips.dem_chip.text().lower()
    assert "no height" in dock.chips.caption.text() and "…" not in dock.chips.caption.text()
