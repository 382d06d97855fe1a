"""Message paths: naming one number (or label) inside the messages of a topic (SPEC §5).

A path is ``/topic.field.sub[index]`` (Foxglove style); ``[-1]`` counts from the end of an
array.  The PlotJuggler/rqt spelling ``/topic/field/sub[0]`` is accepted too: the topic is
the *longest* topic of the log that the path starts with (followed by ``.``, ``/``, ``[`` or
the end), so ``/truth/x1/data`` on a log with topics ``/truth/x1`` and ``/truth`` means field
``data`` of ``/truth/x1``.

The same path works on every kind of message hybridlog reads:

- :func:`evaluate` follows a path through a decoded message -- a rosbags message object (ROS 1
  or ROS 2), an ``mcap-ros1-support``/``mcap-ros2-support`` object or a JSON ``dict`` -- and
  :func:`leaf_value` returns what it finds as a float, a string, or a ``float64`` array for
  numeric arrays, whatever container the library returned.
- :func:`check_path` checks a path against a message definition (a rosbags type store)
  before anything is read, so that a wrong field is reported with the fields that exist.
- :class:`BatchDecoder` reads a path out of many *serialised* CDR or ROS 1 messages at once,
  without building message objects: the byte offset of the field is walked for all messages
  together with NumPy, following the same layout rules as rosbags' generated deserialisers
  (CDR: every primitive aligned to its size relative to the payload; ROS 1: packed).  Before
  any value is taken, :meth:`BatchDecoder.check_sizes` walks every field of every message
  and requires the definition to end where the message ends, as rosbags' deserialiser does:
  a definition that does not describe the bytes is refused, never read into wrong numbers.
  This is what makes reading a selected signal cheaper than deserialising its messages
  (13-21x on ``Float64`` and ``PointStamped``, see ``benchmarks/read_logs.py``); anything it
  does not handle (``float128``, wide strings, long sequences of nested messages) raises
  :class:`LayoutError` and the caller decodes those messages one by one instead.
"""

from __future__ import annotations

import array
import math
import operator
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from hybridlog.io.source import closest_names
from hybridlog.signals import FloatArray, IntArray

Step = str | int
"""One step of a path: a field name or an array index (negative from the end)."""

BASE, NAME, ARRAY, SEQUENCE = 1, 2, 3, 4
"""rosbags' ``Nodetype`` values (an ``IntEnum``; compared as plain ints here)."""

PRIMITIVE_SIZES: dict[str, int] = {
    "bool": 1,
    "byte": 1,
    "char": 1,
    "int8": 1,
    "uint8": 1,
    "int16": 2,
    "uint16": 2,
    "int32": 4,
    "uint32": 4,
    "int64": 8,
    "uint64": 8,
    "float32": 4,
    "float64": 8,
}
_DTYPES: dict[str, str] = {
    "bool": "u1",
    "byte": "i1",
    "char": "u1",
    "int8": "i1",
    "uint8": "u1",
    "int16": "i2",
    "uint16": "u2",
    "int32": "i4",
    "uint32": "u4",
    "int64": "i8",
    "uint64": "u8",
    "float32": "f4",
    "float64": "f8",
}
STRING_TYPES = ("string",)

# A sequence of nested messages longer than this is decoded message by message instead.
MAX_WALKED_ELEMENTS = 1024
# Labels (strings) longer than this are gathered one by one instead of in one array.
MAX_VECTOR_LABEL = 256

_STEP = re.compile(r"[./]([^./\[\]]+)|\[\s*(-?\d+)\s*\]")

Fielddesc = tuple[Any, Any]
Typedefs = Mapping[str, tuple[Any, Sequence[tuple[str, Fielddesc]]]]


class PathError(Exception):
    """A path that does not fit the log or its messages (message without file prefix)."""


class LayoutError(Exception):
    """The batch decoder cannot handle this layout; decode the messages one by one."""


class UndecodableError(Exception):
    """A serialised message does not match its definition.

    Attributes
    ----------
    row:
        Index of the offending message in the batch.
    """

    def __init__(self, row: int, reason: str) -> None:
        super().__init__(reason)
        self.row = row


class IndexRangeError(Exception):
    """An array index outside the array of one message.

    Attributes
    ----------
    row:
        Index of the offending message in the batch.
    length:
        The array's length in that message.
    path:
        The path being read (set by the caller that knows it).
    """

    def __init__(self, row: int, length: int) -> None:
        super().__init__(f"index out of range (the array has {length} elements)")
        self.row = row
        self.length = length
        self.path = ""


# ---------------------------------------------------------------------------- parsing


@dataclass(frozen=True)
class MessagePath:
    """A parsed message path.

    Attributes
    ----------
    text:
        The path as the user wrote it.
    topic:
        The topic it names.
    steps:
        Field names and indices after the topic.
    """

    text: str
    topic: str
    steps: tuple[Step, ...]


def format_steps(steps: Sequence[Step]) -> str:
    """``("a", "b", 0)`` → ``".a.b[0]"``."""
    return "".join(f"[{s}]" if isinstance(s, int) else f".{s}" for s in steps)


def split_path(text: str, topics: Sequence[str]) -> MessagePath:
    """Split ``text`` into the longest matching topic and the steps after it.

    Raises
    ------
    PathError
        When no topic of the log starts the path (listing the closest), or the rest is not
        a sequence of ``.field``, ``/field`` and ``[index]``.
    """
    text = text.strip()
    best = ""
    for topic in topics:
        if len(topic) > len(best) and text.startswith(topic):
            rest = text[len(topic) :]
            if not rest or rest[0] in "./[" or topic.endswith("/"):
                best = topic
    if not best:
        guess = text.split(".", 1)[0].split("[", 1)[0]
        raise PathError(f"no topic for {text!r}; {closest_names([guess], list(topics))}")
    rest = text[len(best) :]
    steps: list[Step] = []
    position = 0
    while position < len(rest):
        match = _STEP.match(rest, position)
        if match is None:
            raise PathError(
                f"{text!r}: cannot read {rest[position:]!r} after the topic "
                "(expected .field, /field or [index], e.g. /joint_states.position[0])"
            )
        field, index = match.groups()
        steps.append(int(index) if index is not None else field.strip())
        position = match.end()
    return MessagePath(text, best, tuple(steps))


# ---------------------------------------------------------------------------- static check


@dataclass(frozen=True)
class Target:
    """What a path names in a message definition.

    Attributes
    ----------
    kind:
        ``"number"``, ``"string"``, ``"array"`` (of numbers, no index given) or ``"message"``.
    type_name:
        The primitive or message type at the end of the path.
    """

    kind: str
    type_name: str


def _field_names(typedefs: Typedefs, msgtype: str) -> list[str]:
    return [
        name for name, _ in typedefs[msgtype][1] if name != "structure_needs_at_least_one_member"
    ]


def check_path(typedefs: Typedefs, msgtype: str, steps: Sequence[Step]) -> Target:
    """Follow ``steps`` through the definition of ``msgtype``.

    Parameters
    ----------
    typedefs:
        rosbags field definitions (``Typestore.fielddefs``).
    msgtype:
        The topic's message type.
    steps:
        Field names and indices.

    Returns
    -------
    Target

    Raises
    ------
    PathError
        For a field that does not exist (listing the fields that do), an index into
        something that is not an array, or a field name after a primitive.
    """
    desc: Fielddesc = (NAME, msgtype)
    where = msgtype
    for step in steps:
        node = int(desc[0])
        if node == NAME:
            if isinstance(step, int):
                raise PathError(
                    f"{where} is a message ({desc[1]}), not an array; [{step}] needs one"
                )
            fields = dict(typedefs[desc[1]][1])
            if step not in fields:
                names = _field_names(typedefs, desc[1])
                raise PathError(
                    f"{desc[1]} has no field {step!r}; "
                    f"{closest_names([step], names).replace('available', 'fields')}"
                )
            desc = fields[step]
            where = f"{where}.{step}" if where != msgtype else f".{step}"
        elif node in (ARRAY, SEQUENCE):
            if not isinstance(step, int):
                raise PathError(f"{where} is an array; index it before .{step}, e.g. [0].{step}")
            sub, length = desc[1]
            if node == ARRAY and not -length <= step < length:
                raise PathError(f"{where}[{step}]: index out of range (the array has {length})")
            desc = sub
            where = f"{where}[{step}]"
        else:
            raise PathError(f"{where} is a {desc[1][0]}; it has no {format_steps([step])}")
    return _target(desc)


def _target(desc: Fielddesc) -> Target:
    node = int(desc[0])
    if node == BASE:
        name = desc[1][0]
        return Target("string" if name in STRING_TYPES else "number", name)
    if node == NAME:
        return Target("message", desc[1])
    sub = desc[1][0]
    if int(sub[0]) == BASE and sub[1][0] not in STRING_TYPES:
        return Target("array", sub[1][0])
    return Target("message", "array")


def leaf_fields(typedefs: Typedefs, msgtype: str, *, limit: int = 64) -> list[str]:
    """Paths (steps only, e.g. ``.position[]``) of the numeric and text leaves of ``msgtype``.

    Arrays are shown as ``[]`` (their length is known only per message); nested messages
    inside arrays are not expanded.  At most ``limit`` are returned.
    """
    out: list[str] = []

    def walk(type_name: str, prefix: str, depth: int) -> None:
        if depth > 8 or type_name not in typedefs:
            return
        for name, desc in typedefs[type_name][1]:
            if len(out) >= limit or name == "structure_needs_at_least_one_member":
                continue
            node = int(desc[0])
            if node == BASE and (desc[1][0] in PRIMITIVE_SIZES or desc[1][0] in STRING_TYPES):
                out.append(f"{prefix}.{name}")
            elif node == NAME:
                walk(desc[1], f"{prefix}.{name}", depth + 1)
            elif node in (ARRAY, SEQUENCE):
                sub = desc[1][0]
                if int(sub[0]) == BASE and sub[1][0] in PRIMITIVE_SIZES:
                    out.append(f"{prefix}.{name}[]")

    walk(msgtype, "", 0)
    return out


# ---------------------------------------------------------------------------- decoded messages


def evaluate(message: object, steps: Sequence[Step]) -> object:
    """Follow ``steps`` through a decoded message (object, ``dict`` or sequence).

    Raises
    ------
    PathError
        For a missing field or an index outside the array (saying which).
    """
    value: object = message
    done: list[Step] = []
    for step in steps:
        if isinstance(step, int):
            if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__len__"):
                raise PathError(f"{format_steps(done) or 'the message'} is not an array")
            length = len(value)
            if not -length <= step < length:
                raise PathError(
                    f"{format_steps([*done, step])}: index out of range "
                    f"(the array has {length} elements)"
                )
            value = value[step]  # type: ignore[index]
        elif isinstance(value, Mapping):
            if step not in value:
                keys = [str(k) for k in value]
                raise PathError(
                    f"{format_steps(done) or 'the message'} has no field {step!r}; "
                    f"{closest_names([step], keys).replace('available', 'fields')}"
                )
            value = value[step]
        else:
            found = _attribute(value, step)
            if found is _MISSING:
                names = _public_names(value)
                raise PathError(
                    f"{format_steps(done) or 'the message'} has no field {step!r}; "
                    f"{closest_names([step], names).replace('available', 'fields')}"
                )
            value = found
        done.append(step)
    return value


_MISSING = object()


def accessor(steps: Sequence[Step]) -> Callable[[object], object]:
    """A function that follows ``steps`` through a decoded message object, at C speed.

    Attribute runs become one :func:`operator.attrgetter`, indices an
    :func:`operator.itemgetter`.  It raises what Python raises (``AttributeError``,
    ``IndexError``, ``TypeError``); :func:`evaluate` is the careful version that says why.
    """
    parts: list[Callable[[Any], Any]] = []
    names: list[str] = []
    for step in steps:
        if isinstance(step, int):
            if names:
                parts.append(operator.attrgetter(".".join(names)))
                names = []
            parts.append(operator.itemgetter(step))
        else:
            names.append(step)
    if names:
        parts.append(operator.attrgetter(".".join(names)))
    if len(parts) == 1:
        return parts[0]

    def follow(message: object) -> object:
        for part in parts:
            message = part(message)
        return message

    return follow


def _attribute(value: object, name: str) -> object:
    for candidate in (name, f"{name}_"):
        try:
            return getattr(value, candidate)
        except AttributeError:
            continue
    return _MISSING


def _public_names(value: object) -> list[str]:
    slots = getattr(value, "__slots__", None)
    names = (
        list(slots)
        if isinstance(slots, (list, tuple))
        else list(vars(value))
        if hasattr(value, "__dict__")
        else []
    )
    return [n.rstrip("_") for n in names if not n.startswith("_")]


def as_number(value: object) -> float:
    """A decoded leaf as a float (booleans as 0/1).

    Raises
    ------
    PathError
        When the value is a string, an array or a nested message.
    """
    if isinstance(value, (bool, int, float, np.number, np.bool_)):
        return float(value)
    raise PathError(f"is {_kind(value)}, not a number")


def as_float_array(value: object) -> FloatArray:
    """A decoded numeric array (list, tuple, ``array.array``, bytes or NumPy) as ``float64``.

    Raises
    ------
    PathError
        When the value is not an array of numbers.
    """
    if isinstance(value, (bytes, bytearray)):
        return np.frombuffer(value, dtype=np.uint8).astype(np.float64)
    if isinstance(value, (np.ndarray, array.array, list, tuple)):
        try:
            result: FloatArray = np.asarray(value, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError) as err:
            raise PathError(f"is {_kind(value)}, not an array of numbers") from err
        return result
    raise PathError(f"is {_kind(value)}, not an array of numbers")


def leaf_value(message: object, steps: Sequence[Step]) -> float | str | FloatArray:
    """What a path names in a decoded message, in one form whatever the decoder.

    Numbers (and booleans) come out as ``float``, text as ``str``, and numeric arrays as
    ``float64`` arrays -- whether the library gave a NumPy array (rosbags), a list
    (``mcap-ros2-support``, JSON), a tuple or ``bytes`` (``mcap-ros1-support``).

    Raises
    ------
    PathError
        For a missing field, an index out of range, or a nested message.
    """
    value = evaluate(message, steps)
    if isinstance(value, str):
        return value
    if isinstance(value, (bytes, bytearray, np.ndarray, array.array, list, tuple)):
        return as_float_array(value)
    return as_number(value)


def as_label(value: object) -> str:
    """A decoded leaf as a mode label: text as is, integral numbers without ``.0``.

    Raises
    ------
    PathError
        When the value is an array or a nested message.
    """
    if isinstance(value, str):
        return value.strip()
    if isinstance(value, (bytes, bytearray)):
        return value.decode("utf-8", errors="replace").strip()
    if isinstance(value, (bool, np.bool_)):
        return str(int(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        number = float(value)
        return str(int(number)) if math.isfinite(number) and number.is_integer() else repr(number)
    raise PathError(f"is {_kind(value)}, not a mode label")


def number_label(values: FloatArray) -> tuple[IntArray, tuple[str, ...]]:
    """Numeric labels (e.g. an ``Int32`` mode) as codes into their text forms."""
    categories, codes = np.unique(values, return_inverse=True)
    texts = tuple(as_label(float(c)) for c in categories)
    return codes.astype(np.int64).reshape(-1), texts


def _kind(value: object) -> str:
    if isinstance(value, str):
        return "a string"
    if isinstance(value, (list, tuple, np.ndarray, array.array, bytes, bytearray)):
        return "an array"
    if value is None:
        return "null"
    if isinstance(value, Mapping):
        return "a message (an object)"
    return f"a message ({type(value).__name__})"


def stamp_ns(value: object) -> int:
    """A decoded ``header.stamp`` in integer nanoseconds.

    Accepts ROS 2 (``sec``/``nanosec``), ROS 1 (``secs``/``nsecs``, or rosbags' ``sec``/
    ``nanosec``), Foxglove JSON (``sec``/``nsec``) and a plain number of seconds.

    Raises
    ------
    PathError
        When the value is none of these.
    """
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if not math.isfinite(value):
            raise PathError(f"is {value}, not a time")
        return round(value * 1_000_000_000)
    for sec_name, nsec_name in (("sec", "nanosec"), ("secs", "nsecs"), ("sec", "nsec")):
        if isinstance(value, Mapping):
            sec, nsec = value.get(sec_name), value.get(nsec_name)
        else:
            sec, nsec = getattr(value, sec_name, None), getattr(value, nsec_name, None)
        if isinstance(sec, (int, np.integer)) and isinstance(nsec, (int, np.integer)):
            return int(sec) * 1_000_000_000 + int(nsec)
    to_nsec = getattr(value, "to_nsec", None)
    if callable(to_nsec):
        return int(to_nsec())
    raise PathError(f"is {_kind(value)}, not a time stamp (sec and nanosec)")


# ---------------------------------------------------------------------------- batch decoding


@dataclass(frozen=True)
class RawBatch:
    """Serialised messages laid end to end.

    Attributes
    ----------
    buffer:
        All messages, concatenated, as bytes.
    starts, ends:
        Payload start (after the CDR encapsulation header) and end of each message in
        ``buffer``.
    big_endian:
        Per message, whether its CDR payload is big-endian; ``None`` when none is.
    """

    buffer: npt.NDArray[np.uint8]
    starts: IntArray
    ends: IntArray
    big_endian: npt.NDArray[np.bool_] | None

    @property
    def size(self) -> int:
        """Number of messages."""
        return int(self.starts.size)


def make_batch(messages: Sequence[bytes | memoryview], *, cdr: bool) -> RawBatch:
    """Concatenate serialised messages and check their CDR encapsulation headers.

    Raises
    ------
    UndecodableError
        For a CDR message shorter than its header or with an encapsulation other than plain
        little- or big-endian CDR.
    """
    n = len(messages)
    lengths = np.fromiter(map(len, messages), dtype=np.int64, count=n)
    ends = np.cumsum(lengths)
    offsets = ends - lengths
    buffer = np.frombuffer(b"".join(messages), dtype=np.uint8)
    big: npt.NDArray[np.bool_] | None = None
    if cdr:
        short = lengths < 4
        if short.any():
            raise UndecodableError(int(np.argmax(short)), "shorter than a CDR header")
        first, kind = buffer[offsets], buffer[offsets + 1]
        bad = (first != 0) | (kind > 1)
        if bad.any():
            row = int(np.argmax(bad))
            raise UndecodableError(
                row,
                f"CDR encapsulation 0x{int(first[row]):02x}{int(kind[row]):02x} is not plain "
                "CDR (0x0000 or 0x0001)",
            )
        little = kind == 1
        if not little.all():
            big = ~little
        offsets = offsets + 4
    return RawBatch(buffer, offsets, ends, big)


class BatchDecoder:
    """Reads paths out of a :class:`RawBatch` of messages of one type, all at once.

    Parameters
    ----------
    typedefs:
        rosbags field definitions (``Typestore.fielddefs``) holding ``msgtype``.
    msgtype:
        The messages' type.
    cdr:
        ``True`` for CDR (ROS 2), ``False`` for ROS 1 serialisation.
    """

    def __init__(self, typedefs: Typedefs, msgtype: str, *, cdr: bool) -> None:
        self._typedefs = typedefs
        self._msgtype = msgtype
        self._cdr = cdr

    # -- public

    def check_sizes(self, batch: RawBatch) -> None:
        """Check that the definition accounts for every byte of every message in ``batch``.

        A definition that does not describe the bytes -- a placeholder stored by the
        recorder, a type changed between recording and reading -- would otherwise be read
        "successfully" into wrong numbers.  The end of each message according to the
        definition must be its actual end: exactly for ROS 1; for CDR up to 3 bytes of
        trailing padding are allowed, as rosbags' deserialiser allows them.

        Raises
        ------
        UndecodableError
            Naming the first message whose size does not fit the definition.
        LayoutError
            When the walk needs the one-by-one fallback (which checks sizes itself).
        """
        rows: IntArray = np.arange(batch.size, dtype=np.int64)
        end = self._skip(batch, rows, np.zeros(batch.size, dtype=np.int64), (NAME, self._msgtype))
        length = batch.ends - batch.starts
        slack = length - end
        bad = (slack < 0) | (slack > (3 if self._cdr else 0))
        if bad.any():
            row = int(np.argmax(bad))
            raise UndecodableError(
                row,
                f"its stored definition of {self._msgtype} accounts for {int(end[row])} of its "
                f"{int(length[row])} bytes: the messages were not written with this definition",
            )

    def numbers(self, batch: RawBatch, steps: Sequence[Step]) -> FloatArray:
        """The number at ``steps`` in every message, as ``float64``.

        Raises
        ------
        UndecodableError, IndexRangeError, LayoutError
        """
        rows, pos, desc = self._locate(batch, steps)
        name = self._primitive(desc)
        values = self._read(batch, rows, pos, name)
        result: FloatArray = values.astype(np.float64)
        return result

    def labels(self, batch: RawBatch, steps: Sequence[Step]) -> tuple[IntArray, tuple[str, ...]]:
        """The label (string, or number as text) at ``steps``: codes and categories."""
        rows, pos, desc = self._locate(batch, steps)
        if int(desc[0]) == BASE and desc[1][0] in STRING_TYPES:
            return self._strings(batch, rows, pos)
        values = self._read(batch, rows, pos, self._primitive(desc)).astype(np.float64)
        return number_label(values)

    def stamps(self, batch: RawBatch, steps: Sequence[Step]) -> IntArray:
        """A ``builtin_interfaces/Time`` at ``steps`` in integer nanoseconds."""
        rows, pos, desc = self._locate(batch, steps)
        if int(desc[0]) != NAME:
            raise LayoutError("not a time stamp")
        fields = self._typedefs[desc[1]][1]
        names = [name for name, _ in fields]
        if names[:2] not in (["sec", "nanosec"], ["secs", "nsecs"]):
            raise LayoutError("not a time stamp")
        sec_name = self._primitive(fields[0][1])
        sec = self._read(batch, rows, pos, sec_name).astype(np.int64)
        pos = self._align(pos, PRIMITIVE_SIZES[sec_name]) + PRIMITIVE_SIZES[sec_name]
        nsec = self._read(batch, rows, pos, self._primitive(fields[1][1])).astype(np.int64)
        result: IntArray = sec * 1_000_000_000 + nsec
        return result

    # -- walking

    def _locate(
        self, batch: RawBatch, steps: Sequence[Step]
    ) -> tuple[IntArray, IntArray, Fielddesc]:
        """Rows, payload-relative offsets and description of the field at ``steps``."""
        rows: IntArray = np.arange(batch.size, dtype=np.int64)
        pos: IntArray = np.zeros(batch.size, dtype=np.int64)
        desc: Fielddesc = (NAME, self._msgtype)
        for step in steps:
            node = int(desc[0])
            if node == NAME:
                for name, field in self._typedefs[desc[1]][1]:
                    if name == step:
                        desc = field
                        break
                    pos = self._skip(batch, rows, pos, field)
                else:
                    raise LayoutError(f"no field {step!r}")
            elif node in (ARRAY, SEQUENCE) and isinstance(step, int):
                sub, length = desc[1]
                if node == SEQUENCE:
                    pos = self._align(pos, 4)
                    count = self._read(batch, rows, pos, "uint32").astype(np.int64)
                    pos = pos + 4
                else:
                    count = np.full(rows.size, length, dtype=np.int64)
                index = count + step if step < 0 else np.full(rows.size, step, dtype=np.int64)
                bad = (index < 0) | (index >= count)
                if bad.any():
                    row = int(np.argmax(bad))
                    raise IndexRangeError(int(rows[row]), int(count[row]))
                if int(sub[0]) == BASE and sub[1][0] in PRIMITIVE_SIZES:
                    size = PRIMITIVE_SIZES[sub[1][0]]
                    pos = self._align(pos, size) + index * size
                else:
                    pos = self._skip_elements(batch, rows, pos, sub, index)
                desc = sub
            else:
                raise LayoutError(f"cannot step {step!r} into {desc!r}")
        return rows, pos, desc

    def _align(self, pos: IntArray, size: int) -> IntArray:
        if not self._cdr or size == 1:
            return pos
        aligned: IntArray = (pos + (size - 1)) & -size
        return aligned

    def _skip(self, batch: RawBatch, rows: IntArray, pos: IntArray, desc: Fielddesc) -> IntArray:
        node = int(desc[0])
        if node == BASE:
            name = desc[1][0]
            if name in PRIMITIVE_SIZES:
                size = PRIMITIVE_SIZES[name]
                return self._align(pos, size) + size
            if name in STRING_TYPES:
                pos = self._align(pos, 4)
                length = self._read(batch, rows, pos, "uint32").astype(np.int64)
                end = pos + 4 + length
                self._check_end(batch, rows, end)
                return end
            raise LayoutError(f"type {name}")
        if node == NAME:
            for name, field in self._typedefs[desc[1]][1]:
                if not self._cdr and name == "structure_needs_at_least_one_member":
                    continue
                pos = self._skip(batch, rows, pos, field)
            return pos
        sub, length = desc[1]
        if node == SEQUENCE:
            pos = self._align(pos, 4)
            count = self._read(batch, rows, pos, "uint32").astype(np.int64)
            pos = pos + 4
        else:
            count = np.full(rows.size, length, dtype=np.int64)
        if int(sub[0]) == BASE and sub[1][0] in PRIMITIVE_SIZES:
            size = PRIMITIVE_SIZES[sub[1][0]]
            nonempty = count > 0
            after: IntArray = np.where(nonempty, self._align(pos, size), pos) + count * size
            self._check_end(batch, rows, after)
            return after
        return self._skip_elements(batch, rows, pos, sub, count)

    def _skip_elements(
        self, batch: RawBatch, rows: IntArray, pos: IntArray, sub: Fielddesc, count: IntArray
    ) -> IntArray:
        """Skip ``count[i]`` elements of type ``sub`` in message ``rows[i]``."""
        if not count.size:
            return pos
        most = int(count.max())
        if most > MAX_WALKED_ELEMENTS:
            raise LayoutError(f"{most} nested elements")
        remaining = batch.ends[rows] - batch.starts[rows] - pos
        if (count > remaining).any():
            row = int(np.argmax(count > remaining))
            raise UndecodableError(
                int(rows[row]), f"array length {int(count[row])} exceeds the message"
            )
        pos = pos.copy()
        for j in range(most):
            active = np.flatnonzero(count > j)
            pos[active] = self._skip(batch, rows[active], pos[active], sub)
        return pos

    # -- reading

    @staticmethod
    def _primitive(desc: Fielddesc) -> str:
        if int(desc[0]) == BASE and desc[1][0] in PRIMITIVE_SIZES:
            return str(desc[1][0])
        raise LayoutError(f"not a primitive: {desc!r}")

    @staticmethod
    def _check_end(batch: RawBatch, rows: IntArray, end: IntArray) -> None:
        over = end > batch.ends[rows] - batch.starts[rows]
        if over.any():
            row = int(np.argmax(over))
            raise UndecodableError(int(rows[row]), "a field runs past the end of the message")

    def _read(
        self, batch: RawBatch, rows: IntArray, pos: IntArray, name: str
    ) -> np.ndarray[Any, Any]:
        size = PRIMITIVE_SIZES[name]
        pos = self._align(pos, size)
        self._check_end(batch, rows, pos + size)
        start = batch.starts[rows] + pos
        if size == 1:
            single: np.ndarray[Any, Any] = batch.buffer[start].view(_DTYPES[name])
            return single
        gathered = batch.buffer[start[:, None] + np.arange(size)]
        if batch.big_endian is not None:
            big = batch.big_endian[rows]
            if big.any():
                gathered[big] = gathered[big, ::-1]
        values: np.ndarray[Any, Any] = (
            np.ascontiguousarray(gathered).view("<" + _DTYPES[name]).reshape(-1)
        )
        return values

    def _strings(
        self, batch: RawBatch, rows: IntArray, pos: IntArray
    ) -> tuple[IntArray, tuple[str, ...]]:
        pos = self._align(pos, 4)
        length = self._read(batch, rows, pos, "uint32").astype(np.int64)
        self._check_end(batch, rows, pos + 4 + length)
        if self._cdr:
            length = np.maximum(length - 1, 0)  # CDR strings carry their NUL
        start = batch.starts[rows] + pos + 4
        if rows.size == 0:
            return np.zeros(0, dtype=np.int64), ()
        longest = int(length.max())
        if longest <= MAX_VECTOR_LABEL:
            width = max(longest, 1)
            columns = np.arange(width)
            inside = columns[None, :] < length[:, None]
            index = np.where(inside, start[:, None] + columns, 0)
            chars = np.where(inside, batch.buffer[index], 0).astype(np.uint8)
            fixed = np.ascontiguousarray(chars).view(f"S{width}").reshape(-1)
            unique, codes = np.unique(fixed, return_inverse=True)
            texts = [u.decode("utf-8", errors="replace").strip() for u in unique.tolist()]
        else:
            raw = [
                batch.buffer[a : a + n].tobytes().decode("utf-8", errors="replace").strip()
                for a, n in zip(start.tolist(), length.tolist(), strict=True)
            ]
            texts_sorted, codes = np.unique(np.array(raw, dtype=object), return_inverse=True)
            texts = [str(t) for t in texts_sorted.tolist()]
        return _merge_equal_labels(codes.astype(np.int64).reshape(-1), texts)


def _merge_equal_labels(codes: IntArray, texts: Sequence[str]) -> tuple[IntArray, tuple[str, ...]]:
    """Codes into distinct texts (texts equal after stripping share one code)."""
    distinct: dict[str, int] = {}
    lookup = np.array([distinct.setdefault(t, len(distinct)) for t in texts], dtype=np.int64)
    remapped: IntArray = lookup[codes] if lookup.size else codes
    return remapped, tuple(distinct)


def decode_each(decode: Callable[[bytes], object], messages: Sequence[bytes]) -> list[object]:
    """Decode messages one by one (the fallback of :class:`BatchDecoder`).

    Raises
    ------
    UndecodableError
        Naming the first message the decoder rejects.
    """
    out: list[object] = []
    for row, data in enumerate(messages):
        try:
            out.append(decode(data))
        except Exception as err:  # any decoder failure means a bad message
            reason = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
            raise UndecodableError(row, reason) from err
    return out
