"""Every module's docstring examples run, under the module's real import name.

Modules are found by walking ``monoplot_plugin/`` (no hand-kept list: a new module's examples run without anyone
adding it here). ``pytest --doctest-modules`` is not used: it would import them as ``main.monoplot_plugin...``
because the repository root is a package, which also confuses numba's on-disk cache.
"""

import doctest
import importlib
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent

PACKAGE = REPO_ROOT / "monoplot_plugin"
MODULES = sorted(".".join(p.relative_to(REPO_ROOT).with_suffix("").parts).removesuffix(".__init__")
                 for p in PACKAGE.rglob("*.py"))


@pytest.mark.parametrize("name", MODULES)
def test_doctests(name, qgis_app):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0


def test_modules_are_found():
    assert "monoplot_plugin.core.camera" in MODULES and "monoplot_plugin.gui.dock" in MODULES
