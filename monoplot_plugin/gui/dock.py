"""Monoplot's dock widget (placeholder shell; the GUI issue fills it). Layout in ``ui/dock.ui``."""

from qgis.PyQt import uic
from qgis.PyQt.QtWidgets import QDockWidget

from .. import PLUGIN_DIR, plugin_version

FORM_CLASS, _ = uic.loadUiType(str(PLUGIN_DIR / "ui" / "dock.ui"))


class MonoplotDock(QDockWidget, FORM_CLASS):
    """The plugin's main panel, docked on the right of the QGIS window."""

    def __init__(self, iface, parent=None):
        super().__init__(parent)
        self.iface = iface
        self.setupUi(self)
        self.setObjectName("MonoplotDock")  # QMainWindow.saveState() needs a stable name
        self.statusLabel.setText(self.tr("Version {0}").format(plugin_version()))
