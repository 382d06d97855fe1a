"""A Parquet log's file read by polars: its schema, or columns, its name as Python takes it.

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
