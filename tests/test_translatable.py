"""User-visible strings go through ``tr()`` as fixed templates: ``tr(f"...")`` hands Qt's translator a string
that changes with every value, so no translation can ever match it. Use ``tr("... {0}").format(value)``."""

import ast
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent


def formatted_tr_calls(source: str) -> list:
    """Lines where ``tr`` / ``self.tr`` / ``QCoreApplication.translate`` is given an f-string."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Call):
            continue
        name = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
        if name in ("tr", "translate") and any(isinstance(a, ast.JoinedStr) for a in node.args):
            found.append(node.lineno)
    return found


def test_the_checker_sees_f_strings_in_tr():
    assert formatted_tr_calls('x = self.tr(f"{n} points")\ny = self.tr("{0} points").format(n)\n') == [1]


@pytest.mark.parametrize("path", sorted((REPO_ROOT / "monoplot_plugin").rglob("*.py")),
                         ids=lambda p: str(p.relative_to(REPO_ROOT)))
def test_translatable_templates(path: Path):
    lines = formatted_tr_calls(path.read_text(encoding="utf-8"))
    assert not lines, f"tr() given an f-string on lines {lines}: use tr('... {{0}}').format(value)"
