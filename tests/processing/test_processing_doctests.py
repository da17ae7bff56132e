"""The examples in the Processing modules' docstrings run and pass."""

import doctest

import pytest

from monoplot_plugin.processing import batch, cli, inputs


@pytest.mark.parametrize("module", [inputs, cli, batch], ids=lambda m: m.__name__)
def test_docstring_examples(module):
    result = doctest.testmod(module)
    assert result.attempted > 0 and result.failed == 0
