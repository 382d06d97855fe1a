"""The jobs' arguments from a Python caller, checked as the command line checks its values.

The command line hands every job strings, tuples of strings and flags of the right types; a
notebook or a test suite calling :func:`~hybridlog.jobs.analysis.analyze` may not.  Unchecked,
``sets="A=100"`` was read letter by letter (``--set: 'A' is not NAME=VALUE``),
``compare(..., "imm,hstf")`` said ``'m' named twice``, ``run_batch("run.csv", ...)`` took the
folder ``/`` (its first letter) for a folder of logs and searched the whole file system until
a bare ``PermissionError``, ``smooth="no"`` smoothed, and ``read={...}``, ``estimator=3`` or a
log path in ``bytes`` ended in an ``AttributeError`` or a ``TypeError``.  Each job checks its
arguments here before anything else; a wrong one is an
:class:`~hybridlog.errors.OptionError` naming the parameter, its command-line option and
what it was given.
"""

from __future__ import annotations

import operator
import os
from collections.abc import Collection, Sequence
from typing import Literal, SupportsIndex, TypeGuard, overload

import numpy as np

from hybridlog.errors import OptionError, excerpt
from hybridlog.io import ReadOptions
from hybridlog.jit import cache_variable

__all__ = [
    "callback",
    "common",
    "flag",
    "instance",
    "integer",
    "names",
    "path",
    "paths",
    "read_options",
    "set_texts",
    "text",
    "texts",
]

OPTIONS = {
    "out_dir": "--out",
    "out": "--out",
    "estimator": "--estimator",
    "estimators": "--estimators",
    "sets": "--set",
    "fail_under": "--fail-under",
    "fail_over": "--fail-over",
    "table_format": "--table-format",
    "force": "--force",
    "smooth": "--smooth",
    "mode_sequence": "--mode-sequence",
    "jobs": "--jobs",
    "scheduler": "--scheduler",
    "plots": "--plots",
    "junit": "--junit",
    "plot": "--plot",
    "compare_kmeans": "--compare-kmeans",
    "log_format": "--format",
    "encoding": "--encoding",
    "schedule": "--schedule",
    "steps": "--steps",
    "seed": "--seed",
    "noise": "--no-noise",
    "disturbance": "--disturbance",
}
"""The command-line option each checked parameter with one stands for, named in its error."""


def _type_name(value: object) -> str:
    """``value``'s type, with its module unless a builtin: ``numpy.bool``, not ``bool``."""
    kind = type(value)
    module = kind.__module__
    return kind.__qualname__ if module == "builtins" else f"{module}.{kind.__qualname__}"


def _refuse(parameter: str, expected: str, value: object) -> OptionError:
    option = f" ({OPTIONS[parameter]})" if parameter in OPTIONS else ""
    return OptionError(
        f"{parameter}{option}: expected {expected}, got the {_type_name(value)} {excerpt(value)}"
    )


def _is_path(value: object) -> bool:
    if isinstance(value, str):
        return True
    try:  # os.fspath raises TypeError where __fspath__ gives neither str nor bytes
        return isinstance(value, os.PathLike) and isinstance(os.fspath(value), str)
    except TypeError:
        return False


def _is_list(value: object) -> TypeGuard[Sequence[object]]:
    """A list or tuple of items: not one ``str``, nor ``bytes`` (a sequence of ints)."""
    return isinstance(value, Sequence) and not isinstance(value, str | bytes | bytearray)


def _one_text(value: object) -> str:
    return " (not one str)" if isinstance(value, str) else ""


def path(value: object, parameter: str, *, optional: bool = False) -> None:
    """Refuse ``value`` unless it is a path as a ``str`` or :class:`~pathlib.Path` (or ``None``).

    A path in ``bytes`` is refused: the checks and messages take text.
    """
    if not (_is_path(value) or (optional and value is None)):
        raise _refuse(parameter, "a path (a str or pathlib.Path)", value)


def paths(value: object, parameter: str) -> None:
    """Refuse ``value`` unless it is a list or tuple of paths (a single path is not split)."""
    if _is_path(value) or not _is_list(value):
        raise _refuse(parameter, "a list of paths (write [path] for one)", value)
    for item in value:
        path(item, parameter)


def texts(value: object, parameter: str) -> None:
    """Refuse ``value`` unless it is a list or tuple of ``str`` (a single ``str`` is not split)."""
    if not _is_list(value):
        raise _refuse(parameter, f"a list of strings{_one_text(value)}", value)
    for item in value:
        if not isinstance(item, str):
            raise _refuse(parameter, "a list of strings", item)


def text(value: object, parameter: str, *, optional: bool = False) -> None:
    """Refuse ``value`` unless it is a ``str`` (or ``None``, where ``optional``)."""
    if not (isinstance(value, str) or (optional and value is None)):
        raise _refuse(parameter, "a string" + (" or None" if optional else ""), value)


@overload
def integer(value: object, parameter: str, *, optional: Literal[False] = False) -> int: ...


@overload
def integer(value: object, parameter: str, *, optional: Literal[True]) -> int | None: ...


def integer(value: object, parameter: str, *, optional: bool = False) -> int | None:
    """``value`` as an ``int``: a whole number (``numpy.int64`` too), not a ``bool``.

    ``None`` where ``optional``.  A NumPy integer (``rng.integers(...)`` as a seed) is
    taken as the ``int`` it holds; anything else, a ``float`` too, is refused.
    """
    if optional and value is None:
        return None
    if isinstance(value, bool | np.bool_) or not isinstance(value, SupportsIndex):
        raise _refuse(parameter, "an int" + (" or None" if optional else ""), value)
    return operator.index(value)


def flag(value: object, parameter: str) -> None:
    """Refuse ``value`` unless it is a ``bool`` (``smooth="no"`` smoothed)."""
    if not isinstance(value, bool):
        raise _refuse(parameter, "True or False", value)


def instance(value: object, kind: type, parameter: str, named: str) -> None:
    """Refuse ``value`` unless it is ``None`` or a ``kind`` (``chiu={"radius": 0.3}``).

    ``named``: where a caller imports ``kind`` from, as the error names it.
    """
    if not (value is None or isinstance(value, kind)):
        raise _refuse(parameter, f"a {named} or None", value)


def names(value: object, parameter: str, known: Collection[str]) -> None:
    """Refuse ``value`` unless it is ``None`` or a collection of names among ``known``.

    One ``str`` is refused, not read as its letters (``given="radius"`` named no option).
    """
    if value is None:
        return
    if isinstance(value, str | bytes | bytearray) or not isinstance(value, Collection):
        raise _refuse(parameter, f"a list of names or None{_one_text(value)}", value)
    for item in value:
        if not isinstance(item, str):
            raise _refuse(parameter, "a list of names", item)
        if item not in known:
            raise OptionError(
                f"{parameter}: {excerpt(item)} is no option; expected some of {', '.join(known)}"
            )


def callback(value: object, parameter: str) -> None:
    """Refuse ``value`` unless it is ``None`` or callable (checked before any work)."""
    if not (value is None or callable(value)):
        raise _refuse(parameter, "a callable or None", value)


def set_texts(values: Sequence[str]) -> dict[str, str]:
    """``--set NAME=VALUE`` texts → ``{name: value as typed}``, each named in its error.

    One reading for ``analyze``, ``compare``, ``batch``
    (:func:`~hybridlog.jobs.overrides.parse_sets`) and ``simulate``, which each kept a copy.
    """
    found: dict[str, str] = {}
    for given in values:
        name, sep, value = given.partition("=")
        name = name.strip()
        if not sep or not name:
            raise OptionError(f"--set: {excerpt(given)} is not NAME=VALUE")
        if name in found:
            raise OptionError(f"--set {excerpt(name)[1:-1]}: given twice")
        found[name] = value
    return found


def read_options(value: object) -> ReadOptions:
    """``value`` if it is a :class:`~hybridlog.io.ReadOptions`; ``None`` gives the defaults."""
    if value is None:
        return ReadOptions()
    if not isinstance(value, ReadOptions):
        raise _refuse("read", "a hybridlog.io.ReadOptions or None", value)
    return value


def common(
    model_ref: object,
    *,
    sets: object,
    read: object,
    fail_under: object,
    fail_over: object,
    table_format: object,
    force: object,
    smooth: object,
    mode_sequence: object,
) -> ReadOptions:
    """Check the arguments ``analyze``, ``compare`` and ``run_batch`` share; the read options.

    The cache folders' variables first (:func:`hybridlog.jit.cache_variable`), as the
    command line checks them before any command: a relative ``NUMBA_CACHE_DIR``, read only
    where numba is first set up, failed each log of ``run_batch`` with ``jobs=1``, and with
    ``jobs=2`` killed the workers' forkserver while it warmed up (a traceback, then
    ``EOFError: unexpected EOF``).
    """
    for variable in ("HYBRIDLOG_CACHE_DIR", "NUMBA_CACHE_DIR"):
        cache_variable(variable)
    path(model_ref, "model_ref")
    for name, given in (("sets", sets), ("fail_under", fail_under), ("fail_over", fail_over)):
        texts(given, name)
    text(table_format, "table_format")
    text(mode_sequence, "mode_sequence", optional=True)
    flag(force, "force")
    flag(smooth, "smooth")
    return read_options(read)
