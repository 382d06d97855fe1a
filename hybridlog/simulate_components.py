r"""Simulation of a components model (paper 002): the whole plant, one joint mode at a time.

A components model's plant at step k is the union of its components' equations for the
joint mode of that step (paper 002 eq. (8)).  For every joint mode the scenario visits, the
union is solved once with sympy, independently of any estimator's decomposition:

.. math::

    x(k) = f_{q(k)}\bigl(v(k-1)\bigr) + v_s(k-1), \qquad
    w(k) = g_{q(k)}\bigl(x(k), u(k)\bigr), \qquad
    y_{meas}(k) = y(k) + v_o(k)

(eq. (1)): the difference equations give the states from every variable at step k−1; the
algebraic equations are solved for the outputs and internal variables at step k.  The
solution is printed by :mod:`hybridlog.model.codegen` into one module per joint mode, kept
in the compiled-code cache (:func:`hybridlog.model.compiled.load_generated`), so a warm run
solves nothing.

The scenario (:mod:`hybridlog.model.scenario`) gives each component's mode per step, the
command values, unmodelled behaviours (their rows' true mode is ``unknown``) and the
controller, which runs after the outputs of step k are measured and computes ``u(k)``.
Process and measurement noise are Gaussian with the variances of the scheduled modes; an
unmodelled behaviour has no process noise (its equations are played as written) and keeps
the sensor noise of the mode the schedule gives.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from hybridlog.cluster.progress import simulating
from hybridlog.errors import ModelError, OptionError, arithmetic_reason, excerpt, first_few
from hybridlog.model.compiled import input_functions, load_generated
from hybridlog.model.component_structure import solve_explicitly
from hybridlog.model.components import UNKNOWN, Component, Equation, joint_label
from hybridlog.signals import FloatArray
from hybridlog.simulation_inputs import input_hint, input_signal, model_origin
from hybridlog.times import format_time

if TYPE_CHECKING:
    import sympy

    from hybridlog.model.hybrid_model import HybridModel
    from hybridlog.model.scenario import Scenario, Step, StepValues

_MODULES = ("hybridlog.simulate_components",)
"""The module whose code shapes the generated joint-mode and controller modules."""


@dataclass(frozen=True)
class ComponentsLog:
    """A simulated run of a components model: the columns of the log ``simulate`` writes.

    Attributes
    ----------
    time:
        ``t_k = k·dt``, shape ``(N,)``.
    inputs, outputs:
        ``u(k)`` and the measured ``y(k)`` (noise included), ``(N, n_u)`` and ``(N, n_y)``.
    states:
        The true states ``x(k)``, ``(N, n_x)``.
    variables:
        The true internal variables ``w(k)``, ``(N, n_w)``.
    commands:
        The command values, ``(N, n_c)``.
    modes:
        Per component, its true mode per row (``unknown`` during an unmodelled behaviour).
    controller:
        The controller's memory per row, ``(N, n_memory)``.
    notes:
        Scenario events the run ends before (:func:`_cut_events`), printed by the CLI.
    unreached:
        Per component, each mode of its ``simulation.modes`` schedule the run ended before
        (a ``--steps`` shorter than the scenario) → the step the scenario starts it.
    unstarted:
        Each unmodelled behaviour the run ended before (its index in
        ``simulation.unmodelled``) → the step the scenario starts it.
    """

    time: FloatArray
    inputs: FloatArray
    outputs: FloatArray
    states: FloatArray
    variables: FloatArray
    commands: FloatArray
    modes: Mapping[str, tuple[str, ...]]
    controller: FloatArray
    notes: tuple[str, ...] = ()
    unreached: Mapping[str, Mapping[str, int]] = field(default_factory=dict)
    unstarted: Mapping[int, int] = field(default_factory=dict)

    def truth_columns(self, model: HybridModel) -> tuple[str, ...]:
        """Columns that are ground truth: ``mode.<component>`` and the states."""
        return (*(f"mode.{c.name}" for c in model.components), *model.states)

    def columns(self, model: HybridModel) -> dict[str, FloatArray | list[str]]:
        """``t``, inputs, outputs, commands, ``mode.<component>``, true states, by name."""
        columns: dict[str, FloatArray | list[str]] = {"t": self.time}
        for group, names in (
            (self.inputs, model.inputs),
            (self.outputs, model.outputs),
            (self.commands, model.commands),
        ):
            for j, name in enumerate(names):
                columns[name] = np.ascontiguousarray(group[:, j])
        for component in model.components:
            columns[f"mode.{component.name}"] = list(self.modes[component.name])
        for j, name in enumerate(model.states):
            columns[name] = np.ascontiguousarray(self.states[:, j])
        return columns


@dataclass(frozen=True)
class _Joint:
    """One joint mode's compiled equations and noise standard deviations."""

    step: Callable[[FloatArray, FloatArray, FloatArray], None]
    algebraic: Callable[[FloatArray, FloatArray], None]
    process_std: FloatArray
    measurement_std: FloatArray


def scenario_settings(
    model: HybridModel, scenario: Scenario, settings: Mapping[str, float] | None
) -> StepValues:
    """The scenario's parameter values with ``settings`` (``--set``), its steps checked with them.

    Also asked by ``simulate`` before it checks its output (a bad ``--set`` is told before
    "already exists"), as the loader checked the scenario without them.

    Raises
    ------
    OptionError
        A setting that is not a scenario parameter, or that leaves a step unplayable.
    """
    from hybridlog.model.scenario import StepValues, check_timing

    origin = model_origin(model)
    try:
        values = scenario.parameter_values(settings)
    except KeyError as err:
        known = ", ".join(scenario.parameters) or "none"
        raise OptionError(
            f"--set {excerpt(err.args[0])[1:-1]}: neither a scenario parameter of {origin} "
            f"(simulation.parameters: {known}) nor a parameter of the model (parameters: "
            f"{', '.join(model.parameters) or 'none'})"
        ) from err
    at = StepValues(origin, values, tuple(settings or ()))
    check_timing(scenario, at)  # the whole scenario, as the loader checked it without --set
    return at


def simulate_components(
    model: HybridModel,
    *,
    steps: int | None = None,
    seed: int = 0,
    settings: Mapping[str, float] | None = None,
    log_format: str | None = None,
) -> ComponentsLog:
    """Play the scenario of a components model (see the module doc).

    Parameters
    ----------
    model:
        A components model with a ``[simulation]`` scenario.
    steps:
        Number of steps (rows − 1); default the scenario's ``steps``, else 100.
    seed:
        Seed of the noise (NumPy PCG64): the same seed and settings give the same log.
    settings:
        Scenario parameter values (``--set NAME=VALUE``): fault times, drift rate, gains.
    log_format:
        The format the run will be written in, as for :func:`hybridlog.simulate.simulate`
        (``None``: no log is written).

    Raises
    ------
    OptionError
        A bad ``steps``, ``seed`` or setting, or a run that does not fit in memory.
    ModelError
        A scenario the model cannot play: a joint mode whose equations do not determine
        every variable, an algebraic loop through the controller, a diverging run, or a
        measured output without a measurement noise covariance in the model file.
    """
    from hybridlog.simulation_inputs import sample_times, start_state
    from hybridlog.simulation_limits import check_run, check_seed, check_steps
    from hybridlog.simulation_range import out_of_range, within_range

    seed = check_seed(seed)
    steps = check_steps(steps)
    origin = model_origin(model)
    scenario = model.scenario
    if not model.has_components or scenario is None:
        raise ModelError(f"{origin}: components: not a components model")
    model.require_measurement_noise("simulate draws the outputs' measurement noise")
    at = scenario_settings(model, scenario, settings)
    values = at.values
    n_steps = steps or scenario.steps or 100
    rows = n_steps + 1
    where = "--steps" if steps else f"{origin}: simulation.steps"
    ends = (
        f"--steps {n_steps:,}"
        if steps
        else f"simulation.steps = {n_steps:,}"
        if scenario.steps
        else f"the default of {n_steps} steps (no --steps, no simulation.steps)"
    )
    check_run(model, rows, where, log_format)

    labels = _mode_labels(model, scenario, rows, at)
    overrides = _overrides(model, scenario, rows, at, labels)
    commands = np.zeros((rows, len(model.commands)))
    for j, name in enumerate(model.commands):
        if name not in scenario.commands:  # the log would hold a 0 the file never gave
            raise ModelError(
                f"{origin}: simulation.commands.{name}: no value of the command to simulate "
                f'with (the log holds one at every step); write {name} = "VALUE" '
                '(or "VALUE, VALUE@STEP, ...") under [simulation.commands]'
            )
        for value, start in _sorted(
            scenario.commands.get(name, ()), at, f"simulation.commands.{name}"
        ):
            commands[min(start, rows) :, j] = value
    joints: dict[tuple[str, ...], _Joint] = {}
    assignment = [
        tuple(
            f"~{overrides[c.name][k]}:{labels[c.name][k]}"
            if overrides[c.name][k] >= 0
            else labels[c.name][k]
            for c in model.components
        )
        for k in range(rows)
    ]
    parameter_names = tuple(values)
    parameters = np.array([values[n] for n in parameter_names], dtype=float)
    for entries in dict.fromkeys(assignment):
        joints[entries] = _compile_joint(
            model, scenario, entries, _labels_of(entries, model), parameter_names
        )

    time = sample_times(rows, model.dt)
    inputs = _open_loop_inputs(model, scenario, time)
    controlled = [model.inputs.index(name) for name in scenario.controller_inputs]
    controller = _controller(model, scenario, parameter_names) if controlled else None
    memory = np.array(list(scenario.controller_states.values()), dtype=float)
    memory_log = np.zeros((rows, memory.shape[0]))
    rng = np.random.default_rng(seed)
    process_draws = rng.standard_normal((rows, model.n_states))
    measurement_draws = rng.standard_normal((rows, model.n_outputs))

    n_x, n_u, n_y = model.n_states, model.n_inputs, model.n_outputs
    universe = (*model.states, *model.inputs, *model.outputs, *model.variables)
    values_log = np.zeros((rows, len(universe)))
    state_slice = slice(0, n_x)
    input_slice = slice(n_x, n_x + n_u)
    output_slice = slice(n_x + n_u, n_x + n_u + n_y)
    measured = np.zeros((rows, n_y))
    initial = start_state(model)
    new_memory = np.zeros_like(memory)
    control = np.zeros(len(controlled))
    # a Python step of the joint modes and the controller, about 50 µs: 10^6 steps in a minute
    stepping = simulating(rows, origin)
    with stepping:
        for k in range(rows):
            joint = joints[assignment[k]]
            now = values_log[k]
            if k == 0:
                now[state_slice] = initial
            else:
                joint.step(values_log[k - 1], parameters, now)
                now[state_slice] += joint.process_std * process_draws[k]
            if controller is not None:  # u(k) is not known yet: the outputs do not depend on it
                inputs[k, controlled] = inputs[k - 1, controlled] if k else 0.0
            now[input_slice] = inputs[k]
            joint.algebraic(now, parameters)
            measured[k] = now[output_slice] + joint.measurement_std * measurement_draws[k]
            if controller is not None:
                try:
                    with np.errstate(divide="raise", invalid="raise", over="raise"):
                        update, compute = controller
                        update(measured[k], memory, parameters, time[k], float(k), new_memory)
                        memory[:] = new_memory
                        compute(measured[k], memory, parameters, time[k], float(k), control)
                except (ArithmeticError, ValueError) as err:  # 1/0, overflow, log(-1), 0*inf
                    raise ModelError(
                        _controller_failed(origin, err, time[k], settings), named=settings or ()
                    ) from None
                inputs[k, controlled] = control
                now[input_slice] = inputs[k]
                joint.algebraic(now, parameters)
                memory_log[k] = memory
            for names, row in ((universe, now), (model.outputs, measured[k])):
                if not np.all(readable := within_range(row)):  # a log holds none, 2^480 on
                    j = int(np.argmin(readable))
                    raise out_of_range(origin, names[j], float(row[j]), float(time[k]))
            stepping.reached(k + 1)
    modes = {
        c.name: tuple(
            UNKNOWN if overrides[c.name][k] >= 0 else labels[c.name][k] for k in range(rows)
        )
        for c in model.components
    }
    return ComponentsLog(
        time=time,
        inputs=inputs,
        outputs=measured,
        states=np.ascontiguousarray(values_log[:, state_slice]),
        variables=np.ascontiguousarray(values_log[:, n_x + n_u + n_y :]),
        commands=commands,
        modes=modes,
        controller=memory_log,
        notes=_cut_events(scenario, rows, at, labels, ends),
        unreached=_unreached(scenario, at, labels),
        unstarted={
            i: start
            for i, b in enumerate(scenario.unmodelled)
            if (start := at.at(b.start, f"{b.key}.start")) >= rows
        },
    )


def _unreached(
    scenario: Scenario, at: StepValues, labels: Mapping[str, list[str]]
) -> dict[str, dict[str, int]]:
    """Component → scheduled mode the run never reached → the step the scenario starts it."""
    unreached: dict[str, dict[str, int]] = {}
    for name, entries in scenario.modes.items():
        key = f"simulation.modes.{name}"
        for mode, step in entries:
            if mode not in labels[name]:
                unreached.setdefault(name, {}).setdefault(mode, at.at(step, key))
    return unreached


def _cut_events(
    scenario: Scenario,
    rows: int,
    at: StepValues,
    labels: Mapping[str, list[str]],
    ends: str,
) -> tuple[str, ...]:
    """A note naming the scheduled modes and unmodelled behaviours the run's end cuts off.

    ``bioplex_pgc --steps 500`` wrote a run without its drift (from step 700) or its light
    fault (900), without a word: a user who asked for the scenario took it for one; so did
    ``--set light_fault=1600`` on the scenario's own 1,500 steps.  ``ends`` names what ended
    the run (``--steps 500``, ``simulation.steps = 1,500``).  As for
    a plain model's schedule (:func:`hybridlog.simulation_schedule.cut_schedule`), what is noted is
    what never runs: a component's scheduled mode it never takes, a behaviour that never
    starts (a repair back to a mode the run already had is no news).
    """
    cut: list[tuple[int, str]] = []
    for name, entries in scenario.modes.items():
        key = f"simulation.modes.{name}"
        cut += [
            (at.at(step, key), f"{key}: {mode} at {at.text(step, key)}")
            for mode, step in entries
            if mode not in labels[name]
        ]
    cut += [
        (at.at(b.start, b.key), f"{b.key} ({b.component}) from {at.text(b.start, b.key)}")
        for b in scenario.unmodelled
        if at.at(b.start, b.key) >= rows
    ]
    if not cut:
        return ()
    cut.sort()
    return (
        f"{ends} ends the run before these events of {at.origin}'s scenario, "
        f"which never run: {first_few(cut, 5, lambda event: event[1], separator='; ')}",
    )


def _labels_of(joint: tuple[str, ...], model: HybridModel) -> dict[str, str]:
    """Component → its entry of a joint assignment.

    A mode id, or ``~i:<scheduled mode>`` while unmodelled behaviour i replaces the
    component's equations.
    """
    return {c.name: entry for c, entry in zip(model.components, joint, strict=True)}


def _unmodelled_index(entry: str) -> int:
    """``i`` of a joint-assignment entry ``~i:<scheduled mode>`` (unmodelled behaviour i)."""
    return int(entry[1:].partition(":")[0])


def _sorted(entries: Sequence[tuple[Any, Step]], at: StepValues, key: str) -> list[tuple[Any, int]]:
    """Schedule entries with their steps resolved (increasing: :func:`check_timing` saw to it)."""
    return [(value, at.at(step, key)) for value, step in entries]


def _mode_labels(
    model: HybridModel, scenario: Scenario, rows: int, at: StepValues
) -> dict[str, list[str]]:
    """Each component's scheduled mode per row (default: its most likely initial mode)."""
    labels: dict[str, list[str]] = {}
    for component in model.components:
        entries = scenario.modes.get(component.name) or ((_default_mode(model, component), 0),)
        row = [entries[0][0]] * rows
        for mode, start in _sorted(entries, at, f"simulation.modes.{component.name}"):
            row[min(start, rows) :] = [mode] * (rows - min(start, rows))
        labels[component.name] = row
    return labels


def _default_mode(model: HybridModel, component: Component) -> str:
    """The mode a component without a ``[simulation.modes]`` entry plays: its most likely.

    Refused where ``initial`` names no single known mode more likely than every other mode
    (``unknown`` included): a tie (the default, uniform) or ``unknown`` itself would have the
    run pick a mode the file never chose, and the log call it the truth.
    """
    initial = component.initial_mode_probabilities
    ranked = sorted(initial.items(), key=lambda item: -item[1])
    best, p_best = ranked[0]
    if best != UNKNOWN and (len(ranked) == 1 or ranked[1][1] < p_best):
        return best
    shown = ", ".join(f"{mode} {p:.6g}" for mode, p in ranked)
    raise ModelError(
        f"{model_origin(model)}: simulation.modes.{component.name}: no mode to simulate component "
        f"'{component.name}' in: its initial probabilities ({component.key}.initial: "
        f"{shown}) name no single most likely known mode; write {component.name} = "
        f'"MODE" (or "MODE, MODE@STEP, ...") under [simulation.modes]'
    )


def _overrides(
    model: HybridModel,
    scenario: Scenario,
    rows: int,
    at: StepValues,
    labels: Mapping[str, list[str]],
) -> dict[str, list[int]]:
    """Per component and row, the index of the unmodelled behaviour in force, or −1.

    The behaviours were checked whole before (:func:`~hybridlog.model.scenario.check_timing`):
    each ends after it starts, and no two of one component overlap.
    """
    overrides = {c.name: [-1] * rows for c in model.components}
    for index, behaviour in enumerate(scenario.unmodelled):  # none overlap: check_timing
        start = at.at(behaviour.start, f"{behaviour.key}.start")
        end = rows if behaviour.end is None else at.at(behaviour.end, f"{behaviour.key}.end")
        first, last = min(start, rows), min(end, rows)
        overrides[behaviour.component][first:last] = [index] * (last - first)
    return overrides


def _open_loop_inputs(model: HybridModel, scenario: Scenario, time: FloatArray) -> FloatArray:
    """``u(k)`` of the inputs ``[simulation.inputs]`` gives; the controller fills the rest."""
    functions = input_functions(model)
    inputs = np.zeros((time.shape[0], model.n_inputs))
    for j, name in enumerate(model.inputs):
        if name in scenario.controller_inputs:
            continue
        if name not in functions:
            raise ModelError(
                f"{model_origin(model)}: simulation.inputs.{name}: no input signal to simulate "
                f"with (nor simulation.controller.inputs); {input_hint(name)}"
            )
        inputs[:, j] = input_signal(model, name, functions[name], time)
    return inputs


def _joint_equations(
    model: HybridModel, scenario: Scenario, joint: Mapping[str, str]
) -> list[Equation]:
    equations: list[Equation] = []
    for component in model.components:
        entry = joint[component.name]
        if entry.startswith("~"):
            equations += scenario.unmodelled[_unmodelled_index(entry)].equations
        else:
            equations += component.equations(entry)
    return equations


def _describe(joint: Mapping[str, str], scenario: Scenario) -> str:
    """The joint mode as the estimators and ``models FILE`` name it: ``m11|m21``.

    A component playing an unmodelled behaviour is ``unknown`` there, as the log's true mode
    says, and the behaviours are named after the label: ``m11|unknown (simulation.
    unmodelled[0])``.  It was ``{A1=m11, A2=m21}``, so one joint mode refused by ``imm``
    and by ``simulate`` (an equation with several solutions) was named two ways.
    """
    modes, behaviours = [], []
    for entry in joint.values():
        unmodelled = entry.startswith("~")
        modes.append(UNKNOWN if unmodelled else entry)
        if unmodelled:
            behaviours.append(scenario.unmodelled[_unmodelled_index(entry)].key)
    shown = joint_label(modes)
    return f"{shown} ({', '.join(behaviours)})" if behaviours else shown


def _compile_joint(
    model: HybridModel,
    scenario: Scenario,
    joint_entries: tuple[str, ...],
    joint: Mapping[str, str],
    parameter_names: tuple[str, ...],
) -> _Joint:
    """The joint mode's solved equations (generated once, then cached) and its noise."""
    digest = hashlib.sha256(repr((joint_entries, parameter_names)).encode()).hexdigest()[:16]

    def generate() -> str:
        return _joint_source(model, scenario, joint, parameter_names)

    module = load_generated(model, f"joint_{digest}", generate, _MODULES)
    process = np.zeros(model.n_states)
    measurement = np.zeros(model.n_outputs)
    for component in model.components:
        entry = joint[component.name]
        unmodelled = entry.startswith("~")
        # An unmodelled behaviour is played as written (no process noise); its outputs keep
        # the sensor noise of the mode the schedule gives.
        mode = component.mode(entry.partition(":")[2] if unmodelled else entry)
        for name, variance in mode.process_noise.items():
            if not unmodelled:
                process[model.states.index(name)] = variance
        for name, variance in mode.measurement_noise.items():
            measurement[model.outputs.index(name)] = variance
    return _Joint(
        step=module.step,
        algebraic=module.algebraic,
        process_std=np.sqrt(process),
        measurement_std=np.sqrt(measurement),
    )


def _joint_source(
    model: HybridModel,
    scenario: Scenario,
    joint: Mapping[str, str],
    parameter_names: tuple[str, ...],
) -> str:
    """Python source of ``step(b, p, a)`` and ``algebraic(a, p)`` for one joint mode.

    ``b`` holds every variable at step k−1 and ``a`` at step k, in the order states, inputs,
    outputs, internal variables; ``p`` the scenario parameters.  ``step`` writes the states
    of ``a``; ``algebraic`` the outputs and internal variables from its states and inputs.
    """
    import sympy

    from hybridlog.model.codegen import assignments
    from hybridlog.model.expressions import previous_symbol

    origin = model_origin(model)
    shown = _describe(joint, scenario)
    equations = _joint_equations(model, scenario, joint)
    universe = (*model.states, *model.inputs, *model.outputs, *model.variables)
    current = {n: sympy.Symbol(n, real=True) for n in universe}
    names: dict[sympy.Symbol, sympy.Symbol] = {}
    for i, name in enumerate(universe):
        names[current[name]] = sympy.Symbol(f"a{i}")
        names[previous_symbol(name)] = sympy.Symbol(f"b{i}")
    for i, name in enumerate(parameter_names):
        names[sympy.Symbol(name, real=True)] = sympy.Symbol(f"p{i}")
    difference = {e.state: e.rhs for e in equations if e.kind == "difference"}
    for state in model.states:
        if state not in difference:
            raise ModelError(
                f"{origin}: simulation: in the joint mode {shown} no difference equation "
                f"gives the state '{state}'"
            )
    targets = (*model.outputs, *model.variables)
    unknowns = [current[n] for n in targets]
    algebraic = [e for e in equations if e.kind == "algebraic"]
    try:
        solution = solve_explicitly(algebraic, targets, shown) if targets else {}
    except ModelError as err:
        raise ModelError(f"{origin}: simulation: {err}") from None
    controlled = {current[n] for n in scenario.controller_inputs}
    for output in model.outputs:
        loop = solution[current[output]].free_symbols & controlled
        if loop:
            raise ModelError(_same_step_input(origin, model, scenario, shown, output, loop))
    n = len(universe)
    lines = [f'"""Generated by hybridlog: the joint mode {shown} of {model.name!r}."""', ""]
    lines += ["import math", "", "", "def step(b, p, a):"]
    lines += [f"    b{i} = b[{i}]" for i in range(n)]
    lines += [f"    p{i} = p[{i}]" for i in range(len(parameter_names))]
    states = list(model.states)
    lines += assignments(
        [difference[s] for s in states],
        [f"a[{universe.index(s)}]" for s in states],
        names,
        "    ",
        temporaries="t_",
    )
    lines += ["    return None", "", "", "def algebraic(a, p):"]
    known = len(model.states) + len(model.inputs)
    lines += [f"    a{i} = a[{i}]" for i in range(known)]
    lines += [f"    p{i} = p[{i}]" for i in range(len(parameter_names))]
    lines += assignments(
        [solution[u] for u in unknowns],
        [f"a[{known + j}]" for j in range(len(unknowns))],
        names,
        "    ",
        temporaries="t_",
    )
    lines.append("    return None")
    return "\n".join(lines) + "\n"


def _same_step_input(
    origin: str,
    model: HybridModel,
    scenario: Scenario,
    shown: str,
    output: str,
    inputs: set[sympy.Symbol],
) -> str:
    """The refusal of an output that needs a controlled input of its own step.

    The controller computes ``u(k)`` after the outputs of step k.  A controller that reads
    outputs closes an algebraic loop; one that reads none (``u1 = "0.1"``, with ``y1 = u1`` in
    a mode) was called a loop too, though the input belongs under ``[simulation.inputs]``.
    """
    name = sorted(map(str, inputs))[0]
    said = (
        f"{origin}: simulation.controller.inputs.{name}: in the joint mode {shown} the output "
        f"'{output}' depends on {name} at the same step, which the controller computes after "
        "the outputs of that step"
    )
    expressions = (*scenario.controller_inputs.values(), *scenario.controller_update.values())
    read = {str(symbol) for e in expressions for symbol in e.free_symbols}
    if read.intersection(model.outputs):
        return f"{said}, from them (an algebraic loop)"
    return (
        f"{said}; the controller reads no output: give {name} under [simulation.inputs] (an "
        "expression in t and k, known before the outputs)"
    )


def _controller_failed(
    origin: str, err: BaseException, at: float, settings: Mapping[str, float] | None
) -> str:
    """Why the controller gave no number at time ``at``, with the ``--set`` values in play.

    ``--set ki=0`` of bioplex_pgc's ``u_max/ki`` was "numerical trouble in
    simulate_components.py:271: divide by zero", naming neither the controller nor the value.
    """
    given = ", ".join(f"{name}={value:g}" for name, value in (settings or {}).items())
    return (
        f"{origin}: simulation.controller: {arithmetic_reason(err)} at t = {format_time(at)} s"
        + (f" (with --set {given})" if given else "")
        + "; the controller gives no number to simulate with"
    )


def _controller(
    model: HybridModel, scenario: Scenario, parameter_names: tuple[str, ...]
) -> tuple[Callable[..., None], Callable[..., None]]:
    """``update(y, c, p, t, k, out)`` and ``control(y, c, p, t, k, out)`` of the controller."""

    def generate() -> str:
        return _controller_source(model, scenario, parameter_names)

    digest = hashlib.sha256(repr(parameter_names).encode()).hexdigest()[:16]
    module = load_generated(model, f"controller_{digest}", generate, _MODULES)
    return module.update, module.control


def _controller_source(
    model: HybridModel, scenario: Scenario, parameter_names: tuple[str, ...]
) -> str:
    import sympy

    from hybridlog.model.codegen import assignments

    names: dict[sympy.Symbol, sympy.Symbol] = {
        sympy.Symbol("t", real=True): sympy.Symbol("t"),
        sympy.Symbol("k", real=True): sympy.Symbol("k"),
    }
    for i, name in enumerate(model.outputs):
        names[sympy.Symbol(name, real=True)] = sympy.Symbol(f"y{i}")
    memory = list(scenario.controller_states)
    for i, name in enumerate(memory):
        names[sympy.Symbol(name, real=True)] = sympy.Symbol(f"c{i}")
    for i, name in enumerate(parameter_names):
        names[sympy.Symbol(name, real=True)] = sympy.Symbol(f"p{i}")
    head = [f"    y{i} = y[{i}]" for i in range(model.n_outputs)]
    head += [f"    c{i} = c[{i}]" for i in range(len(memory))]
    head += [f"    p{i} = p[{i}]" for i in range(len(parameter_names))]
    lines = [f'"""Generated by hybridlog: the simulation controller of {model.name!r}."""', ""]
    lines += ["import math", "", "", "def update(y, c, p, t, k, out):", *head]
    kept = [(i, name) for i, name in enumerate(memory) if name not in scenario.controller_update]
    lines += [f"    out[{i}] = c{i}" for i, _ in kept]
    updated = [(i, name) for i, name in enumerate(memory) if name in scenario.controller_update]
    if updated:
        lines += assignments(
            [scenario.controller_update[name] for _, name in updated],
            [f"out[{i}]" for i, _ in updated],
            names,
            "    ",
            temporaries="t_",
        )
    lines += ["    return None", "", "", "def control(y, c, p, t, k, out):", *head]
    lines += assignments(
        list(scenario.controller_inputs.values()),
        [f"out[{j}]" for j in range(len(scenario.controller_inputs))],
        names,
        "    ",
        temporaries="t_",
    )
    lines.append("    return None")
    return "\n".join(lines) + "\n"
