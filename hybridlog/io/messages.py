"""What every log of messages shares: topics, message paths, batched decoding, time order.

:class:`MessageSource` implements :class:`~hybridlog.io.source.LogSource` for logs made of
timestamped messages on topics (ROS 1 and ROS 2 bags, MCAP).  A subclass opens the file,
describes its topics (:class:`Topic`) and yields raw messages; everything else is here:

- Fields are message paths (:mod:`.message_paths`), checked against the topics' message
  definitions before anything is read, so that a wrong name is reported with the close ones.
- Only the topics of the mapped paths are read, in one pass.  Their serialised messages are
  collected in batches (at most 65,536 messages or 16 MiB per topic); each batch is
  deserialised (rosbags' deserialisers for CDR and ROS 1, which refuse bytes that do not fit
  the definition) and reduced to the requested numbers, 128 messages at a time
  (:data:`DECODED_AT_ONCE`), so memory grows with the selected signals, not with the file;
  where every path is a number field of such a message, each message is reduced to its
  numbers as it is decoded, none kept (``_TopicReader._add_numbers_streamed``).
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
"""

from __future__ import annotations

import abc
import bisect
import json
import math
import operator
from array import array
from collections import Counter
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import numpy as np

from hybridlog.errors import HybridlogError, LogError, excerpt
from hybridlog.io.definitions import first_line
from hybridlog.io.exact import EXACT_LIMIT, beyond_exact, inexact
from hybridlog.io.fixed_messages import single_floats
from hybridlog.io.message_paths import (
    ARRAY,
    FLOAT_TYPES,
    NAME,
    NUMERIC_TYPES,
    SEQUENCE,
    Leaf,
    MessagePath,
    PathError,
    Step,
    Typedefs,
    UndecodableError,
    accessor,
    as_float_array,
    as_label,
    as_number,
    check_path,
    decode_each,
    evaluate,
    format_steps,
    from_the_start,
    leaf_value,
    leaves,
    spell_field,
    split_paths,
    stamp_ns,
)
from hybridlog.io.options import FAR_STAMP_S, ReadOptions
from hybridlog.io.source import (
    NS_PER_S,
    FieldKey,
    LabelSeries,
    Reading,
    Series,
    SourceInfo,
    closest_names,
    format_ns,
    last_of_each_time,
    seconds_of,
)
from hybridlog.io.summary import count_nonfinite, describe_steps
from hybridlog.signals import BoolArray, FloatArray, IntArray

BATCH_MESSAGES = 65_536
BATCH_BYTES = 16 * 2**20
DECODED_AT_ONCE = 128
"""Messages of a batch decoded at a time, each part reduced to its values before the next.

Decoded messages are objects the cyclic garbage collector tracks (a ``PointStamped`` is four);
a whole batch of them alive at once made each of its collections walk up to 65,536 messages
again: a ``PointStamped`` MCAP of 3·10^5 messages read in 2.07 s, against 1.52 s in parts of
512 (1.60 s in parts of 1,024; the same with 256).  A part this small dies young; smaller
still, fewer of its messages outlive the collector's first generation (700 objects): with
``--time header`` (``header.stamp`` read, so not the streamed numbers of
``_TopicReader._add_numbers_streamed``) 10^5 messages a topic took 2.31-2.65 s of CPU in parts
of 128 against 2.52-2.71 s in parts of 512 (alternating, three runs each, a loaded machine)."""
DECODED_BYTES_AT_ONCE = 16 * 1024 * 1024
"""... and at most about this many bytes of serialised messages (``inspect``): 512 camera
images of 6 MiB held at once, decoded for their stamps, made ``inspect`` of a 3.5 GB bag
peak at 6.3 GB (19.5 s, against 84 MB and 4.9 s before stamps were read)."""
HEADER_STAMP: tuple[Step, ...] = ("header", "stamp")
WIDE_INTEGER_TYPES = frozenset(("int64", "uint64"))
"""ROS integer types whose values may lie beyond 2^53, which a ``float64`` does not hold."""
MAX_JSON_DEPTH = 256
"""Nesting of a JSON message or schema (objects and arrays) that ``inspect`` walks; deeper
is reported as a problem of the topic, never cut silently.  Real documents are a few levels
deep; this guards the walk (Python's recursion) against a pathological one."""


class _BeyondFloat(float):
    """A JSON number too large for a float64: infinite, with the text it was written as."""

    written: str


def _float_or_written(text: str) -> float:
    """``json``'s ``parse_float`` keeping the text of a number that overflows to infinity."""
    value = float(text)
    if math.isfinite(value):
        return value
    beyond = _BeyondFloat(value)
    beyond.written = text
    return beyond


def _int_or_written(text: str) -> int | float:
    """``json``'s ``parse_int``: an integer beyond a float64's range kept as its text."""
    value = int(text)
    try:
        float(value)
    except OverflowError:
        beyond = _BeyondFloat(math.inf if value > 0 else -math.inf)
        beyond.written = text
        return beyond
    return value


@dataclass
class Topic:
    """One topic of a message log.

    Attributes
    ----------
    name:
        The topic name, e.g. ``/y1``.
    msgtype:
        Its message type, e.g. ``std_msgs/msg/Float64`` (``""`` when unknown).
    encoding:
        How its messages are serialised: ``"cdr"``, ``"ros1"``, ``"json"`` or another name.
    count:
        How many messages the file's index or summary lists, or ``None`` when it does not say.
    typedefs:
        rosbags field definitions that hold ``msgtype``, when the type's definition is known.
    decode:
        Decodes one serialised message into an object or ``dict`` (fallback path).
    problem:
        Why the topic's messages cannot be decoded (no schema, unknown encoding, no
        definition), or ``None``.
    json_schema:
        The topic's JSON schema, for JSON messages that have one.
    """

    name: str
    msgtype: str
    encoding: str
    count: int | None = None
    typedefs: Typedefs | None = None
    decode: Callable[[bytes], object] | None = None
    problem: str | None = None
    json_schema: Mapping[str, Any] | None = None

    @property
    def label(self) -> str:
        """``'/y1' (std_msgs/msg/Float64)`` for messages."""
        return f"{self.name!r} ({self.msgtype or 'no type'})"


_LATEST_NS = 2**63 - 1
"""The latest log time (ns) hybridlog holds: its time arrays are int64."""


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
        return LogError(f"{self.path}: damaged {self._format} file ({excerpt(first_line(err))})")

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
        leaves = {name: _topic_fields(self._topics[name]) for name in sorted(self._topics)}
        shared = _shared_paths(leaves)
        out: list[str] = []
        for name, found in leaves.items():
            out.extend([_spell(name, leaf, shared) for leaf in found] or [name])
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
        foxglove = [p for p in fitting if _foxglove_form(p)]
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
                kind = _json_kind(topic.json_schema, path.steps)
                type_name = kind or ""
        except PathError as err:
            raise PathError(f"{text!r}: {err}") from None
        if not path.steps:
            raise PathError(
                f"{text!r} names a whole message of topic {topic.label}; {_field_hint(topic)}"
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
        readers: dict[str, _TopicReader] = {}
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
                reader = readers[topic.name] = _TopicReader(self, topic, header)
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
                _json_kind(topic.json_schema, HEADER_STAMP)
            except PathError:
                raise LogError(f"{self.path}: {missing}") from None

    def _collect(self, readers: dict[str, _TopicReader]) -> None:
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
        stamps (see :class:`_ValueCounter`).

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
            (what ``--time header`` reads:
            ``start, end, offset, count``, :meth:`_Stamps.describe`; ``None`` for a topic
            without ``header.stamp``) and ``fields``), ``time`` (``start, end, duration``
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
            if (counter := _ValueCounter.of(topic)) is not None
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
            if topic.problem:
                problems.append(f"topic {topic.label}: {topic.problem}")
            elif topic.json_schema is not None and topic.typedefs is None:
                too_deep = _json_leaves(topic.json_schema).too_deep
                if too_deep is not None:
                    problems.append(
                        f"topic {topic.label}: its JSON schema nests deeper than "
                        f"{MAX_JSON_DEPTH} levels at {excerpt(too_deep, 80)}; the fields below "
                        "are not listed"
                    )
            if topic.count is not None and topic.count != stamps.size and not problems:
                problems.append(
                    f"topic {name!r}: {stamps.size} messages found but the index lists "
                    f"{topic.count}"
                )
            values: list[dict[str, Any]] | None = None  # not known: not decodable
            skipped: dict[str, Any] | None = None  # messages not decoded among others
            header_stamp: dict[str, Any] | None = None
            fields = _topic_fields(topic)
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
                # JSON without a schema: the fields its messages hold
                fields = fields or list(counter.fields)
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
                }
            )
        shared = _shared_paths({t["name"]: t["fields"] for t in topics})
        for entry in topics:  # a path two nested topics make alike: its topic quoted
            name = entry["name"]
            entry["fields"] = [_spell(name, leaf, shared) for leaf in entry["fields"]]
            for value in entry["values"] or []:
                value["name"] = _spell(name, value["name"].removeprefix(name), shared)
            counter = counters.get(name)
            if counter is not None and entry["values"] is not None:
                # what analyze refuses when the field is mapped, said before it is
                problems.extend(
                    f"{excerpt(_spell(name, path, shared))}: {text}"
                    for path, text in {**counter.unheld, **counter.mixed()}.items()
                )
        total = sum(t["count"] for t in topics)
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
        }


def _shared_paths(leaves: Mapping[str, Sequence[str]]) -> set[str]:
    """Paths of ``{topic: leaves}`` that must be written with their topic quoted.

    Those two topics make alike (``/a`` + ``.b.v``, ``/a.b`` + ``.v``), and those that
    :func:`split_paths` reads on another topic first, as ``--map`` would: ``/a`` + ``.v``
    where the log also has a topic ``/a.v``, and every path of a topic named ``""``.  A listed
    ``[]`` is read as the index it stands for: ``/imu.covariance[]`` beside a topic
    ``/imu_raw`` was quoted, as if no topic read it.
    """
    counts = Counter(name + leaf for name, found in leaves.items() for leaf in set(found))
    shared = {path for path, count in counts.items() if count > 1}
    ordered = sorted(leaves)
    for name, found in leaves.items():
        longer = _extensions(ordered, name)
        if name and not longer:
            continue  # no other topic starts its paths: each reads on it
        # split_paths reads a path on its longest topic first: the topic itself or one
        # that extends it (or, for a name in quotes, the topic it quotes); comparing with
        # these alone kept 20,000 topics from taking 50 s
        near = [name, *longer]
        if name.startswith('"'):
            near.extend(t for t in ordered if name.startswith(f'"{t}"'))
        for leaf in found:
            try:  # as --map takes it: a listed `[]` stands for an index
                first = split_paths(name + leaf.replace("[]", "[0]"), near)[0].topic
            except PathError:
                first = None
            if first != name:
                shared.add(name + leaf)
    return shared


def _extensions(ordered: Sequence[str], name: str) -> list[str]:
    """The topics of sorted ``ordered`` other than ``name`` that start with ``name``."""
    found = []
    at = bisect.bisect_left(ordered, name)
    while at < len(ordered) and ordered[at].startswith(name):
        if ordered[at] != name:
            found.append(ordered[at])
        at += 1
    return found


def _spell(topic: str, leaf: str, shared: set[str]) -> str:
    """``topic + leaf``, with the topic quoted (``"/a".b.v``) where another topic makes it too."""
    return f'"{topic}"{leaf}' if topic + leaf in shared else topic + leaf


def _foxglove_form(path: MessagePath) -> bool:
    """Whether ``path`` follows its topic with ``.field`` or ``[index]`` (not the ``/`` alias)."""
    text = path.text.strip()
    quoted = f'"{path.topic}"'
    rest = text[len(quoted) :] if text.startswith(quoted) else text[len(path.topic) :]
    return not rest.startswith("/")


def _topic_fields(topic: Topic) -> list[str]:
    """The paths (after the topic name) of the numeric and text leaves its definition has."""
    if topic.typedefs is not None and topic.msgtype in topic.typedefs:
        return [leaf.text for leaf in _deep_leaves(topic.typedefs, topic.msgtype)]
    if topic.json_schema is not None:
        return _json_leaves(topic.json_schema).leaves
    return []


def _field_hint(topic: Topic) -> str:
    """How to name a field of ``topic``: an example it has, else why none can be given."""
    fields = _topic_fields(topic)
    if topic.typedefs is not None and topic.msgtype in topic.typedefs:
        found = _deep_leaves(topic.typedefs, topic.msgtype)
        fields = [leaf.text for leaf in found if leaf.leaf.type_name in FLOAT_TYPES] or fields
    if fields:
        example = topic.name + fields[0].replace("[]", "[0]")
        more = f" ({len(fields)} fields; hybridlog inspect lists them)" if len(fields) > 1 else ""
        return f"add a field, e.g. {example}{more}"
    if topic.encoding == "json":
        return (
            "add a field of its JSON messages (the topic has no JSON schema listing them; "
            "hybridlog inspect lists the fields found in the messages)"
        )
    return f"its type {topic.msgtype or '(unknown)'} has no numeric or text field to map"


def _describe_times(stamps: IntArray) -> dict[str, Any]:
    """Span and steps of one topic's sorted log times (``None`` where there are none)."""
    span: dict[str, Any] = {"start": None, "end": None, "duration": None}
    if stamps.size:
        span["start"] = seconds_of(stamps[0])
        span["end"] = seconds_of(stamps[-1])
        span["duration"] = seconds_of(int(stamps[-1]) - int(stamps[0]))
    return {**span, **describe_steps(stamps)}


# ---------------------------------------------------------------------- values, for inspect


class _ValueCounter:
    """Counts the values of a topic's fields that can hold NaN or infinities, and those that do.

    For :meth:`MessageSource.describe`: fed the topic's serialised messages one by one, it
    decodes them :data:`DECODED_AT_ONCE` at a time and counts, per field, the values and the
    non-finite ones (:func:`~hybridlog.io.summary.count_nonfinite`).  The fields are the
    ``float32``/``float64`` leaves (scalars and arrays) of a ROS message definition, those
    inside arrays of messages included (``/tf.transforms[].transform.translation.x``, every
    element counted), or every number of a JSON message, inside arrays of objects too (JSON
    has one number type; Python's reader takes ``NaN`` and ``Infinity``).  A message that
    cannot be decoded, or a JSON message nested deeper than :data:`MAX_JSON_DEPTH`, stops the
    count, with ``problem`` saying why.

    The integers ``analyze`` refuses as not held by a ``float64`` (:func:`~hybridlog.io.exact.
    inexact`: beyond 2^53) are looked for too, in ``int64``/``uint64`` fields and JSON
    integers: ``unheld`` maps a field path to the first such value and the time of its message.
    So is a JSON field that holds a number in some messages and text in others, which
    ``analyze`` refuses as a number at the first text (:meth:`mixed`).  The messages of a
    topic that may carry ``header.stamp`` are decoded for their stamps too (``stamps``,
    :class:`_Stamps`), whether or not it has fields to count.

    Parameters
    ----------
    topic:
        The topic, with its decoder.
    float_leaves:
        Its floating-point leaves, or ``None`` for JSON messages, which are walked as they
        come.
    wide_leaves:
        Its ``int64``/``uint64`` leaves (ROS messages), whose values are checked, not counted.
    """

    def __init__(
        self,
        topic: Topic,
        float_leaves: list[_DeepLeaf] | None,
        wide_leaves: Sequence[_DeepLeaf] = (),
    ) -> None:
        self.topic = topic
        self.leaves = float_leaves
        self.wide = wide_leaves
        self.problem: str | None = None
        self.stamps = _Stamps(topic) if _may_have_stamps(topic) else None
        # field path after the topic -> the first value beyond 2^53 a float64 does not hold
        self.unheld: dict[str, str] = {}
        self._datas: list[bytes] = []
        self._held = 0  # bytes in _datas
        self._times: list[int] = []
        # field path after the topic -> [values, non-finite values]
        self._counts: dict[str, list[int]] = {leaf.text: [0, 0] for leaf in float_leaves or ()}
        # JSON: the paths of the numbers and text the messages hold, in order of appearance
        self.fields: dict[str, None] = {}
        # JSON: field path -> the log time of the first message holding text there
        self._text_at: dict[str, int] = {}
        # JSON: field path (outside arrays) -> the log time of the first boolean there
        self._boolean_at: dict[str, int] = {}
        # JSON: field path -> its nulls, non-finite values where the path holds numbers
        self._nulls: Counter[str] = Counter()
        self.messages = 0  # messages taken
        self.undecodable = 0  # of them, those that could not be decoded (skipped)
        self._first_undecodable: tuple[int, str] | None = None  # its log time and why

    @classmethod
    def of(cls, topic: Topic) -> _ValueCounter | None:
        """A counter for ``topic``, or ``None`` when its messages cannot be decoded.

        A topic whose definition has no floating-point field gets a counter that decodes
        nothing (its count of non-finite values is 0).
        """
        if topic.problem or topic.decode is None:
            return None
        if topic.encoding == "json":
            return cls(topic, None)
        if topic.typedefs is None or topic.msgtype not in topic.typedefs:
            return None
        found = _deep_leaves(topic.typedefs, topic.msgtype)
        return cls(
            topic,
            [leaf for leaf in found if leaf.leaf.type_name in FLOAT_TYPES],
            [leaf for leaf in found if leaf.leaf.type_name in WIDE_INTEGER_TYPES],
        )

    def add(self, data: bytes, log_time: int) -> None:
        """Take one serialised message; count a part when :data:`DECODED_AT_ONCE` are held.

        Or :data:`DECODED_BYTES_AT_ONCE`: a part of large messages is decoded sooner.
        """
        if self.problem is not None or (
            self.leaves == [] and not self.wide and self.stamps is None
        ):
            return
        self._datas.append(data)
        self._times.append(log_time)
        self._held += len(data)
        self.messages += 1
        if len(self._datas) >= DECODED_AT_ONCE or self._held >= DECODED_BYTES_AT_ONCE:
            self._count()

    def result(self) -> list[dict[str, Any]] | None:
        """``name, count, nonfinite`` per field, or ``None`` when a message was undecodable.

        A topic none of whose messages decode (a wrong definition, not a bad message) is
        :attr:`problem`, decided here, at its end: its first part of
        :data:`DECODED_AT_ONCE` messages all undecodable (a logger's start cut short) said so
        of a topic whose later messages decode.
        """
        self._count()
        if self.problem is None and self.messages and self.undecodable == self.messages:
            assert self._first_undecodable is not None  # set with each one counted
            log_time, reason = self._first_undecodable
            self.problem = (
                f"the message logged at t={format_ns(log_time)} s cannot be decoded "
                f"({reason}); its values are not counted"
            )
        if self.problem is not None:
            return None
        return [
            {
                "name": self.topic.name + path,
                "count": count + self._nulls[path],
                "nonfinite": nonfinite + self._nulls[path],
            }
            for path, (count, nonfinite) in self._counts.items()
        ]

    def skipped(self) -> dict[str, Any] | None:
        """The messages that could not be decoded while others were, or ``None``.

        ``count`` and ``first``, the earliest one's log time in seconds: ``inspect``'s
        ``undecodable``.  The fields, values and stamps are then the others' (a JSON topic
        with one message cut short listed no field at all).
        """
        if not self.undecodable or self._first_undecodable is None or self.problem is not None:
            return None
        return {"count": self.undecodable, "first": seconds_of(self._first_undecodable[0])}

    def skipped_problem(self) -> str | None:
        """:meth:`skipped` in words, for ``problems``: how many, the first's time and why."""
        if self.skipped() is None or self._first_undecodable is None:
            return None
        log_time, reason = self._first_undecodable
        some = "1 of its" if self.undecodable == 1 else f"{self.undecodable} of its"
        first = "logged" if self.undecodable == 1 else "the first logged"
        return (
            f"{some} {self.messages} messages cannot be decoded, {first} at "
            f"t={format_ns(log_time)} s ({reason}): analyze refuses the topic where a field "
            f"of it is mapped; the fields and values here are the other "
            f"{self.messages - self.undecodable}'s"
        )

    def mixed(self) -> dict[str, str]:
        """Why ``analyze`` refuses each JSON field of text or booleans and numbers.

        Text or a boolean in one message and a number in another.
        Per path, in ``analyze``'s words, the first message holding text (or a boolean, for a
        field outside arrays) there, and how many of its values are numbers.  A field of text
        alone is a label (a mode), one of booleans alone reads as 0 and 1: no problem.
        """
        found: dict[str, str] = {}
        for kind, first_at in (
            ("a string, not a number", self._text_at),
            ("a boolean among numbers", self._boolean_at),
        ):
            for path, log_time in first_at.items():
                numbers = self._counts.get(path, [0])[0]
                if numbers and path not in found:
                    found[path] = (
                        f"the value is {kind} in the message logged at "
                        f"t={format_ns(log_time)} s ({numbers} of its values "
                        f"{'is a number' if numbers == 1 else 'are numbers'}: analyze refuses "
                        "it as an input, output or true state)"
                    )
        return found

    def _count(self) -> None:
        datas, times = self._datas, self._times
        self._datas, self._times, self._held = [], [], 0
        if not datas or self.problem is not None:
            return
        assert self.topic.decode is not None  # checked by ``of``
        try:
            messages = decode_each(self.topic.decode, datas)
        except UndecodableError as err:
            messages, times = self._decodable(datas, times, err)
            if not messages:  # the topic's later parts may decode: :meth:`result` decides
                return
        if self.stamps is not None:
            self.stamps.add(messages, times)
        if self.leaves is None:
            for row, message in enumerate(messages):
                unheld: dict[str, str] = {}
                texts: set[str] = set()
                booleans: set[str] = set()
                too_deep = _count_json(
                    message,
                    "",
                    self._counts,
                    self.fields,
                    0,
                    _JsonFound(unheld, texts, self._nulls, booleans),
                )
                for path, reason in unheld.items():
                    self._note_unheld(path, reason, times[row])
                for path in texts:
                    self._text_at.setdefault(path, times[row])
                for path in booleans:
                    self._boolean_at.setdefault(path, times[row])
                if too_deep is not None:
                    self.problem = (
                        f"the message logged at t={format_ns(times[row])} s nests deeper than "
                        f"{MAX_JSON_DEPTH} levels at {excerpt(too_deep, 80)}; its values are "
                        "not counted"
                    )
                    return
            return
        # the elements of each array of messages, gathered once for all the leaves in them
        elements: dict[tuple[tuple[str, ...], ...], list[object]] = {(): messages}
        for leaf in self.leaves:
            try:
                if leaf.arrays not in elements:
                    elements[leaf.arrays] = _elements(messages, leaf.arrays)
                values = _leaf_values(elements[leaf.arrays], leaf.leaf)
            except (PathError, ValueError) as err:
                self.problem = f"{leaf.text}: {err}; its values are not counted"
                return
            entry = self._counts[leaf.text]
            entry[0] += values.size
            entry[1] += count_nonfinite(values)
        for leaf in self.wide:
            if leaf.text in self.unheld:
                continue
            try:
                if leaf.arrays not in elements:
                    elements[leaf.arrays] = _elements(messages, leaf.arrays)
                if not beyond_exact(_leaf_values(elements[leaf.arrays], leaf.leaf)).any():
                    continue
                found = _first_unheld(messages, leaf)
            except (PathError, ValueError) as err:
                self.problem = f"{leaf.text}: {err}; its values are not counted"
                return
            if found is not None:
                self._note_unheld(leaf.text, found[1], times[found[0]])

    def _decodable(
        self, datas: list[bytes], times: list[int], err: UndecodableError
    ) -> tuple[list[object], list[int]]:
        """The messages of ``datas`` that decode, with their times; the others counted.

        ``err``: :func:`decode_each`'s refusal of the part.  The messages before the one it
        names are decoded again, those after it as a part of their own, and so on: each
        message is decoded at most twice, and only a part holding a bad message pays.
        """
        decode = self.topic.decode
        assert decode is not None  # checked by ``of``
        messages: list[object] = []
        kept: list[int] = []
        start = 0
        error: UndecodableError | None = err
        while error is not None:
            bad = start + error.row
            messages.extend(decode_each(decode, datas[start:bad]))
            kept.extend(times[start:bad])
            self.undecodable += 1
            first = self._first_undecodable
            if first is None or times[bad] < first[0]:
                self._first_undecodable = (times[bad], str(error))
            start, error = bad + 1, None
            try:
                messages.extend(decode_each(decode, datas[start:]))
            except UndecodableError as again:
                error = again
            else:
                kept.extend(times[start:])
        return messages, kept

    def _note_unheld(self, path: str, reason: str, log_time: int) -> None:
        """Keep the first value of field ``path`` a float64 does not hold, with its time."""
        self.unheld.setdefault(
            path, f"the value {reason} in the message logged at t={format_ns(log_time)} s"
        )


def _may_have_stamps(topic: Topic) -> bool:
    """Whether ``topic``'s messages may carry ``header.stamp`` (its definition does not deny it).

    A ROS message's definition says; a JSON schema that lists no ``header.stamp`` among the
    properties it lists denies it; a JSON topic without them leaves it to its messages.
    """
    if topic.typedefs is not None:
        try:
            target = check_path(topic.typedefs, topic.msgtype, HEADER_STAMP)
        except PathError:
            return False
        return target.kind in ("message", "number")
    if topic.encoding != "json":
        return False
    if topic.json_schema is not None:
        try:
            _json_kind(topic.json_schema, HEADER_STAMP)
        except PathError:
            return False
    return True


class _Stamps:
    """The ``header.stamp`` of a topic's messages beside their log times, for ``inspect``.

    What ``--time header`` reads (:func:`_read_stamps`): a stamp that is no time ends the
    reading, ``problem`` saying why in ``analyze``'s words.  A JSON topic whose definition
    does not list ``header.stamp`` and whose first message has none has no stamps
    (``absent``), as ``analyze`` refuses it at that message.
    """

    def __init__(self, topic: Topic) -> None:
        self.topic = topic
        self.integers = _integer_stamps(topic)
        self.stamps: list[IntArray] = []
        self.log_times: list[IntArray] = []
        self.problem: str | None = None
        self.absent = False

    def add(self, messages: list[object], times: list[int]) -> None:
        """Read the stamps of decoded ``messages``, logged at ``times`` (ns)."""
        if self.problem is not None or self.absent:
            return
        stamps = np.empty(len(messages), dtype=np.int64)
        try:
            _read_stamps(messages, stamps, self.integers)
        except _RowError as err:
            if not self.stamps and not err.row and not self._listed():
                self.absent = True  # a JSON topic whose messages carry no stamp
                return
            reason = str(err.error)
            said = f" {reason}" if reason.startswith(("is ", "has ")) else f": {reason}"
            self.problem = (
                f"topic {self.topic.name!r}: header.stamp{said} in the message logged at "
                f"t={format_ns(times[err.row])} s (--time header refuses the topic)"
            )
            stamps = stamps[: err.row]  # those read before it
            times = times[: err.row]
        self.stamps.append(stamps)
        self.log_times.append(np.asarray(times, dtype=np.int64))

    def _listed(self) -> bool:
        """Whether the topic's definition lists ``header.stamp`` (so every message has it)."""
        schema = self.topic.json_schema
        if self.topic.typedefs is not None:
            return True
        return schema is not None and _json_kind(schema, HEADER_STAMP) is not None

    def describe(self, path: str) -> tuple[dict[str, Any] | None, list[str]]:
        """A topic's ``header_stamp`` in ``inspect`` (``None``: no stamps) and its problems.

        ``start`` and ``end``: the earliest and latest stamp; ``offset``: the median of stamp
        minus log time (both in seconds); ``count``: the stamps read.  The problems say what
        ``--time header`` would refuse or do unasked: stamps left at 0
        (:func:`_refuse_unset_stamps`), stamps going backwards in log-time order, a stamp
        that is no time, and stamps further than :data:`FAR_STAMP_S` from the log times.
        """
        problems = [] if self.problem is None else [self.problem]
        log_times = _concat_int(self.log_times)
        if self.absent or not log_times.size:
            return None, problems
        order = np.argsort(log_times, kind="stable")
        stamps = _concat_int(self.stamps)[order]
        log_times = log_times[order]
        offset = _median_offset(stamps, log_times)
        entry = {
            "start": seconds_of(stamps.min()),
            "end": seconds_of(stamps.max()),
            "offset": seconds_of(offset),
            "count": int(stamps.size),
        }
        name = self.topic.name
        try:
            _refuse_unset_stamps(path, name, stamps, log_times)
        except LogError as err:
            problems.append(str(err).removeprefix(f"{path}: "))
            return entry, problems  # zeros among stamps go backwards: said once
        backwards = np.flatnonzero(np.diff(stamps) < 0) + 1
        if backwards.size:
            i = int(backwards[0])
            problems.append(
                f"topic {name!r}: header.stamp goes backwards in {backwards.size} of "
                f"{stamps.size} messages in log-time order (first t={format_ns(int(stamps[i]))} "
                f"s in the message logged at t={format_ns(int(log_times[i]))} s, after "
                f"t={format_ns(int(stamps[i - 1]))} s): --time header refuses the topic "
                "unless --sort"
            )
        if abs(offset) >= FAR_STAMP_S * 1_000_000_000:
            side = "after" if offset > 0 else "before"
            problems.append(
                f"topic {name!r}: header.stamp is {format_ns(abs(offset))} s {side} its log "
                f"time (the median over {stamps.size} messages): another clock than the "
                "recorder's stamped it (simulated time, another machine's); --time header "
                "aligns the topic on that clock"
            )
        return entry, problems


def _first_unheld(messages: list[object], leaf: _DeepLeaf) -> tuple[int, str] | None:
    """The first of ``messages`` whose ``leaf`` holds an integer a float64 does not hold.

    Its row and why (:func:`~hybridlog.io.exact.inexact`); ``None`` when there is none.
    """
    for row, message in enumerate(messages):
        for element in _elements([message], leaf.arrays):
            value = evaluate(element, leaf.leaf.steps)  # as decoded: ints, not floats
            items = np.ravel(np.asarray(value)).tolist() if leaf.leaf.array else [value]
            for item in items:
                reason = inexact(item)
                if reason is not None:
                    return row, reason
    return None


def _leaf_values(messages: list[object], leaf: Leaf) -> FloatArray:
    """The numbers of ``leaf`` in decoded messages, arrays concatenated, as ``float64``."""
    get = accessor(leaf.steps)
    try:
        if not leaf.array:
            return np.fromiter(map(get, messages), dtype=np.float64, count=len(messages))
        parts = [as_float_array(get(message)) for message in messages]
    except (AttributeError, IndexError, KeyError, TypeError, ValueError, PathError):
        # the careful path: renamed fields (``from_``) and containers of other decoders
        parts = [np.asarray(leaf_value(m, leaf.steps), dtype=np.float64) for m in messages]
    return np.concatenate([np.ravel(part) for part in parts]) if parts else np.zeros(0)


@dataclass(frozen=True)
class _DeepLeaf:
    """A numeric or text leaf of a ROS message, possibly inside arrays of messages.

    ``arrays``: the steps to each array of messages on the way to it (from the message, then
    from an element of the array before), every element followed; ``leaf``: the leaf in the
    innermost element (in the message itself when ``arrays`` is empty).
    """

    arrays: tuple[tuple[str, ...], ...]
    leaf: Leaf

    @property
    def text(self) -> str:
        """The path after the topic, e.g. ``.transforms[].transform.translation.x``."""
        return "".join(format_steps(steps) + "[]" for steps in self.arrays) + self.leaf.text


def _deep_leaves(typedefs: Typedefs, msgtype: str) -> list[_DeepLeaf]:
    """The numeric and text leaves of ``msgtype``, inside arrays of messages too.

    :func:`~hybridlog.io.message_paths.leaves` stops at an array of messages (a path into one
    takes an index); the leaves of its elements are fields all the same (listed with ``[]``,
    ``/tf.transforms[].transform.translation.x``) and ``inspect`` counts their values.  An
    element type already on the way is not followed into itself.
    """
    out: list[_DeepLeaf] = []

    def walk(type_name: str, arrays: tuple[tuple[str, ...], ...], within: frozenset[str]) -> None:
        out.extend(_DeepLeaf(arrays, leaf) for leaf in leaves(typedefs, type_name))
        for steps, element in _message_arrays(typedefs, type_name):
            if element not in within:
                walk(element, (*arrays, steps), within | {element})

    walk(msgtype, (), frozenset({msgtype}))
    return out


def _message_arrays(typedefs: Typedefs, msgtype: str) -> list[tuple[tuple[str, ...], str]]:
    """Steps to, and element type of, every array of messages in ``msgtype`` (not in arrays)."""
    out: list[tuple[tuple[str, ...], str]] = []

    def walk(type_name: str, prefix: tuple[str, ...], within: frozenset[str]) -> None:
        if type_name in within or type_name not in typedefs:
            return
        within = within | {type_name}
        for name, desc in typedefs[type_name][1]:
            node = int(desc[0])
            if node == NAME:
                walk(desc[1], (*prefix, name), within)
            elif node in (ARRAY, SEQUENCE) and int(desc[1][0][0]) == NAME:
                out.append(((*prefix, name), str(desc[1][0][1])))

    walk(msgtype, (), frozenset())
    return out


def _elements(messages: list[object], arrays: tuple[tuple[str, ...], ...]) -> list[object]:
    """Every element of the arrays of messages ``arrays`` lead to in ``messages``, in order."""
    items = messages
    for steps in arrays:
        found: list[object] = []
        for item in items:
            value = evaluate(item, steps)
            if not isinstance(value, Sequence) or isinstance(value, str):
                raise PathError(f"{format_steps(steps)} is not an array of messages")
            found.extend(value)
        items = found
    return items


@dataclass(frozen=True)
class _JsonFound:
    """What :func:`_count_json` notes of one JSON message beyond its counts."""

    unheld: dict[str, str]
    """Path -> why the first integer there is not held by a float64 (beyond 2^53)."""
    texts: set[str]
    """The paths holding text (a string, or a string among an array's elements)."""
    nulls: Counter[str]
    """Path -> the nulls there (JSON's NaN and inf), added up over the messages."""
    booleans: set[str]
    """The paths outside arrays holding a boolean."""


def _count_json(
    value: object,
    path: str,
    counts: dict[str, list[int]],
    fields: dict[str, None],
    depth: int,
    found: _JsonFound,
) -> str | None:
    """Add the numbers of a decoded JSON value to ``counts``; ``[]`` marks array elements.

    Objects inside arrays are walked as the array's elements (``.poses[].x``), every number
    counted whatever the nesting up to :data:`MAX_JSON_DEPTH` levels.  The paths of numbers
    (booleans too) and text are added to ``fields``, those of text to ``found.texts`` too;
    an integer a ``float64`` does not hold (beyond 2^53) is noted in ``found.unheld``, the
    first of each path; the nulls of each path are added up in ``found.nulls`` (counted as
    non-finite values where the path holds numbers).  Returns ``None``, or the path at which
    the value nests deeper than that (nothing more is counted).
    """
    if depth > MAX_JSON_DEPTH:
        return path or "the message"
    if isinstance(value, Mapping):
        for key, item in value.items():
            too_deep = _count_json(
                item, f"{path}.{spell_field(key)}", counts, fields, depth + 1, found
            )
            if too_deep is not None:
                return too_deep
    elif isinstance(value, list):
        numbers = [item for item in value if _is_json_number(item)]
        if None in value:
            found.nulls[f"{path}[]"] += value.count(None)
        if any(isinstance(item, str | bool) for item in value) or numbers:
            fields[f"{path}[]"] = None  # text and booleans are fields, uncounted
        if any(isinstance(item, str) for item in value):
            found.texts.add(f"{path}[]")
        if numbers:
            entry = counts.setdefault(f"{path}[]", [0, 0])
            entry[0] += len(numbers)
            entry[1] += sum(map(_is_nonfinite, numbers))
            _note_json_unheld(numbers, f"{path}[]", found.unheld)
        for item in value:
            if isinstance(item, Mapping | list):
                too_deep = _count_json(item, f"{path}[]", counts, fields, depth + 1, found)
                if too_deep is not None:
                    return too_deep
    elif _is_json_number(value) and path:
        fields[path] = None
        entry = counts.setdefault(path, [0, 0])
        entry[0] += 1
        entry[1] += _is_nonfinite(value)
        _note_json_unheld([value], path, found.unheld)
    elif isinstance(value, str | bool) and path:
        fields[path] = None
        if isinstance(value, str):
            found.texts.add(path)
        elif "[]" not in path:  # an index of an array may hold booleans, another numbers
            found.booleans.add(path)
    elif value is None and path:
        found.nulls[path] += 1
    return None


def _note_json_unheld(numbers: Sequence[object], path: str, unheld: dict[str, str]) -> None:
    """Note in ``unheld`` the first of ``numbers`` (of ``path``) a float64 does not hold."""
    if path in unheld:
        return
    for number in numbers:
        if isinstance(number, int) and abs(number) > EXACT_LIMIT:
            reason = inexact(number)
            if reason is not None:
                unheld[path] = reason
                return


def _is_json_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _is_nonfinite(value: object) -> bool:
    """A JSON number that is NaN or infinite as a float64, as analyze reads it.

    An integer of more than 308 digits is infinite there (analyze refuses it as beyond the
    range of a float64, as the CSV reader does a cell of such digits, which inspect counts).
    """
    if isinstance(value, int):
        try:
            float(value)
        except OverflowError:
            return True
        return False
    return isinstance(value, float) and not math.isfinite(value)


# ---------------------------------------------------------------------- one topic


@dataclass
class _Wanted:
    text: str
    path: MessagePath
    kind: str  # "number" or "label"
    values: list[FloatArray] = field(default_factory=list)
    codes: list[IntArray] = field(default_factory=list)
    categories: list[tuple[str, ...]] = field(default_factory=list)
    booleans: bool | None = None
    """JSON: whether this path's values are ``true``/``false`` (``None`` before the first)."""
    present: list[np.ndarray[Any, np.dtype[np.bool_]]] = field(default_factory=list)
    """JSON: per batch, which messages carry the path (see :func:`_absent_key`)."""
    sparse: bool = False
    """JSON: whether some message lacks the path (it is then read from those that carry it)."""
    keys_seen: dict[str, None] = field(default_factory=dict)
    """JSON: the keys found where the path's missing key was looked for, for the message."""
    missing: str = ""
    """JSON: the first key of the path found missing."""


_HELD_EXACTLY = NUMERIC_TYPES - WIDE_INTEGER_TYPES
"""ROS primitive types whose every value a ``float64`` holds (all but the 64-bit integers)."""


class _TopicReader:
    """Collects the wanted paths of one topic, batch by batch."""

    def __init__(self, source: MessageSource, topic: Topic, header: bool) -> None:
        self.source = source
        self.topic = topic
        self.header = header
        self.wanted: list[_Wanted] = []
        self.log_times: list[IntArray] = []
        self.stamps: list[IntArray] = []
        self.count = 0
        self._streamed: bool | None = None  # :meth:`_streamable`, once known

    def stamp_offset(self) -> int:
        """The median of ``header.stamp`` minus log time over the topic's messages (ns).

        The delay from stamp to recorder, or the gap between their clocks: ``--time header``
        aligns topics whose offsets differ by :data:`~hybridlog.io.options.FAR_STAMP_S` or
        more on clocks that disagree (report.md says so).
        """
        return _median_offset(_concat_int(self.stamps), _concat_int(self.log_times))

    def want(self, text: str, path: MessagePath, kind: str) -> None:
        if not any(w.text == text and w.kind == kind for w in self.wanted):
            self.wanted.append(_Wanted(text, path, kind))
            self._streamed = None

    def _where(self, times: Sequence[int], row: int) -> str:
        return f"the message logged at t={format_ns(int(times[row]))} s"

    def add(self, datas: list[bytes], times: list[int]) -> None:
        """Reduce one batch of serialised messages to the wanted values.

        The batch is decoded :data:`DECODED_AT_ONCE` messages at a time, each part reduced to
        its values before the next is decoded.
        """
        count = len(datas)
        if self._add_single_floats(datas, times) or self._add_numbers_streamed(datas, times):
            return
        numbers = [np.empty(count) if w.kind == "number" else None for w in self.wanted]
        texts: list[list[str]] = [[] for _ in self.wanted]
        json = self.topic.encoding == "json"
        present = [np.ones(count, dtype=np.bool_) if json else None for _ in self.wanted]
        stamps = np.empty(count, dtype=np.int64) if self.header else None
        integers = stamps is not None and _integer_stamps(self.topic)
        for first in range(0, count, DECODED_AT_ONCE):
            try:
                messages = self._decode(datas[first : first + DECODED_AT_ONCE])
            except UndecodableError as err:
                raise LogError(
                    f"{self.source.path}: topic {self.topic.label}: "
                    f"{self._where(times, first + err.row)} cannot be decoded ({err})"
                ) from None
            part = slice(first, first + len(messages))
            for wanted, values, labels, carried in zip(
                self.wanted, numbers, texts, present, strict=True
            ):
                here = None if carried is None else carried[part]
                try:
                    if values is not None:
                        self._read_numbers(messages, wanted, values[part], here)
                        if json and not self.source.options.drop_nonfinite:
                            self._refuse_overflow(wanted, values[part], datas, times, first)
                    else:
                        self._read_labels(messages, wanted, labels, here)
                except _RowError as err:
                    reason = str(err.error)
                    if not reason.startswith(("the message", ".", "[")):
                        reason = f"the value {reason}"
                    raise LogError(
                        f"{self.source.path}: {wanted.text!r}: {reason} in "
                        f"{self._where(times, first + err.row)}"
                    ) from None
            if stamps is not None:
                try:
                    _read_stamps(messages, stamps[part], integers)
                except _RowError as err:
                    reason = str(err.error)  # "is 1.7e+18 s ...", or what the path lacks
                    said = f" {reason}" if reason.startswith(("is ", "has ")) else f": {reason}"
                    raise LogError(
                        f"{self.source.path}: topic {self.topic.label}: header.stamp{said} "
                        f"in {self._where(times, first + err.row)} (--time header needs it)"
                    ) from None
        for wanted, values, labels, carried in zip(
            self.wanted, numbers, texts, present, strict=True
        ):
            if carried is not None:
                wanted.present.append(carried)
                wanted.sparse = wanted.sparse or not bool(carried.all())
            if values is not None:
                wanted.values.append(values)
            else:
                unique, codes = np.unique(np.array(labels, dtype=object), return_inverse=True)
                wanted.codes.append(codes.astype(np.int64).reshape(-1))
                wanted.categories.append(tuple(str(u) for u in unique.tolist()))
        if stamps is not None:
            self.stamps.append(stamps)
        self.log_times.append(np.asarray(times, dtype=np.int64))
        self.count += count

    def _add_single_floats(self, datas: list[bytes], times: list[int]) -> bool:
        """Add a batch of one-``float64`` messages read at once (:func:`single_floats`).

        ``False``, having added nothing, when the batch is not such (or ``header.stamp`` is
        wanted): :meth:`add` decodes it message by message then.
        """
        topic = self.topic
        if self.header or topic.decode is None or any(w.kind != "number" for w in self.wanted):
            return False
        steps = [w.path.steps for w in self.wanted]
        values = single_floats(topic.encoding, topic.typedefs, topic.msgtype, steps, datas)
        if values is None:
            return False
        for wanted in self.wanted:
            wanted.values.append(values.copy())
        self.log_times.append(np.asarray(times, dtype=np.int64))
        self.count += len(datas)
        return True

    def _streamable(self) -> bool:
        """Whether every wanted path is a number field a ``float64`` holds exactly.

        Of messages rosbags decodes against a definition (the paths were checked with it, so
        each leaf is a number, :meth:`_numbers`), not JSON.
        """
        if self._streamed is None:
            topic = self.topic
            self._streamed = (
                topic.typedefs is not None
                and topic.encoding != "json"
                and all(w.kind == "number" for w in self.wanted)
            )
            for wanted in self.wanted if self._streamed else []:
                assert topic.typedefs is not None
                try:
                    leaf = check_path(topic.typedefs, topic.msgtype, wanted.path.steps)
                except PathError:
                    self._streamed = False
                    break
                self._streamed = self._streamed and leaf.type_name in _HELD_EXACTLY
        return self._streamed

    def _add_numbers_streamed(self, datas: list[bytes], times: list[int]) -> bool:
        """Add a batch whose wanted paths are all numbers of messages rosbags decodes.

        Each message is decoded and its numbers read before the next is decoded, in one
        :func:`numpy.fromiter` over the batch: no decoded message outlives its numbers, as in
        rosbags' own loop.  Kept in a list (:data:`DECODED_AT_ONCE` at a time), a
        ``PointStamped``'s four objects each made the cyclic garbage collector run four
        times as often, and its full collections walk the messages the young ones had
        survived into: 40 full collections against rosbags' 11 for 10^6 messages, 9.2-9.9 s
        of CPU against 7.6-8.1 s for this (``benchmarks/read_logs.py``).

        Only for fields a ``float64`` holds every value of (:data:`_HELD_EXACTLY`): an
        ``int64`` or ``uint64`` beyond 2^53 is looked at again in its message
        (:meth:`_read_numbers`), which is not kept here.

        ``False``, having added nothing, when the batch is not such (``header.stamp``, a
        label, JSON, a 64-bit integer field), or when a message cannot be decoded or a value
        is no number: :meth:`add` reads the batch message by message then, naming what is
        wrong.
        """
        topic = self.topic
        decode = topic.decode
        if self.header or decode is None or not self._streamable():
            return False
        gets = [accessor(w.path.steps) for w in self.wanted]
        width = len(gets)
        read: Callable[[object], object] = gets[0]
        if width > 1:
            read = lambda message: tuple(get(message) for get in gets)  # noqa: E731
        try:
            values: FloatArray = np.fromiter(
                map(read, map(decode, datas)),
                dtype=np.dtype((np.float64, width)) if width > 1 else np.float64,
                count=len(datas),
            )
        except Exception:  # any decoder or path failure: the careful reading names it
            return False
        columns = [values] if width == 1 else [values[:, k].copy() for k in range(width)]
        for wanted, column in zip(self.wanted, columns, strict=True):
            wanted.values.append(column)
        self.log_times.append(np.asarray(times, dtype=np.int64))
        self.count += len(datas)
        return True

    def _refuse_overflow(
        self,
        wanted: _Wanted,
        values: FloatArray,
        datas: list[bytes],
        times: list[int],
        first: int,
    ) -> None:
        """Refuse a JSON number too large for a float64, which is read as infinite.

        ``1e400``, or an integer of more than 308 digits.  It was reported as ``inf``, which
        the message does not say.  Only a message whose value came out infinite is decoded
        again, keeping its numbers' text: the check costs one pass over the values, not the
        decoding.  ``Infinity``, which Python's ``json`` reads, stays infinite (refused as
        such when mapped, or dropped with ``--drop-nonfinite``, as a number out of range is
        then).

        Raises
        ------
        LogError
            Naming the topic, the field, the message and the number as written.
        """
        infinite = np.flatnonzero(np.isinf(values))
        for row in infinite[:16].tolist():  # a file of Infinity tokens is not decoded anew
            try:
                message = json.loads(
                    datas[first + row], parse_float=_float_or_written, parse_int=_int_or_written
                )
                value = evaluate(message, wanted.path.steps)
            except (ValueError, PathError):
                continue  # decoded once already: the first decoding said what was wrong
            if isinstance(value, _BeyondFloat):
                index = self.count + first + row + 1
                raise LogError(
                    f"{self.source.path}: topic {self.topic.label}, field {wanted.text!r}: "
                    f"{excerpt(value.written, 40)[1:-1]} in {self._where(times, first + row)} "
                    f"(message {index} of the topic) is beyond the range of a float64 "
                    "(about 1.8e308)"
                )

    def _decode(self, datas: list[bytes]) -> list[object]:
        decode = self.topic.decode
        if decode is None:
            raise LogError(
                f"{self.source.path}: topic {self.topic.label}: no decoder for its messages"
            )
        return decode_each(decode, datas)

    def _read_numbers(
        self,
        messages: list[object],
        wanted: _Wanted,
        out: FloatArray,
        present: np.ndarray[Any, np.dtype[np.bool_]] | None = None,
    ) -> None:
        """Fill ``out`` with the numbers ``wanted`` names; a :class:`_RowError` names a bad one.

        A boolean is read as 0/1 (a ROS ``bool``), but in JSON, which has both, only where
        the path holds nothing else: ``true`` where the schema declares a number, or amid
        numbers, is refused rather than read as 1.  A JSON message without the path's key
        (:func:`_absent_key`) is marked in ``present`` and given no value.
        """
        steps = wanted.path.steps
        values = self._numbers(messages, steps)
        if values is not None:
            out[:] = values
            get = accessor(steps)
            for row in np.flatnonzero(beyond_exact(values)).tolist():
                reason = inexact(get(messages[row]))
                if reason is not None:
                    raise _RowError(row, PathError(reason))
            return
        json = self.topic.encoding == "json"
        for row, message in enumerate(messages):  # the careful loop, which names what is wrong
            try:
                try:
                    value = evaluate(message, steps)
                except PathError:
                    if present is None or not self._absent(message, wanted):
                        raise
                    present[row] = False
                    out[row] = np.nan
                    continue
                if json and value is None:
                    out[row] = self._json_null()
                    continue
                if json:
                    self._check_json_kind(wanted, value)
                out[row] = as_number(value)
                reason = inexact(value) if abs(out[row]) >= EXACT_LIMIT else None
                if reason is not None:
                    raise PathError(reason)
            except PathError as err:
                raise _RowError(row, err) from None

    def _read_labels(
        self,
        messages: list[object],
        wanted: _Wanted,
        out: list[str],
        present: np.ndarray[Any, np.dtype[np.bool_]] | None = None,
    ) -> None:
        """Append the labels ``wanted`` names to ``out``, as :meth:`_read_numbers` does."""
        for row, message in enumerate(messages):
            try:
                try:
                    value = evaluate(message, wanted.path.steps)
                except PathError:
                    if present is None or not self._absent(message, wanted):
                        raise
                    present[row] = False
                    out.append("")
                    continue
                out.append(as_label(value))
            except PathError as err:
                raise _RowError(row, err) from None

    def _absent(self, message: object, wanted: _Wanted) -> bool:
        """Whether a JSON message leaves out a key of ``wanted``'s path (not required).

        A logger of sparse signals writes each message with the fields it has at that
        moment (``{"u": 1}``, then ``{"y": 10}``): a field is read from the messages that
        carry it, at their times.  A key the topic's JSON schema lists as ``required`` is
        not optional: a message without it is refused.

        Raises
        ------
        PathError
            For a key the schema requires.
        """
        found = _absent_key(message, wanted.path.steps)
        if found is None:
            return False
        depth, keys = found
        wanted.missing = wanted.missing or str(wanted.path.steps[depth])
        for key in keys[:64]:
            wanted.keys_seen.setdefault(key, None)
        schema = self.topic.json_schema
        if schema is not None and _json_required(schema, wanted.path.steps[: depth + 1]):
            step = wanted.path.steps[depth]
            raise PathError(
                f"{format_steps(wanted.path.steps[:depth]) or 'the message'} has no field "
                f"{step!r}, which the topic's JSON schema lists as required"
            )
        return True

    def _json_null(self) -> float:
        """A JSON ``null`` where a number is meant: NaN with ``--drop-nonfinite``, else refused.

        JSON has no NaN or infinity: JavaScript's ``JSON.stringify`` and serde_json write
        them as ``null``.  A null is then a non-finite sample: dropped and counted with the
        NaNs under ``--drop-nonfinite`` (``inspect`` counts it as non-finite), refused
        otherwise, naming it as written.

        Raises
        ------
        PathError
            Without ``--drop-nonfinite``.
        """
        if self.source.options.drop_nonfinite:
            return math.nan
        raise PathError(
            "is null, not a number (JSON writers write NaN and inf so; --drop-nonfinite "
            "drops it as a NaN)"
        )

    def _check_json_kind(self, wanted: _Wanted, value: object) -> None:
        """Refuse a JSON boolean where numbers are meant, and a number among booleans."""
        boolean = isinstance(value, bool)
        if wanted.booleans is None:
            schema = self.topic.json_schema
            declared = None if schema is None else _json_type(schema, wanted.path.steps)
            if boolean and declared in ("number", "integer"):
                raise PathError(
                    f"is a boolean ({str(value).lower()}) where the schema declares a {declared}"
                )
            wanted.booleans = boolean if declared != "boolean" else True
        if boolean != wanted.booleans:
            raise PathError(
                f"is {'a boolean' if boolean else 'a number'} where the messages before held "
                f"{'numbers' if boolean else 'booleans'}"
            )

    def _numbers(self, messages: list[object], steps: Sequence[Step]) -> FloatArray | None:
        """The numbers at ``steps`` in one go, or ``None`` when any message needs a closer look.

        Only for messages decoded by rosbags against a definition the path was checked with
        (so the leaf is a number); JSON values could be strings that NumPy would parse.
        """
        if self.topic.typedefs is None:
            return None
        try:
            values: FloatArray = np.fromiter(
                map(accessor(steps), messages), dtype=np.float64, count=len(messages)
            )
        except (AttributeError, IndexError, KeyError, TypeError, ValueError):
            return None
        return values

    # -- series

    def series(self) -> tuple[dict[str, Series], dict[str, LabelSeries]]:
        """The wanted paths as series, in time order (see the module docstring)."""
        log_times = _concat_int(self.log_times)
        all_times = _concat_int(self.stamps) if self.header else log_times
        shared: tuple[IntArray, Any, Any] | None = None
        numbers: dict[str, Series] = {}
        labels: dict[str, LabelSeries] = {}
        kept_any: BoolArray | None = None  # the topic's messages of a repeated time kept
        for wanted in self.wanted:
            if wanted.kind == "number":
                values: Any = (
                    np.concatenate(wanted.values) if wanted.values else np.zeros(0, np.float64)
                )
            else:
                values, categories = _merge_labels(wanted.codes, wanted.categories)
            if wanted.sparse:
                # a field only some messages carry: its own times (the module docstring)
                carried = np.concatenate(wanted.present)
                if not carried.any():
                    found = closest_names(
                        [wanted.missing], list(map(spell_field, wanted.keys_seen))
                    )
                    raise LogError(
                        f"{self.source.path}: {wanted.text!r}: none of the {carried.size} "
                        f"messages of topic {self.topic.label} has field "
                        f"{format_steps(wanted.path.steps).removeprefix('.')!r}; "
                        + found.replace("available", "fields found")
                    )
                time_ns = all_times[carried]
                order, keep = self._order(time_ns, log_times[carried], field=wanted.text)
                values = values[carried]
                if keep is not None and wanted.kind == "number":
                    keep = self._usable_last(_reorder(time_ns, order, None), values, order, keep)
                    self._note_duplicates(wanted.text, keep)
                time_ns = _reorder(time_ns, order, keep)
                if wanted.kind == "label":  # without the absent messages' placeholder
                    used, inverse = np.unique(values, return_inverse=True)
                    values = inverse.astype(np.int64).reshape(-1)
                    categories = tuple(categories[int(code)] for code in used)
            else:
                if shared is None:
                    order, keep = self._order(all_times, log_times)
                    shared = (_reorder(all_times, order, keep), order, keep)
                time_ns, order, keep = shared
                if keep is not None and wanted.kind == "number":
                    sorted_times = _reorder(all_times, order, None)
                    keep = self._usable_last(sorted_times, values, order, keep)
                    time_ns = sorted_times[keep]
                if keep is not None:
                    kept_any = keep if kept_any is None else kept_any | keep
            values = _reorder(values, order, keep)
            if wanted.kind == "number":
                numbers[wanted.text] = Series(wanted.text, time_ns, values)
            else:
                labels[wanted.text] = LabelSeries(wanted.text, time_ns, values, categories)
        if kept_any is not None:
            self._note_duplicates(self.topic.name, kept_any)
        return numbers, labels

    def _usable_last(
        self, time_ns: IntArray, values: FloatArray, order: IntArray | None, keep: BoolArray
    ) -> BoolArray:
        """``keep`` of a number field, its ``values`` in the order read, with ``--drop-nonfinite``.

        The last usable message of each time, and the unusable ones, which
        :func:`~hybridlog.io.load_signals` drops and counts
        (:func:`~hybridlog.io.source.last_of_each_time`); ``time_ns``: the times sorted.
        Without the option, ``keep``, the last of each time.
        """
        if not self.source.options.drop_nonfinite:
            return keep
        return last_of_each_time(time_ns, _reorder(values, order, None))

    def _note_duplicates(self, key: str, keep: BoolArray) -> None:
        """``duplicates_dropped[key]``: the messages of a repeated time no field kept."""
        dropped = int(keep.size - np.count_nonzero(keep))
        notes = self.source._notes.setdefault("duplicates_dropped", {})
        if dropped:
            notes[key] = dropped
        else:
            notes.pop(key, None)
            if not notes:
                del self.source._notes["duplicates_dropped"]

    def _order(
        self, time_ns: IntArray, log_times: IntArray, field: str | None = None
    ) -> tuple[IntArray | None, np.ndarray[Any, np.dtype[np.bool_]] | None]:
        """The order and the kept messages of a topic's times (or of a sparse ``field``'s).

        Raises
        ------
        LogError
            For header stamps that go backwards or times that repeat, without ``--sort``.
        """
        source, topic = self.source, self.topic
        # a field only some JSON messages carry is checked, sorted and noted on its own
        what = f"topic {topic.name!r}" if field is None else f"{field!r}"
        key = topic.name if field is None else field
        among = "" if field is None else " (among the messages that carry it)"
        sort = source.options.sort
        word = "header.stamp" if self.header else "log time"
        order: IntArray | None = None
        if self.header:
            _refuse_unset_stamps(source.path, topic.name, time_ns, log_times)
        self._refuse_one_time(time_ns, f"{what}{among}")
        steps = np.diff(time_ns)
        backwards = steps < 0
        if backwards.any():
            if self.header and not sort:
                i = int(np.argmax(backwards)) + 1
                # both messages named: either may be the odd one (a log time left 0 puts a
                # message first, whose stamp the next message's then seems to undercut)
                raise LogError(
                    f"{source.path}: {what}: header.stamp goes backwards{among} "
                    f"(t={format_ns(int(time_ns[i]))} s in the message logged at "
                    f"t={format_ns(int(log_times[i]))} s, after "
                    f"t={format_ns(int(time_ns[i - 1]))} s in the one logged at "
                    f"t={format_ns(int(log_times[i - 1]))} s); --sort puts messages in time order"
                )
            order = np.argsort(time_ns, kind="stable")
            if sort:
                source._notes.setdefault("sorted", {})[key] = int(backwards.sum())
            time_ns = time_ns[order]
            steps = np.diff(time_ns)
        same = steps == 0
        keep = None
        if same.any():
            first = int(np.argmax(same)) + 1
            if not sort:
                raise LogError(
                    f"{source.path}: {what}: {int(same.sum())} message(s){among} have "
                    f"the same {word} as the one before (first at "
                    f"t={format_ns(int(time_ns[first]))} s); --sort keeps the last of each"
                )
            keep = np.append(~same, True)
            source._notes.setdefault("duplicates_dropped", {})[key] = int(same.sum())
        return order, keep

    def _refuse_one_time(self, time_ns: IntArray, what: str) -> None:
        """Refuse a topic whose every message (three or more) has one and the same time.

        A recorder that never set the log time (an MCAP writer leaving it 0), or a publisher
        stamping every message alike, gives no time to tell the messages apart: refused as
        "the same log time as the one before", the remedy offered, ``--sort``, kept one
        message of all.  Refused whatever the options, with the other time to read.
        """
        if time_ns.size < 3 or not bool((time_ns == time_ns[0]).all()):
            return
        at = f"t={format_ns(int(time_ns[0]))} s"
        if self.header:
            cause = "the publisher stamped them all alike; use --time log"
        else:
            cause = "the recorder did not set log times"
            try:
                self.source._check_header(self.topic)
                cause += "; --time header reads each message's header.stamp instead"
            except LogError:
                pass  # no other time in these messages
        word = "header.stamp" if self.header else "log time"
        raise LogError(
            f"{self.source.path}: {what}: all {time_ns.size} messages have the same {word}, "
            f"{at}: {cause}"
        )


def _refuse_unset_stamps(path: str, topic: str, stamps: IntArray, log_times: IntArray) -> None:
    """Refuse ``--time header`` on a topic whose ``header.stamp`` is 0 in several messages.

    A publisher that never fills the header sends 0 in every message; a zero can be a real
    stamp only once, and first (simulated time starting at 0).  Read as times, repeated
    zeros were "the same header.stamp as the one before", whose remedy, ``--sort``, kept one
    message; one zero after stamps of 10 s was, with ``--sort``, moved to the start of the
    log as a sample at t=0 s (with ``--max-gap`` long enough, without a word).
    """
    unset = stamps == 0
    count = int(np.count_nonzero(unset))
    if count == 0:
        return
    first = int(np.argmax(unset))
    if count == 1 and not stamps[:first].any():
        return
    if count == 1:
        raise LogError(
            f"{path}: topic {topic!r}: header.stamp is 0 in message {first + 1} of "
            f"{stamps.size} (logged at t={format_ns(int(log_times[first]))} s), after a "
            f"stamp of t={format_ns(int(stamps[first - 1]))} s: the publisher did not set "
            "it; use --time log"
        )
    raise LogError(
        f"{path}: topic {topic!r}: header.stamp is 0 in {count} of {stamps.size} messages "
        f"(first logged at t={format_ns(int(log_times[first]))} s): the publisher did not "
        "set it; use --time log"
    )


class _RowError(Exception):
    """A :class:`PathError` of the message at ``row`` of a decoded part."""

    def __init__(self, row: int, error: PathError) -> None:
        super().__init__(str(error))
        self.row = row
        self.error = error


def _absent_key(message: object, steps: Sequence[Step]) -> tuple[int, list[str]] | None:
    """Where a decoded JSON message leaves out a key of ``steps``: ``(step index, its keys)``.

    ``None`` when every key is there (what is wrong is then something else: an index out of
    range, a step into a number), or when ``steps`` run into something not an object first.
    """
    value = message
    for depth, step in enumerate(steps):
        if isinstance(step, int):
            if not isinstance(value, list) or not -len(value) <= step < len(value):
                return None
            value = value[step]
        elif isinstance(value, Mapping):
            if step not in value:
                return depth, [str(k) for k in value]
            value = value[step]
        else:
            return None
    return None


def _json_required(schema: Mapping[str, Any], steps: Sequence[Step]) -> bool:
    """Whether a JSON schema lists the last key of ``steps`` as ``required`` in its object."""
    node: Any = schema
    for depth, step in enumerate(steps):
        if not isinstance(node, Mapping):
            return False
        if isinstance(step, int):
            node = node.get("items")
            continue
        required = node.get("required")
        if depth == len(steps) - 1:
            return isinstance(required, list) and step in required
        properties = node.get("properties")
        node = properties.get(step) if isinstance(properties, Mapping) else None
    return False


def _median_offset(stamps: IntArray, log_times: IntArray) -> int:
    """The (lower) median of ``stamps - log_times`` in whole nanoseconds; 0 for none."""
    if stamps.size == 0:
        return 0
    return int(np.sort(stamps - log_times)[(stamps.size - 1) // 2])


_STAMP_INTEGERS = frozenset(("int8", "uint8", "int16", "uint16", "int32", "uint32"))
"""Types of ``sec``/``nanosec`` whose values NumPy reads at C speed, exact and in range."""
_STAMP_SEC = operator.attrgetter("header.stamp.sec")
_STAMP_NANOSEC = operator.attrgetter("header.stamp.nanosec")


def _integer_stamps(topic: Topic) -> bool:
    """Whether ``topic``'s definition makes ``header.stamp`` ``sec`` and ``nanosec`` integers.

    ROS 1 ``time`` and ROS 2 ``builtin_interfaces/Time`` (rosbags decodes both so): their
    stamps are read a batch at a time (:func:`_read_stamps`), where ``np.fromiter`` would
    truncate a float and parse a string of another definition.
    """
    if topic.typedefs is None:
        return False
    try:
        return all(
            check_path(topic.typedefs, topic.msgtype, (*HEADER_STAMP, name)).type_name
            in _STAMP_INTEGERS
            for name in ("sec", "nanosec")
        )
    except PathError:
        return False


def _read_stamps(messages: list[object], out: IntArray, integers: bool = False) -> None:
    """Fill ``out`` with the messages' ``header.stamp``; a :class:`_RowError` names a bad one.

    With ``integers`` (:func:`_integer_stamps`) the seconds and nanoseconds are read at C
    speed (a third of ``inspect``'s time on a ``PointStamped`` log, read one by one); a
    nanosecond count that is no fraction of a second sends the part through
    :func:`~hybridlog.io.message_paths.stamp_ns`, which names it.
    """
    if integers:
        count = len(messages)
        sec = np.fromiter(map(_STAMP_SEC, messages), dtype=np.int64, count=count)
        nanosec = np.fromiter(map(_STAMP_NANOSEC, messages), dtype=np.int64, count=count)
        if bool(((nanosec >= 0) & (nanosec < NS_PER_S)).all()):
            out[:] = sec * NS_PER_S + nanosec  # |sec| < 2^32: within int64 and the grid
            return
    for row, message in enumerate(messages):
        try:
            out[row] = stamp_ns(evaluate(message, HEADER_STAMP))
        except PathError as err:
            raise _RowError(row, err) from None


def _reorder(values: Any, order: IntArray | None, keep: Any) -> Any:
    if order is not None:
        values = values[order]
    if keep is not None:
        values = values[keep]
    return values


def _concat_int(parts: list[IntArray]) -> IntArray:
    if not parts:
        return np.zeros(0, dtype=np.int64)
    result: IntArray = np.concatenate(parts).astype(np.int64)
    return result


def _merge_labels(
    codes: list[IntArray], categories: list[tuple[str, ...]]
) -> tuple[IntArray, tuple[str, ...]]:
    merged: dict[str, int] = {}
    parts: list[IntArray] = []
    for batch_codes, batch_categories in zip(codes, categories, strict=True):
        lookup = np.array(
            [merged.setdefault(c, len(merged)) for c in batch_categories], dtype=np.int64
        )
        parts.append(lookup[batch_codes] if lookup.size else batch_codes)
    return _concat_int(parts), tuple(merged)


# ---------------------------------------------------------------------- JSON schemas


def parse_json_schema(data: bytes) -> Mapping[str, Any] | None:
    """A JSON schema as a dict, or ``None`` when it is empty or not JSON."""
    try:
        schema = json.loads(data) if data else None
    except (ValueError, UnicodeDecodeError):
        return None
    return schema if isinstance(schema, dict) else None


def _json_kind(schema: Mapping[str, Any], steps: Sequence[Step]) -> str | None:
    """What ``steps`` name in a JSON schema, or ``None`` where the schema does not say."""
    return {
        "number": "number",
        "integer": "number",
        "boolean": "number",
        "string": "string",
        "object": "message",
        "array": "array",
    }.get(str(_json_type(schema, steps)))


def _json_type(schema: Mapping[str, Any], steps: Sequence[Step]) -> str | None:
    """The JSON type a schema gives ``steps`` (``"integer"``, ...), or ``None`` if none."""
    node: Any = schema
    done: list[Step] = []
    for step in steps:
        if not isinstance(node, Mapping):
            return None
        if isinstance(step, int):
            if node.get("type") not in ("array", None) and "items" not in node:
                raise PathError(f"{format_steps(done) or 'the message'} is not an array")
            node = node.get("items")
        else:
            properties = node.get("properties")
            if not isinstance(properties, Mapping):
                return None
            if step not in properties:
                names = [spell_field(str(k)) for k in properties]
                raise PathError(
                    f"{format_steps(done) or 'the message'} has no field {step!r}; "
                    f"{closest_names([step], names).replace('available', 'fields')}"
                )
            node = properties[step]
        done.append(step)
    if not isinstance(node, Mapping):
        return None
    kind = node.get("type")
    if isinstance(kind, list):
        kind = next((k for k in kind if k != "null"), None)
    return None if kind is None else str(kind)


@dataclass(frozen=True)
class _JsonLeaves:
    """The leaves a JSON schema lists, and where it nests too deep to follow (or ``None``)."""

    leaves: list[str]
    too_deep: str | None


def _json_leaves(schema: Mapping[str, Any]) -> _JsonLeaves:
    """The numeric and text leaves of a JSON schema's objects, at any depth.

    Arrays of numbers, booleans or text are leaves (``.name[]``), as a single one is; the
    leaves of arrays of objects are listed
    with ``[]`` where a path takes an index (``.poses[].x``), as for ROS messages.  Objects
    nested deeper than :data:`MAX_JSON_DEPTH` are not followed, and the first such path is
    returned.
    """
    out: list[str] = []
    too_deep: str | None = None

    def walk(node: Mapping[str, Any], prefix: str, depth: int) -> None:
        nonlocal too_deep
        properties = node.get("properties")
        if not isinstance(properties, Mapping):
            return
        if depth > MAX_JSON_DEPTH:
            too_deep = too_deep or prefix or "the message"
            return
        for name, child in properties.items():
            if not isinstance(child, Mapping):
                continue
            kind = child.get("type")
            if kind in ("number", "integer", "boolean", "string"):
                out.append(f"{prefix}.{spell_field(name)}")
            elif kind == "object":
                walk(child, f"{prefix}.{spell_field(name)}", depth + 1)
            elif kind == "array":
                items = child.get("items")
                if not isinstance(items, Mapping):
                    continue
                if items.get("type") in ("number", "integer", "boolean", "string"):
                    out.append(f"{prefix}.{spell_field(name)}[]")
                elif items.get("type") == "object":
                    walk(items, f"{prefix}.{spell_field(name)}[]", depth + 1)

    walk(schema, "", 0)
    return _JsonLeaves(out, too_deep)
