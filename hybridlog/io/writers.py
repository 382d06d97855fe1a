"""Writing tables (``hybridlog simulate`` logs, report tables) as CSV or Parquet."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from hybridlog.errors import OptionError, OutputError

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

    The table is written to a temporary file in the same directory and renamed into place,
    so a failure leaves either the old file or nothing -- never half a table.  Floats are
    written in the shortest form that reads back to the same double.

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
    if target.exists() and not force:
        raise OutputError(f"{path}: already exists (use --force to replace it)")
    frame = _frame(columns)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        handle, temp_name = tempfile.mkstemp(
            dir=target.parent, prefix=f".{target.name}.", suffix=".tmp"
        )
        os.close(handle)
        # mkstemp makes the file private (0600); a log should get the usual permissions.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temp_name, 0o666 & ~umask)
    except OSError as err:
        raise OutputError(f"{path}: cannot be written ({err.strerror})") from err
    temp = Path(temp_name)
    try:
        if suffix == ".csv":
            frame.write_csv(temp)
        else:
            frame.write_parquet(temp)
        _publish(temp, target, force=force)
    except (OSError, pl.exceptions.PolarsError) as err:
        raise OutputError(f"{path}: cannot be written ({err})") from err
    finally:
        with contextlib.suppress(FileNotFoundError):
            temp.unlink()
    return target


def _publish(temp: Path, target: Path, *, force: bool) -> None:
    """Move the finished ``temp`` to ``target``, never clobbering it unless ``force``."""
    if force:
        os.replace(temp, target)
        return
    try:
        # A hard link fails if ``target`` appeared meanwhile, unlike a rename.
        os.link(temp, target)
    except FileExistsError as err:
        raise OutputError(f"{target}: already exists (use --force to replace it)") from err
    except OSError:
        if target.exists():
            raise OutputError(f"{target}: already exists (use --force to replace it)") from None
        os.replace(temp, target)


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
