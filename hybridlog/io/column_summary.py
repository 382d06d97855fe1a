"""``inspect``'s entry of one table column: type, counts, range and its own sample times."""

from __future__ import annotations

from typing import Any

import numpy as np

from hybridlog.io.column_types import dtype_name, holds_numbers
from hybridlog.io.source import usable_values
from hybridlog.io.summary import count_nonfinite, describe_steps
from hybridlog.polars_import import pl
from hybridlog.signals import FloatArray, IntArray


def describe_column(
    column: pl.Series, time_ns: IntArray | None, resolution_ns: float
) -> dict[str, Any]:
    """:func:`column_info` of a Parquet column: numbers (booleans as 0 and 1) or not."""
    values: FloatArray | None = None
    if holds_numbers(column.dtype):
        values = column.drop_nulls().cast(pl.Float64).to_numpy().astype(np.float64)
    info: dict[str, Any] = {"count": column.len() - column.null_count(), "nonfinite": None}
    info.update(min=None, max=None)
    if values is not None:
        info["nonfinite"] = count_nonfinite(values)
        usable = values[usable_values(values)]
        if usable.size:
            info["min"] = float(usable.min())
            info["max"] = float(usable.max())
    present = column.is_not_null().to_numpy()
    dtype = dtype_name(column.dtype)
    return column_info(column.name, dtype, info, present, time_ns, resolution_ns)


def column_info(
    name: str,
    dtype: str,
    values: dict[str, Any],
    present: np.ndarray[Any, np.dtype[np.bool_]],
    time_ns: IntArray | None,
    resolution_ns: float,
) -> dict[str, Any]:
    """Name, dtype, non-empty and non-finite counts, finite min/max and timing of a column.

    ``values`` holds ``count`` (every non-empty cell), ``nonfinite`` (those of them that are
    NaN, infinite or out of range, :func:`~hybridlog.io.source.usable_values`; ``None`` for a
    column that is not numeric), ``min`` and ``max`` of the others;
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
