"""The import rules of ARCHITECTURE.md, checked on the source (every import, also those inside functions).

- core imports nothing of the plugin outside core;
- workflow, adapters and outputs import neither gui nor processing;
- gui and processing do not import each other;
- workflow imports no Qt, no qgis and no adapters (it runs in worker threads and in plain scripts).
"""

import ast
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent
PACKAGE = REPO_ROOT / "monoplot_plugin"


def imports_of(path: Path):
    """(line, absolute module name) of every import in a module of the plugin."""
    parts = list(path.relative_to(REPO_ROOT).with_suffix("").parts)
    package = parts if path.name == "__init__.py" else parts[:-1]
    if path.name == "__init__.py":
        package = parts[:-1]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
                names = [target] if node.module else [f"{target}.{a.name}" for a in node.names]
            else:
                names = [node.module]
            for name in names:
                yield node.lineno, name


def layer_of(name: str) -> str:
    """"core", "gui"... for monoplot_plugin.core.x; "qt" for qgis / PyQt; "" for everything else."""
    parts = name.split(".")
    if parts[0] == "monoplot_plugin":
        return parts[1] if len(parts) > 1 else "monoplot_plugin"
    if parts[0] in ("qgis", "PyQt5", "PyQt6", "sip"):
        return "qt"
    return ""


#: layer -> layers (of the plugin, or "qt") it must not import
FORBIDDEN = {
    "core": {"adapters", "outputs", "workflow", "gui", "processing", "state", "deps", "plugin", "logging_bridge",
             "qt"},
    "workflow": {"adapters", "gui", "processing", "qt"},
    "adapters": {"gui", "processing", "workflow"},
    "outputs": {"gui", "processing", "workflow"},
    "gui": {"processing"},
    "processing": {"gui"},
}


def violations():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(REPO_ROOT)
        layer = rel.parts[1] if len(rel.parts) > 2 else ""
        for line, name in imports_of(path):
            if layer_of(name) in FORBIDDEN.get(layer, ()):
                found.append(f"{rel}:{line} ({layer}) imports {name}")
    return found


def test_import_rules_hold():
    assert violations() == []


@pytest.mark.parametrize("source, expected", [
    ("from ..gui.tasks import FunctionTask\n", "monoplot_plugin.gui.tasks"),
    ("from .. import gui\n", "monoplot_plugin.gui"),
    ("def f():\n    from qgis.core import QgsProject\n", "qgis.core"),
])
def test_the_checker_sees_relative_and_local_imports(tmp_path, monkeypatch, source, expected):
    module = PACKAGE / "outputs" / "_layering_probe.py"
    monkeypatch.setattr(Path, "read_text", lambda self, encoding=None: source)
    assert expected in [name for _, name in imports_of(module)]
