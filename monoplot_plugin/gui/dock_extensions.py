"""Where the dock's panels plug in (a mixin of :class:`~.dock.MonoplotDock`): checkable tools on the photo
canvas's bar (the digitising tools) and buttons in the "Fit and results" tab (products, the automatic registration).
The dock provides ``photoPaneLayout``, ``outputsBar``, ``photo_canvas``, ``photo_tool``, ``chips``, ``_photo_toolbar``
and ``_photo_tools``."""

from __future__ import annotations

from qgis.PyQt.QtCore import Qt
from qgis.PyQt.QtWidgets import QAction, QSizePolicy, QToolBar, QToolButton

__all__ = ["DockExtensionsMixin"]


class DockExtensionsMixin:
    """The dock's extension points."""

    def add_photo_tool(self, action: QAction, map_tool) -> QToolButton:
        """Add a checkable photo-canvas tool (e.g. digitising); unchecking it returns to point curation."""
        action.setCheckable(True)
        if self._photo_toolbar is None:
            self._photo_toolbar = QToolBar(self)
            self._photo_toolbar.setToolButtonStyle(Qt.ToolButtonStyle.ToolButtonTextOnly)
            self.photoPaneLayout.insertWidget(1, self._photo_toolbar)
        self._photo_toolbar.addAction(action)
        button = self._photo_toolbar.widgetForAction(action)
        self._photo_tools.append((action, map_tool))

        def toggled(on: bool) -> None:
            if on:
                for other, _ in self._photo_tools:
                    if other is not action:
                        other.setChecked(False)
                self.photo_canvas.setMapTool(map_tool)
            elif self.photo_canvas.mapTool() is map_tool:
                self.photo_canvas.setMapTool(self.photo_tool)
            self.chips.set_paused(self.photo_canvas.mapTool() is not self.photo_tool)

        action.toggled.connect(toggled)
        return button

    def end_photo_tools(self) -> None:
        """Uncheck every photo tool: clicks on the photo curate points again. Done when the Points tab is shown and
        when the project is closed (a trial reopened its project with "Draw lines" still on: its accepts, rejects
        and Ctrl+clicks on the Points tab went into a line, without a word)."""
        for action, _ in self._photo_tools:
            action.setChecked(False)

    def add_output_action(self, action: QAction) -> QToolButton:
        """Add a button for ``action`` to the "Fit and results" tab."""
        button = QToolButton(self)
        button.setDefaultAction(action)
        button.setToolButtonStyle(Qt.ToolButtonStyle.ToolButtonTextOnly)
        button.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
        n = self.outputsBar.count()
        self.outputsBar.addWidget(button, n // 2, n % 2)  # two columns: three clipped the labels at 440 px
        return button
