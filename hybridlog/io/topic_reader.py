"""One topic's wanted message paths: batches decoded into values, then series in time order.

:class:`TopicReader` takes a topic's batches of serialised messages from
:meth:`~hybridlog.io.messages.MessageSource.read` and reduces each to the wanted numbers and
labels (one-``float64`` messages at once, :func:`~hybridlog.io.fixed_messages.single_floats`;
number fields as each message is decoded, :meth:`TopicReader._add_numbers_streamed`; else
:data:`DECODED_AT_ONCE` messages at a time, naming a bad message by its log time), then makes
them series in time order (log time or ``header.stamp``; ``--sort`` and duplicate times; JSON
fields only some messages carry read at their own times).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from hybridlog.errors import LogError, excerpt
from hybridlog.io.array_lengths import ArrayLengths
from hybridlog.io.exact import EXACT_LIMIT, beyond_exact, inexact
from hybridlog.io.fixed_messages import single_floats
from hybridlog.io.header_stamps import (
    RowError,
    concat_int,
    integer_stamps,
    median_offset,
    read_stamps,
    refuse_unset_stamps,
)
from hybridlog.io.json_schemas import json_required, json_type
from hybridlog.io.json_values import BeyondFloat, absent_key, float_or_written, int_or_written
from hybridlog.io.message_leaves import WIDE_INTEGER_TYPES
from hybridlog.io.message_paths import (
    NUMERIC_TYPES,
    MessagePath,
    PathError,
    Step,
    UndecodableError,
    accessor,
    as_label,
    as_number,
    check_path,
    decode_each,
    evaluate,
    format_steps,
    spell_field,
)
from hybridlog.io.message_topics import Topic
from hybridlog.io.source import (
    FieldError,
    LabelSeries,
    Series,
    closest_names,
    format_ns,
    last_of_each_time,
)
from hybridlog.signals import BoolArray, FloatArray, IntArray

if TYPE_CHECKING:
    from hybridlog.io.messages import MessageSource


DECODED_AT_ONCE = 128
"""Messages of a batch decoded at a time, each part reduced to its values before the next.

Decoded messages are objects the cyclic garbage collector tracks (a ``PointStamped`` is four);
a whole batch of them alive at once made each of its collections walk up to 65,536 messages
again: a ``PointStamped`` MCAP of 3·10^5 messages read in 2.07 s, against 1.52 s in parts of
512 (1.60 s in parts of 1,024; the same with 256).  A part this small dies young; smaller
still, fewer of its messages outlive the collector's first generation (700 objects): with
``--time header`` (``header.stamp`` read, so not the streamed numbers of
``TopicReader._add_numbers_streamed``) 10^5 messages a topic took 2.31-2.65 s of CPU in parts
of 128 against 2.52-2.71 s in parts of 512 (alternating, three runs each, a loaded machine)."""


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
    """JSON: per batch, which messages carry the path (see :func:`absent_key`)."""
    sparse: bool = False
    """JSON: whether some message lacks the path (it is then read from those that carry it)."""
    keys_seen: dict[str, None] = field(default_factory=dict)
    """JSON: the keys found where the path's missing key was looked for, for the message."""
    missing: str = ""
    """JSON: the first key of the path found missing."""
    lengths: ArrayLengths | None = None
    """The arrays the path indexes, held to one length in every message (``None``: none)."""


_HELD_EXACTLY = NUMERIC_TYPES - WIDE_INTEGER_TYPES
"""ROS primitive types whose every value a ``float64`` holds (all but the 64-bit integers)."""


class TopicReader:
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
        return median_offset(concat_int(self.stamps), concat_int(self.log_times))

    def want(self, text: str, path: MessagePath, kind: str) -> None:
        """Read the path ``text`` of the messages as ``kind``, ``number`` or ``label`` (once)."""
        if not any(w.text == text and w.kind == kind for w in self.wanted):
            indexed = any(isinstance(step, int) for step in path.steps)
            lengths = ArrayLengths(path.steps) if indexed else None
            self.wanted.append(_Wanted(text, path, kind, lengths=lengths))
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
        integers = stamps is not None and integer_stamps(self.topic)
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
                    if wanted.lengths is not None:
                        lengths = wanted.lengths.of_each(messages)
                        self._check_lengths(wanted, lengths, times[part])
                except RowError as err:
                    reason = str(err.error)
                    if not reason.startswith(("the message", ".", "[")):
                        reason = f"the value {reason}"
                    raise FieldError(
                        self.source.path,
                        wanted.text,
                        f"{reason} in {self._where(times, first + err.row)}",
                    ) from None
            if stamps is not None:
                try:
                    read_stamps(messages, stamps[part], integers)
                except RowError as err:
                    reason = str(err.error)  # "is 1.7e+18 s ...", or what the path lacks
                    said = f" {reason}" if reason.startswith(("is ", "has ")) else f": {reason}"
                    raise FieldError(  # named by the first path read of the topic
                        self.source.path,
                        self.wanted[0].text,
                        f"topic {self.topic.label}: header.stamp{said} in "
                        f"{self._where(times, first + err.row)} (--time header needs it)",
                        unusable=not reason.startswith(("is ", "has ")),  # a stamp it lacks
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
        gets += [get for w in self.wanted if w.lengths is not None for get in w.lengths.getters]
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
        wanted_count = len(self.wanted)
        if width > wanted_count:  # the lengths of the arrays indexed, after the values
            lengths: IntArray = values[:, wanted_count:].astype(np.int64)
            for wanted in self.wanted:
                if wanted.lengths is not None:
                    count = len(wanted.lengths.arrays)
                    self._check_lengths(wanted, lengths[:, :count], times)
                    lengths = lengths[:, count:]
        columns = [values] if width == 1 else [values[:, k].copy() for k in range(wanted_count)]
        for wanted, column in zip(self.wanted, columns, strict=True):
            wanted.values.append(column)
        self.log_times.append(np.asarray(times, dtype=np.int64))
        self.count += len(datas)
        return True

    def _check_lengths(self, wanted: _Wanted, lengths: IntArray, times: Sequence[int]) -> None:
        """Refuse messages whose arrays ``wanted`` indexes differ in length (:class:`ArrayLengths`).

        Raises
        ------
        LogError
            Naming the topic, the path, the array and the two messages.
        """
        assert wanted.lengths is not None
        reason = wanted.lengths.check(lengths, times)
        if reason is not None:
            raise FieldError(self.source.path, wanted.text, f"topic {self.topic.label}: {reason}")

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
                    datas[first + row], parse_float=float_or_written, parse_int=int_or_written
                )
                value = evaluate(message, wanted.path.steps)
            except (ValueError, PathError):
                continue  # decoded once already: the first decoding said what was wrong
            if isinstance(value, BeyondFloat):
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
        """Fill ``out`` with the numbers ``wanted`` names; a :class:`RowError` names a bad one.

        A boolean is read as 0/1 (a ROS ``bool``), but in JSON, which has both, only where
        the path holds nothing else: ``true`` where the schema declares a number, or amid
        numbers, is refused rather than read as 1.  A JSON message without the path's key
        (:func:`absent_key`) is marked in ``present`` and given no value.
        """
        steps = wanted.path.steps
        values = self._numbers(messages, steps)
        if values is not None:
            out[:] = values
            get = accessor(steps)
            for row in np.flatnonzero(beyond_exact(values)).tolist():
                reason = inexact(get(messages[row]))
                if reason is not None:
                    raise RowError(row, PathError(reason))
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
                raise RowError(row, err) from None

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
                raise RowError(row, err) from None

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
        found = absent_key(message, wanted.path.steps)
        if found is None:
            return False
        depth, keys = found
        wanted.missing = wanted.missing or str(wanted.path.steps[depth])
        for key in keys[:64]:
            wanted.keys_seen.setdefault(key, None)
        schema = self.topic.json_schema
        if schema is not None and json_required(schema, wanted.path.steps[: depth + 1]):
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
            declared = None if schema is None else json_type(schema, wanted.path.steps)
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
        log_times = concat_int(self.log_times)
        all_times = concat_int(self.stamps) if self.header else log_times
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
                    raise FieldError(
                        self.source.path,
                        wanted.text,
                        f"none of the {carried.size} messages of topic {self.topic.label} has "
                        f"field {format_steps(wanted.path.steps).removeprefix('.')!r}; "
                        + found.replace("available", "fields found"),
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
            refuse_unset_stamps(source.path, topic.name, time_ns, log_times)
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
                instead = "" if self.header else self._stamps_instead()
                raise LogError(
                    f"{source.path}: {what}: {int(same.sum())} message(s){among} have "
                    f"the same {word} as the one before (first at "
                    f"t={format_ns(int(time_ns[first]))} s); --sort keeps the last of each"
                    + instead.replace("; ", ", or ", 1)
                )
            keep = np.append(~same, True)
            source._notes.setdefault("duplicates_dropped", {})[key] = int(same.sum())
        return order, keep

    def _stamps_instead(self) -> str:
        """``; --time header reads ...`` where the topic's messages carry ``header.stamp``.

        Log times that repeat or never change are the recorder's (messages taken in a burst);
        the publisher's stamps may still tell the messages apart.
        """
        try:
            self.source._check_header(self.topic)
        except LogError:
            return ""  # no other time in these messages
        return "; --time header reads each message's header.stamp instead"

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
            cause = "the recorder did not set log times" + self._stamps_instead()
        word = "header.stamp" if self.header else "log time"
        raise LogError(
            f"{self.source.path}: {what}: all {time_ns.size} messages have the same {word}, "
            f"{at}: {cause}"
        )


def _reorder(values: Any, order: IntArray | None, keep: Any) -> Any:
    if order is not None:
        values = values[order]
    if keep is not None:
        values = values[keep]
    return values


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
    return concat_int(parts), tuple(merged)
