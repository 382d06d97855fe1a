"""Logs → aligned signals.

:func:`load_signals` is the one entry point the jobs use: it opens a log with the reader of
its format (:func:`open_log`, chosen from the table :data:`FORMATS`: CSV/Parquet, MCAP, ROS 1
and ROS 2 bags), maps the model's symbols (a :class:`SignalSpec`) to log fields, reads only
those fields, checks them, and aligns them onto the model's grid, as one :class:`ReadOptions`
says.  Readers implement :class:`~hybridlog.io.source.LogSource`; a new format is a reader
class and a row of :data:`FORMATS` (:mod:`.formats`).

The names below are imported from their modules on first use, so that importing
``hybridlog.io`` (or its light modules :mod:`.options` and :mod:`.formats`) loads no reader
library.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from hybridlog.lazy import lazy_exports

if TYPE_CHECKING:
    from hybridlog.io.formats import FORMATS, LogFormat, open_log
    from hybridlog.io.inspect import format_inspection, inspect_log
    from hybridlog.io.load import SignalSpec, check_read_options, load_signals
    from hybridlog.io.mapping import SignalMap
    from hybridlog.io.options import ReadOptions
    from hybridlog.io.source import LabelSeries, LogSource, Reading, Series, SourceInfo
    from hybridlog.io.writers import write_table

__all__ = [
    "FORMATS",
    "LabelSeries",
    "LogFormat",
    "LogSource",
    "ReadOptions",
    "Reading",
    "Series",
    "SignalMap",
    "SignalSpec",
    "SourceInfo",
    "check_read_options",
    "format_inspection",
    "inspect_log",
    "load_signals",
    "open_log",
    "write_table",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        ".formats": ["FORMATS", "LogFormat", "open_log"],
        ".inspect": ["format_inspection", "inspect_log"],
        ".load": ["SignalSpec", "check_read_options", "load_signals"],
        ".mapping": ["SignalMap"],
        ".options": ["ReadOptions"],
        ".source": ["LabelSeries", "LogSource", "Reading", "Series", "SourceInfo"],
        ".writers": ["write_table"],
    },
)
