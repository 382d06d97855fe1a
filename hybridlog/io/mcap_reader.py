"""MCAP files: checks every MCAP gets, and the reader for those rosbags does not read.

:func:`check_mcap` runs before any MCAP is read, whichever library reads it: it refuses an
empty file and wrong magic bytes, tells a finished file (footer and closing magic) from one
whose recorder was killed or that was cut off, and validates the summary and data-section
CRCs when the writer stored them (the libraries' readers check chunk CRCs at most, and only
when asked).  A damaged summary section is read as an unfinished file is: its data section
holds every message.

``ros2``-profile files of chunks whose summary repeats every channel and schema and indexes
every chunk's messages -- what rosbag2 writes -- are then read by rosbags
(:mod:`.rosbag_reader`), which is faster; :func:`rosbags_summary_problem` says when a file is
not like that (rosbags then lists no topics or reads no messages).  :class:`McapSource` reads
everything else with the ``mcap`` library -- ROS 2 CDR, ROS 1 and JSON messages with any
profile -- validating chunk CRCs.  Channels and schemas need not be repeated in the summary
(the MCAP specification makes that optional): when they are not, the file is read
sequentially and they are taken from the data section.  The sequential reader is also what
``--recover`` uses on any MCAP: records are read in file order up to the first one that is
cut off or damaged, and no further than the data section's end (:func:`data_records`).

Message definitions come from the channels' schemas (``ros2msg``, ``ros2idl``, ``ros1msg``,
each parsed on its own by rosbags, see :mod:`.definitions`; a schema without text falls back
to ``--msg-dir`` and the standard types), and messages are decoded by rosbags, whose
deserialisers check that the definition accounts for every byte; JSON messages are parsed
with :mod:`json`.
"""

from __future__ import annotations

import json
import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from hybridlog.errors import HybridlogError, LogError, excerpt
from hybridlog.io.bag_qos import qos_problem
from hybridlog.io.definitions import (
    DefinitionError,
    definition_key,
    library_reason,
    normal_type,
    types_from_msg_dirs,
    typestore_for,
)
from hybridlog.io.formats import MCAP_MAGIC, LogFormat
from hybridlog.io.json_schemas import parse_json_schema, unread_schema
from hybridlog.io.mcap_side_records import SideRecords
from hybridlog.io.message_topics import Topic
from hybridlog.io.messages import MessageSource
from hybridlog.io.options import ReadOptions

_FOOTER_SIZE = 1 + 8 + 8 + 8 + 4  # opcode, length, summary_start, summary_offset_start, crc
_DATA_END_SIZE = 1 + 8 + 4
_OP_HEADER, _OP_FOOTER, _OP_DATA_END = 0x01, 0x02, 0x0F
_CRC_BLOCK = 1 << 22


@dataclass(frozen=True)
class McapLayout:
    """What :func:`check_mcap` found.

    Attributes
    ----------
    profile:
        The header's profile (``"ros2"``, ``"ros1"``, ``""`` ...), or ``None`` when the header
        itself is cut off.
    finished:
        Whether the file ends with a footer and the closing magic bytes.
    problem:
        Why it is not finished, for messages.
    summary_damaged:
        The file ends as a finished one does but its summary section (the index after the
        data section) is damaged: a stored CRC that does not match, an offset outside the
        file.  Its data section is read sequentially, as a file without footer is.
    """

    profile: str | None
    finished: bool
    problem: str | None = None
    summary_damaged: bool = False

    def finding(self) -> str:
        """What is wrong with a file that is not :attr:`finished`, for messages."""
        if self.summary_damaged:
            return f"damaged MCAP summary section ({self.problem})"
        return (
            f"unfinished MCAP file ({self.problem}: the recorder was killed or the file was "
            "cut off)"
        )


def check_mcap(path: Path) -> McapLayout:
    """Check an MCAP file's framing and stored CRCs (see the module docstring).

    Raises
    ------
    LogError
        For an empty file, wrong magic bytes, or a data-section CRC mismatch (no record of
        the section can be trusted).  A damaged summary section is no error here: the data
        section may be whole (:attr:`McapLayout.summary_damaged`).
    """
    try:
        size = path.stat().st_size
        with path.open("rb") as handle:
            return _check_open_mcap(path, handle, size)
    except OSError as err:
        raise LogError(f"{path}: cannot be read ({err.strerror})") from err


def _check_open_mcap(path: Path, handle: IO[bytes], size: int) -> McapLayout:
    if size == 0:
        raise LogError(f"{path}: empty file")
    head = handle.read(8)
    if head != MCAP_MAGIC:
        raise LogError(
            f"{path}: not an MCAP file (wrong magic bytes {head[:8]!r}, expected {MCAP_MAGIC!r})"
        )
    profile = _read_profile(handle)
    if size < 8 + _FOOTER_SIZE + 8:
        return McapLayout(profile, False, "the file ends before its footer")
    handle.seek(size - 8)
    if handle.read(8) != MCAP_MAGIC:
        return McapLayout(profile, False, "no closing magic bytes")
    footer_at = size - 8 - _FOOTER_SIZE
    handle.seek(footer_at)
    footer = handle.read(_FOOTER_SIZE)
    opcode, length, summary_start, _offsets, summary_crc = struct.unpack("<BQQQI", footer)
    if opcode != _OP_FOOTER or length != _FOOTER_SIZE - 9:
        return McapLayout(profile, False, "no footer record before the closing magic bytes")
    if summary_start and not 8 <= summary_start <= footer_at:
        return McapLayout(
            profile,
            False,
            f"its footer's summary offset {summary_start} is outside the file",
            summary_damaged=True,
        )
    if summary_start and summary_crc:
        actual = _crc(handle, summary_start, footer_at + 1 + 8 + 16)
        if actual != summary_crc:  # the offsets it covers locate nothing for sure
            return McapLayout(
                profile,
                False,
                f"CRC mismatch: stored 0x{summary_crc:08x}, computed 0x{actual:08x}",
                summary_damaged=True,
            )
    data_end_at = (summary_start or footer_at) - _DATA_END_SIZE
    if data_end_at >= 8:
        handle.seek(data_end_at)
        record = handle.read(_DATA_END_SIZE)
        op, record_length, data_crc = struct.unpack("<BQI", record)
        if op == _OP_DATA_END and record_length == 4 and data_crc:
            actual = _crc(handle, 0, data_end_at)
            if actual != data_crc:
                raise LogError(
                    f"{path}: CRC mismatch in the MCAP data section "
                    f"(stored 0x{data_crc:08x}, computed 0x{actual:08x}); the file is corrupt"
                )
    return McapLayout(profile, True)


def _read_profile(handle: IO[bytes]) -> str | None:
    record = handle.read(1 + 8 + 4)
    if len(record) < 13 or record[0] != _OP_HEADER:
        return None
    (length,) = struct.unpack_from("<I", record, 9)
    text = handle.read(length)
    if len(text) < length:
        return None
    return text.decode("utf-8", errors="replace")


def _crc(handle: IO[bytes], start: int, end: int) -> int:
    handle.seek(start)
    crc, remaining = 0, end - start
    while remaining > 0:
        block = handle.read(min(_CRC_BLOCK, remaining))
        if not block:
            break
        crc = zlib.crc32(block, crc)
        remaining -= len(block)
    return crc


def summary_problem(summary: Any) -> str | None:
    """Why an MCAP summary does not describe every channel and schema, or ``None``.

    The MCAP specification makes repeating channels and schemas in the summary optional;
    a reader that seeks with the summary alone then misses them.
    """
    if summary is None:
        return "it has no summary"
    referenced: set[int] = set()
    if summary.statistics is not None:
        referenced.update(summary.statistics.channel_message_counts)
    for chunk_index in summary.chunk_indexes:
        referenced.update(chunk_index.message_index_offsets)
    if not summary.channels or referenced - set(summary.channels):
        return "its summary does not repeat the channels"
    if any(c.schema_id and c.schema_id not in summary.schemas for c in summary.channels.values()):
        return "its summary does not repeat the schemas"
    return None


def _type_name(schema: Any) -> str:
    """The type a schema names, as rosbags names the types it parses (``pkg/msg/Name``).

    An ``omgidl`` schema names its type as IDL does, by its modules, ``foo::Point`` (the
    MCAP specification's form): rosbags names the struct of ``module foo { struct Point }``
    ``foo/Point``, so the name was "not its type" and every such topic undecodable.  A
    ``ros1msg`` name, ``std_msgs/Float64``, is ROS 2's ``std_msgs/msg/Float64``.
    """
    name = str(schema.name)
    if schema.encoding == "omgidl":
        return name.removeprefix("::").replace("::", "/")
    return normal_type(name)


_ROSBAGS_SCHEMAS = frozenset({"ros2msg", "ros2idl", "omgidl", ""})
"""Schema encodings rosbags' MCAP storage reader takes (any other refuses the whole file)."""


def rosbags_summary_problem(path: Path, *, storage: bool = False) -> str | None:
    """Why rosbags' MCAP reader would misread this finished ``ros2`` file, or ``None``.

    rosbags seeks with the summary only: it needs the channels and schemas repeated there
    and, for chunked files, message indexes (without them it reads no message of a chunk);
    it refuses a whole file for one channel of another encoding (a JSON or protobuf
    topic beside the CDR ones), which the ``mcap`` reader reads topic by topic; and it reads
    a file without chunks in file order, refusing it part way through at the first message
    logged before the one ahead of it (the MCAP specification allows any order), which the
    ``mcap`` reader's messages are put in log-time order after; and it refuses a file whose
    channels' QoS metadata it cannot parse (:func:`~.bag_qos.qos_problem`).

    Parameters
    ----------
    storage:
        ``path`` is a storage file of a bag folder, which only rosbags reads: a file without
        chunks is left to it (one out of log-time order is then refused naming the file,
        :meth:`~hybridlog.io.rosbag_reader.BagSource._damaged`).
    """
    from mcap.reader import SeekingReader

    try:
        with path.open("rb") as handle:
            summary = SeekingReader(handle).get_summary()
    except Exception as err:  # a summary the mcap library cannot read: let the reader say why
        return f"its summary cannot be read ({library_reason(err)})"
    problem = summary_problem(summary)
    if summary is None or problem is not None:
        return problem
    # A chunk of schemas and channels only (rosbags' writer makes one for a bag without
    # messages) has no messages to index: its start time is after its end time.
    if any(
        not c.message_index_offsets and c.message_start_time <= c.message_end_time
        for c in summary.chunk_indexes
    ):
        return "its chunks have no message indexes"
    if not summary.chunk_indexes and not storage:
        return "its messages are not in chunks, which rosbags reads only in log-time order"
    foreign = sorted(
        {s.encoding for s in summary.schemas.values() if s.encoding not in _ROSBAGS_SCHEMAS}
        | {c.message_encoding for c in summary.channels.values() if c.message_encoding != "cdr"}
    )
    if foreign:
        return f"it has channels that are not ROS 2 CDR ({', '.join(foreign)})"
    return qos_problem(
        ((c.topic, c.metadata.get("offered_qos_profiles")) for c in summary.channels.values()),
        noun="channel",
    )


def recover_hint(path: Path, topic: str, found: int) -> str:
    """``--recover``, suggested only when a sequential read finds more than ``found`` messages.

    For a topic with fewer messages than the summary lists: the summary may be what is
    damaged, and ``--recover`` reads the data section sequentially instead.
    """
    count = 0
    try:
        with path.open("rb") as handle:
            for _ in _sequential_messages(handle, {topic}):
                count += 1
    except Exception:  # counting stops where the file is damaged, as --recover does
        pass
    if count <= found:
        return ""
    return f"; --recover reads the file sequentially and finds {count}"


DATA_SECTION_END = "the end of the data section"
"""Where a sequential read that met no damaged record stops (``stopped_at`` of a report)."""


def data_records(handle: IO[bytes]) -> Iterator[Any]:
    """The records of an MCAP file's data section, in file order, from its start.

    A sequential read: chunks are opened and their CRCs checked (the mcap library's
    ``StreamReader``).  It ends at the data section's end record or the file's end, whichever
    comes first: what follows is the summary section, an index repeating schemas and
    channels, which a damaged summary could make disagree with the data section.  A
    channel whose schema, or a message whose channel, was not recorded before it (the MCAP
    specification requires them first) is a damaged record, as one the library refuses: a
    flipped id, which every reader of the file must stop at alike.

    Raises
    ------
    Exception
        Whatever the mcap library raises at the first record cut off or damaged;
        ``McapError`` for a record naming a schema or channel not recorded before it.
    """
    from mcap.exceptions import McapError
    from mcap.records import Channel, DataEnd, Message, Schema
    from mcap.stream_reader import StreamReader

    schemas: set[int] = set()
    channels: set[int] = set()
    handle.seek(0)
    for record in StreamReader(handle, validate_crcs=True).records:
        if isinstance(record, DataEnd):
            return
        if isinstance(record, Message) and record.channel_id not in channels:
            raise McapError(f"no channel record found with id {record.channel_id}")
        if isinstance(record, Channel):
            if record.schema_id and record.schema_id not in schemas:
                raise McapError(
                    f"no schema record found with id {record.schema_id}, which the channel "
                    f"of topic {excerpt(record.topic, 60)} names"
                )
            channels.add(record.id)
        elif isinstance(record, Schema):
            schemas.add(record.id)
        yield record


def _sequential_messages(handle: IO[bytes], topics: set[str]) -> Iterator[tuple[str, int, bytes]]:
    """``(topic, log time, data)`` of the messages on ``topics`` in :func:`data_records`.

    Raises
    ------
    Exception
        As :func:`data_records`.
    """
    from mcap.records import Channel, Message

    channels: dict[int, str] = {}
    for record in data_records(handle):
        if isinstance(record, Channel):
            channels[record.id] = record.topic
        elif isinstance(record, Message):
            topic = channels[record.channel_id]
            if topic in topics:
                yield topic, record.log_time, record.data


def _chunked_messages(
    handle: IO[bytes], summary: Any, topics: set[str]
) -> Iterator[tuple[str, int, bytes]]:
    """``(topic, log time, data)`` of the messages on ``topics`` in a chunked file, in file order.

    What the mcap library's ``SeekingReader.iter_messages(log_time_order=False)`` yields, in
    the same order (the summary's chunks, each chunk's records in turn), holding one chunk at
    a time: the library queues each chunk's messages behind the chunks still to read, so it
    read every chunk before it yielded a message -- ``analyze`` of a 77 MB file of
    2.9·10^6 messages took 1.2 GB, ``inspect`` of a 1.9 GB file 5.1 GB.  Chunks that
    index none of the topics' channels are not read.

    Raises
    ------
    Exception
        Whatever the mcap library raises on a damaged chunk (a CRC that does not match).
    """
    from mcap.data_stream import ReadDataStream
    from mcap.records import Chunk, Message
    from mcap.stream_reader import breakup_chunk

    wanted = {key: c.topic for key, c in summary.channels.items() if c.topic in topics}
    for index in summary.chunk_indexes:
        listed = index.message_index_offsets
        if listed and wanted.keys().isdisjoint(listed):
            continue
        handle.seek(index.chunk_start_offset + 1 + 8)  # past the opcode and record length
        chunk = Chunk.read(ReadDataStream(handle))
        for record in breakup_chunk(chunk, validate_crc=True):
            if isinstance(record, Message) and record.channel_id in wanted:
                yield wanted[record.channel_id], record.log_time, record.data


def count_readable(path: Path) -> tuple[int, str]:
    """Messages a sequential read gets out of ``path`` before it stops, and why it stops."""
    from mcap.records import Message

    count = 0
    try:
        with path.open("rb") as handle:
            for record in data_records(handle):
                if isinstance(record, Message):
                    count += 1
    except Exception as err:  # the first record that is cut off or corrupt ends the read
        return count, _stop_reason(err)
    return count, DATA_SECTION_END


def _stop_reason(err: BaseException) -> str:
    name = type(err).__name__
    if name == "EndOfFile" or isinstance(err, (EOFError, struct.error)):
        return "a record cut off at the end of the file"
    if name == "CRCValidationError":
        return f"a CRC mismatch ({library_reason(err)})"
    return f"a damaged record ({library_reason(err)})"


class UnfinishedLogError(LogError):
    """An MCAP file without its footer (cut off, or the recorder was killed).

    The message says what ``--recover`` would do; ``inspect``, which has no such option and
    reads the file sequentially anyway, says what is wrong with ``finding`` alone.

    Attributes
    ----------
    file:
        The unfinished MCAP file: the log, or the storage file of a ROS 2 bag folder.
    finding:
        What is wrong and how many messages are readable, without the log's name and
        without the hint.
    readable:
        How many messages a sequential read gets out of it.
    """

    def __init__(self, message: str, *, file: Path, finding: str, readable: int) -> None:
        super().__init__(message)
        self.file = file
        self.finding = finding
        self.readable = readable


def open_mcap(path: Path, options: ReadOptions, log_format: LogFormat) -> MessageSource:
    """The reader of an MCAP file: rosbags' where it reads the file right, else the mcap one.

    ``ros2``-profile files named ``.mcap`` whose summary indexes everything
    (:func:`rosbags_summary_problem`) go to :class:`~hybridlog.io.rosbag_reader.BagSource`;
    every other file, and any file with ``--recover``, to :class:`McapSource`.

    Raises
    ------
    LogError
        For a file :func:`check_mcap` refuses; :class:`UnfinishedLogError` for a file without
        footer (unless ``options.recover``), saying how many messages ``--recover`` would get.
    """
    layout = check_mcap(path)
    if options.recover:
        return McapSource(path, layout, options)
    if not layout.finished:
        readable, stop = count_readable(path)
        finding = f"{layout.finding()}; " + (
            f"{readable} messages are readable, up to {stop}"
            if readable
            else f"no message is readable (the read stops at {stop})"
        )
        hint = "; --recover analyses them" if readable else ", so --recover cannot help"
        raise UnfinishedLogError(
            f"{path}: {finding}{hint}", file=path, finding=finding, readable=readable
        )
    if (
        layout.profile == "ros2"
        # rosbags reads bare files by their suffix, in its case: x.MCAP (which simulate
        # writes, and reading takes as MCAP) it refused as "Unrecognized storage format"
        and path.suffix in log_format.suffixes
        and rosbags_summary_problem(path) is None
    ):
        from hybridlog.io.rosbag_reader import BagSource  # which imports this module's checks

        return BagSource(path, options, log_format)
    return McapSource(path, layout, options)


def _schema_key(schema: Any) -> tuple[str, str, str]:
    """A schema by what it says (:func:`~hybridlog.io.definitions.definition_key`)."""
    text = bytes(schema.data).decode("utf-8", errors="replace")
    return (schema.name, schema.encoding, definition_key(schema.encoding, text))


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object as a dict; a key given twice is refused (``json`` keeps the last)."""
    result = dict(pairs)
    if len(result) != len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise ValueError(f"the key {key!r} is given twice in one object")
            seen.add(key)
    return result


def _decode_json(data: bytes) -> Any:
    """A JSON message, refusing duplicate keys (which of the values is meant?).

    A message that is a bare value (a number, text, a boolean, null) is refused: ``--map``
    names the fields of an object or the elements of an array, and such a topic had no
    field for ``inspect`` to list nor any problem said.
    """
    message = json.loads(data, object_pairs_hook=_unique_keys)
    if not isinstance(message, dict | list):
        raise ValueError(
            f"the message is a bare {_BARE_JSON[type(message)]}, not a JSON object or array: "
            "--map names a field or an element of one"
        )
    return message


_BARE_JSON = {int: "number", float: "number", str: "string", bool: "boolean", type(None): "null"}
"""What :mod:`json` decodes a JSON value that is neither an object nor an array to."""


class McapSource(MessageSource):
    """An MCAP file read with the ``mcap`` library (see the module docstring).

    Parameters
    ----------
    path:
        The file.
    layout:
        What :func:`check_mcap` found.
    options:
        ``recover`` reads sequentially up to the first damaged record; ``msg_dirs`` adds types.

    Raises
    ------
    LogError
        When the file's summary or records cannot be read.
    """

    def __init__(
        self, path: str | Path, layout: McapLayout, options: ReadOptions | None = None
    ) -> None:
        super().__init__(path, options, "mcap")
        self._details["profile"] = layout.profile or ""
        self._sequential = self.options.recover or not layout.finished
        self._handle: IO[bytes] | None = None
        self._stop: str | None = None
        self._extra_types: dict[str, Any] | None = None
        self._stores: dict[int, Any] = {}
        # attachments and metadata records: collected by a sequential read, else walked for
        # when inspect asks (analyze never does)
        self._side: SideRecords | None = None
        try:
            self._handle = self._file.open("rb")
            schemas, channels, counts = self._structure()
            self._topics = self._make_topics(schemas, channels, counts)
        except HybridlogError:
            self.close()
            raise
        except OSError as err:
            self.close()
            raise LogError(f"{self.path}: cannot be read ({err.strerror})") from err
        except Exception as err:  # the mcap library raises assorted errors on corrupt bytes
            self.close()
            raise self._damaged(err) from err

    def close(self) -> None:
        """Close the file."""
        handle, self._handle = self._handle, None
        if handle is not None:
            handle.close()

    # -- structure

    def _structure(self) -> tuple[dict[int, Any], dict[int, Any], dict[int, int] | None]:
        """Schemas, channels and (when known) per-channel message counts."""
        from mcap.reader import SeekingReader

        assert self._handle is not None
        if self._sequential:
            return self._scan_structure()
        summary = SeekingReader(self._handle, validate_crcs=True).get_summary()
        counts = (
            dict(summary.statistics.channel_message_counts)
            if summary is not None and summary.statistics is not None
            else None
        )
        if summary is not None and summary_problem(summary) is None:
            return dict(summary.schemas), dict(summary.channels), counts
        # Channels and schemas live in the data section only: read it in file order.
        self._sequential = True
        schemas, channels, _ = self._scan_structure()
        return schemas, channels, counts

    def _scan_structure(self) -> tuple[dict[int, Any], dict[int, Any], dict[int, int] | None]:
        """One sequential pass: schemas, channels, and messages up to the first bad record."""
        from mcap.records import Channel, Message, Schema

        assert self._handle is not None
        schemas: dict[int, Any] = {}
        channels: dict[int, Any] = {}
        self._side = SideRecords()
        total = 0
        try:
            for record in data_records(self._handle):
                if isinstance(record, Message):
                    total += 1
                elif isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                else:
                    self._side.add(record)
        except Exception as err:  # the first record that is cut off or corrupt ends the read
            if not self.options.recover:
                raise
            self._stop = _stop_reason(err)
        if self.options.recover:
            if total == 0 and self._stop is not None:
                # else every mapped field is "missing; the log has none", hiding the damage
                raise LogError(
                    f"{self.path}: --recover reads no message (the sequential read stops at "
                    f"{self._stop}, before the first whole message)"
                )
            self._notes.update(
                {
                    "recovered": True,
                    "messages_readable": total,
                    "stopped_at": self._stop or DATA_SECTION_END,
                }
            )
        # Counts of a sequential read are what was read; there is no index to check against.
        return schemas, channels, None

    def _make_topics(
        self, schemas: dict[int, Any], channels: dict[int, Any], counts: dict[int, int] | None
    ) -> dict[str, Topic]:
        grouped: dict[str, list[Any]] = {}
        for channel in channels.values():
            grouped.setdefault(channel.topic, []).append(channel)
        topics: dict[str, Topic] = {}
        for name, group in grouped.items():
            channel = group[0]
            schema = schemas.get(channel.schema_id) if channel.schema_id else None
            count = None if counts is None else sum(counts.get(c.id, 0) for c in group)
            topic = self._topic(name, channel, schema, count)
            # Channels are told apart by what their schemas say, not by the schemas' ids: a
            # writer may record the same schema twice, which decodes the same.
            kinds: dict[tuple[tuple[str, str, str] | None, str], int | None] = {}
            for member in group:
                held = schemas.get(member.schema_id) if member.schema_id else None
                content = None if held is None else _schema_key(held)
                kind = (content, member.message_encoding)
                got = None if counts is None else counts.get(member.id, 0)
                known = kinds.get(kind, 0)
                kinds[kind] = None if got is None or known is None else known + got
            if len(kinds) > 1 and topic.problem is None:
                # the table shows the first channel's type: say what else the topic holds
                described = []
                for (content, encoding), kind_count in kinds.items():
                    named = normal_type(content[0]) if content is not None else "no schema"
                    text = f"{excerpt(named, 60)} in {excerpt(encoding, 20)}"
                    if kind_count is not None:
                        text += f" ({kind_count} message{'' if kind_count == 1 else 's'})"
                    described.append(text)
                listed = ", ".join(described)
                topic.problem = f"has channels with different schemas or encodings: {listed}"
            topics[name] = topic
        return topics

    def _topic(self, name: str, channel: Any, schema: Any, count: int | None) -> Topic:
        encoding = channel.message_encoding
        msgtype = _type_name(schema) if schema is not None else ""
        topic = Topic(name, msgtype, encoding, count)
        if encoding == "json":
            topic.decode = _decode_json
            if schema is not None and schema.encoding == "jsonschema":
                topic.json_schema = parse_json_schema(schema.data)
                if (unread := unread_schema(schema.data)) is not None:
                    topic.note = f"{unread}: passed over, the messages read as they are"
            return topic
        if encoding not in ("cdr", "ros1"):
            topic.problem = (
                f"message encoding {encoding!r} is not supported (supported: cdr, ros1, json)"
            )
            return topic
        if schema is None:
            topic.problem = "schemaless channel: its messages cannot be decoded"
            return topic
        ros1 = encoding == "ros1"
        try:
            store = self._store(schema, msgtype, ros1)
        except DefinitionError as err:
            topic.problem = str(err)
            return topic
        topic.typedefs = store.fielddefs
        if ros1:
            topic.decode = lambda data: store.deserialize_ros1(data, msgtype)
        else:
            topic.decode = lambda data: store.deserialize_cdr(data, msgtype)
        return topic

    def _store(self, schema: Any, msgtype: str, ros1: bool) -> Any:
        """The rosbags type store of one schema (cached per schema id).

        Raises
        ------
        DefinitionError
            When the schema's text cannot be parsed or the type is defined nowhere.
        """
        cached = self._stores.get(schema.id)
        if isinstance(cached, DefinitionError):
            raise cached
        if cached is not None:
            return cached
        if self._extra_types is None:
            self._extra_types = (
                types_from_msg_dirs(self.options.msg_dirs) if self.options.msg_dirs else {}
            )
        encoding = {"ros2msg": "msg", "ros1msg": "msg", "ros2idl": "idl", "omgidl": "idl"}
        try:
            # a schema of another kind (a protobuf FileDescriptorSet, binary) is not read
            text = schema.data.decode("utf-8") if schema.encoding in encoding else ""
            store = typestore_for(
                msgtype,
                encoding.get(schema.encoding, ""),
                text,
                ros1=ros1,
                extra=self._extra_types,
            )
        except UnicodeDecodeError:
            error = DefinitionError("its schema is not UTF-8 text")
            self._stores[schema.id] = error
            raise error from None
        except DefinitionError as err:
            if schema.encoding and schema.encoding not in encoding and schema.data:
                # "no definition in the log" of a log that holds a schema, of another kind
                err = DefinitionError(
                    f"{err} (the log's schema for it is {excerpt(schema.encoding, 20)}, "
                    "not a ROS message definition)"
                )
            self._stores[schema.id] = err
            raise err from None
        self._stores[schema.id] = store
        return store

    def _side_records(self) -> SideRecords:
        """Collected by a sequential read, else walked for (:meth:`SideRecords.walk`)."""
        if self._side is None:
            assert self._handle is not None
            self._side = SideRecords.walk(self._handle)
        return self._side

    # -- reading

    def _damaged(self, err: BaseException) -> LogError:
        if type(err).__name__ == "CRCValidationError":
            return LogError(
                f"{self.path}: CRC mismatch: the file is corrupt ({library_reason(err)})"
            )
        return LogError(f"{self.path}: damaged MCAP file ({library_reason(err)})")

    def _recover_hint(self, topic: str, found: int) -> str:
        """Suggest ``--recover`` only when a sequential read finds more of ``topic``."""
        return "" if self._sequential else recover_hint(self._file, topic, found)

    def _iter_raw(self, topics: set[str]) -> Iterator[tuple[str, int, bytes]]:
        from mcap.reader import SeekingReader

        if not topics:
            return
        assert self._handle is not None
        self._handle.seek(0)
        if not self._sequential:
            reader = SeekingReader(self._handle, validate_crcs=True)
            summary = reader.get_summary()
            if summary is not None and summary.chunk_indexes:
                yield from _chunked_messages(self._handle, summary, topics)
                return
            messages = reader.iter_messages(topics=frozenset(topics), log_time_order=False)
            for _, channel, message in messages:
                yield channel.topic, message.log_time, message.data
            return
        try:
            yield from _sequential_messages(self._handle, topics)
        except Exception:  # --recover: stop at the first record cut off or corrupt
            if not self.options.recover:
                raise
