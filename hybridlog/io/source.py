"""What every log reader provides: named sample series and a description of itself.

A reader (CSV/Parquet table, MCAP file, ROS bag ...) implements :class:`LogSource`.  Everything
after reading -- signal mapping, finiteness checks, alignment onto the model's grid -- works on
the :class:`Series` and :class:`LabelSeries` a source returns and never looks at the format.

Times are integer nanoseconds (``int64``) from reading on: float seconds lose sub-microsecond
resolution at Unix-epoch magnitudes and make "is this sample on the grid" comparisons fragile.
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import Any, Protocol, Self

import numpy as np

from hybridlog.errors import LogError
from hybridlog.signals import FloatArray, IntArray

NS_PER_S = 1_000_000_000

#: Where sample times come from: the recorder's log time, or each message's ``header.stamp``.
TIME_SOURCES: tuple[str, ...] = ("log", "header")

# |t| beyond this many seconds does not fit into int64 nanoseconds (about 292 years).
_MAX_SECONDS = 9.2e9


@dataclass(frozen=True)
class ReadSettings:
    """How a reader turns records into samples (``--time``, ``--sort``, ``--recover``, ...).

    Attributes
    ----------
    time:
        ``"log"`` (default): the time the recorder logged each message (a table's time
        column); ``"header"``: each message's ``header.stamp``.
    sort:
        Put samples that go backwards in time into order, and keep the last of samples with
        the same time, instead of refusing the log.
    recover:
        Read what is readable of a damaged or unfinished MCAP file, sequentially, instead of
        refusing it.
    msg_dirs:
        Folders of ``.msg`` files defining message types the log does not define itself.
    """

    time: str = "log"
    sort: bool = False
    recover: bool = False
    msg_dirs: tuple[str, ...] = ()


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


class LogSource(Protocol):
    """A readable log: the interface alignment and ``inspect`` rely on.

    Sources are context managers; ``read`` may be called once per source, with every field
    the caller needs, so that a reader can decode the file in one pass.
    """

    #: The log's format for reports and ``inspect``: ``"csv"``, ``"mcap"``, ``"ros1-bag"`` ...
    format: str

    @property
    def path(self) -> str:
        """The log's path, used to prefix every error message."""
        ...

    @property
    def field_word(self) -> str:
        """What a field is called in messages: ``"column"`` for tables, ``"field"`` for bags."""
        ...

    @property
    def message_paths(self) -> bool:
        """Whether fields are message paths (``/topic.field``) rather than column names."""
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

    def notes(self) -> dict[str, Any]:
        """What reading did that a report should record (recovery, sorting); JSON-ready."""
        ...

    def read(
        self, numeric: Sequence[str], labels: Sequence[str] = ()
    ) -> tuple[dict[str, Series], dict[str, LabelSeries]]:
        """Read the named fields: ``numeric`` as float series, ``labels`` as label series.

        Raises
        ------
        LogError
            When a field is missing, not numeric, or its timestamps are unusable.
        """
        ...

    def locate(self, name: str, index: int) -> str:
        """Where sample ``index`` of field ``name`` sits, e.g. ``"line 17, column 'y'"``."""
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
    whole = np.floor(seconds)
    fraction = seconds - whole
    result: IntArray = whole.astype(np.int64) * NS_PER_S + np.rint(fraction * 1e9).astype(np.int64)
    return result


def check_seconds_range(seconds: FloatArray) -> int:
    """Index of the first time that is not finite or too large for nanoseconds, else -1."""
    bad = ~(np.abs(seconds) < _MAX_SECONDS)
    return int(np.argmax(bad)) if bad.any() else -1


def format_ns(ns: int) -> str:
    """Format nanoseconds as exact decimal seconds without trailing zeros (``"1.5"``)."""
    sign = "-" if ns < 0 else ""
    whole, rest = divmod(abs(int(ns)), NS_PER_S)
    fraction = f"{rest:09d}".rstrip("0")
    return f"{sign}{whole}.{fraction}" if fraction else f"{sign}{whole}"


def closest_names(wanted: Sequence[str], available: Sequence[str], limit: int = 3) -> str:
    """Describe the available names closest to any of ``wanted``, for error messages.

    Returns
    -------
    str
        ``"closest: 'a', 'b'"``, or, when nothing is close, ``"available: ..."`` listing a few.
    """
    matches: list[str] = []
    for word in wanted:
        for match in difflib.get_close_matches(word, available, n=limit, cutoff=0.5):
            if match not in matches:
                matches.append(match)
    if matches:
        return "closest: " + ", ".join(repr(m) for m in matches[:limit])
    if not available:
        return "the log has none"
    shown = ", ".join(repr(a) for a in available[:8])
    more = f", ... ({len(available)} in all)" if len(available) > 8 else ""
    return f"available: {shown}{more}"


def labels_to_codes(
    source: LogSource, series: LabelSeries, mode_ids: Sequence[str], symbol: str
) -> IntArray:
    """Translate a label series into indices of ``mode_ids``.

    Labels and mode ids are compared as text after stripping whitespace: ``"1"`` matches mode
    ``"1"`` but ``"1.0"`` does not.

    Raises
    ------
    LogError
        Naming the first sample whose label is not a mode id, with its location and time.
    """
    index = {mode_id.strip(): i for i, mode_id in enumerate(mode_ids)}
    lookup = np.array([index.get(label, -1) for label in series.categories], dtype=np.int64)
    codes: IntArray = lookup[series.codes] if lookup.size else series.codes.copy()
    bad = codes < 0
    if bad.any():
        first = int(np.argmax(bad))
        label = series.categories[int(series.codes[first])]
        raise LogError(
            f"{source.path}, {source.locate(series.name, first)}: {symbol} {label!r} at "
            f"t={format_ns(int(series.time_ns[first]))} s is not a mode of the model "
            f"(mode ids: {', '.join(mode_ids)}; compared as text)"
        )
    return codes


def check_finite(source: LogSource, series: Series, symbol: str) -> None:
    """Raise unless every value of ``series`` is finite.

    Raises
    ------
    LogError
        Naming the location, the symbol and the time of the first NaN or infinite value.
    """
    bad = ~np.isfinite(series.values)
    if bad.any():
        first = int(np.argmax(bad))
        value = float(series.values[first])
        raise LogError(
            f"{source.path}, {source.locate(series.name, first)}: {value} for {symbol} at "
            f"t={format_ns(int(series.time_ns[first]))} s (mapped signals must be finite)"
        )
