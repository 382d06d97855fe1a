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

:class:`TableSource` is here; what it reads with is in modules of their own: the header
(:mod:`.csv_header`), the checks of a CSV file's lines (:mod:`.csv_lines`), its blocks read by
polars (:mod:`.csv_frames`) and its cells as numbers (:mod:`.csv_numbers`), a Parquet file
(:mod:`.parquet_files`), the time column's names and ISO 8601 text (:mod:`.table_times`),
label columns (:mod:`.table_labels`), what a column's type holds (:mod:`.column_types`),
``inspect``'s entry of a column (:mod:`.column_summary`) and polars' panics
(:mod:`.polars_errors`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import numpy as np

from hybridlog.errors import LogError, OptionError, excerpt
from hybridlog.io.column_summary import column_info, describe_column
from hybridlog.io.column_types import NARROW_INTEGERS, dtype_name, holds_numbers, holds_text
from hybridlog.io.csv_frames import (
    blank_csv_rows,
    blank_rows,
    csv_text_frames,
    empty_cells,
    first_cell,
    read_csv_frame,
    read_csv_strings,
)
from hybridlog.io.csv_header import header_names
from hybridlog.io.csv_lines import check_record_widths, check_truncated
from hybridlog.io.csv_numbers import parse_floats, texts_among_numbers
from hybridlog.io.csv_tally import ColumnTally, tally_block
from hybridlog.io.exact import (
    WHOLE_NUMBER,
    any_beyond_exact,
    beyond_exact,
    inexact,
)
from hybridlog.io.formats import LogFormat, get_format
from hybridlog.io.message_paths import PathError
from hybridlog.io.options import ReadOptions
from hybridlog.io.parquet_files import read_parquet, read_parquet_schema
from hybridlog.io.polars_errors import first_line, panics_refused
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
    describe_steps,
    round_span,
    seconds_resolution_ns,
)
from hybridlog.io.table_labels import label_codes
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
from hybridlog.io.table_times import TIME_COLUMNS, iso_format, not_a_time
from hybridlog.io.time_grid import clock_tolerance_ns
from hybridlog.polars_import import pl, polars_file
from hybridlog.signals import FloatArray, IntArray
from hybridlog.times import format_time

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
            names = header_names(self._file)
            self._columns = tuple(names)
            stripped = [name for name, as_written in names.items() if name != as_written]
            if stripped:  # ``t, u, y``: the names are read as ``u``, not `` u``
                self._notes["csv_names_stripped"] = stripped
        else:
            self._schema = read_parquet_schema(self._file)
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
            frame = read_parquet(self._file, columns=[path.column], low_memory=True)
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
        if numeric and self._format == "parquet" and not holds_numbers(dtype):
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
            if iso_format(first_cell(self._file, self._columns.index(time_column))):
                as_float.discard(time_column)  # dates and times: parsed by _time_ns
            frame = read_csv_frame(self._file, wanted, as_float, time_column)
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
            codes, categories = label_codes(frame.get_column(name), written=self._format == "csv")
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
            text = read_csv_strings(self._file, [name], checked=True).get_column(name)
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
            or (taken.dtype.is_integer() and taken.dtype not in NARROW_INTEGERS)
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
            if holds_text(taken.dtype):  # the cells as written (inspect)
                written = taken.gather(found)
            else:
                text = read_csv_strings(self._file, [column.name], checked=True)
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
        if holds_numbers(column.dtype):
            return column.cast(pl.Float64)
        return parse_floats(self._file, column, rows)

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
                isinstance(dtype, pl.Datetime | pl.Duration) or holds_text(dtype)
            ):
                continue  # text: ISO 8601 dates and times, as in a CSV file (_time_ns)
            if name == time_column and not dtype.is_numeric():
                raise LogError(not_a_time(self.path, name, dtype))
            if name in numeric and not holds_numbers(dtype):
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
            frame = read_parquet(
                self._file,
                columns=list(dict.fromkeys(p.column for p in paths)),
                low_memory=True,
            )
        except pl.exceptions.PolarsError as err:
            raise LogError(f"{self.path}: not a readable Parquet file ({first_line(err)})") from err
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
            frame = read_parquet(self._file, columns=[path.column], low_memory=True)
        except pl.exceptions.PolarsError as err:
            raise LogError(f"{self.path}: not a readable Parquet file ({first_line(err)})") from err
        column = self._leaf_values(frame, path)
        del frame
        return column if rows is None else column.gather(rows)

    def _kept_rows(self, frame: pl.DataFrame, time_column: str) -> IntArray:
        """Rows to use: all of them, minus blank CSV lines; a row without a time is an error."""
        rows: IntArray = np.arange(frame.height, dtype=np.int64)
        missing = empty_cells(frame.get_column(time_column))
        if not missing.any():
            return rows
        blank = blank_csv_rows(self._file) if self._format == "csv" else np.zeros_like(missing)
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
        if holds_text(column.dtype):
            column = column.cast(pl.String)
            written = column.drop_nulls()
            iso = iso_format(written[0] if written.len() else None)
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
                raise LogError(not_a_time(self.path, name, stored))
            column = self._to_float(column, rows)
            seconds: FloatArray = np.asarray(column.to_numpy(), dtype=np.float64)  # no copy
            bad = check_seconds_range(seconds)
            if bad >= 0:
                as_written = None
                if self._format == "csv" and not np.isfinite(seconds[bad]):
                    # the cell as written: a CSV '1e400' parsed as inf, which it does not say
                    cells = read_csv_strings(self._file, [name], checked=True).get_column(name)
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
                f"time column is {dtype_name(stored)}, whose values near t="
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
            if iso_format(str(text[row])) == iso:  # written alike: a day that does not exist
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
        check_truncated(self._file)
        check_record_widths(self._file, self._columns)
        for frame in csv_text_frames(self._file, list(self._columns), checked=True):
            first = tallies[0].rows
            numbers = tally_block(tallies, frame, keep=self._time_column)
            if numbers is not None and self._time_column is not None:
                cells = frame.get_column(self._time_column)
                seconds.append(numbers)
                empty = empty_cells(cells)
                if empty.any():
                    missing.append(np.flatnonzero(empty) + first)
                    odd = empty & ~blank_rows(frame)
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
            if time.dtype == "float64":  # as parse_floats reads them
                return pl.concat(seconds).alias(time.name).gather(rows)
            text = read_csv_strings(self._file, [time.name], checked=True)
            return text.get_column(time.name).gather(rows)  # dates and times, or an error

        problems: list[str] = []
        rows, time_ns = self._timed_rows(height, kept_rows, time_cells, problems)
        seconds.clear()
        resolution = self._time_resolution_ns
        columns: list[dict[str, Any]] = []
        for tally in tallies:
            present = tally.present()[rows] if rows.size < height else tally.present()
            columns.append(
                column_info(tally.name, tally.dtype, tally.values(), present, time_ns, resolution)
            )
            if columns[-1]["nonfinite"] is not None and tally.name != self._time_column:
                found = self._unheld_value(*tally.suspects()) if tally.suspicious else None
                problems.extend([found] if found is not None else [])
            elif tally.name != self._time_column:  # the time's own problem is said above
                problems.extend(texts_among_numbers(tally))
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
                columns.append(describe_column(column, time_ns, resolution))
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
        if holds_text(taken.dtype):
            column = taken.str.strip_chars().cast(pl.Float64, strict=False)
        elif holds_numbers(taken.dtype):
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
            return read_parquet(self._file, columns=columns, low_memory=True)
        except pl.exceptions.PolarsError as err:
            raise LogError(f"{self.path}: not a readable Parquet file ({first_line(err)})") from err

    def _parquet_rows(self) -> int:
        """How many rows a Parquet log has (from its metadata)."""
        try:
            with panics_refused(self._file, "Parquet"), polars_file(self._file, "rb") as source:
                rows = pl.scan_parquet(source, glob=False).select(pl.len()).collect().item()
        except pl.exceptions.PolarsError as err:
            raise LogError(f"{self.path}: not a readable Parquet file ({first_line(err)})") from err
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
