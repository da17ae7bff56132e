"""Run Monoplot's algorithms with the ``qgis_process`` binary, from a source checkout, headless.

What QGIS 3.22's ``qgis_process`` needs to see a plugin's provider:

- the plugin folder, named ``monoplot``, in a directory listed in ``QGIS_PLUGINPATH`` (here a symbolic link to the
  checkout, in a scratch directory);
- the plugin enabled in the profile's settings (``[PythonPlugins] monoplot=true`` in ``QGIS3.ini``) and its
  metadata saying ``hasProcessingProvider=yes``; ``qgis_process`` then imports it and calls ``initProcessing()``.
  An isolated profile (``QGIS_CUSTOM_CONFIG_PATH``) keeps the user's own QGIS settings untouched;
- the Python packages of the venv (torch, OpenCV): ``qgis_process`` embeds the system Python, so the venv's
  site-packages go on ``PYTHONPATH``;
- ``QT_QPA_PLATFORM=offscreen`` without a display.

Debian's ``/usr/bin/qgis_process`` wrapper passes ``$QGIS_OPTS`` from ``/etc/default/qgis`` (``--noversioncheck``),
which ``qgis_process.bin`` 3.22 rejects ("Command --noversioncheck not known!"), so the binary is called directly.

Usage from a shell (prints the environment to export, then runs)::

    python -m monoplot_plugin.processing.cli run monoplot:fitcamera -- PHOTO=photo.jpg DEM=dem.tif ...

(or export the environment of :func:`prepare_environment` and call ``qgis_process.bin`` yourself). SIGINT (Ctrl+C),
SIGTERM and SIGHUP are forwarded to ``qgis_process``, and the helper waits for it: the algorithm cancels, and the
earlier output stays as it was.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path
from typing import Dict, List, Optional, Sequence

REPO_ROOT = Path(__file__).resolve().parents[2]
PLUGIN_NAME = "monoplot"


def qgis_process_binary() -> str:
    """Path of the qgis_process executable (the Debian ``.bin`` behind the wrapper when present)."""
    for name in ("qgis_process.bin", "qgis_process"):
        for folder in ("/usr/bin", "/usr/local/bin"):
            candidate = os.path.join(folder, name)
            if os.access(candidate, os.X_OK):
                return candidate
        found = shutil.which(name)
        if found:
            return found
    raise FileNotFoundError("qgis_process not found: install QGIS (Debian: apt install qgis)")


def prepare_environment(work_dir: Optional[str] = None, plugin_dir: Path = REPO_ROOT) -> Dict[str, str]:
    """Environment variables under which ``qgis_process`` loads the Monoplot provider from ``plugin_dir``.

    Creates ``<work_dir>/plugins/monoplot`` (a link to the checkout) and an isolated profile in
    ``<work_dir>/profile`` with the plugin enabled. The default work folder is the same for every run of one user
    and checkout, so that numba's compiled kernels (cached per source path) are compiled once, not on every run.
    """
    if not work_dir:
        import hashlib

        tag = hashlib.sha1(str(Path(plugin_dir).resolve()).encode()).hexdigest()[:8]
        work_dir = os.path.join(tempfile.gettempdir(), f"monoplot-qgis-{os.getuid()}-{tag}")
    work = Path(work_dir)
    plugins = work / "plugins"
    plugins.mkdir(parents=True, exist_ok=True)
    link = plugins / PLUGIN_NAME
    if link.is_symlink() and link.resolve() != Path(plugin_dir).resolve():
        link.unlink()
    if not link.exists():
        link.symlink_to(Path(plugin_dir).resolve(), target_is_directory=True)
    profile = work / "profile"
    ini = profile / "profiles" / "default" / "QGIS" / "QGIS3.ini"
    ini.parent.mkdir(parents=True, exist_ok=True)
    text = ini.read_text(encoding="utf-8") if ini.exists() else ""
    if f"{PLUGIN_NAME}=true" not in text:
        with open(ini, "a", encoding="utf-8") as fh:
            fh.write(f"\n[PythonPlugins]\n{PLUGIN_NAME}=true\n")
    env = dict(os.environ)
    site = sysconfig.get_paths()["purelib"]  # the venv's site-packages when run with .venv/bin/python
    env.update({
        "QGIS_PLUGINPATH": str(plugins),
        "QGIS_CUSTOM_CONFIG_PATH": str(profile),
        "QT_QPA_PLATFORM": env.get("QT_QPA_PLATFORM", "offscreen"),
        "PYTHONPATH": os.pathsep.join(p for p in (site, env.get("PYTHONPATH", "")) if p),
        "XDG_RUNTIME_DIR": env.get("XDG_RUNTIME_DIR", str(work / "runtime")),
        # numba's on-disk cache records the module name of each compiled function; inside QGIS the package is
        # "monoplot.monoplot_plugin", in a checkout "monoplot_plugin": they must not share a cache folder
        "NUMBA_CACHE_DIR": os.path.join(tempfile.gettempdir(), f"monoplot-numba-qgis-{os.getuid()}"),
    })
    Path(env["XDG_RUNTIME_DIR"]).mkdir(parents=True, exist_ok=True, mode=0o700)
    return env


def parameter_arguments(parameters: Dict[str, object]) -> List[str]:
    """``NAME=value`` arguments, to follow qgis_process's ``--`` separator (lists repeat the parameter; booleans
    as true/false).

    >>> parameter_arguments({"DEM": "dem.tif", "PAIRED": False, "LAYERS": ["a", "b"]})
    ['DEM=dem.tif', 'PAIRED=false', 'LAYERS=a', 'LAYERS=b']
    """
    args = []
    for name, value in parameters.items():
        values = value if isinstance(value, (list, tuple)) else [value]
        for v in values:
            if isinstance(v, bool):
                v = "true" if v else "false"
            args.append(f"{name}={v}")
    return args


class QgisProcessError(RuntimeError):
    """qgis_process failed; the message holds its output."""


def run(algorithm: str, parameters: Dict[str, object], env: Dict[str, str], timeout: float = 300) -> dict:
    """Run ``qgis_process --json run <algorithm> -- params``; returns the parsed JSON (``results`` etc.).

    Raises QgisProcessError with qgis_process's own messages when it fails.
    """
    command = [qgis_process_binary(), "--json", "run", algorithm, "--", *parameter_arguments(parameters)]
    proc = subprocess.run(command, env=env, capture_output=True, text=True, timeout=timeout)
    start = proc.stdout.find("{")
    if proc.returncode != 0 or start < 0:
        raise QgisProcessError(f"qgis_process run {algorithm} failed (exit {proc.returncode}):\n"
                               f"{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout[start:])


FORWARDED_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def call_forwarding_signals(command: Sequence[str], env: Dict[str, str]) -> int:
    """Run ``command`` and wait for it; SIGINT, SIGTERM and SIGHUP sent to this process are passed on to it (the
    algorithm inside cancels and leaves earlier outputs as they were), and this process waits until it has ended.

    Returns:
        its exit code; 128 + n when it was killed by signal n (the shell's convention).
    """
    # The handlers go in before the child starts: a signal that lands while it starts (the child may already be
    # running and talking) is kept and passed on as soon as it exists, not lost or left to the default action.
    child = None
    early = []

    def forward(signum, frame):
        if child is None:
            early.append(signum)
        elif child.poll() is None:
            try:
                child.send_signal(signum)
            except ProcessLookupError:
                pass

    previous = {}
    for signum in FORWARDED_SIGNALS:
        try:
            previous[signum] = signal.signal(signum, forward)
        except (ValueError, OSError):  # not the main thread
            pass
    try:
        child = subprocess.Popen(list(command), env=env)
        for signum in early:
            forward(signum, None)
        # Never one blocking wait: a signal landing just before the process blocks in waitpid() would only run
        # its Python handler after the child had ended on its own. Short waits run the handler within 0.05 s.
        code = None
        while code is None:
            try:
                code = child.wait(timeout=1.0)
            except subprocess.TimeoutExpired:
                pass
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    return 128 - code if code < 0 else code


def foreign_python() -> str:
    """A sentence when this Python is not the one QGIS embeds (its packages cannot load in qgis_process, which
    then fails with "Couldn't load SIP module"); "" when it is."""
    if sys.platform.startswith("linux") and os.path.realpath(sys.base_prefix) != "/usr" and \
            os.path.isdir("/usr/lib/python3/dist-packages/qgis"):
        return (f"this Python ({sys.executable}, {sys.version.split()[0]}) is not the system's, which QGIS embeds: "
                f"run the helper with /usr/bin/python3 or with the project's .venv/bin/python (made from it)")
    return ""


def main(argv: Sequence[str]) -> int:
    """``python -m monoplot_plugin.processing.cli <qgis_process arguments>``: same arguments as qgis_process."""
    problem = foreign_python()
    if problem:
        print(f"monoplot: {problem}", file=sys.stderr)
        return 2
    env = prepare_environment(os.environ.get("MONOPLOT_QGIS_WORK"))
    return call_forwarding_signals([qgis_process_binary(), *argv], env)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
