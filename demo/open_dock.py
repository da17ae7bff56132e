"""Run by ``make qgis`` inside QGIS (``qgis --code``): open the Monoplot dock, which restores the demo's session."""

import qgis.utils

plugin = qgis.utils.plugins.get("monoplot")
if plugin is not None and plugin.action is not None:
    plugin.action.setChecked(True)
