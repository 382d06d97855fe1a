"""Estimator options: frozen dataclasses parsed and validated from their type hints.

Every estimator declares its options once, as a frozen dataclass whose fields are made with
:func:`option` (a default, a one-line help text and, for numbers, an inclusive range).  The
field's type hint says what a value must be, by one rule for a TOML value of the model file's
``[estimators.<name>]`` table and for the text of ``--set NAME=VALUE``:

``bool``
    ``true`` or ``false``.
``int``
    a whole number; a number with an integral value (``10.0``, ``1e3``) is that number, and
    ``true``/``false`` are refused.
``float``
    a finite number (``1`` is ``1.0``).
``str``
    text.
``Literal["a", "b"]``
    one of the listed strings.
``X | None``
    ``"none"`` (any case) for ``None``, otherwise as ``X`` (TOML has no null); an empty
    value is refused (``--set transition_stay=$STAY`` with ``STAY`` unset was ``None``, the
    option's default run without a word).
a list (``str`` made with ``items=float``, ``int`` or ``str``)
    text of items separated by commas (``"-10,-20"``), or, in a model file, a TOML array of
    items of that type (``[-10.0, -20.0]``), each read by the rule above and refused naming
    its position; the array is then that text (``"-10.0,-20.0"``), read by the same check.

A model file's value is the TOML value itself: ``smooth = "true"`` (a string) and
``smooth = 1`` (a number) are refused for a ``bool``, as ``eigenvalues = -5`` (a number) is
for a ``str``.  A ``--set`` text (:attr:`OptionSource.text`, also a flag of ``hybridlog
cluster``) is read as the TOML value it spells: ``true``/``false`` (not ``yes``, ``1`` or
``True``), a number as :mod:`hybridlog.numbers` reads every typed number (no ``1_000``, no
``inf``), so ``--set beam=2.0`` is ``beam = 2.0``; for a string option the text as it is,
quotes optional (``--set centers=c.json`` and ``--set centers='"c.json"'`` alike).  An
error names where the value came from (the file and key, or ``--set NAME=VALUE``) and spells
a value as it was written (``true``, not Python's ``True``).

An options dataclass may refuse a combination of values with a method ``conflicts(self)``
returning ``(option, other, why)`` triples: ``option``'s value cannot go with ``other``'s
(e.g. ``unknown-mode``'s ``candidates`` below its ``beam``), ``{other}`` in ``why`` standing
for ``other``'s value and where it came from.  :func:`parse_options` raises the
one-line error naming ``option``'s source (``other``'s when ``option`` was not given) and
where ``other``'s value came from, instead of the estimator quietly running another value.

An option made with ``path=True`` names a file: a relative path given in a model file is
taken from the model file's folder (:attr:`OptionSource.base`), as the file's author wrote it
beside the model; one given with ``--set`` from the working directory.  A path naming a
folder is refused when the options are parsed; whether the file exists is the reader's
question (``hybridlog cluster`` may be about to write it).

An options dataclass may refuse a value the model cannot take with a method
``invalid_on(self, model)`` (name → why, e.g. more eigenvalues than the model has states):
:func:`check_table` refuses a model file's key of it, naming the file and the key.

An options dataclass may say that its values leave the estimator without something it needs
with a method ``missing(self)`` (why, or None; ``sliding-mode`` without ``v_max`` or
``drift_bound`` has no gain V_M): :func:`~hybridlog.estimators.registry.prepare` refuses
it, naming the model file's ``[estimators.<name>]`` table, before any log is read.

An options dataclass may say which of its options have no effect: ``inert(self, model)``
(name → why) those the other options' values or the model leave unread (``--set`` of one is
refused), and a classmethod ``inert_on(cls, model)`` those the model alone leaves unread,
whatever the other options say (``theta`` decides between modes: nothing on a one-mode
model).  :func:`check_table` refuses a model file's key of the latter, as a misspelt key is;
a key of the former stays, as the default for when ``--set`` enables it (``beam = 50`` under
``[estimators.imm]`` with ``--mode-sequence kbest``).

:func:`parse_options` builds the dataclass, :func:`describe_options` lists the options for
``--help``, ``--set`` errors and the docs.  Errors are one line naming the estimator, the
option and where the value came from (:class:`OptionSource`).
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import os
import re
import tomllib
import types
import typing
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, TypeVar, Union

from hybridlog.errors import HybridlogError, ModelError, OptionError, excerpt
from hybridlog.numbers import parse_float, parse_int

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = [
    "OptionInfo",
    "OptionSource",
    "check_table",
    "closest",
    "describe_options",
    "format_options",
    "option",
    "options_dict",
    "parse_options",
    "read_text",
    "read_value",
    "shown",
]

T = TypeVar("T")

_BOOLEANS = {"true": True, "false": False}
"""A ``--set`` text of a ``bool`` option: TOML's spellings, and only those."""

_NONE = "none"
"""The text (any case) an ``X | None`` option reads as ``None``."""

_NOT_A_NUMBER = "expected a finite number"
""":func:`~hybridlog.numbers.parse_float`'s reason for text that spells no number at all."""

_WHITESPACE = " \t\n\r\f\v"
"""The ASCII whitespace ignored around a command-line text (as :mod:`hybridlog.numbers`)."""


def option(
    default: T,
    help: str,
    *,
    range: tuple[float, float] | None = None,
    above: bool = False,
    below: bool = False,
    check: Callable[[Any], object] | None = None,
    path: bool = False,
    items: type[Any] | None = None,
) -> T:
    """A dataclass field for an estimator option.

    Parameters
    ----------
    default:
        The value used when neither the model file nor ``--set`` gives one.
    help:
        One line for ``--help`` and the docs (what the option is, with the paper's symbol
        and equation where it has one).
    range:
        Inclusive ``(low, high)`` bounds of a number.
    above:
        The low bound itself is excluded: the value must be above it (``(1, 100]``), as
        ``--help``, the docs and the refusal then say.
    below:
        The high bound itself is excluded: the value must be below it (``(0, 1)``); for a
        bound no value can reach (a threshold that decides nothing at 1, a ratio that must
        stay below another at most 1), so that the range shown is the one that passes.
    check:
        Checks a value beyond its type and range (raising ``ValueError`` with the reason),
        when the options are parsed: before any log is read, the error naming where the
        value came from.
    path:
        The value names a file: relative to :attr:`OptionSource.base` of where it came from.
    items:
        For a ``str`` option whose text lists items separated by commas: their type
        (``float``, ``int`` or ``str``).  A model file may give a TOML array of them
        instead (:func:`_listed`); ``check`` reads the text either way.
    """
    metadata: dict[str, Any] = {"help": help}
    if path:
        metadata["path"] = True
    if range is not None:
        metadata["range"] = range
        metadata["above"] = above
        metadata["below"] = below
    elif above or below:
        raise TypeError("above= and below= need a range")
    if check is not None:
        metadata["check"] = check
    if items is not None:
        if items not in (float, int, str) or not isinstance(default, str):
            raise TypeError("items= is float, int or str, of a str option")
        metadata["items"] = items
    field: T = dataclasses.field(default=default, metadata=metadata)
    return field


@dataclass(frozen=True)
class OptionSource:
    """Where an option value came from, so that an error names what the user must change.

    Attributes
    ----------
    label:
        The place, e.g. ``--set theta=2`` or ``bad.toml: estimators.hstf.theta``.
    error:
        The error class to raise: :class:`OptionError` for the command line,
        :class:`ModelError` for a model file.
    base:
        The folder a relative path in the value is taken from (options made with
        ``path=True``): the model file's; empty for the working directory.
    text:
        A string value is text typed on the command line, read as the TOML value it spells
        (``--set beam=2`` is ``beam = 2``); false for a value already typed (a TOML or JSON
        value: ``smooth = "true"`` is a string, not a boolean).
    """

    label: str
    error: type[HybridlogError] = OptionError
    base: str = ""
    text: bool = True

    @classmethod
    def command_line(cls, flag: str, name: str, raw: object) -> OptionSource:
        """A value given as ``<flag> name=raw`` (``flag`` is ``--set``)."""
        return cls(f"{flag} {name}={excerpt(raw)[1:-1]}")

    @classmethod
    def model_file(cls, origin: str, estimator: str, name: str) -> OptionSource:
        """A value from the ``[estimators.<estimator>]`` table of the model file ``origin``."""
        return cls(
            f"{origin}: estimators.{estimator}.{name}",
            ModelError,
            os.path.dirname(origin),
            text=False,
        )


@dataclass(frozen=True)
class _Kind:
    """How one option's values are read: the base type, its choices, whether None is allowed."""

    base: type[Any]
    choices: tuple[object, ...] | None
    optional: bool

    @property
    def text(self) -> str:
        if self.choices is not None:
            shown = "|".join(str(c) for c in self.choices)
        else:
            shown = self.base.__name__
        return f"{shown} or none" if self.optional else shown


def _kind(hint: object, where: str) -> _Kind:
    optional = False
    origin = typing.get_origin(hint)
    if origin in (Union, types.UnionType):
        members = [a for a in typing.get_args(hint) if a is not type(None)]
        if len(members) != len(typing.get_args(hint)) - 1 or len(members) != 1:
            raise TypeError(f"{where}: only 'X | None' unions are supported, not {hint}")
        optional = True
        hint = members[0]
        origin = typing.get_origin(hint)
    if origin is Literal:
        choices = typing.get_args(hint)
        bases = {type(c) for c in choices}
        if len(bases) != 1 or next(iter(bases)) not in (str, int):
            raise TypeError(f"{where}: Literal choices must all be str or all int, not {hint}")
        return _Kind(next(iter(bases)), choices, optional)
    if hint in (bool, int, float, str):
        return _Kind(typing.cast(type[Any], hint), None, optional)
    raise TypeError(f"{where}: unsupported option type {hint}")


_KINDS: dict[type[Any], dict[str, tuple[dataclasses.Field[Any], _Kind]]] = {}


def _kinds(cls: type[Any]) -> dict[str, tuple[dataclasses.Field[Any], _Kind]]:
    """Each field of ``cls`` with how it is read (worked out once per class)."""
    if cls not in _KINDS:
        if not (dataclasses.is_dataclass(cls) and cls.__dataclass_params__.frozen):  # type: ignore[attr-defined]
            raise TypeError(f"{cls.__name__}: estimator options must be a frozen dataclass")
        hints = typing.get_type_hints(cls)
        _KINDS[cls] = {
            f.name: (f, _kind(hints[f.name], f"{cls.__name__}.{f.name}"))
            for f in dataclasses.fields(cls)
        }
    return _KINDS[cls]


def closest(name: str, candidates: Iterable[str]) -> str:
    """``"; did you mean 'x'?"`` for the candidate most like ``name``, or ``""``.

    Case is ignored in the likeness (``RHO`` suggested nothing for ``rho``); a candidate
    spelled as ``name`` but for case is suggested first.
    """
    spelled: dict[str, str] = {}
    for candidate in candidates:
        spelled.setdefault(candidate.casefold(), candidate)
    key = name.casefold()
    if key in spelled:
        return f"; did you mean '{spelled[key]}'?"
    found = difflib.get_close_matches(key, list(spelled), n=1, cutoff=0.6)
    return f"; did you mean '{spelled[found[0]]}'?" if found else ""


def parse_options(
    cls: type[T],
    values: Mapping[str, Any],
    *,
    estimator: str,
    sources: Mapping[str, OptionSource] | None = None,
) -> T:
    """Build the options dataclass ``cls`` from ``values`` (``--set`` strings or TOML values).

    Parameters
    ----------
    cls:
        A frozen dataclass whose fields were made with :func:`option`.
    values:
        Option name → value; options not named keep their defaults.
    estimator:
        The estimator's registry name, for messages.
    sources:
        Where each value came from; a bad value raises ``sources[name].error`` prefixed with
        its label.  A value without a source is read as command-line text when it is a string
        (:attr:`OptionSource.text`), and its error is an :class:`OptionError`.

    Raises
    ------
    OptionError, ModelError
        One line naming the estimator, the option and (with ``sources``) the file and key or
        the ``--set`` value: an unknown name (with the closest known name), a value of the
        wrong type, outside its range or not one of its choices, or a combination its
        ``conflicts()`` refuses.
    """
    sources = sources or {}
    built = cls(**_converted(cls, values, estimator, sources))
    _refuse_conflicts(built, estimator, sources)
    return built


def check_table(
    cls: type[Any],
    values: Mapping[str, Any],
    *,
    estimator: str,
    sources: Mapping[str, OptionSource],
    model: HybridModel,
) -> None:
    """Check a model file's ``[estimators.<estimator>]`` table, whichever estimator runs.

    Every name must be an option, every value one of it (as :func:`parse_options` reads it),
    and no option one that ``model`` leaves unread whatever the others say (``inert_on``):
    ``transition_stay = 7`` under ``[estimators.imm]`` passed without a word when ``hstf``
    ran.  The table is checked as a whole, with the defaults of the options it leaves out:
    a combination ``conflicts()`` refuses (``candidates = 5`` under
    ``[estimators.unknown-mode]``, below the default beam of 20, was refused when
    ``unknown-mode`` ran and passed when another estimator did), and a value ``model``
    cannot take (``invalid_on(self, model)``, name → why: three eigenvalues for a
    two-state model were refused only as the estimator ran, naming neither the file nor the
    key).  When the estimator is prepared, :func:`parse_options` checks the combination
    again with the ``--set`` values.

    Raises
    ------
    ModelError
        One line naming the file and the key (``sources[name]``).
    """
    built = cls(**_converted(cls, values, estimator, sources))
    inert_on: Callable[[HybridModel], Mapping[str, str]] | None = getattr(cls, "inert_on", None)
    unread = {} if inert_on is None else inert_on(model)
    for name in values:
        source = sources.get(name, OptionSource(""))
        prefix = f"{source.label}: " if source.label else ""
        if name in unread:
            raise source.error(
                f"{prefix}{estimator} option '{name}' has no effect: {unread[name]}; remove the key"
            )
    refuse_invalid(built, model, estimator, sources, values)
    _refuse_conflicts(built, estimator, sources)


def refuse_invalid(
    built: object,
    model: HybridModel,
    estimator: str,
    sources: Mapping[str, OptionSource],
    names: Iterable[str],
) -> None:
    """Refuse a value of ``names`` that ``model`` cannot take (``built.invalid_on(model)``).

    For a model file's table (:func:`check_table`) and, as the estimator is prepared, for
    the values given by ``--set``: ``--set eigenvalues=-1,-2`` on a three-state model was
    refused as the estimator ran, naming neither ``--set`` nor the option.

    Raises
    ------
    HybridlogError
        ``sources[name].error``: one line naming where the value came from.
    """
    invalid_on: Callable[[HybridModel], Mapping[str, str]] | None = getattr(
        built, "invalid_on", None
    )
    invalid = {} if invalid_on is None else invalid_on(model)
    for name in names:
        if name in invalid:
            source = sources.get(name, OptionSource(""))
            prefix = f"{source.label}: " if source.label else ""
            raise source.error(f"{prefix}{estimator} option '{name}': {invalid[name]}")


def _converted(
    cls: type[Any], values: Mapping[str, Any], estimator: str, sources: Mapping[str, OptionSource]
) -> dict[str, Any]:
    """Each of ``values`` read as its option of ``cls`` (path options resolved)."""
    kinds = _kinds(cls)
    converted: dict[str, Any] = {}
    for name, raw in values.items():
        source = sources.get(name, OptionSource(""))
        prefix = f"{source.label}: " if source.label else ""
        if name not in kinds:
            raise source.error(
                f"{prefix}{estimator} has no option {excerpt(name)} (options: "
                f"{', '.join(kinds)}){closest(name, kinds)}"
            )
        field, kind = kinds[name]
        try:
            converted[name] = _read(raw, field, kind, text=source.text, base=source.base)
        except ValueError as err:
            raise source.error(f"{prefix}{estimator} option '{name}': {err}") from None
    return converted


def read_text(cls: type[Any], name: str, text: str) -> Any:
    """The command-line ``text`` read as the option ``name`` of ``cls`` alone.

    As :func:`parse_options` reads a ``--set`` value: its type, choices, range and
    ``check``, a path option's value naming no folder; not whether it goes with the other
    options (``conflicts()``), whose values a model file may yet give.  For command-line
    options made from an options dataclass (``hybridlog cluster --radius``), checked as
    they are parsed.

    Raises
    ------
    ValueError
        The reason alone (``expected a finite number, got 'abc'``, ``0 is outside [0.001,
        100]``): the caller names the option.
    """
    field, kind = _kinds(cls)[name]
    return _read(text, field, kind, text=True, base="")


def read_value(cls: type[Any], name: str, value: object) -> Any:
    """A Python caller's ``value`` of the option ``name`` of ``cls`` alone, as its type reads it.

    As :func:`read_text`, for a value already typed (the field of an options object a
    notebook built, ``ChiuOptions(radius="0.3")``): of the option's type (a string is not
    read as the number it spells), choices, range and ``check``.  A NumPy scalar is the
    Python number it holds.

    Raises
    ------
    ValueError
        The reason alone: the caller names the option.
    """
    field, kind = _kinds(cls)[name]
    item = getattr(value, "item", None)
    if type(value).__module__ == "numpy" and callable(item):
        value = item()
    return _read(value, field, kind, text=False, base="")


def _read(raw: Any, field: dataclasses.Field[Any], kind: _Kind, *, text: bool, base: str) -> Any:
    """``raw`` read as the option ``field`` of ``kind``; ``ValueError`` with the reason.

    A path option's value is taken from ``base`` when relative, and may not name a folder.
    """
    items = field.metadata.get("items")
    if items is not None and not text and not isinstance(raw, str):
        raw = _listed(raw, items)
    value = _convert(raw, kind, text=text)
    if items is int and isinstance(value, str):
        value = _whole_items(value)
    value = _check(value, kind, field)
    if field.metadata.get("path") and value:
        if base and not os.path.isabs(value):
            value = os.path.join(base, value)
        if os.path.isdir(value):  # read as a file only after the log, or never
            raise ValueError(f"{excerpt(value)} is a folder; name a file")
    return value


_ITEMS = {float: "numbers", int: "whole numbers", str: "strings"}
"""What the items of a list option are, for its refusal (:func:`_listed`)."""


def _listed(array: object, items: type[Any]) -> str:
    """A model file's TOML array of a list option as the text of its items, by commas.

    ``eigenvalues = [-20.0, -30.0]`` was refused ("expected text") where an engineer writes
    an array; each item is read as an option of type ``items`` is (:func:`_typed`: no
    booleans, NaN or text for a number), written back as text that reads as the same value
    (``repr`` of a float), so the option's ``check`` reads the one text either way.

    A lone number for a list of numbers is the list of that one (``eigenvalues = -5`` as
    ``"-5"``); any other value that is neither text nor an array is refused.

    Raises
    ------
    ValueError
        Naming the item by its position: ``item 2 of the array: expected a finite number,
        got nan``.
    """
    kind = _Kind(items, None, optional=False)
    if items is not str and isinstance(array, int | float) and not isinstance(array, bool):
        array = [array]
    if not isinstance(array, list):
        raise ValueError(
            f"expected an array of {_ITEMS[items]} or their text separated by commas, got "
            f"{_spelled(array, kind)}"
        )
    texts = []
    for position, item in enumerate(array, start=1):
        try:
            value = _typed(item, kind, None)
        except ValueError as err:
            raise ValueError(f"item {position} of the array: {err}") from None
        if items is str and ("," in value or not value):
            raise ValueError(
                f"item {position} of the array: {excerpt(item)} is no single item (empty, or "
                "holding a comma)"
            )
        texts.append(repr(value) if isinstance(value, float) else str(value))
    return ",".join(texts)


def _whole_items(text: str) -> str:
    """The text of a list of whole numbers with each integral number written as one.

    By the rule of an ``int`` (module docstring), ``10.0`` and ``1e3`` are whole numbers, as
    a TOML array's items are read (:func:`_listed`: ``output_lags = [0, 1.0]`` is ``"0,1"``);
    the text ``--set output_lags=0,1.0`` (or ``"0,1.0"`` in a model file) was refused
    ("'1.0' is not a whole number").  Any other item stays as written, for the option's
    ``check`` to refuse in its own words.
    """

    def whole(match: re.Match[str]) -> str:
        item = match.group(0)
        try:
            parse_int(item)
            return item
        except ValueError:
            pass
        try:
            number = parse_float(item)
        except ValueError:
            return item
        return str(int(number)) if number.is_integer() else item

    return re.sub(r"[^,;]+", whole, text)


def _refuse_conflicts(options: object, estimator: str, sources: Mapping[str, OptionSource]) -> None:
    """Raise for the first ``(option, other, why)`` of ``options.conflicts()``, if any.

    The error is ``option``'s source's (``other``'s when only that was given), and names
    where ``other``'s value came from: its ``--set`` or model file key, or its default.
    """
    conflicts: Callable[[], Iterable[tuple[str, str, str]]] | None = getattr(
        options, "conflicts", None
    )
    for name, other, why in conflicts() if conflicts is not None else ():
        blamed = name if name in sources or other not in sources else other
        source = sources.get(blamed, OptionSource(""))
        prefix = f"{source.label}: " if source.label else ""
        origin = sources[other].label if other in sources else ""
        value = shown(getattr(options, other))
        given = f"{other} = {value} ({origin or 'its default'})"
        raise source.error(f"{prefix}{estimator} option '{name}': {why.format(other=given)}")


def _convert(raw: Any, kind: _Kind, *, text: bool) -> Any:
    """``raw`` read as ``kind``; ``ValueError`` with the reason otherwise.

    With ``text``, a string is command-line text, first read as the TOML value it spells
    (:func:`_from_text`); then the value must be of the type the option's is (:func:`_typed`).
    """
    if text and isinstance(raw, str):
        quoted = _quoted(raw.strip(_WHITESPACE))
        if quoted is not None:  # --set smooth='"true"' is smooth = "true", a string
            return _typed(quoted, kind, None)
        return _typed(_from_text(raw, kind), kind, raw)
    return _typed(raw, kind, None)


def _from_text(text: str, kind: _Kind) -> Any:
    """A command-line text as the TOML value it spells for an option of ``kind``.

    ``none`` (any case) for an optional one; the text itself for a string option;
    ``true``/``false`` for a boolean; a number as :mod:`hybridlog.numbers` reads it.  Text
    that spells none of these is returned as it is, for :func:`_typed` to refuse.  (A quoted
    TOML string is that string, whatever the option: :func:`_convert`.)
    """
    stripped = text.strip(_WHITESPACE)
    if kind.optional and stripped.lower() == _NONE:
        return None
    if kind.base is str:
        return stripped
    if kind.base is bool:
        return _BOOLEANS.get(stripped, text)
    try:
        return parse_int(stripped)
    except ValueError:
        pass
    try:
        return parse_float(stripped)
    except ValueError as err:
        if str(err) == _NOT_A_NUMBER:
            return text
        # a number, but one a double does not hold in full: refused with the reason, as the
        # model file's value is (--set rho=1e-400 was "expected a finite number")
        raise ValueError(f"{err}, got {excerpt(stripped)}") from None


def _quoted(text: str) -> str | None:
    """The value of ``text`` as a TOML string (``"a b"``, ``'c d'``); ``None`` if it is not one."""
    if text[:1] not in ("'", '"'):
        return None
    try:
        parsed = tomllib.loads(f"v = {text}")
    except tomllib.TOMLDecodeError:
        return None
    value = parsed.get("v")
    return value if len(parsed) == 1 and isinstance(value, str) else None


def _typed(value: Any, kind: _Kind, typed: str | None) -> Any:
    """``value`` (a TOML value, or ``typed`` read as one) as ``kind``; ``ValueError`` if not.

    The one rule of both sources (module docstring); the reason spells the value as it was
    written: ``typed`` itself, or the TOML value (``true``, not Python's ``True``; a string
    in quotes, named a string where the option is not text).
    """
    if kind.optional:
        if value is None or (isinstance(value, str) and value.strip().lower() == _NONE):
            return None
        if isinstance(value, str) and not value.strip(_WHITESPACE):
            raise ValueError("got an empty value: write a value, or none")
    given = excerpt(typed) if typed is not None else _spelled(value, kind)
    if kind.base is bool:
        if isinstance(value, bool):
            return value
        raise ValueError(f"expected true or false, got {given}")
    if kind.base is str:
        if isinstance(value, str):
            return value.strip()
        raise ValueError(f"expected text (a TOML string, in quotes), got {given}")
    whole = kind.base is int
    expected = "a whole number" if whole else "a finite number"
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"expected {expected}, got {given}")
    if isinstance(value, int) and whole:
        return value
    if not math.isfinite(number := _as_float(value)):
        raise ValueError(f"expected a finite number, got {given}")
    if not whole:
        return number
    if not number.is_integer():
        raise ValueError(f"expected a whole number, got {given}")
    return int(number)


def _spelled(value: object, kind: _Kind) -> str:
    """A TOML (or JSON) value as its file spells it, for an error about ``kind``."""
    if isinstance(value, bool):
        return f"'{shown(value)}'"
    if isinstance(value, dict | list):  # Python's repr is no TOML ({'a': 1}, [True])
        return "a table" if isinstance(value, dict) else "an array"
    if isinstance(value, str) and kind.base is not str:
        try:
            unquoted = _from_text(value, kind)
        except ValueError:  # '1e-400', a number all the same
            unquoted = None
        hint = "" if isinstance(unquoted, str) else ": write it without quotes"
        return f"the string {excerpt(value)}{hint}"
    return excerpt(value)


def _as_float(value: float) -> float:
    """A TOML number as a float; infinite for an integer beyond the range of floats."""
    try:
        return float(value)
    except OverflowError:
        return math.inf


def _check(value: Any, kind: _Kind, field: dataclasses.Field[Any]) -> Any:
    if value is None:
        return None
    if kind.choices is not None and value not in kind.choices:
        raise ValueError(
            f"{excerpt(value)} is not one of {', '.join(str(c) for c in kind.choices)}"
        )
    bounds = field.metadata.get("range")
    if bounds is not None:
        low = value > bounds[0] if field.metadata["above"] else value >= bounds[0]
        high = value < bounds[1] if field.metadata["below"] else value <= bounds[1]
        if not (low and high):
            raise ValueError(f"{shown(value)} is outside {interval(field)}")
    check = field.metadata.get("check")
    if check is not None:
        check(value)
    return value


@dataclass(frozen=True)
class OptionInfo:
    """One option as ``--help`` and the docs show it.

    Attributes
    ----------
    name:
        The option's name (as in ``--set NAME=VALUE``).
    type:
        ``float``, ``int``, ``bool``, ``str``, ``a|b`` for choices, with ``or none`` when
        ``none`` is allowed.
    default:
        The default value.
    constraint:
        ``in [low, high]`` for a ranged number, else empty.
    help:
        The one-line help text.
    """

    name: str
    type: str
    default: object
    constraint: str
    help: str


def describe_options(cls: type[Any]) -> tuple[OptionInfo, ...]:
    """Every option of the options dataclass ``cls``, in declaration order.

    Raises
    ------
    TypeError
        When ``cls`` is not a frozen dataclass of supported option types, or an option has
        no help text (a defect of the estimator, found by the tests).
    """
    infos = []
    for name, (field, kind) in _kinds(cls).items():
        help_text = field.metadata.get("help", "")
        if not help_text:
            raise TypeError(f"{cls.__name__}.{name}: an estimator option needs a help text")
        items = field.metadata.get("items")
        constraint = "" if field.metadata.get("range") is None else f"in {interval(field)}"
        infos.append(
            OptionInfo(
                name=name,
                type=kind.text if items is None else f"list of {items.__name__}",
                default=field.default,
                constraint=constraint,
                help=help_text,
            )
        )
    return tuple(infos)


def interval(field: dataclasses.Field[Any]) -> str:
    """The range of a ranged option as written: ``[0, 1]``, ``(1, 100]`` or ``(0, 1)``.

    A round bracket is a bound excluded (``above``, ``below`` of :func:`option`).
    """
    low, high = field.metadata["range"]
    opening = "(" if field.metadata["above"] else "["
    closing = ")" if field.metadata["below"] else "]"
    return f"{opening}{shown(low)}, {shown(high)}{closing}"


def shown(value: object) -> str:
    """A default or bound as ``--set`` would take it: ``none``, ``true``, ``""``, ``0.95``.

    A float is written with the fewest significant digits (six at least, ``1e+06``) that
    read back as the same float: a value just outside a range (``1.0000001`` against
    ``[1e-12, 1]``) and a bound that six digits round (2^52) are shown as they are, never as
    the bound itself, which would read as inside.
    """
    if value is None:
        return "none"
    if isinstance(value, bool):
        return str(value).lower()
    if value == "":
        return '""'
    return _float_text(value) if isinstance(value, float) else str(value)


def _float_text(value: float) -> str:
    """``value`` in ``%g`` style with the fewest digits (from six) that read back as it."""
    for digits in range(6, 18):
        text = f"{value:.{digits}g}"
        if not math.isfinite(value) or float(text) == value:
            return text
    return repr(value)  # unreachable: 17 significant digits identify every float64


def format_options(infos: Iterable[OptionInfo]) -> str:
    """Plain-text lines, one per option: ``name=DEFAULT  (type, range)  help``."""
    rows = [
        (
            f"{i.name}={shown(i.default)}",
            ", ".join(p for p in (i.type, i.constraint) if p),
            i.help,
        )
        for i in infos
    ]
    if not rows:
        return "(no options)"
    first = max(len(r[0]) for r in rows)
    second = max(len(r[1]) for r in rows)
    return "\n".join(f"{a:<{first}}  {b:<{second}}  {c}".rstrip() for a, b, c in rows)


def options_dict(options: object) -> dict[str, Any]:
    """The options as a plain dict for reports (:func:`parse_options` reads it back)."""
    return dataclasses.asdict(options)  # type: ignore[call-overload, no-any-return]
