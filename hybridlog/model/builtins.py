"""Built-in models shipped as package data (``hybridlog/model/builtin/*.toml``)."""

from __future__ import annotations

from importlib import resources


def builtin_names() -> list[str]:
    """Names of the built-in models, sorted."""
    folder = resources.files("hybridlog.model").joinpath("builtin")
    return sorted(
        entry.name.removesuffix(".toml")
        for entry in folder.iterdir()
        if entry.name.endswith(".toml")
    )


def builtin_text(name: str) -> str:
    """The model file text of the built-in model ``name``."""
    return (
        resources.files("hybridlog.model")
        .joinpath("builtin", f"{name}.toml")
        .read_text(encoding="utf-8")
    )
