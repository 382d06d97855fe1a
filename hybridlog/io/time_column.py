"""A table log's time column read as integer nanoseconds, or refused naming its line or row.

:func:`kept_rows` gives the rows to use (a blank CSV line has none, an empty time cell is an
error: :func:`empty_time_cell`); :func:`time_ns` the times of those rows, from seconds as
numbers (refused where the column's type is too coarse for its own steps), a Parquet
``Datetime`` or ``Duration``, or ISO 8601 dates and times as text, and how far apart they
could be told.  The column's names and the ISO format are :mod:`.table_times`'.
"""

from __future__ import annotations

from decimal import Decimal, InvalidOperation
from typing import Any

import numpy as np

from hybridlog.errors import LogError, excerpt
from hybridlog.io.column_types import dtype_name, holds_text
from hybridlog.io.csv_frames import blank_csv_rows, empty_cells, read_csv_strings
from hybridlog.io.source import (
    MAX_SECONDS,
    NS_PER_S,
    bad_seconds,
    check_seconds_range,
    format_ns,
    seconds_to_ns,
)
from hybridlog.io.summary import seconds_resolution_ns
from hybridlog.io.table_file import TableFile
from hybridlog.io.table_numbers import to_float
from hybridlog.io.table_times import iso_format, not_a_time
from hybridlog.io.time_grid import clock_tolerance_ns
from hybridlog.polars_import import pl
from hybridlog.signals import FloatArray, IntArray
from hybridlog.times import format_time


def kept_rows(table: TableFile, frame: pl.DataFrame, time_column: str) -> IntArray:
    """Rows to use: all of them, minus blank CSV lines; a row without a time is an error."""
    rows: IntArray = np.arange(frame.height, dtype=np.int64)
    missing = empty_cells(frame.get_column(time_column))
    if not missing.any():
        return rows
    blank = blank_csv_rows(table.file) if table.format == "csv" else np.zeros_like(missing)
    not_blank = missing & ~blank[: missing.size]
    if not_blank.any():
        raise empty_time_cell(table, int(np.argmax(not_blank)))
    kept: IntArray = rows[~missing]
    return kept


def empty_time_cell(table: TableFile, row: int) -> LogError:
    """The error of an empty time cell in data row ``row`` (0-based) not on a blank line."""
    return LogError(
        f"{table.path}, {table.row_label(row)}, column {excerpt(str(table.time_column))}: "
        "empty time cell"
    )


def time_ns(
    table: TableFile,
    column: pl.Series,
    rows: IntArray,
    *,
    check: bool = True,
    repeats: bool = False,
) -> tuple[IntArray, float]:
    """The time column in integer nanoseconds, and how far apart its times could be told.

    ``rows``: the data row of each cell.  With ``check``, refused unless increasing
    (non-decreasing with ``repeats``), naming the line or row where it is not.  The
    resolution is :func:`~hybridlog.io.summary.seconds_resolution_ns` of seconds, 1 of a
    ``Datetime`` or ``Duration``.
    """
    name = column.name
    if holds_text(column.dtype):
        text_type = column.dtype  # a Categorical or Enum: said as such, not as its String
        column = column.cast(pl.String)
        written = column.drop_nulls()
        iso = iso_format(written[0] if written.len() else None)
        if iso is not None:
            column = _parse_iso(table, column, iso, rows)
        elif table.format != "csv":  # a CSV cell is text whatever it holds
            raise LogError(
                f"{table.path}: column {excerpt(name)} has type {text_type}, expected "
                "seconds as numbers or ISO 8601 dates and times (e.g. "
                f"2024-01-01T00:00:00.5), and its first value is {excerpt(written[0], 40)}"
                if written.len()
                else f"{table.path}: column {excerpt(name)} has no value"
            )
    if isinstance(column.dtype, pl.Datetime | pl.Duration):
        resolution_ns = 1.0
        stored_seconds: FloatArray | None = None
        times: IntArray = _temporal_ns(table, column, rows)
    elif isinstance(column.dtype, pl.Decimal):
        resolution_ns = 1.0
        stored_seconds = None
        times = _decimal_ns(table, column, rows)
    else:
        stored = column.dtype
        if table.format == "parquet" and not stored.is_numeric():
            # a Date, Time or Boolean: as read() refuses it (inspect said "line 2 ...
            # '2024-01-01' is not a number", or that a Boolean time goes backwards)
            raise LogError(not_a_time(table.path, name, stored))
        column = to_float(table, column, rows)
        seconds: FloatArray = np.asarray(column.to_numpy(), dtype=np.float64)  # no copy
        bad = check_seconds_range(seconds)
        if bad >= 0:
            as_written = None
            if table.format == "csv" and not np.isfinite(seconds[bad]):
                # the cell as written: a CSV '1e400' parsed as inf, which it does not say
                cells = read_csv_strings(table.file, [name], checked=True).get_column(name)
                as_written = excerpt(str(cells[int(rows[bad])]).strip(), 40)
            raise LogError(
                f"{table.path}, {table.row_label(int(rows[bad]))}, column {excerpt(name)}: "
                f"{bad_seconds(float(seconds[bad]), as_written)}"
            )
        if stored in (pl.Float32, pl.Float16):
            _check_resolution(table, name, stored, seconds, rows)
        else:
            _check_float64_resolution(table, name, seconds, rows)
        kind: type[np.floating[Any]] = np.float64
        if stored == pl.Float32:
            kind = np.float32
        elif stored == pl.Float16:
            kind = np.float16
        resolution_ns = seconds_resolution_ns(seconds, kind)
        times = seconds_to_ns(seconds)
        stored_seconds = seconds
    # Compared pairwise (no array of N differences): within +-9.2e18 ns differences
    # do not overflow, so ``later <= earlier`` is ``diff <= 0``.
    not_after = times[1:] < times[:-1] if repeats else times[1:] <= times[:-1]
    if check and not_after.size and not_after.any():
        i = int(np.argmax(not_after)) + 1
        how = "repeats" if times[i] == times[i - 1] else "goes backwards"
        merged = _read_as_one(
            table,
            name,
            (int(rows[i - 1]), int(rows[i])),
            int(times[i]),
            None if stored_seconds is None else stored_seconds[i - 1 : i + 1],
        )
        if how == "repeats" and merged is not None:
            raise LogError(merged)
        raise LogError(
            f"{table.path}, {table.row_label(int(rows[i]))}, column {excerpt(name)}: time {how} "
            f"(t={format_ns(int(times[i]))} s after t={format_ns(int(times[i - 1]))} s "
            f"on {table.row_label(int(rows[i - 1]))}); time must be strictly increasing "
            "(--sort puts rows in time order, rows of one time as one sample per column)"
        )
    return times, resolution_ns


def _check_resolution(
    table: TableFile, name: str, stored: pl.DataType, seconds: FloatArray, rows: IntArray
) -> None:
    """Refuse a float32 (or float16) time column too coarse for its own steps.

    float32 holds about seven digits: near t = 1.7e9 s (Unix time) its values are 128 s
    apart, near 1000 s 61 µs.  Times rounded by more than a thousandth of the mean step
    (the clock tolerance the alignment allows) would put samples on the wrong side of a
    grid point without a word, or collapse into repeats that say nothing of why.
    """
    if seconds.size < 2:
        return
    magnitude = np.abs(seconds)
    row = int(np.argmax(magnitude))
    kind = np.float32 if stored == pl.Float32 else np.float16
    resolution = float(np.spacing(kind(magnitude[row])))
    step = float(seconds.max() - seconds.min()) / (seconds.size - 1)
    if resolution > step / 1000:
        steps = (
            f"too coarse for its steps of {step:.3g} s on average (times would be rounded "
            "by more than a thousandth of a step)"
            if step > 0
            else "so every row holds that one time"
        )
        raise LogError(
            f"{table.path}, {table.row_label(int(rows[row]))}, column {excerpt(name)}: the "
            f"time column is {dtype_name(stored)}, whose values near t="
            f"{format_time(seconds[row])} s "
            f"are {resolution:.3g} s apart, {steps}: write the time as float64 (or as a "
            "Datetime)"
        )


def _check_float64_resolution(
    table: TableFile, name: str, seconds: FloatArray, rows: IntArray
) -> None:
    """Refuse float64 seconds too coarse for the log's own steps (Unix time, MHz logs).

    Near t = 1.7e9 s float64 values are 238 ns apart: a log sampled every 0.1 µs
    there read as repeated times ("time repeats", which said nothing of why), and with
    ``--sort`` its rows were merged into fewer, unevenly spaced samples.  Refused when
    the spacing exceeds the tolerance the alignment allows a sample's time
    (:func:`~hybridlog.io.time_grid.clock_tolerance_ns` of the mean step, at least the
    nanosecond).
    """
    if seconds.size < 2:
        return
    high, low = float(seconds.max()), float(seconds.min())
    row = int(np.argmax(seconds)) if abs(high) >= abs(low) else int(np.argmin(seconds))
    spacing_ns = float(np.spacing(abs(seconds[row]))) * NS_PER_S
    step_ns = (high - low) / (seconds.size - 1) * NS_PER_S
    # at least the nanosecond every time is rounded to anyway (seconds_to_ns)
    if step_ns <= 0 or spacing_ns <= max(clock_tolerance_ns(round(step_ns)), 1):
        return
    raise LogError(
        f"{table.path}, {table.row_label(int(rows[row]))}, column {excerpt(name)}: float64 "
        f"seconds near t={format_time(seconds[row])} s are {spacing_ns:.3g} ns apart, "
        f"too coarse for the log's steps of {format_time(step_ns / NS_PER_S)} s on "
        "average (its times would be rounded by more than the alignment tolerates): "
        "write the time from the log's start, or as ISO 8601 dates and times with "
        "nanoseconds (a Datetime in Parquet)"
    )


def _decimal_ns(table: TableFile, column: pl.Series, rows: IntArray) -> IntArray:
    """A Parquet decimal time column in nanoseconds, as written (to the nearest ns).

    A decimal holds its digits: read through a ``float64`` (as a float column is), Unix
    times lost all below 238 ns, and a log whose decimals step by 100 ns was refused as
    "float64 seconds ... too coarse", a type it does not have.

    Raises
    ------
    LogError
        For a time beyond what int64 nanoseconds hold, naming its row.
    """
    scaled = column.cast(pl.Decimal(38, 9), strict=False).to_physical()  # Int128 ns
    inside = (scaled.abs() < int(MAX_SECONDS * NS_PER_S)).fill_null(False).to_numpy()
    if not inside.all():
        row = int(np.argmin(inside))
        raise LogError(
            f"{table.path}, {table.row_label(int(rows[row]))}, column {excerpt(column.name)}: "
            f"{bad_seconds(float(column[row]))}"
        )
    time_ns: IntArray = scaled.cast(pl.Int64).to_numpy().astype(np.int64, copy=False)
    return time_ns


def _parse_iso(table: TableFile, column: pl.Series, iso: str, rows: IntArray) -> pl.Series:
    """A text time column of ISO 8601 dates and times as a ``Datetime`` (ns; UTC if zoned).

    CSV cells and Parquet string columns alike.

    The format is the first cell's (``T`` or a space between date and time, with or
    without an offset such as ``Z`` or ``+01:00``); every cell must have it.  Parsed to
    microseconds first, which hold any year, so that a date past 2262 is refused by
    :func:`_temporal_ns` and not wrapped around by a parse to nanoseconds; then to
    nanoseconds, for the digits past the microsecond.
    """
    text = column.str.strip_chars()
    coarse = text.str.to_datetime(iso, strict=False, time_unit="us")
    failed = (coarse.is_null() & text.is_not_null()).to_numpy()
    if failed.any():
        row = int(np.argmax(failed))
        first = int(np.argmax(text.is_not_null().to_numpy()))
        if iso_format(str(text[row])) == iso:  # written alike: a day that does not exist
            raise LogError(
                f"{table.path}, {table.row_label(int(rows[row]))}, column "
                f"{excerpt(column.name)}: {excerpt(text[row], 40)} is not a date and time "
                "(ISO 8601): no such day of its month, or hour, minute or second of a day"
            )
        raise LogError(
            f"{table.path}, {table.row_label(int(rows[row]))}, column {excerpt(column.name)}: "
            f"{excerpt(text[row], 40)} is not a date and time written like "
            f"{excerpt(text[first], 40)} on {table.row_label(int(rows[first]))} (ISO 8601)"
        )
    _temporal_ns(table, coarse, rows)
    return text.str.to_datetime(iso, strict=True, time_unit="ns").alias(column.name)


def _temporal_ns(table: TableFile, column: pl.Series, rows: IntArray) -> IntArray:
    """A ``Datetime`` (since 1970, UTC) or ``Duration`` time column in nanoseconds.

    Taken from the stored integers in the column's own unit, so that a time beyond what
    int64 nanoseconds hold (before 1678 or after 2262; a duration over 292 years) is
    refused naming its row, not wrapped or turned into NaN by the conversion.
    """
    unit = str(getattr(column.dtype, "time_unit", "ns"))
    factor = {"ns": 1, "us": 1_000, "ms": 1_000_000}[unit]
    stored = column.to_physical().to_numpy().astype(np.int64)
    limit = int(MAX_SECONDS * NS_PER_S) // factor
    bad = (stored >= limit) | (stored <= -limit)
    if bad.any():
        row = int(np.argmax(bad))
        if isinstance(column.dtype, pl.Datetime):
            what, held = "date", "the years 1678 to 2262"
        else:
            what, held = "duration", f"{MAX_SECONDS:.2g} s either way"
        shown = _stored_time(column, row, int(stored[row]), unit)
        raise LogError(
            f"{table.path}, {table.row_label(int(rows[row]))}, column "
            f"{excerpt(column.name)}: the {what} {shown} is beyond "
            f"what the nanosecond grid holds ({held})"
        )
    time_ns: IntArray = stored * factor
    return time_ns


# What Python's datetime and timedelta hold: the years 1 to 9999, 999999999 days.
_DATETIME_SECONDS = (-62_135_596_800.0, 253_402_300_800.0)
_TIMEDELTA_SECONDS = 999_999_999 * 86_400.0


def _stored_time(column: pl.Series, row: int, stored: int, unit: str) -> str:
    """The ``row``-th date or duration of ``column``, ``stored`` in its ``unit``.

    As polars shows it where Python's ``datetime`` or ``timedelta`` holds it; else as
    numpy's ``datetime64`` writes the date (any year), or in seconds: the conversion of a
    date in the year 0 or beyond 9999 raised ``ValueError``, and one past the year 262143
    made polars panic (a traceback, exit 1), in place of the error naming the row.
    """
    seconds = stored * {"ns": 1e-9, "us": 1e-6, "ms": 1e-3}[unit]
    if isinstance(column.dtype, pl.Datetime):
        if _DATETIME_SECONDS[0] <= seconds < _DATETIME_SECONDS[1]:
            return excerpt(str(column[row]), 40)
        return f"{np.array(stored, dtype=np.int64).astype(f'datetime64[{unit}]')} (UTC)"
    if abs(seconds) < _TIMEDELTA_SECONDS:
        return excerpt(str(column[row]), 40)
    return f"{format_time(seconds)} s"


def _read_as_one(
    table: TableFile,
    name: str,
    rows: tuple[int, int],
    time: int,
    stored: FloatArray | None,
) -> str | None:
    """Why two times written as different numbers read as one, if they do.

    ``rows``: the two data rows (0-based), which read as ``time`` (ns); ``stored``: their
    seconds as read, for a Parquet number column.  Seconds are read as a ``float64`` and
    then to the nanosecond: a CSV ``1700000004.0000001`` after ``1700000004.0`` (float64
    holds 238 ns there), or ``4.0000000001`` after ``4.0`` (in a Parquet float64 column
    too), were refused as a time that "repeats (t=1700000004 s after t=1700000004 s)",
    which the file did not say.  ``None`` for times written alike, and for ISO 8601 text
    and a ``Datetime`` or ``Duration`` (read to the nanosecond as written).
    """
    earlier, later = rows
    if table.format == "csv":
        cells = read_csv_strings(table.file, [name], checked=True).get_column(name)
        first, second = (str(cells[row]).strip() for row in rows)
        try:
            if Decimal(first) == Decimal(second):
                return None
        except InvalidOperation:  # ISO 8601 text
            return None
    elif stored is None or stored[0] == stored[1]:
        return None
    else:
        first, second = (repr(float(value)) for value in stored)
    seconds = time / NS_PER_S
    spacing_ns = float(np.spacing(abs(float(second)))) * NS_PER_S
    held = (
        f"float64 seconds near t={format_time(seconds)} s are {spacing_ns:.3g} ns apart"
        if spacing_ns > 1
        else "times are read to the nanosecond"
    )
    return (
        f"{table.path}, {table.row_label(later)}, column {excerpt(name)}: time "
        f"{excerpt(second, 40)} reads as the time of {excerpt(first, 40)} on "
        f"{table.row_label(earlier)} (t={format_time(seconds)} s): {held}, so the two "
        "rows have one time; write times further apart (or from the log's start), or "
        "--sort combines such rows into one sample per column"
    )
