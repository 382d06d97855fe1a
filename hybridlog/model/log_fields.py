"""A model's names against the fields of its logs and the columns of a run's tables.

``[signals]`` and ``[truth]`` map symbols to a log's fields (:func:`log_paths`), each key one
the log mapping reads; a symbol may not be named like a field a log gives another meaning
(``mode``, ``time``), two names may not make the same report column (an output ``x1_var``
beside a state ``x1``), and a component's mode id may not hold the joint separator ``|``.
The lists cannot import ``io/``, ``report/`` or ``estimators/`` (a lower layer), so tests in
``tests/model/`` keep them equal to those layers' own names.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

from hybridlog.errors import ModelError, excerpt
from hybridlog.model.components import JOINT_SEPARATOR, Component
from hybridlog.model.file_keys import TOP_KEYS, misplaced_top_key
from hybridlog.model.values import as_string, as_table, key_path

_MODE_KEY = "mode"
"""The true mode's key in ``[truth]`` (``mode.<component>`` per component)."""
_STATE_COLUMNS = (
    ("_hat", "estimate"),
    ("_var", "variance"),
    ("_hat_filtered", "filtered estimate"),
    ("_var_filtered", "filtered variance"),
    ("_true", "true value"),
)
"""The columns of ``estimates`` a state gives (report/tables.py), and what they hold."""
_LOGGED_GROUPS = ("states", "inputs", "outputs", "commands")
"""The symbols a log holds a field of (true states, inputs, outputs, commands)."""
_LOG_FIELD_NAMES = {
    "mode": (
        "is the true mode's field of a log (a CSV/Parquet column 'mode', [truth] mode, "
        "--map truth.mode)"
    ),
    "time": "is a time column of a CSV/Parquet log ('t' or 'time')",
}
"""Field names a log gives another meaning (:mod:`hybridlog.io.mapping`, ``io/table_times.py``).

A symbol of that name would be read from the same field as that meaning: a state ``mode``
read the true mode's column as its true value and the true mode's as a number (the log was
refused), and ``simulate`` wrote one column for both.  (``t``, the other time column, is a
name of the expression grammar, refused for every symbol.)
"""


def refuse_joint_separator(components: tuple[Component, ...]) -> None:
    """Refuse a component mode id holding ``|``: two joint modes would get one id.

    With modes ``a|b`` and ``a`` of one component and ``c`` and ``b|c`` of another, the joint
    modes (``a|b``, ``c``) and (``a``, ``b|c``) were both ``a|b|c``: the timeline kept one
    ``p_a|b|c`` column of the two and its ``mode`` column could not tell them apart.
    """
    for component in components:
        for mode_id in component.mode_ids:
            if JOINT_SEPARATOR in mode_id:
                key = key_path(key_path("components", component.name) + ".modes", mode_id)
                raise ModelError(
                    f"{key}: a component's mode id may not hold {JOINT_SEPARATOR!r}, which joins "
                    "the components' mode ids into a joint mode's id (m11|m21)"
                )


def refuse_log_field_names(groups: Mapping[str, tuple[str, ...]]) -> None:
    """Refuse a logged symbol named like a field a log gives another meaning (``mode``)."""
    for group in _LOGGED_GROUPS:
        for name in groups[group]:
            if name in _LOG_FIELD_NAMES:
                raise ModelError(
                    f"{group}: '{name}' {_LOG_FIELD_NAMES[name]} and cannot be a symbol name"
                )


def _report_columns(
    states: tuple[str, ...], outputs: tuple[str, ...], mode_ids: tuple[str, ...]
) -> Iterator[tuple[str, str, str, str]]:
    """``(table, column, key, what)`` for every column a run's tables may have.

    The columns the model's names make in ``timeline`` and ``estimates``
    (report/tables.py; with ``--smooth`` and ground truth, in the tables' order), the
    model-file key naming each, and what the column holds.  The other columns (``t``,
    ``mode``, ``truth_mode``, ``mode.<component>``) have names no symbol or ``p_<mode>`` has.
    """
    for m in mode_ids:
        yield "timeline", f"p_{m}", key_path("modes", m), f"the probability of mode {m!r}"
    for m in mode_ids:
        what = f"the filtered probability of mode {m!r}"
        yield "timeline", f"p_{m}_filtered", key_path("modes", m), what
    for x in states:
        for suffix, what in _STATE_COLUMNS:
            yield "estimates", f"{x}{suffix}", "states", f"the {what} of state {x!r}"
    for y in outputs:
        yield "estimates", f"{y}_hat", "outputs", f"the prediction of output {y!r}"
        yield "estimates", y, "outputs", f"the measurement of output {y!r}"


def check_report_columns(
    states: tuple[str, ...], outputs: tuple[str, ...], mode_ids: tuple[str, ...]
) -> None:
    """Refuse names whose report columns coincide: the later column replaced the first.

    With an output ``x1_var`` beside a state ``x1``, ``estimates.csv`` held the measured
    output under ``x1_var`` and the state's variance nowhere; with modes ``a`` and
    ``a_filtered``, a smoothed run's ``p_a_filtered`` was the filter's probability of ``a``.
    """
    seen: dict[tuple[str, str], str] = {}
    for table, column, key, what in _report_columns(states, outputs, mode_ids):
        if (table, column) in seen:
            raise ModelError(
                f"{key}: {table} column {excerpt(column, 40)} would hold both "
                f"{seen[table, column]} and {what}; rename one of them"
            )
        seen[table, column] = what


def log_paths(
    data: Mapping[str, Any], groups: Mapping[str, tuple[str, ...]], components: tuple[str, ...]
) -> tuple[dict[str, str], dict[str, str]]:
    """``[signals]`` (inputs and outputs) and ``[truth]`` (true mode and states): symbol → path.

    Every key must be one the log mapping reads (:mod:`hybridlog.io.mapping`): a key it
    would skip (a state under ``[signals]``, a command, an input under ``[truth]``) is
    refused, naming where the key belongs, rather than silently ignored.  In ``[truth]``,
    a components model maps each component's true mode as ``"mode.<component>"``, which
    TOML also reads from the dotted key ``mode.<component> = ...`` (a table ``mode``).
    """
    modes = tuple(f"{_MODE_KEY}.{c}" for c in components) or (_MODE_KEY,)
    truth = dict(as_table(data.get("truth", {}), "truth"))
    if isinstance(truth.get(_MODE_KEY), dict):
        for component, path in as_table(truth.pop(_MODE_KEY), "truth.mode").items():
            name = f"{_MODE_KEY}.{component}"
            if name in truth:
                raise ModelError(
                    f"{key_path('truth', name)}: given twice (also as mode.{component})"
                )
            truth[name] = path
    return (
        _path_table(data.get("signals", {}), "signals", groups, modes),
        _path_table(truth, "truth", groups, modes),
    )


def _path_table(
    value: Any, table: str, groups: Mapping[str, tuple[str, ...]], modes: tuple[str, ...]
) -> dict[str, str]:
    """``[signals]`` or ``[truth]``: keys the log mapping reads, non-empty path strings."""
    result: dict[str, str] = {}
    for name, path in as_table(value, table).items():
        _refuse_misplaced(name, table, groups, modes)
        text = as_string(path, key_path(table, name))
        if not text:
            raise ModelError(f"{key_path(table, name)}: an empty path names no field of a log")
        result[name] = text
    return result


def _refuse_misplaced(
    name: str, table: str, groups: Mapping[str, tuple[str, ...]], modes: tuple[str, ...]
) -> None:
    """Refuse a ``[signals]``/``[truth]`` key the log mapping would not read, saying why."""
    key = key_path(table, name)
    signal_names = (*groups["inputs"], *groups["outputs"])
    if table == "signals" and name in (*signal_names, *groups["commands"]):
        return  # a command is read like an input where a transition rule's `when` names it
    if table == "truth" and name in (*modes, *groups["states"]):
        return
    if table == "signals" and name in groups["states"]:
        reason = f"a state; true states map under [truth] ({key_path('truth', name)} = ...)"
    elif table == "signals" and (name == _MODE_KEY or name.startswith(f"{_MODE_KEY}.")):
        reason = "the true mode maps under [truth]"
    elif table == "truth" and name in signal_names:
        reason = f"{_role(name, groups)}; inputs and outputs map under [signals]"
    elif table == "truth" and name == _MODE_KEY:
        reason = (
            "a components model has no mode of the whole model; map each component's "
            'true mode as "mode.<component>"'
        )
    elif table == "truth" and name in groups["commands"]:
        reason = "a command; commands map under [signals]"
    elif name in (*groups["variables"], *groups["booleans"]):
        reason = f"{_role(name, groups)}, which no log holds"
    elif name in TOP_KEYS:  # default_estimator appended below the file's last table
        raise ModelError(misplaced_top_key(table, name))
    else:
        allowed = (
            (*signal_names, *groups["commands"])
            if table == "signals"
            else (*modes, *groups["states"])
        )
        what = (
            ("an input, output or command" if groups["commands"] else "an input or output")
            if table == "signals"
            else "a true mode or state"
        )
        reason = f"not {what} of the model (allowed: {_names(allowed)})"
    raise ModelError(f"{key}: {reason}")


_LISTED_NAMES = 12
"""Most names an error lists (a model may have hundreds of outputs)."""


def _names(names: tuple[str, ...]) -> str:
    """``a, b, c`` for an error; past :data:`_LISTED_NAMES` names, how many more."""
    if not names:
        return "none"
    shown = ", ".join(names[:_LISTED_NAMES])
    more = len(names) - _LISTED_NAMES
    return f"{shown} and {more} more" if more > 0 else shown


def _role(name: str, groups: Mapping[str, tuple[str, ...]]) -> str:
    """``an input``, ``an output``, ``a variable``: the group a symbol belongs to."""
    group = next(g for g, names in groups.items() if name in names)
    singular = group.removesuffix("s")
    return f"{'an' if singular[0] in 'aeiou' else 'a'} {singular}"
