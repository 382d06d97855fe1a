"""A Parquet log's columns read for a table: checked for their type, nested fields as leaves.

:func:`read_parquet_frame` reads the columns a read wants but those decoded later, one at a
time, by :func:`parquet_column`; each field inside a struct, list or array column is
taken as :mod:`~hybridlog.io.table_paths` names it (:func:`leaf_column`).
:func:`leaves_of` turns every nested column of a frame into its leaves, for ``inspect``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from hybridlog.errors import LogError, excerpt
from hybridlog.io.column_types import holds_numbers, holds_text
from hybridlog.io.message_paths import PathError
from hybridlog.io.parquet_files import read_parquet_columns
from hybridlog.io.table_file import TableFile
from hybridlog.io.table_paths import ColumnPath, expand, is_nested, leaf_values
from hybridlog.io.table_times import not_a_time
from hybridlog.polars_import import pl
from hybridlog.signals import IntArray


def read_parquet_frame(
    table: TableFile,
    paths: dict[str, ColumnPath],
    numeric: set[str],
    labels: set[str],
    skip: Sequence[str] = (),
) -> pl.DataFrame:
    """The fields of ``paths`` (the wanted ones) but ``skip``, all checked for their type.

    Numeric fields are cast to ``Float64``; a nested field is its leaf (:func:`leaf_column`).
    """
    time_column = table.time_column
    for name, path in paths.items():
        dtype = path.dtype
        if name == time_column and (
            isinstance(dtype, pl.Datetime | pl.Duration) or holds_text(dtype)
        ):
            continue  # text: ISO 8601 dates and times, as in a CSV file (time_column.time_ns)
        if name == time_column and not dtype.is_numeric():
            raise LogError(not_a_time(table.path, name, dtype))
        if name in numeric and not holds_numbers(dtype):
            raise LogError(
                f"{table.path}: column {excerpt(name)} has type {dtype}, expected a number"
            )
        if name in labels and not (
            dtype.is_numeric()
            or dtype in (pl.String, pl.Categorical, pl.Boolean)
            or isinstance(dtype, pl.Enum)
        ):
            raise LogError(
                f"{table.path}: column {excerpt(name)} has type {dtype}, expected mode ids"
            )
    # low_memory: decoded a row group at a time, 10^6 rows of 9 columns (82 MB of
    # values) peak about 25 MiB lower, in about the same time
    read = [name for name in paths if name not in skip]
    wanted = [paths[name] for name in read]
    frame = read_parquet_columns(table.file, list(dict.fromkeys(p.column for p in wanted)))
    if any(p.nested for p in wanted):
        frame = pl.DataFrame([leaf_column(table, frame, p) for p in wanted])
    casts = [
        pl.col(name).cast(pl.Float64)
        for name in read
        if name in numeric and name not in labels and frame.schema[name] != pl.Float64
    ]
    return frame.with_columns(casts) if casts else frame


def leaf_column(table: TableFile, frame: pl.DataFrame, path: ColumnPath) -> pl.Series:
    """:func:`~hybridlog.io.table_paths.leaf_values`, its error a :class:`LogError`."""
    try:
        return leaf_values(frame, path, table.path, table.row_label)
    except PathError as err:
        raise LogError(str(err)) from None


def parquet_column(table: TableFile, path: ColumnPath, rows: IntArray | None) -> pl.Series:
    """One numeric field of a Parquet log, at ``rows`` (``None``: all), as stored.

    :func:`~hybridlog.io.table_numbers.to_float` makes it ``Float64`` after
    :func:`~hybridlog.io.table_numbers.refuse_inexact` looked at it.
    """
    frame = read_parquet_columns(table.file, [path.column])
    column = leaf_column(table, frame, path)
    del frame
    return column if rows is None else column.gather(rows)


def leaves_of(table: TableFile, frame: pl.DataFrame, problems: list[str]) -> pl.DataFrame:
    """``frame`` with each struct, list or array column replaced by its leaves.

    A list whose rows differ in length stays whole (``q[]``) and a null inside a list is
    noted in ``problems``: both are what ``analyze`` refuses (:mod:`~hybridlog.io.table_paths`).
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
            if leaf.text in table.columns:  # a flat column of that name is what it names
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
                    f"{table.row_label(int(np.argmax(hole)))}, column {excerpt(name)}: "
                    f"{excerpt(leaf.text)} is null inside the row's list "
                    f"({int(hole.sum())} such rows; analyze refuses them)"
                )
            columns.append(values)
    return pl.DataFrame(columns)
