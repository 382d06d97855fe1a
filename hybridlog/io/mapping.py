"""Which log field feeds which model symbol (SPEC §5).

For each model input and output, and for the ground truth (``truth.mode``,
``truth.<state>``, and for a ``[components]`` model ``truth.mode.<component>`` instead of
``truth.mode``), the field is chosen in this order:

1. ``--map SYMBOL=PATH`` given by the user (the field must exist);
2. the model's ``[signals]`` / ``[truth]`` path, when the log has that field (a field the
   log has but that cannot be used -- text, the time column, a path naming two fields -- is
   an error for an input or output, and no truth for ground truth: never replaced by the
   default field, which the model did not name);
3. the default name: in CSV/Parquet, a column named like the symbol (``u1``, ``y``; ``mode``
   for the true mode; the state's name for a true state); in bags and MCAP files, the topics
   ``hybridlog simulate`` writes (:func:`default_fields`):

   ==================== ==========================================
   symbol               default message path
   ==================== ==========================================
   input or output *s*  ``/s.data`` (``std_msgs/Float64``)
   ``truth.mode``       ``/truth/mode.data`` (``std_msgs/String``)
   ``truth.mode.c``     ``/truth/mode/c.data`` (``std_msgs/String``): component ``c``
   ``truth.x`` (state)  ``/truth/x.data`` (``std_msgs/Float64``)
   ==================== ==========================================

   Topics are ROS names (:func:`column_topic`: ``/``-separated tokens of ASCII letters,
   digits and ``_``, none starting with a digit, as ``ros2 bag`` and rclcpp require): a
   name that is not a token is written as one (``θ`` → ``theta``, ``fr-1`` → ``fr_1``).
   The topics hybridlog wrote before (``/truth/mode.c``, ``/truth/θ``) are looked for
   when the log has no topic of the ROS name.

The commands a ``[components]`` model's transition rules name (``when``) are found like
inputs (``--map``, ``[signals]``, the default name ``/s.data`` or column ``s``), but are
optional: a log without one is read, and the estimator that applies the rules refuses it
(``unknown-mode``); a field the log has but that cannot be used is an error, as for an input.

Inputs and outputs must be found; ground truth is optional unless mapped with ``--map``
(and a ground-truth field found by default that holds no sample is no truth either:
:func:`~hybridlog.io.load.load_signals` drops it).  A ground-truth field the log has (in
``fields``) but that cannot be used as asked -- text for a state, a topic without
``header.stamp`` read with ``--time header`` -- is no truth either, unless mapped with
``--map``; :attr:`SignalMap.unusable_truth` says why, for the report.

One field never feeds two inputs or outputs (by ``--map``, ``[signals]`` or default; two
spellings of one field are one, ``LogSource.field_key``: ``q[2]`` and ``q[-1]`` of an array
of three): refused, naming both; so are indices from both ends of an array whose length is
known only per message, one element in messages of some length.  Nor is one field the
ground truth of two symbols (two states, a state and the true mode): refused alike.  Ground
truth may share the field of an input or output (a state measured directly).  Where each
symbol's field came from is kept (:attr:`SignalMap.origins`) for the report's
``reading.fields``.

An error names the symbol and the field as a place, then the cause: ``output 'y1' (field
'/a.b.v', from --map y1=/a.b.v): '/a.b.v' names 2 fields ...``; ``input 'u' (field
'/u.data', the default; ...): topic '/u' (...) has no header.stamp``.  "no field" (or "no
column") is said only of a field the log lacks.
"""

from __future__ import annotations

import re
import unicodedata
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

from hybridlog.errors import LogError, OptionError, excerpt
from hybridlog.io.source import FieldKey, closest_names, non_ascii

TRUTH_PREFIX = "truth."
TRUTH_MODE = "truth.mode"
DEFAULT_MODE_FIELD = "mode"


SIGNAL_FEEDS = (
    "feeds one input or output (an input equal to an output, or one measurement counted "
    "twice, is a mapping slip)"
)
"""Why one field may not feed two inputs, outputs or commands (:func:`_refuse_shared`)."""

TRUTH_FEEDS = (
    "is the ground truth of one symbol (two states, or a state and the true mode, are not "
    "one measurement: a slip of --map or [truth])"
)
"""Why one field may not be the ground truth of two symbols (:func:`_refuse_shared`)."""


@dataclass(frozen=True)
class SignalMap:
    """The log field chosen for every symbol.

    Attributes
    ----------
    inputs, outputs:
        ``{symbol: field}`` in the model's order.
    commands:
        ``{command: field}`` of the commands the log has, in the model's order.
    truth_mode:
        Field holding the true mode id, or ``None``.
    truth_states:
        ``{state: field}`` for the states the log has, in the model's order.
    truth_components:
        ``{component: field}`` holding the true mode of each component the log has, in
        the model's order (``[components]`` models).
    unusable_truth:
        ``{symbol: "field: why"}`` for ground truth not mapped with ``--map`` whose field
        the log has but that cannot be used (so the symbol has no truth).
    origins:
        ``{symbol: origin}`` for every symbol given a field: where its field came from,
        ``"--map"``, ``"[signals]"``, ``"[truth]"`` or ``"default"`` (ground truth as
        ``truth.mode``, ``truth.mode.<component>``, ``truth.<state>``).
    """

    inputs: dict[str, str]
    outputs: dict[str, str]
    truth_mode: str | None = None
    truth_states: dict[str, str] = field(default_factory=dict)
    truth_components: dict[str, str] = field(default_factory=dict)
    unusable_truth: dict[str, str] = field(default_factory=dict)
    origins: dict[str, str] = field(default_factory=dict)
    commands: dict[str, str] = field(default_factory=dict)

    def fields_read(self) -> dict[str, dict[str, str]]:
        """``{symbol: {"field": ..., "from": origin}}`` of every symbol given a field.

        Inputs, outputs, commands, then ground truth (``truth.mode``, ``truth.mode.<component>``,
        ``truth.<state>``), for the report: which log field fed which symbol, and why.
        """
        chosen = {
            **self.inputs,
            **self.outputs,
            **self.commands,
            **({} if self.truth_mode is None else {TRUTH_MODE: self.truth_mode}),
            **{component_truth_symbol(c): f for c, f in self.truth_components.items()},
            **{f"{TRUTH_PREFIX}{x}": f for x, f in self.truth_states.items()},
        }
        return {
            symbol: {"field": name, "from": self.origins.get(symbol, "default")}
            for symbol, name in chosen.items()
        }

    def place(self, name: str, field_word: str) -> str | None:
        """The first symbol reading field ``name``, as a place an error names, or ``None``.

        ``output 'y' (field '/p.position[3]', from --map y=/p.position[3])``: the words
        :func:`resolve_signal_map` puts before why a field cannot be used, for an error found
        only in the field's values (:class:`~hybridlog.io.source.FieldError`).
        """
        for symbol, read in self.fields_read().items():
            if read["field"] == name:
                origin = read["from"]
                said = f"from --map {symbol}={name}"
                if origin != "--map":  # as resolve_signal_map says a field it refuses
                    where = "the default" if origin == "default" else f"from the model's {origin}"
                    said = f"{where}; use --map {symbol}=... for another"
                described = _describe(symbol, tuple(self.inputs), tuple(self.commands))
                return f"{described} ({field_word} {name!r}, {said})"
        return None


ROS_TOPIC = re.compile(r"(?:/[A-Za-z_][A-Za-z0-9_]*)+", re.ASCII)
"""A fully qualified ROS topic name, as rmw's ``rmw_validate_full_topic_name`` (ROS 2) and ROS 1
take one: ``/`` and a token of ASCII letters, digits and ``_`` not starting with a digit,
any number of times (no empty token, no trailing ``/``)."""
MAX_TOPIC_LENGTH = 247
"""Longest ROS 2 topic name (rmw's ``RMW_TOPIC_MAX_NAME_LENGTH``: 255 less 8 for prefixes)."""
MAX_PATH_LENGTH = 255
"""Longest ``--map`` path (a topic of :data:`MAX_TOPIC_LENGTH` and a short field, or a column)."""
_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*", re.ASCII)
_GREEK = re.compile(r"GREEK (SMALL|CAPITAL) LETTER ([A-Z]+)")


def ros_token(name: str) -> str | None:
    """``name`` as one token of a ROS name, or ``None`` when nothing of it is ASCII.

    A token (``[A-Za-z_][A-Za-z0-9_]*``) is kept as it is.  Otherwise each character is
    written: accents dropped (``é`` → ``e``, Unicode NFKD), a Greek letter by its name (``θ``
    → ``theta``, ``Ω`` → ``Omega``), any other character but an ASCII letter, digit or ``_``
    as ``_`` (``fr-1`` → ``fr_1``); a leading digit gets a ``_`` before it.  Two names can so
    become one token: the writer refuses that
    (:func:`hybridlog.io.bag_writers.check_topic_names`).
    """
    if _TOKEN.fullmatch(name):
        return name
    parts: list[str] = []
    for char in unicodedata.normalize("NFKD", name):
        if char.isascii() and (char.isalnum() or char == "_"):
            parts.append(char)
        elif unicodedata.combining(char):
            continue
        elif (greek := _GREEK.fullmatch(unicodedata.name(char, ""))) is not None:
            letter = greek.group(2)
            parts.append(letter.lower() if greek.group(1) == "SMALL" else letter.capitalize())
        else:
            parts.append("_")
    token = "".join(parts)
    if not any(char.isalnum() for char in token):
        return None
    return f"_{token}" if token[0].isdigit() else token


def column_topic(column: str, *, truth: bool) -> str | None:
    """The ROS topic of a log column (:func:`ros_token`), ``None`` if it has none.

    ``/<column>``, or ``/truth/<column>`` for ground truth; a column ``<a>.<b>`` (the true
    mode of a component, ``mode.fr1``) is the topic ``/truth/<a>/<b>``.
    """
    head, dot, rest = column.partition(".")
    tokens: list[str] = ["truth"] if truth else []
    for part in (head, rest) if dot else (head,):
        token = ros_token(part)
        if token is None:
            return None
        tokens.append(token)
    return "/" + "/".join(tokens)


def default_fields(symbols: Sequence[str], *, message_paths: bool) -> dict[str, tuple[str, ...]]:
    """The fields each symbol is looked for in when neither ``--map`` nor the model names one.

    For a table, the column named like the symbol (``mode`` for ``truth.mode``).  For a bag
    or MCAP file, the ``data`` field of the topic of the symbol's ROS name
    (:func:`column_topic`), then of the topic hybridlog wrote before it wrote ROS names
    (``/truth/mode.fr1``, ``/truth/θ``), when that differs.  A ROS name shared by two of
    ``symbols`` (states ``θ`` and ``theta``) is no symbol's but its own (the writer refuses
    to write such a pair).
    """
    out: dict[str, tuple[str, ...]] = {}
    if not message_paths:
        for symbol in symbols:
            column = symbol.removeprefix(TRUTH_PREFIX)
            out[symbol] = (DEFAULT_MODE_FIELD if symbol == TRUTH_MODE else column,)
        return out
    written: dict[str, tuple[str, str | None]] = {}
    for symbol in symbols:
        truth = symbol.startswith(TRUTH_PREFIX)
        column = symbol.removeprefix(TRUTH_PREFIX)
        old = f"/truth/{column}" if truth else f"/{column}"
        written[symbol] = (old, column_topic(column, truth=truth))
    shared = Counter(new for _, new in written.values() if new is not None)
    for symbol, (old, new) in written.items():
        topics = [old]
        if new is not None and new != old and shared[new] == 1:
            topics.insert(0, new)
        out[symbol] = tuple(f"{topic}.data" for topic in topics)
    return out


def valid_map_symbols(
    inputs: Sequence[str],
    outputs: Sequence[str],
    states: Sequence[str],
    components: Sequence[str] = (),
    commands: Sequence[str] = (),
) -> tuple[str, ...]:
    """Every symbol ``--map`` accepts on its left-hand side.

    A ``[components]`` model has no mode of the whole model, only each component's: it
    takes ``truth.mode.<component>`` and not ``truth.mode``.
    """
    return (
        *inputs,
        *outputs,
        *commands,
        *(() if components else (TRUTH_MODE,)),
        *(component_truth_symbol(c) for c in components),
        *(f"{TRUTH_PREFIX}{state}" for state in states),
    )


def is_mode_symbol(symbol: str) -> bool:
    """Whether ``symbol`` is a true mode, read as labels: ``truth.mode``, ``truth.mode.<c>``.

    Not a true state whose name starts with ``mode`` (``truth.modes``): a number.
    """
    return symbol == TRUTH_MODE or symbol.startswith(f"{TRUTH_MODE}.")


def component_truth_symbol(component: str) -> str:
    """The symbol of a component's true mode: ``truth.mode.<component>``."""
    return f"{TRUTH_MODE}.{component}"


def parse_maps(
    maps: Sequence[str],
    *,
    inputs: Sequence[str],
    outputs: Sequence[str],
    states: Sequence[str],
    components: Sequence[str] = (),
    commands: Sequence[str] = (),
) -> dict[str, str]:
    """Parse ``--map SYMBOL=PATH`` options.

    Parameters
    ----------
    maps:
        The option values, e.g. ``["y=level_m", "truth.mode=/truth/mode.data"]``.
    inputs, outputs, states, components, commands:
        The model's symbol names (and component names, and the commands its rules name).

    Returns
    -------
    dict
        ``{symbol: path}`` with ``truth.``-prefixed keys for ground truth; the path as
        written, spaces and all (:func:`resolve_signal_map` takes it so if the log has such a
        field, else without the spaces around it).

    Raises
    ------
    OptionError
        For a value without ``=``, an empty side, an unknown symbol (listing the valid ones)
        or a symbol mapped twice.
    """
    valid = valid_map_symbols(inputs, outputs, states, components, commands)
    parsed: dict[str, str] = {}
    for item in maps:
        symbol, sep, path = item.partition("=")
        symbol = symbol.strip()
        if not sep or not symbol or not path.strip():
            raise OptionError(f"--map {excerpt(item)}: expected SYMBOL=PATH, e.g. y=level")
        if symbol not in valid:
            # a symbol that prints like a valid one ('у1', Cyrillic у) names its odd characters
            hint = f"; {non_ascii(symbol)}" if not symbol.isascii() else ""
            raise OptionError(
                f"--map {excerpt(item)}: unknown symbol {excerpt(symbol)}{hint}; valid symbols: "
                f"{', '.join(valid)}"
            )
        if len(path) > MAX_PATH_LENGTH:  # every message naming the field echoes it whole
            raise OptionError(
                f"--map {excerpt(item)}: the path has {len(path):,} characters; at most "
                f"{MAX_PATH_LENGTH} (a ROS 2 topic name has at most {MAX_TOPIC_LENGTH})"
            )
        if symbol in parsed:
            raise OptionError(f"--map: symbol {symbol!r} is mapped twice")
        parsed[symbol] = path
    return parsed


def resolve_signal_map(
    fields: Sequence[str],
    *,
    source: str,
    inputs: Sequence[str],
    outputs: Sequence[str],
    states: Sequence[str],
    components: Sequence[str] = (),
    signals: Mapping[str, str] | None = None,
    truth: Mapping[str, str] | None = None,
    maps: Mapping[str, str] | None = None,
    field_word: str = "column",
    message_paths: bool = False,
    explain: Callable[[str, bool], str | None] | None = None,
    field_key: Callable[[str], FieldKey] | None = None,
    commands: Sequence[str] = (),
) -> SignalMap:
    """Choose the log field of every symbol (see the module docstring for the order).

    Parameters
    ----------
    fields:
        The fields the log has (``LogSource.fields()``).
    source:
        The log's path, for messages.
    inputs, outputs, states:
        The model's symbol names.
    components:
        The components of a ``[components]`` model (whose true modes are looked for).
    signals, truth:
        The model's ``[signals]`` (symbol → path) and ``[truth]`` (``mode``/state → path).
    maps:
        Parsed ``--map`` options (:func:`parse_maps`).
    field_word:
        ``"column"`` or ``"field"``, for messages.
    message_paths:
        Whether fields are message paths (bags, MCAP): selects the default names.
    explain:
        ``explain(name, numeric)`` is ``None`` when the log has field ``name`` (holding
        numbers, if ``numeric``), else why not (``LogSource.explain_missing``); default:
        membership in ``fields``.
    field_key:
        What a field name names, the same for every spelling of one field
        (``LogSource.field_key``: ``/y1/data`` and ``/y1.data``); default: the name.
    commands:
        The commands the model's transition rules name: looked for like inputs, optional.

    Returns
    -------
    SignalMap

    Raises
    ------
    LogError
        When an input or output, or a truth symbol given with ``--map``, has no field in the
        log; the message lists the closest field names.
    """
    available = set(fields)
    signals = signals or {}
    truth = truth or {}
    maps = maps or {}
    unusable: dict[str, str] = {}
    origins: dict[str, str] = {}

    def missing(name: str, numeric: bool) -> str | None:
        if explain is not None:
            reason = explain(name, numeric)
            return None if reason is None else reason.removeprefix(f"{name!r}: ")
        if name in available:
            return None
        return f"no {field_word} {name!r}; {closest_names([name], fields)}"

    def choose(
        symbol: str, model_path: str | None, defaults: tuple[str, ...], required: bool
    ) -> str | None:
        numeric = not is_mode_symbol(symbol)
        mapped = maps.get(symbol)
        if mapped is not None:
            # as written, so that a column named ' u' (a header 't, u, y') can be named; else
            # without the spaces around it (--map 'y = level')
            if mapped != mapped.strip() and missing(mapped, numeric) is None:
                origins[symbol] = "--map"
                return mapped
            mapped = mapped.strip()
            reason = missing(mapped, numeric)
            if reason is not None:
                raise unusable_field(symbol, mapped, f"from --map {symbol}={mapped}", reason)
            origins[symbol] = "--map"
            return mapped
        table = "[truth]" if symbol.startswith(TRUTH_PREFIX) else "[signals]"
        if model_path is not None:
            reason = missing(model_path, numeric)
            if reason is None:
                origins[symbol] = table
                return model_path
            if not absent(reason):
                # the log has the model's field but it cannot be used: reading the default
                # field instead would analyse a signal the model did not name
                if required:
                    origin = f"from the model's {table}; use --map {symbol}=... for another"
                    raise unusable_field(symbol, model_path, origin, reason)
                unusable[symbol] = f"{field_word} {model_path!r}, the model's {table}: {reason}"
                return None
        for default in defaults:
            if missing(default, numeric) is None:
                origins[symbol] = "default"
                return default
        looked = list(dict.fromkeys([*([] if model_path is None else [model_path]), *defaults]))
        if not required:
            for name in looked:
                # a field the log has in a form that cannot be used (a list column 'mode'
                # whose fields are 'mode[0]', ...): no truth, and the report says why
                reason = missing(name, numeric)
                if reason is not None and not absent(reason):
                    unusable.setdefault(symbol, f"{field_word} {name!r}: {reason}")
            return None
        for name in looked if explain is not None else ():
            # A field that exists but cannot be used (e.g. its topic cannot be decoded) is
            # worth more to the user than a list of names, and is the cause to name first.
            reason = missing(name, numeric)
            if reason is not None and not reason.startswith(("no topic", f"no {field_word} ")):
                where = "from the model's [signals]" if name == model_path else "the default"
                origin = f"{where}; use --map {symbol}=... for another"
                raise unusable_field(symbol, name, origin, reason)
        raise LogError(
            f"{source}: no {field_word} for {_describe(symbol, inputs, commands)} (looked for "
            f"{' and '.join(repr(name) for name in looked)}; use --map {symbol}=...); "
            f"{closest_names(looked, fields)}"
        )

    def absent(reason: str) -> bool:
        # why a name is no field: the log lacks it (a topic, a column, a field of a message),
        # rather than has it in a form that cannot be used
        return reason.startswith(("no topic", f"no {field_word} ")) or " has no field " in reason

    def unusable_field(symbol: str, name: str, origin: str, reason: str) -> LogError:
        # The symbol and field as a place, then the cause: "output 'y1' (field '/a.b.v',
        # from --map y1=/a.b.v): '/a.b.v' names 2 fields ..." -- not "no field '/a.b.v'"
        # before a reason that says the field is there but cannot be used.
        return LogError(
            f"{source}: {_describe(symbol, inputs, commands)} ({field_word} {name!r}, {origin}): "
            f"{reason}"
        )

    every = [
        *inputs,
        *outputs,
        *commands,
        *([] if components else [TRUTH_MODE]),
        *(component_truth_symbol(c) for c in components),
        *(f"{TRUTH_PREFIX}{x}" for x in states),
    ]
    defaults = default_fields(every, message_paths=message_paths)

    def default(symbol: str) -> tuple[str, ...]:
        return defaults[symbol]

    def required(symbol: str) -> str:
        chosen = choose(symbol, signals.get(symbol), default(symbol), required=True)
        assert chosen is not None  # choose raises instead of returning None when required
        return chosen

    input_fields = {u: required(u) for u in inputs}
    output_fields = {y: required(y) for y in outputs}
    command_fields: dict[str, str] = {}
    for command in commands:
        chosen = choose(command, signals.get(command), default(command), required=False)
        why = unusable.pop(command, None)
        if why is not None:  # the log has the field, in a form that cannot be used
            raise LogError(f"{source}: command {command!r} ({why})")
        if chosen is not None:
            command_fields[command] = chosen
    _refuse_shared(
        source,
        field_word,
        {**input_fields, **output_fields, **command_fields},
        inputs,
        origins,
        field_key or (lambda name: (name, ())),
        commands,
    )
    # a [components] model enumerates no modes of its own: a ``mode`` field (a controller's
    # mode, joint labels) is no truth of it, its components' true modes are
    truth_mode = (
        None
        if components
        else choose(TRUTH_MODE, truth.get("mode"), default(TRUTH_MODE), required=False)
    )
    truth_states: dict[str, str] = {}
    for state in states:
        symbol = f"{TRUTH_PREFIX}{state}"
        chosen = choose(symbol, truth.get(state), default(symbol), required=False)
        if chosen is not None:
            truth_states[state] = chosen
    truth_components: dict[str, str] = {}
    for component in components:
        symbol = component_truth_symbol(component)
        key = symbol.removeprefix(TRUTH_PREFIX)
        chosen = choose(symbol, truth.get(key), default(symbol), required=False)
        if chosen is not None:
            truth_components[component] = chosen
    _refuse_shared(
        source,
        field_word,
        {
            **({} if truth_mode is None else {TRUTH_MODE: truth_mode}),
            **{component_truth_symbol(c): name for c, name in truth_components.items()},
            **{f"{TRUTH_PREFIX}{x}": name for x, name in truth_states.items()},
        },
        inputs,
        origins,
        field_key or (lambda name: (name, ())),
        commands,
        feeds=TRUTH_FEEDS,
        ends_meet=False,
    )
    return SignalMap(
        input_fields,
        output_fields,
        truth_mode,
        truth_states,
        truth_components,
        unusable,
        origins,
        command_fields,
    )


def _refuse_shared(
    source: str,
    field_word: str,
    chosen: Mapping[str, str],
    inputs: Sequence[str],
    origins: Mapping[str, str],
    field_key: Callable[[str], FieldKey],
    commands: Sequence[str] = (),
    *,
    feeds: str = SIGNAL_FEEDS,
    ends_meet: bool = True,
) -> None:
    """Refuse one field feeding two inputs, outputs or commands (``--map u=y1``, an output ``y1``).

    An input read from an output's field makes the model predict the output from itself (a
    perfect fit that says nothing); two outputs read from one field are one measurement
    counted twice.  Either is almost always a slip of ``--map`` or ``[signals]``, never
    what a log of distinct signals means.  Ground truth may share a field with an output (a
    state measured directly): the report notes it (``reading.truth_shared``).  But two
    ground-truth symbols never share one (``feeds``: :data:`TRUTH_FEEDS`, said why): two
    states, or a state and the true mode, are not one measurement: the estimates of both
    would be scored against one signal.

    Two spellings of one field are one (``LogSource.field_key``): ``q[2]`` and ``q[-1]`` of
    an array of three.  Into an array whose length is known only per message (a sequence),
    an index from the start and one from the end read one element in messages of some
    length (``q[2]`` and ``q[-1]`` in those of three): refused too, asking for both indices
    counted from one end.  Not for ground truth (``ends_meet=False``): a state array's first
    and last elements (``data[0]``, ``data[-1]``) are the usual way to read two true states,
    and they meet only in messages holding a single element.

    Raises
    ------
    LogError
        Naming both symbols, the field and where each came from.
    """
    owner: dict[FieldKey, str] = {}

    def described(symbol: str) -> str:
        origin = _origin(symbol, chosen[symbol], origins.get(symbol, "default"))
        return f"{_describe(symbol, inputs, commands)} {origin}"

    for symbol, name in chosen.items():
        key = field_key(name)
        for other_key, other in owner.items():
            length = _one_element_at(key, other_key) if ends_meet else None
            if length is not None:
                raise LogError(
                    f"{source}: {described(other)} and {described(symbol)} index one array "
                    f"from its start and from its end ({chosen[other]!r} and {name!r}), one "
                    f"element where the array holds {length}; count both indices from one end"
                )
        first = owner.setdefault(key, symbol)
        if first == symbol:
            continue
        named = (
            repr(name)
            if chosen[first] == name
            else f"({chosen[first]!r} and {name!r} name one {field_word})"
        )
        raise LogError(
            f"{source}: {described(first)} and {described(symbol)} read the same {field_word} "
            f"{named}: one {field_word} {feeds}; map one of them to another {field_word} "
            "with --map"
        )


def _one_element_at(a: FieldKey, b: FieldKey) -> int | None:
    """The array length at which two fields that index one array from both ends meet.

    ``("/q", ("data", 2))`` and ``("/q", ("data", -1))``: 3.  ``None`` when the two differ in
    a name or in an index counted from the same end (never one element), or are equal.
    """
    (column_a, steps_a), (column_b, steps_b) = a, b
    if column_a != column_b or len(steps_a) != len(steps_b) or steps_a == steps_b:
        return None
    meets: int | None = None
    for x, y in zip(steps_a, steps_b, strict=True):
        if x == y:
            continue
        if not (isinstance(x, int) and isinstance(y, int)) or (x < 0) == (y < 0):
            return None
        meets = meets or max(x, y) - min(x, y)
    return meets


def _origin(symbol: str, name: str, origin: str) -> str:
    """Where a symbol's field came from, as a clause: ``(from --map u=y1)``."""
    if origin == "--map":
        return f"(from --map {symbol}={name})"
    if origin == "default":
        return "(the default)"
    return f"(from the model's {origin})"


def _describe(symbol: str, inputs: Sequence[str], commands: Sequence[str] = ()) -> str:
    if symbol.startswith(TRUTH_PREFIX):
        return symbol
    if symbol in commands:
        return f"command {symbol!r}"
    return f"{'input' if symbol in inputs else 'output'} {symbol!r}"
