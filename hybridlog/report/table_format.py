"""``--table-format``: the formats of a report's tables, checked without loading polars.

The batch process of ``batch --jobs N`` and of ``--scheduler`` checks the option but writes
no table (its workers do): it must not import :mod:`hybridlog.report.tables`, whose polars
import costs 0.13-0.17 s of a core that the workers need (:mod:`hybridlog.jobs.batch`).
"""

from __future__ import annotations

from typing import Literal

from hybridlog.errors import OptionError

__all__ = ["TABLE_FORMATS", "TableFormat", "check_table_format"]

TableFormat = Literal["csv", "parquet"]
TABLE_FORMATS: tuple[TableFormat, ...] = ("csv", "parquet")


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
