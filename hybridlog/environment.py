"""Environment variables hybridlog's libraries read as numbers, checked before a command runs.

numba and polars read their settings from the environment when they are imported, in the
command's worker processes, and take a malformed value badly: numba warns with a
``RuntimeWarning`` (``NUMBA_NUM_THREADS=abc``: hybridlog, which reports no number it cannot
vouch for, stopped on "numerical trouble"), ``NUMBA_NUM_THREADS=0`` raised a ``ValueError``
at numba's import (a batch's forkserver printed its traceback), ``POLARS_MAX_THREADS=0``
panicked in polars' first query, ``POLARS_MAX_THREADS=abc`` was dropped with a warning, and
``POLARS_MAX_THREADS=100000`` left every command starting polars' threads for minutes.
:func:`check_environment` refuses them up front, with one line naming the variable and its
value.

What was tried and needs no check: ``OMP_NUM_THREADS`` and ``OPENBLAS_NUM_THREADS`` (OpenBLAS
takes a malformed value as unset), ``NUMBA_THREADING_LAYER`` (read as text; used only by
numba's parallel code, which hybridlog does not run), ``TMPDIR`` (Python's :mod:`tempfile`
falls back to ``/tmp``; one too long for a batch's socket is named by
:func:`hybridlog.jobs.workers.start_forkserver`).  The cache folders ``HYBRIDLOG_CACHE_DIR``
and ``NUMBA_CACHE_DIR`` (under which :func:`hybridlog.jit.machine_code_dir` keeps the machine
code) are checked to be absolute paths (a relative one was a cache in each working folder,
each batch worker's and Dask worker's too; :func:`hybridlog.jit.cache_variable` refuses it
for the library in the same words); a folder that cannot be
written is named by :func:`hybridlog.model.compiled.store`.

Importing this module imports neither numba nor polars: numba's own table of the settings it
reads as whole numbers is read from its source (:func:`numba_whole_numbers`), and only when a
``NUMBA_`` variable is set.
"""

from __future__ import annotations

import ast
import functools
import importlib.util
import math
import os
import re
from collections.abc import Callable, Mapping
from pathlib import Path

from hybridlog.cgroups import cpu_limit
from hybridlog.errors import (
    OptionError,
    OutputError,
    absolute_folder_expected,
    environment_error,
)
from hybridlog.limits import owner_masked

__all__ = [
    "check_environment",
    "check_umask",
    "check_working_folder",
    "numba_whole_numbers",
    "usable_cores",
]


def check_working_folder() -> None:
    """Refuse to run in a working folder that was removed (``cd x; rm -r ../x``).

    Every relative path a command is given, ``--out r`` among them, is resolved against
    it, and the system then has none: ``analyze`` failed with an "unexpected
    FileNotFoundError" naming a line of hybridlog's code.

    Raises
    ------
    OptionError
        Saying so, and what to do.
    """
    try:
        os.getcwd()
    except FileNotFoundError as err:
        raise OptionError(
            "the working folder no longer exists (removed while the shell was in it); "
            "change to an existing folder and run again"
        ) from err


def check_umask() -> None:
    """Refuse to run under a umask that takes the owner's own permissions (:func:`owner_masked`).

    Checked before a command starts anything that writes: a batch's forkserver made its
    temporary folder unreadable, and its clean-up printed a traceback after the one line.

    Raises
    ------
    OutputError
        Naming the umask and one to set.
    """
    if (why := owner_masked()) is not None:
        raise OutputError(why)


def usable_cores() -> int:
    """The cores this process may use, at least 1.

    Its CPU affinity where the system has one, no more than its control groups' CPU quota
    allows (:func:`hybridlog.cgroups.cpu_limit`), rounded up (``--cpus 1.5``: 2, as the JVM
    and .NET count a container's processors).
    """
    if hasattr(os, "sched_getaffinity"):
        cores = len(os.sched_getaffinity(0))
    else:
        cores = os.cpu_count() or 1
    quota = cpu_limit()
    if quota is not None:
        cores = min(cores, math.ceil(quota))
    return max(1, cores)


def _python_int(value: str) -> int | None:
    """``value`` as numba reads a whole number (Python's ``int``), or ``None``."""
    try:
        return int(value)
    except ValueError:
        return None


def _threads(value: str) -> bool:
    number = _python_int(value)
    return number is not None and number >= 1


POLARS_THREADS_MAX = 1024
"""The most threads :data:`RULES` lets polars start.  polars starts its whole pool at its first
query, one thread after another: on the 2-core development machine 512 threads took 0.8 s,
1,024 3.8 s, 4,096 21 s and 32,768 more than a minute, in every process that reads a table
(a batch's workers each have their own pool).  A value past the bound is a slip, not a
machine."""


def _polars_threads(value: str) -> bool:
    # polars parses the trimmed text as an unsigned integer (Rust's usize: a '+' allowed)
    return (
        re.fullmatch(r"\+?[0-9]+", value.strip()) is not None
        and 1 <= int(value) <= POLARS_THREADS_MAX
    )


def _absolute_or_empty(value: str) -> bool:
    # empty is unset, as numba and jit.cache_dir take it
    return not value or os.path.isabs(value)


RULES: dict[str, tuple[Callable[[str], bool], str | Callable[[str], str]]] = {
    "NUMBA_NUM_THREADS": (_threads, "a whole number of threads, at least 1"),
    "NUMBA_OPT": (
        lambda value: value in {"0", "1", "2", "3", "max"},
        "an optimisation level 0, 1, 2, 3 or max",
    ),
    "POLARS_MAX_THREADS": (
        _polars_threads,
        f"a whole number of threads from 1 to {POLARS_THREADS_MAX} "
        "(polars starts them all at once)",
    ),
    # the cache folders, read by jit.cache_dir and jit.machine_code_dir (which refuse alike)
    "HYBRIDLOG_CACHE_DIR": (_absolute_or_empty, absolute_folder_expected),
    "NUMBA_CACHE_DIR": (_absolute_or_empty, absolute_folder_expected),
}
"""Variables with a rule of their own: (check, what is expected, or its text for the value)."""


@functools.cache
def numba_whole_numbers() -> frozenset[str]:
    """The ``NUMBA_`` settings numba reads with ``int`` (its ``_readenv(name, int, ...)`` calls).

    Read from ``numba/core/config.py`` with :mod:`ast`, without importing numba (its import
    loads LLVM: seconds of a command that may never use it).  Empty when numba is not
    installed or its file no longer reads so; then only :data:`RULES` are checked.
    """
    spec = importlib.util.find_spec("numba")
    if spec is None or not spec.submodule_search_locations:
        return frozenset()
    try:
        source = (Path(spec.submodule_search_locations[0]) / "core" / "config.py").read_text()
        tree = ast.parse(source)
    except (OSError, SyntaxError, ValueError):
        return frozenset()
    names: set[str] = set()
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id == "_readenv"
            and len(node.args) >= 2
            and isinstance(name := node.args[0], ast.Constant)
            and isinstance(name.value, str)
            and isinstance(ctor := node.args[1], ast.Name)
            and ctor.id == "int"
        ):
            names.add(name.value)
    return frozenset(names)


def check_environment(environ: Mapping[str, str] | None = None) -> None:
    """Refuse a malformed number numba or polars reads, or a cache folder's relative path.

    ``environ`` defaults to :data:`os.environ`.

    Raises
    ------
    OptionError
        ``environment variable NUMBA_NUM_THREADS='abc': expected a whole number of threads,
        at least 1; unset it or set it so``: the first malformed one.
    """
    environ = os.environ if environ is None else environ
    numba_set = sorted(name for name in environ if name.startswith("NUMBA_"))
    whole = numba_whole_numbers() if numba_set else frozenset()
    for name in [*numba_set, *(n for n in RULES if not n.startswith("NUMBA_"))]:
        value = environ.get(name)
        if value is None:
            continue
        if name in RULES:
            check, expected = RULES[name]
        elif name in whole:
            check, expected = (lambda v: _python_int(v) is not None), "a whole number"
        else:
            continue
        if not check(value):
            said = expected if isinstance(expected, str) else expected(value)
            raise environment_error(name, value, said)
