"""No module of ``hybridlog/`` imports another module's private name.

A name with a leading underscore says "used here only": once another module imports it, the
name is shared and must say so (STYLE.md, small modules whose names say what they hold; the
splits of ``io/messages.py`` and others moved code whose helpers other modules now call).
Every ``from hybridlog... import _name`` of the package is found with :mod:`ast`, nothing is
imported; tests may reach into a module's private names, the package may not.
"""

from __future__ import annotations

import ast
from pathlib import Path

import hybridlog

PACKAGE = Path(hybridlog.__file__).parent


def private_imports(source: str) -> list[str]:
    """``module._name`` for each private hybridlog name ``source`` imports from a module."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("hybridlog"):
            found += [
                f"{node.module}.{alias.name}"
                for alias in node.names
                if alias.name.startswith("_") and not alias.name.startswith("__")
            ]
    return found


def test_the_check_sees_a_private_import() -> None:
    source = "from hybridlog.io.align import _listed, sampled_every\nimport hybridlog\n"
    assert private_imports(source) == ["hybridlog.io.align._listed"]


def test_no_module_imports_another_modules_private_name() -> None:
    offending = [
        f"{path.relative_to(PACKAGE.parent)}: {name}"
        for path in sorted(PACKAGE.rglob("*.py"))
        for name in private_imports(path.read_text(encoding="utf-8"))
    ]
    assert offending == []
