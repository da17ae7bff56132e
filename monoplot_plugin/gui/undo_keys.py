"""Ctrl+Z, Ctrl+Shift+Z and Ctrl+Y for the point edits while the focus is anywhere in the dock's tabs.

A QShortcut of the tabs clashed with QGIS's own Edit ▸ Undo (Ctrl+Z too) whenever a layer was being edited: Qt
called the key ambiguous and neither fired (a re-check trial). Here the focused widget claims the key first
(``ShortcutOverride``), so QGIS's shortcut does not see it, and the key press clicks the dock's Undo or Redo button.
Text and number boxes keep their own undo.
"""

from __future__ import annotations

from qgis.PyQt.QtCore import QEvent, QObject, Qt
from qgis.PyQt.QtWidgets import QAbstractSpinBox, QComboBox, QLineEdit, QPlainTextEdit, QTextEdit, QWidget

__all__ = ["UndoKeys", "install_undo_keys"]

_TYPED_IN = (QLineEdit, QAbstractSpinBox, QTextEdit, QPlainTextEdit, QComboBox)


class UndoKeys(QObject):
    """Event filter: Ctrl+Z clicks ``undo``, Ctrl+Shift+Z and Ctrl+Y click ``redo``."""

    def __init__(self, parent, undo, redo):
        super().__init__(parent)
        self.undo, self.redo = undo, redo

    def button_for(self, event):
        """The button a key event asks for, or None."""
        mods = event.modifiers() & (Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier
                                    | Qt.KeyboardModifier.AltModifier | Qt.KeyboardModifier.MetaModifier)
        ctrl, ctrl_shift = Qt.KeyboardModifier.ControlModifier, \
            Qt.KeyboardModifier.ControlModifier | Qt.KeyboardModifier.ShiftModifier
        if event.key() == Qt.Key.Key_Z and mods == ctrl:
            return self.undo
        if (event.key() == Qt.Key.Key_Z and mods == ctrl_shift) or (event.key() == Qt.Key.Key_Y and mods == ctrl):
            return self.redo
        return None

    def eventFilter(self, watched, event) -> bool:  # noqa: N802 (Qt's name)
        kind = event.type()
        if kind not in (QEvent.Type.ShortcutOverride, QEvent.Type.KeyPress):
            return False
        button = self.button_for(event)
        if button is None:
            return False
        if kind == QEvent.Type.ShortcutOverride:
            event.accept()  # ours: QGIS's window-wide Ctrl+Z does not get it
            return True
        button.click()  # a disabled button does nothing
        return True


def install_undo_keys(root: QWidget, undo, redo) -> UndoKeys:
    """Watch ``root`` and every widget under it that can take the focus (text and number boxes excepted)."""
    keys = UndoKeys(root, undo, redo)
    for widget in [root] + root.findChildren(QWidget):
        if widget.focusPolicy() != Qt.FocusPolicy.NoFocus and not isinstance(widget, _TYPED_IN):
            widget.installEventFilter(keys)
    return keys
