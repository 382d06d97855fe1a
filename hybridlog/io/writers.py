"""Writing tables (``hybridlog simulate`` logs, report tables) as CSV or Parquet."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from hybridlog.errors import OptionError, OutputError
from hybridlog.outputs import atomic_files
from hybridlog.polars_import import pl, polars_file

TABLE_FORMATS = (".csv", ".parquet")

#: What a column may be: a 1-D numeric array or a sequence of strings (e.g. mode ids).
Column = np.ndarray[Any, Any] | Sequence[str]


def write_table(
    path: str | os.PathLike[str],
    columns: Mapping[str, Column],
    *,
    force: bool = False,
) -> Path:
    """Write named columns to a ``.csv`` or ``.parquet`` file, atomically.

    The table is written to a temporary file in the same directory and renamed into place
    (:func:`hybridlog.outputs.atomic_files`), so a failure leaves either the old file or
    nothing -- never half a table.  Floats are written in the shortest form that reads back
    to the same double.

    Parameters
    ----------
    path:
        Output file; the suffix chooses the format.  Missing parent directories are created.
    columns:
        ``{name: values}`` in column order: 1-D numeric arrays or sequences of strings
        (e.g. mode ids), all of the same length.
    force:
        Replace an existing file.

    Returns
    -------
    pathlib.Path
        The written file.

    Raises
    ------
    OptionError
        For an unsupported suffix.
    OutputError
        When the file exists and ``force`` is false, or it cannot be written.
    ValueError
        For columns of different lengths or arrays that are not 1-D.
    """
    target = Path(path)
    suffix = target.suffix.lower()
    if suffix not in TABLE_FORMATS:
        raise OptionError(
            f"{path}: unsupported table format {target.suffix or '(none)'!r}; "
            f"supported: {', '.join(TABLE_FORMATS)}"
        )
    frame = _frame(columns)
    with atomic_files([target], force=force) as (temporary,):
        try:
            with polars_file(temporary, "wb") as file:
                if suffix == ".csv":
                    frame.write_csv(file)
                else:
                    frame.write_parquet(file)
        except (OSError, pl.exceptions.PolarsError) as err:
            raise OutputError(f"{path}: cannot be written ({err})") from err
    return target


def _frame(columns: Mapping[str, Column]) -> pl.DataFrame:
    series: list[pl.Series] = []
    length: int | None = None
    for name, values in columns.items():
        if isinstance(values, np.ndarray):
            if values.ndim != 1:
                raise ValueError(f"column {name!r}: expected a 1-D array, got shape {values.shape}")
            column = pl.Series(name, values)
        else:
            column = pl.Series(name, [str(v) for v in values], dtype=pl.String)
        if length is not None and column.len() != length:
            raise ValueError(f"column {name!r} has {column.len()} values, expected {length}")
        length = column.len()
        series.append(column)
    return pl.DataFrame(series)
