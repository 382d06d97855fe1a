"""Message paths: naming one number (or label) inside the messages of a topic (SPEC §5).

A path is ``/topic.field.sub[index]`` (Foxglove style); ``[-1]`` counts from the end of an
array.  The PlotJuggler/rqt spelling ``/topic/field/sub[0]`` is accepted too: the topic is
the *longest* topic of the log that the path starts with (followed by ``.``, ``/``, ``[`` or
the end), so ``/truth/x1/data`` on a log with topics ``/truth/x1`` and ``/truth`` means field
``data`` of ``/truth/x1``.  A topic in double quotes (``"/a.b".v``) is that topic exactly;
:func:`split_paths` gives every reading of a path on nested topics, of which
:meth:`~hybridlog.io.messages.MessageSource.resolve` keeps the one that names a field.

The same path works on every kind of message hybridlog reads:

- :func:`evaluate` follows a path through a decoded message -- a rosbags message object (ROS 1
  or ROS 2), an ``mcap-ros1-support``/``mcap-ros2-support`` object or a JSON ``dict`` -- and
  :func:`leaf_value` returns what it finds as a float, a string, or a ``float64`` array for
  numeric arrays, whatever container the library returned.
- :func:`check_path` checks a path against a message definition (a rosbags type store)
  before anything is read, so that a wrong field is reported with the fields that exist.
- :func:`decode_each` deserialises messages with the log's deserialiser and :func:`accessor`
  reads a path out of each with compiled attribute getters.  (A hand-written decoder that
  read paths straight from the serialised bytes was measured at 1.15x the whole read of a
  rosbags deserialise loop on ``Float64`` messages -- not worth code that must re-implement
  rosbags' size checks to be safe -- and was removed.)
"""

from __future__ import annotations

import array
import math
import operator
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, TypeGuard

import numpy as np

from hybridlog.errors import excerpt
from hybridlog.io.source import MAX_SECONDS, NS_PER_S, closest_names
from hybridlog.signals import FloatArray

Step = str | int
"""One step of a path: a field name or an array index (negative from the end)."""

BASE, NAME, ARRAY, SEQUENCE = 1, 2, 3, 4
"""rosbags' ``Nodetype`` values (an ``IntEnum``; compared as plain ints here)."""

NUMERIC_TYPES = frozenset(
    (
        "bool",
        "byte",
        "char",
        "int8",
        "uint8",
        "int16",
        "uint16",
        "int32",
        "uint32",
        "int64",
        "uint64",
        "float32",
        "float64",
    )
)
"""The primitive types of ROS messages that read as numbers."""
STRING_TYPES = ("string",)

_STEP = re.compile(r'[./]"((?:[^"\\]|\\.)*)"|[./]([^./\[\]]+)|\[\s*(-?\d+)\s*\]')
"""A step: ``.field`` (or ``/field``), ``."field.with.dots"`` (a JSON key holding path syntax,
quoted as :func:`spell_field` writes it: ``\\"`` and ``\\\\`` inside the quotes are ``"`` and
``\\``; ``.""`` is the empty key) or ``[index]``."""

_ESCAPED = re.compile(r'\\(["\\])')
"""An escaped ``"`` or ``\\`` inside a quoted step."""

_PATH_SYNTAX = frozenset('./[]"')


def spell_field(name: str) -> str:
    r"""``name`` as a step of a path, quoted where a bare step would not read back as it.

    In double quotes when it holds ``.``, ``/``, ``[``, ``]`` or ``"``, has spaces at either
    end (an unquoted step is stripped) or is empty (``""``); inside the quotes ``"`` and ``\``
    are written ``\"`` and ``\\``, so that :func:`split_path` reads the step back as
    ``name``.  A JSON key such as ``"a.b"`` or ``"c[0]"`` would otherwise read as two steps or
    as an index (``.a.b``, ``.c[0]``): listed that way by ``inspect``, it named a field no
    message has; so did ``a"b`` listed ``."a"b"`` and the empty key listed ``.``.
    """
    syntax = not name or any(c in _PATH_SYNTAX for c in name) or name != name.strip()
    if not syntax:
        return name
    # a key holding '"' (or an empty one) listed as ."a"b" (or as ".") named nothing --map read
    return '"' + name.replace("\\", "\\\\").replace('"', '\\"') + '"'


Fielddesc = tuple[Any, Any]
Typedefs = Mapping[str, tuple[Any, Sequence[tuple[str, Fielddesc]]]]


class PathError(Exception):
    """A path that does not fit the log or its messages (message without file prefix)."""


def no_field(where: str, step: str, names: Sequence[str]) -> PathError:
    """``<where> has no field 'x'; closest fields: ...``, of a path step no field matches.

    One wording for a path into a ROS definition, a decoded message and a JSON schema.
    """
    return PathError(
        f"{where} has no field {step!r}; "
        f"{closest_names([step], names).replace('available', 'fields')}"
    )


class UndecodableError(Exception):
    """A serialised message does not match its definition.

    Attributes
    ----------
    row:
        Index of the offending message among those given to :func:`decode_each`.
    """

    def __init__(self, row: int, reason: str) -> None:
        super().__init__(reason)
        self.row = row


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
    return "".join(f"[{s}]" if isinstance(s, int) else f".{spell_field(s)}" for s in steps)


def split_path(text: str, topics: Sequence[str]) -> MessagePath:
    """Split ``text`` into the longest matching topic and the steps after it.

    A topic written in double quotes (``"/a.b".v``) is that topic exactly.

    Raises
    ------
    PathError
        When no topic of the log starts the path (listing the closest), or the rest is not
        a sequence of ``.field``, ``/field`` and ``[index]``.
    """
    return split_paths(text, topics)[0]


def split_paths(text: str, topics: Sequence[str]) -> list[MessagePath]:
    """Every way ``text`` splits into a topic of ``topics`` and steps, longest topic first.

    A path names one topic unless topics nest (``/truth`` and ``/truth/x1``, or ``/a`` and
    ``/a.b`` in an MCAP file): the caller checks which readings name a field.  A quoted topic
    (``"/a.b".v``) gives one reading.  A topic whose rest is not a sequence of steps gives
    no reading, the longest too: ``/u/data`` on topics ``/u/`` and ``/u`` is ``/u`` +
    ``/data`` (it was refused, "cannot read 'data' after the topic" ``/u/``).

    Raises
    ------
    PathError
        As :func:`split_path`: no topic starts the path, or no topic's rest is a sequence of
        steps (the longest topic's error).
    """
    text = text.strip()
    quoted = [t for t in topics if text.startswith(f'"{t}"')]
    candidates = sorted(
        quoted or (t for t in topics if _starts(text, t)),
        key=len,
        reverse=True,
    )
    if not candidates:
        guess = text.split(".", 1)[0].split("[", 1)[0]
        raise PathError(f"no topic for {text!r}; {closest_names([guess], list(topics))}")
    readings: list[MessagePath] = []
    errors: list[PathError] = []
    for topic in candidates:
        rest = text[len(topic) + 2 :] if quoted else text[len(topic) :]
        try:
            readings.append(MessagePath(text, topic, _steps(text, rest)))
        except PathError as err:
            errors.append(err)
    if not readings:
        raise errors[0]
    return readings


def _starts(text: str, topic: str) -> bool:
    """Whether ``text`` is ``topic`` or the topic followed by a step."""
    if not topic or not text.startswith(topic):
        return False
    rest = text[len(topic) :]
    return not rest or rest[0] in "./[" or topic.endswith("/")


def _steps(text: str, rest: str) -> tuple[Step, ...]:
    """The steps of ``rest`` (``.a/b[0]``), the part of path ``text`` after its topic."""
    steps: list[Step] = []
    position = 0
    while position < len(rest):
        match = _STEP.match(rest, position)
        if match is None:
            raise PathError(
                f"{text!r}: cannot read {rest[position:]!r} after the topic "
                '(expected .field, /field, ."field" or [index], e.g. /joint_states.position[0])'
            )
        quoted, field, index = match.groups()
        if index is not None and index.startswith("-") and int(index) == 0:
            # Python reads a[-0] as a[0]; one counting from the end meant another element
            raise PathError(
                f"{text!r}: [{index}] counts from neither end; write [0] for the first "
                "element or [-1] for the last"
            )
        if quoted is not None:
            steps.append(_ESCAPED.sub(r"\1", quoted))
        else:
            steps.append(int(index) if index is not None else field.strip())
        position = match.end()
    return tuple(steps)


# ---------------------------------------------------------------------------- static check


@dataclass(frozen=True)
class Target:
    """What a path names in a message definition.

    Attributes
    ----------
    kind:
        ``"number"``, ``"string"``, ``"array"`` (no index given) or ``"message"``.
    type_name:
        The primitive or message type at the end of the path (of the elements, for an
        array).
    """

    kind: str
    type_name: str


def _field_names(typedefs: Typedefs, msgtype: str) -> list[str]:
    return [
        name for name, _ in typedefs[msgtype][1] if name != "structure_needs_at_least_one_member"
    ]


def _refuse_constant(typedefs: Typedefs, msgtype: str, step: Step) -> None:
    """Raise for a path step naming a constant of ``msgtype``: messages do not carry it.

    It read "has no field 'POWER_SUPPLY_STATUS_FULL'; closest fields: power_supply_status",
    of a name the definition holds.
    """
    for constant in typedefs[msgtype][0]:
        if constant[0] == step:
            raise PathError(
                f"{msgtype} has no field {step!r}: it is a constant of the type ({constant[1]} "
                f"{excerpt(constant[2], 40)[1:-1]}), which no message carries"
            )


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
                _refuse_constant(typedefs, desc[1], step)
                raise no_field(desc[1], step, _field_names(typedefs, desc[1]))
            desc = fields[step]
            where = f"{where}.{step}" if where != msgtype else f".{step}"
        elif node in (ARRAY, SEQUENCE):
            if not isinstance(step, int):
                if step.removeprefix("-").isdigit():  # PlotJuggler's .0 for [0]
                    raise PathError(f"{where} is an array; write its index in brackets: [{step}]")
                raise PathError(f"{where} is an array; index it before .{step}, e.g. [0].{step}")
            sub, length = desc[1]
            if node == ARRAY and not -length <= step < length:
                raise PathError(out_of_range(f"{where}[{step}]", length))
            desc = sub
            where = f"{where}[{step}]"
        else:
            raise PathError(f"{where} is a {desc[1][0]}; it has no {format_steps([step])}")
    return _target(desc)


def out_of_range(where: str, length: int) -> str:
    """Why an index is no element: ``.data[3]: index out of range (the array has 3 elements)``.

    One wording for an array whose length the schema fixes and one whose length a message
    gives: the fixed one read "(the array has 9)", 9 of what left to guess.
    """
    return (
        f"{where}: index out of range (the array has {length} element{'' if length == 1 else 's'})"
    )


def from_the_start(typedefs: Typedefs, msgtype: str, steps: Sequence[Step]) -> tuple[Step, ...]:
    """``steps`` with every negative index into a fixed-size array counted from its start.

    ``q[-1]`` of a ``float64[3]`` is ``q[2]``: one element, two spellings.  An index into a
    sequence, whose length is known only per message, stays as written.  ``steps`` fit the
    definition (:func:`check_path` passed them).
    """
    desc: Fielddesc = (NAME, msgtype)
    counted: list[Step] = []
    for step in steps:
        node = int(desc[0])
        if node == NAME:
            desc = dict(typedefs[desc[1]][1])[str(step)]
        else:  # an array or a sequence: check_path let nothing else take a step
            sub, length = desc[1]
            if node == ARRAY and isinstance(step, int) and step < 0:
                step += int(length)
            desc = sub
        counted.append(step)
    return tuple(counted)


def _target(desc: Fielddesc) -> Target:
    node = int(desc[0])
    if node == BASE:
        name = desc[1][0]
        return Target("string" if name in STRING_TYPES else "number", name)
    if node == NAME:
        return Target("message", desc[1])
    # an array of numbers, of strings or of messages: an index picks one element
    sub = desc[1][0]
    return Target("array", sub[1][0] if int(sub[0]) == BASE else sub[1])


FLOAT_TYPES = frozenset(("float32", "float64"))
"""The primitive types of ROS messages that can hold NaN and infinities."""


@dataclass(frozen=True)
class Leaf:
    """A numeric or text leaf of a message definition.

    Attributes
    ----------
    steps:
        Field names from the message down to the leaf.
    type_name:
        Its primitive type (of the elements, for an array), e.g. ``float64``.
    array:
        Whether it is an array of numbers or text (whose length is known only per message).
    """

    steps: tuple[str, ...]
    type_name: str
    array: bool

    @property
    def text(self) -> str:
        """The path after the topic, e.g. ``.position[]`` (``[]`` marks an array)."""
        return format_steps(self.steps) + ("[]" if self.array else "")


def leaves(typedefs: Typedefs, msgtype: str) -> list[Leaf]:
    """Every numeric and text leaf of ``msgtype``, in definition order.

    Arrays of numbers and of text are leaves (an element of a ``string[]`` is a mode label
    as a ``string`` is: ``inspect`` left them out of the fields it lists); nested messages
    inside arrays are not expanded.  All of
    them, however many: ``inspect`` lists them as the fields a symbol can be mapped to, and
    counts the NaN and infinite values of each floating-point one (a cap left the fields
    past it unlisted and their values uncounted).  A definition that contains itself (no
    ROS type can, a damaged one might) is not followed into itself.
    """
    out: list[Leaf] = []

    def walk(type_name: str, prefix: tuple[str, ...], within: frozenset[str]) -> None:
        if type_name in within or type_name not in typedefs:
            return
        within = within | {type_name}
        for name, desc in typedefs[type_name][1]:
            if name == "structure_needs_at_least_one_member":
                continue
            node = int(desc[0])
            if node == BASE and (desc[1][0] in NUMERIC_TYPES or desc[1][0] in STRING_TYPES):
                out.append(Leaf((*prefix, name), desc[1][0], array=False))
            elif node == NAME:
                walk(desc[1], (*prefix, name), within)
            elif node in (ARRAY, SEQUENCE):
                sub = desc[1][0]
                if int(sub[0]) == BASE and (
                    sub[1][0] in NUMERIC_TYPES or sub[1][0] in STRING_TYPES
                ):
                    out.append(Leaf((*prefix, name), sub[1][0], array=True))

    walk(msgtype, (), frozenset())
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
            # bytes are a uint8[] as mcap-ros1-support decodes it: indexed like any array
            if isinstance(value, (str, Mapping)) or not hasattr(value, "__len__"):
                raise PathError(f"{format_steps(done) or 'the message'} is not an array")
            length = len(value)
            if not -length <= step < length:
                raise PathError(out_of_range(format_steps([*done, step]), length))
            value = value[step]  # type: ignore[index]
        elif isinstance(value, Mapping):
            if step not in value:
                keys = [spell_field(str(k)) for k in value]
                raise no_field(format_steps(done) or "the message", step, keys)
            value = value[step]
        else:
            found = _attribute(value, step)
            if found is _MISSING:
                raise no_field(format_steps(done) or "the message", step, _public_names(value))
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

    A JSON integer beyond the range of a float64 (JSON integers have no bound) is infinite,
    as ``1e400`` is: the reader names either as written, or drops it with
    ``--drop-nonfinite``, and ``inspect`` counts it as non-finite.

    Raises
    ------
    PathError
        When the value is a string, an array or a nested message.
    """
    if isinstance(value, (bool, int, float, np.number, np.bool_)):
        try:
            return float(value)
        except OverflowError:  # only a Python int overflows
            return math.inf if value > 0 else -math.inf
    raise PathError(f"is {_kind(value)}, not a number")


def as_float_array(value: object) -> FloatArray:
    """A decoded numeric array (list, tuple, ``array.array``, bytes or NumPy) as ``float64``.

    An integer beyond the range of a float64 is infinite there, as in :func:`as_number`.

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
        except OverflowError:  # a JSON integer of more than 308 digits
            return np.array([as_number(v) for v in value], dtype=np.float64)
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
    ``nanosec``), Foxglove JSON (``sec``/``nsec``) and a plain number of seconds.  The
    nanoseconds must be a fraction of a second (0 to 999999999, as ROS's ``Time`` says): a
    stamp of 10 s and 1500000000 ns comes from a publisher that did not carry into the
    seconds, and which time it meant is a guess; booleans (JSON ``true``) are no numbers.

    Raises
    ------
    PathError
        When the value is none of these, the nanoseconds are not a fraction of a second, or
        the time is beyond the :data:`~hybridlog.io.source.MAX_SECONDS` the nanosecond grid
        holds.
    """
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if not math.isfinite(value):
            raise PathError(f"is {value}, not a time")
        seconds = f"{value:g} s (a stamp in nanoseconds or milliseconds, where seconds are meant?)"
        return _on_the_grid(round(value * 1_000_000_000), seconds)
    for sec_name, nsec_name in (("sec", "nanosec"), ("secs", "nsecs"), ("sec", "nsec")):
        if isinstance(value, Mapping):
            sec, nsec = value.get(sec_name), value.get(nsec_name)
        else:
            sec, nsec = getattr(value, sec_name, None), getattr(value, nsec_name, None)
        if _whole(sec) and _whole(nsec):
            if not 0 <= int(nsec) < NS_PER_S:
                raise PathError(
                    f"has {nsec_name} = {int(nsec)}, not a fraction of a second ({sec_name} = "
                    f"{int(sec)}; {nsec_name} is 0 to {NS_PER_S - 1})"
                )
            ns = int(sec) * NS_PER_S + int(nsec)
            return _on_the_grid(ns, f"{int(sec)} s and {int(nsec)} ns")
    to_nsec = getattr(value, "to_nsec", None)
    if callable(to_nsec):
        ns = int(to_nsec())
        return _on_the_grid(ns, f"{ns} ns")
    raise PathError(f"is {_kind(value)}, not a time stamp (sec and nanosec)")


def _whole(value: object) -> TypeGuard[int | np.integer[Any]]:
    """Whether ``value`` is an integer (Python's or NumPy's), a boolean not counted."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def _on_the_grid(ns: int, shown: str) -> int:
    """``ns``, if it fits the int64 nanoseconds of the grid (``|t| <`` ``MAX_SECONDS``)."""
    if not abs(ns) < MAX_SECONDS * NS_PER_S:
        raise PathError(f"is beyond the {MAX_SECONDS:.2g} s the nanosecond grid holds: {shown}")
    return ns


def decode_each(decode: Callable[[bytes], object], messages: Sequence[bytes]) -> list[object]:
    """Decode messages one by one with the log's deserialiser (rosbags' for CDR and ROS 1).

    rosbags' deserialisers refuse a message whose bytes do not end where its definition
    says (a placeholder definition stored in a bag), so a wrong definition is an error here,
    never a wrong number.

    A message the decoder rejects whose bytes open a compressed frame (:data:`COMPRESSED`)
    is named so: the storage file of a ROS 2 bag compressed per message, read without its
    folder, was "Invalid or unsupported CDR encapsulation", which names no cause.

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
            raise UndecodableError(row, _compressed(data) or reason) from err
    return out


COMPRESSED = {b"\x28\xb5\x2f\xfd": "zstd", b"\x04\x22\x4d\x18": "LZ4"}
"""Magic numbers opening a compressed frame, and the compression they name."""


def _compressed(data: bytes) -> str | None:
    """Why a message whose bytes are a compressed frame does not decode, or ``None``."""
    kind = next((name for magic, name in COMPRESSED.items() if data.startswith(magic)), None)
    if kind is None:
        return None
    return (
        f"its bytes are {kind}-compressed: a ROS 2 bag compressed per message is read "
        "through its folder, whose metadata.yaml names the compression"
    )
