"""What every part of reading a table log shares: its file, format, columns and rows' names.

:class:`TableFile` is what :class:`~hybridlog.io.tables.TableSource` hands the functions it
reads with (:mod:`.time_column`, :mod:`.time_order`, :mod:`.table_numbers`,
:mod:`.parquet_columns`, :mod:`.table_description`), so that their messages name the file
and a line or row alike.  Imports no polars.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class TableFile:
    """A CSV or Parquet log as its header (or schema) gave it."""

    file: Path
    format: str
    """``csv`` or ``parquet``."""
    columns: tuple[str, ...]
    """Every column, the time included, in file order."""
    time_column: str | None
    """The time column (:data:`~hybridlog.io.table_times.TIME_COLUMNS`), or ``None``."""

    @property
    def path(self) -> str:
        """The file's path as given: what every message starts with."""
        return str(self.file)

    def row_label(self, row: int) -> str:
        """Line (CSV, header = line 1) or row (Parquet, 1-based) of data row ``row`` (0-based)."""
        return f"line {row + 2}" if self.format == "csv" else f"row {row + 1}"
