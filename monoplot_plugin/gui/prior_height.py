"""The camera tab's "Above ground" box: the rough camera's height above the DEM.

It shows the current prior's height (drawn, imported from a KML or a camera JSON, from EXIF) and, edited, moves the
prior up or down to the DEM + that height; it is also the height of the next camera drawn on the map."""

from __future__ import annotations

import math
from typing import Optional

from qgis.PyQt.QtCore import QCoreApplication

__all__ = ["PriorHeightBox"]


def tr(text: str) -> str:
    return QCoreApplication.translate("MonoplotPriorHeight", text)


class PriorHeightBox:
    """Keeps ``spin`` and the controller's prior in step (``say``: the dock's status message)."""

    def __init__(self, controller, spin, say):
        self.controller, self.spin, self.say = controller, spin, say
        spin.setMinimum(-1000.0)  # a prior under a coarse DEM shows how far under, not 0
        spin.setToolTip(tr("Height of the rough camera above the DEM: edit it to move the camera up or down "
                           "(also the height of the next camera drawn on the map)"))
        spin.setKeyboardTracking(False)  # typing "50" moves the camera once, on Enter, not to 5 m first
        spin.valueChanged.connect(self._edited)
        controller.cameraChanged.connect(self.show)
        controller.demChanged.connect(self.show)
        self.show()

    def clearance(self) -> Optional[float]:
        """Height (m) of the rough camera above the DEM at its position; None without either, or off the DEM."""
        prior, dem = self.controller.prior, self.controller.dem
        if prior is None or dem is None:
            return None
        x, y, z = prior.position
        ground = float(dem.sample(x, y))
        return z - ground if math.isfinite(ground) else None

    def show(self) -> None:
        """The box shows the current prior's height (not the last drawn camera's)."""
        clearance = self.clearance()
        if clearance is not None and abs(clearance - self.spin.value()) >= 0.05:  # the box shows 0.1 m
            self.spin.blockSignals(True)
            self.spin.setValue(clearance)
            self.spin.blockSignals(False)

    def _edited(self, value: float) -> None:
        clearance = self.clearance()
        if clearance is None or abs(clearance - value) < 0.05:  # no prior, or the box only shows its height
            return
        prior = self.controller.prior
        z = prior.position[2] + value - clearance
        self.controller.set_prior(prior.with_parameters(z=z))
        self.say(tr("Rough camera moved to {0:.1f} m above the DEM (Z {1:.1f} m).").format(value, z))
