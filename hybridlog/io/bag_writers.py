"""Writing logs in every format hybridlog reads (``hybridlog simulate``).

:func:`write_log` takes the same named columns as :func:`~hybridlog.io.writers.write_table`
(a time column ``t`` in seconds, numeric columns, text columns such as mode ids) and writes
them as a table, an MCAP file, a ROS 1 bag or a ROS 2 bag directory.  In the message formats
each column becomes a topic with standard message types, so any ROS tool can read them:

======================================== ===================== ============================
column                                   topic                 message type
======================================== ===================== ============================
numeric column *c* (inputs, outputs)     ``/c``                ``std_msgs/Float64``
ground-truth column *c* (``truth=``)     ``/truth/c``          ``std_msgs/Float64``
text column (e.g. the true ``mode``)     ``/truth/mode``       ``std_msgs/String``
a component's true mode ``mode.fr1``     ``/truth/mode/fr1``   ``std_msgs/String``
======================================== ===================== ============================

Topics are ROS names, which ``ros2 bag play`` and rclcpp require: a column name that is not a
ROS name token is written as one (:func:`hybridlog.io.mapping.column_topic`: ``θ`` →
``/truth/theta``); columns that would share a topic, or a name with nothing ASCII in it, are
refused before anything is written (:func:`log_topics`).  Every message of row *k* is logged
at ``t_k`` (integer nanoseconds, the nearest to the float seconds of the table; times from 0
to 9.2e9 s, a ROS 1 bag's to 2^32 s, and times whose rounding moves them by more than a
thousandth of a step, a step of 1.5 ns, refused before anything is written), so the message
paths ``/u.data``, ``/y1.data``, ``/truth/mode.data``, ``/truth/x1.data`` are the default
mapping of :mod:`~hybridlog.io.mapping`.  MCAP files are
zstd-compressed with chunk and data-section CRCs; the encoding is ROS 2 CDR (profile ``ros2``,
``ros2msg`` schemas) by default, JSON (``jsonschema`` schemas, no profile) or ROS 1 (profile
``ros1``, ``ros1msg`` schemas) on request.  Files appear complete or not at all: they are
written under a temporary name and renamed (:mod:`hybridlog.outputs`); a ROS 2 bag records
in its ``custom_data`` that hybridlog wrote it (:data:`BAG_WRITER`), so ``--force`` may
replace it later.  ROS 2 bags have ``metadata.yaml`` version 8 (:data:`BAG_VERSION`), which
``ros2 bag`` reads from ROS 2 Humble on.
"""

from __future__ import annotations

import json
import os
import re
import struct
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Final, Literal

from hybridlog import __version__
from hybridlog.errors import OptionError, OutputError, excerpt
from hybridlog.outputs import (
    PathLike,
    atomic_files,
    check_apart,
    check_dir_target,
    check_file_name,
    check_file_target,
    output_path,
    publish_dir,
    staging_dir,
)
from hybridlog.times import format_time

if TYPE_CHECKING:
    from hybridlog.io.writers import Column

# numpy, polars and the writers are imported where they are used: ``hybridlog simulate
# --help`` reads LOG_FORMATS and MCAP_ENCODINGS from here and must stay light.

#: ``--format`` values; the first four also follow from the suffix.
LOG_FORMATS: tuple[str, ...] = ("csv", "parquet", "mcap", "bag", "ros2-sqlite3", "ros2-mcap")
#: ``--encoding`` values for MCAP files.
MCAP_ENCODINGS: tuple[str, ...] = ("cdr", "json", "ros1")

_BAG_ENCODINGS: Final = {"bag": "ros1", "ros2-sqlite3": "cdr", "ros2-mcap": "cdr"}
"""The one message encoding of each kind of bag (``--encoding`` may name it, to no effect)."""

_BAG_NAMES: Final = {
    "ros1": "a ROS 1 bag's messages are ROS 1's",
    "cdr": "a ROS 2 bag's messages are CDR",
}
"""What a bag's own encoding is, for the refusal of another encoding."""

SUFFIX_FORMATS = {".csv": "csv", ".parquet": "parquet", ".mcap": "mcap", ".bag": "bag"}

FLOAT64 = "std_msgs/msg/Float64"
STRING = "std_msgs/msg/String"
_CDR_LE = b"\x00\x01\x00\x00"
_F64 = struct.Struct("<d")
_U32 = struct.Struct("<I")
_JSON_SCHEMAS = {
    FLOAT64: {"type": "object", "properties": {"data": {"type": "number"}}},
    STRING: {"type": "object", "properties": {"data": {"type": "string"}}},
}


@dataclass(frozen=True)
class TopicColumn:
    """One topic written from one column."""

    topic: str
    column: str
    msgtype: str


def log_format(path: str | os.PathLike[str], format: str | None) -> str:
    """The format to write: ``format`` if given, else the one the suffix names.

    Raises
    ------
    OptionError
        For an unknown format, or a path whose suffix names none (listing the choices).
    """
    if format is not None:
        if format not in LOG_FORMATS:
            raise OptionError(
                f"--format: unknown format {format!r}; choose one of {', '.join(LOG_FORMATS)}"
            )
        return format
    suffix = Path(path).suffix.lower()
    if suffix in SUFFIX_FORMATS:
        return SUFFIX_FORMATS[suffix]
    if suffix == ".db3":  # read alone, written only inside a bag folder
        stem = Path(path).with_suffix("")
        raise OptionError(
            f"{path}: a ROS 2 sqlite3 bag is written as a folder (metadata.yaml and its .db3 "
            f"file): --out {stem} --format ros2-sqlite3 writes {stem / stem.name}.db3"
        )
    if not suffix and Path(path).is_dir():  # `--out out`: a folder, not a log's name
        raise OptionError(
            f"{path}: is a folder; name the log in it ({Path(path) / 'log.csv'}, or a "
            f"{', '.join(SUFFIX_FORMATS)} file), or write a ROS 2 bag folder there with "
            "--format ros2-sqlite3|ros2-mcap"
        )
    raise OptionError(
        f"{path}: cannot tell the log format from suffix {suffix or '(none)'!r}; use "
        f"{', '.join(SUFFIX_FORMATS)} or --format ros2-sqlite3|ros2-mcap for a ROS 2 bag folder"
    )


def log_topics(
    columns: Mapping[str, Column], truth: Sequence[str] = (), *, path: PathLike = "log"
) -> list[TopicColumn]:
    """The topic of every column but ``t`` (see the module docstring).

    Raises
    ------
    OptionError
        As :func:`check_topic_names`.
    """
    import numpy as np

    topics = check_topic_names(path, [name for name in columns if name != "t"], truth)
    out = []
    for name, topic in topics.items():
        values = columns[name]
        numeric = isinstance(values, np.ndarray) and values.dtype.kind in "biuf"
        out.append(TopicColumn(topic, name, FLOAT64 if numeric else STRING))
    return out


def check_topic_names(
    path: PathLike, names: Sequence[str], truth: Sequence[str] = ()
) -> dict[str, str]:
    """``{column: topic}``: the ROS topic each column is written to in a bag or MCAP file.

    Checked before a run is simulated (``hybridlog simulate``) as well as when it is written.

    Raises
    ------
    OptionError
        For a column whose name has no ROS name (nothing ASCII in it), two columns that
        would be one topic (states ``θ`` and ``theta``), or a topic longer than ROS 2 takes;
        naming the log, the columns and the topic.
    """
    from hybridlog.io.mapping import MAX_TOPIC_LENGTH, ROS_TOPIC, column_topic

    hint = "rename it in the model, or write a CSV or Parquet log"
    topics: dict[str, str] = {}
    owners: dict[str, str] = {}
    for name in names:
        topic = column_topic(name, truth=name in truth)
        if topic is None:
            raise OptionError(
                f"{path}: column {excerpt(name, 40)} has no ROS topic name (ROS names are "
                f"ASCII letters, digits and _); {hint}"
            )
        assert ROS_TOPIC.fullmatch(topic), topic  # column_topic makes nothing else
        if len(topic) > MAX_TOPIC_LENGTH:
            raise OptionError(
                f"{path}: the topic of column {excerpt(name, 40)} is {len(topic)} characters "
                f"long, longer than ROS 2 takes ({MAX_TOPIC_LENGTH}); {hint}"
            )
        if topic in owners:
            raise OptionError(
                f"{path}: columns {excerpt(owners[topic], 40)} and {excerpt(name, 40)} would "
                f"both be topic {excerpt(topic, 60)} (ROS names are ASCII letters, digits and "
                f"_); rename one in the model, or write a CSV or Parquet log"
            )
        owners[topic] = name
        topics[name] = topic
    return topics


def check_log_target(
    path: PathLike,
    *,
    format: str | None = None,
    encoding: str | None = None,
    force: bool = False,
    inputs: Sequence[tuple[str, PathLike]] = (),
) -> str:
    """Check everything about a log to write before it is simulated; return its format.

    Parameters
    ----------
    path, format, encoding, force:
        As for :func:`write_log`.
    inputs:
        ``(what, path)`` pairs the log must not replace, contain or sit inside (the model
        file of ``simulate``).

    Raises
    ------
    OptionError
        For an unknown format or encoding, an encoding given for a format without one, or a
        log file named otherwise than its format (:func:`_check_file_name`).
    OutputError
        When the target is, contains or sits inside an input; exists without ``force``; is
        a folder where a file is written (or the reverse); or is a folder hybridlog did not
        write (see :mod:`hybridlog.outputs`).
    """
    chosen = log_format(path, format)
    if encoding is not None and encoding not in MCAP_ENCODINGS:
        raise OptionError(
            f"--encoding: unknown {encoding!r}; choose one of {', '.join(MCAP_ENCODINGS)}"
        )
    # --encoding cdr of a table or a ROS 1 bag was ignored; a bag's own encoding is no choice
    own = _BAG_ENCODINGS.get(chosen)
    if encoding is not None and encoding != own and chosen != "mcap":
        what = (
            f"{_BAG_NAMES[own]}, whatever its storage (--format mcap writes an MCAP "
            "file of the encoding chosen)"
            if own is not None
            else f"only an MCAP file (.mcap) has a choice of encoding, not a {chosen} log"
        )
        raise OptionError(f"--encoding {encoding}: {what}")
    if not chosen.startswith("ros2-"):
        check_file_name(path, "--out")  # x.csv/: a folder's name, where a file is written
        _check_file_name(path, chosen)
    check_apart([("--out", path)], inputs)
    if chosen.startswith("ros2-"):
        check_dir_target(path, force=force, ours=written_by_hybridlog, written=bag_files)
        _check_folder_name(path, chosen)
    else:
        check_file_target(path, force=force)
    return chosen


#: The row of :data:`hybridlog.io.formats.FORMATS` that reads each file format written.
_READ_AS = {"csv": "csv", "parquet": "parquet", "mcap": "mcap", "bag": "ros1-bag"}


def _check_folder_name(path: PathLike, chosen: str) -> None:
    """Refuse a ROS 2 bag folder named like a log file (``x.db3``, ``x.mcap``).

    The folder's storage file is named after it: ``--out x.db3 --format ros2-sqlite3`` made
    a folder ``x.db3/`` holding ``x.db3.db3``, where a user asking for ``x.db3`` meant the
    file (which hybridlog reads alone, but writes only inside a bag folder).
    """
    from hybridlog.io.formats import FORMATS

    name = Path(path)
    suffix = name.suffix.lower()
    named = next((f for f in FORMATS if not f.directory and suffix in f.suffixes), None)
    if named is None:
        return
    storage = ".db3" if chosen == "ros2-sqlite3" else ".mcap"
    stem = name.with_suffix("")
    raise OptionError(
        f"{path}: a ROS 2 bag is a folder (metadata.yaml and the {storage} file named after "
        f"the folder), not a file named *{suffix} like {named.what}; name the folder without "
        f"{suffix}: --out {stem} writes {stem / stem.name}{storage}"
    )


def _check_file_name(path: PathLike, chosen: str) -> None:
    """Refuse a log file named so that hybridlog would not read it as what it holds.

    Its suffix must not be another format's (``--format bag --out run.mcap`` made a bag that
    reading then refused, as rosbags reads bags by their names), and a format told by its
    name -- ROS 1 bags, and CSV and Parquet files, whose writer picks the table format by
    the suffix -- must have its own.  An MCAP file is known by its content and may have any
    other name.
    """
    from hybridlog.io.formats import FORMATS, get_format

    row = get_format(_READ_AS[chosen])
    suffix = Path(path).suffix.lower()
    named = next((f for f in FORMATS if not f.directory and suffix in f.suffixes), None)
    if named is row or (named is None and chosen == "mcap"):
        return
    other = f", not *{suffix} (the suffix of {named.what})" if named is not None else ""
    raise OptionError(f"{path}: {row.what} must be named *{row.suffixes[0]}{other}")


def write_log(
    path: PathLike,
    columns: Mapping[str, Column],
    *,
    truth: Sequence[str] = (),
    format: str | None = None,
    encoding: str | None = None,
    force: bool = False,
    inputs: Sequence[tuple[str, PathLike]] = (),
    progress: Callable[[int], None] | None = None,
) -> Path:
    """Write a log in any format hybridlog reads.

    Parameters
    ----------
    path:
        Output file, or folder for a ROS 2 bag.  Missing parent folders are created.
    columns:
        ``{name: values}``: ``t`` (seconds, increasing) and 1-D numeric arrays or sequences
        of text, all of the same length.
    truth:
        Columns that are ground truth: their topics go under ``/truth/``.
    format:
        One of :data:`LOG_FORMATS`; default from the suffix.
    encoding:
        MCAP message encoding: ``cdr``, ``json`` or ``ros1``; ``None`` (default): not
        chosen, ``cdr`` for an MCAP file.  Chosen for another format, it is refused, but
        ``cdr`` for a ROS 2 bag (whose messages are CDR): a ROS 1 bag's messages are ROS 1, a
        table's are none.
    force:
        Replace an existing file, or a ROS 2 bag folder hybridlog wrote.
    inputs:
        ``(what, path)`` pairs the log must not touch (see :func:`check_log_target`).
    progress:
        Called with the rows written so far, every :data:`PROGRESS_ROWS` rows and at the
        end, as a bag or MCAP file is written a message at a time (a table is written at
        once): about 6 µs a message, a minute for 10^6 rows of eight topics.

    Returns
    -------
    pathlib.Path
        What was written.

    Raises
    ------
    OptionError, OutputError
        As :func:`check_log_target`; ``OutputError`` also when the log cannot be written.
    """
    import numpy as np

    from hybridlog.io.source import seconds_to_ns
    from hybridlog.io.writers import write_table

    chosen = check_log_target(path, format=format, encoding=encoding, force=force, inputs=inputs)
    if "t" not in columns:
        raise ValueError("columns: a time column 't' is needed")
    time = np.asarray(columns["t"], dtype=np.float64)
    _check_times(path, chosen, time)
    if chosen in ("csv", "parquet"):
        return write_table(path, columns, force=force)
    topics = log_topics(columns, truth, path=path)
    rows = _rows(topics, columns, seconds_to_ns(time), progress)
    writer: Callable[[Path, Sequence[TopicColumn], Iterable[_Row]], None]
    if chosen == "mcap":
        writer = _MCAP_WRITERS[encoding or "cdr"]
    elif chosen == "bag":
        writer = _write_ros1_bag
    else:
        writer = _ros2_writer(chosen.removeprefix("ros2-"))
    target = Path(path)
    if chosen.startswith("ros2-"):
        folder = output_path(target)
        # an existing folder (empty, or a bag of ours with --force) is filled in place, so
        # the staging folder is made inside it, on its file system (a mount point's)
        with staging_dir(folder, inside=folder.is_dir()) as area:
            # rosbag2 names its storage file after the folder: its name as the system
            # resolves it (``out/..`` has none of its own), so the staged bag's files carry
            # the names they have in ``folder``
            staged = area / folder.name
            _written(target, lambda: writer(staged, topics, rows))
            publish_dir(
                staged,
                folder,
                force=force,
                ours=written_by_hybridlog,
                written=bag_files,
                recognised_by="metadata.yaml",
            )
    else:
        with atomic_files([target], force=force) as (staged,):
            _written(target, lambda: writer(staged, topics, rows))
    return target


#: Times a log holds, in seconds, from 0 to before these: int64 nanoseconds, as hybridlog
#: reads every log (and MCAP files and ROS 2 bags store times), up to 9.2e9 s; a ROS 1 bag's
#: seconds are unsigned 32-bit.
_TIMES_BEFORE_S = {"bag": float(2**32)}
_NS_TIMES_BEFORE_S = 9.2e9


def times_before(format: str) -> float:
    """The time (s) every time of a log of ``format`` (:data:`LOG_FORMATS`) comes before."""
    return _TIMES_BEFORE_S.get(format, _NS_TIMES_BEFORE_S)


#: Bytes a message costs the writer of a log format until the log is closed, beyond its
#: value: rosbags' ROS 1 bag writer keeps an index entry per message (measured: 104 bytes a
#: message, three-tank runs of 8 topics and ``bioplex_pgc`` runs of 18; with a margin).  The
#: MCAP writers (mcap's, rosbags' for a ROS 2 bag) write their indexes a chunk at a time,
#: the sqlite3 storage holds none in memory, and a table has no messages: measured, their
#: peaks grow with the rows' values alone.
_MESSAGE_BYTES = {"bag": 128}


def message_bytes(format: str) -> int:
    """Bytes a message of a log of ``format`` (:data:`LOG_FORMATS`) costs its writer, held."""
    return _MESSAGE_BYTES.get(format, 0)


def _check_times(path: PathLike, chosen: str, time: Any) -> None:
    """Refuse times a log of format ``chosen`` cannot hold, or hybridlog could not read back.

    Raises
    ------
    OptionError
        For a time before 0 or too late for the format, naming the file and the time.
    """
    import numpy as np

    from hybridlog.io.formats import get_format
    from hybridlog.io.source import seconds_to_ns

    before = times_before(chosen)
    held = (time >= 0.0) & (time < before)
    what = get_format(_READ_AS.get(chosen, "ros2-bag")).what
    if not held.all():
        raise OptionError(
            f"{path}: t = {format_time(time[~held][0])} s is beyond the times {what} holds "
            f"(from 0 to before {before:.10g} s)"
        )
    steps = np.diff(time)
    steps = steps[steps > 0.0]
    if chosen in ("csv", "parquet") or not steps.size or steps.min() >= _EXACT_STEP_S:
        return
    # Messages are logged at integer nanoseconds: a step of 1.5 ns became 2, 1, 2, 1 ns.
    whole = np.floor(time)
    off = np.abs((seconds_to_ns(time) - seconds_to_ns(whole)) * 1e-9 - (time - whole))
    worst = int(np.argmax(off))
    smallest = float(steps.min())
    if off[worst] > _NS_TOLERANCE * smallest:
        raise OptionError(
            f"{path}: t = {format_time(float(time[worst]), below_ns=True)} s is "
            f"{float(off[worst]) * 1e9:.2g} ns off "
            f"the whole nanoseconds {what} holds its times in, too much for steps of "
            f"{smallest:.6g} s; use a dt of whole nanoseconds, or write a CSV or Parquet log"
        )


_NS_TOLERANCE = 1e-3
#: Steps (s) from which the nanosecond rounding of message times (at most 0.5 ns) is always
#: within :data:`_NS_TOLERANCE` of a step, as the readers' clock tolerance (dt/1000) takes it.
_EXACT_STEP_S = 0.5e-9 / _NS_TOLERANCE


#: ``version`` of the ``metadata.yaml`` of the ROS 2 bags written: 8, which every ROS 2
#: distribution from Humble on reads.  rosbags writes 8 or 9; version 9 (rosbag2 of Jazzy on)
#: writes a topic's ``offered_qos_profiles`` as a YAML list, which Humble's and Iron's
#: ``ros2 bag`` cannot parse ("yaml-cpp: ... bad conversion"), while version 8 writes it as
#: the string they expect (empty: default QoS) and later distributions still read it.  A bag
#: of ours has no QoS profiles to record, so version 9 would hold nothing more.
BAG_VERSION: Final[Literal[8]] = 8

#: ``custom_data`` entry of the ``metadata.yaml`` of every ROS 2 bag ``simulate`` writes: a
#: bag folder carries no file of hybridlog's own, so ``--force`` knows it by this.
BAG_WRITER = ("written_by", "hybridlog")


def written_by_hybridlog(folder: Path) -> bool:
    """Whether ``folder`` is a ROS 2 bag that hybridlog wrote (see :data:`BAG_WRITER`).

    A conservative check of the text rosbags' writer puts in ``metadata.yaml`` (the entry
    right under ``custom_data:``); any other layout counts as someone else's bag.
    """
    key, value = BAG_WRITER
    try:
        text = (folder / "metadata.yaml").read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return False
    return (
        re.search(rf"^  custom_data:\n(    \w+: .*\n)*    {key}: {value}$", text, re.M) is not None
    )


def bag_files(folder: Path) -> Collection[str] | None:
    """The files a ROS 2 bag folder consists of: ``metadata.yaml`` and its storage files.

    Read from the ``relative_file_paths`` list of ``metadata.yaml``, as rosbags writes it;
    None when there is no such list (then nothing is known to be foreign).
    """
    try:
        text = (folder / "metadata.yaml").read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None
    listed = re.search(r"^  relative_file_paths:\n((?:  - .*\n)*)", text, re.M)
    if listed is None:
        return None
    return {"metadata.yaml", *(line[4:].strip() for line in listed.group(1).splitlines())}


def _written(target: Path, write: Callable[[], None]) -> None:
    """Run ``write``, turning what the writers raise on a failed write into ``OutputError``."""
    import sqlite3  # a ROS 2 bag's storage: "database or disk is full"

    try:
        write()
    except (OSError, ValueError, sqlite3.Error) as err:
        raise OutputError(f"{target}: cannot be written ({err})") from err
    except Exception as err:  # the bag writers raise their own WriterError classes
        if type(err).__name__ != "WriterError":
            raise
        raise OutputError(f"{target}: cannot be written ({err})") from err


_Row = tuple[int, int, Any]
"""A message to write: ``(log time in ns, topic index, value)``."""

PROGRESS_ROWS = 1024
"""How many rows :func:`write_log` writes between two calls of its ``progress``."""


def _rows(
    topics: Sequence[TopicColumn],
    columns: Mapping[str, Column],
    time_ns: Any,
    progress: Callable[[int], None] | None,
) -> Iterator[_Row]:
    """``(log time, topic index, value)`` row by row, topics in column order.

    ``progress`` is told the rows yielded whole, every :data:`PROGRESS_ROWS` and at the end.
    """
    values = [columns[t.column] for t in topics]
    stamps = time_ns.tolist()
    for k, stamp in enumerate(stamps):
        for j, column in enumerate(values):
            yield stamp, j, column[k]
        if progress is not None and (k + 1) % PROGRESS_ROWS == 0:
            progress(k + 1)
    if progress is not None:
        progress(len(stamps))


def _typestore(ros1: bool) -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.LATEST)


def _serializer(msgtype: str, encoding: str) -> Callable[[Any], bytes]:
    """Serialise a value as a ``std_msgs`` ``Float64``/``String`` message."""
    if encoding == "json":
        return lambda value: json.dumps({"data": _plain(value)}).encode()
    if msgtype == FLOAT64:
        if encoding == "cdr":
            return lambda value: _CDR_LE + _F64.pack(float(value))
        return lambda value: _F64.pack(float(value))

    def string(value: Any) -> bytes:
        data = str(value).encode()
        if encoding == "cdr":
            return _CDR_LE + _U32.pack(len(data) + 1) + data + b"\x00"
        return _U32.pack(len(data)) + data

    return string


def _plain(value: Any) -> Any:
    import numpy as np

    return value.item() if isinstance(value, np.generic) else value


def _write_mcap(
    path: Path, topics: Sequence[TopicColumn], rows: Iterable[_Row], encoding: str
) -> None:
    from mcap.writer import CompressionType, Writer

    profile = {"cdr": "ros2", "ros1": "ros1", "json": ""}[encoding]
    store = _typestore(ros1=encoding == "ros1") if encoding != "json" else None
    with path.open("xb") as handle:
        writer = Writer(handle, compression=CompressionType.ZSTD, enable_data_crcs=True)
        writer.start(profile=profile, library=f"hybridlog {__version__}")
        schema_ids: dict[str, int] = {}
        channels: list[int] = []
        serializers = []
        for topic in topics:
            if topic.msgtype not in schema_ids:
                schema_ids[topic.msgtype] = _register_schema(writer, store, topic.msgtype, encoding)
            channels.append(
                writer.register_channel(topic.topic, encoding, schema_ids[topic.msgtype])
            )
            serializers.append(_serializer(topic.msgtype, encoding))
        for sequence, (stamp, j, value) in enumerate(rows, 1):
            writer.add_message(channels[j], stamp, serializers[j](value), stamp, sequence)
        writer.finish()  # type: ignore[no-untyped-call]


def _register_schema(writer: Any, store: Any, msgtype: str, encoding: str) -> int:
    if encoding == "json":
        data = json.dumps(_JSON_SCHEMAS[msgtype]).encode()
        return int(writer.register_schema(msgtype, "jsonschema", data))
    ros1 = encoding == "ros1"
    text, _ = store.generate_msgdef(msgtype, ros_version=1 if ros1 else 2)
    name = msgtype.replace("/msg/", "/") if ros1 else msgtype
    return int(writer.register_schema(name, "ros1msg" if ros1 else "ros2msg", text.encode()))


_MCAP_WRITERS: dict[str, Callable[[Path, Sequence[TopicColumn], Iterable[_Row]], None]] = {
    encoding: (lambda e: lambda p, t, r: _write_mcap(p, t, r, e))(encoding)
    for encoding in MCAP_ENCODINGS
}


def _write_ros1_bag(path: Path, topics: Sequence[TopicColumn], rows: Iterable[_Row]) -> None:
    from rosbags.rosbag1 import Writer

    store = _typestore(ros1=True)
    with Writer(path) as writer:
        connections = [writer.add_connection(t.topic, t.msgtype, typestore=store) for t in topics]
        serializers = [_serializer(t.msgtype, "ros1") for t in topics]
        for stamp, j, value in rows:
            writer.write(connections[j], stamp, serializers[j](value))


def _ros2_writer(storage: str) -> Callable[[Path, Sequence[TopicColumn], Iterable[_Row]], None]:
    def write(path: Path, topics: Sequence[TopicColumn], rows: Iterable[_Row]) -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer

        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        store = _typestore(ros1=False)
        with Writer(path, version=BAG_VERSION, storage_plugin=plugin) as writer:
            writer.set_custom_data(*BAG_WRITER)
            connections = [
                writer.add_connection(t.topic, t.msgtype, typestore=store) for t in topics
            ]
            serializers = [_serializer(t.msgtype, "cdr") for t in topics]
            for stamp, j, value in rows:
                writer.write(connections[j], stamp, serializers[j](value))

    return write
