"""What every log of messages shares: topics, message paths, batched decoding, time order.

:class:`MessageSource` implements :class:`~hybridlog.io.source.LogSource` for logs made of
timestamped messages on topics (ROS 1 and ROS 2 bags, MCAP).  A subclass opens the file,
describes its topics (:class:`~hybridlog.io.message_topics.Topic`) and yields raw messages;
everything else is here and in the modules named below:

- Fields are message paths (:mod:`.message_paths`), checked against the topics' message
  definitions before anything is read, so that a wrong name is reported with the close ones.
- Only the topics of the mapped paths are read, in one pass.  Their serialised messages are
  collected in batches (at most 65,536 messages or 16 MiB per topic); each batch is
  deserialised (rosbags' deserialisers for CDR and ROS 1, which refuse bytes that do not fit
  the definition) and reduced to the requested numbers, 128 messages at a time
  (:data:`~hybridlog.io.topic_reader.DECODED_AT_ONCE`), so memory grows with the selected
  signals, not with the file; where every path is a number field of such a message, each
  message is reduced to its numbers as it is decoded, none kept
  (``topic_reader.TopicReader._add_numbers_streamed``).
  A message that cannot be decoded or read is named by its log time.
- Time: ``--time log`` (default) takes the recorder's log time.  Messages are taken in log-time
  order, the order every ROS and MCAP player replays them; files read sequentially are put in
  that order (stably) when they are not already.  ``--time header`` takes each message's
  ``header.stamp``; a topic whose stamps go backwards (in log-time order) is refused unless
  ``--sort``.  Two messages of one topic with the same time are refused unless ``--sort``,
  which keeps the last of them (with ``--drop-nonfinite``, per field the last usable one,
  the NaN ones left for :func:`~hybridlog.io.load_signals` to drop and count).
- A JSON message may leave a field out: a logger of sparse signals writes ``{"u": 1}``, then
  ``{"y": 10}`` on one topic.  A field is then read from the messages that carry it, at their
  times, as a signal of its own (times checked, sorted and de-duplicated per field); a key the
  topic's JSON schema lists as ``required`` must be in every message, and a field no message
  carries is an error listing the fields found.  ``null`` is never "no sample": JSON writers
  write NaN and inf so, and it is one of them: refused, or dropped and counted with
  ``--drop-nonfinite``, and counted as non-finite by ``inspect``.
- When the file says how many messages a topic has (MCAP summary, bag index, ``metadata.yaml``),
  the messages read must add up to it: a damaged index that hides messages is an error.

Where the pieces are: :mod:`.message_topics` (a topic, its fields, paths spelled with their
topic quoted where nested topics make them alike), :mod:`.topic_reader` (one topic's batches
decoded into the wanted values, then series in time order), :mod:`.header_stamps`
(``header.stamp`` read, checked and described), :mod:`.value_counter` (``inspect``'s counts of
values), :mod:`.message_leaves` (the leaves of ROS messages, inside arrays of messages too),
:mod:`.json_schemas` and :mod:`.json_values` (JSON messages' schemas and decoded values).
"""

from __future__ import annotations

import abc
from array import array
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import numpy as np

from hybridlog.errors import HybridlogError, LogError, excerpt
from hybridlog.io.definitions import library_reason
from hybridlog.io.header_stamps import HEADER_STAMP
from hybridlog.io.json_schemas import MAX_JSON_DEPTH, json_kind, json_leaves
from hybridlog.io.mcap_side_records import SideRecords
from hybridlog.io.message_paths import (
    MessagePath,
    PathError,
    check_path,
    format_steps,
    from_the_start,
    split_path,
    split_paths,
)
from hybridlog.io.message_topics import (
    Topic,
    field_hint,
    foxglove_form,
    shared_paths,
    spelt_path,
    topic_fields,
)
from hybridlog.io.options import ReadOptions
from hybridlog.io.source import (
    FieldKey,
    LabelSeries,
    Reading,
    Series,
    SourceInfo,
    format_ns,
    seconds_of,
)
from hybridlog.io.summary import describe_steps
from hybridlog.io.topic_reader import TopicReader
from hybridlog.io.value_counter import ValueCounter
from hybridlog.signals import IntArray

BATCH_MESSAGES = 65_536


BATCH_BYTES = 16 * 2**20


_LATEST_NS = 2**63 - 1
"""The latest log time (ns) hybridlog holds: its time arrays are int64."""

_BYTES = (bytes, bytearray, memoryview)
"""What a message's serialised data may be, as the libraries return it."""

_KINDS: dict[type, str] = {str: "text", int: "a number", float: "a number", type(None): "NULL"}
"""What else a sqlite3 column gives, in words."""


class MessageSource(abc.ABC):
    """Base of the message-log readers: a :class:`~hybridlog.io.source.LogSource`.

    Subclasses fill ``_topics`` when opened (and may refine ``_format``), implement
    :meth:`_iter_raw` and :meth:`close`, and may word :meth:`_damaged` and
    :meth:`_recover_hint` for their format.  Messages are only ever read through
    :meth:`_messages`, which turns whatever the library raises on a damaged file into a
    :class:`~hybridlog.errors.LogError`.

    Parameters
    ----------
    path:
        The log.
    options:
        How to read it (``time``, ``sort``, ``recover`` and ``msg_dirs`` are used).
    format_name:
        The format for reports and ``inspect`` (a row name of the table of formats).
    """

    def __init__(self, path: str | Path, options: ReadOptions | None, format_name: str) -> None:
        self._file = Path(path)
        self.options = options or ReadOptions()
        self._format = format_name
        self._topics: dict[str, Topic] = {}
        self._notes: dict[str, Any] = {}
        self._problems: list[str] = []
        # Format details for ``describe`` (e.g. an MCAP file's profile).
        self._details: dict[str, Any] = {}

    # ------------------------------------------------------------------ subclass hooks

    @abc.abstractmethod
    def _iter_raw(self, topics: set[str]) -> Iterator[tuple[str, int, bytes]]:
        """Yield ``(topic, log_time_ns, serialised message)`` for the named topics."""

    def _damaged(self, err: BaseException) -> LogError:
        """The error for a file the library could not read to the end."""
        return LogError(f"{self.path}: damaged {self._format} file ({library_reason(err)})")

    def _recover_hint(self, topic: str, found: int) -> str:
        """A hint for a topic with fewer messages than the index lists ("" when none helps)."""
        return ""

    def _messages(self, topics: set[str]) -> Iterator[tuple[str, int, bytes]]:
        """:meth:`_iter_raw`, with whatever the library raises turned into a :class:`LogError`.

        This is the one place where reading a damaged file fails: the libraries below raise
        assorted exceptions on corrupt bytes (``OverflowError``, ``struct.error``,
        ``KeyError``, decompression errors ...), so everything but hybridlog's own errors is
        caught around the library's iteration (the checks here raise hybridlog's own errors only)
        and reported as a damaged file.
        """
        try:
            # One loop inside the ``try``: what the body raises is hybridlog's own (re-raised
            # as it is), and what the consumer raises never enters this generator.  A
            # ``next`` in a ``try`` of its own for every message took 2.90 s against 2.72 s
            # for this over 10^6 messages (the PointStamped file of benchmarks/read_logs.py).
            for item in self._iter_raw(topics):
                log_time = item[1]
                if type(log_time) is not int and not isinstance(log_time, int | np.integer):
                    # a sqlite3 column holds anything
                    raise LogError(
                        f"{self.path}: topic {item[0]!r}: a message's log time, "
                        f"{excerpt(log_time, 40)}, is not a whole number of nanoseconds"
                    )
                if log_time > _LATEST_NS:  # an unsigned 64-bit log time int64 cannot hold
                    raise LogError(
                        f"{self.path}: topic {item[0]!r}: a message's log time, {log_time} ns, "
                        "is after the year 2262 (2^63 ns), which no clock records: a damaged or "
                        "mis-stamped log"
                    )
                data = item[2]
                if type(data) is not bytes and not isinstance(data, _BYTES):
                    # a sqlite3 column holds anything: text was taken for bytes, a traceback
                    raise LogError(
                        f"{self.path}: topic {item[0]!r}: the message logged at "
                        f"t={format_ns(log_time)} s is {_KINDS.get(type(data), 'a value')}"
                        f"{'' if data is None else f' ({excerpt(data, 40)})'}, not serialised "
                        "bytes"
                    )
                yield item
        except HybridlogError:
            raise
        except Exception as err:  # corrupt bytes make the libraries raise anything
            raise self._damaged(err) from err

    # ------------------------------------------------------------------ LogSource

    @property
    def info(self) -> SourceInfo:
        """Path and format; fields are message paths."""
        return SourceInfo(self.path, self._format, message_paths=True)

    @property
    def path(self) -> str:
        """The log's path as given."""
        return str(self._file)

    @property
    def topics(self) -> dict[str, Topic]:
        """The log's topics by name."""
        return self._topics

    def __enter__(self) -> Self:
        """Return the opened source."""
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """Release the file (subclasses close their readers)."""
        self.close()

    @abc.abstractmethod
    def close(self) -> None:
        """Release what the source holds."""

    def fields(self) -> tuple[str, ...]:
        """Numeric and text leaves of every topic's messages, as message paths."""
        leaves = {name: topic_fields(self._topics[name]) for name in sorted(self._topics)}
        shared = shared_paths(leaves)
        out: list[str] = []
        for name, found in leaves.items():
            out.extend([spelt_path(name, leaf, shared) for leaf in found] or [name])
        return tuple(out)

    def explain_missing(self, name: str, numeric: bool = False) -> str | None:
        """``None`` when ``name`` is a usable path (a number, with ``numeric``), else why not.

        With ``--time header``, a path is usable only on a topic with ``header.stamp``.
        """
        try:
            path = self.resolve(name, "number" if numeric else "any")
        except PathError as err:
            return str(err)
        if self.options.time == "header":
            try:
                self._check_header(self._topics[path.topic])
            except LogError as err:
                return str(err).removeprefix(f"{self.path}: ")
        return None

    def field_key(self, name: str) -> FieldKey:
        """The topic and steps ``name`` reads (:meth:`LogSource.field_key`)."""
        try:
            path = self.resolve(name, "any")
        except PathError:
            return name, ()
        topic = self._topics[path.topic]
        if topic.typedefs is None:  # JSON: arrays of any length
            return path.topic, path.steps
        return path.topic, from_the_start(topic.typedefs, topic.msgtype, path.steps)

    def resolve(self, text: str, want: str) -> MessagePath:
        """Parse a path and check it against the topic's definition.

        Where topics nest (``/robot`` and ``/robot/pose``; ``/a`` and ``/a.b`` in an MCAP
        file), the path is read on the longest topic it starts with, or on the one topic
        whose definition has the field, the Foxglove form (``/robot/pose.pose``) before the
        ``/field`` alias (``/robot`` + ``/pose.pose``); a path that still names a field of two
        topics is refused, with each reading spelled with its topic quoted (``"/a.b".v``).
        A field counts whatever it holds: a text field where a number is wanted is refused
        as text, never passed over for another topic's number.

        Parameters
        ----------
        text:
            The path.
        want:
            ``"number"``, ``"label"`` (a number or a string) or ``"any"`` (either).

        Raises
        ------
        PathError
            Naming the path and what is wrong, with close names where that helps.
        """
        readings = split_paths(text, list(self._topics))
        fitting: list[MessagePath] = []
        errors: list[PathError] = []
        for rank, path in enumerate(readings):
            try:
                # a text field counts as one where numbers are wanted: '/a/b.v' (text) beside
                # '/a' + '.b.v' (a number) was read on '/a' without a word; checked below
                known = self._check(text, path, "any")
            except PathError as err:
                errors.append(err)
                continue
            if known or rank == 0:  # a shorter topic counts where its definition says so
                fitting.append(path)
        if not fitting:  # the longest reading failed: its error
            raise errors[0]
        foxglove = [p for p in fitting if foxglove_form(p)]
        fitting = foxglove or fitting  # the /field alias only where Foxglove's form fits none
        if len(fitting) > 1:
            spelled = [
                f"field {format_steps(p.steps).removeprefix('.')!r} of topic {p.topic!r} "
                f'("{p.topic}"{format_steps(p.steps)})'
                for p in fitting
            ]
            raise PathError(
                f"{text!r} names {len(fitting)} fields: {' and '.join(spelled)}; "
                "quote the topic of the one meant"
            )
        self._check(text, fitting[0], want)
        return fitting[0]

    def _check(self, text: str, path: MessagePath, want: str) -> bool:
        """Check one reading of a path; whether the topic's definition knows the field.

        Raises
        ------
        PathError
            When the reading names no usable field of its topic.
        """
        topic = self._topics[path.topic]
        if topic.problem:
            raise PathError(f"topic {topic.label}: {topic.problem}")
        kind: str | None = None
        type_name = ""
        try:
            if topic.typedefs is not None:
                target = check_path(topic.typedefs, topic.msgtype, path.steps)
                kind, type_name = target.kind, target.type_name
            elif topic.json_schema is not None:
                kind = json_kind(topic.json_schema, path.steps)
                type_name = kind or ""
        except PathError as err:
            raise PathError(f"{text!r}: {err}") from None
        if not path.steps:
            raise PathError(
                f"{text!r} names a whole message of topic {topic.label}; {field_hint(topic)}"
            )
        if kind == "message":
            raise PathError(
                f"{text!r} is a message ({type_name}), not a number; name a field in it"
            )
        if kind == "array":
            raise PathError(f"{text!r} is an array of {type_name}; add an index, e.g. {text}[0]")
        if kind == "string" and want == "number":
            raise PathError(f"{text!r} is a string, not a number")
        return kind is not None

    # ------------------------------------------------------------------ reading

    def read(self, numeric: Sequence[str], labels: Sequence[str] = ()) -> Reading:
        """Read the named message paths in one pass over the mapped topics.

        Raises
        ------
        LogError
            For a path that does not fit the log, an undecodable message, an index out of
            range, a topic without ``header.stamp`` under ``--time header``, times that go
            backwards or repeat (without ``--sort``), a count that differs from the index.
        """
        header = self.options.time == "header"
        readers: dict[str, TopicReader] = {}
        for text, want in [*((t, "number") for t in numeric), *((t, "label") for t in labels)]:
            try:
                path = self.resolve(text, want)
            except PathError as err:
                raise LogError(f"{self.path}: {err}") from None
            topic = self._topics[path.topic]
            reader = readers.get(topic.name)
            if reader is None:
                if header:
                    self._check_header(topic)
                reader = readers[topic.name] = TopicReader(self, topic, header)
            reader.want(text, path, want)
        if not readers:
            return Reading({}, {}, dict(self._notes))
        self._collect(readers)
        if not self.options.recover:
            for reader in readers.values():
                expected = reader.topic.count
                if expected is not None and reader.count != expected:
                    raise LogError(
                        f"{self.path}: topic {reader.topic.name!r}: {reader.count} messages "
                        f"found but the file's index lists {expected} (a damaged index or "
                        f"summary){self._recover_hint(reader.topic.name, reader.count)}"
                    )
        numeric_series: dict[str, Series] = {}
        label_series: dict[str, LabelSeries] = {}
        for reader in readers.values():
            numbers, texts = reader.series()
            numeric_series.update(numbers)
            label_series.update(texts)
        if header:
            self._notes["stamp_offsets"] = {
                name: seconds_of(reader.stamp_offset()) for name, reader in readers.items()
            }
        return Reading(numeric_series, label_series, dict(self._notes))

    def _check_header(self, topic: Topic) -> None:
        missing = f"topic {topic.label} has no header.stamp; --time header needs it on every "
        missing += "mapped topic (use --time log)"
        if topic.typedefs is not None:
            try:
                target = check_path(topic.typedefs, topic.msgtype, HEADER_STAMP)
            except PathError:
                raise LogError(f"{self.path}: {missing}") from None
            if target.kind not in ("message", "number"):
                raise LogError(f"{self.path}: {missing}")
        elif topic.json_schema is not None:
            try:
                json_kind(topic.json_schema, HEADER_STAMP)
            except PathError:
                raise LogError(f"{self.path}: {missing}") from None

    def _collect(self, readers: dict[str, TopicReader]) -> None:
        """One pass over the file, handing batches of raw messages to the topic readers."""
        buffers: dict[str, tuple[list[bytes], list[int], list[int]]] = {
            name: ([], [], [0]) for name in readers
        }
        for topic, log_time, data in self._messages(set(readers)):
            datas, times, size = buffers[topic]
            datas.append(data)
            times.append(log_time)
            size[0] += len(data)
            if size[0] >= BATCH_BYTES or len(datas) >= BATCH_MESSAGES:
                readers[topic].add(datas, times)
                buffers[topic] = ([], [], [0])
        for name, (datas, times, _) in buffers.items():
            if datas:
                readers[name].add(datas, times)

    # ------------------------------------------------------------------ inspect

    def describe(self) -> dict[str, Any]:
        """Summarise the log for ``hybridlog inspect``.

        One pass over every topic's messages: their log times are collected, and the
        messages of topics with fields that can hold NaN or infinities, or with
        ``header.stamp``, are decoded (512 at a time) to count those values and read the
        stamps (see :class:`ValueCounter`).

        Returns
        -------
        dict
            ``path, format, messages, topics`` (each ``name, type, encoding, count,
            indexed_count, start, end, duration``, the steps of its log times as
            :func:`~hybridlog.io.summary.describe_steps` gives them (``rate_hz``: the mean
            rate over the span, ``sample_time``: the median step, ``min_step``,
            ``max_step``, ``regular``, ``gap_count``, ``gaps``), ``nonfinite`` (NaN and
            infinite values in its fields), ``values`` (per field that can hold them:
            ``name, count, nonfinite``), ``undecodable`` (``count`` and ``first``, the
            earliest log time, of the messages that could not be decoded while others were,
            whose fields, values and stamps these are; else ``None``), ``header_stamp``
            (what ``--time header`` reads: ``start, end, offset, count``,
            :meth:`~hybridlog.io.header_stamps.HeaderStamps.describe`; ``None`` for a topic
            without ``header.stamp``), ``fields`` and ``arrays`` (per array of one length in
            every message, ``name``, ``elements`` and, of a few short texts, ``first``, the
            first message's, :meth:`ValueCounter.lengths`)), ``time`` (``start, end, duration``
            over all messages, or ``None``), ``problems`` and ``reading`` (what reading did,
            e.g. recovery).  Times are seconds as floats.  ``nonfinite`` and ``values`` are
            ``None`` for a topic whose messages cannot be decoded.
        """
        problems = list(self._problems)
        # 8 bytes a message: a list of Python integers took 40 (160 MB more for 4.4e6)
        times = {name: array("q") for name in self._topics}
        counters = {
            name: counter
            for name, topic in self._topics.items()
            if (counter := ValueCounter.of(topic)) is not None
        }
        try:
            for topic_name, log_time, data in self._messages(set(self._topics)):
                times[topic_name].append(log_time)
                counter = counters.get(topic_name)
                if counter is not None:
                    counter.add(data, log_time)
        except LogError as err:  # what was read before it is described, and said to be
            read = sum(len(t) for t in times.values())
            problems.append(
                f"{str(err).removeprefix(f'{self.path}: ')}; reading stopped there, after "
                f"{read} message{'' if read == 1 else 's'}: the counts and times above are of "
                "those"
            )
        # counts are checked against the index only where the file was read whole: a topic's
        # own problem (a schema passed over, a depth) must not skip the check of the next
        read_whole = not problems
        topics = []
        undecodable: list[str] = []
        start, end = None, None
        for name in sorted(self._topics):
            topic = self._topics[name]
            stamps = np.sort(np.frombuffer(times.pop(name), dtype=np.int64))
            info = _describe_times(stamps)
            if stamps.size:
                first, last = int(stamps[0]), int(stamps[-1])
                start = first if start is None else min(start, first)
                end = last if end is None else max(end, last)
            if topic.problem or topic.note:
                problems.append(f"topic {topic.label}: {topic.problem or topic.note}")
            elif topic.json_schema is not None and topic.typedefs is None:
                too_deep = json_leaves(topic.json_schema).too_deep
                if too_deep is not None:
                    problems.append(
                        f"topic {topic.label}: its JSON schema nests deeper than "
                        f"{MAX_JSON_DEPTH} levels at {excerpt(too_deep, 80)}; the fields below "
                        "are not listed"
                    )
            if topic.count is not None and topic.count != stamps.size and read_whole:
                problems.append(
                    f"topic {name!r}: {stamps.size} messages found but the index lists "
                    f"{topic.count}"
                )
            values: list[dict[str, Any]] | None = None  # not known: not decodable
            skipped: dict[str, Any] | None = None  # messages not decoded among others
            header_stamp: dict[str, Any] | None = None
            fields = topic_fields(topic)
            counter = counters.get(name)
            if counter is not None:
                values = counter.result()
                skipped = counter.skipped()
                if (said := counter.skipped_problem()) is not None:
                    undecodable.append(f"topic {topic.label}: {said}")
                if counter.problem is not None:
                    undecodable.append(f"topic {topic.label}: {counter.problem}")
                elif counter.stamps is not None:
                    header_stamp, stamp_problems = counter.stamps.describe(self.path)
                    problems.extend(stamp_problems)
                fields = _with_found_fields(topic, fields, counter.fields)
            topics.append(
                {
                    "name": name,
                    "type": topic.msgtype,
                    "encoding": topic.encoding,
                    "count": int(stamps.size),
                    "indexed_count": topic.count,
                    **info,
                    "nonfinite": None if values is None else sum(v["nonfinite"] for v in values),
                    "values": values,
                    "undecodable": skipped,
                    "header_stamp": header_stamp,
                    "fields": fields,
                    "arrays": [],
                }
            )
        shared = shared_paths({t["name"]: t["fields"] for t in topics})
        for entry in topics:  # a path two nested topics make alike: its topic quoted
            name = entry["name"]
            entry["fields"] = [spelt_path(name, leaf, shared) for leaf in entry["fields"]]
            for value in entry["values"] or []:
                value["name"] = spelt_path(name, value["name"].removeprefix(name), shared)
            counter = counters.get(name)
            if counter is not None and entry["values"] is not None:
                entry["arrays"] = [
                    {"name": spelt_path(name, path, shared), **length}
                    for path, length in counter.lengths().items()
                ]
                # what analyze refuses when the field is mapped, said before it is
                problems.extend(
                    f"{excerpt(spelt_path(name, path, shared))}: {text}"
                    for path, text in {
                        **counter.unheld,
                        **counter.mixed(),
                        **counter.uneven(),
                    }.items()
                )
        total = sum(t["count"] for t in topics)
        side = self._side_records()
        if side is not None and side.problem is not None:
            problems.append(side.problem)
        return {
            "path": self.path,
            "format": self._format,
            **self._details,
            "messages": total,
            "topics": topics,
            "time": None
            if start is None or end is None
            else {
                "start": seconds_of(start),
                "end": seconds_of(end),
                "duration": seconds_of(end - start),
            },
            "problems": [*problems, *undecodable],
            "reading": dict(self._notes),
            **({} if side is None else side.describe()),
        }

    def _side_records(self) -> SideRecords | None:
        """An MCAP file's attachments and metadata records; ``None`` for other formats."""
        return None


def _describe_times(stamps: IntArray) -> dict[str, Any]:
    """Span and steps of one topic's sorted log times (``None`` where there are none)."""
    span: dict[str, Any] = {"start": None, "end": None, "duration": None}
    if stamps.size:
        span["start"] = seconds_of(stamps[0])
        span["end"] = seconds_of(stamps[-1])
        span["duration"] = seconds_of(int(stamps[-1]) - int(stamps[0]))
    return {**span, **describe_steps(stamps)}


def _with_found_fields(topic: Topic, listed: list[str], found: Iterable[str]) -> list[str]:
    """A JSON topic's fields: those its schema lists, then those found in its messages.

    A schema need not list every key (JSON Schema closes an object only with
    ``"additionalProperties": false``); a key a closed object leaves out is not listed, as
    ``analyze`` refuses it.
    """
    out = dict.fromkeys(listed)
    for field in found:
        if field not in out and not _left_out(topic, field):
            out[field] = None
    return list(out)


def _left_out(topic: Topic, field: str) -> bool:
    """Whether ``topic``'s JSON schema refuses ``field`` (a key a closed object leaves out)."""
    if topic.json_schema is None:
        return False
    try:
        steps = split_path(topic.name + field.replace("[]", "[0]"), [topic.name]).steps
    except PathError:
        return False  # listed as found; a mapping of it says what is wrong
    try:
        json_kind(topic.json_schema, steps)
    except PathError:
        return True
    return False
