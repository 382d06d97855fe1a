"""A Parquet log's file read by polars: its schema, rows or columns, its name as Python takes it.

A file polars panics on is refused (:func:`.polars_errors.panics_refused`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from hybridlog.errors import LogError
from hybridlog.io.polars_errors import first_line, panics_refused
from hybridlog.polars_import import pl, polars_file


def read_parquet(path: Path, **options: Any) -> pl.DataFrame:
    """``pl.read_parquet`` of a log, its name taken as it is (:func:`polars_file`)."""
    with panics_refused(path, "Parquet"), polars_file(path, "rb") as source:
        return pl.read_parquet(source, glob=False, **options)


def read_parquet_schema(path: Path) -> dict[str, pl.DataType]:
    """The columns of a Parquet log and their types; a file polars cannot read refused."""
    try:
        with panics_refused(path, "Parquet"), polars_file(path, "rb") as source:
            schema = pl.scan_parquet(source, glob=False).collect_schema()
    except (pl.exceptions.PolarsError, OSError) as err:
        raise LogError(f"{path}: not a readable Parquet file ({first_line(err)})") from err
    if not schema:
        raise LogError(f"{path}: the Parquet file has no columns")
    return dict(schema)


def read_parquet_columns(path: Path, columns: list[str]) -> pl.DataFrame:
    """The named top-level columns of a Parquet log, as stored, a row group at a time."""
    try:
        return read_parquet(path, columns=columns, low_memory=True)
    except pl.exceptions.PolarsError as err:
        raise LogError(f"{path}: not a readable Parquet file ({first_line(err)})") from err


def parquet_rows(path: Path) -> int:
    """How many rows a Parquet log has (from its metadata)."""
    try:
        with panics_refused(path, "Parquet"), polars_file(path, "rb") as source:
            rows = pl.scan_parquet(source, glob=False).select(pl.len()).collect().item()
    except pl.exceptions.PolarsError as err:
        raise LogError(f"{path}: not a readable Parquet file ({first_line(err)})") from err
    return int(rows)
