"""The dock's number boxes take either decimal separator (gui/number_entry.py): a German-locale trial typed
"63.25" into Field of view and got 63; a Swiss one typed "63,5" and got 63. Real key presses into the real dock."""

import pytest
from qgis.PyQt.QtCore import QLocale, Qt

GERMANY = QLocale(QLocale.Language.German, QLocale.Country.Germany)
SWITZERLAND = QLocale(QLocale.Language.German, QLocale.Country.Switzerland)
US = QLocale(QLocale.Language.English, QLocale.Country.UnitedStates)


@pytest.mark.parametrize("name, locale, typed, value", [
    ("fovSpin", GERMANY, "63.5", 63.5), ("fovSpin", GERMANY, "63,5", 63.5), ("fovSpin", SWITZERLAND, "63,5", 63.5),
    ("fovSpin", US, "63,5", 63.5), ("pitchSpin", GERMANY, "-2.5", -2.5), ("pitchSpin", US, "-2,5", -2.5),
])
def test_either_decimal_separator_types_a_decimal(dock, qtbot, name, locale, typed, value):
    box = getattr(dock, name)
    box.setLocale(locale)
    box.setFocus()
    box.selectAll()
    qtbot.keyClicks(box, typed)
    qtbot.keyClick(box, Qt.Key.Key_Return)
    assert box.value() == pytest.approx(value), box.text()

