"""Run the doctests of the core modules under their real import names.

(``pytest --doctest-modules`` would import them as ``main.monoplot_plugin...`` because the repository root is a
package, which also confuses numba's on-disk cache; doctest.testmod on the imported module avoids both.)
"""

import doctest
import importlib

import pytest

MODULES = ["dem", "xyz", "render", "transforms", "synthetic"]


@pytest.mark.parametrize("name", MODULES)
def test_core_doctests(name):
    module = importlib.import_module(f"monoplot_plugin.core.{name}")
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0
    assert result.failed == 0
