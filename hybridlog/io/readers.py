"""The reader of each log format, chosen by file suffix."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

from hybridlog.errors import LogError
from hybridlog.io.source import LogSource
from hybridlog.io.tables import TableSource

#: Opener of each supported file suffix (lower case); new formats register here.
READERS: dict[str, Callable[[Path], LogSource]] = {
    ".csv": TableSource,
    ".parquet": TableSource,
}


def open_log(path: str | os.PathLike[str]) -> LogSource:
    """Open a log with the reader its suffix names.

    Parameters
    ----------
    path:
        The log file.

    Returns
    -------
    LogSource
        An open source; use it as a context manager.

    Raises
    ------
    LogError
        When the file does not exist or its format is not supported (listing those that are).
    """
    file = Path(path)
    if not file.exists():
        raise LogError(f"{path}: no such file")
    opener = READERS.get(file.suffix.lower())
    if opener is None or not file.is_file():
        kind = "a directory" if file.is_dir() else f"suffix {file.suffix or '(none)'!r}"
        raise LogError(f"{path}: unsupported log format ({kind}); supported: {', '.join(READERS)}")
    return opener(file)
