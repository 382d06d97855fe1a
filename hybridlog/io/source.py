"""What every log reader provides: named sample series and a description of itself.

A reader (CSV/Parquet table, MCAP file, ROS bag ...) implements :class:`LogSource`.  Everything
after reading -- signal mapping, finiteness checks, alignment onto the model's grid -- works on
the :class:`Series` and :class:`LabelSeries` a source returns and never looks at the format.

Times are integer nanoseconds (``int64``) from reading on: float seconds lose sub-microsecond
resolution at Unix-epoch magnitudes and make "is this sample on the grid" comparisons fragile.
"""

from __future__ import annotations

import difflib
import math
import unicodedata
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any, Protocol, Self

import numpy as np
import numpy.typing as npt

from hybridlog.errors import LogError, names_apart
from hybridlog.signals import MAX_MAGNITUDE, BoolArray, FloatArray, IntArray

NS_PER_S = 1_000_000_000

MAX_SECONDS = 9.2e9
"""|t| beyond this many seconds does not fit into int64 nanoseconds (about 292 years)."""

BLOCK = 1 << 16
"""Elements per block where a full-size array is converted or checked in blocks."""

FieldKey = tuple[str, tuple[str | int, ...]]
"""What a field name names (:meth:`LogSource.field_key`): its column or topic, and the steps
into it (field names and indices, each index into an array of known length counted from its
start)."""


class FieldError(LogError):
    """A mapped field's values cannot be read: ``{file}: '{field}': {reason}``.

    With ``file``, ``field`` and ``reason`` apart, so that
    :func:`~hybridlog.io.load.load_signals` names the symbol the field feeds and where it
    came from (:meth:`~hybridlog.io.mapping.SignalMap.place`), as the mapping names it for a
    field that does not fit the log: an index out of range of a topic's array read
    ``'/p': .position[3]: ...`` where a field the schema lacks read ``output 'y' (field
    '/p.nope', from --map y=/p.nope): ...``.
    """

    def __init__(self, file: str, name: str, reason: str, *, unusable: bool = False) -> None:
        super().__init__(f"{file}: {name!r}: {reason}")
        self.file, self.name, self.reason = file, name, reason
        self.unusable = unusable
        """The messages lack what the reading asks of the whole topic (``header.stamp`` under
        ``--time header``), as a typed topic's definition shows before the read: the field
        cannot be used as asked, rather than holds a bad value."""


@dataclass(frozen=True)
class Series:
    """Samples of one numeric field, in time order.

    Attributes
    ----------
    name:
        The field (column name or message path) the samples came from.
    time_ns:
        Sample times in integer nanoseconds, strictly increasing, shape ``(n,)``.
    values:
        Sample values, shape ``(n,)``.
    """

    name: str
    time_ns: IntArray
    values: FloatArray


@dataclass(frozen=True)
class LabelSeries:
    """Samples of one field holding labels (a mode id per sample), in time order.

    The labels are stored as codes into ``categories`` so that mapping them onto a model's mode
    ids costs one look-up per distinct label, not per sample.

    Attributes
    ----------
    name:
        The field the samples came from.
    time_ns:
        Sample times in integer nanoseconds, strictly increasing, shape ``(n,)``.
    codes:
        Index into ``categories`` of each sample's label, shape ``(n,)``.
    categories:
        The distinct labels (whitespace stripped), in order of first appearance.
    """

    name: str
    time_ns: IntArray
    codes: IntArray
    categories: tuple[str, ...]


@dataclass(frozen=True)
class SourceInfo:
    """The static facts of an open log, for messages, mapping and reports.

    Attributes
    ----------
    path:
        The log's path as given, which prefixes every error message.
    format:
        The log's format for reports and ``inspect``: ``"csv"``, ``"mcap"``,
        ``"ros2-bag (sqlite3)"`` ... (a row name of :data:`~hybridlog.io.formats.FORMATS`,
        refined where the reader learns more, such as a bag folder's storage).
    message_paths:
        Whether fields are message paths (``/topic.field``) rather than column names.
    """

    path: str
    format: str
    message_paths: bool

    @property
    def field_word(self) -> str:
        """What a field is called in messages: ``"field"`` in message logs, else ``"column"``."""
        return "field" if self.message_paths else "column"


def field_location(name: str, index: int) -> str:
    """Where a sample of a message log sits: its field (the messages quote its time)."""
    return f"field {name!r}"


@dataclass(frozen=True)
class Reading:
    """What :meth:`LogSource.read` returns.

    Attributes
    ----------
    numeric:
        ``{field: Series}`` of the fields read as numbers.
    labels:
        ``{field: LabelSeries}`` of the fields read as labels.
    notes:
        What reading did that a report should record (recovery, sorting); JSON-ready.
    locate:
        ``locate(field, index)``: where sample ``index`` of ``field`` sits in the file, e.g.
        ``"line 17, column 'y'"``, for messages about its value.
    """

    numeric: dict[str, Series]
    labels: dict[str, LabelSeries]
    notes: dict[str, Any] = field(default_factory=dict)
    locate: Callable[[str, int], str] = field_location


class LogSource(Protocol):
    """A readable log: what signal mapping, alignment and ``inspect`` rely on.

    Sources are context managers; :meth:`read` may be called once per source, with every field
    the caller needs, so that a reader can decode the file in one pass.  A reader is chosen
    from the table of formats (:mod:`.formats`); :class:`~hybridlog.io.tables.TableSource`
    and :class:`~hybridlog.io.messages.MessageSource` are the two families.
    """

    @property
    def info(self) -> SourceInfo:
        """The log's path, format and kind of field names."""
        ...

    def fields(self) -> tuple[str, ...]:
        """Names of the fields a symbol can be mapped to (the time field excluded).

        For message logs these are the numeric and text leaves of every topic's messages;
        arrays are listed as ``field[]`` and take any index.
        """
        ...

    def explain_missing(self, name: str, numeric: bool = False) -> str | None:
        """``None`` when ``name`` is a field of the log, else why not (with close names).

        With ``numeric``, a field that holds text (not a number) is explained as unusable.
        """
        ...

    def field_key(self, name: str) -> FieldKey:
        """What ``name`` names, the same for every spelling of one field.

        ``/y1/data`` and ``/y1.data`` of a message log name one field, as a path with spaces
        around it names the field without, and ``q[-1]`` names ``q[2]`` of an array of three;
        mapping compares these to find one field given to two symbols.  ``(name, ())`` when
        it names no field.
        """
        ...

    def read(self, numeric: Sequence[str], labels: Sequence[str] = ()) -> Reading:
        """Read the named fields: ``numeric`` as float series, ``labels`` as label series.

        Raises
        ------
        LogError
            When a field is missing, not numeric, or its timestamps are unusable.
        """
        ...

    def describe(self) -> dict[str, Any]:
        """A JSON-serialisable summary for ``hybridlog inspect``."""
        ...

    def __enter__(self) -> Self:
        """Open the source."""
        ...

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """Release whatever the source holds."""
        ...


def seconds_to_ns(seconds: FloatArray) -> IntArray:
    """Convert finite float seconds to integer nanoseconds, rounding to the nearest.

    The whole and fractional seconds are converted separately: ``t - floor(t)`` is exact in
    floating point, so the result is the nanosecond nearest to the float even for Unix-epoch
    times, where ``t * 1e9`` alone would be off by up to 128 ns.

    Parameters
    ----------
    seconds:
        Finite times in seconds with ``|t| < 9.2e9``; the caller checks both.

    Returns
    -------
    numpy.ndarray
        ``int64`` nanoseconds, same shape.
    """
    seconds = np.asarray(seconds, dtype=np.float64)
    result: IntArray = np.empty(seconds.shape, dtype=np.int64)
    flat_in, flat_out = seconds.reshape(-1), result.reshape(-1)
    # In blocks: the temporaries are a block's, not the whole array's (a 10^6-row log
    # peaked at four full-size arrays); every element gets the same operations.
    for lo in range(0, flat_in.size, BLOCK):
        part = flat_in[lo : lo + BLOCK]
        whole = np.floor(part)
        fraction = part - whole
        fraction *= 1e9
        np.rint(fraction, out=fraction)
        out = flat_out[lo : lo + BLOCK]
        out[...] = whole
        out *= NS_PER_S
        out += fraction.astype(np.int64)
    return result


_EXACT_NS = 2**53
"""Nanosecond counts up to this are exact in float64."""


def ns_to_seconds(ns: IntArray) -> FloatArray:
    """Convert integer nanoseconds to float seconds, the float nearest to each time.

    A count of at most ``2**53`` ns (104 days) is exact in float64, so ``ns / 1e9`` rounds
    once, correctly.  A larger one (a Unix time: ``ns / 1e9`` held 1.7e18 ns to 256 ns, then
    divided, and put 1700000001510000000 ns at 1700000001.5100002 s, a time the log never
    had, in report.json and timeline.csv) is divided as whole seconds (exact in float64)
    and the fraction (a count below 1e9, exact too), added once: beyond ``2**23`` s the
    fraction's rounding is far below the sum's half step, and the sum is the nearest float,
    as Python's ``int / int``.  Small times take the first way: split, -300000000 ns was
    ``-1 + 0.7``, -0.30000000000000004 s, and 1930000000 ns 1.9300000000000002 s.

    Examples
    --------
    >>> ns_to_seconds(np.array([1_700_000_001_510_000_000, -300_000_000])).tolist()
    [1700000001.51, -0.3]
    """
    counts = np.asarray(ns, dtype=np.int64)
    if counts.size == 0 or (counts.min() >= -_EXACT_NS and counts.max() <= _EXACT_NS):
        seconds: FloatArray = counts.astype(np.float64)
        seconds /= 1e9
        return seconds
    if counts.min() > _EXACT_NS or counts.max() < -_EXACT_NS:  # all large: no mask
        return _split_seconds(counts)
    seconds = counts.astype(np.float64)
    seconds /= 1e9
    large = (counts > _EXACT_NS) | (counts < -_EXACT_NS)
    seconds[large] = _split_seconds(counts[large])
    return seconds


def _split_seconds(counts: IntArray) -> FloatArray:
    """Whole seconds plus the fraction: the nearest float for counts beyond ``2**53`` ns."""
    whole, fraction = np.divmod(counts, NS_PER_S)
    seconds: FloatArray = whole.astype(np.float64)
    seconds += fraction / 1e9
    return seconds


def seconds_of(ns: int | np.integer[Any]) -> float:
    """One time in integer nanoseconds as float seconds, correctly rounded (``int / int``)."""
    return int(ns) / NS_PER_S


def usable_values(values: npt.NDArray[np.floating[Any]]) -> BoolArray:
    """Which ``values`` a signal may hold: finite and below ``MAX_MAGNITUDE`` in magnitude.

    The others ``analyze`` refuses in a mapped signal, ``--drop-nonfinite`` drops and
    ``inspect`` counts as ``nonfinite`` (:data:`~hybridlog.signals.MAX_MAGNITUDE`).
    """
    usable: BoolArray = np.isfinite(values) & (np.abs(values) < MAX_MAGNITUDE)
    return usable


def last_of_each_time(time_ns: IntArray, values: FloatArray | None = None) -> BoolArray:
    """Which samples of sorted ``time_ns`` (repeats allowed) ``--sort`` keeps.

    The last of each time.  With ``values`` (``--drop-nonfinite``): the last *usable* one
    of each time (finite, below :data:`~hybridlog.signals.MAX_MAGNITUDE` in magnitude),
    and every unusable one, which :func:`~hybridlog.io.load_signals` then drops and counts
    (``nonfinite_dropped``): a NaN written after a measurement of the same time dropped
    the measurement with it, and the grid point read another sample, or none.
    """
    last: BoolArray = np.append(time_ns[1:] != time_ns[:-1], True)
    if values is None:
        return last
    usable = usable_values(values)
    if usable.all():
        return last
    kept = np.flatnonzero(usable)
    times = time_ns[kept]
    keep: BoolArray = ~usable
    keep[kept[np.append(times[1:] != times[:-1], True)]] = True
    return keep


def check_seconds_range(seconds: FloatArray) -> int:
    """Index of the first time that is not finite or too large for nanoseconds, else -1."""
    if seconds.size:
        lo, hi = float(seconds.min()), float(seconds.max())  # NaN when any is NaN
        if lo > -MAX_SECONDS and hi < MAX_SECONDS:
            return -1  # every time is in range, found without a full-size mask
    bad = ~(np.abs(seconds) < MAX_SECONDS)
    return int(np.argmax(bad)) if bad.any() else -1


def bad_seconds(value: float, written: str | None = None) -> str:
    """Why ``value`` (found by :func:`check_seconds_range`) is not a time in seconds.

    ``written`` is the cell as the log has it (a CSV ``1e400`` parses as ``inf``): said
    instead of the parsed value.  A time that is not finite is refused even with
    ``--drop-nonfinite``, which drops samples at known times: the message says so.
    """
    shown = str(value) if written is None else written
    spelled = written is None or written.strip("'\"+-").lower() in ("inf", "infinity")
    if math.isinf(value) and not spelled:
        return f"time {written} is beyond the range of a float64 (about 1.8e308)"
    if not math.isfinite(value):
        return (
            f"time {shown} is not a finite number of seconds (--drop-nonfinite drops "
            "values, never a row without a finite time)"
        )
    # 1.7e18 is now in nanoseconds since 1970, 1.7e12 in milliseconds: a unit, not a time
    return (
        f"time {value:g} is beyond the {MAX_SECONDS:.2g} s the nanosecond grid holds "
        "(times are in seconds: a column of milliseconds or nanoseconds?)"
    )


def format_ns(ns: int) -> str:
    """Format nanoseconds as exact decimal seconds without trailing zeros (``"1.5"``)."""
    sign = "-" if ns < 0 else ""
    whole, rest = divmod(abs(int(ns)), NS_PER_S)
    fraction = f"{rest:09d}".rstrip("0")
    return f"{sign}{whole}.{fraction}" if fraction else f"{sign}{whole}"


def non_ascii(name: str, besides: str = "") -> str:
    """The non-ASCII characters of ``name`` that ``besides`` lacks, by code point and name.

    ``"'у1' has U+0443 CYRILLIC SMALL LETTER U"``; ``""`` when there are none.
    """
    odd = [c for c in dict.fromkeys(name) if not c.isascii() and c not in besides]
    if not odd:
        return ""
    named = ", ".join(f"U+{ord(c):04X} {unicodedata.name(c, '(unnamed)')}" for c in odd)
    return f"{name!r} has {named}"


def lookalikes(wanted: Sequence[str], match: str) -> str:
    """Name the non-ASCII characters that tell ``match`` from the wanted name closest to it.

    ``'dаta'`` with a Cyrillic ``а`` and ``'data'`` print alike: "no field 'dаta'; closest:
    'data'" reads as nonsense unless the character is named.
    """
    word = max(wanted, key=lambda w: difflib.SequenceMatcher(None, w, match).ratio())
    parts = [p for p in (non_ascii(word, match), non_ascii(match, word)) if p]
    return f" ({'; '.join(parts)})" if parts else ""


def closest_names(wanted: Sequence[str], available: Sequence[str], limit: int = 3) -> str:
    """Describe the available names closest to any of ``wanted``, for error messages.

    A name that differs from a wanted one only in case (a column ``U`` for the input ``u``,
    ``T`` for the time column ``t``) comes first and is said to differ in case: difflib
    compares characters as they are, so for short names it ranked other names above it (or
    found none close) and the error pointed away from the column the user meant.

    Returns
    -------
    str
        ``"closest: 'a', 'b'"``, or, when nothing is close, ``"available: ..."`` listing a few.
    """
    folded = {word.casefold(): word for word in wanted}
    cased = [name for name in available if name.casefold() in folded and name not in wanted]
    matches: list[str] = list(dict.fromkeys(cased))
    for word in wanted:
        for match in difflib.get_close_matches(word, available, n=limit, cutoff=0.5):
            if match not in matches:
                matches.append(match)
    if matches:
        closest = "closest: " + ", ".join(repr(m) for m in matches[:limit])
        if cased:
            first = cased[0]
            meant = folded[first.casefold()]
            return f"{closest} (names are case-sensitive: {first!r} is not {meant!r})"
        return closest + lookalikes(wanted, matches[0])
    if not available:
        return "the log has none"
    # two names alike but for their Unicode form (café NFC and NFD) are written apart
    apart = names_apart(list(available[:8]))
    shown = ", ".join(
        repr(a) if a == written else f"'{written}'"
        for a, written in zip(available[:8], apart, strict=True)
    )
    more = f", ... ({len(available)} in all)" if len(available) > 8 else ""
    return f"available: {shown}{more}"
