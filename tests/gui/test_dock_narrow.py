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
