"""A table log's time column: its names, and ISO 8601 dates and times written as text.

:data:`TIME_COLUMNS` names it (``t``, else ``time``); :func:`iso_format` gives the polars
format of a text time like the first cell's; :func:`not_a_time` says why a Parquet column's
type cannot be the time.  Imports no polars.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

from hybridlog.errors import excerpt

if TYPE_CHECKING:
    from hybridlog.polars_import import pl


TIME_COLUMNS = ("t", "time")


ISO_DATE = re.compile(
    r"\d{4}-\d{2}-\d{2}([Tt ])\d{2}:\d{2}(:\d{2}(\.\d+)?)?(Z|[+-]\d{2}(?::?\d{2})?)?$"
)


def iso_format(text: str | None) -> str | None:
    """The polars format of an ISO 8601 date and time like ``text``, or ``None`` if not one.

    ``2024-01-01T00:00:00.5``, ``2024-01-01 00:00:00`` (pandas), ``t`` as RFC 3339 allows,
    either with ``Z`` or an offset (``+01:00``, ``+0100``, ``+01``); seconds are needed.
    """
    match = ISO_DATE.match(text.strip()) if text else None
    if match is None or match.group(2) is None:
        return None
    zone = "%#z" if match.group(4) else ""
    return f"%Y-%m-%d{match.group(1)}%H:%M:%S%.f{zone}"


def not_a_time(path: str, name: str, dtype: pl.DataType) -> str:
    """Why a Parquet column of ``dtype`` (a Date, Time, Boolean) cannot be the time column."""
    return (
        f"{path}: column {excerpt(name)} has type {dtype}, expected seconds as numbers, a "
        "Datetime or Duration, or ISO 8601 dates and times as text"
    )
