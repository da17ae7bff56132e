"""pip for QGIS's own Python without breaking it: pins of what is installed, a dry run, a refusal with the reason.

A plain ``pip install --user torch opencv-python-headless scipy numba`` resolves against nothing that QGIS has: on
Debian 12 it puts numpy 2.x in the user site, in front of the numpy 1.24 that GDAL's and QGIS's bindings are built
against, and ``osgeo.gdal_array`` stops importing. Here instead:

1. :func:`probe` asks the target interpreter (not this process: tests and scripts run in a venv) what it has;
2. :func:`constraint_lines` pins every installed distribution at its version (numpy, SciPy, GDAL, PyQt, ...), except
   a few pure-Python libraries that torch needs newer than old distributions ship (:data:`UPGRADABLE`): those may be
   upgraded, never downgraded; pip then chooses the releases of torch, OpenCV, numba, SciPy compatible with the pins;
3. :func:`install_arguments` adds PyTorch's CPU index where PyPI's torch is the CUDA build (Linux, Windows);
   ``MONOPLOT_TORCH_INDEX`` overrides it (a mirror's URL, or empty for pip's own configuration only);
4. the dry run (``pip install --dry-run --report``) is checked by :func:`refusal`: a change of numpy or of any other
   installed package outside :data:`UPGRADABLE` stops the install, with the reason.

No Qt here: ``deps.PipInstaller`` runs the same arguments in a ``QProcess``; :func:`install` is the blocking form.
"""

import json
import os
import re
import subprocess
import sys
import tempfile
from collections import namedtuple

TORCH_CPU_INDEX = "https://download.pytorch.org/whl/cpu"
TORCH_INDEX_ENV = "MONOPLOT_TORCH_INDEX"

#: Pure-Python dependencies of torch that Debian 12 ships too old (sympy 1.11, mpmath "0.0.0", setuptools 66) and
#: that QGIS does not import: may be upgraded in the user site (``>=`` installed); everything else is pinned ``==``.
UPGRADABLE = frozenset({"sympy", "mpmath", "networkx", "filelock", "fsspec", "typing-extensions", "setuptools",
                        # the same for dask[distributed] (the cluster batch): Debian 12 ships cloudpickle 2.2, toolz
                        # 0.12, which QGIS does not import either
                        "cloudpickle", "toolz", "partd", "locket", "zict", "tblib", "sortedcontainers"})

#: The optional cluster engine of the batch (``workflow/cluster.py``), as requirements.txt pins it; not needed for
#: anything else, so not in the Install button's list: ``install(CLUSTER_PACKAGES, python)`` adds it with the pins
#: above (it needs no numpy: it resolves under numpy 1.24 and 2.2 alike).
CLUSTER_PACKAGES = ("dask[distributed]==2026.8.0", "distributed==2026.8.0")

Target = namedtuple("Target", "python platform in_venv externally_managed distributions")
Target.__doc__ = """What :func:`probe` found: ``distributions`` maps a normalized name to ``(name, version)``."""

_PROBE = r"""
import importlib.metadata, json, os, sys, sysconfig
seen = {}
for dist in importlib.metadata.distributions():  # sys.path order: the first one is the one imported
    name = dist.metadata["Name"]
    if name and name not in seen:
        seen[name] = dist.version
stdlib = sysconfig.get_paths().get("stdlib", "")
json.dump({"platform": sys.platform, "in_venv": sys.prefix != sys.base_prefix,
           "externally_managed": os.path.exists(os.path.join(stdlib, "EXTERNALLY-MANAGED")),
           "distributions": sorted(seen.items())}, sys.stdout)
"""

# PEP 440 public version with an optional local part; Debian's odd ones ("0.0.0" is fine, "1.2~rc1" is not) skipped.
_VERSION = re.compile(r"^\d+(\.\d+)*((a|b|rc)\d+)?(\.post\d+)?(\.dev\d+)?(\+[A-Za-z0-9.]+)?$")


def normalize(name):
    """PEP 503 name: ``typing_extensions`` -> ``typing-extensions``."""
    return re.sub(r"[-_.]+", "-", name).lower()


def probe(python, env=None):
    """:class:`Target` of ``python`` run with ``env`` (e.g. a ``PYTHONUSERBASE``): platform, venv, distributions."""
    result = subprocess.run([python, "-c", _PROBE], capture_output=True, text=True, env=env, timeout=120,
                            check=True)
    data = json.loads(result.stdout)
    distributions = {normalize(name): (name, version) for name, version in data["distributions"]}
    return Target(python, data["platform"], data["in_venv"], data["externally_managed"], distributions)


def torch_index(platform, environ=None):
    """Index for torch: PyTorch's CPU index on Linux and Windows (PyPI's torch is the CUDA build there, several GB),
    none on macOS; ``MONOPLOT_TORCH_INDEX`` overrides (a mirror; empty: pip's configuration only).

    >>> torch_index("linux", {}), torch_index("darwin", {}), torch_index("win32", {"MONOPLOT_TORCH_INDEX": ""})
    ('https://download.pytorch.org/whl/cpu', None, None)
    """
    environ = os.environ if environ is None else environ
    if TORCH_INDEX_ENV in environ:
        return environ[TORCH_INDEX_ENV].strip() or None
    return None if platform == "darwin" else TORCH_CPU_INDEX


def constraint_lines(target, extra=()):
    """pip constraints: every installed distribution ``==`` its version, :data:`UPGRADABLE` ones ``>=``.

    >>> t = Target("py", "linux", False, False, {"numpy": ("numpy", "1.24.2"), "sympy": ("sympy", "1.11.1")})
    >>> constraint_lines(t, ["torch==2.13.0+cpu"])
    ['numpy==1.24.2', 'sympy>=1.11.1', 'torch==2.13.0+cpu']
    """
    lines = []
    for key, (name, version) in sorted(target.distributions.items()):
        if _VERSION.match(version):
            lines.append(f"{name}{'>=' if key in UPGRADABLE else '=='}{version}")
    return lines + list(extra)


def scheme_arguments(target):
    """``--user`` for a system Python on Linux/macOS (plus ``--break-system-packages`` under PEP 668)."""
    if target.in_venv or target.platform.startswith("win"):
        return []
    return ["--user"] + (["--break-system-packages"] if target.externally_managed else [])


def install_arguments(target, packages, constraints_file=None, extra_args=None, environ=None):
    """Arguments after the interpreter: ``-m pip install [scheme] [-c FILE] [--extra-index-url CPU] PACKAGES``.

    ``extra_args`` (e.g. ``--target DIR``) replace the scheme choice.
    """
    args = ["-m", "pip", "install"] + (list(extra_args) if extra_args else scheme_arguments(target))
    args += ["-c", str(constraints_file)] if constraints_file else []
    names = [getattr(p, "package", p) for p in packages]
    index = torch_index(target.platform, environ)
    if index and "torch" in names:
        args += ["--extra-index-url", index]
    return args + names


def write_constraints(target, folder, extra=()):
    path = os.path.join(folder, "monoplot-constraints.txt")
    with open(path, "w", encoding="utf-8") as handle:
        handle.write("# Monoplot: what QGIS's Python has stays as it is\n" + "\n".join(constraint_lines(target, extra))
                     + "\n")
    return path


def dry_run_arguments(arguments, report_file):
    return arguments + ["--dry-run", "--report", str(report_file)]


def planned_installs(report_file):
    """``[(name, version)]`` that pip's ``--report`` would install."""
    with open(report_file, encoding="utf-8") as handle:
        report = json.load(handle)
    return [(item["metadata"]["name"], item["metadata"]["version"]) for item in report.get("install", [])]


def refusal(installs, target):
    """Why the planned ``installs`` must not happen (``None`` when they may).

    >>> t = Target("py", "linux", False, False, {"numpy": ("numpy", "1.24.2"), "sympy": ("sympy", "1.11.1")})
    >>> refusal([("torch", "2.13.0"), ("sympy", "1.14.0")], t) is None
    True
    >>> refusal([("numpy", "2.4.6"), ("cv2", "5.0")], t)
    "pip would replace numpy 1.24.2 by 2.4.6 in QGIS's Python (py): QGIS and GDAL are built against it"
    """
    changes = []
    for name, version in installs:
        installed = target.distributions.get(normalize(name))
        if installed and installed[1] != version and normalize(name) not in UPGRADABLE:
            changes.append(f"{installed[0]} {installed[1]} by {version}")
    if not changes:
        return None
    return (f"pip would replace {', '.join(changes)} in QGIS's Python ({target.python}): QGIS and GDAL are built "
            "against it")


def pip_failure(output):
    r"""Why pip failed, from its output: its first ``ERROR:`` line and the conflict it names, else the last line.

    >>> pip_failure("x\nERROR: Cannot install torch\n\nThe conflict is caused by:\n    torch depends on a>=2\n"
    ...             "    The user requested (constraint) a==1\n\nTo fix\nERROR: ResolutionImpossible")
    'Cannot install torch: torch depends on a>=2; The user requested (constraint) a==1'
    """
    lines = [line.strip() for line in output.splitlines()]
    errors = [line[len("ERROR: "):] for line in lines if line.startswith("ERROR: ")]
    if not errors:
        return next((line for line in reversed(lines) if line), "")
    if "The conflict is caused by:" in lines:
        start = lines.index("The conflict is caused by:") + 1
        conflict = lines[start:lines.index("", start) if "" in lines[start:] else None]
        return errors[0].rstrip(".") + ": " + "; ".join(conflict)
    return errors[0]


def dry_run_failure(output):
    r"""What to tell the user when the dry run failed.

    >>> dry_run_failure("Usage: ...\nno such option: --dry-run")
    "pip is too old for a dry run (needs 22.2): upgrade pip in QGIS's Python first"
    """
    if "no such option: --dry-run" in output or "no such option: --report" in output:
        return "pip is too old for a dry run (needs 22.2): upgrade pip in QGIS's Python first"
    return "pip found no versions compatible with QGIS's packages: " + pip_failure(output)


Outcome = namedtuple("Outcome", "ok detail installs output")


def install(packages, python, env=None, extra_args=None, extra_constraints=(), dry_run_only=False):
    """Blocking: probe, pin, dry run, refuse or install ``packages`` into ``python``; returns :class:`Outcome`."""
    target = probe(python, env)
    with tempfile.TemporaryDirectory(prefix="monoplot-pip-") as folder:
        constraints = write_constraints(target, folder, extra_constraints)
        arguments = install_arguments(target, packages, constraints, extra_args, env)
        report_file = os.path.join(folder, "report.json")
        run = subprocess.run([python] + dry_run_arguments(arguments, report_file), capture_output=True, text=True,
                             env=env)
        output = run.stdout + run.stderr
        if run.returncode != 0:
            return Outcome(False, dry_run_failure(output), [], output)
        installs = planned_installs(report_file)
        reason = refusal(installs, target)
        if reason or dry_run_only:
            return Outcome(reason is None, reason or "dry run", installs, output)
        run = subprocess.run([python] + arguments, capture_output=True, text=True, env=env)
        output += run.stdout + run.stderr
        ok = run.returncode == 0
        return Outcome(ok, "installed" if ok else "pip failed: " + pip_failure(output), installs, output)


if __name__ == "__main__":  # python -m monoplot_plugin.deps_pins [--dry-run] PACKAGE...
    dry = "--dry-run" in sys.argv
    outcome = install([a for a in sys.argv[1:] if a != "--dry-run"], sys.executable, dry_run_only=dry)
    print("\n".join(f"{n} {v}" for n, v in outcome.installs))
    print(outcome.detail)
    sys.exit(0 if outcome.ok else 1)
