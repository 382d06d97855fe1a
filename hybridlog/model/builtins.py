"""Built-in models shipped as package data (``hybridlog/model/builtin/*.toml``).

Reading a built-in's name, text or ``reference`` needs only the standard library (no sympy):
``hybridlog models`` lists them without building a model.  The files are package data fixed
when hybridlog is built; that each one is a valid model (loads with
:func:`~hybridlog.model.loader.load_model`, with the ``reference`` read here) is checked by
the test suite, not again on every listing.
"""

from __future__ import annotations

import tomllib
from importlib import resources

from hybridlog.errors import ModelError, excerpt


def builtin_names() -> list[str]:
    """Names of the built-in models, sorted."""
    folder = resources.files("hybridlog.model").joinpath("builtin")
    return sorted(
        entry.name.removesuffix(".toml")
        for entry in folder.iterdir()
        if entry.name.endswith(".toml")
    )


def builtin_text(name: str) -> str:
    """The model file text of the built-in model ``name``.

    Raises
    ------
    ModelError
        ``name`` is not a built-in model (the message lists them).
    """
    if name not in builtin_names():
        raise ModelError(
            f"{excerpt(name)[1:-1]}: not a built-in model (built-ins: {', '.join(builtin_names())})"
        )
    return (
        resources.files("hybridlog.model")
        .joinpath("builtin", f"{name}.toml")
        .read_text(encoding="utf-8")
    )


def builtin_reference(name: str) -> str:
    """The ``reference`` of the built-in model ``name`` (paper and equations), or ``""``."""
    reference = tomllib.loads(builtin_text(name)).get("reference", "")
    return reference if isinstance(reference, str) else ""
