"""Per-sample tables of one run: the mode timeline and the state/output estimates.

Columns
-------
``timeline``
    ``t``, ``mode`` (estimated mode id), ``p_<mode>`` for each mode id (posterior
    probability or normalised score), then, for a smoothed run (``--smooth``,
    ``--mode-sequence viterbi``), ``mode_filtered`` and ``p_<mode>_filtered`` (the causal
    filter's own), ``truth_mode`` (true mode id) when the log has a ground-truth mode, then the
    estimator's own columns (``EstimationResult.timeline_columns``).
``estimates``
    ``t``; for each state ``x``: ``<x>_hat`` (estimate) and ``<x>_var`` (diagonal of the
    error covariance), then for a smoothed run ``<x>_hat_filtered`` and ``<x>_var_filtered``
    (the causal filter's own); for each output ``y``: ``<y>_hat`` (one-step-ahead prediction) and
    ``<y>`` (the measured output, so metrics can be recomputed from this file alone); then
    ``<x>_true`` for each state the log has ground truth for (a column that is not all NaN).

In a smoothed run ``mode``, ``p_<mode>``, ``<x>_hat`` and ``<x>_var`` hold the smoothed (or
Viterbi) values; ``<y>_hat`` is the filter's one-step-ahead prediction either way.

Missing values (no prediction in row 0, no variance, a gap in the truth) are written as
nulls: an empty cell in CSV, a null in Parquet.  Floats are written with full round-trip
precision.

A table is a :class:`Table`: its columns as views of the result's arrays, turned into polars
batches of :data:`BATCH_ROWS` rows only while :func:`write_table` streams them to the file.
A 10^6-row estimates table (16 columns, most of them strided columns of ``(N, n)`` arrays
that polars would have to copy) is written without a second copy of the whole table in
memory: the whole-frame write held 128 MB more at its peak.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import polars as pl
from polars.io.plugins import register_io_source

from hybridlog.errors import OptionError
from hybridlog.estimators.result import EstimationResult
from hybridlog.signals import AlignedSignals, FloatArray, IntArray

__all__ = [
    "BATCH_ROWS",
    "PARQUET_COMPRESSION",
    "TABLE_FORMATS",
    "Table",
    "TableFormat",
    "check_table_format",
    "estimates_frame",
    "estimates_table",
    "timeline_frame",
    "timeline_table",
    "write_table",
]

TableFormat = Literal["csv", "parquet"]
TABLE_FORMATS: tuple[TableFormat, ...] = ("csv", "parquet")

PARQUET_COMPRESSION: Literal["snappy"] = "snappy"
"""Codec of the Parquet tables (every Parquet reader has it; pyarrow's and Spark's default).
Estimates are mostly noise-like float64 that no codec shrinks much.  Both tables of a 10^6-row
three-tank run, in one process: snappy 145 MiB in 0.27-0.35 s (0.39-0.49 s of CPU, four
rounds), lz4 146 MiB in 0.28-0.32 s, uncompressed 153 MiB in 0.31-0.34 s, zstd level 1 131 MiB
in 0.39-0.41 s (0.61-0.65 s of CPU; polars' default zstd level took three times as long as
level 1).  ``analyze`` writes them while the plots are drawn on the other core, so the CPU
counts: 0.2 s less of it, for 11 % larger files."""


def check_table_format(table_format: str) -> TableFormat:
    """Validate a ``--table-format`` value.

    Parameters
    ----------
    table_format:
        ``"csv"`` or ``"parquet"``.

    Returns
    -------
    str
        The same value, typed.

    Raises
    ------
    OptionError
        For any other value.

    """
    for fmt in TABLE_FORMATS:
        if table_format == fmt:
            return fmt
    raise OptionError(f"--table-format {table_format!r} is not one of {', '.join(TABLE_FORMATS)}")


BATCH_ROWS = 1 << 14
"""Rows per batch when a :class:`Table` is streamed to its file, and per Parquet row group.

What polars buffers while writing grows with both (a row group is encoded once it is
complete): on a 10^6-row three-tank run, batches and row groups of 16,384 rows left the
process 25-35 MiB smaller after writing both tables than polars' default row groups
(about 120,000 rows) did, in the same time; polars reads the file back faster, not slower.
"""

Column = Callable[[int, int], pl.Series]
"""Rows ``lo:hi`` of one column as a polars series."""


@dataclass(frozen=True)
class Table:
    """Named columns of equal length, built into polars series one batch of rows at a time.

    Attributes
    ----------
    height:
        Number of rows.
    schema:
        Column name → polars dtype, in column order.
    columns:
        Column name → function of ``(lo, hi)`` returning those rows of the column.
    """

    height: int
    schema: pl.Schema
    columns: dict[str, Column]

    def batch(self, lo: int, hi: int, names: list[str] | None = None) -> pl.DataFrame:
        """Rows ``lo:hi`` of the named columns (all by default) as a data frame."""
        wanted = list(self.schema) if names is None else names
        return pl.DataFrame([self.columns[name](lo, hi) for name in wanted])

    def frame(self) -> pl.DataFrame:
        """The whole table as one data frame (a copy of every column)."""
        return self.batch(0, self.height)

    def lazy(self) -> pl.LazyFrame:
        """The table as a lazy frame whose rows are produced in batches when collected."""

        def batches(
            with_columns: list[str] | None,
            predicate: pl.Expr | None,
            n_rows: int | None,
            batch_size: int | None,
        ) -> Iterator[pl.DataFrame]:
            end = self.height if n_rows is None else min(self.height, n_rows)
            for lo in range(0, end, BATCH_ROWS):
                frame = self.batch(lo, min(lo + BATCH_ROWS, end), with_columns)
                yield frame.filter(predicate) if predicate is not None else frame

        return register_io_source(batches, schema=self.schema)


class _TableBuilder:
    """Collects the columns of a :class:`Table`, each a view of an array of the result."""

    def __init__(self, height: int) -> None:
        self.height = height
        self.schema: dict[str, pl.DataType] = {}
        self.columns: dict[str, Column] = {}

    def floats(self, name: str, values: FloatArray) -> None:
        # NaN becomes null so CSV gets an empty cell rather than the text "NaN".
        array = np.asarray(values, dtype=np.float64)

        def rows(lo: int, hi: int) -> pl.Series:
            return pl.Series(name, array[lo:hi], dtype=pl.Float64, nan_to_null=True)

        self.schema[name] = pl.Float64()
        self.columns[name] = rows

    def labels(self, name: str, ids: tuple[str, ...], index: IntArray) -> None:
        # Gathered by polars from the mode ids: no Python string per row.
        categories = pl.Series(name, ids, dtype=pl.String)

        def rows(lo: int, hi: int) -> pl.Series:
            return categories.gather(index[lo:hi])

        self.schema[name] = pl.String()
        self.columns[name] = rows

    def table(self) -> Table:
        return Table(self.height, pl.Schema(self.schema), self.columns)


def timeline_table(result: EstimationResult, signals: AlignedSignals) -> Table:
    """The mode timeline table (columns in the module docstring), streamed when written.

    Parameters
    ----------
    result:
        The estimation result.
    signals:
        The aligned signals (for the ground-truth mode).

    Returns
    -------
    Table
        One row per sample.

    """
    ids = tuple(str(m) for m in result.mode_ids)
    table = _TableBuilder(result.time.shape[0])
    table.floats("t", result.time)
    table.labels("mode", ids, result.modes)
    for j, m in enumerate(ids):
        table.floats(f"p_{m}", result.mode_probabilities[:, j])
    if result.post_processing is not None:
        filtered = result.post_processing.filtered
        table.labels("mode_filtered", ids, filtered.modes)
        for j, m in enumerate(ids):
            table.floats(f"p_{m}_filtered", filtered.mode_probabilities[:, j])
    if signals.truth_modes is not None:
        table.labels("truth_mode", ids, signals.truth_modes)
    for column in result.timeline_columns:
        if column.labels:
            table.labels(column.name, column.labels, column.values.astype(np.int64, copy=False))
        else:
            table.floats(column.name, column.values.astype(np.float64, copy=False))
    return table.table()


def estimates_table(result: EstimationResult, signals: AlignedSignals) -> Table:
    """The state and output estimates table (columns in the module docstring), streamed.

    Parameters
    ----------
    result:
        The estimation result.
    signals:
        The aligned signals (measured outputs, ground-truth states).

    Returns
    -------
    Table
        One row per sample.

    """
    table = _TableBuilder(result.time.shape[0])
    table.floats("t", result.time)
    filtered = None if result.post_processing is None else result.post_processing.filtered
    for i, x in enumerate(result.state_names):
        table.floats(f"{x}_hat", result.state_means[:, i])
        table.floats(f"{x}_var", result.state_variances[:, i])
        if filtered is not None:
            table.floats(f"{x}_hat_filtered", filtered.state_means[:, i])
            table.floats(f"{x}_var_filtered", filtered.state_variances[:, i])
    for j, y in enumerate(result.output_names):
        table.floats(f"{y}_hat", result.output_predictions[:, j])
        table.floats(y, signals.outputs[:, j])
    if signals.truth_states is not None:
        for i, x in enumerate(result.state_names):
            col = signals.truth_states[:, i]
            if np.isfinite(col).any():
                table.floats(f"{x}_true", col)
    return table.table()


def timeline_frame(result: EstimationResult, signals: AlignedSignals) -> pl.DataFrame:
    """The mode timeline table as one data frame (:func:`timeline_table`, collected)."""
    return timeline_table(result, signals).frame()


def estimates_frame(result: EstimationResult, signals: AlignedSignals) -> pl.DataFrame:
    """The estimates table as one data frame (:func:`estimates_table`, collected)."""
    return estimates_table(result, signals).frame()


def write_table(frame: pl.DataFrame | Table, stem: Path, table_format: TableFormat) -> Path:
    """Write a table as ``<stem>.csv`` or ``<stem>.parquet``.

    A :class:`Table` is streamed in batches of :data:`BATCH_ROWS` rows (polars' streaming
    sink); the file holds the same data as that of its whole :meth:`~Table.frame`, in
    Parquet row groups of one batch each.  A table of one batch is written whole, without the
    sink's start-up: both tables of a 300-row log in 2.1-2.6 ms against 2.7-2.8 ms (CSV, 200
    logs, three rounds each in one process), 2-4 % of the log's time in ``batch``.

    Parameters
    ----------
    frame:
        The table.
    stem:
        Path without suffix, e.g. ``out/timeline``.
    table_format:
        ``"csv"`` or ``"parquet"``.

    Returns
    -------
    pathlib.Path
        The file written.

    """
    path = stem.with_name(f"{stem.name}.{table_format}")
    if isinstance(frame, Table) and frame.height <= BATCH_ROWS:
        frame = frame.frame()  # one batch: the eager writer, without the sink's start-up
    if isinstance(frame, Table):
        lazy = frame.lazy()
        if table_format == "csv":
            lazy.sink_csv(path, null_value="")
        else:
            lazy.sink_parquet(
                path,
                compression=PARQUET_COMPRESSION,
                row_group_size=BATCH_ROWS,
            )
    elif table_format == "csv":
        frame.write_csv(path, null_value="")
    else:
        frame.write_parquet(path, compression=PARQUET_COMPRESSION)
    return path
