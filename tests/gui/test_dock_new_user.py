"""What a new user hit in the real desktop: clipped buttons at the dock's minimum width, a geographic DEM whose
markers went to (inf, inf), a stale photo path after a new project, typed paths that silently did nothing, and an
overlay opacity not restored when the dock is opened on an already open project."""

from __future__ import annotations

import math

import pytest
from qgis.core import Qgis, QgsProject, QgsRasterLayer
from qgis.PyQt.QtCore import Qt
from qgis.PyQt.QtGui import QKeySequence
from qgis.PyQt.QtWidgets import QToolButton


@pytest.fixture
def narrow_dock(dock, qtbot):
    """The dock at the 440 px it gets when first opened on the right of a 1600 px window."""
    dock.resize(440, 700)
    dock.stepTabs.setCurrentWidget(dock.pointsTab)
    qtbot.wait(50)
    return dock


def _clipped(buttons):
    return [b.text() for b in buttons if b.isVisible() and b.width() < b.sizeHint().width()]


def test_point_buttons_not_clipped_at_minimum_width(narrow_dock, qtbot):
    d = narrow_dock
    buttons = [d.suggestButton, d.mapToolButton, d.acceptViewButton, d.resetButton, d.undoButton, d.redoButton]
    assert _clipped(buttons) == []


def test_output_buttons_not_clipped_at_minimum_width(narrow_dock, qtbot):
    d = narrow_dock
    d.stepTabs.setCurrentWidget(d.fitTab)
    qtbot.wait(50)
    bar = d.outputsBar
    buttons = [bar.itemAt(i).widget() for i in range(bar.count())]
    assert len(buttons) >= 7
    assert _clipped(buttons) == []


def test_all_photo_tools_on_the_photo_bar_at_minimum_width(narrow_dock, qtbot):
    toolbar = narrow_dock._photo_toolbar
    overflow = toolbar.findChild(QToolButton, "qt_toolbar_ext_button")
    assert overflow is None or not overflow.isVisible()  # the polygon tool was hidden behind ">>"
    for action in narrow_dock.output_tools.actions.values():
        if action.isCheckable():
            assert toolbar.widgetForAction(action).isVisible(), action.text()


def test_fit_tab_scrolls_instead_of_clipping(dock):
    from qgis.PyQt.QtWidgets import QScrollArea

    assert isinstance(dock.findChild(QScrollArea, "fitScroll"), QScrollArea)
    assert dock.resultLabel.window() is dock and dock.fitButton.isVisibleTo(dock.fitTab)


def test_geographic_dem_markers_use_the_reprojected_crs(dock, scene, tmp_path):
    """A DEM in degrees is reprojected to UTM metres; the map must draw and pick in that CRS, not the layer's."""
    from osgeo import gdal

    from monoplot_plugin.state import MAP, Point, add_points

    path = str(tmp_path / "dem_degrees.tif")
    gdal.Warp(path, scene.dem_path, dstSRS="EPSG:4326")
    layer = QgsRasterLayer(path, "DEM in degrees")
    QgsProject.instance().addMapLayer(layer)
    dock.photoFile.setFilePath(scene.photo_path)
    dock.demCombo.setLayer(layer)
    c = dock.controller
    assert c.dem is not None and "UTM" in c.dem.crs_wkt
    assert not c.dem_crs.isGeographic() and c.dem_crs.isValid()
    # a point at the DEM centre (UTM metres) is drawn at the DEM centre on a canvas in the scene's CRS
    x0, y0 = c.dem.cell_to_map(c.dem.elevation.shape[1] // 2, c.dem.elevation.shape[0] // 2)
    p = Point.new(MAP, x0, y0, 1500.0)
    c.stack.push(add_points(c.state, [p]))
    c.select(MAP, p.id)
    shown = dock.map_view.markers.highlight.center()
    centre = QgsProject.instance().mapLayersByName("synthetic DEM")[0].extent().center()
    assert math.isfinite(shown.x()) and math.hypot(shown.x() - centre.x(), shown.y() - centre.y()) < 200.0
    # and a rough camera there draws its marker without a transform error
    c.set_prior(scene.prior.with_parameters(x=x0, y=y0))
    assert math.isfinite(dock.map_view.camera_marker.center().x())


def test_photo_box_cleared_with_the_project(dock, scene):
    dock.photoFile.setFilePath(scene.photo_path)
    assert dock.controller.photo_size is not None
    QgsProject.instance().clear()
    assert dock.controller.image is None
    assert dock.photoFile.filePath() == ""


def test_typed_missing_photo_path_is_reported(dock, qtbot, qgis_iface, tmp_path):
    edit = dock.photoFile.lineEdit()
    edit.setFocus()
    edit.setText(str(tmp_path / "no_such_photo.jpg"))
    qtbot.keyClick(edit, Qt.Key.Key_Return)
    warnings = qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Warning)
    assert any("No photo file" in m for m in warnings)
    assert "No photo file" in dock.statusLabel.text()


def test_good_photo_replaces_the_error_in_the_status_line(dock, scene, tmp_path):
    bad = tmp_path / "not_a_photo.jpg"
    bad.write_text("not an image")
    dock.photoFile.setFilePath(str(bad))
    assert "cannot read" in dock.statusLabel.text()
    dock.photoFile.setFilePath(scene.photo_path)
    assert "cannot read" not in dock.statusLabel.text() and "px" in dock.statusLabel.text()


def test_overlay_opacity_restored_when_dock_opens_on_open_project(dock, qgis_iface, qtbot, scene):
    from monoplot_plugin.gui.dock import MonoplotDock

    dock.photoFile.setFilePath(scene.photo_path)
    dock.overlaySlider.setValue(80)
    dock.controller.save()
    second = MonoplotDock(qgis_iface)  # e.g. the plugin reloaded: a new dock on the same project
    qtbot.addWidget(second)
    try:
        assert second.overlaySlider.value() == 80
    finally:
        second.unload()


def test_suggest_progress_and_cancel_visible_on_the_points_tab(dock, scene, qtbot):
    dock.photoFile.setFilePath(scene.photo_path)
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    c = dock.controller
    c.set_prior(scene.prior)
    assert not dock.progressBar.isVisible()  # idle: no empty progress bar
    dock.stepTabs.setCurrentWidget(dock.pointsTab)
    qtbot.mouseClick(dock.suggestButton, Qt.MouseButton.LeftButton)
    assert c.busy
    assert dock.stepTabs.currentWidget() is dock.pointsTab
    assert dock.progressBar.isVisible() and dock.cancelButton.isVisible() and dock.cancelButton.isEnabled()
    assert "Suggest" in dock.progressBar.format()
    with qtbot.waitSignal(c.taskFinished, timeout=60000):
        qtbot.mouseClick(dock.cancelButton, Qt.MouseButton.LeftButton)
    assert not dock.progressBar.isVisible() and dock.suggestButton.isEnabled()


def test_product_buttons_come_first_in_the_fit_tab(narrow_dock):
    """The fit tab scrolls at the default dock height and its last row is out of sight: that row must not be a
    product (it was "Active map layer on photo"), the attribute helpers go last."""
    bar = narrow_dock.outputsBar
    texts = [bar.itemAt(i).widget().text() for i in range(bar.count())]
    assert texts[:5] == ["XYZ raster…", "Orthophoto…", "Report…", "Save drawn features…",
                         "Active map layer on photo"]



def test_a_short_points_tab_scrolls_instead_of_squashing_its_buttons(dock, qtbot):
    """On a 1280 x 800 desktop the Points tab got ~300 px for ~500 px of contents: its five button rows were squashed
    to half their height (texts cut through) and the point table to one row. Now the tab scrolls (as the Fit tab)."""
    d = dock
    d.stepTabs.setCurrentWidget(d.pointsTab)
    d.resize(440, 900)  # as narrow as it goes (the dock's minimum width)
    d.splitter.setSizes([2000, 1])  # the photo takes all it can: the tabs at their minimum
    qtbot.wait(50)
    assert d.stepTabs.height() < 400
    panel = d.curation_panel
    buttons = [d.suggestButton, d.mapToolButton, d.undoButton, panel.moreButton, panel.rejectRestButton,
               panel.acceptLikelyButton, panel.rejectOutliersButton, panel.showButton]
    assert [b.text() for b in buttons if b.height() < b.sizeHint().height()] == []
    panel.acceptLikelyButton.setText("Accept likely (153)")  # the texts the refit gives them later
    panel.rejectOutliersButton.setText("Reject outliers (12)")
    qtbot.wait(50)
    viewport = d.pointsScroll.viewport()  # nothing cut on the right by the scroll bar or the dock's edge
    right = min(viewport.width(), viewport.mapFrom(d, d.rect().topRight()).x())
    assert [b.text() for b in buttons if b.mapTo(viewport, b.rect().topRight()).x() > right] == []
    rows = d.pointTable.verticalHeader().defaultSectionSize()
    assert d.pointTable.height() >= 3 * rows
    assert d.pointsScroll.verticalScrollBar().maximum() > 0  # the rest is a scroll away
    assert d.photoHolder.height() > 300  # and the photo keeps most of the dock


def test_the_point_table_is_in_sight_under_the_points_buttons(dock, qtbot):
    """At 1600 x 1000 the dock (560 x 870) showed one row of the point table: the first show gave the tabs 38 % of
    the splitter, less than the Points tab's buttons and counts take. Now its first rows are in sight, unscrolled,
    as many as the tabs' largest share (the photo keeps the rest) allows (the offscreen platform's fonts are
    larger than the desktop's: 870 px show fewer rows here than the 3 of the desktop)."""
    from monoplot_plugin.gui.dock_layout import TABLE_ROWS, TABS_SHARE, split_photo_and_tabs

    d = dock
    d.stepTabs.setCurrentWidget(d.pointsTab)
    for height in (870, 1100):
        d.resize(560, height)
        qtbot.wait(50)
        total = sum(d.splitter.sizes())
        split_photo_and_tabs(d, total)  # what the first show does
        qtbot.wait(50)
        viewport = d.pointsScroll.viewport()
        assert d.pointsScroll.verticalScrollBar().value() == 0
        table_top = d.pointTable.mapTo(viewport, d.pointTable.rect().topLeft()).y()
        rows = d.pointTable.verticalHeader().defaultSectionSize()
        in_sight = (viewport.height() - table_top - d.pointTable.horizontalHeader().height()) // rows
        photo, tabs = d.splitter.sizes()
        assert in_sight >= 1 and photo >= (1 - TABS_SHARE[1]) * total - 2
        at_most = tabs >= TABS_SHARE[1] * total - 2 or photo <= d.photoPane.minimumSizeHint().height() + 2
        assert in_sight >= TABLE_ROWS or at_most, (height, in_sight, photo, tabs)
        if height == 1100:
            assert in_sight >= TABLE_ROWS and photo >= 0.5 * total  # room for both: the photo keeps the rest


def test_the_dock_fits_a_laptop_screen_768_px_tall(dock, qtbot):
    """A trial at 1366 x 768: the dock needed 777 px at least (the photo pane 324, the Camera tab 266 without a
    scroll area), so QGIS's window grew past the screen and the products were below its edge. The Camera tab now
    scrolls like the others; docked or floating, the dock's minimum leaves room for QGIS's menus and tool bars."""
    d = dock
    for tab in (d.cameraTab, d.pointsTab, d.fitTab):
        d.stepTabs.setCurrentWidget(tab)
        qtbot.wait(10)
        assert d.minimumSizeHint().height() <= 560, (tab.objectName(), d.minimumSizeHint().height())
    d.resize(460, 560)
    d.stepTabs.setCurrentWidget(d.cameraTab)
    qtbot.wait(50)
    # the camera tab's rows keep their height and the rest is a scroll away
    assert d.drawCameraButton.height() >= d.drawCameraButton.sizeHint().height()
    assert d.cameraScroll.verticalScrollBar().maximum() > 0
    # Find camera automatically is there too, under the rough camera's buttons, in full (a trial looked for it
    # there and found it at the bottom of the fit tab, among the products)
    from qgis.PyQt.QtWidgets import QToolButton

    found = [b for b in d.cameraScroll.widget().findChildren(QToolButton) if b.defaultAction() is d.auto_panel.action]
    assert len(found) == 1 and found[0].width() >= found[0].sizeHint().width()
    assert found[0].geometry().top() > d.drawCameraButton.geometry().top()


def test_ctrl_z_in_the_tabs_undoes_the_last_point_edit(dock, scene, qtbot):
    """A keyboard trial pressed Ctrl+Z with the focus in the point table: nothing happened (only the photo canvas
    took it). The tabs take Ctrl+Z and Ctrl+Shift+Z / Ctrl+Y too; the Undo button's tooltip says so."""
    from test_dock import accept_everything, add_scene_points, load_inputs

    from monoplot_plugin.state import ACCEPTED, PHOTO

    load_inputs(dock, scene, qtbot)
    c = dock.controller
    add_scene_points(dock, scene, n=4)
    accept_everything(c)
    accepted = c.state.counts()[PHOTO][ACCEPTED]
    dock.stepTabs.setCurrentWidget(dock.pointsTab)
    dock.pointTable.setFocus()
    qtbot.waitUntil(dock.pointTable.hasFocus, timeout=2000)
    assert "(Ctrl+Z)" in dock.undoButton.toolTip()
    qtbot.keyClick(dock.pointTable, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert c.state.counts()[PHOTO][ACCEPTED] < accepted
    qtbot.keyClick(dock.pointTable, Qt.Key.Key_Y, Qt.KeyboardModifier.ControlModifier)
    assert c.state.counts()[PHOTO][ACCEPTED] == accepted
    # QGIS's Edit > Undo has Ctrl+Z too while a layer is edited: the re-check trial's Ctrl+Z then did nothing at all
    # (the key was ambiguous); the point table claims it first
    from qgis.PyQt.QtWidgets import QAction

    qgis_undo = QAction("Undo", dock)
    qgis_undo.setShortcut(QKeySequence("Ctrl+Z"))
    qgis_undo.setShortcutContext(Qt.ShortcutContext.ApplicationShortcut)
    dock.addAction(qgis_undo)
    triggered = []
    qgis_undo.triggered.connect(lambda: triggered.append(True))
    qtbot.keyClick(dock.pointTable, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert c.state.counts()[PHOTO][ACCEPTED] < accepted and not triggered


def test_tab_leaves_the_point_table(dock, scene, qtbot):
    """A keyboard trial: 24 Tab and 6 Shift+Tab presses all stayed in the point table (Tab walked its cells)."""
    from test_dock import add_scene_points, load_inputs

    load_inputs(dock, scene, qtbot)
    add_scene_points(dock, scene, n=4)
    dock.stepTabs.setCurrentWidget(dock.pointsTab)
    dock.pointTable.setFocus()
    qtbot.waitUntil(dock.pointTable.hasFocus, timeout=2000)
    qtbot.keyClick(dock.pointTable, Qt.Key.Key_Tab)
    assert not dock.pointTable.hasFocus()
