"""How a log is read: the one options type, from the command line down to the readers.

:class:`ReadOptions` gathers ``--map``, ``--resample``, ``--max-gap``, ``--split-gaps``,
``--time``, ``--sort``, ``--drop-nonfinite``, ``--recover`` and ``--msg-dir``.  It is checked
when it is built, so every value that exists is valid: the CLI builds one, the job layer
passes it on, :func:`~hybridlog.io.load_signals` and the readers take what they need from it.

Only the standard library is imported here, so that the CLI can name the options without
loading a reader.
"""

from __future__ import annotations

import contextlib
import math
import numbers
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from hybridlog.errors import OptionError, excerpt

Resample = Literal["nearest", "linear"]
TimeSource = Literal["log", "header"]

#: How outputs and true states are put on the grid (:mod:`.align`).
RESAMPLE_METHODS: tuple[str, ...] = ("nearest", "linear")

#: Where sample times come from: the recorder's log time, or each message's ``header.stamp``.
TIME_SOURCES: tuple[str, ...] = ("log", "header")

FAR_STAMP_S = 1.0
"""How far ``header.stamp`` may lie from the log time before another clock is said to set it.

The median over a topic's messages of stamp minus log time is the delay from the stamp (a
sensor's reading, a publisher's clock) to the recorder.  Delivery on one machine or a
network takes milliseconds, a sensor's processing a fraction of a second; a second or more
says another clock than the recorder's stamped the messages (simulated time from 0, where
log times are Unix times 1.7e9 s on, or an unsynchronised machine).  ``inspect`` names such
a topic; ``analyze --time header`` warns when the mapped topics' medians differ by this
much (their samples aligned on clocks that disagree)."""


def check_resample(resample: str) -> Resample:
    """``resample`` as a method name, or :class:`OptionError` naming the choices."""
    if resample not in RESAMPLE_METHODS:
        raise OptionError(
            f"--resample: unknown method {resample!r}; choose one of {', '.join(RESAMPLE_METHODS)}"
        )
    return "linear" if resample == "linear" else "nearest"


LONGEST_GAP_S = 1e9
"""The longest ``--max-gap``: the grid counts nanoseconds in int64 (up to 9.2e9 s)."""


def check_max_gap(max_gap: float | None) -> None:
    """Refuse a ``max_gap`` that is neither ``None`` nor seconds in ``[0, LONGEST_GAP_S]``."""
    if max_gap is not None and not (math.isfinite(max_gap) and 0 <= max_gap <= LONGEST_GAP_S):
        raise OptionError(
            f"--max-gap: must be between 0 and {LONGEST_GAP_S:g} seconds, got {max_gap:g}"
        )


@dataclass(frozen=True)
class ReadOptions:
    """How to read a log and align it onto the model's grid.

    Attributes
    ----------
    maps:
        ``--map SYMBOL=PATH`` values (parsed against the model's symbols when the log is read).
    resample:
        ``"nearest"`` (default) or ``"linear"``, for outputs and true states.
    max_gap:
        Longest tolerated gap in the outputs, in seconds; ``None``: ``5*dt``.
    split_gaps:
        Analyse the longest piece between over-long output gaps instead of refusing the log.
    time:
        ``"log"`` (default): the time the recorder logged each message (a table's time
        column); ``"header"``: each message's ``header.stamp``.
    sort:
        Put samples that go backwards in time into order, and keep the last of samples with
        the same time, instead of refusing the log.
    drop_nonfinite:
        Drop NaN, infinite and out-of-range samples (counted in the reading notes) instead
        of refusing the log; with ``sort``, before the last sample of a time is kept.
    recover:
        Read what is readable of a damaged or unfinished MCAP file, sequentially, instead of
        refusing it.
    msg_dirs:
        Folders of ``.msg`` files defining message types the log does not define itself.

    Raises
    ------
    OptionError
        When built with an unknown ``time`` or ``resample``, or a negative or non-finite
        ``max_gap``.
    """

    maps: tuple[str, ...] = ()
    resample: Resample = "nearest"
    max_gap: float | None = None
    split_gaps: bool = False
    time: TimeSource = "log"
    sort: bool = False
    drop_nonfinite: bool = False
    recover: bool = False
    msg_dirs: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        """Check every value: its type, then a fixed set or range (the one place they are checked).

        The command line gives each its type; a notebook may not: ``max_gap="0.5"`` was a
        ``TypeError``, ``maps="y1=level"`` and ``msg_dirs="msgs"`` were read letter by letter
        (``--map 'y'``), and ``sort="no"`` sorted.  The lists are kept as tuples of ``str``.
        """
        for name in ("maps", "msg_dirs"):
            object.__setattr__(self, name, _texts(getattr(self, name), name))
        for name in ("split_gaps", "sort", "drop_nonfinite", "recover"):
            if not isinstance(getattr(self, name), bool):
                raise _wrong(name, "True or False", getattr(self, name))
        if self.max_gap is not None:
            object.__setattr__(self, "max_gap", _seconds(self.max_gap))
        check_resample(self.resample)
        check_max_gap(self.max_gap)
        for folder in self.msg_dirs:  # a CSV or Parquet log never reads it: it was ignored
            problem = msg_dir_problem(folder)
            if problem is not None:
                raise OptionError(f"--msg-dir {folder}: {problem}")
        if self.time not in TIME_SOURCES:
            raise OptionError(
                f"--time: expected one of {', '.join(TIME_SOURCES)}, got {self.time!r}"
            )


_OPTION_NAMES = {
    "maps": "--map",
    "msg_dirs": "--msg-dir",
    "max_gap": "--max-gap",
    "split_gaps": "--split-gaps",
    "sort": "--sort",
    "drop_nonfinite": "--drop-nonfinite",
    "recover": "--recover",
}
"""Each :class:`ReadOptions` field a Python caller may give a value of the wrong type, and
its command-line option."""


def _wrong(name: str, expected: str, value: object) -> OptionError:
    """A :class:`ReadOptions` field of the wrong type, as ``jobs.arguments`` words it."""
    kind = type(value)
    module = "" if kind.__module__ == "builtins" else f"{kind.__module__}."
    return OptionError(
        f"ReadOptions {name} ({_OPTION_NAMES[name]}): expected {expected}, "
        f"got the {module}{kind.__qualname__} {excerpt(value)}"
    )


def log_arguments(path: object, options: object) -> ReadOptions:
    """``options`` of a reader's call on the log ``path``: a :class:`ReadOptions`, or the default.

    For the library's callers of :func:`~hybridlog.io.load_signals` and
    :func:`~hybridlog.io.inspect_log`, as ``jobs.arguments`` checks the jobs' arguments: a
    ``None`` path raised Python's ``TypeError``, a dict of options an ``AttributeError``.

    Raises
    ------
    OptionError
        ``path`` is not a non-empty ``str`` or path, or ``options`` not a ``ReadOptions``.
    """
    if not isinstance(path, str | os.PathLike) or not os.fspath(path):
        kind = type(path).__name__
        raise OptionError(
            f"log: expected a path (a str or pathlib.Path), got the {kind} {excerpt(path)}"
        )
    if options is None:
        return ReadOptions()
    if not isinstance(options, ReadOptions):
        kind = type(options).__name__
        raise OptionError(
            f"read: expected a hybridlog.io.ReadOptions or None, got the {kind} {excerpt(options)}"
        )
    return options


def _seconds(value: object) -> float:
    """``max_gap`` as a ``float``: a real number (a NumPy one too), not a ``bool``.

    An ``int`` beyond float64's range is infinite, for :func:`check_max_gap` to refuse.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise _wrong("max_gap", "a number of seconds or None", value)
    try:
        return float(value)
    except OverflowError:
        return math.inf


def _texts(value: object, name: str) -> tuple[str, ...]:
    """``maps`` or ``msg_dirs`` as a tuple of ``str``: a list or tuple of them (paths too).

    One ``str`` is refused, not read as its letters.
    """
    paths = name == "msg_dirs"
    expected = "a list of paths" if paths else "a list of strings"
    if isinstance(value, str | bytes | bytearray) or not isinstance(value, list | tuple):
        one = " (write [x] for one)" if isinstance(value, str) else ""
        raise _wrong(name, expected + one, value)
    items: list[str] = []
    for item in value:
        if paths and isinstance(item, os.PathLike):
            with contextlib.suppress(TypeError):  # an __fspath__ giving bytes or no path
                item = os.fspath(item)
        if not isinstance(item, str):
            raise _wrong(name, expected, item)
        items.append(item)
    return tuple(items)


def msg_dir_problem(folder: str) -> str | None:
    """Why ``folder`` is no ``--msg-dir`` (not a folder), or ``None``."""
    root = Path(folder)
    if root.is_dir():
        return None
    if root.exists():
        return "a file, not a folder of .msg files"
    if root.is_symlink():  # said "no such folder" of a link to nothing or a loop
        try:
            root.stat()
        except OSError as err:
            return f"a symbolic link that cannot be followed ({err.strerror})"
    return "no such folder"
