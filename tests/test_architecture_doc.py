"""docs/architecture.md names every module of the package, and names none that is gone.

Its "Where each step lives" table has a row per top-level module or package, written by
hand: nothing checked that a new module (``model/stability.py``, ``report/junit.py``, which
the ``report/`` row did not list) got its entry, nor that a renamed one lost its old name.
"""

from __future__ import annotations

import re
from pathlib import Path

from tests.support.paths import ROOT

PACKAGE = ROOT / "hybridlog"
TEXT = (ROOT / "docs" / "architecture.md").read_text()


def _rows() -> dict[str, str]:
    """The table's rows by their first cell: ``cli.py``, ``io/``, ..."""
    return {m[1]: m[0] for m in re.finditer(r"^\| `([^`]+)` \|.*$", TEXT, flags=re.MULTILINE)}


def _modules() -> list[Path]:
    """Every module of the package but the ``__init__.py`` files, relative to it."""
    return sorted(p.relative_to(PACKAGE) for p in PACKAGE.rglob("*.py") if p.name != "__init__.py")


def _unnamed(module: Path, rows: dict[str, str]) -> bool:
    """Whether the page does not name ``module`` where a reader looks for it.

    A top-level module anywhere (in the layers table or a row of its own); a module of a
    package in that package's row, by its name or its path inside the package, or anywhere
    by its path from the package root (``model/scenario.py``); a package's ``__main__.py``
    by its command, ``python -m hybridlog.<package>``.
    """
    if len(module.parts) == 1:
        return f"`{module.name}`" not in TEXT
    if module.name == "__main__.py":
        dotted = ".".join(module.parts[:-1])
        return f"python -m hybridlog.{dotted}" not in TEXT
    row = rows.get(f"{module.parts[0]}/", "")
    inside = module.relative_to(module.parts[0]).as_posix()
    return not (
        f"`{module.name}`" in row or f"`{inside}`" in row or f"`{module.as_posix()}`" in TEXT
    )


def test_every_module_is_named_where_its_package_is_described() -> None:
    rows = _rows()
    assert {"cli.py", "io/", "model/", "estimators/", "report/", "jobs/"} <= set(rows)
    missing = [m.as_posix() for m in _modules() if _unnamed(m, rows)]
    assert not missing, f"docs/architecture.md does not name: {missing}"


def test_every_module_the_page_names_exists() -> None:
    """A file named ``*.py`` on the page is in the repository (generated cache modules,
    ``imm_<key>.py``, aside)."""
    files = [
        p.relative_to(ROOT).as_posix()
        for folder in ("hybridlog", "tests", "benchmarks", "docs")
        for p in (ROOT / folder).rglob("*.py")
    ]
    named = set(re.findall(r"`([A-Za-z0-9_./]+\.py)`", TEXT))
    gone = sorted(n for n in named if not any(f == n or f.endswith(f"/{n}") for f in files))
    assert not gone, f"docs/architecture.md names files that do not exist: {gone}"
