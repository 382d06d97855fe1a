"""Per-sample tables of one run: the mode timeline and the state/output estimates.

Columns
-------
``timeline``
    ``t``, ``mode`` (estimated mode id), ``p_<mode>`` for each mode id (posterior
    probability or normalised score), and ``truth_mode`` (true mode id) when the log has a
    ground-truth mode.
``estimates``
    ``t``; for each state ``x``: ``<x>_hat`` (estimate) and ``<x>_var`` (diagonal of the
    error covariance); for each output ``y``: ``<y>_hat`` (one-step-ahead prediction) and
    ``<y>`` (the measured output, so metrics can be recomputed from this file alone); then
    ``<x>_true`` for each state the log has ground truth for (a column that is not all NaN).

Missing values (no prediction in row 0, no variance, a gap in the truth) are written as
nulls: an empty cell in CSV, a null in Parquet.  Floats are written with full round-trip
precision.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
import polars as pl

from hybridlog.errors import OptionError
from hybridlog.estimators.result import EstimationResult
from hybridlog.signals import AlignedSignals, FloatArray, IntArray

__all__ = [
    "PARQUET_ZSTD_LEVEL",
    "TABLE_FORMATS",
    "TableFormat",
    "check_table_format",
    "estimates_frame",
    "timeline_frame",
    "write_table",
]

TableFormat = Literal["csv", "parquet"]
TABLE_FORMATS: tuple[TableFormat, ...] = ("csv", "parquet")

PARQUET_ZSTD_LEVEL = 1
"""zstd level of the Parquet tables.  Estimates are mostly noise-like float64 that zstd
hardly shrinks at any level: on a 10^6-row three-tank run polars' default level wrote the
same 108 MiB three times slower than level 1 (1.5 s against 0.46 s)."""


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


def _float_column(name: str, values: FloatArray) -> pl.Series:
    # NaN becomes null so CSV gets an empty cell rather than the text "NaN".
    return pl.Series(name, np.asarray(values, dtype=np.float64), dtype=pl.Float64, nan_to_null=True)


def _labels(name: str, ids: tuple[str, ...], index: IntArray) -> pl.Series:
    # Gathered by polars from the mode ids: no Python string per row.
    return pl.Series(name, ids, dtype=pl.String).gather(index)


def timeline_frame(result: EstimationResult, signals: AlignedSignals) -> pl.DataFrame:
    """Build the mode timeline table (columns in the module docstring).

    Parameters
    ----------
    result:
        The estimation result.
    signals:
        The aligned signals (for the ground-truth mode).

    Returns
    -------
    polars.DataFrame
        One row per sample.

    """
    ids = tuple(str(m) for m in result.mode_ids)
    columns: list[pl.Series] = [
        _float_column("t", result.time),
        _labels("mode", ids, result.modes),
    ]
    for j, m in enumerate(ids):
        columns.append(_float_column(f"p_{m}", result.mode_probabilities[:, j]))
    if signals.truth_modes is not None:
        columns.append(_labels("truth_mode", ids, signals.truth_modes))
    return pl.DataFrame(columns)


def estimates_frame(result: EstimationResult, signals: AlignedSignals) -> pl.DataFrame:
    """Build the state and output estimates table (columns in the module docstring).

    Parameters
    ----------
    result:
        The estimation result.
    signals:
        The aligned signals (measured outputs, ground-truth states).

    Returns
    -------
    polars.DataFrame
        One row per sample.

    """
    columns: list[pl.Series] = [_float_column("t", result.time)]
    for i, x in enumerate(result.state_names):
        columns.append(_float_column(f"{x}_hat", result.state_means[:, i]))
        columns.append(_float_column(f"{x}_var", result.state_variances[:, i]))
    for j, y in enumerate(result.output_names):
        columns.append(_float_column(f"{y}_hat", result.output_predictions[:, j]))
        columns.append(_float_column(y, signals.outputs[:, j]))
    if signals.truth_states is not None:
        for i, x in enumerate(result.state_names):
            col = signals.truth_states[:, i]
            if np.isfinite(col).any():
                columns.append(_float_column(f"{x}_true", col))
    return pl.DataFrame(columns)


def write_table(frame: pl.DataFrame, stem: Path, table_format: TableFormat) -> Path:
    """Write a table as ``<stem>.csv`` or ``<stem>.parquet``.

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
    if table_format == "csv":
        frame.write_csv(path, null_value="")
    else:
        frame.write_parquet(path, compression="zstd", compression_level=PARQUET_ZSTD_LEVEL)
    return path
