"""The outputs modules' doctests, run under their real import names (not through --doctest-modules, which would
import them as ``main.monoplot_plugin...`` and upset numba's cache of the core they import)."""

import doctest
import importlib

import pytest

MODULES = ["safe_write", "_gdal", "vectors", "geometry", "report", "qgis_layers"]


@pytest.mark.parametrize("name", MODULES)
def test_doctests(name):
    module = importlib.import_module(f"monoplot_plugin.outputs.{name}")
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
