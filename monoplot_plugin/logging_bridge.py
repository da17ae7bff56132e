"""Python ``logging`` of the whole plugin shown in QGIS's Log Messages panel, tab "Monoplot".

Every module logs with ``logging.getLogger(__name__)`` (some core modules with ``logging.getLogger("monoplot")``);
:func:`install` attaches one handler to the loggers that hold them all: the plugin's package logger
(``monoplot.monoplot_plugin`` when installed in QGIS, ``monoplot_plugin`` in tests) and ``monoplot``, once each (a
record reaches one handler only), so modules need no qgis import to log. ``uninstall`` removes it again (plugin
unload). The dock logs its fits, suggestions and every message it shows (``gui/controller.py``).
"""

import logging

from qgis.core import Qgis, QgsMessageLog

TAB = "Monoplot"
#: Parent logger of every plugin module, whatever the folder is called when installed.
PACKAGE_LOGGER = __name__.rpartition(".")[0]
#: the loggers the handler goes on: "monoplot" (core's) and the package's, unless the package is under "monoplot"
ROOTS = tuple(dict.fromkeys(["monoplot"] + ([] if PACKAGE_LOGGER.startswith("monoplot.") else [PACKAGE_LOGGER])))


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
    for name in ROOTS:
        logger = logging.getLogger(name)
        if not any(isinstance(h, QgsMessageLogHandler) for h in logger.handlers):
            handler = QgsMessageLogHandler()
            handler.setFormatter(logging.Formatter("%(name)s: %(message)s"))
            logger.addHandler(handler)
        logger.setLevel(level)
    return logging.getLogger(PACKAGE_LOGGER)


def uninstall():
    """Remove the handlers added by :func:`install`."""
    for name in ROOTS:
        logger = logging.getLogger(name)
        for handler in [h for h in logger.handlers if isinstance(h, QgsMessageLogHandler)]:
            logger.removeHandler(handler)
