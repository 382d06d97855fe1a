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

:class:`TableSource` is here: the file's header, its fields and their keys, and
:meth:`~TableSource.read`, which puts together what it reads with, in modules of their own:
the facts every part shares (:mod:`.table_file`), the header (:mod:`.csv_header`), the
checks of a CSV file's lines (:mod:`.csv_lines`), its blocks read by polars
(:mod:`.csv_frames`) and its cells as numbers (:mod:`.csv_numbers`), a Parquet file
(:mod:`.parquet_files`) and its columns and their nested fields (:mod:`.parquet_columns`),
the time column's names and ISO 8601 text (:mod:`.table_times`), the time column read as
nanoseconds (:mod:`.time_column`), ``--sort``'s rows in time order (:mod:`.time_order`),
numbers as ``float64`` and those it does not hold (:mod:`.table_numbers`), label columns
(:mod:`.table_labels`), what a column's type holds (:mod:`.column_types`), ``inspect``'s
description of the table (:mod:`.table_description`) and entry of a column
(:mod:`.column_summary`) and polars' panics (:mod:`.polars_errors`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import numpy as np

from hybridlog.errors import LogError, OptionError, excerpt
from hybridlog.io.column_types import holds_numbers
from hybridlog.io.csv_frames import first_cell, read_csv_frame
from hybridlog.io.csv_header import header_names
from hybridlog.io.formats import LogFormat, get_format
from hybridlog.io.message_paths import PathError
from hybridlog.io.options import ReadOptions
from hybridlog.io.parquet_columns import parquet_column, read_parquet_frame
from hybridlog.io.parquet_files import read_parquet, read_parquet_schema
from hybridlog.io.source import (
    FieldKey,
    LabelSeries,
    Reading,
    Series,
    SourceInfo,
    closest_names,
)
from hybridlog.io.table_description import describe_csv, describe_parquet
from hybridlog.io.table_file import TableFile
from hybridlog.io.table_labels import label_codes
from hybridlog.io.table_numbers import ColumnBlock, refuse_inexact, refuse_overflow, to_float
from hybridlog.io.table_paths import ARRAY, STRUCT, ColumnPath, field_names
from hybridlog.io.table_paths import resolve as resolve_path
from hybridlog.io.table_times import TIME_COLUMNS, iso_format, not_a_time
from hybridlog.io.time_column import kept_rows, time_ns
from hybridlog.io.time_order import count_repeats, last_at_each_time, sorted_rows, superseded_notes
from hybridlog.polars_import import pl
from hybridlog.signals import IntArray

_TABLES = (get_format("csv"), get_format("parquet"))


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
        file = Path(path)
        if log_format is None:
            suffix = file.suffix.lower()
            log_format = next((f for f in _TABLES if suffix in f.suffixes), None)
        if log_format is None or log_format not in _TABLES:
            raise LogError(f"{path}: not a table log (expected a .csv or .parquet file)")
        if not file.is_file():
            raise LogError(f"{path}: no such file")
        self._schema: dict[str, pl.DataType] = {}
        if log_format.name == "csv":
            names = header_names(file)
            columns = tuple(names)
            stripped = [name for name, as_written in names.items() if name != as_written]
            if stripped:  # ``t, u, y``: the names are read as ``u``, not `` u``
                self._notes["csv_names_stripped"] = stripped
        else:
            self._schema = read_parquet_schema(file)
            columns = tuple(self._schema)
        time_column = next((c for c in TIME_COLUMNS if c in columns), None)
        others = [c for c in TIME_COLUMNS if c in columns and c != time_column]
        if others:  # ``t`` is the time; a ``time`` beside it is a column like any other
            self._notes["time_columns_passed_over"] = [time_column, *others]
        self._table = TableFile(file, log_format.name, columns, time_column)
        """File, format, columns and time column: what the functions it reads with share."""
        # Parquet: the fields inside struct, list and array columns (``pose.x``, ``q[1]``)
        self._paths: dict[str, ColumnPath] = {}
        # Parquet: the one length of each list indexed from its end (``field_key``), or None
        self._list_lengths: dict[tuple[str, tuple[str | int, ...]], int | None] = {}
        # Row (0-based, data rows only) of every sample returned by ``read``, per column.
        self._rows: dict[str, IntArray] = {}

    @property
    def info(self) -> SourceInfo:
        """Path and format (``csv`` or ``parquet``); fields are column names."""
        return SourceInfo(self.path, self._table.format, message_paths=False)

    @property
    def path(self) -> str:
        """The file's path as given."""
        return self._table.path

    @property
    def columns(self) -> tuple[str, ...]:
        """Every column of the table, time included, in file order."""
        return self._table.columns

    @property
    def time_column(self) -> str | None:
        """Name of the time column, or ``None`` when the table has none."""
        return self._table.time_column

    def fields(self) -> tuple[str, ...]:
        """Columns a symbol can be mapped to: all but the time column.

        Inside a Parquet struct, list or array column, its fields as
        :mod:`~hybridlog.io.table_paths` names them: ``pose.x``, ``q[]`` (``[]`` takes an
        index).
        """
        return tuple(
            name
            for c in self._table.columns
            if c != self._table.time_column
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
            if self._table.format == "csv":
                if name not in self._table.columns:
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
            frame = read_parquet(self._table.file, columns=[path.column], low_memory=True)
            lengths = frame.select(path.expr(depth).list.len()).to_series().drop_nulls().unique()
            self._list_lengths[key] = int(lengths[0]) if lengths.len() == 1 else None
        return self._list_lengths[key]

    def explain_missing(self, name: str, numeric: bool = False) -> str | None:
        """``None`` for a field of the table, else why not: the time column, or the closest.

        With ``numeric``, a Parquet column whose type holds no numbers (text, a date) is
        explained as such; whether a CSV column holds numbers is known when it is read.
        """
        if name == self._table.time_column:
            return (
                f"{excerpt(name)} is the table's time column ("
                f"{' or, without it, '.join(map(repr, TIME_COLUMNS))}, in seconds), "
                f"not a signal; other columns: {', '.join(map(excerpt, self.fields())) or 'none'}"
            )
        try:
            dtype = self._path(name).dtype
        except PathError as err:
            return str(err)
        if numeric and self._table.format == "parquet" and not holds_numbers(dtype):
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
        return f"{self._table.row_label(row)}, column {excerpt(name)}"

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
        table = self._table
        time_column = self._require_time()
        for name in (time_column, *numeric, *labels):
            try:
                self._path(name)
            except PathError as err:
                if name == time_column:  # a struct or list column: as inspect says it
                    raise LogError(not_a_time(self.path, name, self._schema[name])) from None
                raise LogError(f"{self.path}: {err}") from None
        wanted = list(dict.fromkeys([time_column, *numeric, *labels]))
        as_float = {time_column, *numeric} - set(labels)
        # Parquet numeric columns are decoded one at a time once the rows are known (below):
        # polars' memory then peaks at about one column, not all of them.
        later: list[str] = []
        if table.format == "csv":
            if iso_format(first_cell(table.file, table.columns.index(time_column))):
                as_float.discard(time_column)  # dates and times: parsed by time_column.time_ns
            frame = read_csv_frame(table.file, wanted, as_float, time_column)
        else:
            later = [n for n in dict.fromkeys(numeric) if n not in labels and n != time_column]
            paths = {name: self._path(name) for name in wanted}
            frame = read_parquet_frame(table, paths, set(numeric), set(labels), skip=later)
        if frame.height == 0:
            raise LogError(f"{self.path}: no data rows")
        height = frame.height
        rows = kept_rows(table, frame, time_column)
        if rows.size < frame.height:
            frame = frame[pl.Series(rows)]
        sort = self.options.sort
        times, _ = time_ns(table, frame.get_column(time_column), rows, check=not sort)
        self._rows[time_column] = rows
        repeats = False
        superseded: dict[str, IntArray] = {}  # per column, the rows of its samples not kept
        if sort:
            frame, rows, times, out_of_order = sorted_rows(frame, rows, times)
            if out_of_order:
                self._notes["sorted"] = {"rows_out_of_order": out_of_order}
            self._rows[time_column] = rows
            repeated = count_repeats(times)
            if repeated:
                self._notes["rows_combined"] = repeated
            repeats = repeated > 0

        label_series: dict[str, LabelSeries] = {}
        for name in labels:
            codes, categories = label_codes(frame.get_column(name), written=table.format == "csv")
            label_time, label_rows = times, rows
            present = codes >= 0
            if not present.all():
                codes, label_time, label_rows = codes[present], times[present], rows[present]
            last = last_at_each_time(label_time, repeats)
            if last is not None:
                superseded[name] = label_rows[~last]
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
        block = ColumnBlock(len(numeric), rows.size)
        for name in numeric:
            if name in later:
                at = rows if rows.size < height or sort else None
                taken = parquet_column(table, self._path(name), at)
            else:
                taken = frame.get_column(name)
            column = to_float(table, taken, rows)
            # copied into the block from polars' chunks (a CSV log's blocks of lines), one
            # copy, and the 2^53 check looks at the copy: converted to NumPy twice, the
            # chunks were first put end to end in an array of their own, each time
            whole = column.null_count() == 0 and not repeats
            held = block.take(column) if whole else None
            refuse_inexact(table, taken, column, rows, held)
            del taken
            if (
                table.format == "csv"
                and not self.options.drop_nonfinite
                and column.is_infinite().any()
            ):
                refuse_overflow(table, column, rows)
            if held is not None:
                numeric_series[name] = Series(name, times, held)
                self._rows[name] = rows
                continue
            present = column.is_not_null().to_numpy()
            values = column.filter(pl.Series(present)).to_numpy().astype(np.float64)
            column_time, column_rows = times[present], rows[present]
            usable_last = values if self.options.drop_nonfinite else None
            last = last_at_each_time(column_time, repeats, usable_last)
            if last is not None:
                superseded[name] = column_rows[~last]
                values, column_time = values[last], column_time[last]
                column_rows = column_rows[last]
            numeric_series[name] = Series(name, column_time, values)
            self._rows[name] = column_rows
        if superseded:
            kept = [self._rows[n] for n in dict.fromkeys(wanted[1:])]
            self._notes.update(superseded_notes(superseded, kept))
        return Reading(numeric_series, label_series, dict(self._notes), self._locate)

    def _require_time(self) -> str:
        if self._table.time_column is None:
            raise LogError(
                f"{self.path}: no time column (expected 't' or 'time' in seconds); "
                f"{closest_names(list(TIME_COLUMNS), self._table.columns)}; rename the time column "
                "to 't' (no option names another)"
            )
        return self._table.time_column

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
        if self._table.format == "csv":
            return describe_csv(self._table)
        return describe_parquet(self._table)
