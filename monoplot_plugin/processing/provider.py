"""The "Monoplot" Processing provider (id ``monoplot``)."""

import os

from qgis.core import QgsProcessingProvider
from qgis.PyQt.QtGui import QIcon

from .algorithms import all_algorithms

_ICON = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                     "icons", "monoplot.svg")


class MonoplotProvider(QgsProcessingProvider):
    """Registers one instance of every Monoplot algorithm."""

    def id(self) -> str:
        return "monoplot"

    def name(self) -> str:
        return "Monoplot"

    def longName(self) -> str:
        return self.tr("Monoplot: georeference a single oblique photo against a DEM")

    def icon(self):
        return QIcon(_ICON) if os.path.exists(_ICON) else QgsProcessingProvider.icon(self)

    def loadAlgorithms(self):
        for algorithm in all_algorithms():
            self.addAlgorithm(algorithm)
