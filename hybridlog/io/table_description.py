"""``inspect``'s description of a table log: its rows, columns, time and problems.

:func:`describe_csv` reads a CSV file a block of lines at a time (:mod:`.csv_tally`),
:func:`describe_parquet` a Parquet file a column at a time; both give the dict
:meth:`~hybridlog.io.tables.TableSource.describe` documents.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from hybridlog.errors import LogError
from hybridlog.io.column_summary import column_info, describe_column
from hybridlog.io.csv_frames import blank_rows, csv_text_frames, empty_cells, read_csv_strings
from hybridlog.io.csv_lines import check_record_widths, check_truncated
from hybridlog.io.csv_numbers import texts_among_numbers
from hybridlog.io.csv_tally import ColumnTally, tally_block
from hybridlog.io.parquet_columns import leaves_of
from hybridlog.io.parquet_files import parquet_rows, read_parquet_columns
from hybridlog.io.source import seconds_of
from hybridlog.io.summary import describe_steps, round_span
from hybridlog.io.table_file import TableFile
from hybridlog.io.table_numbers import unheld_value
from hybridlog.io.time_column import empty_time_cell, kept_rows, time_ns
from hybridlog.polars_import import pl
from hybridlog.signals import IntArray


def describe_csv(table: TableFile) -> dict[str, Any]:
    """The description of a CSV file, its lines read a block at a time (:mod:`.csv_tally`)."""
    tallies = [ColumnTally(name) for name in table.columns]
    seconds: list[pl.Series] = []  # the time column's numbers, while they are all numbers
    missing: list[IntArray] = []  # rows of an empty time cell
    unblank: int | None = None  # the first of them that is not a blank line
    check_truncated(table.file)
    check_record_widths(table.file, table.columns)
    for frame in csv_text_frames(table.file, list(table.columns), checked=True):
        first = tallies[0].rows
        numbers = tally_block(tallies, frame, keep=table.time_column)
        if numbers is not None and table.time_column is not None:
            cells = frame.get_column(table.time_column)
            seconds.append(numbers)
            empty = empty_cells(cells)
            if empty.any():
                missing.append(np.flatnonzero(empty) + first)
                odd = empty & ~blank_rows(frame)
                if unblank is None and odd.any():
                    unblank = first + int(np.argmax(odd))
        del frame
    height = tallies[0].rows

    def kept() -> IntArray:
        if unblank is not None:
            raise empty_time_cell(table, unblank)
        dropped = np.concatenate([np.zeros(0, dtype=np.int64), *missing])
        return np.delete(np.arange(height, dtype=np.int64), dropped)

    def time_cells(rows: IntArray) -> pl.Series:
        time = next(t for t in tallies if t.name == table.time_column)
        if time.dtype == "float64":  # as parse_floats reads them
            return pl.concat(seconds).alias(time.name).gather(rows)
        text = read_csv_strings(table.file, [time.name], checked=True)
        return text.get_column(time.name).gather(rows)  # dates and times, or an error

    problems: list[str] = []
    rows, times, resolution = _timed_rows(table, height, kept, time_cells, problems)
    seconds.clear()
    columns: list[dict[str, Any]] = []
    for tally in tallies:
        present = tally.present()[rows] if rows.size < height else tally.present()
        columns.append(
            column_info(tally.name, tally.dtype, tally.values(), present, times, resolution)
        )
        if columns[-1]["nonfinite"] is not None and tally.name != table.time_column:
            found = unheld_value(table, *tally.suspects()) if tally.suspicious else None
            problems.extend([found] if found is not None else [])
        elif tally.name != table.time_column:  # the time's own problem is said above
            problems.extend(texts_among_numbers(tally))
    return _described(table, rows.size, columns, times, resolution, problems)


def describe_parquet(table: TableFile) -> dict[str, Any]:
    """The description of a Parquet file, read a column at a time."""
    height = parquet_rows(table.file)
    time_frame = pl.DataFrame()
    if table.time_column is not None and height:
        time_frame = read_parquet_columns(table.file, [table.time_column])

    def kept() -> IntArray:
        return kept_rows(table, time_frame, str(table.time_column))

    def time_cells(rows: IntArray) -> pl.Series:
        return time_frame.get_column(str(table.time_column))[pl.Series(rows)]

    problems: list[str] = []
    rows, times, resolution = _timed_rows(table, height, kept, time_cells, problems)
    time_frame = time_frame.clear()
    columns: list[dict[str, Any]] = []
    unheld: list[str] = []
    for name in table.columns:
        frame = leaves_of(table, read_parquet_columns(table.file, [name]), problems)
        if rows.size < frame.height:
            frame = frame[pl.Series(rows)]
        for column in frame.iter_columns():
            columns.append(describe_column(column, times, resolution))
            if columns[-1]["nonfinite"] is not None and column.name != table.time_column:
                found = unheld_value(table, column, rows)
                unheld.extend([found] if found is not None else [])
    return _described(table, rows.size, columns, times, resolution, problems + unheld)


def _timed_rows(
    table: TableFile,
    height: int,
    kept: Callable[[], IntArray],
    time_cells: Callable[[IntArray], pl.Series],
    problems: list[str],
) -> tuple[IntArray, IntArray | None, float]:
    """The rows described, their times (``None``: no usable time) and the times' resolution.

    ``kept`` gives the rows but those of blank lines, or raises for an empty time
    cell; ``time_cells`` the time column at those rows.  Why the time is unusable is
    appended to ``problems``; the rows are then all of them.
    """
    rows: IntArray = np.arange(height, dtype=np.int64)
    if height == 0:
        problems.append("no data rows")
    elif table.time_column is None:
        problems.append("no time column (expected 't' or 'time')")
    else:
        try:
            taken = kept()
            times, resolution = time_ns(table, time_cells(taken), taken, repeats=True)
            return taken, times, resolution
        except LogError as err:
            problems.append(
                str(err).removeprefix(f"{table.path}, ").removeprefix(f"{table.path}: ")
            )
    return rows, None, 1.0  # no times: the resolution describes none


def _described(
    table: TableFile,
    height: int,
    columns: list[dict[str, Any]],
    time_ns: IntArray | None,
    resolution: float,
    problems: list[str],
) -> dict[str, Any]:
    """The description of the described ``columns`` and times."""
    steps = describe_steps(
        time_ns if time_ns is not None else np.zeros(0, dtype=np.int64),
        resolution_ns=resolution,
    )
    info: dict[str, Any] = {
        "path": table.path,
        "format": table.format,
        "rows": height,
        "columns": columns,
        "time": None,
        **steps,
        "problems": problems,
    }
    if time_ns is not None and time_ns.size:
        info["time"] = {
            "column": table.time_column,
            "start": seconds_of(time_ns[0]),
            "end": seconds_of(time_ns[-1]),
            "duration": round_span(int(time_ns[-1]) - int(time_ns[0]), resolution),
        }
    return info
