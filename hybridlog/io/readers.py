r"""The reader of each log, chosen by content and suffix.

The first bytes decide what a file is: MCAP (``\x89MCAP0``), ROS 1 bag (``#ROSBAG V2.0``),
SQLite (a ROS 2 ``.db3``) or Parquet (``PAR1``); anything else is read as CSV when its name
ends in ``.csv``.  A directory is a ROS 2 bag.  A suffix that promises a format the content
does not have is an error naming both.

=============================== ========================================================
log                             reader
=============================== ========================================================
``.csv``, ``.parquet``          :class:`~hybridlog.io.tables.TableSource` (polars)
``.bag`` (ROS 1)                :class:`~hybridlog.io.rosbag_reader.BagSource` (rosbags)
ROS 2 bag directory             :class:`~hybridlog.io.rosbag_reader.BagSource` (rosbags)
``.db3``                        :class:`~hybridlog.io.rosbag_reader.BagSource` (rosbags)
``.mcap``, profile ros2,        :class:`~hybridlog.io.rosbag_reader.BagSource` (rosbags)
fully indexed summary
``.mcap``, any other            :class:`~hybridlog.io.mcap_reader.McapSource` (mcap library)
``.mcap`` with --recover        :class:`~hybridlog.io.mcap_reader.McapSource`, sequential
=============================== ========================================================

Every reader turns whatever its library raises on a damaged file into a
:class:`~hybridlog.errors.LogError` naming the file, so a corrupt log never ends in a
traceback.
"""

from __future__ import annotations

import os
from pathlib import Path

from hybridlog.errors import LogError
from hybridlog.io.mcap_reader import MAGIC as MCAP_MAGIC
from hybridlog.io.mcap_reader import (
    McapSource,
    check_mcap,
    count_readable,
    rosbags_summary_problem,
)
from hybridlog.io.rosbag_reader import BagSource
from hybridlog.io.source import LogSource, ReadSettings
from hybridlog.io.tables import TableSource

ROS1_MAGIC = b"#ROSBAG V2.0\n"
SQLITE_MAGIC = b"SQLite format 3\x00"
PARQUET_MAGIC = b"PAR1"

#: What each suffix promises (the content decides; see the module docstring).
FORMATS: dict[str, str] = {
    ".csv": "a CSV file",
    ".parquet": "a Parquet file",
    ".mcap": "an MCAP file",
    ".bag": "a ROS 1 bag",
    ".db3": "a ROS 2 sqlite3 bag",
}


class UnfinishedLogError(LogError):
    """An MCAP file without its footer (cut off, or the recorder was killed).

    Attributes
    ----------
    readable:
        How many messages a sequential read gets out of it.
    """

    def __init__(self, message: str, readable: int) -> None:
        super().__init__(message)
        self.readable = readable


def sniff(path: Path) -> str:
    """What the content of a file is: ``mcap``, ``ros1``, ``sqlite``, ``parquet`` or ``other``."""
    try:
        with path.open("rb") as handle:
            head = handle.read(16)
    except OSError as err:
        raise LogError(f"{path}: cannot be read ({err.strerror})") from err
    if head.startswith(MCAP_MAGIC):
        return "mcap"
    if head.startswith(ROS1_MAGIC):
        return "ros1"
    if head.startswith(SQLITE_MAGIC):
        return "sqlite"
    if head.startswith(PARQUET_MAGIC):
        return "parquet"
    return "empty" if not head else "other"


def open_log(path: str | os.PathLike[str], settings: ReadSettings | None = None) -> LogSource:
    """Open a log with the reader its content and suffix call for.

    Parameters
    ----------
    path:
        A log file, or a ROS 2 bag directory.
    settings:
        Reading settings (``--time``, ``--sort``, ``--recover``, ``--msg-dir``).

    Returns
    -------
    LogSource
        An open source; use it as a context manager.

    Raises
    ------
    LogError
        When the log does not exist, is empty, its content does not match its suffix, its
        format is not supported (listing those that are), or it cannot be opened.
        :class:`UnfinishedLogError` for an MCAP file without footer (unless ``recover``).
    """
    settings = settings or ReadSettings()
    file = Path(path)
    if not file.exists():
        raise LogError(f"{path}: no such file")
    if file.is_dir():
        if not (file / "metadata.yaml").exists() and not any(
            p.suffix in (".db3", ".mcap") for p in file.iterdir()
        ):
            raise LogError(
                f"{path}: a directory without metadata.yaml or bag files is not a ROS 2 bag"
            )
        return BagSource(file, "ros2", settings)
    suffix = file.suffix.lower()
    content = sniff(file)
    if content == "empty":
        raise LogError(f"{path}: empty file")
    if content == "mcap":
        return _open_mcap(file, settings)
    if content == "ros1":
        if suffix != ".bag":
            raise LogError(f"{path}: is a ROS 1 bag; rename it to end in .bag to read it")
        return BagSource(file, "ros1", settings)
    if content == "sqlite":
        if suffix != ".db3":
            raise LogError(f"{path}: is an SQLite database; a ROS 2 bag file must end in .db3")
        return BagSource(file, "db3", settings)
    if content == "parquet" and suffix == ".parquet":
        return TableSource(file, settings)
    if suffix in (".mcap", ".bag", ".db3", ".parquet"):
        raise LogError(f"{path}: not {FORMATS[suffix]} (wrong magic bytes)")
    if suffix == ".csv":
        return TableSource(file, settings)
    raise LogError(
        f"{path}: unsupported log format (suffix {file.suffix or '(none)'!r}); supported: "
        f"{', '.join(FORMATS)} and ROS 2 bag directories"
    )


def _open_mcap(file: Path, settings: ReadSettings) -> LogSource:
    layout = check_mcap(file)
    if settings.recover:
        return McapSource(file, layout, settings)
    if not layout.finished:
        readable, stop = count_readable(file)
        then = (
            f"{readable} messages are readable, up to {stop}; --recover analyses them"
            if readable
            else f"no message is readable (the read stops at {stop}), so --recover cannot help"
        )
        raise UnfinishedLogError(
            f"{file}: unfinished MCAP file ({layout.problem}: the recorder was killed or the "
            f"file was cut off); {then}",
            readable,
        )
    if (
        layout.profile == "ros2"
        and file.suffix.lower() == ".mcap"
        and rosbags_summary_problem(file) is None
    ):
        return BagSource(file, "mcap", settings)
    return McapSource(file, layout, settings)
