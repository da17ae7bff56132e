"""The report made from the dock after an unpaired fit: it gets the fit's automatic pairs and its sigmas."""

import numpy as np

from monoplot_plugin.state import ACCEPTED, MAP, PHOTO, Point, add_points

from test_dock_actions import dock_with_fit  # noqa: F401 (fixture)


def _accepted_points(c, scene, n=8):
    """n photo points and the DEM points they see (from the scene's exact XYZ), all accepted, unpaired."""
    rng = np.random.default_rng(3)
    xyz = scene.xyz
    h, w = xyz.shape[:2]
    photo, world = [], []
    while len(photo) < n:
        u, v = int(rng.integers(5, w - 5)), int(rng.integers(5, h - 5))
        if np.isfinite(xyz[v, u]).all():
            photo.append(Point.new(PHOTO, u + 0.5, v + 0.5))
            world.append(Point.new(MAP, *map(float, xyz[v, u])))
    c.stack.push(add_points(c.state, photo + world))
    c.set_status([p.id for p in photo + world], ACCEPTED)
    return photo, world


def test_report_inputs_after_unpaired_fit(dock_with_fit, plane_scene):
    dock, tools = dock_with_fit
    c = dock.controller
    photo, world = _accepted_points(c, plane_scene)
    c.state.fit_info = {"rmse_px": 0.5, "matched": [[a.id, b.id] for a, b in zip(photo, world)][:6],
                        "sigma": {"x": 12.0, "heading": 0.1}}
    points, sigmas = c.report_inputs()
    assert points is not None and len(points.uv) == 6  # the pairs the fit used, not nothing
    assert np.allclose(points.uv[0], (photo[0].x, photo[0].y))
    assert np.allclose(points.xyz[0], (world[0].x, world[0].y, world[0].z))
    assert sigmas == {"x": 12.0, "heading": 0.1}


def test_report_inputs_core_summary_std_still_read(dock_with_fit):
    dock, tools = dock_with_fit
    dock.controller.state.fit_info = {"std": {"x": 3.0}}
    assert dock.controller.report_inputs() == (None, {"x": 3.0})


def test_a_report_after_the_points_changed_says_its_figures_are_the_fits(dock_with_fit, plane_scene, tmp_path,
                                                                          qgis_iface):
    """A trial's report drew the points of after an edit under the figures of the fit before it, unsaid."""
    from qgis.core import Qgis

    dock, tools = dock_with_fit
    c = dock.controller
    photo, world = _accepted_points(c, plane_scene)
    c.state.fit_info = {"status": "ok", "message": "paired fit on 8 pairs: RMSE 0.5 px.", "rmse_px": 0.5,
                        "fit_point_xy": {p.id: (p.x, p.y) for p in photo + world}}
    bar = qgis_iface.messageBar()
    bar.clearWidgets()
    assert tools.export_report(tmp_path / "same.png").exists()
    assert not any("changed after this fit" in m for m in bar.get_messages(Qgis.MessageLevel.Warning))
    c.move(photo[0].id, photo[0].x + 3.0, photo[0].y)
    assert c.fit_points_changed()
    assert tools.export_report(tmp_path / "changed.png").exists()
    assert any("The accepted points changed after this fit" in m
               for m in bar.get_messages(Qgis.MessageLevel.Warning))
