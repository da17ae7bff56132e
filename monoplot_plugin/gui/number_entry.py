"""Number boxes that take either decimal separator: the key the person's locale does not use for decimals becomes
the one it does, as they type.

A German-locale trial typed "63.25" into Field of view and got 63 (Qt read the point as a thousands separator and
dropped the rest); on a Swiss locale "63,5" became 63. Spreadsheets, GPS units and papers write numbers either
way, so the other separator is taken as the decimal one: a box of degrees or metres has no thousands to group.
"""

from __future__ import annotations

from qgis.PyQt.QtCore import QEvent, QObject
from qgis.PyQt.QtGui import QKeyEvent
from qgis.PyQt.QtWidgets import QApplication, QDoubleSpinBox

__all__ = ["DecimalKeys", "accept_both_separators"]


class DecimalKeys(QObject):
    """Event filter of a :class:`QDoubleSpinBox`: "." or "," typed where the box's locale uses the other for
    decimals is sent on as that one."""

    def eventFilter(self, watched, event) -> bool:  # noqa: N802 (Qt's name)
        if event.type() != QEvent.Type.KeyPress or not isinstance(watched, QDoubleSpinBox):
            return False
        text = event.text()
        decimal = watched.locale().decimalPoint()
        if text not in (".", ",") or text == decimal:
            return False
        QApplication.sendEvent(watched, QKeyEvent(QEvent.Type.KeyPress, event.key(), event.modifiers(), decimal,
                                                  event.isAutoRepeat(), event.count()))
        return True


def accept_both_separators(root) -> DecimalKeys:
    """Install one :class:`DecimalKeys` (parented to ``root``) on every QDoubleSpinBox under ``root`` (a spin box's
    keys reach its line edit through the box, which the filter watches)."""
    keys = DecimalKeys(root)
    for box in root.findChildren(QDoubleSpinBox):
        box.installEventFilter(keys)
    return keys
