"""The dock at its narrowest (QGIS opens it from the tool bar at about its minimum width): every widget of the
Camera and Fit tabs lies inside the tab, the Fit tab does not scroll sideways, the point table follows the counts."""

from __future__ import annotations

from qgis.PyQt.QtWidgets import QApplication, QWidget


def _outside(page: QWidget, width: int):
    """Names of the visible widgets of ``page`` whose right edge lies beyond ``width``."""
    out = []
    for w in page.findChildren(QWidget):
        if w.isVisibleTo(page) and w.mapTo(page, w.rect().topRight()).x() > width:
            out.append(w.objectName() or type(w).__name__ + ":" + (getattr(w, "text", lambda: "")() or ""))
    return out


def test_tabs_fit_the_narrowest_dock(dock, scene):
    # no tab needs more than the dock's fixed minimum width (five camera buttons in a row did: the dock was cut)
    for page in (dock.cameraTab, dock.fitScrollContents, dock.pointsTab):
        assert page.minimumSizeHint().width() <= dock.dockContents.minimumWidth(), page.objectName()
    dock.resize(dock.minimumSizeHint().width(), 900)
    dock.photoFile.setFilePath(scene.photo_path)
    dock.controller.set_prior(scene.prior)
    for tab in (dock.cameraTab, dock.fitTab, dock.pointsTab):
        dock.stepTabs.setCurrentWidget(tab)
        QApplication.processEvents()
        assert dock.dockContents.width() <= dock.width()
    dock.stepTabs.setCurrentWidget(dock.cameraTab)
    QApplication.processEvents()
    assert not _outside(dock.cameraTab, dock.cameraTab.width())
    dock.stepTabs.setCurrentWidget(dock.fitTab)
    dock.fit_settings.setCollapsed(False)
    QApplication.processEvents()
    assert dock.fitScroll.horizontalScrollBar().maximum() == 0
    assert not _outside(dock.fitScrollContents, dock.fitScroll.viewport().width())
    layout = dock.pointTable.parentWidget().layout()
    assert layout.indexOf(dock.pointTable) < layout.indexOf(dock.helpLabel)  # the table first, then the help


def test_float_puts_the_dock_window_on_the_screen_with_the_photo_large(dock, qtbot, qgis_iface):
    """Float makes the dock a window inside the screen's free area (it stayed where the dock had been, half off a
    1600 px screen); Float again docks it."""
    from qgis.PyQt.QtCore import Qt

    qgis_iface.mainWindow().addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, dock)
    assert not dock.isFloating()
    qtbot.mouseClick(dock.floatButton, Qt.MouseButton.LeftButton)
    assert dock.isFloating()
    area = (dock.screen() or QApplication.primaryScreen()).availableGeometry()  # 800 x 600 offscreen
    frame = dock.frameGeometry()
    assert area.contains(frame.topLeft()) and frame.right() <= area.right()  # its title bar in reach
    assert frame.bottom() <= area.bottom() or dock.height() <= dock.minimumSizeHint().height() + 1
    # (the photo's share of the window is looked at in the desktop: here the 600 px screen leaves the tabs their
    # minimum and the photo the rest)
    assert dock.floatButton.text() == "Dock"  # what the button does next
    qtbot.mouseClick(dock.floatButton, Qt.MouseButton.LeftButton)
    assert not dock.isFloating() and dock.floatButton.text() == "Float"
