"""CSV and Parquet logs: one row per time stamp, one column per signal.

The time column is ``t`` (or ``time``) in seconds; Parquet may also store it as a
``Datetime``/``Duration``, and both as ISO 8601 dates and times in text (``2024-01-01T00:00:00.5``,
a space for the ``T``, an offset such as ``Z`` or ``+01:00``; zoned times are taken in UTC).
Every other column is a field a symbol can be mapped to (inside a Parquet struct, list or
array column, as :mod:`~hybridlog.io.table_paths` names them).  An empty cell means "no
sample of this column at this time", which is how a multi-rate table is written; a cell that
is not a number is an error naming its line, never a silent string column.

CSV files are read with an explicit schema: the header line is parsed first, then the wanted
columns are read as ``Float64`` (label columns such as ``mode`` as strings).  Line numbers in
messages count the header as line 1 and assume one record per physical line (no quoted line
breaks); blank lines (empty, or of blanks and commas alone) are skipped but counted.  Polars
reads a CSV file a block of lines at a time (:mod:`~hybridlog.io.csv_tally`), and
:meth:`TableSource.describe` describes one block by block, a Parquet file column by column.
"""

from __future__ import annotations

import contextlib
import csv
import os
import re
import sys
import tempfile
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import numpy as np

from hybridlog.errors import LogError, OptionError, excerpt
from hybridlog.io.align import clock_tolerance_ns
from hybridlog.io.csv_encoding import refuse_not_utf8
from hybridlog.io.csv_tally import BOOLEANS, ColumnTally, csv_blocks, stripped_cells
from hybridlog.io.exact import (
    EXACT_LIMIT,
    WHOLE_NUMBER,
    any_beyond_exact,
    beyond_exact,
    inexact,
)
from hybridlog.io.formats import LogFormat, get_format
from hybridlog.io.message_paths import PathError
from hybridlog.io.options import ReadOptions
from hybridlog.io.source import (
    MAX_SECONDS,
    NS_PER_S,
    FieldKey,
    LabelSeries,
    Reading,
    Series,
    SourceInfo,
    bad_seconds,
    check_seconds_range,
    closest_names,
    format_ns,
    last_of_each_time,
    seconds_of,
    seconds_to_ns,
)
from hybridlog.io.summary import (
    count_nonfinite,
    describe_steps,
    round_span,
    seconds_resolution_ns,
)
from hybridlog.io.table_paths import (
    ARRAY,
    STRUCT,
    ColumnPath,
    expand,
    field_names,
    is_nested,
    leaf_values,
)
from hybridlog.io.table_paths import resolve as resolve_path
from hybridlog.polars_import import pl, polars_file
from hybridlog.signals import FloatArray, IntArray
from hybridlog.times import format_time

TIME_COLUMNS = ("t", "time")

_TABLES = (get_format("csv"), get_format("parquet"))

_NARROW_INTEGERS = (pl.Int8, pl.Int16, pl.Int32, pl.UInt8, pl.UInt16, pl.UInt32)
"""Integer types every value of which a ``float64`` holds exactly."""

COUNTED_AT_ONCE = 1 << 18
"""Bytes of a CSV file :func:`_count_separators` reads and counts at a time (256 KiB: of the
sizes measured, the fastest; 1 MiB took a fifth longer, 4 MiB half as long again)."""
COMMA, NEWLINE, QUOTE, CARRIAGE_RETURN = (ord(c) for c in ',\n"\r')


class TableSource:
    """A CSV or Parquet log (:class:`~hybridlog.io.source.LogSource` implementation).

    Parameters
    ----------
    path:
        A CSV or Parquet file.  The header (or Parquet schema) is read at once; the data
        only by :meth:`read` and :meth:`describe`.
    options:
        How to read it (``sort`` is used; ``time`` must be ``"log"``).
    log_format:
        The ``csv`` or ``parquet`` row of the table of formats; by default the one the
        suffix names.

    Raises
    ------
    LogError
        When the file is missing, empty, has no header, or has duplicate or unnamed columns.
    """

    def __init__(
        self,
        path: str | Path,
        options: ReadOptions | None = None,
        log_format: LogFormat | None = None,
    ) -> None:
        self.options = options or ReadOptions()
        if self.options.time != "log":
            raise OptionError(
                f"--time {self.options.time}: {path} is a table; its time column is the "
                "only time it has (use --time log)"
            )
        self._notes: dict[str, Any] = {}
        self._file = Path(path)
        if log_format is None:
            suffix = self._file.suffix.lower()
            log_format = next((f for f in _TABLES if suffix in f.suffixes), None)
        if log_format is None or log_format not in _TABLES:
            raise LogError(f"{path}: not a table log (expected a .csv or .parquet file)")
        self._format = log_format.name
        if not self._file.is_file():
            raise LogError(f"{path}: no such file")
        self._schema: dict[str, pl.DataType] = {}
        if self._format == "csv":
            names = _header_names(self._file)
            self._columns = tuple(names)
            stripped = [name for name, as_written in names.items() if name != as_written]
            if stripped:  # ``t, u, y``: the names are read as ``u``, not `` u``
                self._notes["csv_names_stripped"] = stripped
        else:
            self._schema = _read_parquet_schema(self._file)
            self._columns = tuple(self._schema)
        self._time_column = next((c for c in TIME_COLUMNS if c in self._columns), None)
        others = [c for c in TIME_COLUMNS if c in self._columns and c != self._time_column]
        if others:  # ``t`` is the time; a ``time`` beside it is a column like any other
            self._notes["time_columns_passed_over"] = [self._time_column, *others]
        # Parquet: the fields inside struct, list and array columns (``pose.x``, ``q[1]``)
        self._paths: dict[str, ColumnPath] = {}
        # Parquet: the one length of each list indexed from its end (``field_key``), or None
        self._list_lengths: dict[tuple[str, tuple[str | int, ...]], int | None] = {}
        # Row (0-based, data rows only) of every sample returned by ``read``, per column.
        self._rows: dict[str, IntArray] = {}
        self._time_resolution_ns = 1.0
        """How far apart the times last read could be told (``summary.seconds_resolution_ns``)."""
        # ``--sort``: per column, the rows of its samples superseded at a repeated time
        self._superseded: dict[str, IntArray] = {}

    @property
    def info(self) -> SourceInfo:
        """Path and format (``csv`` or ``parquet``); fields are column names."""
        return SourceInfo(self.path, self._format, message_paths=False)

    @property
    def path(self) -> str:
        """The file's path as given."""
        return str(self._file)

    @property
    def columns(self) -> tuple[str, ...]:
        """Every column of the table, time included, in file order."""
        return self._columns

    @property
    def time_column(self) -> str | None:
        """Name of the time column, or ``None`` when the table has none."""
        return self._time_column

    def fields(self) -> tuple[str, ...]:
        """Columns a symbol can be mapped to: all but the time column.

        Inside a Parquet struct, list or array column, its fields as
        :mod:`~hybridlog.io.table_paths` names them: ``pose.x``, ``q[]`` (``[]`` takes an
        index).
        """
        return tuple(
            name
            for c in self._columns
            if c != self._time_column
            for name in (field_names(c, self._schema[c]) if c in self._schema else [c])
        )

    def _path(self, name: str) -> ColumnPath:
        """The field ``name`` names (a column, or a leaf of a nested Parquet column).

        Raises
        ------
        PathError
            Why ``name`` names no number or text of the table.
        """
        path = self._paths.get(name)
        if path is None:
            if self._format == "csv":
                if name not in self._columns:
                    raise PathError(
                        f"no column {excerpt(name)}; {closest_names([name], self.fields())}"
                    )
                path = ColumnPath(name, name, (), (), pl.String())
            else:
                path = resolve_path(name, self._schema, list(self.fields()))
            self._paths[name] = path
        return path

    def field_key(self, name: str) -> FieldKey:
        """The column and steps ``name`` reads (:meth:`LogSource.field_key`).

        A negative index counts from the start of its fixed-size array, or of its lists when
        they hold one length (as reading them requires): ``q[-1]`` of lists of three is
        ``q[2]``.  One beyond that length (``q[-5]``) is no element and so no other field's
        key: reading it refuses it as out of range.
        """
        try:
            path = self._path(name)
        except PathError:
            return name, ()
        steps: list[str | int] = []
        dtype: Any = self._schema.get(path.column)
        for depth, (step, kind) in enumerate(zip(path.steps, path.kinds, strict=True)):
            if kind == STRUCT:
                dtype = {f.name: f.dtype for f in dtype.fields}[step]
            else:
                if isinstance(step, int) and step < 0:
                    length = dtype.size if kind == ARRAY else self._list_length(path, depth)
                    step += length or 0
                    if length is not None and step < 0:
                        # 'q[-5]' beside 'q[1]' was refused as one element "where the array
                        # holds 4", which no row's list does
                        return name, ()
                dtype = dtype.inner
            steps.append(step)
        return path.column, tuple(steps)

    def _list_length(self, path: ColumnPath, depth: int) -> int | None:
        """The one length of the lists ``path`` indexes at ``depth``; ``None`` if not one.

        Read once per list (mapping asks for every symbol's key more than once).
        """
        key = (path.column, path.steps[:depth])
        if key not in self._list_lengths:
            frame = _read_parquet(self._file, columns=[path.column], low_memory=True)
            lengths = frame.select(path.expr(depth).list.len()).to_series().drop_nulls().unique()
            self._list_lengths[key] = int(lengths[0]) if lengths.len() == 1 else None
        return self._list_lengths[key]

    def explain_missing(self, name: str, numeric: bool = False) -> str | None:
        """``None`` for a field of the table, else why not: the time column, or the closest.

        With ``numeric``, a Parquet column whose type holds no numbers (text, a date) is
        explained as such; whether a CSV column holds numbers is known when it is read.
        """
        if name == self._time_column:
            return (
                f"{excerpt(name)} is the table's time column ("
                f"{' or, without it, '.join(map(repr, TIME_COLUMNS))}, in seconds), "
                f"not a signal; other columns: {', '.join(map(excerpt, self.fields())) or 'none'}"
            )
        try:
            dtype = self._path(name).dtype
        except PathError as err:
            return str(err)
        if numeric and self._format == "parquet" and not _holds_numbers(dtype):
            return f"column {excerpt(name)} has type {dtype}, expected a number"
        return None

    def __enter__(self) -> Self:
        """Return the source itself; the file is read eagerly."""
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """Nothing to release."""

    def _locate(self, name: str, index: int) -> str:
        """Line (CSV, header = line 1) or row (Parquet, 1-based) of a sample read earlier."""
        rows = self._rows.get(name)
        row = int(rows[index]) if rows is not None and 0 <= index < rows.size else index
        return f"{self._row_label(row)}, column {excerpt(name)}"

    def _row_label(self, row: int) -> str:
        return f"line {row + 2}" if self._format == "csv" else f"row {row + 1}"

    # ------------------------------------------------------------------ reading

    def read(self, numeric: Sequence[str], labels: Sequence[str] = ()) -> Reading:
        """Read the named columns as numeric series and label series.

        Parameters
        ----------
        numeric:
            Columns to read as ``float64``; must hold numbers (or be empty) in every row.
        labels:
            Columns to read as text labels (stripped; empty means no sample).

        Returns
        -------
        Reading
            ``{column: Series}`` and ``{column: LabelSeries}``, each series holding the rows
            where that column has a value; notes on ``--sort``; the line or row of a sample.

        Raises
        ------
        LogError
            Naming the file and the line/row and column of a non-numeric cell, a missing
            or unordered time, or a missing column.
        """
        time_column = self._require_time()
        for name in (*numeric, *labels):
            try:
                self._path(name)
            except PathError as err:
                raise LogError(f"{self.path}: {err}") from None
        wanted = list(dict.fromkeys([time_column, *numeric, *labels]))
        as_float = {time_column, *numeric} - set(labels)
        # Parquet numeric columns are decoded one at a time once the rows are known (below):
        # polars' memory then peaks at about one column, not all of them.
        later: list[str] = []
        if self._format == "csv":
            if _iso_format(_first_cell(self._file, self._columns.index(time_column))):
                as_float.discard(time_column)  # dates and times: parsed by _time_ns
            frame = _read_csv_frame(self._file, wanted, as_float, time_column)
        else:
            later = [n for n in dict.fromkeys(numeric) if n not in labels and n != time_column]
            frame = self._read_parquet_frame(wanted, set(numeric), set(labels), skip=later)
        if frame.height == 0:
            raise LogError(f"{self.path}: no data rows")
        height = frame.height
        rows = self._kept_rows(frame, time_column)
        if rows.size < frame.height:
            frame = frame[pl.Series(rows)]
        sort = self.options.sort
        time_ns = self._time_ns(frame.get_column(time_column), rows, check=not sort)
        repeats = False
        superseded: dict[str, IntArray] = {}  # per column, the rows of its samples not kept
        self._superseded = superseded
        if sort:
            frame, rows, time_ns = self._sorted(frame, rows, time_ns)
            self._rows[time_column] = rows
            repeats = self._count_repeats(time_ns)

        label_series: dict[str, LabelSeries] = {}
        for name in labels:
            codes, categories = _label_codes(frame.get_column(name), written=self._format == "csv")
            label_time, label_rows = time_ns, rows
            present = codes >= 0
            if not present.all():
                codes, label_time, label_rows = codes[present], time_ns[present], rows[present]
            last = self._last_at_each_time(name, label_time, label_rows, repeats)
            if last is not None:
                codes, label_time, label_rows = codes[last], label_time[last], label_rows[last]
            label_series[name] = LabelSeries(name, label_time, codes, categories)
            self._rows[name] = label_rows
        if all(name in later for name in numeric):
            del frame  # time and labels are NumPy arrays now: polars frees their columns

        # A column without an empty cell (the common case) shares the time and row arrays;
        # its values are copied into one NumPy block for all columns and the polars column
        # is dropped at once.  Polars' allocator keeps what it frees for a while (its
        # decay), so columns handed over as they were decoded stayed resident until after
        # alignment had copied them, and their pages were still resident while the
        # estimator filled its result; decoded and dropped one at a time, polars reuses the
        # same pages for every column, and the block, one allocation, goes back to the
        # system as soon as alignment has copied it.
        numeric_series: dict[str, Series] = {}
        block = _ColumnBlock(len(numeric), rows.size)
        for name in numeric:
            if name in later:
                taken = self._parquet_column(name, rows if rows.size < height or sort else None)
            else:
                taken = frame.get_column(name)
            column = self._to_float(taken, rows)
            # copied into the block from polars' chunks (a CSV log's blocks of lines), one
            # copy, and the 2^53 check looks at the copy: converted to NumPy twice, the
            # chunks were first put end to end in an array of their own, each time
            whole = column.null_count() == 0 and not repeats
            held = block.take(column) if whole else None
            self._refuse_inexact(taken, column, rows, held)
            del taken
            if (
                self._format == "csv"
                and not self.options.drop_nonfinite
                and column.is_infinite().any()
            ):
                self._refuse_overflow(column, rows)
            if held is not None:
                numeric_series[name] = Series(name, time_ns, held)
                self._rows[name] = rows
                continue
            present = column.is_not_null().to_numpy()
            values = column.filter(pl.Series(present)).to_numpy().astype(np.float64)
            column_time, column_rows = time_ns[present], rows[present]
            usable_last = values if self.options.drop_nonfinite else None
            last = self._last_at_each_time(name, column_time, column_rows, repeats, usable_last)
            if last is not None:
                values, column_time = values[last], column_time[last]
                column_rows = column_rows[last]
            numeric_series[name] = Series(name, column_time, values)
            self._rows[name] = column_rows
        if superseded:
            self._note_superseded(superseded, [self._rows[n] for n in dict.fromkeys(wanted[1:])])
        return Reading(numeric_series, label_series, dict(self._notes), self._locate)

    def _refuse_overflow(
        self, column: pl.Series, rows: IntArray, written: pl.Series | None = None
    ) -> None:
        """Refuse a CSV number too large for a float64 (``1e400``), which parsed as infinite.

        A number beyond 1.8e308 was reported as ``inf``, which the cell does not say; with
        ``--drop-nonfinite`` it is dropped as infinite (it is out of range in any case).
        ``written``: ``column``'s cells as written, if known (else read from the file).

        Raises
        ------
        LogError
            Naming the line and column of the first such cell.
        """
        name = column.name
        infinite = column.is_infinite().fill_null(False).to_numpy()
        if written is None:
            text = _read_csv_strings(self._file, [name], checked=True).get_column(name)
            written = text.gather(rows[infinite])
        else:
            written = written.filter(pl.Series(infinite))
        cells = written.str.strip_chars().str.to_lowercase()
        spelled = cells.str.strip_chars_start("+-").is_in(["inf", "infinity"]).to_numpy()
        if not spelled.all():
            first = int(np.argmin(spelled))
            row = int(rows[infinite][first])
            raise LogError(
                f"{self.path}, {self._row_label(row)}, column {excerpt(name)}: "
                f"{excerpt(written[first], 40)} is beyond the range of a float64 (about 1.8e308)"
            )

    def _refuse_inexact(
        self,
        taken: pl.Series,
        column: pl.Series,
        rows: IntArray,
        values: FloatArray | None = None,
    ) -> None:
        """Refuse a number ``column`` (``taken`` as ``Float64``) does not hold (:mod:`.exact`).

        An ``int64``/``uint64`` or decimal Parquet value, or a CSV cell written as a whole
        number, beyond 2^53 lost its last digits as a ``float64``.  Only the cells whose
        value reached 2^53 are looked at again.  ``values``: ``column`` as NumPy, if at hand.

        Raises
        ------
        LogError
            Naming the line or row and column of the first such cell in the file.
        """
        if self._format == "parquet" and not (
            isinstance(taken.dtype, pl.Decimal)
            or (taken.dtype.is_integer() and taken.dtype not in _NARROW_INTEGERS)
        ):
            return
        if values is None:
            values = column.to_numpy()
        if not any_beyond_exact(values):
            return
        found = np.flatnonzero(beyond_exact(values))
        if not found.size:
            return
        found = found[np.argsort(rows[found], kind="stable")]  # in the file's order
        if self._format == "csv":
            if _holds_text(taken.dtype):  # the cells as written (inspect)
                written = taken.gather(found)
            else:
                text = _read_csv_strings(self._file, [column.name], checked=True)
                written = text.get_column(column.name).gather(rows[found])
            whole = written.str.contains(WHOLE_NUMBER).fill_null(False).to_numpy()
            found, cells = found[whole], written.filter(pl.Series(whole)).to_list()
        else:
            cells = taken.gather(found).to_list()
        for index, cell in zip(found.tolist(), cells, strict=True):
            reason = inexact(cell)
            if reason is not None:
                raise LogError(
                    f"{self.path}, {self._row_label(int(rows[index]))}, column "
                    f"{excerpt(column.name)}: {reason}"
                )

    def _to_float(self, column: pl.Series, rows: IntArray) -> pl.Series:
        if column.dtype == pl.Float64:
            return column
        if _holds_numbers(column.dtype):
            return column.cast(pl.Float64)
        return _parse_floats(self._file, column, rows)

    def _require_time(self) -> str:
        if self._time_column is None:
            raise LogError(
                f"{self.path}: no time column (expected 't' or 'time' in seconds); "
                f"{closest_names(list(TIME_COLUMNS), self._columns)}; rename the time column "
                "to 't' (no option names another)"
            )
        return self._time_column

    def _read_parquet_frame(
        self, wanted: list[str], numeric: set[str], labels: set[str], skip: Sequence[str] = ()
    ) -> pl.DataFrame:
        """The ``wanted`` columns but ``skip`` (all of them checked for their type)."""
        time_column = self._require_time()
        for name in wanted:
            dtype = self._path(name).dtype
            if name == time_column and (
                isinstance(dtype, pl.Datetime | pl.Duration) or _holds_text(dtype)
            ):
                continue  # text: ISO 8601 dates and times, as in a CSV file (_time_ns)
            if name == time_column and not dtype.is_numeric():
                raise LogError(_not_a_time(self.path, name, dtype))
            if name in numeric and not _holds_numbers(dtype):
                raise LogError(
                    f"{self.path}: column {excerpt(name)} has type {dtype}, expected a number"
                )
            if name in labels and not (
                dtype.is_numeric()
                or dtype in (pl.String, pl.Categorical, pl.Boolean)
                or isinstance(dtype, pl.Enum)
            ):
                raise LogError(
                    f"{self.path}: column {excerpt(name)} has type {dtype}, expected mode ids"
                )
        try:
            # low_memory: decoded a row group at a time, 10^6 rows of 9 columns (82 MB of
            # values) peak about 25 MiB lower, in about the same time
            read = [name for name in wanted if name not in skip]
            paths = [self._path(name) for name in read]
            frame = _read_parquet(
                self._file,
                columns=list(dict.fromkeys(p.column for p in paths)),
                low_memory=True,
            )
        except pl.exceptions.PolarsError as err:
            raise LogError(
                f"{self.path}: not a readable Parquet file ({_first_line(err)})"
            ) from err
        if any(p.nested for p in paths):
            frame = pl.DataFrame([self._leaf_values(frame, p) for p in paths])
        casts = [
            pl.col(name).cast(pl.Float64)
            for name in read
            if name in numeric and name not in labels and frame.schema[name] != pl.Float64
        ]
        return frame.with_columns(casts) if casts else frame

    def _leaf_values(self, frame: pl.DataFrame, path: ColumnPath) -> pl.Series:
        """:func:`~hybridlog.io.table_paths.leaf_values`, its error a :class:`LogError`."""
        try:
            return leaf_values(frame, path, self.path, self._row_label)
        except PathError as err:
            raise LogError(str(err)) from None

    def _parquet_column(self, name: str, rows: IntArray | None) -> pl.Series:
        """One numeric field of a Parquet log, at ``rows`` (``None``: all), as stored.

        :meth:`_to_float` makes it ``Float64`` after :meth:`_refuse_inexact` looked at it.
        """
        path = self._path(name)
        try:
            frame = _read_parquet(self._file, columns=[path.column], low_memory=True)
        except pl.exceptions.PolarsError as err:
            raise LogError(
                f"{self.path}: not a readable Parquet file ({_first_line(err)})"
            ) from err
        column = self._leaf_values(frame, path)
        del frame
        return column if rows is None else column.gather(rows)

    def _kept_rows(self, frame: pl.DataFrame, time_column: str) -> IntArray:
        """Rows to use: all of them, minus blank CSV lines; a row without a time is an error."""
        rows: IntArray = np.arange(frame.height, dtype=np.int64)
        missing = _empty_cells(frame.get_column(time_column))
        if not missing.any():
            return rows
        blank = _blank_csv_rows(self._file) if self._format == "csv" else np.zeros_like(missing)
        not_blank = missing & ~blank[: missing.size]
        if not_blank.any():
            raise self._empty_time_cell(int(np.argmax(not_blank)))
        kept: IntArray = rows[~missing]
        return kept

    def _empty_time_cell(self, row: int) -> LogError:
        """The error of an empty time cell in data row ``row`` (0-based) not on a blank line."""
        return LogError(
            f"{self.path}, {self._row_label(row)}, column {excerpt(str(self._time_column))}: "
            "empty time cell"
        )

    def _sorted(
        self, frame: pl.DataFrame, rows: IntArray, time_ns: IntArray
    ) -> tuple[pl.DataFrame, IntArray, IntArray]:
        """``--sort``: rows in time order (stable: rows of one time stay in file order)."""
        steps = np.diff(time_ns)
        if steps.size and (steps < 0).any():
            order = np.argsort(time_ns, kind="stable")
            self._notes["sorted"] = {"rows_out_of_order": int((steps < 0).sum())}
            frame, rows, time_ns = frame[pl.Series(order)], rows[order], time_ns[order]
        return frame, rows, time_ns

    def _count_repeats(self, time_ns: IntArray) -> bool:
        """Whether sorted ``time_ns`` repeats a time; notes how many rows are combined.

        Rows of one time are one sample per column (:meth:`_last_at_each_time`): a logger of
        sparse signals writes a row per signal, ``0.1,1,`` then ``0.1,,10``, and both values
        are samples at t = 0.1.
        """
        repeated = int(np.count_nonzero(time_ns[1:] == time_ns[:-1]))
        if repeated:
            self._notes["rows_combined"] = repeated
        return repeated > 0

    def _last_at_each_time(
        self,
        name: str,
        time_ns: IntArray,
        rows: IntArray,
        repeats: bool,
        values: FloatArray | None = None,
    ) -> np.ndarray[Any, np.dtype[np.bool_]] | None:
        """Which of a column's samples (sorted ``time_ns``, on ``rows``) to keep.

        The last at each time (with ``values``, ``--drop-nonfinite``: the last usable one,
        and the unusable ones for it to drop, :func:`~.source.last_of_each_time`); ``None``
        when every sample is kept; else the rows of the others are kept for
        :meth:`_note_superseded`.
        """
        if not repeats or time_ns.size < 2:
            return None
        last = last_of_each_time(time_ns, values)
        if last.all():
            return None
        self._superseded[name] = rows[~last]
        return last

    def _note_superseded(self, superseded: dict[str, IntArray], kept: list[IntArray]) -> None:
        """Note what ``--sort`` dropped of the rows of a repeated time.

        ``duplicates_dropped``: rows none of whose cells read was kept (a row written twice);
        ``values_superseded``: per column, the values replaced by a later row's at the same
        time in rows that gave others.  Rows that each give other columns (a row per signal)
        lose nothing and are only counted in ``rows_combined``.
        """
        giving = np.unique(np.concatenate(kept)) if kept else np.zeros(0, dtype=np.int64)
        dropped_rows = np.setdiff1d(np.unique(np.concatenate(list(superseded.values()))), giving)
        if dropped_rows.size:
            self._notes["duplicates_dropped"] = int(dropped_rows.size)
        replaced = {
            name: int(np.count_nonzero(~np.isin(rows, dropped_rows)))
            for name, rows in superseded.items()
        }
        replaced = {name: count for name, count in replaced.items() if count}
        if replaced:
            self._notes["values_superseded"] = replaced

    def _time_ns(
        self, column: pl.Series, rows: IntArray, *, check: bool = True, repeats: bool = False
    ) -> IntArray:
        """The time column in integer nanoseconds.

        With ``check``, refused unless increasing (non-decreasing with ``repeats``), naming
        the line or row where it is not.
        """
        name = column.name
        if _holds_text(column.dtype):
            column = column.cast(pl.String)
            written = column.drop_nulls()
            iso = _iso_format(written[0] if written.len() else None)
            if iso is not None:
                column = self._parse_iso(column, iso, rows)
            elif self._format != "csv":  # a CSV cell is text whatever it holds
                raise LogError(
                    f"{self.path}: column {excerpt(name)} has type {column.dtype}, expected "
                    "seconds as numbers or ISO 8601 dates and times (e.g. "
                    f"2024-01-01T00:00:00.5), and its first value is {excerpt(written[0], 40)}"
                    if written.len()
                    else f"{self.path}: column {excerpt(name)} has no value"
                )
        if isinstance(column.dtype, pl.Datetime | pl.Duration):
            self._time_resolution_ns = 1.0
            time_ns: IntArray = self._temporal_ns(column, rows)
        else:
            stored = column.dtype
            if self._format == "parquet" and not stored.is_numeric():
                # a Date, Time or Boolean: as read() refuses it (inspect said "line 2 ...
                # '2024-01-01' is not a number", or that a Boolean time goes backwards)
                raise LogError(_not_a_time(self.path, name, stored))
            column = self._to_float(column, rows)
            seconds: FloatArray = np.asarray(column.to_numpy(), dtype=np.float64)  # no copy
            bad = check_seconds_range(seconds)
            if bad >= 0:
                as_written = None
                if self._format == "csv" and not np.isfinite(seconds[bad]):
                    # the cell as written: a CSV '1e400' parsed as inf, which it does not say
                    cells = _read_csv_strings(self._file, [name], checked=True).get_column(name)
                    as_written = excerpt(str(cells[int(rows[bad])]).strip(), 40)
                raise LogError(
                    f"{self.path}, {self._row_label(int(rows[bad]))}, column {excerpt(name)}: "
                    f"{bad_seconds(float(seconds[bad]), as_written)}"
                )
            if stored in (pl.Float32, pl.Float16):
                self._check_resolution(name, stored, seconds, rows)
            else:
                self._check_float64_resolution(name, seconds, rows)
            kind: type[np.floating[Any]] = np.float64
            if stored == pl.Float32:
                kind = np.float32
            elif stored == pl.Float16:
                kind = np.float16
            self._time_resolution_ns = seconds_resolution_ns(seconds, kind)
            time_ns = seconds_to_ns(seconds)
        # Compared pairwise (no array of N differences): within +-9.2e18 ns differences
        # do not overflow, so ``later <= earlier`` is ``diff <= 0``.
        not_after = time_ns[1:] < time_ns[:-1] if repeats else time_ns[1:] <= time_ns[:-1]
        if check and not_after.size and not_after.any():
            i = int(np.argmax(not_after)) + 1
            how = "repeats" if time_ns[i] == time_ns[i - 1] else "goes backwards"
            raise LogError(
                f"{self.path}, {self._row_label(int(rows[i]))}, column {excerpt(name)}: time {how} "
                f"(t={format_ns(int(time_ns[i]))} s after t={format_ns(int(time_ns[i - 1]))} s "
                f"on {self._row_label(int(rows[i - 1]))}); time must be strictly increasing "
                "(--sort puts rows in time order, rows of one time as one sample per column)"
            )
        self._rows[name] = rows
        return time_ns

    def _check_resolution(
        self, name: str, stored: pl.DataType, seconds: FloatArray, rows: IntArray
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
                f"{self.path}, {self._row_label(int(rows[row]))}, column {excerpt(name)}: the "
                f"time column is {_dtype_name(stored)}, whose values near t="
                f"{format_time(seconds[row])} s "
                f"are {resolution:.3g} s apart, {steps}: write the time as float64 (or as a "
                "Datetime)"
            )

    def _check_float64_resolution(self, name: str, seconds: FloatArray, rows: IntArray) -> None:
        """Refuse float64 seconds too coarse for the log's own steps (Unix time, MHz logs).

        Near t = 1.7e9 s float64 values are 238 ns apart: a log sampled every 0.1 µs
        there read as repeated times ("time repeats", which said nothing of why), and with
        ``--sort`` its rows were merged into fewer, unevenly spaced samples.  Refused when
        the spacing exceeds the tolerance the alignment allows a sample's time
        (:func:`~hybridlog.io.align.clock_tolerance_ns` of the mean step, at least the
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
            f"{self.path}, {self._row_label(int(rows[row]))}, column {excerpt(name)}: float64 "
            f"seconds near t={format_time(seconds[row])} s are {spacing_ns:.3g} ns apart, "
            f"too coarse for the log's steps of {format_time(step_ns / NS_PER_S)} s on "
            "average (its times would be rounded by more than the alignment tolerates): "
            "write the time from the log's start, or as ISO 8601 dates and times with "
            "nanoseconds (a Datetime in Parquet)"
        )

    def _parse_iso(self, column: pl.Series, iso: str, rows: IntArray) -> pl.Series:
        """A text time column of ISO 8601 dates and times as a ``Datetime`` (ns; UTC if zoned).

        CSV cells and Parquet string columns alike.

        The format is the first cell's (``T`` or a space between date and time, with or
        without an offset such as ``Z`` or ``+01:00``); every cell must have it.  Parsed to
        microseconds first, which hold any year, so that a date past 2262 is refused by
        :meth:`_temporal_ns` and not wrapped around by a parse to nanoseconds; then to
        nanoseconds, for the digits past the microsecond.
        """
        text = column.str.strip_chars()
        coarse = text.str.to_datetime(iso, strict=False, time_unit="us")
        failed = (coarse.is_null() & text.is_not_null()).to_numpy()
        if failed.any():
            row = int(np.argmax(failed))
            first = int(np.argmax(text.is_not_null().to_numpy()))
            if _iso_format(str(text[row])) == iso:  # written alike: a day that does not exist
                raise LogError(
                    f"{self.path}, {self._row_label(int(rows[row]))}, column "
                    f"{excerpt(column.name)}: {excerpt(text[row], 40)} is not a date and time "
                    "(ISO 8601): no such day of its month, or hour, minute or second of a day"
                )
            raise LogError(
                f"{self.path}, {self._row_label(int(rows[row]))}, column {excerpt(column.name)}: "
                f"{excerpt(text[row], 40)} is not a date and time written like "
                f"{excerpt(text[first], 40)} on {self._row_label(int(rows[first]))} (ISO 8601)"
            )
        self._temporal_ns(coarse, rows)
        return text.str.to_datetime(iso, strict=True, time_unit="ns").alias(column.name)

    def _temporal_ns(self, column: pl.Series, rows: IntArray) -> IntArray:
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
            raise LogError(
                f"{self.path}, {self._row_label(int(rows[row]))}, column "
                f"{excerpt(column.name)}: the {what} {excerpt(str(column[row]), 40)} is beyond "
                f"what the nanosecond grid holds ({held})"
            )
        time_ns: IntArray = stored * factor
        return time_ns

    # ------------------------------------------------------------------ inspect

    def describe(self) -> dict[str, Any]:
        """Summarise the table for ``hybridlog inspect``.

        Returns
        -------
        dict
            JSON-serialisable: ``path, format, rows, columns`` (``name, dtype, count,
            nonfinite, min, max`` and the steps of the column's own samples, its non-empty
            cells, as for the time column below; a Parquet struct, list or array column gives
            an entry per field and element, ``pose.x``, ``q[0]``, or ``q[]`` for lists of
            different lengths, named in ``problems``), ``time`` (``column, start, end, duration`` in
            seconds, or ``None``), the time column's steps as
            :func:`~hybridlog.io.summary.describe_steps` gives them (``rate_hz``: the mean
            rate over the span, ``sample_time``: the median step, ``min_step``,
            ``max_step``, ``regular``, ``gaps``: steps longer than 1.5 times the median, at
            most 1000, ``gap_count``, ``repeated``: rows at the time of the one before, which
            ``analyze`` refuses unless ``--sort``) and ``problems`` (why time is unusable:
            a time that goes backwards, a missing or bad time).  Times are
            seconds as floats; statistics of columns that are not numeric are ``None``.
        """
        if self._format == "csv":
            return self._describe_csv()
        return self._describe_parquet()

    def _describe_csv(self) -> dict[str, Any]:
        """:meth:`describe` of a CSV file, its lines read a block at a time (:mod:`.csv_tally`)."""
        tallies = [ColumnTally(name) for name in self._columns]
        seconds: list[pl.Series] = []  # the time column's numbers, while they are all numbers
        missing: list[IntArray] = []  # rows of an empty time cell
        unblank: int | None = None  # the first of them that is not a blank line
        _check_truncated(self._file)
        _check_record_widths(self._file, self._columns)
        for frame in _csv_text_frames(self._file, list(self._columns), checked=True):
            first = tallies[0].rows
            for tally in tallies:
                cells = frame.get_column(tally.name)
                parsed = tally.add(cells)
                if tally.name != self._time_column:
                    continue
                seconds.append(parsed)
                empty = _empty_cells(cells)
                if empty.any():
                    missing.append(np.flatnonzero(empty) + first)
                    odd = empty & ~_blank_rows(frame)
                    if unblank is None and odd.any():
                        unblank = first + int(np.argmax(odd))
            del frame
        height = tallies[0].rows

        def kept_rows() -> IntArray:
            if unblank is not None:
                raise self._empty_time_cell(unblank)
            dropped = np.concatenate([np.zeros(0, dtype=np.int64), *missing])
            return np.delete(np.arange(height, dtype=np.int64), dropped)

        def time_cells(rows: IntArray) -> pl.Series:
            time = next(t for t in tallies if t.name == self._time_column)
            if time.dtype == "float64":  # as _parse_floats reads them
                return pl.concat(seconds).alias(time.name).gather(rows)
            text = _read_csv_strings(self._file, [time.name], checked=True)
            return text.get_column(time.name).gather(rows)  # dates and times, or an error

        problems: list[str] = []
        rows, time_ns = self._timed_rows(height, kept_rows, time_cells, problems)
        seconds.clear()
        resolution = self._time_resolution_ns
        columns: list[dict[str, Any]] = []
        for tally in tallies:
            present = tally.present()[rows] if rows.size < height else tally.present()
            columns.append(
                _column_info(tally.name, tally.dtype, tally.values(), present, time_ns, resolution)
            )
            if columns[-1]["nonfinite"] is not None and tally.name != self._time_column:
                found = self._unheld_value(*tally.suspects())
                problems.extend([found] if found is not None else [])
            elif tally.name != self._time_column:  # the time's own problem is said above
                problems.extend(_texts_among_numbers(tally))
        return self._described(rows.size, columns, time_ns, problems)

    def _describe_parquet(self) -> dict[str, Any]:
        """:meth:`describe` of a Parquet file, a column at a time."""
        height = self._parquet_rows()
        time_frame = pl.DataFrame()
        if self._time_column is not None and height:
            time_frame = self._read_parquet_columns([self._time_column])

        def kept_rows() -> IntArray:
            return self._kept_rows(time_frame, str(self._time_column))

        def time_cells(rows: IntArray) -> pl.Series:
            return time_frame.get_column(str(self._time_column))[pl.Series(rows)]

        problems: list[str] = []
        rows, time_ns = self._timed_rows(height, kept_rows, time_cells, problems)
        time_frame = time_frame.clear()
        resolution = self._time_resolution_ns
        columns: list[dict[str, Any]] = []
        unheld: list[str] = []
        for name in self._columns:
            frame = self._leaves_of(self._read_parquet_columns([name]), problems)
            if rows.size < frame.height:
                frame = frame[pl.Series(rows)]
            for column in frame.iter_columns():
                columns.append(_describe_column(column, time_ns, resolution))
                if columns[-1]["nonfinite"] is not None and column.name != self._time_column:
                    found = self._unheld_value(column, rows)
                    unheld.extend([found] if found is not None else [])
        return self._described(rows.size, columns, time_ns, problems + unheld)

    def _timed_rows(
        self,
        height: int,
        kept_rows: Callable[[], IntArray],
        time_cells: Callable[[IntArray], pl.Series],
        problems: list[str],
    ) -> tuple[IntArray, IntArray | None]:
        """The rows :meth:`describe` describes, and their times (``None``: no usable time).

        ``kept_rows`` gives the rows but those of blank lines, or raises for an empty time
        cell; ``time_cells`` the time column at those rows.  Why the time is unusable is
        appended to ``problems``; the rows are then all of them.
        """
        rows: IntArray = np.arange(height, dtype=np.int64)
        if height == 0:
            problems.append("no data rows")
        elif self._time_column is None:
            problems.append("no time column (expected 't' or 'time')")
        else:
            try:
                kept = kept_rows()
                return kept, self._time_ns(time_cells(kept), kept, repeats=True)
            except LogError as err:
                problems.append(
                    str(err).removeprefix(f"{self.path}, ").removeprefix(f"{self.path}: ")
                )
        return rows, None

    def _described(
        self,
        height: int,
        columns: list[dict[str, Any]],
        time_ns: IntArray | None,
        problems: list[str],
    ) -> dict[str, Any]:
        """:meth:`describe`'s dict of the described ``columns`` and times."""
        resolution = self._time_resolution_ns
        steps = describe_steps(
            time_ns if time_ns is not None else np.zeros(0, dtype=np.int64),
            resolution_ns=resolution,
        )
        info: dict[str, Any] = {
            "path": self.path,
            "format": self._format,
            "rows": height,
            "columns": columns,
            "time": None,
            **steps,
            "problems": problems,
        }
        if time_ns is not None and time_ns.size:
            info["time"] = {
                "column": self._time_column,
                "start": seconds_of(time_ns[0]),
                "end": seconds_of(time_ns[-1]),
                "duration": round_span(int(time_ns[-1]) - int(time_ns[0]), resolution),
            }
        return info

    def _unheld_value(self, taken: pl.Series, rows: IntArray) -> str | None:
        """The first value of a numeric column that ``analyze`` refuses as not held, if any.

        The checks :meth:`read` makes of a number it reads, made here too: an integer beyond
        2^53 that a ``float64`` cannot hold (:meth:`_refuse_inexact`), a CSV number beyond
        the range of a ``float64`` (:meth:`_refuse_overflow`).  Inspect, which parsed the
        column on its own, gave such a column's range as though it held the number, and
        ``analyze`` then refused the log naming a line inspect said nothing of.  ``rows``:
        the data row of each of ``taken``'s cells.  ``None`` when every value is held.
        """
        if _holds_text(taken.dtype):
            column = taken.str.strip_chars().cast(pl.Float64, strict=False)
        elif _holds_numbers(taken.dtype):
            column = taken.cast(pl.Float64)
        else:
            return None
        try:
            self._refuse_inexact(taken, column, rows)
            if self._format == "csv" and column.is_infinite().any():
                self._refuse_overflow(column, rows, taken)
        except LogError as err:
            return str(err).removeprefix(f"{self.path}, ")
        return None

    def _leaves_of(self, frame: pl.DataFrame, problems: list[str]) -> pl.DataFrame:
        """``frame`` with each struct, list or array column replaced by its leaves.

        A list whose rows differ in length stays whole (``q[]``) and a null inside a list is
        noted: both are what ``analyze`` refuses (:mod:`~hybridlog.io.table_paths`).
        """
        if not any(is_nested(dtype) for dtype in frame.schema.values()):
            return frame
        columns: list[pl.Series] = []
        for name, dtype in frame.schema.items():
            if not is_nested(dtype):
                columns.append(frame.get_column(name))
                continue
            leaves, found = expand(frame, name)
            problems.extend(found)
            cell = frame.get_column(name).is_not_null()
            for leaf in leaves:
                if leaf.text in self._columns:  # a flat column of that name is what it names
                    problems.append(
                        f"column {excerpt(leaf.text)} hides the field of that name inside "
                        f"column {excerpt(name)}, which therefore cannot be mapped"
                    )
                    continue
                if leaf.text.endswith("[]"):
                    columns.append(frame.select(leaf.expr().alias(leaf.text)).to_series())
                    continue
                values = frame.select(leaf.expr().alias(leaf.text)).to_series()
                hole = (values.is_null() & cell).to_numpy() if leaf.in_list else None
                if hole is not None and hole.any():
                    problems.append(
                        f"{self._row_label(int(np.argmax(hole)))}, column {excerpt(name)}: "
                        f"{excerpt(leaf.text)} is null inside the row's list "
                        f"({int(hole.sum())} such rows; analyze refuses them)"
                    )
                columns.append(values)
        return pl.DataFrame(columns)

    def _read_parquet_columns(self, columns: list[str]) -> pl.DataFrame:
        """The named top-level columns of a Parquet log, as stored."""
        try:
            return _read_parquet(self._file, columns=columns, low_memory=True)
        except pl.exceptions.PolarsError as err:
            raise LogError(
                f"{self.path}: not a readable Parquet file ({_first_line(err)})"
            ) from err

    def _parquet_rows(self) -> int:
        """How many rows a Parquet log has (from its metadata)."""
        try:
            with _panics_refused(self._file, "Parquet"), polars_file(self._file, "rb") as source:
                rows = pl.scan_parquet(source, glob=False).select(pl.len()).collect().item()
        except pl.exceptions.PolarsError as err:
            raise LogError(
                f"{self.path}: not a readable Parquet file ({_first_line(err)})"
            ) from err
        return int(rows)


class _ColumnBlock:
    """One NumPy allocation holding the numeric columns of a read, a row per column.

    Allocated on the first :meth:`take` (a read whose columns all have empty cells needs
    none), uninitialised: every row used is written once.
    """

    def __init__(self, columns: int, length: int) -> None:
        self._shape = (columns, length)
        self._block: FloatArray | None = None
        self._used = 0

    def take(self, values: pl.Series) -> FloatArray:
        """A copy of ``values`` (``Float64``, no nulls) in the next row of the block.

        Copied a chunk at a time (each a NumPy view of polars' memory), with no array of
        them put end to end in between.
        """
        if self._block is None:
            self._block = np.empty(self._shape, dtype=np.float64)
        row: FloatArray = self._block[self._used]
        start = 0
        for chunk in values.get_chunks():
            row[start : start + chunk.len()] = chunk.to_numpy()
            start += chunk.len()
        self._used += 1
        return row


# ---------------------------------------------------------------------- polars' panics


@contextlib.contextmanager
def _panics_refused(path: Path, kind: str) -> Iterator[None]:
    """Refuse a file on which polars panics (a damaged Parquet page), as a :class:`LogError`.

    A panic is a ``BaseException`` (``pyo3_runtime.PanicException``), which escaped as a
    traceback, after Rust's own message and, with ``RUST_BACKTRACE`` set, its stack printed
    to the process's standard error: that is held while polars reads, and written out unless
    polars panicked.  ``sys.stderr`` is ``None`` in a process started with descriptor 2
    closed: a worker of ``batch --jobs 2 2>&-`` (multiprocessing's forkserver), where every
    log failed on "'NoneType' object has no attribute 'flush'".
    """
    if sys.stderr is not None:
        sys.stderr.flush()
    saved = os.dup(2)
    panicked = False
    try:
        with _held_file() as held:
            os.dup2(held.fileno(), 2)
            try:
                yield
            except pl.exceptions.PanicException as err:
                panicked = True
                raise LogError(
                    f"{path}: not a readable {kind} file (damaged? polars failed on it: "
                    f"{_first_line(err)})"
                ) from None
            finally:
                os.dup2(saved, 2)
                if not panicked:
                    held.seek(0)
                    written = held.read()
                    if written:
                        os.write(2, written)
    finally:
        os.close(saved)


def _held_file() -> Any:
    """A file in memory (no disk, no ``TMPDIR``), or a temporary file where there is none."""
    if hasattr(os, "memfd_create"):
        return os.fdopen(os.memfd_create("hybridlog-polars-stderr"), "w+b")
    return tempfile.TemporaryFile()  # pragma: no cover - not Linux


# ---------------------------------------------------------------------- CSV helpers


def _first_line(err: BaseException) -> str:
    """The first line of a library's error, cut short: it may quote the file's bytes."""
    text = str(err).strip()
    return excerpt(text.splitlines()[0], 120)[1:-1] if text else type(err).__name__


def _read_csv_header(path: Path) -> tuple[str, ...]:
    """The column names of a CSV file, without the spaces around them (:func:`_header_names`)."""
    return tuple(_header_names(path))


def _header_names(path: Path) -> dict[str, str]:
    """``{name: name as written}`` for the columns of a CSV file, in file order.

    Loggers that write ``t, u, y`` (a space after each comma) give the names ``" u"`` and
    ``" y"``, which no user means: names are taken without the ASCII spaces around them
    (the reading notes say so), unless that would make two of them the same.

    Raises
    ------
    LogError
        As :func:`_header_as_written`, and when two names differ only in spaces around them.
    """
    written = _header_as_written(path)
    names: dict[str, str] = {}
    for as_written in written:
        name = as_written.strip(" ")
        if name in names:
            raise LogError(
                f"{path}, line 1: the header's columns {excerpt(names[name])} and "
                f"{excerpt(as_written)} differ only in the spaces around them: rename one"
            )
        names[name] = as_written
    return names


def _header_as_written(path: Path) -> tuple[str, ...]:
    """Parse line 1 of a CSV file into column names as written, checking them."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            line = handle.readline()
    except UnicodeDecodeError as err:
        refuse_not_utf8(path)
        raise LogError(f"{path}: not a UTF-8 text file ({err.reason})") from err
    except OSError as err:
        raise LogError(f"{path}: cannot be read ({err.strerror})") from err
    if not line:
        raise LogError(f"{path}: empty file")
    if not line.strip():
        raise LogError(f"{path}, line 1: no header (the first line must name the columns)")
    if line.endswith("\r"):  # newline="" ends a line at "\r\n", "\n" or a lone "\r"
        raise LogError(
            f"{path}, line 1: ends in a carriage return alone (classic Mac OS line endings); "
            "hybridlog reads LF or CRLF line endings: convert the file, e.g. tr '\\r' '\\n'"
        )
    names = next(csv.reader([line]))
    if names[-1].endswith("\n"):  # the line's end read into a quoted field left open
        raise LogError(
            f"{path}, line 1: the header's column {len(names)} opens a quote that runs on to "
            "line 2; a header names its columns on one line (an unclosed quote?)"
        )
    if '"' in line and _RECORD.fullmatch(line.rstrip("\r\n")) is None:
        # t,u"x,y: polars opened a quote at u"x that ran to the end of the file and read
        # the log as 0 rows ("no data rows"), with no word of the quote
        raise LogError(
            f"{path}, line 1: a quote inside a column name that is not quoted "
            f'({excerpt(line.strip(), 60)}); a name with a quote is quoted whole, e.g. "u""x"'
        )
    if line.startswith("#") and not set(TIME_COLUMNS) & {name.strip(" ") for name in names}:
        # a comment line before the header, or numpy.savetxt's header ('# t,u,y'): the
        # columns were named '# t' or after the comment, and the next line "had 3 fields"
        raise LogError(
            f"{path}, line 1: {excerpt(line.strip(), 40)} starts with '#', a comment; the first "
            "line must be the header naming the columns, e.g. t,u,y: remove the comment "
            "lines (numpy.savetxt writes its header so unless given comments='')"
        )
    if len(names) == 1:
        # Excel in locales with a decimal comma writes ';', other tools tabs: one column
        # named 't;u;y' would be listed as the only column, or as text that is not printable
        for separator, word in ((";", "semicolons"), ("\t", "tabs")):
            if separator in line:
                raise LogError(
                    f"{path}, line 1: the header {excerpt(line.strip(), 40)} is separated by "
                    f"{word}; hybridlog reads comma-separated CSV (and a point as the "
                    "decimal separator): convert the file"
                )
    if all(_is_number(name) for name in names):
        raise LogError(
            f"{path}, line 1: no header; {excerpt(line.strip(), 40)} looks like data "
            "(the first line must name the columns, e.g. t,u,y)"
        )
    for position, name in enumerate(names, start=1):
        if not name.strip():
            why = ""
            if position == len(names):
                why = " (a separator at the end of the line?)"
            elif position == 1:
                why = " (pandas' to_csv writes its index so: write with index=False)"
            raise LogError(f"{path}, line 1: column {position} of the header has no name{why}")
        if not name.isprintable():
            if "\x00" in name:
                refuse_not_utf8(path)  # UTF-16 without a byte-order mark, ASCII header
            raise LogError(
                f"{path}, line 1: column {position} of the header, {excerpt(name, 40)}, is not "
                "printable text (a zeroed or binary file?)"
            )
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise LogError(f"{path}, line 1: duplicate column name {excerpt(name)} in the header")
        seen.add(name)
    return tuple(names)


_ISO_DATE = re.compile(
    r"\d{4}-\d{2}-\d{2}([Tt ])\d{2}:\d{2}(:\d{2}(\.\d+)?)?(Z|[+-]\d{2}(?::?\d{2})?)?$"
)


def _iso_format(text: str | None) -> str | None:
    """The polars format of an ISO 8601 date and time like ``text``, or ``None`` if not one.

    ``2024-01-01T00:00:00.5``, ``2024-01-01 00:00:00`` (pandas), ``t`` as RFC 3339 allows,
    either with ``Z`` or an offset (``+01:00``, ``+0100``, ``+01``); seconds are needed.
    """
    match = _ISO_DATE.match(text.strip()) if text else None
    if match is None or match.group(2) is None:
        return None
    zone = "%#z" if match.group(4) else ""
    return f"%Y-%m-%d{match.group(1)}%H:%M:%S%.f{zone}"


def _first_cell(path: Path, index: int) -> str | None:
    """The first non-empty cell of column ``index`` in the first 1000 data lines of a CSV."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            reader = csv.reader(handle)
            next(reader, None)
            for record, _ in zip(reader, range(1000), strict=False):
                if len(record) > index and record[index].strip():
                    return record[index]
    except (UnicodeDecodeError, csv.Error, OSError):
        return None  # the reading proper says what is wrong
    return None


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _read_csv(path: Path, **options: Any) -> pl.DataFrame:
    """``pl.read_csv`` of a log, its blocks of lines (:func:`_csv_frames`) put end to end."""
    return pl.concat(list(_csv_frames(path, **options)))


def _csv_frames(path: Path, **options: Any) -> Iterator[pl.DataFrame]:
    """``pl.read_csv`` of each block of a log's lines (:func:`.csv_tally.csv_blocks`), in turn.

    Given the file, polars maps it into memory whole, and its pages count in the process's
    memory beside the columns read: 9 columns of 10^7 rows read from a 1.3 GB file peaked at
    1.8 GB.  Read from blocks, the file is read once, the blocks' bytes one at a time, and
    its name taken as Python takes it (polars takes only UTF-8 names,
    :func:`~hybridlog.polars_import.polars_file`).  ``columns`` and ``schema_overrides``
    name columns as :func:`_read_csv_header` does (no spaces around), and so do the frames'
    columns.
    """
    names = _header_names(path)
    written = {name: w for name, w in names.items() if name != w}
    if any('"' in name for name in names):
        written = _polars_names(path, names)
    if written:
        if "columns" in options:
            options["columns"] = [written.get(c, c) for c in options["columns"]]
        if "schema_overrides" in options:
            options["schema_overrides"] = {
                written.get(c, c): t for c, t in options["schema_overrides"].items()
            }
    renamed = {w: name for name, w in written.items()}
    for data in csv_blocks(path):
        with _panics_refused(path, "CSV"):
            frame = pl.read_csv(data, **options)
        yield frame.rename(renamed, strict=False) if renamed else frame


def _polars_names(path: Path, names: Mapping[str, str]) -> dict[str, str]:
    """``{name: polars' name}`` of the columns of a CSV log whose names polars reads otherwise.

    A quote in a quoted name is written twice (``"a""b"``, RFC 4180), and polars 2.1 keeps
    both in a header's name (``a""b``) while the ``csv`` module reads the ``a"b`` that
    :func:`_header_names` gives: polars then found no column ``a"b``, and the log was
    refused as "not a readable CSV file (unable to find column ...)".  polars' names are
    read from the header line and paired with ``names`` by position.
    """
    try:
        with path.open("rb") as handle:
            line = handle.readline()
    except OSError as err:
        raise LogError(f"{path}: cannot be read ({err.strerror})") from err
    try:
        with _panics_refused(path, "CSV"):
            theirs = pl.read_csv(line, n_rows=0, infer_schema=False).columns
    except pl.exceptions.PolarsError:
        theirs = []
    if len(theirs) != len(names):
        return {name: w for name, w in names.items() if name != w}
    return {name: their for name, their in zip(names, theirs, strict=True) if name != their}


def _read_csv_strings(path: Path, columns: list[str], *, checked: bool = False) -> pl.DataFrame:
    """Read ``columns`` as text (:func:`_csv_text_frames`) put end to end."""
    return pl.concat(list(_csv_text_frames(path, columns, checked=checked)))


def _csv_text_frames(
    path: Path, columns: list[str], *, checked: bool = False
) -> Iterator[pl.DataFrame]:
    """``columns`` of each block of a log's lines as text; a file polars cannot parse refused.

    ``checked``: the caller already ran :func:`_check_truncated` and
    :func:`_check_record_widths`.

    Raises
    ------
    LogError
        Naming the file, and the line of a byte that is not UTF-8 or a stray quote.
    """
    if not checked:
        _check_truncated(path)
        _check_record_widths(path, columns)
    frames = _csv_frames(path, columns=columns, infer_schema=False)
    while True:
        try:
            frame = next(frames, None)
        except pl.exceptions.PolarsError as err:
            refuse_not_utf8(path)
            _refuse_stray_quote(path)
            _check_record_widths(path)
            raise LogError(f"{path}: not a readable CSV file ({_first_line(err)})") from err
        if frame is None:
            return
        yield frame


_FIELD = r'(?:[^",\r\n]*|\s*"(?:[^"]|"")*"\s*)'
_RECORD = re.compile(rf"{_FIELD}(?:,{_FIELD})*")


def _refuse_stray_quote(path: Path) -> None:
    """Name the first line with a quote inside an unquoted field (``a"b``), if there is one.

    polars refuses such a file ("CSV malformed") without saying where; the ``csv`` module
    takes the quote as text.  Only called once polars has refused the file.

    Raises
    ------
    LogError
        Naming the line.
    """
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            for number, line in enumerate(handle, start=1):
                text = line.rstrip("\r\n")
                if '"' in text and _RECORD.fullmatch(text) is None:
                    raise LogError(
                        f"{path}, line {number}: a quote inside a field that is not quoted "
                        f'({excerpt(text, 60)}); a field is quoted whole, e.g. "1.5"'
                    )
    except (UnicodeDecodeError, OSError):
        return


def _read_csv_frame(
    path: Path, columns: list[str], as_float: set[str], time_column: str
) -> pl.DataFrame:
    """Read ``columns``: those in ``as_float`` as ``Float64``, the others as text.

    A column of ``true`` and ``false`` reads as 1 and 0, but for ``time_column``
    (:func:`_parse_floats`).

    The fast path lets polars parse the numbers; when that fails the columns are read as
    text and converted here, which tolerates surrounding blanks and finds the bad cell.
    """
    schema = {c: pl.Float64 if c in as_float else pl.String for c in columns}
    _check_truncated(path)
    _check_record_widths(path, columns)
    try:
        frame = _read_csv(path, columns=columns, schema_overrides=schema, infer_schema=False)
    except pl.exceptions.PolarsError:
        text = _read_csv_strings(path, columns, checked=True)
        rows: IntArray = np.arange(text.height, dtype=np.int64)
        return text.with_columns(
            [
                _parse_floats(path, text.get_column(c), rows, booleans=c != time_column)
                for c in columns
                if c in as_float
            ]
        )
    return frame


_DECIMAL_COMMA = re.compile(r"[+-]?\d*,\d+(?:[eE][+-]?\d+)?")
_GROUPED = re.compile(r"[+-]?\d{1,3}(?:[,.' \u00a0\u202f]\d{3})+(?:[.,]\d*)?")
"""Digits grouped by thousands (``1,000``, ``1.234.567,5``, ``1 000``): the comma is not
only a decimal comma, whose hint alone led a user to write ``1.000`` for one thousand."""


def _parse_floats(
    path: Path, column: pl.Series, rows: IntArray, *, booleans: bool = False
) -> pl.Series:
    """Convert a text column to ``Float64``; empty cells become nulls, others must parse.

    With ``booleans`` (a signal, not the time), a column whose every cell is ``true`` or
    ``false`` (any case: polars and pandas write booleans so) reads as 1 and 0, as a
    Parquet boolean column, a ROS ``bool`` or a JSON ``true`` do; such a cell among numbers
    is refused, as any other text.
    """
    text = stripped_cells(column)
    values = text.cast(pl.Float64, strict=False)
    bad = (values.is_null() & text.is_not_null()).to_numpy()
    if bad.any():
        lowered = text.str.to_lowercase()
        if booleans and bool(lowered.drop_nulls().is_in(BOOLEANS).all()):
            return (lowered == "true").cast(pl.Float64).alias(column.name)
        first = int(np.argmax(bad))
        raise LogError(
            f"{path}, line {int(rows[first]) + 2}, column {excerpt(column.name)}: "
            f"{_not_a_number(str(text[first]), booleans=booleans)}"
        )
    return values


def _not_a_number(cell: str, *, booleans: bool) -> str:
    """``'0x10' is not a number``, with a hint where the cell is a number written otherwise.

    ``booleans``: true and false count as numbers in a column of nothing else.
    ``analyze``'s refusal of the cell (:func:`_parse_floats`) and ``inspect``'s note of the
    first such cell of a column of numbers (:meth:`TableSource._describe_csv`) alike.
    """
    hint = ""
    if booleans and cell.lower() in BOOLEANS:
        hint = " (true and false read as 1 and 0 only in a column of nothing else)"
    elif _ISO_DATE.match(cell):  # 2024-01-01T00:00: no seconds
        hint = " (a date and time is read with its seconds, e.g. 2024-01-01T00:00:00)"
    elif _GROUPED.fullmatch(cell):  # "1,000": one thousand, or one?
        hint = (
            " (digits grouped by thousands, or a decimal comma? hybridlog reads digits "
            "alone, with a point as the decimal separator)"
        )
    elif _DECIMAL_COMMA.fullmatch(cell):  # "1,5" quoted, as Excel writes it
        hint = " (a decimal comma? hybridlog reads a point as the decimal separator)"
    return f"{excerpt(cell)} is not a number{hint}"


def _texts_among_numbers(tally: ColumnTally) -> list[str]:
    """Where a CSV column of numbers has cells that are not: the first, in analyze's words.

    ``inspect`` showed such a column as ``string`` and said no more, and ``analyze`` then
    refused it: ``line 4, column 'y': '0x10' is not a number``.  Nothing for a column
    without a number (labels), nor for one of booleans.
    """
    if tally.first_text is None or not tally.numbers or tally.dtype != "string":
        return []
    row, cell = tally.first_text
    return [
        f"line {row + 2}, column {excerpt(tally.name)}: {_not_a_number(cell, booleans=True)}; "
        f"{tally.numbers} of its {tally.count} cells are numbers: analyze takes it as mode "
        "ids, not as a signal"
    ]


def _empty_cells(column: pl.Series) -> np.ndarray[Any, np.dtype[np.bool_]]:
    """Which cells are empty: null, or text of nothing but blanks (`` ``, a tab, ``""``)."""
    if column.dtype == pl.String:
        empty: np.ndarray[Any, np.dtype[np.bool_]] = (
            (column.str.strip_chars() == "").fill_null(True).to_numpy()
        )
        return empty
    return column.is_null().to_numpy()


def _blank_csv_rows(path: Path) -> np.ndarray[Any, np.dtype[np.bool_]]:
    """Rows that polars read from blank lines (:func:`_blank_rows`), a block at a time.

    Read whole as text, a log of 10^7 rows of 9 columns with one blank line took 4 GB here.
    """
    columns = list(_read_csv_header(path))
    blank = [_blank_rows(frame) for frame in _csv_text_frames(path, columns, checked=True)]
    return np.concatenate(blank)


def _blank_rows(frame: pl.DataFrame) -> np.ndarray[Any, np.dtype[np.bool_]]:
    """Rows of a CSV frame read as text whose every cell is empty (:func:`_empty_cells`).

    A line of spaces or a tab, ``,,`` and ``"",,`` are blank lines as an empty one is: the
    record-width check lets them through as such (:func:`_check_record_widths`).
    """
    blank: np.ndarray[Any, np.dtype[np.bool_]] = (
        frame.select(pl.all_horizontal((pl.all().str.strip_chars() == "").fill_null(True)))
        .to_series()
        .to_numpy()
    )
    return blank


def _check_record_widths(path: Path, reading: Collection[str] = ()) -> None:
    """Every record has as many fields as the header names; blank lines aside.

    polars reads a record with too few fields as missing values, which would silently turn
    a damaged line into "no sample"; too many fields it refuses without saying where, and
    only when it reads every column: reading some (``columns=``), it takes a long line's
    first fields and drops the others.  Both are errors naming the line.  Without quote
    characters in the file, fields are counted from the comma and newline positions; with
    quotes, by the ``csv`` module.

    ``reading``: the columns polars reads once the check passes.  When they are every column
    of the header, the file's count of commas stands for each line's (one pass of NumPy, the
    common case): a short line and a long one cancel out in that count, and polars refuses
    the long one.  Otherwise (``reading`` empty: once polars has refused a file, to find the
    line) every line's commas are counted (:func:`_first_odd_line`): reading some columns,
    a short line and a long one had loaded as cells not measured and the long one's first
    fields.

    Raises
    ------
    LogError
        Naming the first line whose field count differs from the header's.
    """
    header = _read_csv_header(path)
    width = len(header)
    quoted = False
    try:
        if reading and set(header) <= set(reading):
            commas, newlines, quoted, last = _count_separators(path)
            if not quoted and commas == (width - 1) * (newlines + (last != NEWLINE)):
                return  # every line has width - 1 commas, unless a short and a long one
                # cancel out, and polars refuses the long one when it reads every column
        odd = None if quoted else _first_odd_line(path, width)
        if odd is None:  # the file holds a quote
            line, fields, start = *_first_odd_record(path, width), -1
        else:
            line, fields, start = odd
        lone_cr = line > 0 and start >= 0 and _holds_lone_cr(path, start)
    except OSError as err:
        raise LogError(f"{path}: cannot be read ({err.strerror})") from err
    if line:
        why = ""
        if lone_cr:
            why = (
                " (a carriage return alone inside it, a line ending of classic Mac OS: "
                "hybridlog reads LF or CRLF line endings)"
            )
        raise LogError(
            f"{path}, line {line}: {fields} field{'' if fields == 1 else 's'}, but the header "
            f"names {width} columns{why}"
        )


def _holds_lone_cr(path: Path, start: int) -> bool:
    """Whether the line from byte ``start`` of the file holds a carriage return before its end.

    Read :data:`COUNTED_AT_ONCE` bytes at a time up to the line's end: a file of classic Mac
    OS line endings is one line.
    """
    with path.open("rb") as handle:
        handle.seek(start)
        before = b""  # the last byte read: a carriage return that a newline may follow
        while block := handle.read(COUNTED_AT_ONCE):
            text = before + block
            end = text.find(b"\n")
            if end >= 0:
                return b"\r" in text[:end].removesuffix(b"\r")
            if b"\r" in text[:-1]:
                return True
            before = text[-1:]
    return False


def _count_separators(path: Path) -> tuple[int, int, bool, int]:
    """The file's commas, its newlines, whether it holds a quote, and its last byte (-1: none).

    Read :data:`COUNTED_AT_ONCE` bytes at a time into one buffer and counted by NumPy: 35 ms
    for a 112 MiB file, against 0.21 s for reading it whole and counting with ``bytes.count``
    (which also held the file's bytes beside polars' reading of it).
    """
    buffer = bytearray(COUNTED_AT_ONCE)
    block = np.frombuffer(buffer, dtype=np.uint8)  # a view: it sees what is read into buffer
    commas = newlines = 0
    quoted = False
    last = -1
    with path.open("rb", buffering=0) as handle:
        while size := handle.readinto(buffer):
            part = block[:size]
            commas += int(np.count_nonzero(part == COMMA))
            newlines += int(np.count_nonzero(part == NEWLINE))
            quoted = quoted or bool((part == QUOTE).any())
            last = int(part[-1])
    return commas, newlines, quoted, last


def _first_odd_line(path: Path, width: int) -> tuple[int, int, int] | None:
    """Line number, field count and first byte of the first odd line of a file without quotes.

    Odd: not the header, not blank, and without ``width`` fields.  ``(0, 0, -1)`` when there
    is none, ``None`` when the file holds a quote (:func:`_first_odd_record` counts its
    fields then).

    Read :data:`COUNTED_AT_ONCE` bytes at a time into one buffer and counted a line at a
    time by :class:`_LineCommas`.  The file read whole had held its bytes and, for 10^7
    lines, 0.3 GB of positions beside them.
    """
    buffer = bytearray(COUNTED_AT_ONCE)
    block = np.frombuffer(buffer, dtype=np.uint8)  # a view: it sees what is read into buffer
    lines = _LineCommas(width)
    found = None
    with path.open("rb", buffering=0) as handle:
        while size := handle.readinto(buffer):
            part = block[:size]
            if (part == QUOTE).any():
                return None
            if found is None:
                found = lines.first_odd(part)
    return found or lines.last_odd() or (0, 0, -1)


class _LineCommas:
    """The commas of each line of a file given a block at a time (:func:`_first_odd_line`).

    In each block the separators (commas and newlines) are found once, and a line's commas
    are the separators between its newline and the one before: 0.14 s for the 112 MiB
    benchmark file, where NumPy's positions of the commas and of the newlines, paired by
    ``searchsorted``, took 0.20 s.  The line that runs on past a block is carried into the
    next: its number, first byte, commas so far, and whether it is blanks alone so far
    (looked at only while it has no comma).
    """

    def __init__(self, width: int) -> None:
        self.width = width
        self.line, self.start, self.commas, self.blank = 1, 0, 0, True
        self.offset = 0  # the file's bytes before the block

    def first_odd(self, part: np.ndarray[Any, np.dtype[np.uint8]]) -> tuple[int, int, int] | None:
        """Number, fields and first byte of the first odd line ending in the next block."""
        newline = part == NEWLINE
        separators = np.flatnonzero((part == COMMA) | newline)
        ends = np.flatnonzero(newline[separators])  # the newlines among the separators
        if not ends.size:
            self.commas += separators.size
            self.blank = self.blank and not self.commas and not part.tobytes().strip()
            self.offset += part.size
            return None
        counts = np.diff(ends, prepend=-1) - 1  # the commas of each line ending in the block
        counts[0] += self.commas
        stops = separators[ends]  # the lines' newlines, in the block
        starts = np.concatenate(([self.start - self.offset], stops[:-1] + 1))
        found = None
        for index in _odd_lines(part, counts, starts, stops, self.width):
            if self.line + index > 1 and (  # not the header
                counts[index] or not _blank(part, starts[index], stops[index], self.blank)
            ):
                found = self.line + index, int(counts[index]) + 1, self.offset + int(starts[index])
                break
        self.line += ends.size
        self.start = self.offset + int(stops[-1]) + 1
        self.commas = separators.size - int(ends[-1]) - 1
        self.blank = not self.commas and not part[stops[-1] + 1 :].tobytes().strip()
        self.offset += part.size
        return found

    def last_odd(self) -> tuple[int, int, int] | None:
        """The last line's number, fields and first byte if it is odd and has no line ending."""
        odd = self.commas != self.width - 1 and (self.commas or not self.blank)
        if self.offset > self.start and self.line > 1 and odd:
            return self.line, self.commas + 1, self.start
        return None


def _blank(part: np.ndarray[Any, np.dtype[np.uint8]], start: int, stop: int, before: bool) -> bool:
    """Whether ``part[start:stop]`` is blanks alone, ``before``: the line's bytes before ``part``.

    ``start`` is negative for a line that began in a block before.
    """
    return (before or start >= 0) and not part[max(start, 0) : stop].tobytes().strip()


def _odd_lines(
    part: np.ndarray[Any, np.dtype[np.uint8]],
    counts: IntArray,
    starts: IntArray,
    stops: IntArray,
    width: int,
) -> list[int]:
    """Lines (indices into ``counts``) without ``width - 1`` commas but for empty ones.

    An empty line (or a carriage return alone, of a CRLF file) is blank: left out here by
    NumPy, so that a file with a blank line between rows is not looked at a line at a time.
    """
    odd = np.flatnonzero(counts != width - 1)
    if not odd.size:
        return []
    length = stops[odd] - starts[odd]
    cr = part[np.maximum(stops[odd] - 1, 0)] == CARRIAGE_RETURN
    empty = (counts[odd] == 0) & (odd > 0) & ((length == 0) | ((length == 1) & cr))
    kept: list[int] = odd[~empty].tolist()
    return kept


def _first_odd_record(path: Path, width: int) -> tuple[int, int]:
    """Like :func:`_first_odd_line` for files with quoted fields, by the ``csv`` module.

    A quoted field that runs over more than one line is refused here: no value of a log
    needs a line break, so it is an unclosed quote (which swallows the rest of the file
    into one record), and every line number reported later counts one record per line.

    A quote where a field cannot hold one (``"1.5"x``: text after a closing quote) is refused
    here too, naming its line: polars refuses it without saying where.

    Raises
    ------
    LogError
        Naming the line the multi-line field starts on and the line it runs to, or the line
        of a misplaced quote.
    """
    ended = 0
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            reader = csv.reader(handle, strict=True)
            next(reader, [])
            ended = reader.line_num
            for record in reader:
                if reader.line_num > ended + 1:
                    _runs_on(path, ended, reader.line_num)
                ended = reader.line_num
                if record and len(record) != width and any(f.strip() for f in record):
                    return reader.line_num, len(record)
    except UnicodeDecodeError:
        return 0, 0  # polars then says what it cannot parse
    except csv.Error as err:
        if reader.line_num > ended + 1:
            _runs_on(path, ended, reader.line_num)
        raise LogError(
            f"{path}, line {reader.line_num}: a quote where a field cannot hold one ({err}); "
            'a field is quoted whole, e.g. "1.5"'
        ) from None
    return 0, 0


def _runs_on(path: Path, ended: int, line: int) -> None:
    """Refuse a quoted field that runs from the line after ``ended`` on to ``line``."""
    raise LogError(
        f"{path}, line {ended + 1}: a quoted field runs on to line {line}; a log's values "
        "fit on one line (an unclosed quote?)"
    )


def _check_truncated(path: Path) -> None:
    """Reject a file whose last line has no line ending.

    That is what a log cut off while being written looks like: with fewer fields than the
    header polars would read the missing cells as empty, and with all of them the last
    number may itself be cut short (``69.78`` read as ``6``), which nothing in the line
    shows.  Every CSV writer ends its last line; a file that does not cannot be vouched for.
    """
    with path.open("rb") as handle:
        handle.seek(0, 2)
        size = handle.tell()
        handle.seek(max(0, size - 65536))
        tail = handle.read()
    if not tail or tail.endswith((b"\n", b"\r")):
        return
    last = tail.rsplit(b"\n", 1)[-1].decode("utf-8", errors="replace")
    fields = next(csv.reader([last]), [])
    width = len(_read_csv_header(path))
    with path.open("rb") as handle:
        line = sum(chunk.count(b"\n") for chunk in iter(lambda: handle.read(1 << 20), b""))
    if line == 0:
        return  # the header alone: refused as a log without rows
    shown = f"{len(fields)} of {width} fields" if len(fields) < width else "all its fields"
    raise LogError(
        f"{path}, line {line + 1}: the last line ({shown}) has no line ending, so the file "
        "may have been cut off inside it; if that line is whole, end the file with a newline"
    )


def _as_labels(column: pl.Series, *, written: bool = False) -> pl.Series:
    """Mode ids as stripped text; integer-valued floats lose their ``.0``.

    A float column (Parquet) holds numbers: each whole one is written as an integer (``1.0``
    is mode ``1`` beside ``2.5``, as in a message log,
    :func:`hybridlog.io.message_paths.as_label`).  So does a column of cells as written
    (``written``: a CSV file, which has no types) whose every cell is a number: each cell
    written as a float (``1.0``, ``2e0``: pandas writes an integer column with a gap so)
    that is whole is read as an integer (but an id beyond 2^53 keeps its digits: a
    ``float64`` would merge it with others, :mod:`~hybridlog.io.exact`), every other cell
    as written.  Cell by cell: a column of ``1.0`` and ``1.5`` was read as written
    throughout when some cell was not whole, and refused naming the first ``1.0`` rather
    than the ``1.5``.  A text column of a typed table (Parquet ``String``) is text, as a
    ROS ``string`` or a JSON string is: ``"1.0"`` there is no mode ``1``.  A Boolean column
    is mode ``0`` or ``1``, as a ROS ``bool`` or a JSON boolean is (it read ``'true'``, no
    mode of a model whose modes are ``0`` and ``1``).
    """
    if column.dtype == pl.String and written:
        text = column.str.strip_chars()
        cells = text.filter(text != "").drop_nulls()
        if cells.len() and not cells.cast(pl.Float64, strict=False).is_null().any():
            floats = text.cast(pl.Float64, strict=False)
            whole = (
                text.str.contains("[.eE]")
                & floats.is_finite()
                & (floats == floats.round(0))
                & (floats.abs() < EXACT_LIMIT)
            )
            column = pl.select(
                pl.when(whole)
                .then(floats.cast(pl.Int64, strict=False).cast(pl.String))
                .otherwise(text)
            ).to_series()
    if column.dtype == pl.Boolean:  # as a ROS bool or a JSON boolean reads: mode 0 or 1
        column = column.cast(pl.Int8)
    dtype = column.dtype
    # NaN and infinities keep their text ('NaN', 'inf'), which names no mode and is refused
    # with its row: cast to an integer they became empty cells, no sample, and so did a
    # whole number beyond int64
    if dtype.is_float() and bool(column.is_finite().any()):
        whole = column.cast(pl.Int64, strict=False)
        exact = whole.is_not_null() & (whole.cast(pl.Float64) == column)
        column = pl.select(
            pl.when(exact).then(whole.cast(pl.String)).otherwise(column.cast(pl.String))
        ).to_series()
    text = column.cast(pl.String).str.strip_chars()
    return pl.select(pl.when(text != "").then(text)).to_series().alias(column.name)


def _label_codes(column: pl.Series, *, written: bool = False) -> tuple[IntArray, tuple[str, ...]]:
    """Mode-id codes of a label column: ``(codes, labels)``, code -1 where a cell is empty.

    ``labels`` are the distinct stripped labels (:func:`_as_labels`; ``written`` for a CSV
    file's cells) in order of first appearance; ``codes[i]`` indexes them.  Labels are
    worked out on the column's distinct values only, and each cell becomes a small integer
    code through an ``Enum`` of them: a 10^6-row column of a few mode ids costs a few MB, not
    the string copies of the whole column that stripping and mapping it cell by cell made
    (about 50 MB).
    """
    text = column if column.dtype == pl.String else _as_labels(column)
    distinct = text.unique(maintain_order=True).drop_nulls()
    first: dict[str, int] = {}
    lookup: list[int] = []
    for label in _as_labels(distinct, written=written).to_list():
        lookup.append(-1 if label is None else first.setdefault(label, len(first)))
    lookup.append(-1)  # empty cells (null)
    physical = text.cast(pl.Enum(distinct.to_list())).to_physical()
    index = physical.fill_null(distinct.len()).to_numpy()
    codes: IntArray = np.asarray(lookup, dtype=np.int64)[index]
    return codes, tuple(first)


# ---------------------------------------------------------------------- Parquet helpers


def _read_parquet(path: Path, **options: Any) -> pl.DataFrame:
    """``pl.read_parquet`` of a log, its name taken as it is (:func:`polars_file`)."""
    with _panics_refused(path, "Parquet"), polars_file(path, "rb") as source:
        return pl.read_parquet(source, glob=False, **options)


def _read_parquet_schema(path: Path) -> dict[str, pl.DataType]:
    try:
        with _panics_refused(path, "Parquet"), polars_file(path, "rb") as source:
            schema = pl.scan_parquet(source, glob=False).collect_schema()
    except (pl.exceptions.PolarsError, OSError) as err:
        raise LogError(f"{path}: not a readable Parquet file ({_first_line(err)})") from err
    if not schema:
        raise LogError(f"{path}: the Parquet file has no columns")
    return dict(schema)


# ---------------------------------------------------------------------- describe helpers


def _describe_column(
    column: pl.Series, time_ns: IntArray | None, resolution_ns: float
) -> dict[str, Any]:
    """:func:`_column_info` of a Parquet column: numbers (booleans as 0 and 1) or not."""
    values: FloatArray | None = None
    if _holds_numbers(column.dtype):
        values = column.drop_nulls().cast(pl.Float64).to_numpy().astype(np.float64)
    info: dict[str, Any] = {"count": column.len() - column.null_count(), "nonfinite": None}
    info.update(min=None, max=None)
    if values is not None:
        info["nonfinite"] = count_nonfinite(values)
        finite = values[np.isfinite(values)]
        if finite.size:
            info["min"] = float(finite.min())
            info["max"] = float(finite.max())
    present = column.is_not_null().to_numpy()
    dtype = _dtype_name(column.dtype)
    return _column_info(column.name, dtype, info, present, time_ns, resolution_ns)


def _column_info(
    name: str,
    dtype: str,
    values: dict[str, Any],
    present: np.ndarray[Any, np.dtype[np.bool_]],
    time_ns: IntArray | None,
    resolution_ns: float,
) -> dict[str, Any]:
    """Name, dtype, non-empty and non-finite counts, finite min/max and timing of a column.

    ``values`` holds ``count`` (every non-empty cell), ``nonfinite`` (those of them that are
    NaN or infinite; ``None`` for a column that is not numeric), ``min`` and ``max``;
    ``present`` which rows hold a cell.  The column's own sample times (the times of its
    non-empty cells) are described by :func:`~hybridlog.io.summary.describe_steps`, gaps
    included: an empty stretch in one column of a table whose time column has no gap is
    that column's gap, which ``analyze`` refuses in an output.  Without usable times
    (``time_ns`` ``None``) the timing is ``None``; ``resolution_ns`` is how far apart they
    could be told where they were read from.
    """
    info: dict[str, Any] = {"name": name, "dtype": dtype, **values}
    times = np.zeros(0, dtype=np.int64)
    if time_ns is not None and time_ns.size == present.size:
        times = time_ns[present]
    info.update(describe_steps(times, resolution_ns=resolution_ns))
    return info


def _not_a_time(path: str, name: str, dtype: pl.DataType) -> str:
    """Why a Parquet column of ``dtype`` (a Date, Time, Boolean) cannot be the time column."""
    return (
        f"{path}: column {excerpt(name)} has type {dtype}, expected seconds as numbers, a "
        "Datetime or Duration, or ISO 8601 dates and times as text"
    )


def _holds_text(dtype: pl.DataType) -> bool:
    """Whether a column of ``dtype`` holds text: strings, categories (pyarrow dictionaries)."""
    return dtype == pl.String or isinstance(dtype, pl.Categorical | pl.Enum)


def _holds_numbers(dtype: pl.DataType) -> bool:
    """Whether a Parquet column of ``dtype`` is read as numbers: booleans are 0 and 1.

    A valve's open/closed input is a boolean in Parquet as in a ROS message (``bool``) or a
    JSON one, where it reads as 0 and 1; only a time column must be numeric proper.
    """
    return dtype.is_numeric() or dtype == pl.Boolean


def _dtype_name(dtype: pl.DataType) -> str:
    text = str(dtype)
    return text.lower() if text.isalnum() else text
