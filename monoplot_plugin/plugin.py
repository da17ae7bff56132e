"""The object QGIS loads: a Plugins-toolbar button and a Raster-menu entry that toggle Monoplot's dock.

The button goes on the Plugins toolbar because it is visible in a fresh profile; the Raster toolbar is not.

``unload()`` undoes everything ``initGui()``/``initProcessing()`` did, so that a plugin reload leaves nothing behind.
"""

import importlib
import importlib.util
import logging

from qgis.core import QgsApplication, QgsProject
from qgis.PyQt.QtCore import QCoreApplication, QFile, Qt, QTimer
from qgis.PyQt.QtGui import QIcon
from qgis.PyQt.QtWidgets import QAction

from . import PLUGIN_DIR, deps, logging_bridge

LOG = logging.getLogger(__name__)
#: Icon compiled from resources.qrc (resources_rc.py, made by `make resources`); the SVG file is the fallback.
ICON_RESOURCE = ":/plugins/monoplot/icons/monoplot.svg"
ICON_FILE = PLUGIN_DIR / "icons" / "monoplot.svg"
PROVIDER_MODULE = __name__.rpartition(".")[0] + ".processing.provider"


def plugin_icon_path():
    """``':/plugins/monoplot/icons/monoplot.svg'`` when the compiled resources are loaded, else the file path."""
    return ICON_RESOURCE if QFile.exists(ICON_RESOURCE) else str(ICON_FILE)


#: the warm-up starts this long after initGui (milliseconds); QGIS quitting waits for the step it is in
#: (gui/tasks.py keeps the task until its thread ends, also after the plugin's unload)
WARM_UP_DELAY_MS = 2000
#: Longest wait (milliseconds) in unload for the warm-up's current kernel compile (a cold cache: 3-12 s each)
UNLOAD_WARM_UP_WAIT_MS = 30000
#: Longest wait (seconds) at quit for a background import to end (torch: 3-5 s warm, 35 s on a cold disk).
QUIT_IMPORT_WAIT_S = 60.0


def start_warm_up():
    """Compile or load numba's kernels and import torch, OpenCV, SciPy in a background task (never the main thread),
    so the first Suggest, the first fit and a reopened project do not pay for it (``workflow/warmup.py``).
    Returns the task, or None when it could not start."""
    try:
        from .gui.tasks import HiddenTask, start_task
        from .workflow.warmup import import_plugin_modules, warm_up

        import_plugin_modules()  # here, on the main thread: the warm-up thread then imports none of them

        def done(result):
            if result.ok:
                LOG.info("Monoplot warmed up: %s", ", ".join(f"{k} {v:.1f} s" for k, v in result.value.items()))

        task = HiddenTask("Monoplot: preparing", lambda progress, is_canceled: warm_up(progress, is_canceled),
                            done)
        return start_task(task)
    except Exception:  # noqa: BLE001 — a warm-up is an optimisation, never a reason to fail loading
        LOG.exception("Monoplot warm-up not started")
        return None


class MonoplotPlugin:
    """QGIS plugin instance (created by the root ``classFactory``)."""

    def __init__(self, iface):
        self.iface = iface
        self.action = None
        self.dock = None
        self.provider = None
        self.menu = self.tr("&Monoplot")

    @staticmethod
    def tr(text):
        return QCoreApplication.translate("MonoplotPlugin", text)

    # --- Processing provider hook (monoplot_plugin/processing/provider.py, owned by the processing issue) ---
    def initProcessing(self):  # noqa: N802 (QGIS calls this name)
        """Register ``MonoplotProvider`` when that module exists; a broken provider is logged, never fatal."""
        if importlib.util.find_spec(PROVIDER_MODULE) is None:
            return
        try:
            provider_class = importlib.import_module(PROVIDER_MODULE).MonoplotProvider
            provider = provider_class()
            if QgsApplication.processingRegistry().addProvider(provider):
                self.provider = provider
            else:  # id already registered, or load() failed; QGIS has deleted our instance
                LOG.warning("Processing provider not registered: id %r already taken or its load() failed",
                            "monoplot")
        except Exception:  # noqa: BLE001 — e.g. a missing optional dependency must not block the GUI
            LOG.exception("Monoplot Processing provider could not be registered")
            self.provider = None

    def initGui(self):  # noqa: N802
        logging_bridge.install()
        self.action = QAction(QIcon(plugin_icon_path()), self.tr("Monoplot"), self.iface.mainWindow())
        self.action.setObjectName("MonoplotAction")
        self.action.setToolTip(self.tr("Monoplot: georeference an oblique photograph against a DEM"))
        self.action.setCheckable(True)
        self.action.toggled.connect(self.toggle_dock)
        self.iface.addToolBarIcon(self.action)
        self.iface.addPluginToRasterMenu(self.menu, self.action)
        self.initProcessing()
        # a project with Monoplot work opens the dock, which rebuilds its layers (a camera, a footprint and the
        # features drawn on the photo are memory layers: before the dock was opened they stayed empty)
        QgsProject.instance().readProject.connect(self._project_read)
        QgsApplication.instance().aboutToQuit.connect(self._quitting)
        self.dependency_notice = deps.notify_missing(self.iface)
        if QgsProject.instance().fileName():
            # a reload mid-session (the plugin manager's update, Plugin Reloader): the dock comes back for a project
            # with Monoplot work, as when that project is opened (a trial: it stayed closed until clicked)
            QTimer.singleShot(0, self._project_read)
        elif hasattr(self.iface, "initializationCompleted"):
            # once QGIS has started (a project named on its command line is open by then): opened during the start,
            # the restored work made the start's new project "modified", QGIS asked whether to save it before
            # anything showed, and "Discard" there would have thrown the work away
            self.iface.initializationCompleted.connect(self._open_on_crashed_work)
        self.warmup_task = None
        if self.dependency_notice is None:  # a moment after start-up, so that a quick reload starts nothing
            self._warmup_timer = QTimer()
            self._warmup_timer.setSingleShot(True)
            self._warmup_timer.timeout.connect(self._start_warm_up)
            self._warmup_timer.start(WARM_UP_DELAY_MS)

    def _start_warm_up(self):
        self.warmup_task = start_warm_up()

    @staticmethod
    def _quitting():
        """QGIS quits: a library import still under way in the background (torch, seconds at start-up) is waited
        for; Python shut down under it and QGIS crashed on quit (a trial: 3 of 16 quits in the first seconds)."""
        from .workflow.warmup import finish_imports

        finish_imports(QUIT_IMPORT_WAIT_S)

    def _open_on_crashed_work(self):
        """A session that ended without QGIS closing its never-saved project (a crash) left Monoplot work: the dock
        opens and takes it back, saying so (a re-check trial: nothing at start said the work was waiting; it came
        back only if the person happened to open the dock on an empty project)."""
        if self.dock is not None or self.action is None or QgsProject.instance().fileName():
            return
        try:
            from .gui.persistence import unsaved_work_left

            waiting = unsaved_work_left(QgsProject.instance())
        except Exception:  # noqa: BLE001 — a start-up nicety must never break the plugin's start
            LOG.exception("Monoplot could not look for work left by a crash")
            return
        if waiting:
            self.action.setChecked(True)

    def _project_read(self, *args):
        if self.dock is not None or self.action is None:
            return  # the dock restores the project itself
        from .gui.persistence import KEY, SCOPE

        text, found = QgsProject.instance().readEntry(SCOPE, KEY, "")
        if found and text:
            self.action.setChecked(True)

    def toggle_dock(self, visible):
        """Show or hide the dock, creating it on first use (keeps QGIS start-up light)."""
        if self.dock is None:
            if not visible:
                return
            if deps.missing_requirements(deps.REQUIRED):
                # the dock cannot work without them: the notice with its Install button again (a project with
                # Monoplot work opened a Python error dialog, "No module named 'cv2'", instead)
                deps.dismiss(self.iface, self.dependency_notice)
                self.dependency_notice = deps.notify_missing(self.iface, deps.REQUIRED)
                self.action.blockSignals(True)
                self.action.setChecked(False)
                self.action.blockSignals(False)
                return
            from .gui.dock import MonoplotDock

            self.dock = MonoplotDock(self.iface, self.iface.mainWindow())
            self.iface.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, self.dock)
            self.dock.visibilityChanged.connect(self.action.setChecked)  # closing the dock unchecks the button
        self.dock.setVisible(visible)

    def unload(self):
        started = getattr(self.iface, "initializationCompleted", None)
        for signal, slot in ((QgsProject.instance().readProject, self._project_read),
                             (QgsApplication.instance().aboutToQuit, self._quitting),
                             (started, self._open_on_crashed_work)):
            if signal is None:
                continue
            try:
                signal.disconnect(slot)
            except (TypeError, RuntimeError):  # initGui did not run, or already disconnected
                pass
        timer = getattr(self, "_warmup_timer", None)
        if timer is not None:
            timer.stop()
            self._warmup_timer = None
        task, self.warmup_task = getattr(self, "warmup_task", None), None
        if task is not None:  # it stops after the kernel it compiles; wait for that
            from .gui.tasks import abandon

            abandon(task)
            # A reload deletes the plugin's modules from sys.modules and imports them again on the main thread
            # right after this: a warm-up still running would import the ones it needs next at the same time,
            # and either thread could find a module half-initialised (the Processing provider once failed to
            # import core/xyz/zbuffer in a reload 1 s after the warm-up began)
            try:
                task.waitForFinished(UNLOAD_WARM_UP_WAIT_MS)
            except RuntimeError:  # already deleted: it is over
                pass
        if self.dock is not None:
            self.dock.visibilityChanged.disconnect(self.action.setChecked)
            self.dock.unload()  # main-map markers, map tools, project signals (gui/dock.py)
            self.iface.removeDockWidget(self.dock)
            self.dock.deleteLater()
            self.dock = None
        if self.action is not None:
            self.iface.removeToolBarIcon(self.action)
            self.iface.removePluginRasterMenu(self.menu, self.action)
            self.action.deleteLater()
            self.action = None
        if self.provider is not None:
            QgsApplication.processingRegistry().removeProvider(self.provider)
            self.provider = None
            try:  # the project's layersAdded, watched once an output was loaded (processing/safe_sink.py)
                importlib.import_module(PROVIDER_MODULE.rpartition(".")[0] + ".safe_sink").stop_watching_added_layers()
            except Exception:  # noqa: BLE001 — a broken provider module was logged when it was registered
                pass
        deps.dismiss(self.iface, getattr(self, "dependency_notice", None))
        logging_bridge.uninstall()
