"""The plugin's Python must run on the Qt 6 builds of newer QGIS too: Qt only through ``qgis.PyQt``, enum members
spelled with their enum (``Qt.AlignmentFlag.AlignLeft``: PyQt6 has no ``Qt.AlignLeft``), no ``exec_()``.

The check reads the sources (ast) and asks this machine's PyQt5 what each ``Class.Member`` is, so it knows
enum members from methods and nested types without a list kept by hand.
"""

import ast
from pathlib import Path

import pytest
from qgis.PyQt import QtCore, QtGui, QtWidgets


REPO_ROOT = Path(__file__).resolve().parent.parent
QT_MODULES = {"qgis.PyQt.QtCore": QtCore, "qgis.PyQt.QtGui": QtGui, "qgis.PyQt.QtWidgets": QtWidgets}
# QGIS's Qt 6 builds put QVariant.Int & co. back (as QMetaType.Type values), and PyQt6 has no QVariant.Type
# to spell them with: QVariant.Double is the portable spelling for QgsField.
PORTABLE_UNSCOPED = {"QVariant"}


def plugin_sources():
    files = [REPO_ROOT / "__init__.py"] + sorted((REPO_ROOT / "monoplot_plugin").rglob("*.py"))
    return [f for f in files if "__pycache__" not in f.parts]


def imported_qt_names(tree: ast.AST) -> dict:
    names = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module in QT_MODULES:
            for alias in node.names:
                obj = getattr(QT_MODULES[node.module], alias.name, None)
                if isinstance(obj, type):
                    names[alias.asname or alias.name] = obj
    return names


def unscoped_enum_uses(source: str) -> list:
    """``(line, 'Qt.AlignLeft', 'Qt.AlignmentFlag.AlignLeft')`` for each enum member reached without its enum."""
    tree = ast.parse(source)
    classes = imported_qt_names(tree)
    found = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)):
            continue
        owner = classes.get(node.value.id)
        if owner is None or node.value.id in PORTABLE_UNSCOPED:
            continue
        member = getattr(owner, node.attr, None)
        if member is None or isinstance(member, type) or callable(member) or not isinstance(member, int):
            continue
        enum_name = type(member).__name__
        if enum_name != node.attr and getattr(owner, enum_name, None) is type(member):
            found.append((node.lineno, f"{node.value.id}.{node.attr}", f"{node.value.id}.{enum_name}.{node.attr}"))
    return found


def test_the_checker_finds_unscoped_members_and_accepts_scoped_ones():
    source = ("from qgis.PyQt.QtCore import Qt\nfrom qgis.PyQt.QtWidgets import QMessageBox\n"
              "a = Qt.AlignLeft\nb = Qt.AlignmentFlag.AlignLeft\nc = QMessageBox.Yes\nd = QMessageBox.question\n")
    assert unscoped_enum_uses(source) == [(3, "Qt.AlignLeft", "Qt.AlignmentFlag.AlignLeft"),
                                          (5, "QMessageBox.Yes", "QMessageBox.StandardButton.Yes")]


@pytest.mark.parametrize("path", plugin_sources(), ids=lambda p: str(p.relative_to(REPO_ROOT)))
def test_qt_is_portable(path: Path):
    source = path.read_text(encoding="utf-8")
    tree = ast.parse(source)
    direct = [f"line {n.lineno}: {n.module or n.names[0].name}" for n in ast.walk(tree)
              if (isinstance(n, ast.ImportFrom) and (n.module or "").split(".")[0] in ("PyQt5", "PyQt6", "sip"))
              or (isinstance(n, ast.Import) and any(a.name.split(".")[0] in ("PyQt5", "PyQt6", "sip")
                                                    for a in n.names))]
    assert not direct, f"import Qt through qgis.PyQt: {direct}"
    assert ".exec_(" not in source, "exec_() is gone in PyQt6: use exec()"
    bad = [f"line {line}: {used} -> {scoped}" for line, used, scoped in unscoped_enum_uses(source)]
    assert not bad, "spell enum members with their enum (PyQt6 needs it): " + "; ".join(bad)
