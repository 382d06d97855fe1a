"""Lazy package exports (PEP 562): a package names what it offers without importing it.

``hybridlog --help`` and ``hybridlog models`` must not pay for numpy, polars, numba, sympy or
matplotlib, yet ``from hybridlog.report import write_report`` should keep working.  A
package's ``__init__`` therefore lists its exports with the submodule that defines each, and
the submodule is imported on first access to one of its names::

    __getattr__, __dir__ = lazy_exports(__name__, {".writer": ["write_report"]})

Type checkers see the same names through an ``if TYPE_CHECKING:`` import block beside it.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Iterable, Mapping
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, exports: Mapping[str, Iterable[str]]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """Module-level ``__getattr__`` and ``__dir__`` for the package ``package``.

    Parameters
    ----------
    package:
        The package's ``__name__``.
    exports:
        Module (absolute, or relative to ``package`` like ``".writer"``) → the names it
        defines that the package exports.  The module is imported on first access to one of
        them; the value is then kept in the package, so later accesses cost nothing.

    Returns
    -------
    tuple
        ``(__getattr__, __dir__)`` to assign at the package's top level.
    """
    where = {name: module for module, names in exports.items() for name in names}

    def getattr_(name: str) -> Any:
        module = where.get(name)
        if module is None:
            # Also how ``from package import submodule`` falls back to importing it.
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module, package), name)
        setattr(sys.modules[package], name, value)
        return value

    def dir_() -> list[str]:
        return sorted({*vars(sys.modules[package]), *where})

    return getattr_, dir_
