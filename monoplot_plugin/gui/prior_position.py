"""The camera tab's "Position" box: the rough camera's X, Y typed in the DEM's CRS.

A time-lapse camera's or a lookout's position is often surveyed (GNSS, a map): drawing it on the map put a trial's
camera 0.6-1.3 m from the coordinates the person had, at the screen's pixel size. The box shows the current rough
camera's X, Y and, edited (Enter), moves it there, keeping its height above the DEM and its angles; with no rough
camera yet it places one there, looking along the Heading box."""

from __future__ import annotations

import math
import re
from typing import Callable, Optional, Tuple

from qgis.core import Qgis
from qgis.PyQt.QtCore import QCoreApplication

__all__ = ["PriorPositionBox", "parse_xy"]


def tr(text: str) -> str:
    return QCoreApplication.translate("MonoplotPriorPosition", text)


def parse_xy(text: str) -> Optional[Tuple[float, float]]:
    """(x, y) from "x, y", "x y" or "x; y" (a decimal comma only with ";" or spaces between the two); None when the
    text is not two numbers.

    >>> parse_xy("2643210.5, 1154830.2"), parse_xy(" 2643210.5 1154830 "), parse_xy("2643210,5; 1154830,2")
    ((2643210.5, 1154830.2), (2643210.5, 1154830.0), (2643210.5, 1154830.2))
    >>> parse_xy("2643210"), parse_xy("x, y"), parse_xy("1, 2, 3")
    (None, None, None)
    """
    text = text.strip()
    if ";" in text:
        parts = [p.replace(",", ".") for p in text.split(";")]
    elif text.count(",") == 1:
        parts = text.split(",")
    else:
        parts = re.split(r"\s+", text)
        parts = [p.replace(",", ".") for p in parts] if len(parts) == 2 else parts
    try:
        x, y = (float(p) for p in parts)
    except ValueError:
        return None
    return (x, y) if math.isfinite(x) and math.isfinite(y) else None


class PriorPositionBox:
    """Keeps ``edit`` (a QLineEdit) and the controller's rough camera in step. ``say(text, level)``: the dock's
    message; ``place(x, y)``: a new rough camera at (x, y) from the dock's boxes (its heading, pitch, field of view
    and height above the DEM), when there is none yet."""

    def __init__(self, controller, edit, say, place: Callable[[float, float], object]):
        self.controller, self.edit, self.say, self.place = controller, edit, say, place
        edit.setPlaceholderText(tr("X, Y in the DEM's CRS, then Enter"))
        edit.setToolTip(tr("Position of the rough camera in the DEM's coordinate system (e.g. surveyed by GNSS): "
                           "type X, Y and press Enter to move the camera there (its height above the DEM and its "
                           "angles are kept); with no rough camera yet, one is placed there looking along the "
                           "Heading box"))
        edit.editingFinished.connect(self._edited)
        controller.cameraChanged.connect(self.show)
        controller.demChanged.connect(self.show)
        self.show()

    def _camera_text(self) -> str:
        """The rough camera's X, Y to the centimetre, "" without one."""
        prior = self.controller.prior
        return "" if prior is None else f"{prior.position[0]:.2f}, {prior.position[1]:.2f}"

    def show(self) -> None:
        """The box shows the rough camera's X, Y, empty without one (not while the person types in it)."""
        text = self._camera_text()
        if self.edit.text() != text and not self.edit.hasFocus():
            self.edit.setText(text)

    def _edited(self) -> None:
        prior, dem = self.controller.prior, self.controller.dem
        shown = self._camera_text()
        text = self.edit.text().strip()
        if not text or text == shown:  # left as it is (editingFinished also fires on leaving the box)
            return
        xy = parse_xy(text)
        if xy is None:
            self.say(tr("Type the camera's position as X, Y in the DEM's CRS, e.g. 2643210.5, 1154830.2."),
                     Qgis.MessageLevel.Warning)
            self.edit.setText(shown)  # the camera's position again, not the text that is none
            return
        x, y = xy
        if prior is None:
            placed = self.place(x, y)
            if placed is not None:  # say which way it looks: a trial had typed the heading, and was told to set it
                self.say(tr("Rough camera placed at X {0:.2f}, Y {1:.2f}, looking along heading {2:.0f}°: if it "
                            "looks elsewhere, change the Heading box or use Draw on map.").format(
                    x, y, float(placed.heading)))
            self.show()
            return
        old_ground, ground = float(dem.sample(*prior.position[:2])), float(dem.sample(x, y))
        if not math.isfinite(ground):
            self.say(tr("X {0:.2f}, Y {1:.2f} is outside the DEM: the rough camera stays where it was.").format(x, y),
                     Qgis.MessageLevel.Warning)
            self.edit.setText(shown)
            return
        clearance = prior.position[2] - old_ground if math.isfinite(old_ground) else 2.0
        self.controller.set_prior(prior.with_parameters(x=x, y=y, z=ground + clearance))
        self.say(tr("Rough camera moved to X {0:.2f}, Y {1:.2f}, {2:.1f} m above the DEM.").format(x, y, clearance))
