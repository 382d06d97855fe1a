"""Model files (TOML, SPEC §6) → :class:`~hybridlog.model.hybrid_model.HybridModel`.

Every value is validated and every error starts with the file (or built-in name) and names
the key at fault, e.g. ``model.toml: modes.2.C: matrix C of mode '2' has the wrong number of
columns; expected 3 instead of 4``.

A model's modes come in one of three ways, and the keys of the others are refused:

- ``[modes.<id>]``, each with ``f`` (discrete time) or ``dx`` (continuous time) and ``h``,
  or with matrices ``A``, ``B``, ``C`` (``D``);
- ``booleans = [...]`` with the equations written once in ``[dynamics]`` (paper 003): the
  modes are the ``2^L`` combinations (:class:`~hybridlog.model.hybrid_model.BooleanAffine`);
- ``[components.<name>]`` (paper 002), see :mod:`hybridlog.model.component_loader`.

Continuous time: ``time = "continuous"``, ``dt`` (the sample time of the log) and
``integration = {method = "euler" | "rk4", step = ...}`` (``rk4`` when not given), ``dt``
an integer multiple of ``step``.  ``[jumps."a->b"]`` give state resets at switches.

:func:`load_model` (re-exported from :mod:`hybridlog.model.cache`) reads a model file or a
built-in and calls :func:`parse_model` only when the loaded-model cache has no valid file.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np
import sympy

from hybridlog.errors import ModelError, UnusedParameterError, excerpt, prefixed
from hybridlog.model.cache import load_model
from hybridlog.model.component_loader import load_components
from hybridlog.model.component_structure import ComponentNames, check_joint_modes
from hybridlog.model.components import Component
from hybridlog.model.diagnosis import diagnose
from hybridlog.model.expressions import expression_text, parse_expression
from hybridlog.model.file_keys import (
    DYNAMICS_KEYS,
    INITIAL_KEYS,
    INTEGRATION_KEYS,
    MODE_KEYS,
    NOISE_KEYS,
    SIMULATION_KEYS,
    TOP_KEYS,
    model_kind,
    refuse_misplaced_top_keys,
)
from hybridlog.model.hybrid_model import (
    INTEGRATION_METHODS,
    BooleanAffine,
    HybridModel,
    IntegrationMethod,
    Jump,
    LinearForm,
    Mode,
    Timebase,
    outputs_differ,
)
from hybridlog.model.log_fields import (
    check_report_columns,
    log_paths,
    refuse_joint_separator,
    refuse_log_field_names,
)
from hybridlog.model.mode_equations import (
    Symbols,
    check_boolean_affine,
    check_guards,
    mode_guard,
    mode_linear_form,
    mode_matrix,
    numeric_matrix,
)
from hybridlog.model.mode_switching import initial_modes, jump_maps, markov_transitions
from hybridlog.model.reads import PROSE_KEYS, identifiers
from hybridlog.model.scenario import COMPONENT_KEYS, load_scenario
from hybridlog.model.schedule import parse_schedule
from hybridlog.model.toml_text import read_toml, spelled
from hybridlog.model.twins import component_twin_modes, twin_modes
from hybridlog.model.values import (
    Names,
    as_covariance,
    as_expressions,
    as_mode_id,
    as_name,
    as_names,
    as_number,
    as_positive,
    as_string,
    as_table,
    as_vector,
    check_disjoint,
    check_distinct_labels,
    check_keys,
    key_path,
    required,
)
from hybridlog.signals import LONGEST_DT_S, MAX_SUBSTEPS, SHORTEST_DT_S, FloatArray

__all__ = ["load_model", "parse_model"]


MAX_BOOLEANS = 10
"""Most booleans of a boolean-affine model (2^10 = 1024 modes)."""
_STEP_TOLERANCE = 1e-9
"""Relative tolerance of ``dt`` being an integer multiple of the integration step."""


def parse_model(
    text: str, *, origin: str = "<model>", parameters: Mapping[str, float] | None = None
) -> HybridModel:
    """Parse and validate the text of a model file; ``origin`` prefixes every error.

    A byte-order mark at the start (which Windows editors write) is no part of the TOML.
    """
    try:
        data = read_toml(text)
    except ModelError as err:
        raise ModelError(f"{origin}: {err}") from err
    if not data:
        raise ModelError(
            f"{origin}: no keys (an empty model file?); `hybridlog models NAME` prints a "
            "built-in model's file to start from"
        )
    try:
        return _Builder(data, text, parameters or {}, origin).build()
    except ModelError as err:
        raise prefixed(err, f"{origin}: ") from err
    except RecursionError as err:  # sympy on a pathological expression the grammar let by
        raise ModelError(f"{origin}: an expression is nested too deeply") from err


class _Builder:
    """Validates the parsed TOML table step by step; each step names its keys in errors."""

    def __init__(
        self, data: dict[str, Any], text: str, overrides: Mapping[str, float], origin: str
    ) -> None:
        self.data = data
        self.text = text
        self.origin = origin
        self.overrides = overrides

    def build(self) -> HybridModel:
        data = self.data
        check_keys(data, TOP_KEYS, "")
        kind = model_kind(data)
        refuse_misplaced_top_keys(data)
        # before the time base, which asks a continuous-time model for its [integration]
        # ("integration: required key is missing" said nothing of the components)
        if kind == "components" and data.get("time") == "continuous":
            raise ModelError(
                "time: a components model is discrete-time (paper 002 eq. (1)); "
                "use time = 'discrete'"
            )
        timebase = _timebase(data)
        states = as_names(required(data, "states", ""), "states")
        inputs = as_names(data.get("inputs", []), "inputs", allow_empty=True)
        outputs = as_names(required(data, "outputs", ""), "outputs")
        booleans: tuple[str, ...] = ()
        variables: tuple[str, ...] = ()
        commands: tuple[str, ...] = ()
        if kind == "booleans":
            booleans = as_names(data["booleans"], "booleans")
            if len(booleans) > MAX_BOOLEANS:
                raise ModelError(
                    f"booleans: at most {MAX_BOOLEANS} booleans (2^{MAX_BOOLEANS} modes), "
                    f"got {len(booleans)}"
                )
        if kind == "components":
            variables = as_names(data.get("variables", []), "variables", allow_empty=True)
            commands = as_names(data.get("commands", []), "commands", allow_empty=True)
        groups = {
            "states": states,
            "inputs": inputs,
            "outputs": outputs,
            "booleans": booleans,
            "variables": variables,
            "commands": commands,
        }
        check_disjoint(groups)
        refuse_log_field_names(groups)
        params = self.parameters(groups)
        _refuse_unused_overrides(data, self.overrides)
        x = tuple(sympy.Symbol(s, real=True) for s in states)
        u = tuple(sympy.Symbol(s, real=True) for s in inputs)
        symbols = Symbols(
            states=states,
            inputs=inputs,
            outputs=outputs,
            x=x,
            u=u,
            parameters=params,
            env={
                **dict(zip(states, x, strict=True)),
                **dict(zip(inputs, u, strict=True)),
                **params,
            },
            continuous=timebase.is_continuous,
        )
        noise = as_table(data.get("noise", {}), "noise")
        check_keys(noise, NOISE_KEYS, "noise")
        by_state, by_output = ("state", tuple(states)), ("output", tuple(outputs))
        default_q = as_covariance(noise.get("process", 0.0), len(states), "noise.process", by_state)
        default_r = _default_measurement_noise(noise, by_output)
        initial = as_table(required(data, "initial", ""), "initial")
        if kind == "components":
            for key in ("mode", "mode_probabilities"):
                if key in initial:
                    raise ModelError(
                        f"initial.{key}: a components model gives its initial modes per "
                        "component (components.<name>.initial)"
                    )
        check_keys(initial, INITIAL_KEYS, "initial")
        modes: tuple[Mode, ...] = ()
        components: tuple[Component, ...] = ()
        boolean_affine = None
        jumps: tuple[Jump, ...] = ()
        unchecked: str | None = None
        if kind == "components":
            components = load_components(
                as_table(data["components"], "components"),
                states=states,
                inputs=inputs,
                outputs=outputs,
                variables=variables,
                commands=commands,
                parameters=params,
                process_variances=_variances(default_q, "noise.process"),
                measurement_variances=(
                    _variances(default_r, "noise.measurement")
                    if "measurement" in noise
                    else np.diag(default_r).copy()
                ),
            )
            refuse_joint_separator(components)
            unchecked = check_joint_modes(
                components, ComponentNames(states, inputs, outputs, variables)
            )
            mu0 = np.zeros(0)
            transitions = None
        else:
            if kind == "booleans":
                boolean_affine, modes = self.boolean_modes(symbols, booleans, default_q, default_r)
            else:
                modes = self.listed_modes(symbols, default_q, default_r)
            mode_ids = tuple(m.id for m in modes)
            mu0 = initial_modes(initial, mode_ids)
            transitions = markov_transitions(data.get("transitions"), mode_ids)
            jumps = jump_maps(data.get("jumps", {}), mode_ids, symbols)
        check_report_columns(states, outputs, tuple(m.id for m in modes))
        x0 = as_vector(
            required(initial, "state", "initial"), len(states), "initial.state", by_state
        )
        p0 = as_covariance(
            initial.get("covariance", 1.0), len(states), "initial.covariance", by_state
        )
        simulation = as_table(data.get("simulation", {}), "simulation")
        check_keys(simulation, SIMULATION_KEYS, "simulation")
        sim_state = (
            as_vector(simulation["state"], len(states), "simulation.state", by_state)
            if "state" in simulation
            else None
        )
        sim_inputs = self.simulation_inputs(simulation, inputs, params)
        scenario = None
        if kind == "components":
            scenario = load_scenario(
                simulation,
                components=components,
                states=states,
                inputs=inputs,
                outputs=outputs,
                variables=variables,
                commands=commands,
                parameters=params,
            )
        else:
            for key in sorted(COMPONENT_KEYS & set(simulation)):
                raise ModelError(f"simulation.{key}: only a components model's scenario has {key}")
        if "state_min" in simulation and kind == "components":
            raise ModelError(
                "simulation.state_min: a components model's scenario does not bound its states; "
                "bound them in the equations (e.g. max(..., 0))"
            )
        if "schedule" in simulation and kind == "components":
            raise ModelError(
                "simulation.schedule: a components model has no joint mode schedule; "
                "its components switch by their transition probabilities"
            )
        if "schedule" in simulation and modes and modes[0].guard is not None:
            raise ModelError(
                "simulation.schedule: the modes switch by their guards (modes.<id>.guard); "
                "a schedule does not apply"
            )
        estimators = as_table(data.get("estimators", {}), "estimators")
        signals, truth = log_paths(data, groups, tuple(c.name for c in components))
        return HybridModel(
            name=as_name(data.get("name", "unnamed"), "name"),
            description=as_string(data.get("description", ""), "description"),
            reference=as_string(data.get("reference", ""), "reference"),
            timebase=timebase,
            states=states,
            inputs=inputs,
            outputs=outputs,
            parameters={k: float(v) for k, v in params.items()},
            modes=modes,
            initial_state=x0,
            initial_covariance=p0,
            initial_mode_probabilities=mu0,
            transitions=transitions,
            signals=signals,
            truth=truth,
            default_estimator=(
                None
                if "default_estimator" not in data
                else as_string(data["default_estimator"], "default_estimator")
            ),
            estimator_options={
                str(k): dict(as_table(v, key_path("estimators", str(k))))
                for k, v in estimators.items()
            },
            simulation_state=sim_state,
            simulation_inputs=sim_inputs,
            simulation_schedule=_schedule_text(simulation, tuple(m.id for m in modes)),
            simulation_state_min=_state_min(
                simulation, states, x0 if sim_state is None else sim_state
            ),
            source=self.text,
            origin=self.origin,
            jumps=jumps,
            boolean_affine=boolean_affine,
            components=components,
            variables=variables,
            commands=commands,
            scenario=scenario,
            twin_modes=twin_modes(modes, jumps),
            component_twin_modes=component_twin_modes(components),
            diagnoses=(
                *diagnose(modes, states, inputs, timebase, x0, jumps, linearise=False),
                *(() if unchecked is None else (f"NOTE: {unchecked}",)),
            ),
            outputs_differ=outputs_differ(modes),
        )

    def parameters(self, groups: Mapping[str, tuple[str, ...]]) -> dict[str, sympy.Expr]:
        table = as_table(self.data.get("parameters", {}), "parameters")
        taken = {name: group for group, names in groups.items() for name in names}
        values: dict[str, float] = {}
        for name, value in table.items():
            key = key_path("parameters", name)
            as_names([name], key)
            if name in taken:
                raise ModelError(f"{key}: the name is already one of the {taken[name]}")
            values[name] = as_number(value, key)
        for name, value in self.overrides.items():
            if name not in values:
                known = ", ".join(sorted(values)) or "none"
                raise ModelError(
                    f"{key_path('parameters', name)}: no such parameter (known: {known})"
                )
            values[name] = as_number(value, f"parameters.{name}")
        return {name: sympy.Float(v) for name, v in values.items()}

    def listed_modes(
        self, symbols: Symbols, default_q: FloatArray, default_r: FloatArray
    ) -> tuple[Mode, ...]:
        """The ``[modes.<id>]`` tables, in the file's order."""
        if "dynamics" in self.data:
            raise ModelError(
                "dynamics: only a boolean-affine model (booleans = [...]) writes its "
                "equations once in [dynamics]; give them per mode in [modes.<id>]"
            )
        table = as_table(required(self.data, "modes", ""), "modes")
        if not table:
            raise ModelError("modes: at least one mode is required")
        modes = tuple(
            self.mode(
                as_mode_id(str(mode_id), key_path("modes", str(mode_id))),
                as_table(spec, key_path("modes", str(mode_id))),
                symbols,
                default_q,
                default_r,
            )
            for mode_id, spec in table.items()
        )
        check_distinct_labels(((m.id, key_path("modes", str(m.id))) for m in modes), "mode id")
        check_guards(modes)
        return modes

    def mode(
        self,
        mode_id: str,
        spec: dict[str, Any],
        symbols: Symbols,
        default_q: FloatArray,
        default_r: FloatArray,
    ) -> Mode:
        key = key_path("modes", mode_id)
        check_keys(spec, MODE_KEYS, key)
        _check_dynamics_key(spec, key, symbols.continuous)
        dyn = symbols.dynamics_key
        n_x, n_u, n_y = len(symbols.states), len(symbols.inputs), len(symbols.outputs)
        linear = any(k in spec for k in ("A", "B", "C", "D"))
        if linear and (dyn in spec or "h" in spec):
            raise ModelError(f"{key}: give either {dyn} and h or A, B, C (and D), not both")
        form: LinearForm | None
        if linear:
            A = mode_matrix(spec, "A", (n_x, n_x), mode_id, symbols, required=True)
            B = mode_matrix(spec, "B", (n_x, n_u), mode_id, symbols, required=n_u > 0)
            C = mode_matrix(spec, "C", (n_y, n_x), mode_id, symbols, required=True)
            D = mode_matrix(spec, "D", (n_y, n_u), mode_id, symbols, required=False)
            x, u = sympy.Matrix(symbols.x), sympy.Matrix(symbols.u)
            dynamics = tuple(A * x + B * u) if n_u else tuple(A * x)
            h = tuple(C * x + D * u) if n_u else tuple(C * x)
            form = LinearForm(
                A=numeric_matrix(A),
                B=numeric_matrix(B),
                C=numeric_matrix(C),
                D=numeric_matrix(D),
                state_offset=np.zeros(n_x),
                output_offset=np.zeros(n_y),
            )
            nonlinear_key = ""
        else:
            dynamics = as_expressions(required(spec, dyn, key), n_x, f"{key}.{dyn}", symbols.env)
            h = as_expressions(required(spec, "h", key), n_y, f"{key}.h", symbols.env)
            form, nonlinear_key = mode_linear_form(dynamics, h, symbols, f"{key}.{dyn}", f"{key}.h")
        by_state, by_output = ("state", symbols.states), ("output", symbols.outputs)
        q, q_key = _mode_noise(spec, "process_noise", key, by_state, default_q, "noise.process")
        r, r_key = _mode_noise(
            spec, "measurement_noise", key, by_output, default_r, "noise.measurement"
        )
        guard = (
            mode_guard(
                spec["guard"], f"{key}.guard", symbols.env, {*symbols.states, *symbols.inputs}
            )
            if "guard" in spec
            else None
        )
        return Mode(
            id=mode_id,
            f=() if symbols.continuous else dynamics,
            h=h,
            process_noise=q,
            measurement_noise=r,
            dx=dynamics if symbols.continuous else (),
            guard=guard,
            linear_form=form,
            nonlinear_key=nonlinear_key,
            process_noise_key=q_key,
            measurement_noise_key=r_key,
        )

    def boolean_modes(
        self,
        symbols: Symbols,
        booleans: tuple[str, ...],
        default_q: FloatArray,
        default_r: FloatArray,
    ) -> tuple[BooleanAffine, tuple[Mode, ...]]:
        """The ``2^L`` modes of a boolean-affine model, σ = Σ_j δ_j 2^(L−j) (paper 003 (48))."""
        if "modes" in self.data:
            raise ModelError(
                "modes: a boolean-affine model's modes are the combinations of its booleans "
                "(σ = Σ δ_j 2^(L−j), paper 003 eq. (48)); write the equations once in [dynamics]"
            )
        spec = as_table(required(self.data, "dynamics", ""), "dynamics")
        check_keys(spec, DYNAMICS_KEYS, "dynamics")
        _check_dynamics_key(spec, "dynamics", symbols.continuous)
        dyn = symbols.dynamics_key
        deltas = tuple(sympy.Symbol(b, real=True) for b in booleans)
        env = {**symbols.env, **dict(zip(booleans, deltas, strict=True))}
        n_x, n_y = len(symbols.states), len(symbols.outputs)
        dynamics = as_expressions(required(spec, dyn, "dynamics"), n_x, f"dynamics.{dyn}", env)
        h = as_expressions(required(spec, "h", "dynamics"), n_y, "dynamics.h", env)
        check_boolean_affine(dynamics, f"dynamics.{dyn}", deltas)
        check_boolean_affine(h, "dynamics.h", deltas)
        used = set().union(*(e.free_symbols for e in (*dynamics, *h)))
        unused = [b for b, d in zip(booleans, deltas, strict=True) if d not in used]
        if unused:
            raise ModelError(f"booleans: '{unused[0]}' appears in no expression of [dynamics]")
        q, q_key = _mode_noise(
            spec, "process_noise", "dynamics", ("state", symbols.states), default_q, "noise.process"
        )
        r, r_key = _mode_noise(
            spec,
            "measurement_noise",
            "dynamics",
            ("output", symbols.outputs),
            default_r,
            "noise.measurement",
        )
        affine = BooleanAffine(booleans=booleans, dynamics=dynamics, h=h)
        modes = []
        for sigma in range(2 ** len(booleans)):
            values = {
                d: sympy.Integer(bit) for d, bit in zip(deltas, affine.delta(sigma), strict=True)
            }
            f_sigma = tuple(e.xreplace(values) for e in dynamics)
            h_sigma = tuple(e.xreplace(values) for e in h)
            form, nonlinear_key = mode_linear_form(
                f_sigma, h_sigma, symbols, f"dynamics.{dyn}", "dynamics.h"
            )
            modes.append(
                Mode(
                    id=str(sigma),
                    f=() if symbols.continuous else f_sigma,
                    h=h_sigma,
                    process_noise=q,
                    measurement_noise=r,
                    dx=f_sigma if symbols.continuous else (),
                    linear_form=form,
                    nonlinear_key=nonlinear_key,
                    process_noise_key=q_key,
                    measurement_noise_key=r_key,
                )
            )
        return affine, tuple(modes)

    def simulation_inputs(
        self, simulation: dict[str, Any], inputs: tuple[str, ...], params: Mapping[str, Any]
    ) -> dict[str, sympy.Expr]:
        table = as_table(simulation.get("inputs", {}), "simulation.inputs")
        env = {"t": sympy.Symbol("t", real=True), "k": sympy.Symbol("k", real=True), **params}
        result: dict[str, sympy.Expr] = {}
        for name, text in table.items():
            key = key_path("simulation.inputs", name)
            if name not in inputs:
                raise ModelError(
                    f"{key}: {excerpt(name, 40)} is not an input (inputs: {', '.join(inputs)})"
                )
            result[name] = parse_expression(expression_text(text), env, key=key)
        return result


def _timebase(data: Mapping[str, Any]) -> Timebase:
    time = data.get("time", "discrete")
    if time not in ("discrete", "continuous"):
        raise ModelError(f"time: expected 'discrete' or 'continuous', got {spelled(time)}")
    dt = as_positive(required(data, "dt", ""), "dt")
    if not SHORTEST_DT_S <= dt <= LONGEST_DT_S:
        raise ModelError(
            f"dt: the sample time must be between {SHORTEST_DT_S:g} s and {LONGEST_DT_S:g} s, "
            f"got {dt:g}"
        )
    if time == "discrete":
        if "integration" in data:
            raise ModelError(
                "integration: only a continuous-time model (time = 'continuous') has an "
                "integration step"
            )
        return Timebase(kind="discrete", dt=dt, step=dt, method=None)
    spec = as_table(required(data, "integration", ""), "integration")
    check_keys(spec, INTEGRATION_KEYS, "integration")
    step = as_positive(required(spec, "step", "integration"), "integration.step")
    method = spec.get("method", "rk4")
    if method not in INTEGRATION_METHODS:
        raise ModelError(
            f"integration.method: expected one of {', '.join(INTEGRATION_METHODS)}, got "
            f"{excerpt(repr(method), 40)[1:-1]}"
        )
    ratio = dt / step
    if step > dt * (1 + _STEP_TOLERANCE) or abs(ratio - round(ratio)) > _STEP_TOLERANCE * ratio:
        raise ModelError(
            f"integration.step: dt = {dt!r} must be an integer multiple of the integration "
            f"step {step!r} (dt/step = {ratio!r})"
        )
    if round(ratio) > MAX_SUBSTEPS:
        raise ModelError(
            f"integration.step: {step:g} s gives {round(ratio):,} integration steps per sample "
            f"of dt = {dt:g} s (at most {MAX_SUBSTEPS:,})"
        )
    checked: IntegrationMethod = "euler" if method == "euler" else "rk4"
    return Timebase(kind="continuous", dt=dt, step=step, method=checked)


def _check_dynamics_key(spec: Mapping[str, Any], key: str, continuous: bool) -> None:
    """``f`` in discrete time, ``dx`` in continuous time: the other one is refused."""
    if continuous and "f" in spec:
        raise ModelError(
            f"{key}.f: a continuous-time model (time = 'continuous') gives the time "
            "derivatives as dx, not a next state f"
        )
    if not continuous and "dx" in spec:
        raise ModelError(
            f"{key}.dx: a discrete-time model gives the next state as f; dx (time "
            "derivatives) needs time = 'continuous'"
        )


def _default_measurement_noise(noise: Mapping[str, Any], outputs: Names) -> FloatArray:
    """``[noise] measurement``, or NaN throughout when the file gives none.

    A measurement noise covariance the file does not give is not guessed: NaN records it
    as unstated, and what weighs the outputs by it refuses the model
    (:meth:`~hybridlog.model.hybrid_model.HybridModel.unstated_measurement_noise`).  A
    missing ``process`` is a statement (no process noise, 0), and stays one.
    """
    n = len(outputs[1])
    if "measurement" in noise:
        return as_covariance(noise["measurement"], n, "noise.measurement", outputs)
    return np.full((n, n), np.nan)


def _mode_noise(
    spec: Mapping[str, Any],
    name: str,
    key: str,
    names: Names,
    default: FloatArray,
    default_key: str,
) -> tuple[FloatArray, str]:
    """A mode's own covariance and its key, or the model-wide default and its key."""
    if name not in spec:
        return default, default_key
    return as_covariance(spec[name], len(names[1]), f"{key}.{name}", names), f"{key}.{name}"


def _variances(matrix: FloatArray, key: str) -> FloatArray:
    """The diagonal of a covariance that must be diagonal (the components model's noise)."""
    if np.count_nonzero(matrix - np.diag(np.diag(matrix))):
        raise ModelError(
            f"{key}: a components model takes variances (a number or a list), not a "
            "matrix with correlations"
        )
    variances: FloatArray = np.diag(matrix).copy()
    return variances


def _refuse_unused_overrides(data: Mapping[str, Any], overrides: Mapping[str, float]) -> None:
    """Refuse ``--set`` of a parameter no string of the model names: it would change nothing.

    Parameters are used only in expressions, which are strings; a parameter named in no
    string outside the prose keys (read as the parser reads names, in NFKC form) is used
    nowhere, and a run with it changed would be the run without, silently.  (A name in other
    text, a scenario's description, counts as used.)
    """
    if not overrides:
        return
    named: set[str] = set()
    for value in _strings({k: v for k, v in data.items() if k not in PROSE_KEYS}):
        named.update(identifiers(value))
    for name in overrides:
        if name not in named:
            raise UnusedParameterError(
                f"{key_path('parameters', name)}: used by no expression of the model, so "
                f"--set {name}=... would change nothing",
                named=(name,),
            )


def _strings(value: Any) -> Iterator[str]:
    """Every string in a parsed TOML value, keys excepted."""
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for item in value.values():
            yield from _strings(item)
    elif isinstance(value, list):
        for item in value:
            yield from _strings(item)


def _schedule_text(simulation: Mapping[str, Any], mode_ids: tuple[str, ...]) -> str:
    """``[simulation] schedule`` as written, checked against the modes; ``""`` where absent.

    An empty or blank value was taken as no schedule at all (the first mode for 100 steps),
    where ``--schedule ""`` is refused: given, it must say something.  A schedule naming a
    mode the file does not list (a mode renamed or removed in a copy of a built-in) was
    refused only by ``simulate``; ``analyze`` ran on the inconsistent file.
    """
    if "schedule" not in simulation:
        return ""
    text = as_string(simulation["schedule"], "simulation.schedule")
    if not text.strip():
        raise ModelError(
            'simulation.schedule: empty; write MODE:STEPS,... (e.g. "1:100,2:100") or '
            "leave the key out"
        )
    if mode_ids:
        parse_schedule(text, mode_ids, where="simulation.schedule")
    return text


def _state_min(
    simulation: Mapping[str, Any], states: tuple[str, ...], start: FloatArray
) -> FloatArray | None:
    """``[simulation] state_min``, which the run's first state must respect; ``None`` where absent.

    ``start``: where ``simulate`` starts (``simulation.state``, else ``initial.state``).  A
    start below the bound (``state = [-15, ...]``, ``state_min = [0, ...]``) wrote a log whose
    row 0 held the level the model calls impossible, and a jump to the bound at row 1.
    """
    if "state_min" not in simulation:
        return None
    bound = as_vector(
        simulation["state_min"], len(states), "simulation.state_min", ("state", tuple(states))
    )
    below = [j for j in range(len(states)) if start[j] < bound[j]]
    if below:
        j = below[0]
        where = (
            "simulation.state"
            if "state" in simulation
            else "initial.state; the file gives no simulation.state"
        )
        raise ModelError(
            f"simulation.state_min[{j}]: the run starts with {states[j]} = {start[j]:g} "
            f"({where}), below its bound {bound[j]:g}; raise the start or lower the bound"
        )
    return bound
