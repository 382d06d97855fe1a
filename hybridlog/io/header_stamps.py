"""``header.stamp``: read a batch at a time, checked, and described beside the log times.

What ``--time header`` reads (:func:`read_stamps`, fast for ROS integer stamps,
:func:`integer_stamps`), what it refuses (stamps left at 0, :func:`refuse_unset_stamps`) and
what ``inspect`` says of a topic's stamps (:class:`HeaderStamps`): their span, their median offset
from the log times (:func:`median_offset`) and the problems ``--time header`` would meet.
A bad value is raised as a :class:`RowError` naming its row in the decoded part, as the topic
reader's paths are.
"""

from __future__ import annotations

import operator
from typing import Any

import numpy as np

from hybridlog.errors import LogError
from hybridlog.io.json_schemas import json_kind
from hybridlog.io.message_paths import PathError, Step, check_path, evaluate, stamp_ns
from hybridlog.io.message_topics import Topic
from hybridlog.io.options import FAR_STAMP_S
from hybridlog.io.source import NS_PER_S, format_ns, seconds_of
from hybridlog.signals import IntArray

HEADER_STAMP: tuple[Step, ...] = ("header", "stamp")


def may_have_stamps(topic: Topic) -> bool:
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
            json_kind(topic.json_schema, HEADER_STAMP)
        except PathError:
            return False
    return True


class HeaderStamps:
    """The ``header.stamp`` of a topic's messages beside their log times, for ``inspect``.

    What ``--time header`` reads (:func:`read_stamps`): a stamp that is no time ends the
    reading, ``problem`` saying why in ``analyze``'s words.  A JSON topic whose definition
    does not list ``header.stamp`` and whose first message has none has no stamps
    (``absent``), as ``analyze`` refuses it at that message.
    """

    def __init__(self, topic: Topic) -> None:
        self.topic = topic
        self.integers = integer_stamps(topic)
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
            read_stamps(messages, stamps, self.integers)
        except RowError as err:
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
        return schema is not None and json_kind(schema, HEADER_STAMP) is not None

    def describe(self, path: str) -> tuple[dict[str, Any] | None, list[str]]:
        """A topic's ``header_stamp`` in ``inspect`` (``None``: no stamps) and its problems.

        ``start`` and ``end``: the earliest and latest stamp; ``offset``: the median of stamp
        minus log time (both in seconds); ``count``: the stamps read.  The problems say what
        ``--time header`` would refuse or do unasked: stamps left at 0
        (:func:`refuse_unset_stamps`), stamps going backwards in log-time order, a stamp
        that is no time, and stamps further than :data:`FAR_STAMP_S` from the log times.
        """
        problems = [] if self.problem is None else [self.problem]
        log_times = concat_int(self.log_times)
        if self.absent or not log_times.size:
            return None, problems
        order = np.argsort(log_times, kind="stable")
        stamps = concat_int(self.stamps)[order]
        log_times = log_times[order]
        offset = median_offset(stamps, log_times)
        entry = {
            "start": seconds_of(stamps.min()),
            "end": seconds_of(stamps.max()),
            "offset": seconds_of(offset),
            "count": int(stamps.size),
        }
        name = self.topic.name
        try:
            refuse_unset_stamps(path, name, stamps, log_times)
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


def refuse_unset_stamps(path: str, topic: str, stamps: IntArray, log_times: IntArray) -> None:
    """Refuse ``--time header`` on a topic whose ``header.stamp`` is 0 in several messages.

    A publisher that never fills the header sends 0 in every message; a zero can be a real
    stamp only once, and in time order: first (simulated time starting at 0), or after
    negative stamps only (a clock counting from an event, through 0).  Read as times,
    repeated zeros were "the same header.stamp as the one before", whose remedy, ``--sort``,
    kept one message; one zero after stamps of 10 s was, with ``--sort``, moved to the start
    of the log as a sample at t=0 s (with ``--max-gap`` long enough, without a word).  The
    one zero of stamps from -1 s to 1 s was refused as unset.
    """
    unset = stamps == 0
    count = int(np.count_nonzero(unset))
    if count == 0:
        return
    first = int(np.argmax(unset))
    if count == 1 and bool((stamps[:first] < 0).all()):
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


class RowError(Exception):
    """A :class:`PathError` of the message at ``row`` of a decoded part."""

    def __init__(self, row: int, error: PathError) -> None:
        super().__init__(str(error))
        self.row = row
        self.error = error


def median_offset(stamps: IntArray, log_times: IntArray) -> int:
    """The (lower) median of ``stamps - log_times`` in whole nanoseconds; 0 for none."""
    if stamps.size == 0:
        return 0
    return int(np.sort(stamps - log_times)[(stamps.size - 1) // 2])


_STAMP_INTEGERS = frozenset(("int8", "uint8", "int16", "uint16", "int32", "uint32"))
"""Types of ``sec``/``nanosec`` whose values NumPy reads at C speed, exact and in range."""


_STAMP_SEC = operator.attrgetter("header.stamp.sec")


_STAMP_NANOSEC = operator.attrgetter("header.stamp.nanosec")


def integer_stamps(topic: Topic) -> bool:
    """Whether ``topic``'s definition makes ``header.stamp`` ``sec`` and ``nanosec`` integers.

    ROS 1 ``time`` and ROS 2 ``builtin_interfaces/Time`` (rosbags decodes both so): their
    stamps are read a batch at a time (:func:`read_stamps`), where ``np.fromiter`` would
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


def read_stamps(messages: list[object], out: IntArray, integers: bool = False) -> None:
    """Fill ``out`` with the messages' ``header.stamp``; a :class:`RowError` names a bad one.

    With ``integers`` (:func:`integer_stamps`) the seconds and nanoseconds are read at C
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
            raise RowError(row, err) from None


def concat_int(parts: list[IntArray]) -> IntArray:
    """``parts`` end to end as one ``int64`` array (empty for none)."""
    if not parts:
        return np.zeros(0, dtype=np.int64)
    result: IntArray = np.concatenate(parts).astype(np.int64)
    return result
