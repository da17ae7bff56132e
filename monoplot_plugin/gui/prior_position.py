"""The camera tab's "Position" box: the rough camera's X, Y (and, surveyed, its Z) typed in the DEM's CRS.

A time-lapse camera's or a lookout's position is often surveyed (GNSS, a map): drawing it on the map put a trial's
camera 0.6-1.3 m from the coordinates the person had, at the screen's pixel size. The box shows the current rough
camera's X, Y and, edited (Enter), moves it there, keeping its height above the DEM and its angles (or at the Z
typed as a third number); with no rough camera yet it places one there, looking along the Heading box."""

from __future__ import annotations

import math
import re
from typing import Callable, Optional, Tuple

from qgis.core import Qgis
from qgis.PyQt.QtCore import QCoreApplication

__all__ = ["PriorPositionBox", "parse_xy"]


def tr(text: str) -> str:
    return QCoreApplication.translate("MonoplotPriorPosition", text)


def parse_xy(text: str) -> Optional[Tuple[float, ...]]:
    """(x, y), or (x, y, z), from "x, y", "x y" or "x; y" (and the same with a third number, a surveyed height; a
    decimal comma only with ";" or spaces between the numbers); None when the text is not two or three numbers.

    >>> parse_xy("2643210.5, 1154830.2"), parse_xy(" 2643210.5 1154830 "), parse_xy("2643210,5; 1154830,2")
    ((2643210.5, 1154830.2), (2643210.5, 1154830.0), (2643210.5, 1154830.2))
    >>> parse_xy("2643210.5, 1154830.2, 2332.4"), parse_xy("2643210,5; 1154830,2; 2332,4")
    ((2643210.5, 1154830.2, 2332.4), (2643210.5, 1154830.2, 2332.4))
    >>> parse_xy("2643210"), parse_xy("x, y"), parse_xy("1, 2, 3, 4")
    (None, None, None)
    """
    text = text.strip()
    if ";" in text:
        parts = [p.replace(",", ".") for p in text.split(";")]
    elif text.count(",") in (1, 2) and not re.search(r"\d\s+\d", text):
        parts = text.split(",")
    else:
        parts = re.split(r"\s+", text)
        parts = [p.replace(",", ".") for p in parts] if len(parts) in (2, 3) else parts
    if len(parts) not in (2, 3):
        return None
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        return None
    return values if all(math.isfinite(v) for v in values) else None


class PriorPositionBox:
    """Keeps ``edit`` (a QLineEdit) and the controller's rough camera in step. ``say(text, level)``: the dock's
    message; ``place(x, y)``: a new rough camera at (x, y) from the dock's boxes (its heading, pitch, field of view
    and height above the DEM), when there is none yet."""

    def __init__(self, controller, edit, say, place: Callable[[float, float], object]):
        self.controller, self.edit, self.say, self.place = controller, edit, say, place
        edit.setPlaceholderText(tr("X, Y (or X, Y, Z) in the DEM's CRS, then Enter"))
        edit.setToolTip(tr("Position of the rough camera in the DEM's coordinate system (e.g. surveyed by GNSS): "
                           "type X, Y and press Enter to move the camera there (its height above the DEM and its "
                           "angles are kept), or X, Y, Z to put it at a surveyed height too (in the DEM's height "
                           "system); with no rough camera yet, one is placed there looking along the Heading box"))
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
        xyz = parse_xy(text)
        if xyz is None:
            self.say(tr("Type the camera's position as X, Y in the DEM's CRS, e.g. 2643210.5, 1154830.2, or X, Y, Z "
                        "with a surveyed height in the DEM's height system."), Qgis.MessageLevel.Warning)
            self.edit.setText(shown)  # the camera's position again, not the text that is none
            return
        x, y = xyz[:2]
        height = xyz[2] if len(xyz) == 3 else None  # a surveyed height (a trial's GNSS X, Y, Z was refused)
        if prior is None:
            placed = self.place(x, y)
            if placed is not None and height is not None:
                placed = self._at_height(placed, height)
            if placed is not None:  # say which way it looks: a trial had typed the heading, and was told to set it
                note, level = self._height_note(placed) if height is not None else ("", Qgis.MessageLevel.Info)
                where = tr("X {0:.2f}, Y {1:.2f}").format(x, y) if height is None else \
                    tr("X {0:.2f}, Y {1:.2f}, Z {2:.2f}").format(x, y, height) + note
                self.say(tr("Rough camera placed at {0}, looking along heading {1:.0f}°: if it looks elsewhere, "
                            "change the Heading box or use Draw on map.").format(where, float(placed.heading)), level)
            self.show()
            return
        old_ground, ground = float(dem.sample(*prior.position[:2])), float(dem.sample(x, y))
        if not math.isfinite(ground):
            self.say(tr("X {0:.2f}, Y {1:.2f} is outside the DEM: the rough camera stays where it was.").format(x, y),
                     Qgis.MessageLevel.Warning)
            self.edit.setText(shown)
            return
        if height is not None:
            note, level = self._height_note(self._at_height(prior.with_parameters(x=x, y=y), height))
            self.say(tr("Rough camera moved to X {0:.2f}, Y {1:.2f}, Z {2:.2f}").format(x, y, height) + note + ".",
                     level)
            return
        clearance = prior.position[2] - old_ground if math.isfinite(old_ground) else 2.0
        self.controller.set_prior(prior.with_parameters(x=x, y=y, z=ground + clearance))
        self.say(tr("Rough camera moved to X {0:.2f}, Y {1:.2f}, {2:.1f} m above the DEM.").format(x, y, clearance))

    def _at_height(self, camera, height: float):
        """``camera`` at the typed height ``height`` (m, the DEM's height system) as the rough camera."""
        moved = camera.with_parameters(z=float(height))
        self.controller.set_prior(moved)
        return moved

    def _height_note(self, camera) -> Tuple[str, object]:
        """(" (h m above the DEM)", info) for ``camera``, or under it with the likely cause and a warning (a typed
        height in another height system); ("", info) off the DEM."""
        from ..workflow.fit import ground_clearance

        above = ground_clearance(camera, self.controller.dem) if self.controller.dem is not None else math.nan
        if not math.isfinite(above):
            return "", Qgis.MessageLevel.Info
        if above < 0:
            return " " + tr("({0:.1f} m under the DEM: is the height in the DEM's height system, not above the "
                            "ellipsoid?)").format(-above), Qgis.MessageLevel.Warning
        return " " + tr("({0:.1f} m above the DEM)").format(above), Qgis.MessageLevel.Info
