"""The Install button for real: torch, OpenCV, SciPy, numba resolved and installed by pip into a throwaway user site
of QGIS's own Python (Debian's /usr/bin/python3, the one the desktop QGIS runs), then osgeo.gdal_array, qgis.core
and the plugin imported from it, and QGIS's numpy the same before and after.

Minutes of pip: run by ``make test-installer`` and ``make test-qgis340`` (both in CI), skipped by ``make test``.
pip is configured as on the machine (its indexes, local folders, cache); PyTorch's CPU index is replaced by pip's
own configuration unless MONOPLOT_TORCH_INDEX is set (CI reaches only the package registries), and torch is the
release the venv has (a CPU build there).
"""

import importlib.metadata
import json
import os
import subprocess
from pathlib import Path

import pytest
from qgis.core import Qgis

from monoplot_plugin import deps, deps_pins

ROOT = Path(__file__).resolve().parent.parent
QGIS_PYTHON = "/usr/bin/python3"

pytestmark = pytest.mark.skipif(not os.environ.get("MONOPLOT_INSTALLER_TEST"),
                                reason="minutes of pip: make test-installer (MONOPLOT_INSTALLER_TEST=1)")

STATE = r"""
import importlib.util, json, sys
import numpy
state = {"numpy": numpy.__version__, "numpy_file": numpy.__file__,
         "missing": [m for m in ("torch", "cv2", "scipy", "numba") if importlib.util.find_spec(m) is None]}
if len(sys.argv) > 1:  # after the install: everything QGIS and the plugin import, from the user site
    from osgeo import gdal_array
    state["gdal_array_sum"] = float(gdal_array.OpenArray(numpy.arange(6.0).reshape(2, 3)).ReadAsArray().sum())
    from qgis.core import QgsApplication, QgsRasterLayer
    app = QgsApplication([], False)
    app.initQgis()
    state["dem_valid"] = QgsRasterLayer(sys.argv[2], "dem").isValid()
    sys.path.insert(0, sys.argv[1])
    import pkgutil, importlib
    import monoplot_plugin.core as core
    from monoplot_plugin import deps
    state["core_modules"] = [importlib.import_module(m.name).__name__
                             for m in pkgutil.walk_packages(core.__path__, "monoplot_plugin.core.")]
    state["missing_after"] = [r.package for r in deps.missing_requirements()]
    import cv2, numba, scipy, torch
    state["versions"] = {m.__name__: m.__version__ for m in (cv2, numba, scipy, torch)}
    state["files"] = {m.__name__: m.__file__ for m in (cv2, numba, scipy, torch)}
    state["orb"] = len(cv2.ORB_create().detect((numpy.random.default_rng(0).random((64, 64)) * 255)
                                               .astype(numpy.uint8), None)) >= 0
    state["njit"] = float(numba.njit(lambda a: a.sum())(numpy.arange(4.0)))
    state["numpy_after_imports"] = numpy.__version__
print(json.dumps(state))
"""


def qgis_python_state(env, *args):
    result = subprocess.run([QGIS_PYTHON, "-c", STATE, *map(str, args)], env=env, capture_output=True, text=True,
                            timeout=600, cwd="/")
    assert result.returncode == 0, result.stderr[-4000:]
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_install_button_puts_compatible_packages_in_the_user_site_and_keeps_qgis_numpy(
        qgis_iface, qtbot, tmp_path, aletsch_dir):
    user_base = tmp_path / "userbase"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env.update(PYTHONUSERBASE=str(user_base), QT_QPA_PLATFORM="offscreen")
    env.setdefault(deps_pins.TORCH_INDEX_ENV, "")
    before = qgis_python_state(env)
    assert before["missing"], "QGIS's Python already has everything: nothing to test"
    missing = [r for r in deps.REQUIRED if r.module in before["missing"]]
    pins = [f"torch=={importlib.metadata.version('torch')}"] if "torch" in before["missing"] else []

    installer = deps.PipInstaller(missing, parent=qgis_iface.messageBar(), python=QGIS_PYTHON, environment=env,
                                  extra_constraints=pins)
    with qtbot.waitSignal(installer.finished, timeout=1_500_000) as result:
        installer.start(qgis_iface)
    assert result.args == [True], installer.output[-4000:]
    planned = {deps_pins.normalize(name) for name, _ in installer.installs}
    assert {deps_pins.normalize(r.package) for r in missing} <= planned
    assert "numpy" not in planned
    assert any("installed" in m for m in qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Success))

    after = qgis_python_state(env, ROOT, aletsch_dir / "dem.tif")
    assert (after["numpy"], after["numpy_file"]) == (before["numpy"], before["numpy_file"])
    assert after["numpy_after_imports"] == before["numpy"]
    assert after["gdal_array_sum"] == 15.0 and after["dem_valid"]
    assert after["missing_after"] == []
    assert {"monoplot_plugin.core.camera"} <= set(after["core_modules"]), after["core_modules"]
    for module in before["missing"]:
        assert after["files"][module].startswith(str(user_base)), after["files"]
    assert after["orb"] and after["njit"] == 6.0
    print(json.dumps({"installed": installer.installs, "versions": after["versions"]}))
