"""The photo | DEM chips of the selected point in the real dock: where they look, and the partner's mark."""

from __future__ import annotations

import numpy as np
from qgis.core import QgsProject

from monoplot_plugin.gui.chips import chip_radius
from monoplot_plugin.state import MAP, PHOTO, Point, add_points, link


def _load(dock, scene, qtbot):
    dock.photoFile.setFilePath(scene.photo_path)
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    qtbot.wait(50)  # the dock's layout settles (the chips' size follows the photo canvas's)


def _pixels(pixmap, rgb, tol=30):
    """(row, col) arrays of the chip's pixels of colour ``rgb``."""
    img = pixmap.toImage()
    found = [(y, x) for y in range(img.height()) for x in range(img.width())
             if all(abs(a - b) <= tol for a, b in zip(img.pixelColor(x, y).getRgb()[:3], rgb))]
    return np.array(found, dtype=float).reshape(-1, 2)


def test_chips_show_the_selected_photo_point_and_its_partner(dock, scene, qtbot):
    _load(dock, scene, qtbot)
    c = dock.controller
    c.set_fitted(scene.camera)  # the DEM view is the fitted camera's overlay
    u, v = scene.uv[3]
    # the partner lies 12 px to the right of the photo point under the camera: a wrong pair
    a = Point.new(PHOTO, u, v)
    from monoplot_plugin.core.transforms import photo_points_to_map

    ground = photo_points_to_map(np.array([[u + 12.0, v]]), scene.camera, scene.dem)[0][0]
    assert np.isfinite(ground).all()
    b = Point.new(MAP, ground[0], ground[1], ground[2])
    c.stack.push(add_points(c.state, [a, b]))
    c.stack.push(link(c.state, a.id, b.id))
    assert dock.chips.isHidden()
    c.select(PHOTO, a.id)
    assert not dock.chips.isHidden()
    assert not dock.chips.photo_chip.pixmap().isNull() and not dock.chips.dem_chip.pixmap().isNull()
    side = dock.chips.side
    zoom = side / (2 * chip_radius(scene.camera.width))
    red = _pixels(dock.chips.dem_chip.pixmap(), (255, 60, 60))
    cyan = _pixels(dock.chips.dem_chip.pixmap(), (0, 230, 255))
    assert len(red) and len(cyan)
    assert abs(red[:, 1].mean() - side / 2) < 3 and abs(red[:, 0].mean() - side / 2) < 3  # the point: centre
    assert abs(cyan[:, 1].mean() - (side / 2 + 12 * zoom)) < 4  # the partner where the camera puts it
    assert abs(cyan[:, 0].mean() - side / 2) < 4
    assert "paired" in dock.chips.caption.toolTip()
    # at the smallest chips the caption takes a second line rather than cutting the camera's word off (a trial:
    # "Photo point · paired (cya…")
    dock.chips._resize_chips(72)
    assert "camera" in dock.chips.caption.text() and "…" not in dock.chips.caption.text()
    assert dock.chips.caption.height() > dock.chips.caption.fontMetrics().lineSpacing()
    dock.chips._resize_chips(side)
    # the photo chip is the photo, zoomed: its corner pixel is the photo's pixel there
    img = dock.chips.photo_chip.pixmap().toImage()
    r = chip_radius(scene.camera.width)
    photo_px = c.image.pixelColor(int(u + r * 0.8), int(v + r * 0.8)).getRgb()[:3]
    chip_px = img.pixelColor(int(side * 0.9), int(side * 0.9)).getRgb()[:3]
    assert max(abs(p - q) for p, q in zip(photo_px, chip_px)) < 40


def test_map_point_with_the_rough_camera_renders_in_a_task(dock, scene, qtbot):
    _load(dock, scene, qtbot)
    c = dock.controller
    b = Point.new(MAP, *scene.xyz[5])
    c.stack.push(add_points(c.state, [b]))
    c.select(MAP, b.id)
    assert "camera" in dock.chips.dem_chip.text().lower()  # no camera: it says so
    c.set_prior(scene.prior)
    qtbot.waitUntil(lambda: dock.chips.dem_chip.pixmap() is not None and not dock.chips.dem_chip.pixmap().isNull(),
                    timeout=30000)
    red = _pixels(dock.chips.dem_chip.pixmap(), (255, 60, 60))
    assert len(red) and abs(red[:, 1].mean() - dock.chips.side / 2) < 3  # the map point: its projection, centred
    assert "rough" in dock.chips.caption.toolTip()
    # A background refit's camera ranks the suggestions and draws the links: the chips follow it (a desktop trial:
    # they stayed on the rough camera, 64 px off, beside an "ok" refit's links), rendered for it in a task.
    c.shortlist.set_camera(scene.camera, 3.0)
    c.select(MAP, "")
    c.select(MAP, b.id)
    assert "refit camera" in dock.chips.caption.toolTip()
    qtbot.waitUntil(lambda: dock.chips._view is not None and dock.chips._view[0] == scene.camera.to_dict(),
                    timeout=30000)
    c.select(MAP, "")
    assert dock.chips.isHidden()


def test_an_edit_that_changes_nothing_shown_does_not_redraw_the_chips(dock, scene, qtbot):
    """A click selects a point and accepts it: the chips are drawn once, for the selection; an edit that moves the
    point draws them again."""
    _load(dock, scene, qtbot)
    c = dock.controller
    c.set_fitted(scene.camera)
    u, v = scene.uv[3]
    a = Point.new(PHOTO, u, v)
    c.stack.push(add_points(c.state, [a]))
    c.select(PHOTO, a.id)
    drawn = dock.chips.photo_chip.pixmap().cacheKey(), dock.chips.dem_chip.pixmap().cacheKey()
    c.set_status([a.id], "accepted")
    qtbot.wait(50)  # the edit's refresh runs from the event loop
    assert (dock.chips.photo_chip.pixmap().cacheKey(), dock.chips.dem_chip.pixmap().cacheKey()) == drawn
    c.move(a.id, u + 20.0, v)
    qtbot.wait(50)
    assert dock.chips.photo_chip.pixmap().cacheKey() != drawn[0]
    red = _pixels(dock.chips.photo_chip.pixmap(), (255, 60, 60))
    assert len(red) and abs(red[:, 1].mean() - dock.chips.side / 2) < 3  # centred on the moved point


def test_chips_keep_to_the_corner_away_from_the_point_and_can_be_switched_off(dock, scene, qtbot):
    """At 120 px the chips covered a quarter of the docked photo, always in its lower left corner (over the points
    there): now they are smaller on a small canvas, sit diagonally away from the selected point, and the photo
    bar's "Chips" box hides them."""
    _load(dock, scene, qtbot)
    c = dock.controller
    c.set_fitted(scene.camera)
    dock.photo_canvas.zoom_to_photo()
    canvas = dock.photo_canvas
    qtbot.waitUntil(lambda: canvas.width() > 200 and canvas.height() > 150)
    assert dock.chips.side <= max(72, min(canvas.width(), canvas.height()) // 4)
    w, h = scene.camera.image_size
    corners, points = {}, {}
    for name, (u, v) in {"upper left": (0.1 * w, 0.1 * h), "lower right": (0.9 * w, 0.9 * h),
                         "lower left": (0.1 * w, 0.9 * h)}.items():
        a = points[name] = Point.new(PHOTO, u, v)
        c.stack.push(add_points(c.state, [a]))
        c.select(PHOTO, a.id)
        qtbot.wait(20)
        assert not dock.chips.isHidden()
        chips = dock.chips.geometry()
        at = canvas.getCoordinateTransform().transform(u, -v)
        assert not chips.contains(int(at.x()), int(at.y())), name  # never over the point it shows
        corners[name] = (chips.center().x() > canvas.width() / 2, chips.center().y() > canvas.height() / 2)
    assert corners == {"upper left": (True, True), "lower right": (False, False), "lower left": (True, False)}
    # the cursor readout, two lines over the bottom edge, does not cover the chips' caption (a trial's did)
    c.select(PHOTO, points["upper left"].id)  # the chips in the lower right corner, where the readout is
    canvas.set_readout("photo pixel (12, 34) → X 2603952.1  Y 1202531.4  Z 424.0 m (EPSG:2056); X, Y ± 172 m "
                       "(the camera's σ here 41.5 px; the camera is uncertain: it may be far more)")
    assert canvas.readout.height() > canvas.readout.fontMetrics().lineSpacing()  # wrapped
    assert not dock.chips.geometry().intersects(canvas.readout.geometry())
    c.select(PHOTO, a.id)
    area = dock.chips.width() * dock.chips.height() / float(canvas.width() * canvas.height())
    assert area < 0.2
    # a drawing tool on the photo: the chips would hide what is traced (a trial's small dock canvas)
    draw_lines = dock.output_tools.actions["line"]
    draw_lines.trigger()
    assert canvas.mapTool() is not dock.photo_tool and dock.chips.isHidden()
    draw_lines.trigger()  # off: point curation again, the chips with it
    assert canvas.mapTool() is dock.photo_tool and not dock.chips.isHidden()
    try:
        dock.chipsCheck.setChecked(False)
        assert dock.chips.isHidden()
        c.select(PHOTO, a.id)
        assert dock.chips.isHidden()  # a new selection does not bring them back
    finally:
        dock.chipsCheck.setChecked(True)  # a user setting (QgsSettings): on again for the other tests
    assert not dock.chips.isHidden()
