"""The examples in the GUI-side docstrings run (state, adapters, engine, tools, tasks)."""

import doctest
import importlib

import pytest

MODULES = ["monoplot_plugin.state", "monoplot_plugin.adapters.exif", "monoplot_plugin.adapters.dem",
           "monoplot_plugin.gui.engine", "monoplot_plugin.gui.tools", "monoplot_plugin.gui.tasks",
           "monoplot_plugin.gui.summary"]


@pytest.mark.parametrize("name", MODULES)
def test_doctests(name):
    result = doctest.testmod(importlib.import_module(name))
    assert result.attempted > 0 and result.failed == 0
