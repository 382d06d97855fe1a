"""What ``pip install .`` puts in the wheel is what the package reads when it runs.

The suite runs on the source tree, where every file is there whatever pyproject.toml says: a
data file added beside the code (a template, a built-in model) without a pattern in
``[tool.setuptools.package-data]`` passed every test and was missing from an installed
hybridlog.  This checks the declaration against the tree, without building.
"""

from __future__ import annotations

import tomllib
from fnmatch import fnmatch
from pathlib import Path

from tests.support.paths import ROOT

PACKAGE = ROOT / "hybridlog"
SETUPTOOLS = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]


def _files(root: Path) -> list[Path]:
    """The package's files, relative to the repository (no bytecode or numba cache)."""
    return sorted(
        p.relative_to(ROOT) for p in root.rglob("*") if p.is_file() and "__pycache__" not in p.parts
    )


def _packages() -> set[str]:
    """The packages ``[tool.setuptools.packages.find]`` finds.

    From pyproject.toml it finds namespace packages too (``namespaces`` is true unless set
    false): every folder then, with or without ``__init__.py``.
    """
    find = SETUPTOOLS["packages"]["find"]
    folders = [PACKAGE, *(p for p in PACKAGE.rglob("*") if p.is_dir())]
    if not find.get("namespaces", True):
        folders = [f for f in folders if (f / "__init__.py").is_file()]
    return {
        ".".join(f.relative_to(ROOT).parts)
        for f in folders
        if "__pycache__" not in f.parts
        and any(fnmatch(".".join(f.relative_to(ROOT).parts), p) for p in find["include"])
    }


def _shipped(file: Path, packages: set[str]) -> bool:
    """Whether ``file`` is in the wheel: a module of a package, or declared package data."""
    if file.suffix == ".py":
        return ".".join(file.parent.parts) in packages
    data: dict[str, list[str]] = SETUPTOOLS.get("package-data", {})
    for package in packages:
        folder = Path(*package.split("."))
        if folder not in file.parents:
            continue
        inside = file.relative_to(folder).as_posix()
        patterns = [*data.get(package, []), *data.get("*", [])]
        if any(fnmatch(inside, pattern) for pattern in patterns):
            return True
    return False


def test_every_file_of_the_package_is_in_the_wheel():
    packages = _packages()
    missing = [str(f) for f in _files(PACKAGE) if not _shipped(f, packages)]
    assert not missing, (
        "files of hybridlog/ that `pip install .` leaves out (add a pattern for it to "
        f"[tool.setuptools.package-data]): {missing}"
    )


def test_the_built_in_models_are_package_data():
    # the check above is not vacuous: the files hybridlog opens with importlib.resources
    builtin = [f for f in _files(PACKAGE / "model" / "builtin") if f.suffix == ".toml"]
    assert builtin
    assert all(_shipped(f, _packages()) for f in builtin)
