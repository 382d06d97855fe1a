"""Estimator options: typed dataclasses filled from model defaults and ``--set`` values."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, TypeVar

from hybridlog.errors import OptionError

T = TypeVar("T")

_TRUE = {"true", "yes", "on", "1"}
_FALSE = {"false", "no", "off", "0"}


def parse_options(cls: type[T], values: Mapping[str, Any], *, estimator: str) -> T:
    """Build the options dataclass ``cls`` from ``values`` (strings from ``--set`` or TOML).

    Unknown names and values of the wrong type are :class:`OptionError` naming the option.
    Each field may declare ``metadata={"choices": (...)}`` or ``{"range": (low, high)}``.
    """
    fields = {f.name: f for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    converted: dict[str, Any] = {}
    for name, raw in values.items():
        if name not in fields:
            known = ", ".join(sorted(fields))
            raise OptionError(f"{estimator} option '{name}': unknown (options: {known})")
        field = fields[name]
        value = _convert(raw, str(field.type), f"{estimator} option '{name}'")
        choices = field.metadata.get("choices")
        if choices is not None and value not in choices:
            raise OptionError(
                f"{estimator} option '{name}': {value!r} is not one of {', '.join(choices)}"
            )
        bounds = field.metadata.get("range")
        if bounds is not None and not bounds[0] <= value <= bounds[1]:
            raise OptionError(
                f"{estimator} option '{name}': {value!r} is outside [{bounds[0]}, {bounds[1]}]"
            )
        converted[name] = value
    return cls(**converted)


def _convert(raw: Any, annotation: str, what: str) -> Any:
    if annotation == "bool":
        if isinstance(raw, bool):
            return raw
        text = str(raw).strip().lower()
        if text in _TRUE:
            return True
        if text in _FALSE:
            return False
        raise OptionError(f"{what}: expected true or false, got {raw!r}")
    if annotation == "float":
        if isinstance(raw, bool):
            raise OptionError(f"{what}: expected a number, got {raw!r}")
        try:
            number = float(raw)
        except (TypeError, ValueError) as err:
            raise OptionError(f"{what}: expected a number, got {raw!r}") from err
        if not math.isfinite(number):
            raise OptionError(f"{what}: non-finite number {raw!r}")
        return number
    if annotation == "str":
        return str(raw)
    if annotation == "float | None":
        if raw is None or str(raw).strip().lower() in {"none", ""}:
            return None
        return _convert(raw, "float", what)
    raise TypeError(f"unsupported option type {annotation}")  # pragma: no cover


def options_dict(options: object) -> dict[str, Any]:
    """The options as a plain dict for reports."""
    return dataclasses.asdict(options)  # type: ignore[call-overload, no-any-return]
