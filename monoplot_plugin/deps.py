"""Python dependencies of Monoplot: detect missing ones without importing them, tell the user, install with pip.

Missing packages are never a crash: the plugin loads, a message-bar warning names them with the exact pip command
for QGIS's own interpreter, and its "Install" button runs that command in the background (``QProcess``).

``python -m monoplot_plugin.deps`` prints a dependency report (used by ``make demo``).
"""

import importlib
import importlib.util
import logging
import os
import shlex
import subprocess
import sys
import sysconfig
import tempfile
from collections import namedtuple
from pathlib import Path

from qgis.core import Qgis, QgsApplication
from qgis.PyQt.QtCore import QObject, QProcess, QProcessEnvironment, pyqtSignal
from qgis.PyQt.QtWidgets import QProgressBar, QPushButton

from . import deps_pins

LOG = logging.getLogger(__name__)

#: ``module`` is what the code imports, ``package`` what pip installs.
Requirement = namedtuple("Requirement", "module package")
REQUIRED = (
    Requirement("torch", "torch"),
    Requirement("cv2", "opencv-python-headless"),
    Requirement("scipy", "scipy"),
    Requirement("numba", "numba"),
)


def missing_requirements(required=REQUIRED):
    """Requirements whose module cannot be found (``find_spec``: nothing heavy is imported).

    >>> missing_requirements([Requirement("os", "os"), Requirement("surely_absent_pkg_x", "surely-absent")])
    [Requirement(module='surely_absent_pkg_x', package='surely-absent')]
    """
    importlib.invalidate_caches()
    missing = []
    for requirement in required:
        try:
            found = importlib.util.find_spec(requirement.module) is not None
        except (ImportError, ValueError):  # broken half-installed package
            found = False
        if not found:
            missing.append(requirement)
    return missing


def _looks_like_python(path):
    name = Path(path).name.lower()
    return name.startswith("python") and not name.startswith("pythonw")


def _inside(path, folder):
    """True when ``path``'s folder lies in ``folder``: rejects e.g. a pyenv shim found on PATH.

    The file itself is not resolved: a venv's ``bin/python`` is a symlink out of the venv.
    """
    here, folder = os.path.realpath(os.path.dirname(path)), os.path.realpath(folder)
    try:
        return os.path.commonpath([here, folder]) == folder
    except ValueError:  # different drives on Windows
        return False


def qgis_python_executable(executable=None, platform=None, prefix=None, exists=os.path.exists):
    """Path of the Python interpreter that QGIS embeds (inside QGIS ``sys.executable`` is the qgis binary).

    - already a python of this installation (scripts, tests, venvs): ``executable`` itself (embedded Python may
      report an unrelated ``python3`` found on PATH, e.g. a pyenv shim: that one is skipped);
    - Windows OSGeo4W / standalone: ``python3.exe``/``python.exe`` next to ``qgis-bin.exe`` or in ``sys.prefix``;
    - macOS bundle: ``QGIS.app/Contents/MacOS/bin/python3``;
    - Linux: ``<prefix>/bin/python3.X`` (``/usr/bin/python3.11`` for Debian's QGIS).

    >>> qgis_python_executable("/usr/bin/qgis", "linux", "/usr", exists=lambda p: p == "/usr/bin/python3")
    '/usr/bin/python3'
    """
    executable = sys.executable if executable is None else executable
    platform = sys.platform if platform is None else platform
    prefix = sys.prefix if prefix is None else prefix
    if executable and _looks_like_python(executable) and _inside(executable, prefix):
        return executable  # a python of this installation (a venv's lies inside its prefix too)
    here = os.path.dirname(executable or "")
    version = f"{sys.version_info.major}.{sys.version_info.minor}"
    if platform.startswith("win"):
        candidates = [os.path.join(d, n) for d in (here, prefix) for n in ("python3.exe", "python.exe")]
    elif platform == "darwin":
        candidates = [os.path.join(here, "bin", "python3"), os.path.join(here, "bin", f"python{version}"),
                      os.path.join(prefix, "bin", "python3")]
    else:
        candidates = [os.path.join(prefix, "bin", f"python{version}"), os.path.join(prefix, "bin", "python3"),
                      "/usr/bin/python3"]
    for candidate in candidates:
        if exists(candidate):
            return candidate
    return "python3"


def local_target(python=None):
    """:class:`deps_pins.Target` of this process (inside QGIS: QGIS's Python), without starting a subprocess."""
    import importlib.metadata

    stdlib = sysconfig.get_paths().get("stdlib", "")
    distributions = {}
    for dist in importlib.metadata.distributions():
        name = dist.metadata["Name"]
        if name and deps_pins.normalize(name) not in distributions:
            distributions[deps_pins.normalize(name)] = (name, dist.version)
    return deps_pins.Target(python or qgis_python_executable(), sys.platform, sys.prefix != sys.base_prefix,
                            os.path.exists(os.path.join(stdlib, "EXTERNALLY-MANAGED")), distributions)


def pip_command_line(packages, python=None, extra_args=(), target=None):
    """The command a user can paste in a shell (quoted for this platform): the missing packages plus QGIS's own
    numpy (and SciPy) at their installed versions, so that pip chooses releases compatible with them.

    The Install button does more (every installed package pinned, a dry run first): :class:`PipInstaller`.
    """
    target = target or local_target(python)
    names = [r.package if isinstance(r, Requirement) else str(r) for r in packages]
    keep = [f"{target.distributions[key][0]}=={target.distributions[key][1]}" for key in ("numpy", "scipy")
            if key in target.distributions and key not in names]
    command = [target.python] + deps_pins.install_arguments(target, names, None, extra_args) + keep
    return subprocess.list2cmdline(command) if sys.platform.startswith("win") else shlex.join(command)


def report(required=REQUIRED):
    """One line per requirement: version if importable, else MISSING. Imports the packages (slow: not at load)."""
    lines = []
    for requirement in required:
        try:
            module = importlib.import_module(requirement.module)
            lines.append(f"{requirement.package:24s} {getattr(module, '__version__', '?')}")
        except ImportError as error:
            lines.append(f"{requirement.package:24s} MISSING ({error})")
    return lines


# --- QGIS side: message bar + background pip -------------------------------------------------------------------

def notify_missing(iface, required=REQUIRED, extra_pip_args=()):
    """Warn in ``iface.messageBar()`` about missing packages; returns the bar item (``None`` when all present).

    The item has an "Install" button that starts :class:`PipInstaller`; the item is kept on the returned
    object's ``installer`` attribute so that tests can wait for it.
    """
    missing = missing_requirements(required)
    if not missing:
        return None
    tr = lambda text: QgsApplication.translate("MonoplotDeps", text)  # noqa: E731
    names = ", ".join(r.package for r in missing)
    command = pip_command_line(missing, extra_args=extra_pip_args)
    bar = iface.messageBar()
    item = bar.createMessage(tr("Monoplot"), tr("Missing Python packages: {0}. Click Install, or run: {1}")
                             .format(names, command))
    button = QPushButton(tr("Install"), item)
    button.setObjectName("MonoplotInstallButton")
    item.layout().addWidget(button)
    item.installer = PipInstaller(missing, extra_pip_args, required, parent=bar)
    button.clicked.connect(lambda: item.installer.start(iface, item))
    bar.pushWidget(item, Qgis.MessageLevel.Warning)
    LOG.warning("Missing Python packages: %s. Install them with: %s", names, command)
    return item


def dismiss(iface, item):
    """Remove a bar item made by :func:`notify_missing` (plugin unload); ignores ``None``/deleted items."""
    if item is None:
        return
    try:
        iface.messageBar().popWidget(item)
    except RuntimeError:  # already closed by the user: the C++ object is gone
        pass


class PipInstaller(QObject):
    """Runs pip for QGIS's interpreter in a ``QProcess``: a dry run against pins of everything QGIS's Python has
    (:mod:`.deps_pins`), a refusal with the reason if numpy or another installed package would change, else the
    install. Shows a busy progress bar, then the result.

    ``succeeded`` is ``None`` while running, then ``True``/``False``; ``output`` holds pip's stdout+stderr,
    ``installs`` the ``(name, version)`` pairs of the dry run. ``python``/``environment`` (default: QGIS's
    interpreter, this process' environment) and ``extra_constraints`` (pip constraint lines) are for tests.
    """

    finished = pyqtSignal(bool)

    def __init__(self, missing, extra_args=(), required=REQUIRED, parent=None, python=None, environment=None,
                 extra_constraints=()):
        super().__init__(parent)
        self.missing, self.extra_args, self.required = list(missing), list(extra_args), required
        self.python = python or qgis_python_executable()
        self.environment, self.extra_constraints = environment, list(extra_constraints)
        self.process = None
        self.succeeded = None
        self.output = ""
        self.installs = []

    def start(self, iface, notice=None):
        if self.process is not None:
            return  # already running (double click)
        self.iface = iface
        bar = iface.messageBar()
        if notice is not None:
            dismiss(iface, notice)
        self.progress_item = bar.createMessage(self.tr("Monoplot"), self.tr(
            "Checking which versions of {0} suit QGIS's Python…").format(self._names()))
        progress = QProgressBar(self.progress_item)
        progress.setRange(0, 0)  # busy indicator: pip gives no reliable percentage
        progress.setObjectName("MonoplotInstallProgress")
        self.progress_item.layout().addWidget(progress)
        bar.pushWidget(self.progress_item, Qgis.MessageLevel.Info)
        self.folder = tempfile.TemporaryDirectory(prefix="monoplot-pip-")
        try:
            self.target = deps_pins.probe(self.python, self.environment)
        except (OSError, ValueError, subprocess.SubprocessError) as error:
            self._report(False, self.tr("could not run {0}: {1}").format(self.python, error))
            return
        constraints = deps_pins.write_constraints(self.target, self.folder.name, self.extra_constraints)
        self.arguments = deps_pins.install_arguments(self.target, self.missing, constraints, self.extra_args,
                                                     self.environment)
        self.report_file = os.path.join(self.folder.name, "report.json")
        self._run(deps_pins.dry_run_arguments(self.arguments, self.report_file), self._dry_run_finished)

    def _names(self):
        return ", ".join(r.package for r in self.missing)

    def _run(self, arguments, on_finished):
        self.process = QProcess(self)
        self.process.setProcessChannelMode(QProcess.ProcessChannelMode.MergedChannels)
        if self.environment is not None:
            environment = QProcessEnvironment()
            for key, value in self.environment.items():
                environment.insert(key, value)
            self.process.setProcessEnvironment(environment)
        self.process.finished.connect(on_finished)
        self.process.errorOccurred.connect(self._failed_to_start)
        LOG.info("Running %s", shlex.join([self.python] + arguments))
        self.process.start(self.python, arguments)

    def _read(self):
        self.output += bytes(self.process.readAll()).decode("utf-8", "replace")

    def _failed_to_start(self, error):
        if error == QProcess.ProcessError.FailedToStart:
            self._report(False, self.tr("could not start {0}").format(self.python))

    def _dry_run_finished(self, exit_code, _status):
        self._read()
        if exit_code != 0:
            self._report(False, self.tr("not installed, {0}").format(deps_pins.dry_run_failure(self.output)))
            return
        self.installs = deps_pins.planned_installs(self.report_file)
        reason = deps_pins.refusal(self.installs, self.target)
        if reason:
            self._report(False, self.tr("not installed: {0}").format(reason))
            return
        self.progress_item.setText(self.tr("Installing {0} with pip…").format(
            ", ".join(f"{name} {version}" for name, version in self.installs)))
        self._run(self.arguments, self._finished)

    def _finished(self, exit_code, _status):
        self._read()
        still_missing = missing_requirements(self.required) if exit_code == 0 else self.missing
        if exit_code == 0 and still_missing and not self.extra_args:
            detail = self.tr("installed; restart QGIS to use them")
        elif exit_code == 0:
            detail = self.tr("installed")
        else:
            detail = self.tr("pip failed (exit code {0}): {1}").format(exit_code, deps_pins.pip_failure(self.output))
        self._report(exit_code == 0, detail)

    def _report(self, ok, detail):
        if self.succeeded is not None:
            return
        self.succeeded = ok
        dismiss(self.iface, self.progress_item)
        self.folder.cleanup()
        self.iface.messageBar().pushMessage(
            self.tr("Monoplot"), f"{self._names()}: {detail}",
            Qgis.MessageLevel.Success if ok else Qgis.MessageLevel.Critical, 0 if not ok else 10)
        (LOG.info if ok else LOG.error)("pip install %s: %s\n%s", self._names(), detail, self.output)
        self.finished.emit(ok)


def main():
    """Print the plugin version, QGIS version and the dependency report (``make demo`` until the pipeline lands)."""
    from . import plugin_version

    print(f"Monoplot {plugin_version()}")
    print(f"QGIS {Qgis.QGIS_VERSION}, Python {sys.version.split()[0]} ({sys.executable})")
    for line in report():
        print("  " + line)
    missing = missing_requirements()
    if missing:
        print("Install the missing ones with:", pip_command_line(missing))
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
