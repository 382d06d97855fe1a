"""What a table column's polars type holds: numbers, text, integers a float64 holds exactly."""

from __future__ import annotations

from hybridlog.polars_import import pl

NARROW_INTEGERS = (pl.Int8, pl.Int16, pl.Int32, pl.UInt8, pl.UInt16, pl.UInt32)
"""Integer types every value of which a ``float64`` holds exactly."""


def holds_text(dtype: pl.DataType) -> bool:
    """Whether a column of ``dtype`` holds text: strings, categories (pyarrow dictionaries)."""
    return dtype == pl.String or isinstance(dtype, pl.Categorical | pl.Enum)


def holds_numbers(dtype: pl.DataType) -> bool:
    """Whether a Parquet column of ``dtype`` is read as numbers: booleans are 0 and 1.

    A valve's open/closed input is a boolean in Parquet as in a ROS message (``bool``) or a
    JSON one, where it reads as 0 and 1; only a time column must be numeric proper.
    """
    return dtype.is_numeric() or dtype == pl.Boolean


def dtype_name(dtype: pl.DataType) -> str:
    """``dtype`` as ``inspect`` and messages name it: ``float64``, ``List(Int64)``."""
    text = str(dtype)
    return text.lower() if text.isalnum() else text
