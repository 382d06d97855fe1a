r"""The ``[simulation]`` scenario of a components model: what ``hybridlog simulate`` plays.

A components model (paper 002) has no joint mode schedule; its scenario says, per
component, when it changes mode, and adds what the model does not contain::

    [simulation]
    state = [0.49, 0.49, 1200.0]
    steps = 1500

    [simulation.parameters]           # numbers; `hybridlog simulate --set NAME=VALUE`
    light_fault = 900
    drift_rate = 0.003

    [simulation.modes]                # MODE@STEP, ...: the mode from that step on
    ls = "full, one_bank_out@light_fault, full@1300"

    [simulation.commands]             # VALUE@STEP, ...: command values (logged)
    light_cmd = "1"

    [[simulation.unmodelled]]         # behaviour no mode of the model describes
    component = "fr2"
    start = 700                       # a step or a parameter name
    end = 1100                        # optional: until the end
    equations = ["xc2[k] = min(xc2[k-1] + drift_rate, q_max)", "yc2 = xc2"]

    [simulation.controller]           # commands of the inputs computed from measurements
    states = {integral = 0.0}         # controller memory and its value before step 0
    update = {integral = "integral + 1200 - yc3"}
    inputs = {uc1 = "0.98 + 0.01*(1200 - yc3) + 5e-4*integral"}

Steps are integers or names of ``[simulation.parameters]``, so a hidden scenario can move a
fault with ``--set``.  An unmodelled behaviour replaces the component's equations from
``start`` to ``end`` (exclusive); its true mode is ``unknown`` (paper 002 §3).  Its
equations are played as written (no process noise: a drift stays a ramp, not a random
walk); its outputs keep the sensor noise of the mode the schedule gives.  The controller runs
once per step after the outputs are measured: ``update`` computes its memory at step k from
the memory at k−1 and the measured outputs ``y(k)``; ``inputs`` then computes ``u(k)`` from
``y(k)`` and the new memory (names of outputs, controller states, model and scenario
parameters, ``t`` and ``k``).

This module holds the data and its validation; :mod:`hybridlog.simulate_components` plays it.
"""

from __future__ import annotations

import itertools
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from hybridlog.errors import HybridlogError, ModelError, OptionError, excerpt
from hybridlog.model.component_loader import parse_equation
from hybridlog.model.components import UNKNOWN, Component, Equation
from hybridlog.model.toml_text import spelled, unheld_number
from hybridlog.model.values import (
    as_names,
    as_number,
    as_string,
    as_table,
    check_keys,
    key_path,
    required,
)
from hybridlog.numbers import parse_float, parse_int

if TYPE_CHECKING:
    import sympy

COMPONENT_KEYS = frozenset({"steps", "parameters", "modes", "commands", "unmodelled", "controller"})
"""``[simulation]`` keys only a components model has (besides ``state`` and ``inputs``)."""
_UNMODELLED_KEYS = {"component", "start", "end", "equations", "description"}
_CONTROLLER_KEYS = {"states", "update", "inputs"}

Step = int | str
"""A step: a non-negative integer, or the name of a scenario parameter holding one."""


@dataclass(frozen=True)
class Unmodelled:
    """Equations that replace one component's for a while (its true mode is ``unknown``).

    Attributes
    ----------
    component:
        The component's name.
    start, end:
        First step of the behaviour and the step it ends at (exclusive; ``None``: never).
    equations:
        The equations, parsed as a component mode's; they may use scenario parameters.
    key:
        ``simulation.unmodelled[i]``.
    """

    component: str
    start: Step
    end: Step | None
    equations: tuple[Equation, ...]
    key: str


@dataclass(frozen=True)
class Scenario:
    """A components model's ``[simulation]`` scenario (see the module doc).

    Attributes
    ----------
    steps:
        Default number of steps (rows − 1); ``None``: 100.
    parameters:
        Scenario parameters and their default values (``--set`` overrides them).
    modes:
        Per component, ``(mode, step)`` pairs: the mode from that step on.
    commands:
        Per command, ``(value, step)`` pairs.
    unmodelled:
        Behaviours the model does not contain, in the file's order.
    controller_states:
        Controller memory and its value before step 0.
    controller_update:
        Controller memory at step k as expressions of its memory at k−1 (its plain
        symbols), the measured outputs, parameters, ``t`` and ``k``.
    controller_inputs:
        Inputs computed by the controller, expressions of the measured outputs, the
        memory at step k, parameters, ``t`` and ``k``.
    """

    steps: int | None = None
    parameters: Mapping[str, float] = field(default_factory=dict)
    modes: Mapping[str, tuple[tuple[str, Step], ...]] = field(default_factory=dict)
    commands: Mapping[str, tuple[tuple[float, Step], ...]] = field(default_factory=dict)
    unmodelled: tuple[Unmodelled, ...] = ()
    controller_states: Mapping[str, float] = field(default_factory=dict)
    controller_update: Mapping[str, sympy.Expr] = field(default_factory=dict)
    controller_inputs: Mapping[str, sympy.Expr] = field(default_factory=dict)

    def parameter_values(self, settings: Mapping[str, float] | None = None) -> dict[str, float]:
        """The scenario parameters with ``settings`` (``--set``) applied.

        Raises
        ------
        KeyError
            A setting that is not a scenario parameter (the caller names the option).
        """
        values = dict(self.parameters)
        for name, value in (settings or {}).items():
            if name not in values:
                raise KeyError(name)
            values[name] = float(value)
        return values


@dataclass(frozen=True)
class StepValues:
    """A scenario's steps resolved: a number, or a parameter (its value, maybe ``--set``).

    Errors about a step name what set it: ``--set NAME`` (an :class:`OptionError`) when the
    user's setting is involved, else the key, after ``origin`` (the model file; ``None``
    while the file is loaded, whose loader prefixes it) (a :class:`ModelError`).
    """

    origin: str | None
    values: Mapping[str, float]
    settings: Collection[str] = ()

    def at(self, step: Step, key: str) -> int:
        """The row a step names; a parameter used as one must be a whole number >= 0."""
        if isinstance(step, int):
            return step
        value = self.values[step]
        if value < 0 or value != int(value):
            # every digit it takes: 900.0000000000001 was said "900", a whole number
            shown = f"{value:g}" if float(f"{value:g}") == value else repr(value)
            raise self.error(
                (step,),
                key,
                f"{step} = {shown} is used as a step; it must be a whole number >= 0",
            )
        return int(value)

    def text(self, step: Step, key: str) -> str:
        """A step for messages: ``1300`` or ``light_repair = 1300``."""
        return str(step) if isinstance(step, int) else f"{step} = {self.at(step, key):.15g}"

    def error(self, steps: Sequence[Step | None], key: str, problem: str) -> HybridlogError:
        """The error ``problem`` at ``key``, naming the ``--set`` of ``steps`` if there is one."""
        where = key if self.origin is None else f"{self.origin}: {key}"
        given = [s for s in steps if isinstance(s, str) and s in self.settings]
        if given:
            return OptionError(f"--set {given[0]}: {where}: {problem}", named=given[:1])
        return ModelError(f"{where}: {problem}")


def check_timing(scenario: Scenario, at: StepValues) -> None:
    """Refuse a scenario whose steps cannot be played, with the parameter values of ``at``.

    Every step a whole number >= 0, each mode and command schedule's steps increasing,
    every unmodelled behaviour ending after it starts, and no two of one component's
    behaviours overlapping.  Run as the file is loaded (the parameters' own values: a
    scenario ``simulate`` would refuse is an error of the file, which ``hybridlog models``
    reports) and again as it is played with ``--set`` (which then names the setting).
    The whole scenario is checked, not only the steps a shorter ``--steps`` run reaches.
    """
    schedules = [
        *((f"simulation.modes.{name}", entries) for name, entries in scenario.modes.items()),
        *((f"simulation.commands.{n}", entries) for n, entries in scenario.commands.items()),
    ]
    for key, entries in schedules:
        for (_, before), (_, after) in itertools.pairwise(entries):
            if at.at(after, key) <= at.at(before, key):
                raise at.error(
                    (before, after),
                    key,
                    f"the steps must increase ({at.text(before, key)} then {at.text(after, key)})",
                )
    spans: list[tuple[Unmodelled, int, float]] = []
    for behaviour in scenario.unmodelled:
        start = at.at(behaviour.start, f"{behaviour.key}.start")
        end = (
            float("inf") if behaviour.end is None else at.at(behaviour.end, f"{behaviour.key}.end")
        )
        if end <= start:
            assert behaviour.end is not None  # an end of inf comes after any start
            raise at.error(
                (behaviour.start, behaviour.end),
                behaviour.key,
                f"end ({at.text(behaviour.end, behaviour.key)}) must come after start "
                f"({at.text(behaviour.start, behaviour.key)})",
            )
        for earlier, first, last in spans:
            if earlier.component == behaviour.component and max(first, start) < min(last, end):
                raise at.error(
                    (earlier.start, earlier.end, behaviour.start, behaviour.end),
                    behaviour.key,
                    f"overlaps {earlier.key} at step {max(first, start)} (both replace "
                    f"{behaviour.component}'s equations there)",
                )
        spans.append((behaviour, start, end))


def load_scenario(
    table: Mapping[str, Any],
    *,
    components: tuple[Component, ...],
    states: tuple[str, ...],
    inputs: tuple[str, ...],
    outputs: tuple[str, ...],
    variables: tuple[str, ...],
    commands: tuple[str, ...],
    parameters: Mapping[str, sympy.Expr],
) -> Scenario:
    """Validate the components-only keys of ``[simulation]`` (see the module doc)."""
    import sympy

    steps = None
    if "steps" in table:
        value = table["steps"]
        if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
            raise ModelError(
                f"simulation.steps: expected a positive whole number, got {spelled(value)}"
            )
        steps = int(value)
    scenario_parameters: dict[str, float] = {}
    taken = {*states, *inputs, *outputs, *variables, *commands, *parameters}
    for name, value in as_table(table.get("parameters", {}), "simulation.parameters").items():
        key = key_path("simulation.parameters", name)
        as_names([name], key)
        if name in taken:
            raise ModelError(f"{key}: the name is already a variable or parameter of the model")
        scenario_parameters[name] = as_number(value, key)
    symbols = {name: sympy.Symbol(name, real=True) for name in scenario_parameters}
    by_name = {c.name: c for c in components}

    def step(value: Any, key: str) -> Step:
        if isinstance(value, str):
            if value not in scenario_parameters:
                known = ", ".join(scenario_parameters) or "none"
                raise ModelError(
                    f"{key}: {excerpt(value, 40)} is not a scenario parameter "
                    f"(simulation.parameters: {known}) nor a step (a whole number >= 0)"
                )
            return value
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise ModelError(f"{key}: expected a step (a whole number >= 0 or a parameter name)")
        return int(value)

    modes: dict[str, tuple[tuple[str, Step], ...]] = {}
    for name, text in as_table(table.get("modes", {}), "simulation.modes").items():
        key = key_path("simulation.modes", name)
        if name not in by_name:
            raise ModelError(f"{key}: not a component (components: {', '.join(by_name)})")
        allowed = by_name[name].mode_ids
        entries = []
        for label, at in _entries(as_string(text, key), key, step):
            if label not in allowed:
                raise ModelError(
                    f"{key}: unknown mode {excerpt(label, 40)} (modes: {', '.join(allowed)}; "
                    f"'{UNKNOWN}' is played by simulation.unmodelled)"
                )
            entries.append((label, at))
        modes[name] = tuple(entries)
    command_values: dict[str, tuple[tuple[float, Step], ...]] = {}
    for name, text in as_table(table.get("commands", {}), "simulation.commands").items():
        key = key_path("simulation.commands", name)
        if name not in commands:
            raise ModelError(f"{key}: not a command (commands: {', '.join(commands) or 'none'})")
        raw = str(text) if isinstance(text, int | float) and not isinstance(text, bool) else text
        entries_c = []
        for label, at in _entries(as_string(raw, key), key, step):
            try:
                value = parse_float(label)  # strictly: not 1_0, ٣, inf, nan or 1e-400
            except ValueError:
                raise ModelError(f"{key}: {_not_a_number(label)}") from None
            entries_c.append((value, at))
        command_values[name] = tuple(entries_c)
    unmodelled = []
    raw_list = table.get("unmodelled", [])
    if not isinstance(raw_list, list):
        raise ModelError("simulation.unmodelled: expected an array of tables")
    equation_parameters = {**parameters, **symbols}
    for i, raw in enumerate(raw_list):
        key = f"simulation.unmodelled[{i}]"
        spec = as_table(raw, key)
        check_keys(spec, _UNMODELLED_KEYS, key)
        component = as_string(required(spec, "component", key), f"{key}.component")
        if component not in by_name:
            raise ModelError(f"{key}.component: not a component (components: {', '.join(by_name)})")
        texts = required(spec, "equations", key)
        if isinstance(texts, str):
            texts = [texts]
        if not isinstance(texts, list) or not texts:
            raise ModelError(f"{key}.equations: expected a non-empty list of equation strings")
        equations = tuple(
            parse_equation(
                text,
                f"{key}.equations[{j}]",
                states=states,
                inputs=inputs,
                outputs=outputs,
                variables=variables,
                parameters=equation_parameters,
            )
            for j, text in enumerate(texts)
        )
        owned = set(by_name[component].states)
        for equation in equations:
            if equation.state and equation.state not in owned:
                raise ModelError(
                    f"{equation.key}: '{equation.state}' is a state of another component "
                    f"(a state belongs to one component)"
                )
        unmodelled.append(
            Unmodelled(
                component=component,
                start=step(required(spec, "start", key), f"{key}.start"),
                end=step(spec["end"], f"{key}.end") if "end" in spec else None,
                equations=equations,
                key=key,
            )
        )
    controller = as_table(table.get("controller", {}), "simulation.controller")
    check_keys(controller, _CONTROLLER_KEYS, "simulation.controller")
    memory: dict[str, float] = {}
    for name, value in as_table(
        controller.get("states", {}), "simulation.controller.states"
    ).items():
        key = key_path("simulation.controller.states", name)
        as_names([name], key)
        if name in taken or name in scenario_parameters:
            raise ModelError(f"{key}: the name is already a variable or parameter of the model")
        memory[name] = as_number(value, key)
    env: dict[str, sympy.Expr] = {
        **{name: sympy.Symbol(name, real=True) for name in (*outputs, *memory)},
        "t": sympy.Symbol("t", real=True),
        "k": sympy.Symbol("k", real=True),
        **parameters,
        **symbols,
    }
    update: dict[str, sympy.Expr] = {}
    for name, text in as_table(
        controller.get("update", {}), "simulation.controller.update"
    ).items():
        key = key_path("simulation.controller.update", name)
        if name not in memory:
            raise ModelError(
                f"{key}: not a controller state (simulation.controller.states: "
                f"{', '.join(memory) or 'none'})"
            )
        update[name] = _expression(text, env, key)
    for name in [name for name in memory if name not in update]:  # kept its first value, unsaid
        raise ModelError(
            f"{key_path('simulation.controller.states', name)}: the controller state has no "
            f"update ({key_path('simulation.controller.update', name)}): it would keep "
            f"{memory[name]:g} at every step; write its update, or make it a parameter"
        )
    control: dict[str, sympy.Expr] = {}
    for name, text in as_table(
        controller.get("inputs", {}), "simulation.controller.inputs"
    ).items():
        key = key_path("simulation.controller.inputs", name)
        if name not in inputs:
            raise ModelError(f"{key}: not an input (inputs: {', '.join(inputs) or 'none'})")
        if name in as_table(table.get("inputs", {}), "simulation.inputs"):
            raise ModelError(f"{key}: simulation.inputs.{name} gives this input already")
        control[name] = _expression(text, env, key)
    scenario = Scenario(
        steps=steps,
        parameters=scenario_parameters,
        modes=modes,
        commands=command_values,
        unmodelled=tuple(unmodelled),
        controller_states=memory,
        controller_update=update,
        controller_inputs=control,
    )
    check_timing(scenario, StepValues(None, scenario_parameters))
    return scenario


def _expression(value: Any, env: Mapping[str, sympy.Expr], key: str) -> sympy.Expr:
    from hybridlog.model.expressions import expression_text, parse_expression

    return parse_expression(as_string(expression_text(value), key), env, key=key)


def _entries(text: str, key: str, step: Any) -> list[tuple[str, Step]]:
    """``"a, b@10, c@name"`` → ``[("a", 0), ("b", 10), ("c", "name")]``; the first is at 0."""
    entries: list[tuple[str, Step]] = []
    for i, part in enumerate(text.split(",")):
        label, sep, at = part.strip().partition("@")
        label = label.strip()
        if not label:
            raise ModelError(
                f"{key}: an empty entry in {excerpt(text, 60)} (write VALUE@STEP, ...)"
            )
        if not sep:
            if i:
                raise ModelError(
                    f"{key}: {excerpt(part.strip(), 40)} needs @STEP (only the first "
                    "entry starts at step 0 without one)"
                )
            entries.append((label, 0))
            continue
        at = at.strip()
        try:  # strictly: ASCII digits (not 1_0 or ١٠); anything else is a parameter's name
            number: Step = parse_int(at)
        except ValueError:
            number = at
        entries.append((label, step(number, key)))
    if not entries or entries[0][1] != 0:
        raise ModelError(f"{key}: the first entry must start at step 0 (write it without @STEP)")
    return entries


def _not_a_number(label: str) -> str:
    """Why ``label`` is no command value, which ``parse_float`` refused.

    A number no double holds (``1e-400`` would be the value 0), or no number at all.
    """
    try:
        unheld = unheld_number(label, float(label))
    except ValueError:  # not even Python's float
        unheld = ""
    return unheld or f"{excerpt(label, 40)} is not a number (ASCII digits, finite)"
