r"""``[components.<name>]`` of a model file → :class:`~hybridlog.model.components.Component`.

A components model (paper 002) lists its continuous ``states``, measured ``outputs``,
``inputs``, internal ``variables`` (neither states nor measured, e.g. a flow between two
components) and ``commands`` (discrete inputs that condition transitions).  Each component::

    [components.regulator]
    unknown = 0.001                  # Pr(a known mode turns unknown) per step
    initial = "partly_open"          # or {partly_open = 0.9, off = 0.1}

    [components.regulator.modes.partly_open]
    equations = ["x1[k] = 0.5*u1[k-1]", "y1 = x1"]
    process_noise = {x1 = 0.01}      # variances; default: [noise] process
    measurement_noise = {y1 = 0.04}  # default: [noise] measurement (one is required)

    [[components.regulator.transitions]]
    from = "partly_open"             # a mode id, "unknown", or "*" (every known mode)
    when = {cmd = 1}                 # optional command values
    to = {stuck_open = 0.001}        # the rest stays in the source mode

A difference equation ``x[k] = ...`` defines a state from variables at step k−1 (written
``v[k-1]``); an algebraic equation ``lhs = rhs`` relates variables at step k (written ``v``
or ``v[k]``).  Every name is checked; an error names the equation's key,
``components.<c>.modes.<m>.equations[i]``.  See
:meth:`~hybridlog.model.components.Component.transition_probabilities` for how the rules
and the unknown mode's probability combine.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

import sympy

from hybridlog.errors import ModelError, excerpt
from hybridlog.model.components import (
    COMMAND_TOLERANCE,
    UNKNOWN,
    Component,
    ComponentMode,
    Equation,
    EquationKind,
    TransitionRule,
)
from hybridlog.model.expressions import parse_expression, previous_symbol
from hybridlog.model.values import (
    as_label,
    as_mode_id,
    as_number,
    as_probability,
    as_string,
    as_table,
    check_distinct_labels,
    check_keys,
    key_path,
    required,
)
from hybridlog.signals import FloatArray

_COMPONENT_KEYS = {"modes", "transitions", "unknown", "initial", "description"}
_MODE_KEYS = {"equations", "process_noise", "measurement_noise", "description"}
_RULE_KEYS = {"from", "when", "to"}
_EQUALS = re.compile(r"(?<![<>=!])=(?!=)")
_DIFFERENCE_LEFT = re.compile(r"\s*([^\W\d]\w*)\s*\[\s*k\s*\]\s*")
_PROBABILITY_TOLERANCE = 1e-9


class _Variables:
    """The names a components model's equations may use, and their symbols at k and k−1."""

    def __init__(
        self,
        states: tuple[str, ...],
        inputs: tuple[str, ...],
        outputs: tuple[str, ...],
        variables: tuple[str, ...],
        parameters: Mapping[str, sympy.Expr],
    ) -> None:
        self.states = states
        self.outputs = outputs
        names = (*states, *inputs, *outputs, *variables)
        self.current = {n: sympy.Symbol(n, real=True) for n in names}
        self.previous = {n: previous_symbol(n) for n in names}
        self.env: dict[str, sympy.Expr] = {**self.current, **parameters}
        self.name_of = {
            **{s: (n, False) for n, s in self.current.items()},
            **{s: (n, True) for n, s in self.previous.items()},
        }

    def used(self, *expressions: sympy.Expr) -> tuple[frozenset[str], frozenset[str]]:
        """Names used at step k and at step k−1."""
        now: set[str] = set()
        before: set[str] = set()
        for expr in expressions:
            for symbol in expr.free_symbols:
                entry = self.name_of.get(symbol)
                if entry is None:  # a symbol of the caller's own (a scenario parameter)
                    continue
                name, previous = entry
                (before if previous else now).add(name)
        return frozenset(now), frozenset(before)


def load_components(
    table: dict[str, Any],
    *,
    states: tuple[str, ...],
    inputs: tuple[str, ...],
    outputs: tuple[str, ...],
    variables: tuple[str, ...],
    commands: tuple[str, ...],
    parameters: Mapping[str, sympy.Expr],
    process_variances: FloatArray,
    measurement_variances: FloatArray,
) -> tuple[Component, ...]:
    """Validate ``[components.*]`` and build the components, in the file's order.

    ``process_variances`` and ``measurement_variances`` are the ``[noise]`` defaults per
    state and per output (NaN for an output when the file gives no ``[noise]
    measurement``: unstated, not guessed).  Besides each table's own checks: a state is
    defined by the difference equations of one component only (at most one per mode, and
    one in every known mode: :func:`_refuse_missing_states`), and every state, output and
    internal variable appears in some equation.
    """
    if not table:
        raise ModelError("components: at least one component is required")
    names = _Variables(states, inputs, outputs, variables, parameters)
    defaults_q = dict(zip(states, (float(v) for v in process_variances), strict=True))
    defaults_r = dict(zip(outputs, (float(v) for v in measurement_variances), strict=True))
    owner: dict[str, str] = {}
    components = []
    check_distinct_labels(((n, key_path("components", n)) for n in table), "component name")
    for raw_name, spec in table.items():
        key = key_path("components", raw_name)
        name = as_label(raw_name, key, "component name")
        component = _component(
            name, as_table(spec, key), key, names, commands, defaults_q, defaults_r
        )
        for state in component.states:
            if state in owner:
                first = next(
                    e.key for m in component.modes for e in m.equations if e.state == state
                )
                raise ModelError(
                    f"{first}: '{state}' already has difference equations in {owner[state]}; "
                    "a state belongs to one component"
                )
            owner[state] = key
        _refuse_missing_states(component)
        components.append(component)
    _refuse_close_settings(components)
    _refuse_unknown_column_labels(components)
    used = set(owner)
    related: set[str] = set()  # used at step k by an algebraic equation
    for component in components:
        for mode in component.modes:
            for equation in mode.equations:
                used |= equation.variables | equation.previous
                if equation.kind == "algebraic":
                    related |= equation.variables
    for group, group_names in (("states", states), ("outputs", outputs), ("variables", variables)):
        for name in group_names:
            if group == "states" and name not in owner:
                raise ModelError(f"states: '{name}' has no difference equation in any component")
            if name not in used:
                raise ModelError(f"{group}: '{name}' appears in no component equation")
            if group != "states" and name not in related:
                # Only an algebraic equation at step k can give it a value: without one, no
                # joint mode determines it and everything computed from it is left out.
                raise ModelError(
                    f"{group}: '{name}' is used but appears in no algebraic equation of any "
                    "component, so no mode gives it a value (is its component missing?)"
                )
    return tuple(components)


def _refuse_unknown_column_labels(components: Sequence[Component]) -> None:
    """Refuse mode ids whose joint mode's label is ``unknown.<component>``.

    ``unknown-mode``'s timeline has a column ``p_<joint mode>`` per joint mode kept and
    ``p_unknown.<component>`` per component: a one-component model with the mode id
    ``unknown.A`` (or mode ids joined by ``|`` that spell it) gave two columns one name, and
    the run ended in "unexpected ResultShapeError ... (a bug ...)" once that mode was kept.
    """
    for component in components:
        label = f"{UNKNOWN}.{component.name}"
        parts = label.split("|")
        if len(parts) != len(components):
            continue
        if all(
            part == UNKNOWN or part in c.mode_ids for part, c in zip(parts, components, strict=True)
        ):
            first = components[0]
            raise ModelError(
                f"{key_path(f'{first.key}.modes', parts[0])}: the joint mode {label!r} it makes "
                f"is named like the column p_{label} of unknown-mode's timeline, the belief "
                f"that component {component.name!r} is unknown; choose another mode id"
            )


def _refuse_missing_states(component: Component) -> None:
    """Refuse a known mode without a difference equation for a state its component gives.

    Paper 002 §3: a known mode is fully specified, the union of the joint mode's equations
    being the model of eq. (1), which gives every state; only the ``unknown`` mode imposes
    no equation, and a state it leaves undetermined is held (§3.1).  Such a mode had three
    meanings: ``unknown-mode`` held the state there as if the component were unknown,
    ``imm`` refused the joint mode ("nothing determines xc1") and ``simulate`` refused it
    only when its schedule reached it.  Refused here, one line naming the mode and state,
    before any log is read; a mode meant to keep the state writes ``x[k] = x[k-1]``.
    """
    for state in component.states:
        given = next(m for m in component.modes if any(e.state == state for e in m.equations))
        for mode in component.modes:
            if not any(e.state == state for e in mode.equations):
                raise ModelError(
                    f"{mode.key}: no difference equation for the state '{state}' of component "
                    f"'{component.name}', which its mode '{given.id}' gives: a known mode "
                    f"gives every state of its component (write {state}[k] = {state}[k-1] "
                    "to keep it; only the unknown mode leaves it undetermined, paper 002 §3)"
                )


def parse_equation(
    text: Any,
    key: str,
    *,
    states: tuple[str, ...],
    inputs: tuple[str, ...],
    outputs: tuple[str, ...],
    variables: tuple[str, ...],
    parameters: Mapping[str, sympy.Expr],
) -> Equation:
    """One equation in the grammar of a component mode, outside ``[components]``.

    For equations a model file writes elsewhere (``[[simulation.unmodelled]]``);
    ``parameters`` may map names to free symbols of the caller's own, which are kept in the
    equation and are neither variables at step k nor at step k−1.
    """
    return _equation(text, key, _Variables(states, inputs, outputs, variables, parameters))


def _component(
    name: str,
    spec: dict[str, Any],
    key: str,
    names: _Variables,
    commands: tuple[str, ...],
    defaults_q: Mapping[str, float],
    defaults_r: Mapping[str, float],
) -> Component:
    check_keys(spec, _COMPONENT_KEYS, key)
    modes_table = as_table(required(spec, "modes", key), f"{key}.modes")
    if not modes_table:
        raise ModelError(f"{key}.modes: at least one mode is required")
    modes = []
    for raw_id, mode_spec in modes_table.items():
        mode_key = key_path(f"{key}.modes", raw_id)
        mode_id = as_mode_id(raw_id, mode_key)
        if mode_id == UNKNOWN:
            raise ModelError(
                f"{mode_key}: '{UNKNOWN}' is every component's implicit unknown mode "
                "(no equations); choose another id"
            )
        modes.append(
            _mode(mode_id, as_table(mode_spec, mode_key), mode_key, names, defaults_q, defaults_r)
        )
    check_distinct_labels(((m.id, key_path(f"{key}.modes", m.id)) for m in modes), "mode id")
    mode_ids = tuple(m.id for m in modes)
    unknown = as_probability(required(spec, "unknown", key), f"{key}.unknown", below_one=True)
    return Component(
        name=name,
        modes=tuple(modes),
        unknown_probability=unknown,
        initial_mode_probabilities=_initial(spec.get("initial"), f"{key}.initial", mode_ids),
        rules=_rules(spec.get("transitions", []), f"{key}.transitions", mode_ids, commands),
        key=key,
    )


def _mode(
    mode_id: str,
    spec: dict[str, Any],
    key: str,
    names: _Variables,
    defaults_q: Mapping[str, float],
    defaults_r: Mapping[str, float],
) -> ComponentMode:
    check_keys(spec, _MODE_KEYS, key)
    texts = required(spec, "equations", key)
    if isinstance(texts, str):
        texts = [texts]
    if not isinstance(texts, list):
        raise ModelError(f"{key}.equations: expected a list of equation strings")
    if not texts:
        raise ModelError(
            f"{key}.equations: at least one equation is required (the mode without equations "
            f"is the implicit '{UNKNOWN}' mode)"
        )
    equations = tuple(
        _equation(text, f"{key}.equations[{i}]", names) for i, text in enumerate(texts)
    )
    defined: dict[str, str] = {}
    for equation in equations:
        if equation.state in defined:
            raise ModelError(
                f"{equation.key}: a second difference equation for '{equation.state}' in this "
                f"mode (the first is {defined[equation.state]})"
            )
        if equation.state:
            defined[equation.state] = equation.key
    measured = sorted(
        {v for e in equations if e.kind == "algebraic" for v in e.variables if v in names.outputs},
        key=names.outputs.index,
    )
    return ComponentMode(
        id=mode_id,
        equations=equations,
        process_noise=_variances(
            spec.get("process_noise", {}),
            f"{key}.process_noise",
            list(defined),
            defaults_q,
            "states this mode's difference equations define",
        ),
        measurement_noise=_variances(
            spec.get("measurement_noise", {}),
            f"{key}.measurement_noise",
            measured,
            defaults_r,
            "outputs this mode's algebraic equations use",
        ),
        key=key,
    )


def _variances(
    value: Any,
    key: str,
    allowed: list[str],
    defaults: Mapping[str, float],
    what: str,
) -> dict[str, float]:
    """Per-name variances of a mode, the defaults filled in for the names not given."""
    table = as_table(value, key)
    result = {name: defaults[name] for name in allowed}
    for name, variance in table.items():
        entry = key_path(key, name)
        if name not in allowed:
            listed = ", ".join(allowed) or "none"
            raise ModelError(f"{entry}: not one of the {what} ({listed})")
        number = as_number(variance, entry)
        if number < 0:
            raise ModelError(f"{entry}: a variance must be non-negative, got {number!r}")
        result[name] = number
    return result


def _equation(value: Any, key: str, names: _Variables) -> Equation:
    """One equation, difference (``x[k] = ...``) or algebraic (``lhs = rhs``)."""
    text = as_string(value, key)
    sides = _EQUALS.split(text)
    if len(sides) != 2:
        raise ModelError(f"{key}: expected one equation 'lhs = rhs', got {excerpt(text)}")
    left_text, right_text = sides
    difference = _DIFFERENCE_LEFT.fullmatch(left_text)
    kind: EquationKind
    if difference and difference.group(1) in names.states:
        state = difference.group(1)
        lhs: sympy.Expr = names.current[state]
        kind = "difference"
    else:
        state = ""
        lhs = parse_expression(left_text, names.env, key=key, previous=names.previous)
        kind = "algebraic"
    rhs = parse_expression(right_text, names.env, key=key, previous=names.previous)
    now, before = names.used(lhs, rhs)
    if kind == "difference":
        now_right, _ = names.used(rhs)
        if now_right:
            first = sorted(now_right)[0]
            raise ModelError(
                f"{key}: the right side of a difference equation uses step k−1 only; "
                f"write {first}[k-1] instead of {first}"
            )
        now = frozenset()
    elif before:
        first = sorted(before)[0]
        raise ModelError(
            f"{key}: an algebraic equation relates variables at one step; {first}[k-1] "
            f"belongs in a difference equation x[k] = ..."
        )
    elif not now:
        raise ModelError(f"{key}: {excerpt(text)} uses no variable")
    return Equation(
        key=key,
        text=text,
        kind=kind,
        lhs=lhs,
        rhs=rhs,
        state=state,
        variables=now,
        previous=before,
    )


def _initial(value: Any, key: str, mode_ids: tuple[str, ...]) -> dict[str, float]:
    """``initial = "mode"`` or ``{mode = p, ...}`` over the modes and ``unknown``."""
    allowed = (*mode_ids, UNKNOWN)
    if value is None:
        return {m: 1.0 / len(mode_ids) for m in mode_ids} | {UNKNOWN: 0.0}
    if isinstance(value, str):
        if value not in allowed:
            raise ModelError(
                f"{key}: unknown mode {excerpt(value, 40)} (modes: {', '.join(allowed)})"
            )
        return {m: float(m == value) for m in allowed}
    table = as_table(value, key)
    probabilities = {m: 0.0 for m in allowed}
    for mode, p in table.items():
        if mode not in allowed:
            raise ModelError(f"{key_path(key, mode)}: unknown mode (modes: {', '.join(allowed)})")
        probabilities[mode] = as_probability(p, key_path(key, mode))
    total = sum(probabilities.values())
    if abs(total - 1.0) > _PROBABILITY_TOLERANCE:
        raise ModelError(f"{key}: probabilities must sum to 1; they sum to {total:.10g}")
    return probabilities


def _rules(
    value: Any, key: str, mode_ids: tuple[str, ...], commands: tuple[str, ...]
) -> tuple[TransitionRule, ...]:
    """``[[components.<c>.transitions]]``: ``from``, optional ``when``, ``to``."""
    if not isinstance(value, list):
        raise ModelError(f"{key}: expected an array of tables ([[{key}]])")
    targets_allowed = (*mode_ids, UNKNOWN)
    seen: dict[tuple[str, tuple[tuple[str, float], ...]], str] = {}
    rules = []
    for i, raw in enumerate(value):
        rule_key = f"{key}[{i}]"
        spec = as_table(raw, rule_key)
        check_keys(spec, _RULE_KEYS, rule_key)
        source = as_string(required(spec, "from", rule_key), f"{rule_key}.from")
        if source not in (*targets_allowed, "*"):
            raise ModelError(
                f"{rule_key}.from: unknown mode {excerpt(source, 40)} (modes: "
                f"{', '.join(targets_allowed)}, or * for every known mode)"
            )
        when: dict[str, float] = {}
        for command, setting in as_table(spec.get("when", {}), f"{rule_key}.when").items():
            entry = key_path(f"{rule_key}.when", command)
            if command not in commands:
                listed = ", ".join(commands) or "none declared"
                raise ModelError(f"{entry}: not a command (commands: {listed})")
            when[command] = as_number(setting, entry)
        targets: dict[str, float] = {}
        for target, p in as_table(required(spec, "to", rule_key), f"{rule_key}.to").items():
            entry = key_path(f"{rule_key}.to", target)
            if target not in targets_allowed:
                raise ModelError(f"{entry}: unknown mode (modes: {', '.join(targets_allowed)})")
            targets[target] = as_probability(p, entry)
        total = sum(targets.values())
        if total > 1.0 + _PROBABILITY_TOLERANCE:
            raise ModelError(
                f"{rule_key}.to: probabilities sum to {total:g} > 1 (the rest of 1 stays in "
                "the source mode)"
            )
        identity = (source, tuple(sorted(when.items())))
        if identity in seen:
            raise ModelError(f"{rule_key}: the same from and when as {seen[identity]}")
        seen[identity] = rule_key
        rules.append(TransitionRule(source=source, when=when, targets=targets, key=rule_key))
    _refuse_ties(rules, mode_ids)
    _refuse_shadowed(rules, mode_ids)
    return tuple(rules)


def _refuse_ties(rules: list[TransitionRule], mode_ids: tuple[str, ...]) -> None:
    """Refuse two rules neither of which is more specific where both apply.

    Out of a mode the most specific matching rule applies: the mode's own before ``*``,
    then the one with more ``when`` conditions.  Two rules from the same mode with as many
    conditions, which hold together for some commands (``{a = 1}`` and ``{b = 1}``) and move
    the component differently, tie there; the first in the file was taken, silently.  They
    do not tie where a rule that outranks both holds whenever both do: one from that mode
    with more conditions or, for two ``*`` rules, the mode's own.
    """

    def outranks(rule: TransitionRule, source: str, pair: str, size: int) -> bool:
        if rule.source == pair:
            return len(rule.when) > size
        return pair == "*" and rule.source == source

    for j, later in enumerate(rules):
        for earlier in rules[:j]:
            if (
                earlier.source != later.source
                or len(earlier.when) != len(later.when)
                or earlier.targets == later.targets
                or any(later.when.get(c, v) != v for c, v in earlier.when.items())
            ):
                continue  # never both the most specific, or the same either way
            both = {**earlier.when, **later.when}
            pair, size = later.source, len(later.when)
            tied = [
                source
                for source in (mode_ids if pair == "*" else (pair,))
                if not any(
                    outranks(rule, source, pair, size)
                    and all(both.get(c) == v for c, v in rule.when.items())
                    for rule in rules
                )
            ]
            if not tied:
                continue  # a more specific rule applies wherever both do
            held = " and ".join(f"{c} = {v:.15g}" for c, v in both.items())
            table = ", ".join(f"{c} = {v:.15g}" for c, v in both.items())
            raise ModelError(
                f"{later.key}: ties with {earlier.key}: both apply from '{tied[0]}' while "
                f"{held}, with as many `when` conditions, so neither is more specific, and "
                f"their `to` differ; add a rule from '{pair}' with when = {{{table}}} for "
                "that case, or make their `when` exclusive"
            )


def _refuse_shadowed(rules: list[TransitionRule], mode_ids: tuple[str, ...]) -> None:
    """Refuse a ``*`` rule that applies out of no mode.

    A mode's own rule comes before ``*``: where every known mode has one that holds whenever
    the ``*`` rule does (no ``when``, or a part of its ``when``), the ``*`` rule is never
    applied, and the model silently meant something else (``from = "*", when = {cmd = 0}``
    beside each mode's fault rule without ``when``: the commanded switch never happened).
    """
    for star in rules:
        if star.source != "*":
            continue
        shadows = []
        for mode in mode_ids:
            own = next(
                (
                    rule
                    for rule in rules
                    if rule.source == mode
                    and all(star.when.get(c) == v for c, v in rule.when.items())
                ),
                None,
            )
            if own is None:
                break
            shadows.append(f"{mode}: {own.key}")
        else:
            raise ModelError(
                f"{star.key}: never applies: a mode's own rule comes before '*', and every "
                f"mode has one that holds wherever this one does ({'; '.join(shadows)}); "
                "give those rules this rule's `when` conditions and more, or write this "
                "rule for each mode"
            )


def _refuse_close_settings(components: list[Component]) -> None:
    """Refuse two ``when`` values of one command a logged value could match both of.

    A logged value within :data:`COMMAND_TOLERANCE` of a ``when`` value counts as it (a
    32-bit field's ``0.1``); ``cmd = 0.1`` and ``cmd = 0.1000001`` in two rules would both be
    matched by one logged value, which then counted as whichever came last.
    """
    seen: dict[str, list[tuple[float, str]]] = {}
    for component in components:
        for rule in component.rules:
            for command, value in rule.when.items():
                entry = f"{rule.key}.when.{command}"
                for other, other_entry in seen.setdefault(command, []):
                    scale = max(1.0, abs(value), abs(other))
                    if value != other and abs(value - other) <= 2 * COMMAND_TOLERANCE * scale:
                        raise ModelError(
                            f"{entry}: {value!r} is within {COMMAND_TOLERANCE:g} (relative) of "
                            f"{other!r} ({other_entry}), the distance within which a logged "
                            "value counts as a when value: one logged value would hold both; "
                            "give one value for both, or values further apart"
                        )
                seen[command].append((value, entry))
