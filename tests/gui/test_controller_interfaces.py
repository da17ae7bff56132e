"""Issue 16: each mixin of the controller uses only what its host protocol declares, and the controller provides it
(the mixins' needs were a docstring; a new attribute used silently now fails here)."""

from __future__ import annotations

import ast
import inspect

import pytest

from monoplot_plugin.gui.curation import CurationHost, CurationMixin
from monoplot_plugin.gui.dem_input import DemInputHost, DemInputMixin
from monoplot_plugin.gui.priors import PriorsHost, PriorsMixin
from monoplot_plugin.gui.project_session import ProjectSessionHost, ProjectSessionMixin
from monoplot_plugin.gui.results import ResultsHost, ResultsMixin


def used_names(cls) -> set:
    """Every ``self.<name>`` read or written in the methods of ``cls``."""
    tree = ast.parse(inspect.getsource(cls))
    return {node.attr for node in ast.walk(tree) if isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name) and node.value.id == "self"}


def declared(protocol) -> set:
    names = set(getattr(protocol, "__annotations__", {}))
    return names | {n for n, v in vars(protocol).items() if callable(v) and not n.startswith("__")}


@pytest.mark.parametrize("mixin, host", [(CurationMixin, CurationHost), (PriorsMixin, PriorsHost),
                                         (ResultsMixin, ResultsHost), (DemInputMixin, DemInputHost),
                                         (ProjectSessionMixin, ProjectSessionHost)])
def test_mixins_use_only_their_declared_host(mixin, host, dock):
    own = {n for n in vars(mixin) if not n.startswith("__")}
    undeclared = used_names(mixin) - own - declared(host) - {"__dict__"}
    assert undeclared == set(), f"{mixin.__name__} uses {sorted(undeclared)}: declare them in {host.__name__}"
    controller = dock.controller
    missing = [n for n in declared(host) if not hasattr(controller, n)]
    assert missing == [], missing
