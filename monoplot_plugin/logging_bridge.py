"""Python ``logging`` of the whole plugin shown in QGIS's Log Messages panel, tab "Monoplot".

Every module logs with ``logging.getLogger(__name__)``; :func:`install` attaches one handler to the plugin's
package logger (``monoplot.monoplot_plugin`` when installed in QGIS, ``monoplot_plugin`` in tests), so modules need
no qgis import to log. ``uninstall`` removes it again (plugin unload).
"""

import logging

from qgis.core import Qgis, QgsMessageLog

TAB = "Monoplot"
#: Parent logger of every plugin module, whatever the folder is called when installed.
PACKAGE_LOGGER = __name__.rpartition(".")[0]


def qgis_level(levelno):
    """QGIS message level for a ``logging`` level number.

    >>> qgis_level(logging.ERROR) == Qgis.MessageLevel.Critical
    True
    """
    if levelno >= logging.ERROR:
        return Qgis.MessageLevel.Critical
    if levelno >= logging.WARNING:
        return Qgis.MessageLevel.Warning
    return Qgis.MessageLevel.Info


class QgsMessageLogHandler(logging.Handler):
    """Forwards log records to ``QgsMessageLog`` (thread-safe: QgsMessageLog queues across threads)."""

    def emit(self, record):
        try:
            QgsMessageLog.logMessage(self.format(record), TAB, qgis_level(record.levelno), notifyUser=False)
        except Exception:  # noqa: BLE001 — logging must never raise into the caller
            self.handleError(record)


def install(level=logging.INFO):
    """Attach the handler (idempotent) and return the package logger."""
    logger = logging.getLogger(PACKAGE_LOGGER)
    if not any(isinstance(h, QgsMessageLogHandler) for h in logger.handlers):
        handler = QgsMessageLogHandler()
        handler.setFormatter(logging.Formatter("%(name)s: %(message)s"))
        logger.addHandler(handler)
    logger.setLevel(level)
    return logger


def uninstall():
    """Remove the handlers added by :func:`install`."""
    logger = logging.getLogger(PACKAGE_LOGGER)
    for handler in [h for h in logger.handlers if isinstance(h, QgsMessageLogHandler)]:
        logger.removeHandler(handler)
