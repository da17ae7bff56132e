"""Missing Python packages: detected, reported with the right pip command, installed by the "Install" button.

The install tests run real pip (QProcess) on a real wheel built here, from a local folder, into a temporary
``--target``: no network, nothing installed into the venv.
"""

import base64
import hashlib
import importlib.metadata
import os
import sys
import zipfile

import pytest
from qgis.core import Qgis
from qgis.PyQt.QtWidgets import QProgressBar, QPushButton

from monoplot_plugin import deps, deps_pins
from monoplot_plugin.deps import Requirement

ABSENT = Requirement("monoplot_test_tinypkg", "monoplot-test-tinypkg")


def build_wheel(folder, name="monoplot_test_tinypkg", version="1.0"):
    """A minimal valid pure-Python wheel (PEP 427) with one module ``name`` defining ``ANSWER = 42``."""
    dist_info = f"{name}-{version}.dist-info"
    files = {
        f"{name}/__init__.py": b"ANSWER = 42\n",
        f"{dist_info}/METADATA": f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n".encode(),
        f"{dist_info}/WHEEL": b"Wheel-Version: 1.0\nGenerator: monoplot-tests\nRoot-Is-Purelib: true\nTag: py3-none-any\n",
    }
    record = []
    for path, data in files.items():
        digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        record.append(f"{path},sha256={digest},{len(data)}")
    record.append(f"{dist_info}/RECORD,,")
    files[f"{dist_info}/RECORD"] = ("\n".join(record) + "\n").encode()
    wheel = folder / f"{name}-{version}-py3-none-any.whl"
    with zipfile.ZipFile(wheel, "w") as archive:
        for path, data in files.items():
            archive.writestr(path, data)
    return wheel


def test_missing_requirements_finds_really_absent_package_only():
    assert deps.missing_requirements(deps.REQUIRED + (ABSENT,)) == [ABSENT]  # the venv has torch, cv2, scipy, numba


def test_dependency_check_imports_nothing_heavy(monkeypatch):
    for name in ("torch", "cv2", "scipy", "numba"):
        monkeypatch.delitem(sys.modules, name, raising=False)  # put back afterwards: a half-removed cv2 breaks later imports
    before = set(sys.modules)
    deps.missing_requirements()
    assert not {"torch", "cv2", "scipy", "numba"} & (set(sys.modules) - before)


@pytest.mark.parametrize("platform, layout, expected", [
    ("win32", ["bin/qgis-bin.exe", "bin/python3.exe"], "bin/python3.exe"),  # OSGeo4W
    ("win32", ["bin/qgis-ltr-bin.exe", "apps/Python39/python.exe"], "apps/Python39/python.exe"),  # prefix
    ("darwin", ["QGIS.app/Contents/MacOS/QGIS", "QGIS.app/Contents/MacOS/bin/python3"],
     "QGIS.app/Contents/MacOS/bin/python3"),
    ("linux", ["usr/bin/qgis", f"usr/bin/python{sys.version_info[0]}.{sys.version_info[1]}"],
     f"usr/bin/python{sys.version_info[0]}.{sys.version_info[1]}"),
])
def test_qgis_python_executable_finds_the_interpreter_beside_qgis(tmp_path, platform, layout, expected):
    for relative in layout:
        (tmp_path / relative).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / relative).write_bytes(b"")
    prefix = {"win32": tmp_path / "apps/Python39", "darwin": tmp_path / "QGIS.app/Contents/Frameworks",
              "linux": tmp_path / "usr"}[platform]
    found = deps.qgis_python_executable(str(tmp_path / layout[0]), platform, str(prefix))
    assert found == str(tmp_path / expected)


def test_qgis_python_executable_keeps_a_real_python():
    assert deps.qgis_python_executable() == sys.executable  # tests run under .venv/bin/python
    assert os.access(deps.qgis_python_executable(), os.X_OK)


def test_qgis_python_executable_ignores_a_foreign_python_on_path(tmp_path):
    """Embedded in /usr/bin/qgis, sys.executable can be a pyenv shim: not the Python QGIS runs."""
    shim = tmp_path / "pyenv/shims/python3"
    system = tmp_path / "usr/bin/python3"
    for path in (shim, system):
        path.parent.mkdir(parents=True)
        path.write_bytes(b"")
    assert deps.qgis_python_executable(str(shim), "linux", str(tmp_path / "usr")) == str(system)


def test_pip_command_names_interpreter_pip_packages_and_keeps_numpy():
    line = deps.pip_command_line([Requirement("cv2", "opencv-python-headless"), ABSENT], python="/opt/py 3/python3")
    assert line.startswith("'/opt/py 3/python3' -m pip install ")
    in_venv = sys.prefix != sys.base_prefix
    assert ("--user" in line) is (not in_venv)
    numpy_pin = f"numpy=={importlib.metadata.version('numpy')}"
    assert line.endswith(f"opencv-python-headless monoplot-test-tinypkg {numpy_pin} scipy=={scipy_version()}")
    assert "download.pytorch.org" not in line  # torch is not asked for
    torch_line = deps.pip_command_line([Requirement("torch", "torch")], python="python3")
    if sys.platform != "darwin":
        assert f"--extra-index-url {deps_pins.TORCH_CPU_INDEX} torch {numpy_pin}" in torch_line


def scipy_version():
    return importlib.metadata.version("scipy")


def test_constraints_pin_every_installed_distribution_of_the_target_python():
    target = deps_pins.probe(sys.executable)
    lines = deps_pins.constraint_lines(target)
    assert f"numpy=={importlib.metadata.version('numpy')}" in lines
    assert f"pytest=={importlib.metadata.version('pytest')}" in lines  # from the venv, not just Debian's
    assert {line.split(">=")[0] for line in lines if ">=" in line} <= {
        target.distributions[key][0] for key in deps_pins.UPGRADABLE}


def test_torch_index_override_for_mirrors(monkeypatch):
    target = deps_pins.Target("python3", "linux", False, True, {})
    args = deps_pins.install_arguments(target, ["torch", "scipy"], "/tmp/c.txt")
    assert args == ["-m", "pip", "install", "--user", "--break-system-packages", "-c", "/tmp/c.txt",
                    "--extra-index-url", deps_pins.TORCH_CPU_INDEX, "torch", "scipy"]
    monkeypatch.setenv(deps_pins.TORCH_INDEX_ENV, "https://mirror.example/torch-cpu")
    assert "https://mirror.example/torch-cpu" in deps_pins.install_arguments(target, ["torch"], "/tmp/c.txt")
    monkeypatch.setenv(deps_pins.TORCH_INDEX_ENV, "")
    assert "--extra-index-url" not in deps_pins.install_arguments(target, ["torch"], "/tmp/c.txt")


def test_install_that_would_change_numpy_stops_at_the_dry_run(qgis_iface, qtbot, tmp_path):
    """Real pip, a local 'numpy 99.0' asked for directly: the pins make the dry run fail, nothing is installed."""
    wheels = tmp_path / "wheels"
    wheels.mkdir()
    build_wheel(wheels, "numpy", "99.0")
    pip_args = ["--no-index", "--find-links", str(wheels), "--target", str(tmp_path / "target")]
    installer = deps.PipInstaller([Requirement("numpy", "numpy==99.0")], pip_args, parent=qgis_iface.messageBar())
    with qtbot.waitSignal(installer.finished, timeout=120_000) as result:
        installer.start(qgis_iface)
    assert result.args == [False]
    message = [m for m in qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Critical) if "numpy==99.0" in m]
    assert message and "pip found no versions compatible with QGIS's packages" in message[-1]
    assert f"numpy=={importlib.metadata.version('numpy')}" in message[-1]  # the reason: the pin
    assert not (tmp_path / "target").exists()


def test_a_planned_change_of_an_installed_package_is_refused_with_the_reason():
    target = deps_pins.probe(sys.executable)
    installed = importlib.metadata.version("numpy")
    reason = deps_pins.refusal([("numpy", "99.0"), ("monoplot-test-tinypkg", "1.0")], target)
    assert reason.startswith(f"pip would replace numpy {installed} by 99.0 in QGIS's Python ({sys.executable})")
    assert deps_pins.refusal([("numpy", installed), ("sympy", "99.0"), ("monoplot-test-tinypkg", "1.0")],
                             target) is None


def notice_texts(item):
    return item.text() + " " + item.title()


def test_missing_package_warning_and_install_button(qgis_iface, qtbot, tmp_path):
    wheels, target = tmp_path / "wheels", tmp_path / "target"
    wheels.mkdir()
    build_wheel(wheels)
    pip_args = ["--no-index", "--find-links", str(wheels), "--target", str(target)]
    item = deps.notify_missing(qgis_iface, deps.REQUIRED + (ABSENT,), extra_pip_args=pip_args)
    assert item is not None and qgis_iface.messageBar().currentItem() is item
    assert item.level() == Qgis.MessageLevel.Warning
    text = notice_texts(item)
    assert "monoplot-test-tinypkg" in text and "torch" not in text.split("Click Install")[0]
    assert deps.pip_command_line([ABSENT], extra_args=pip_args) in text

    button = item.findChild(QPushButton, "MonoplotInstallButton")
    installer = item.installer
    button.click()
    progress = qgis_iface.messageBar().currentItem().findChild(QProgressBar, "MonoplotInstallProgress")
    assert progress is not None and progress.maximum() == 0  # busy indicator while pip runs
    with qtbot.waitSignal(installer.finished, timeout=120_000) as result:
        pass
    assert result.args == [True], installer.output
    assert (target / "monoplot_test_tinypkg" / "__init__.py").read_text() == "ANSWER = 42\n"
    assert any("monoplot-test-tinypkg: installed" in m
               for m in qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Success))
    sys.path.insert(0, str(target))
    try:
        assert deps.missing_requirements([ABSENT]) == []
    finally:
        sys.path.remove(str(target))


def test_failed_install_reports_pip_error(qgis_iface, qtbot, tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    pip_args = ["--no-index", "--find-links", str(empty), "--target", str(tmp_path / "target")]
    item = deps.notify_missing(qgis_iface, [ABSENT], extra_pip_args=pip_args)
    with qtbot.waitSignal(item.installer.finished, timeout=120_000) as result:
        item.findChild(QPushButton, "MonoplotInstallButton").click()
    assert result.args == [False]
    assert "No matching distribution" in item.installer.output or "Could not find" in item.installer.output
    assert item.installer.installs == []  # stopped at the dry run
    assert any("pip found no versions compatible" in m and "monoplot-test-tinypkg" in m
               for m in qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Critical))


def test_nothing_shown_when_all_present(qgis_iface):
    assert deps.notify_missing(qgis_iface) is None


def test_deps_pins_doctests():
    import doctest

    result = doctest.testmod(deps_pins)
    assert result.attempted >= 7 and result.failed == 0
