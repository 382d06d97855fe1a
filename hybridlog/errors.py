"""The one error family of hybridlog.

Every failure caused by what a user gave (a log, a model file, an option) is raised as a
subclass of :class:`HybridlogError` whose message is one line naming the file, key, field or
line at fault.  The CLI turns these into exit code 2; nothing below the CLI prints or exits.
"""

from __future__ import annotations

import re
import unicodedata
from contextlib import contextmanager
from typing import TYPE_CHECKING, TypeVar

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence

T = TypeVar("T")


class HybridlogError(Exception):
    """Base class of every error hybridlog raises on purpose.

    ``named``: the names of the ``--set`` values (model parameters, estimator options,
    scenario parameters) whose setting the message names already (``--set A=0: m.toml:
    ...``), or that cannot have changed what failed (:func:`independent_of`), so that
    :func:`after_given` does not name them.  Kept by :func:`prefixed` and by pickling (a
    worker's error reaches the command intact).
    """

    named: frozenset[str] = frozenset()

    def __init__(self, *args: object, named: Iterable[str] = ()) -> None:
        super().__init__(*args)
        self.named = frozenset(named)


class ModelError(HybridlogError):
    """A model file (TOML) is malformed, names an unknown symbol or has a wrong shape."""


class UnusedParameterError(ModelError):
    """``--set`` of a model parameter no expression reads: the run would be the run without it."""


class DivergenceError(ModelError):
    """An estimator's run broke on a log every check accepted: the result cannot be vouched for.

    Its estimate or a variance went non-finite or negative, the model left its domain at an
    estimate, or the run met numerical trouble (:mod:`hybridlog.estimators.vouch`).  For one
    estimator (``analyze``) it is an error like any other; ``compare`` reports it as that
    estimator's result, its row saying why, and writes the others'.  A model that is wrong
    whatever the log (a singular covariance) is a plain :class:`ModelError`.
    """


class LogError(HybridlogError):
    """A log is unreadable, lacks a mapped signal or holds values that cannot be used."""


class OptionError(HybridlogError):
    """A command-line option or estimator option has an invalid name or value."""


class DataShortError(OptionError):
    """Data too short for the options: lags as long as it, fewer distinct points than clusters.

    Raised by the algorithms over arrays (:mod:`hybridlog.cluster`), which know no file: the
    message names the option and the counts, and whoever knows where the data came from
    raises a :class:`LogError` naming the log from it
    (:func:`hybridlog.estimators.chiu.mode_classifier`).
    """


class OutputError(HybridlogError):
    """An output path cannot be written without destroying something the user has."""


class ReportError(HybridlogError):
    """A ``report.json`` cannot be read back: not JSON, not a hybridlog report, or malformed."""


def prefixed(err: HybridlogError, prefix: str) -> HybridlogError:
    """``err``'s message after ``prefix``, as an error of its kind in this module's family.

    A subclass elsewhere may take more than a message (``UnfinishedLogError``'s file and
    counts); the copy is of the nearest class here, whose constructor takes the message
    alone, so that the exit code and the handling of the kind stay the same.
    """
    return _kind(err)(f"{prefix}{err}", named=err.named)


def suffixed(err: HybridlogError, suffix: str) -> HybridlogError:
    """``err``'s message, then ``suffix``, as an error of its kind (as :func:`prefixed`)."""
    return _kind(err)(f"{err}{suffix}", named=err.named)


def after_given(err: HybridlogError, given: Mapping[str, str]) -> HybridlogError:
    """``err``, then the command-line values that changed what failed: ``(after --set fE=1000)``.

    ``given``: name → the option as typed (``fE`` → ``--set fE=1000``; ``smooth`` →
    ``--smooth``), every value the command line changed of what raised ``err`` (a run of
    the model, an estimator).  Those ``err`` names already (:attr:`HybridlogError.named`) are
    left out; ``err`` itself is returned when none is left.  An error raised during a run
    said what broke (a step too long, a filter that diverged) but not which of several
    ``--set`` options made it break.
    """
    rest = {name: shown for name, shown in given.items() if name not in err.named}
    if not rest:
        return err
    return _kind(err)(
        f"{err} (after {', '.join(rest.values())})", named=err.named | frozenset(rest)
    )


@contextmanager
def given_in_errors(
    given: Mapping[str, str], kinds: tuple[type[HybridlogError], ...] = (HybridlogError,)
) -> Iterator[None]:
    """Errors of ``kinds`` raised inside name the command-line values ``given`` changed.

    The one place a run's errors (an estimator's, a simulation's) get the ``--set``
    options that changed what the run used: ``… (after --set fE=1000, --set beam=5)``
    (:func:`after_given`; those a message names already are not named again).  ``given``:
    name → option as typed (:func:`hybridlog.jobs.origins.given_values`).
    """
    try:
        yield
    except kinds as err:
        named = after_given(err, given)
        if named is err:
            raise
        raise named from err


@contextmanager
def independent_of(names: Iterable[str]) -> Iterator[None]:
    """Errors raised inside cannot have been changed by the values of ``names``.

    They join each error's :attr:`HybridlogError.named`, so :func:`after_given` does not
    blame them: the IMM's forward pass, which no offline-pass option changes, stopped on a
    sample no mode explains, and the message ended ``(after --smooth)`` as if the smoother
    had failed (:func:`hybridlog.estimators.imm.run_imm`).
    """
    try:
        yield
    except HybridlogError as err:
        err.named = err.named | frozenset(names)
        raise


def set_text(name: str, text: str) -> str:
    """``--set NAME=VALUE`` as typed (the value quoted as an error quotes it, unquoted)."""
    return f"--set {name}={excerpt(text)[1:-1]}"


def _kind(err: HybridlogError) -> type[HybridlogError]:
    """The nearest class of ``err`` in this module (whose constructor takes the message)."""
    return next(
        c for c in type(err).__mro__ if c.__module__ == __name__ and issubclass(c, HybridlogError)
    )


EXCERPT_LIMIT = 80
"""Longest excerpt of user-supplied text quoted in an error message."""


def excerpt(text: object, limit: int = EXCERPT_LIMIT) -> str:
    r"""``text`` as a short, printable, one-line quotation for an error message.

    Control characters (NUL bytes of a zeroed file, newlines) are shown escaped and anything
    longer than ``limit`` characters is cut in the middle with an ellipsis, so that an error
    about a 16 KB line or a deeply nested expression stays one short line.  A byte of a
    file name that is not UTF-8 is written ``\xNN``, as :func:`as_text` and the summaries
    write it (it read ``\udcff`` in notes and errors, ``\xff`` in summary.md).

    Examples
    --------
    >>> excerpt("a\x00b")
    "'a\\x00b'"
    >>> len(excerpt("x" * 10_000)) <= EXCERPT_LIMIT + 2
    True
    >>> excerpt("run\udcff.csv")
    "'run\\xff.csv'"
    """
    raw = as_text(text)
    keep = max(limit - 1, 2)
    head, tail = keep - keep // 3, keep // 3
    if len(raw) > limit:
        # escaping only lengthens a character: the excerpt's ends are the escaped ends of
        # the text's, cut before escaping (a 50 MB line of NUL bytes in a model file, or a
        # mode name of a centres file, escaped whole took 4 GB: 80 bytes a character)
        return "'" + printable(raw[:head])[:head] + "…" + _escaped_end(raw, tail) + "'"
    shown = printable(raw)
    if len(shown) > limit:
        shown = shown[:head] + "…" + shown[len(shown) - tail :]
    return "'" + shown + "'"


def _escaped_end(text: str, count: int) -> str:
    """The last ``count`` characters of ``printable(text)``, escaping only those it needs."""
    if count <= 0:
        return ""
    end = printable(text[len(text) - count :])
    return end[len(end) - count :]


def printable(text: object) -> str:
    r"""``text`` with every character that is not printable escaped (``\x00``, ``\n``).

    By :meth:`str.translate`, whose output is the only copy made: a character at a time as
    a list of strings took 80 bytes a character (4 GB for a 50 MB text).
    """
    return as_text(text).translate(_ESCAPES)


class _Escapes(dict[int, str]):
    """``str.translate``'s table: each character's escape, found when first met.

    Kept for the Basic Multilingual Plane alone (at most 65,536 entries, about 10 MB): a
    text of every code point would otherwise leave 1.1 million in a long-lived process.
    """

    def __missing__(self, code: int) -> str:
        character = chr(code)
        escaped = (
            character
            if character.isprintable()
            else character.encode("unicode_escape").decode("ascii")
        )
        if code < _KEPT_ESCAPES:
            self[code] = escaped
        return escaped


_KEPT_ESCAPES = 0x10000
"""The code points whose escapes :class:`_Escapes` keeps."""


_ESCAPES = _Escapes()


_LINE_BREAKS = re.compile(r" *[\t\n\v\f\r\x1c-\x1f\x85\u2028\u2029]\s*")
"""A run of white space with a line break or tab in it (a message written over lines)."""


def on_one_line(text: str) -> str:
    """``text`` with each run of white space that breaks a line or tabs one space, trimmed.

    Runs of plain spaces stay: they are the user's, in a quoted name (``'run  1.csv'`` read
    ``'run 1.csv'``, another file's name, where all white space was squeezed).
    """
    return _LINE_BREAKS.sub(" ", text).strip()


def shortened(text: str, limit: int, *, end_share: float = 1 / 3) -> str:
    """``text`` on one line (:func:`on_one_line`), at most ``limit`` characters.

    A longer one is cut in the middle, where a message says least (it starts with the file or
    option and ends with what is wrong), the end keeping ``end_share`` of the room; the cut
    falls between words where one is near, so that no number is cut in two (``t = 0.0015 s``
    read ``t = 0.… s``), and within a word only where there is none (a quoted 16 KB line),
    never between a letter and its combining marks (:func:`_joined`).
    """
    line = on_one_line(text)
    if len(line) <= limit:
        return line
    tail_room = round((limit - 1) * end_share)
    head_room = limit - 1 - tail_room
    start = len(line) - tail_room
    head, tail = line[:head_room], line[start:]
    space = head.rfind(" ")
    if space >= head_room - head_room // 4:  # a word boundary within the last quarter
        head = head[: space + 1]
    inside = _escape_interiors(line)
    while head and (_joined(line, len(head)) or len(head) in inside):  # 'é', not 'e'
        head = head[:-1]
    space = tail.find(" ")
    if 0 <= space <= tail_room // 4:
        tail = tail[space:]
    while tail and (_joined(line, len(line) - len(tail)) or len(line) - len(tail) in inside):
        tail = tail[1:]  # no mark on the ellipsis, no escape's digits after it
    return head + "…" + tail


_ESCAPE = re.compile(r"\\(?:x[0-9a-fA-F]{2}|u[0-9a-fA-F]{4}|U[0-9a-fA-F]{8}|[ntr])")
r"""A character :func:`printable` wrote as an escape (``\x1b``, ``\n``)."""


def _escape_interiors(line: str) -> frozenset[int]:
    r"""The positions inside an escape of ``line`` (after its ``\``): no cut falls there.

    A long word of control characters, escaped by :func:`printable` before the CLI's line
    is cut, was cut inside one: ``\x…0``.
    """
    if "\\" not in line:
        return frozenset()
    return frozenset(
        at for found in _ESCAPE.finditer(line) for at in range(found.start() + 1, found.end())
    )


def _joined(line: str, at: int) -> bool:
    """Whether ``line[at]`` belongs with the character before it.

    A combining mark (an accent, a variation selector), a zero-width joiner or the character
    after one: a cut there left an accent on the ellipsis, or half an emoji.
    """
    joiner = "\u200d"
    return 0 < at < len(line) and (
        unicodedata.category(line[at]).startswith("M") or joiner in (line[at], line[at - 1])
    )


ABSOLUTE_FOLDER = (
    "an absolute path (a relative one is a folder of each process's working folder, not one "
    'cache; write "$PWD/..." for the folder the shell is in)'
)
"""What a cache folder's variable (``HYBRIDLOG_CACHE_DIR``, ``NUMBA_CACHE_DIR``) must be:
checked before a command starts (:func:`hybridlog.environment.check_environment`) and where
the library reads it (:func:`hybridlog.jit.cache_dir`, :func:`hybridlog.jit.machine_code_dir`),
both through :func:`absolute_folder_expected`."""


def absolute_folder_expected(value: str) -> str:
    """:data:`ABSOLUTE_FOLDER`, for a value starting with ``~`` also that nothing expanded it.

    A shell expands ``~`` only where it starts a word (``X=~/c`` but not ``X="~/c"``), and a
    CI file's or a service's environment not at all: the value reached hybridlog as written.
    """
    if value.startswith("~"):
        return (
            "an absolute path ('~' is the shell's, and nothing expanded it here: write "
            '"$HOME/..." for a folder of your home)'
        )
    return ABSOLUTE_FOLDER


def environment_error(name: str, value: str, expected: str) -> OptionError:
    """``environment variable NAME='value': expected ...; unset it or give it such a value``."""
    return OptionError(
        f"environment variable {name}={excerpt(value)}: expected {expected}; "
        "unset it or give it such a value"
    )


def first_few(
    items: Sequence[T],
    shown: int,
    show: Callable[[T], str],
    *,
    separator: str = ", ",
    before_more: str = " and ",
) -> str:
    """The first ``shown`` of ``items`` as ``show`` writes them, the others counted.

    How a note names what may be thousands of paths in one line.

    Examples
    --------
    >>> first_few(["a", "b", "c", "d"], 2, str)
    'a, b and 2 more'
    """
    listed = separator.join(show(item) for item in items[:shown])
    rest = len(items) - shown
    return f"{listed}{before_more}{rest} more" if rest > 0 else listed


def as_text(text: object) -> str:
    r"""``text`` (a path as the system gave it) as text that UTF-8 can hold.

    A file name that is not UTF-8 reaches Python with each undecodable byte as a lone
    surrogate (``surrogateescape``), which no UTF-8 file, JSON, XML or terminal can take;
    such a byte is written ``\xNN`` instead, as ``ls`` shows it.  Every other character,
    line breaks included, is kept: a report and a summary name the log as it was given.

    Examples
    --------
    >>> as_text("run\udcff.csv")
    'run\\xff.csv'
    >>> as_text("sub/run.csv")
    'sub/run.csv'
    """
    shown = str(text)
    try:
        return shown.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
    except UnicodeEncodeError:  # a surrogate that is no escaped byte
        return shown.encode("utf-8", "backslashreplace").decode("utf-8")


def as_name(path: object) -> str:
    r"""``path`` as text that UTF-8 can hold and that no other name reads as.

    As :func:`as_text` (a byte that is not UTF-8 written ``\xNN``), with each backslash of
    the name written ``\\`` (as ``ls -b`` writes it), so that the escapes written for what
    a summary's format cannot hold (that byte; a control character in JUnit XML or
    Markdown, ``\x01``; a line break in Markdown, ``\n``) never read as another log's name:
    the logs ``ctl\x01.csv``, named with a control character, and ``ctl\\x01.csv``, named
    with a backslash, were one test case of a batch's JUnit file and one name in
    summary.md, summary.csv and its gate lines.

    Examples
    --------
    >>> as_name("run\udcff.csv"), as_name("run\\xff.csv")
    ('run\\xff.csv', 'run\\\\xff.csv')
    """
    return as_text(str(path).replace("\\", "\\\\"))


def names_apart(names: Sequence[str]) -> list[str]:
    r"""``names`` (as :func:`as_name` writes them), those that read alike written apart.

    Two names equal in Unicode's composed form (NFC) but not as text, ``café.csv`` with
    ``é`` one character and with ``e`` and a combining accent (as macOS writes names), are
    two files that look one in every summary: two rows alike in summary.md and summary.csv,
    two test cases of one name in a JUnit file.  Each such name is written with its
    characters beyond ASCII as ``\uXXXX`` (``caf\u00e9.csv``, ``cafe\u0301.csv``); every
    other name is kept.  No other name reads as one so written: its backslash is ``\\``.

    Examples
    --------
    >>> names_apart(["caf\u00e9.csv", "cafe\u0301.csv", "th\u00e9.csv"])
    ['caf\\u00e9.csv', 'cafe\\u0301.csv', 'thé.csv']
    """
    forms: dict[str, set[str]] = {}
    for name in names:
        forms.setdefault(unicodedata.normalize("NFC", name), set()).add(name)
    return [
        _escaped_beyond_ascii(name) if len(forms[unicodedata.normalize("NFC", name)]) > 1 else name
        for name in names
    ]


def _escaped_beyond_ascii(name: str) -> str:
    return "".join(
        c if c.isascii() else f"\\u{ord(c):04x}" if ord(c) <= 0xFFFF else f"\\U{ord(c):08x}"
        for c in name
    )


def arithmetic_reason(err: BaseException) -> str:
    """Why a computation failed, as a person reads it: ``Numerical result out of range``.

    Python's ``x ** y`` overflow is ``OverflowError(34, 'Numerical result out of range')``,
    whose ``str`` is the tuple ``(34, 'Numerical result out of range')``: the C errno
    number leaked into an error line.  Such an ``(errno, text)`` pair gives its text; any
    other error its ``str``.
    """
    args = err.args
    if len(args) == 2 and isinstance(args[0], int) and isinstance(args[1], str):
        return args[1]
    return str(err)
