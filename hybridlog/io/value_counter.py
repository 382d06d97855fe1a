"""``inspect``'s counts of a topic's values: non-finite ones, integers a float64 does not hold.

:class:`ValueCounter` is fed a topic's serialised messages by
:meth:`~hybridlog.io.messages.MessageSource.describe` and decodes them in parts
(:data:`~hybridlog.io.topic_reader.DECODED_AT_ONCE` messages, at most
:data:`DECODED_BYTES_AT_ONCE` bytes), counting per field what ``analyze`` would refuse and
reading the stamps (:class:`~hybridlog.io.header_stamps.HeaderStamps`).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import Any

from hybridlog.errors import excerpt
from hybridlog.io.exact import beyond_exact
from hybridlog.io.header_stamps import HeaderStamps, may_have_stamps
from hybridlog.io.json_schemas import MAX_JSON_DEPTH
from hybridlog.io.json_values import JsonFound, count_json
from hybridlog.io.message_leaves import (
    WIDE_INTEGER_TYPES,
    DeepLeaf,
    array_elements,
    deep_leaves,
    first_unheld,
    message_leaf_values,
)
from hybridlog.io.message_paths import (
    FLOAT_TYPES,
    PathError,
    UndecodableError,
    accessor,
    decode_each,
    format_steps,
)
from hybridlog.io.message_topics import Topic
from hybridlog.io.source import format_ns, seconds_of
from hybridlog.io.summary import count_nonfinite
from hybridlog.io.topic_reader import DECODED_AT_ONCE

DECODED_BYTES_AT_ONCE = 16 * 1024 * 1024
"""... and at most about this many bytes of serialised messages (``inspect``): 512 camera
images of 6 MiB held at once, decoded for their stamps, made ``inspect`` of a 3.5 GB bag
peak at 6.3 GB (19.5 s, against 84 MB and 4.9 s before stamps were read)."""


TEXTS_SHOWN = 8
"""``inspect`` shows the values of an array of text of at most this many ..."""
TEXT_SHOWN = 32
"""... each of at most this many characters (the names of a ``JointState``'s joints)."""


class ValueCounter:
    """Counts the values of a topic's fields that can hold NaN or infinities, and those that do.

    For :meth:`~hybridlog.io.messages.MessageSource.describe`: fed the topic's serialised
    messages one by one, it decodes them :data:`DECODED_AT_ONCE` at a time and counts, per
    field, the values and the non-finite ones (:func:`~hybridlog.io.summary.count_nonfinite`).
    The fields are the ``float32``/``float64`` leaves (scalars and arrays) of a ROS message
    definition, those inside arrays of messages included
    (``/tf.transforms[].transform.translation.x``, every element counted), or every number of a
    JSON message, inside arrays of objects too (JSON has one number type; Python's reader takes
    ``NaN`` and ``Infinity``).  A message that cannot be decoded, or a JSON message nested
    deeper than :data:`MAX_JSON_DEPTH`, stops the count, with ``problem`` saying why.

    The integers ``analyze`` refuses as not held by a ``float64`` (:func:`~hybridlog.io.exact.
    inexact`: beyond 2^53) are looked for too, in ``int64``/``uint64`` fields and JSON
    integers: ``unheld`` maps a field path to the first such value and the time of its message.
    So is a JSON field that holds a number in some messages and text in others, which
    ``analyze`` refuses as a number at the first text (:meth:`mixed`).  The messages of a
    topic that may carry ``header.stamp`` are decoded for their stamps too (``stamps``,
    :class:`HeaderStamps`), whether or not it has fields to count.

    Parameters
    ----------
    topic:
        The topic, with its decoder.
    float_leaves:
        Its floating-point leaves, or ``None`` for JSON messages, which are walked as they
        come.
    wide_leaves:
        Its ``int64``/``uint64`` leaves (ROS messages), whose values are checked, not counted.
    arrays:
        The steps to its arrays outside arrays of messages (ROS messages), whose lengths are
        held to one in every message where a path reads one by index (:meth:`uneven`), and
        listed where they are (:meth:`lengths`).
    texts:
        Those of them that are arrays of text (``JointState.name``), whose first message's
        values :meth:`lengths` lists where they are few and short.
    """

    def __init__(
        self,
        topic: Topic,
        float_leaves: list[DeepLeaf] | None,
        wide_leaves: Sequence[DeepLeaf] = (),
        arrays: Sequence[tuple[str, ...]] = (),
        texts: Sequence[tuple[str, ...]] = (),
    ) -> None:
        self.topic = topic
        self.leaves = float_leaves
        self.wide = wide_leaves
        # field path of an array outside arrays of messages -> its fewest and most elements
        self._lengths: dict[tuple[str, ...], list[int]] = {steps: [] for steps in arrays}
        # field path of an array of text -> its values in the first message decoded
        self._first_texts: dict[tuple[str, ...], list[str] | None] = dict.fromkeys(texts)
        self.problem: str | None = None
        self.stamps = HeaderStamps(topic) if may_have_stamps(topic) else None
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
    def of(cls, topic: Topic) -> ValueCounter | None:
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
        found = deep_leaves(topic.typedefs, topic.msgtype)
        arrays = [leaf.arrays[0] if leaf.arrays else leaf.leaf.steps for leaf in found]
        return cls(
            topic,
            [leaf for leaf in found if leaf.leaf.type_name in FLOAT_TYPES],
            [leaf for leaf in found if leaf.leaf.type_name in WIDE_INTEGER_TYPES],
            list(
                dict.fromkeys(
                    a for a, f in zip(arrays, found, strict=True) if f.arrays or f.leaf.array
                )
            ),
            [
                f.leaf.steps
                for f in found
                if not f.arrays and f.leaf.array and f.leaf.type_name == "string"
            ],
        )

    def add(self, data: bytes, log_time: int) -> None:
        """Take one serialised message; count a part when :data:`DECODED_AT_ONCE` are held.

        Or :data:`DECODED_BYTES_AT_ONCE`: a part of large messages is decoded sooner.
        """
        if self.problem is not None or (
            self.leaves == [] and not self.wide and self.stamps is None and not self._lengths
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

    def uneven(self) -> dict[str, str]:
        """Why ``analyze`` refuses an index into each array whose length differs by message.

        Per path (``.position[]``), the fewest and the most elements its messages hold:
        an index names one signal only in arrays of one length in every message
        (:mod:`hybridlog.io.array_lengths`).
        """
        return {
            format_steps(steps) + "[]": (
                f"its messages hold {fewest} to {most} elements: analyze refuses an index "
                "into it (one index names one signal only in arrays of one length in every "
                "message; two publishers on one topic?)"
            )
            for steps, (fewest, most) in ((s, v) for s, v in self._lengths.items() if v)
            if fewest != most
        }

    def lengths(self) -> dict[str, dict[str, Any]]:
        """Per array of one length in every message (``.position[]``), that length.

        ``{"elements": 3}``, and of an array of text of at most :data:`TEXTS_SHOWN` values
        of at most :data:`TEXT_SHOWN` characters each, the first message's (``"first":
        ["j1", "j2", "j3"]``): the indexes a path may take, and which joint each one is,
        which ``inspect`` did not say (``/joint_states.position[]`` alone).
        """
        found: dict[str, dict[str, Any]] = {}
        for steps, seen in self._lengths.items():
            if not seen or seen[0] != seen[1]:
                continue
            entry: dict[str, Any] = {"elements": seen[0]}
            first = self._first_texts.get(steps)
            if first and len(first) <= TEXTS_SHOWN and max(map(len, first)) <= TEXT_SHOWN:
                entry["first"] = first
            found[format_steps(steps) + "[]"] = entry
        return found

    def _measure(self, messages: list[object]) -> None:
        """Widen each array's range of lengths by those in ``messages``.

        An array of text's values in the first message are kept too (:meth:`lengths`).
        """
        for steps, seen in self._lengths.items():
            get = accessor(steps)
            try:
                lengths = [len(get(message)) for message in messages]  # type: ignore[arg-type]
                if messages and steps in self._first_texts and self._first_texts[steps] is None:
                    first = get(messages[0])
                    self._first_texts[steps] = (
                        [str(v) for v in first] if isinstance(first, list) else []
                    )
            except (AttributeError, IndexError, KeyError, TypeError):
                continue  # a renamed field (``from_``): no index is checked here
            if lengths:
                fewest, most = min(lengths), max(lengths)
                seen[:] = [min(seen[0], fewest), max(seen[1], most)] if seen else [fewest, most]

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
                too_deep = count_json(
                    message,
                    "",
                    self._counts,
                    self.fields,
                    0,
                    JsonFound(unheld, texts, self._nulls, booleans),
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
        self._measure(messages)
        # the elements of each array of messages, gathered once for all the leaves in them
        elements: dict[tuple[tuple[str, ...], ...], list[object]] = {(): messages}
        for leaf in self.leaves:
            try:
                if leaf.arrays not in elements:
                    elements[leaf.arrays] = array_elements(messages, leaf.arrays)
                values = message_leaf_values(elements[leaf.arrays], leaf.leaf)
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
                    elements[leaf.arrays] = array_elements(messages, leaf.arrays)
                if not beyond_exact(message_leaf_values(elements[leaf.arrays], leaf.leaf)).any():
                    continue
                found = first_unheld(messages, leaf)
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
