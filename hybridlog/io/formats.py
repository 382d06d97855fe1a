r"""The table of log formats, and the reader of each log chosen from it.

Every log format is one row of :data:`FORMATS`: its name, the magic bytes its content starts
with, its suffixes, whether it is a directory, and its reader (imported only when a log of
that format is opened).  :func:`open_log`, :func:`sniff`, the suffix cross-check, the list of
supported formats in errors and help, and ``inspect`` all read this table; there is no other
list of formats.

The content decides what a file is: the row whose magic bytes start it.  A format whose
reader needs the suffix (rosbags reads ROS 1 bags and ``.db3`` files by their names) refuses
a file named otherwise, saying how to rename it; MCAP and Parquet content is read whatever
the name.  A file whose content matches no row is read by the row of its suffix when that
row has no magic bytes (CSV), and refused when it has (a suffix that promises a format the
content does not have).  A directory is read by the directory row that holds it.

=================== ========================== ================================================
format              content                    reader
=================== ========================== ================================================
``csv``             ``.csv``, any text         :class:`~hybridlog.io.tables.TableSource`
``parquet``         ``PAR1``                   :class:`~hybridlog.io.tables.TableSource`
``mcap``            ``\x89MCAP0\r\n``          :func:`~hybridlog.io.mcap_reader.open_mcap`:
                                               rosbags for ``ros2``-profile CDR files of chunks
                                               with a full summary, else the ``mcap`` library
                                               (also ``--recover``)
``ros1-bag``        ``#ROSBAG V2.0``, ``.bag`` :class:`~hybridlog.io.rosbag_reader.BagSource`
``ros2-db3``        SQLite, ``.db3``           :class:`~hybridlog.io.rosbag_reader.BagSource`
``ros2-bag``        a directory with           :class:`~hybridlog.io.rosbag_reader.BagSource`
                    ``metadata.yaml`` or bag
                    files
=================== ========================== ================================================

Only the standard library is imported here, so that help texts can list the formats without
loading a reader.  Every reader turns whatever its library raises on a damaged file into a
:class:`~hybridlog.errors.LogError` naming the file, so a corrupt log never ends in a
traceback.
"""

from __future__ import annotations

import errno
import importlib
import os
import re
import stat
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, cast

from hybridlog.errors import LogError, OptionError
from hybridlog.io.options import ReadOptions
from hybridlog.outputs import MARKER, is_temporary

if TYPE_CHECKING:
    from hybridlog.io.source import LogSource

MCAP_MAGIC = b"\x89MCAP0\r\n"


@dataclass(frozen=True)
class LogFormat:
    """One row of the table of log formats.

    Attributes
    ----------
    name:
        The format's name in reports and ``inspect`` (``"csv"``, ``"ros1-bag"`` ...).
    what:
        The format with its article, for messages (``"a ROS 1 bag"``).
    title:
        The format in lists of formats (``"ROS 1 bags"``).
    suffixes:
        The file suffixes of the format; for a directory, the suffixes of the files it holds.
    reader:
        ``"module:name"`` of the reader: a callable ``reader(path, options, log_format)``
        returning a :class:`~hybridlog.io.source.LogSource` (usually the source class).
    magic:
        The bytes the content starts with (empty: the format has none, e.g. CSV).
    misnamed:
        When the reader needs the suffix: what to tell the user about a file with this
        content and another name ("" when any name will do).
    directory:
        Whether the log is a directory.
    index_file:
        For a directory: a file whose presence marks the format (``metadata.yaml``).
    recovers:
        Whether its reader reads the file with ``--recover`` (sequentially, up to the first
        damaged record): a bare MCAP file only.  Another format given ``--recover`` is
        refused as it is opened (:meth:`open`): the option was silently ignored.
    stamped:
        Whether its messages may carry the ``header.stamp`` that ``--time header`` reads: bags
        and MCAP files.  A table's time column is the only time it has: ``--time header`` is
        refused as a log of another format is opened (:meth:`open`).
    """

    name: str
    what: str
    title: str
    suffixes: tuple[str, ...]
    reader: str
    magic: bytes = b""
    misnamed: str = ""
    directory: bool = False
    index_file: str = ""
    recovers: bool = False
    stamped: bool = False

    def open(self, path: Path, options: ReadOptions) -> LogSource:
        """Open ``path`` with this format's reader (imported on first use).

        Raises
        ------
        OptionError
            For ``--recover`` on a format that does not read it (:attr:`recovers`), and for
            ``--time header`` on one whose logs carry no stamps (:attr:`stamped`): each
            reader refused it itself, or, a new one, read its own times without a word.
        """
        if options.recover and not self.recovers:
            raise OptionError(self.recover_refusal(path))
        if options.time != "log" and not self.stamped:
            raise OptionError(
                f"--time {options.time}: {os.fspath(path)} is {self.what}; its time column is "
                "the only time it has (use --time log)"
            )
        module, _, name = self.reader.partition(":")
        reader = getattr(importlib.import_module(module), name)
        opener = cast("Callable[[Path, ReadOptions, LogFormat], LogSource]", reader)
        return opener(path, options, self)

    def recover_refusal(self, path: str | os.PathLike[str]) -> str:
        """``--recover: PATH is a CSV file; ...``: why ``--recover`` cannot read ``path``."""
        where = (
            "for an unfinished .mcap storage file of the bag, give that file itself"
            if self.directory
            else "leave it out"
        )
        return (
            f"--recover: {os.fspath(path)} is {self.what}; --recover reads only an unfinished "
            f"or damaged MCAP file (sequentially, up to its first bad record): {where}"
        )

    def holds(self, folder: Path) -> bool:
        """For a directory format: whether ``folder`` has its index file or one of its files."""
        if (folder / self.index_file).exists():
            return True
        return any(p.suffix in self.suffixes for p in folder.iterdir())


#: Every log format hybridlog reads, in the order the help lists them (directories last).
FORMATS: tuple[LogFormat, ...] = (
    LogFormat("csv", "a CSV file", "CSV", (".csv",), "hybridlog.io.tables:TableSource"),
    LogFormat(
        "parquet",
        "a Parquet file",
        "Parquet",
        (".parquet",),
        "hybridlog.io.tables:TableSource",
        magic=b"PAR1",
    ),
    LogFormat(
        "mcap",
        "an MCAP file",
        "MCAP",
        (".mcap",),
        "hybridlog.io.mcap_reader:open_mcap",
        magic=MCAP_MAGIC,
        recovers=True,
        stamped=True,
    ),
    LogFormat(
        "ros1-bag",
        "a ROS 1 bag",
        "ROS 1 bags",
        (".bag",),
        "hybridlog.io.rosbag_reader:BagSource",
        magic=b"#ROSBAG V2.0\n",
        misnamed="is a ROS 1 bag; rename it to end in .bag to read it",
        stamped=True,
    ),
    LogFormat(
        "ros2-db3",
        "a ROS 2 sqlite3 bag",
        "ROS 2 sqlite3 bags",
        (".db3",),
        "hybridlog.io.rosbag_reader:BagSource",
        magic=b"SQLite format 3\x00",
        misnamed="is an SQLite database; a ROS 2 bag file must end in .db3",
        stamped=True,
    ),
    LogFormat(
        "ros2-bag",
        "a ROS 2 bag",
        "ROS 2 bag directories",
        (".db3", ".mcap"),
        "hybridlog.io.rosbag_reader:BagSource",
        directory=True,
        index_file="metadata.yaml",
        stamped=True,
    ),
)


def _log_file_name(name: str) -> bool:
    """Whether a file name has the suffix of a file format (``.csv``, ``.parquet``, ...)."""
    suffix = Path(name).suffix.lower()
    return any(suffix in f.suffixes for f in FORMATS if not f.directory)


def indexed_log(folder: str | os.PathLike[str]) -> bool:
    """Whether a folder is a log by a directory format's index file (``metadata.yaml``)."""
    return any((Path(folder) / f.index_file).is_file() for f in FORMATS if f.index_file)


def logs_in(
    folder: str | os.PathLike[str],
    links: list[Path] | None = None,
    hidden: list[Path] | None = None,
) -> list[Path]:
    """The logs in a folder of logs and its subfolders, for ``hybridlog batch FOLDER``.

    A log is a file with the suffix of a file format (any case), or a subfolder that
    :func:`indexed_log` (one log, not searched further).  Other files (notes, images), names
    starting with ``.`` and folders hybridlog wrote (with its marker file
    :data:`hybridlog.outputs.MARKER`: their tables are not logs) are skipped, ``folder``
    itself too if it is one; a bag folder without its ``metadata.yaml`` is
    searched like any other, its ``.db3`` or ``.mcap`` files each a log of its own.  Links to
    files are followed, links to folders are not (a loop would never end): each one met is
    appended to ``links``, when given, so that the caller can say it was not searched.  A
    hidden name that would be a log (``.run.csv``, a bag folder ``.bag/``) is appended to
    ``hidden``, when given, for the same reason; not a macOS ``._run.csv`` beside
    ``run.csv`` (the file's metadata, which macOS writes where the file system has no room
    for it) nor a temporary file hybridlog writes a log through
    (:func:`~hybridlog.outputs.temporary_name`); no folder starting with ``.`` is searched
    (``.git``, ``.snapshot``: a tool's, not logs).  In the order of :func:`os.walk`, each
    folder's entries sorted.

    Raises
    ------
    LogError
        When ``folder`` or one of its subfolders cannot be listed (never a silent gap).
    """

    def unreadable(err: OSError) -> None:
        raise LogError(f"{err.filename}: cannot be listed ({err.strerror})") from err

    found: list[Path] = []
    if (Path(folder) / MARKER).exists():
        return found
    for root, folders, files in os.walk(folder, onerror=unreadable):
        here = Path(root)
        searched = []
        for name in sorted(folders):
            if name.startswith(".") and hidden is not None and indexed_log(here / name):
                hidden.append(here / name)
            if name.startswith(".") or (here / name / MARKER).exists():
                continue
            if indexed_log(here / name):
                found.append(here / name)
            elif (here / name).is_symlink():  # os.walk lists it, but does not enter it
                if links is not None:
                    links.append(here / name)
            else:
                searched.append(name)
        folders[:] = searched
        logs = [name for name in sorted(files) if _log_file_name(name)]
        found += [here / name for name in logs if not name.startswith(".")]
        if hidden is not None:
            names = set(files)
            hidden += [
                here / name
                for name in logs
                if name.startswith(".")
                and not (name.startswith("._") and name[2:] in names)
                and not is_temporary(name)
            ]
    return found


def get_format(name: str) -> LogFormat:
    """The row of :data:`FORMATS` called ``name`` (a programming error if there is none)."""
    return next(f for f in FORMATS if f.name == name)


def format_list(*, titles: bool = False) -> str:
    """The supported formats as text, for errors and help.

    Parameters
    ----------
    titles:
        ``False``: ``".csv, .parquet, .mcap, .bag, .db3 and ROS 2 bag directories"``;
        ``True``: ``"CSV (.csv), Parquet (.parquet), ... and ROS 2 bag directories"``.
    """
    items: list[str] = []
    for log_format in FORMATS:
        if log_format.directory:
            items.append(log_format.title)
        elif titles:
            items.append(f"{log_format.title} ({', '.join(log_format.suffixes)})")
        else:
            items.extend(log_format.suffixes)
    return f"{', '.join(items[:-1])} and {items[-1]}"


def sniff(path: str | os.PathLike[str]) -> LogFormat | None:
    """The file format whose magic bytes start ``path``, or ``None`` when none does.

    Raises
    ------
    LogError
        When the file cannot be read or is empty.
    """
    try:
        with Path(path).open("rb") as handle:
            head = handle.read(max(len(f.magic) for f in FORMATS))
    except OSError as err:
        raise LogError(f"{os.fspath(path)}: cannot be read ({err.strerror})") from err
    if not head:
        raise LogError(f"{os.fspath(path)}: empty file")
    return next((f for f in FORMATS if f.magic and head.startswith(f.magic)), None)


def log_format(path: str | os.PathLike[str]) -> LogFormat:
    """The row of :data:`FORMATS` that reads ``path`` (rules in the module docstring).

    Raises
    ------
    LogError
        When the log does not exist, is not a regular file or a folder (a pipe, which would
        block, or a device), is empty, its content does not match its suffix, or its format
        is not supported (listing those that are).
    """
    shown = os.fspath(path)
    file = Path(path)
    mode = _file_mode(file, shown)
    if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        raise LogError(
            f"{shown}: not a regular file (a pipe, device or socket); a log must be a file or "
            "a bag folder, which hybridlog reads more than once"
        )
    if stat.S_ISDIR(mode):
        folders = [f for f in FORMATS if f.directory]
        try:
            chosen = next((f for f in folders if f.holds(file)), None)
        except OSError as err:  # a folder one may not list: Permission denied
            raise LogError(f"{shown}: cannot be read ({err.strerror})") from err
        if chosen is None:
            wanted = " or ".join(f"{f.index_file} or bag files" for f in folders)
            what = " or ".join(f.what for f in folders)
            raise LogError(
                f"{shown}: a directory without {wanted} is not {what}{_batch_hint(file, shown)}"
            )
        return chosen
    suffix = file.suffix.lower()
    content = sniff(path)
    if content is not None:
        if content.misnamed and suffix not in content.suffixes:
            raise LogError(f"{shown}: {content.misnamed}")
        return content
    version = _older_bag_version(file)
    if version is not None:
        raise LogError(
            f"{shown}: a ROS 1 bag of format version {version}, which hybridlog does not read "
            f"(rosbags reads version 2.0, the one rosbag record writes); ROS 1's "
            f"`rosbag filter {file.name} new.bag True` rewrites it as version 2.0"
        )
    named = next((f for f in FORMATS if not f.directory and suffix in f.suffixes), None)
    if named is None:
        raise LogError(
            f"{shown}: unsupported log format (suffix {file.suffix or '(none)'!r}); "
            f"supported: {format_list()}{_inside_bag_hint(file)}"
        )
    if named.magic:
        raise LogError(f"{shown}: not {named.what} (wrong magic bytes)")
    return named


_BAG_VERSION_LINE = re.compile(rb"#ROSBAG V(\d{1,3}\.\d{1,3})\n")
"""The first line of a ROS 1 bag of any format version (``#ROSBAG V1.2``)."""


def _older_bag_version(file: Path) -> str | None:
    """The format version of a ROS 1 bag other than 2.0 (``"1.2"``), or ``None``.

    Such a bag (format 1.2, of ROS's first releases) failed the ``#ROSBAG V2.0`` magic bytes
    and was refused as "not a ROS 1 bag (wrong magic bytes)", which it is.
    """
    try:
        with file.open("rb") as handle:
            head = handle.read(len("#ROSBAG V123.123\n"))
    except OSError:
        return None
    found = _BAG_VERSION_LINE.match(head)
    return None if found is None else found.group(1).decode("ascii")


def _file_mode(file: Path, shown: str) -> int:
    """The ``st_mode`` of ``file`` (links followed), or why there is none as a LogError.

    ``Path.exists`` said ``False`` of a symbolic link that leads back to itself, which was
    then "no such file", and raised ``PermissionError`` for a log inside a folder one may
    not enter, which ended as "unexpected PermissionError (a bug)".  One ``stat`` tells
    them apart: a missing file, a link to nothing (named with its target), or the
    system's reason (``Too many levels of symbolic links``, ``Permission denied``).
    """
    try:
        return file.stat().st_mode
    except OSError as err:
        if err.errno not in (errno.ENOENT, errno.ENOTDIR):
            raise LogError(f"{shown}: cannot be read ({err.strerror})") from err
        if file.is_symlink():
            raise LogError(
                f"{shown}: a symbolic link to {os.readlink(file)!r}, which does not exist"
            ) from err
        raise LogError(f"{shown}: no such file") from err


def _inside_bag_hint(file: Path) -> str:
    """For a file of a bag folder no reader takes alone: the folder that is the log.

    A ROS 2 bag's ``metadata.yaml``, or its storage compressed per file
    (``bag_0.db3.zstd``, ``bag_0.mcap.zstd``), is read through the folder only.
    """
    folder = file.parent
    if not indexed_log(folder):
        return ""
    return f"; it is part of the ROS 2 bag {str(folder)!r}: give that folder as the log"


def _is_file(entry: os.DirEntry[str]) -> bool:
    """Whether ``entry`` is a regular file or a link to one; a link loop is not."""
    try:
        return entry.is_file()
    except OSError:  # a link loop (ELOOP) raises where a missing target is False
        return False


def _batch_hint(folder: Path, shown: str) -> str:
    """For a folder that is no log: how many log files it holds, and what reads them.

    Its own entries only: a folder of many subfolders is not searched to word an error.
    """
    try:
        with os.scandir(folder) as entries:
            held = sum(1 for entry in entries if _log_file_name(entry.name) and _is_file(entry))
    except OSError:
        return ""
    if not held:
        return ""
    files = "1 log file" if held == 1 else f"{held} log files"
    return f"; it holds {files}: 'hybridlog batch {shown}' analyses a folder of logs"


def open_log(path: str | os.PathLike[str], options: ReadOptions | None = None) -> LogSource:
    """Open a log with the reader of its format (:func:`log_format`).

    Parameters
    ----------
    path:
        A log file, or a ROS 2 bag directory.
    options:
        How to read it (``time``, ``sort``, ``recover``, ``msg_dirs`` concern the readers).

    Returns
    -------
    LogSource
        An open source; use it as a context manager.

    Raises
    ------
    LogError
        When the log does not exist, is empty, its content does not match its suffix, its
        format is not supported (listing those that are), or it cannot be opened;
        :class:`~hybridlog.io.mcap_reader.UnfinishedLogError` for an MCAP file without
        footer (unless ``recover``).
    OptionError
        For ``recover`` on a log of another format than MCAP (:attr:`LogFormat.recovers`).
    """
    return log_format(path).open(Path(path), options or ReadOptions())
