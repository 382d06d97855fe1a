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

import ast
import json
import math
import re
import unicodedata
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy
from sympy.core.function import Application

from hybridlog.errors import ModelError, excerpt
from hybridlog.model.cache import load_model
from hybridlog.model.component_loader import load_components
from hybridlog.model.component_structure import ComponentNames, check_joint_modes
from hybridlog.model.components import JOINT_SEPARATOR, Component
from hybridlog.model.derivatives import boolean_affine_problem
from hybridlog.model.diagnosis import diagnose
from hybridlog.model.expressions import expression_text, parse_expression
from hybridlog.model.hybrid_model import (
    INTEGRATION_METHODS,
    BooleanAffine,
    HybridModel,
    IntegrationMethod,
    Jump,
    LinearForm,
    Mode,
    Timebase,
    markov_matrix,
    outputs_differ,
)
from hybridlog.model.scenario import COMPONENT_KEYS, load_scenario
from hybridlog.model.schedule import parse_schedule
from hybridlog.model.toml_text import read_toml, spelled
from hybridlog.model.twins import component_twin_modes, twin_modes
from hybridlog.model.values import (
    Names,
    as_covariance,
    as_expressions,
    as_mode_id,
    as_names,
    as_number,
    as_positive,
    as_probability,
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

_TOP_KEYS = {
    "name",
    "description",
    "reference",
    "time",
    "dt",
    "integration",
    "states",
    "inputs",
    "outputs",
    "parameters",
    "modes",
    "booleans",
    "dynamics",
    "components",
    "variables",
    "commands",
    "noise",
    "initial",
    "transitions",
    "jumps",
    "signals",
    "truth",
    "default_estimator",
    "estimators",
    "simulation",
}
_MODE_KEYS = {"f", "dx", "h", "A", "B", "C", "D", "process_noise", "measurement_noise", "guard"}
_DYNAMICS_KEYS = {"f", "dx", "h", "process_noise", "measurement_noise"}
_INTEGRATION_KEYS = {"method", "step"}
_NOISE_KEYS = {"process", "measurement"}
_INITIAL_KEYS = {"state", "covariance", "mode", "mode_probabilities"}
_TRANSITION_KEYS = {"matrix", "stay"}
_SIMULATION_KEYS = {"state", "state_min", "inputs", "schedule", *COMPONENT_KEYS}
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
        raise ModelError(f"{origin}: {err}", named=err.named) from err
    except RecursionError as err:  # sympy on a pathological expression the grammar let by
        raise ModelError(f"{origin}: an expression is nested too deeply") from err


@dataclass(frozen=True)
class _Symbols:
    """What the mode equations of one model may refer to."""

    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    x: tuple[sympy.Symbol, ...]
    u: tuple[sympy.Symbol, ...]
    parameters: dict[str, sympy.Expr]
    env: dict[str, sympy.Expr]
    continuous: bool

    @property
    def dynamics_key(self) -> str:
        """``dx`` in continuous time, ``f`` in discrete time."""
        return "dx" if self.continuous else "f"


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
        check_keys(data, _TOP_KEYS, "")
        kind = _kind(data)
        _refuse_misplaced_top_keys(data)
        timebase = _timebase(data)
        if kind == "components" and timebase.is_continuous:
            raise ModelError(
                "time: a components model is discrete-time (paper 002 eq. (1)); "
                "use time = 'discrete'"
            )
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
        _refuse_log_field_names(groups)
        params = self.parameters(groups)
        _refuse_unused_overrides(data, self.overrides)
        x = tuple(sympy.Symbol(s, real=True) for s in states)
        u = tuple(sympy.Symbol(s, real=True) for s in inputs)
        symbols = _Symbols(
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
        check_keys(noise, _NOISE_KEYS, "noise")
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
        check_keys(initial, _INITIAL_KEYS, "initial")
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
            _refuse_joint_separator(components)
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
            mu0 = _initial_modes(initial, mode_ids)
            transitions = _transitions(data.get("transitions"), mode_ids)
            jumps = _jumps(data.get("jumps", {}), mode_ids, symbols)
        _check_report_columns(states, outputs, tuple(m.id for m in modes))
        x0 = as_vector(
            required(initial, "state", "initial"), len(states), "initial.state", by_state
        )
        p0 = as_covariance(
            initial.get("covariance", 1.0), len(states), "initial.covariance", by_state
        )
        simulation = as_table(data.get("simulation", {}), "simulation")
        check_keys(simulation, _SIMULATION_KEYS, "simulation")
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
        signals, truth = _paths(data, groups, tuple(c.name for c in components))
        return HybridModel(
            name=as_string(data.get("name", "unnamed"), "name"),
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
        self, symbols: _Symbols, default_q: FloatArray, default_r: FloatArray
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
        _check_guards(modes)
        return modes

    def mode(
        self,
        mode_id: str,
        spec: dict[str, Any],
        symbols: _Symbols,
        default_q: FloatArray,
        default_r: FloatArray,
    ) -> Mode:
        key = key_path("modes", mode_id)
        check_keys(spec, _MODE_KEYS, key)
        _check_dynamics_key(spec, key, symbols.continuous)
        dyn = symbols.dynamics_key
        n_x, n_u, n_y = len(symbols.states), len(symbols.inputs), len(symbols.outputs)
        linear = any(k in spec for k in ("A", "B", "C", "D"))
        if linear and (dyn in spec or "h" in spec):
            raise ModelError(f"{key}: give either {dyn} and h or A, B, C (and D), not both")
        form: LinearForm | None
        if linear:
            A = _matrix(spec, "A", (n_x, n_x), mode_id, symbols, required=True)
            B = _matrix(spec, "B", (n_x, n_u), mode_id, symbols, required=n_u > 0)
            C = _matrix(spec, "C", (n_y, n_x), mode_id, symbols, required=True)
            D = _matrix(spec, "D", (n_y, n_u), mode_id, symbols, required=False)
            x, u = sympy.Matrix(symbols.x), sympy.Matrix(symbols.u)
            dynamics = tuple(A * x + B * u) if n_u else tuple(A * x)
            h = tuple(C * x + D * u) if n_u else tuple(C * x)
            form = LinearForm(
                A=_numeric(A),
                B=_numeric(B),
                C=_numeric(C),
                D=_numeric(D),
                state_offset=np.zeros(n_x),
                output_offset=np.zeros(n_y),
            )
            nonlinear_key = ""
        else:
            dynamics = as_expressions(required(spec, dyn, key), n_x, f"{key}.{dyn}", symbols.env)
            h = as_expressions(required(spec, "h", key), n_y, f"{key}.h", symbols.env)
            form, nonlinear_key = _linear_form(dynamics, h, symbols, f"{key}.{dyn}", f"{key}.h")
        by_state, by_output = ("state", symbols.states), ("output", symbols.outputs)
        q, q_key = _mode_noise(spec, "process_noise", key, by_state, default_q, "noise.process")
        r, r_key = _mode_noise(
            spec, "measurement_noise", key, by_output, default_r, "noise.measurement"
        )
        guard = (
            _guard(spec["guard"], f"{key}.guard", symbols.env, {*symbols.states, *symbols.inputs})
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
        symbols: _Symbols,
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
        check_keys(spec, _DYNAMICS_KEYS, "dynamics")
        _check_dynamics_key(spec, "dynamics", symbols.continuous)
        dyn = symbols.dynamics_key
        deltas = tuple(sympy.Symbol(b, real=True) for b in booleans)
        env = {**symbols.env, **dict(zip(booleans, deltas, strict=True))}
        n_x, n_y = len(symbols.states), len(symbols.outputs)
        dynamics = as_expressions(required(spec, dyn, "dynamics"), n_x, f"dynamics.{dyn}", env)
        h = as_expressions(required(spec, "h", "dynamics"), n_y, "dynamics.h", env)
        _check_boolean_affine(dynamics, f"dynamics.{dyn}", deltas)
        _check_boolean_affine(h, "dynamics.h", deltas)
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
            form, nonlinear_key = _linear_form(
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


def _kind(data: Mapping[str, Any]) -> str:
    """``"modes"``, ``"booleans"`` or ``"components"``; refuses keys of the other kinds."""
    if "components" in data:
        for key in ("modes", "booleans", "dynamics", "transitions", "jumps"):
            if key in data:
                raise ModelError(
                    f"{key}: not part of a components model (its modes, equations and "
                    "transition probabilities are in components.<name>)"
                )
        return "components"
    for key in ("variables", "commands"):
        if key in data:
            raise ModelError(f"{key}: only a components model ([components.<name>]) has {key}")
    return "booleans" if "booleans" in data else "modes"


def _refuse_misplaced_top_keys(data: Mapping[str, Any]) -> None:
    """Refuse a top-level key written below a table header, before it is missed at the top.

    In TOML every key after ``[initial]`` belongs to ``[initial]``: ``dt = 0.01`` appended
    at the end of a file, or ``time = "continuous"`` below ``[noise]``, was reported as
    ``dt: required key is missing`` (or, for ``time``, as a discrete-time model's ``dx``),
    although the file held it.  Checked in the tables whose keys are fixed (a parameter or
    a state may be called ``dt``) and in each ``[estimators.<name>]`` table, none of whose
    options is named like a top-level key (``default_estimator`` appended below the last
    table of a file that ends with one was "imm has no option 'default_estimator'");
    ``[signals]`` and ``[truth]``, whose keys are symbols, in :func:`_refuse_misplaced`.  A
    sub-table (``[modes.a.noise]``) is no such slip: it is left to the table's own check of
    its keys.
    """
    tables: list[tuple[str, Any, set[str]]] = [
        (name, data.get(name), allowed)
        for name, allowed in (
            ("noise", _NOISE_KEYS),
            ("initial", _INITIAL_KEYS),
            ("transitions", _TRANSITION_KEYS),
            ("dynamics", _DYNAMICS_KEYS),
            ("simulation", _SIMULATION_KEYS),
        )
    ]
    modes = data.get("modes")
    if isinstance(modes, dict):
        tables += [(key_path("modes", i), spec, _MODE_KEYS) for i, spec in modes.items()]
    estimators = data.get("estimators")
    if isinstance(estimators, dict):  # no option is named like a top-level key
        tables += [(key_path("estimators", n), spec, set()) for n, spec in estimators.items()]
    for where, table, allowed in tables:
        if not isinstance(table, dict):
            continue
        for key in table:
            if key in _TOP_KEYS and key not in allowed and not isinstance(table[key], dict):
                raise ModelError(_misplaced_top_key(where, key))


def _misplaced_top_key(where: str, key: str) -> str:
    """The error of the top-level ``key`` written below the header of the table ``where``."""
    return (
        f"{key_path(where, key)}: {key!r} is a top-level key, but written below "
        f"the [{where}] header it belongs to that table; move it above the "
        "first [table] header"
    )


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
    check_keys(spec, _INTEGRATION_KEYS, "integration")
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


def _affine_coefficients(expr: sympy.Expr, variables: list[sympy.Symbol]) -> list[float] | None:
    """``[∂e/∂v for v in variables] + [e(0)]`` when ``expr`` is affine, else ``None``.

    A function or a non-polynomial power of a variable rules affinity out at once (cheap,
    and it spares the derivatives of nonlinear expressions); what is left is a polynomial,
    affine when every first derivative is a constant (expanded if need be, so that
    ``(x + 1)**2 - x**2`` counts as affine).
    """
    if expr.free_symbols:
        for atom in expr.atoms(Application):
            if atom.free_symbols:
                return None
        for power in expr.atoms(sympy.Pow):
            if power.free_symbols and not (power.exp.is_Integer and power.exp > 0):
                return None
    row = []
    try:
        for variable in variables:
            slope = expr.diff(variable)
            if slope.free_symbols:
                slope = sympy.expand(slope)
                if slope.free_symbols:
                    return None
            row.append(float(slope))
        row.append(float(expr.xreplace(dict.fromkeys(variables, sympy.Integer(0)))))
    except TypeError:
        return None
    return row


def _linear_form(
    dynamics: tuple[sympy.Expr, ...],
    h: tuple[sympy.Expr, ...],
    symbols: _Symbols,
    dynamics_key: str,
    h_key: str,
) -> tuple[LinearForm | None, str]:
    """The mode's matrices when every expression is affine; else ``None`` and the first key."""
    variables = [*symbols.x, *symbols.u]
    rows: list[list[float]] = []
    for key, expressions in ((dynamics_key, dynamics), (h_key, h)):
        for i, expr in enumerate(expressions):
            row = _affine_coefficients(expr, variables)
            if row is None:
                return None, f"{key}[{i}]"
            rows.append(row)
    n_x, n_u = len(symbols.x), len(symbols.u)
    table = np.array(rows, dtype=float).reshape(len(rows), n_x + n_u + 1)
    top, bottom = table[:n_x], table[n_x:]
    return (
        LinearForm(
            A=np.ascontiguousarray(top[:, :n_x]),
            B=np.ascontiguousarray(top[:, n_x : n_x + n_u]),
            C=np.ascontiguousarray(bottom[:, :n_x]),
            D=np.ascontiguousarray(bottom[:, n_x : n_x + n_u]),
            state_offset=np.ascontiguousarray(top[:, -1]),
            output_offset=np.ascontiguousarray(bottom[:, -1]),
        ),
        "",
    )


def _check_boolean_affine(
    expressions: tuple[sympy.Expr, ...], key: str, deltas: tuple[sympy.Symbol, ...]
) -> None:
    """Each expression affine in the booleans, ``G + D·δ`` (paper 003 eq. (1))."""
    for i, expr in enumerate(expressions):
        problem = boolean_affine_problem(expr, deltas)
        if problem:
            raise ModelError(
                f"{key}[{i}]: not affine in the booleans ({problem}); write it as "
                "G(x, u) + D(x, u)·δ (a valve: c*sqrt(h)*U, not Piecewise(c*sqrt(h), U > 0.5, 0))"
            )


def _guard(value: Any, key: str, env: Mapping[str, sympy.Expr], variables: set[str]) -> sympy.Basic:
    """A mode's guard: one comparison of states and inputs, e.g. ``"x3 <= 0"``."""
    text = as_string(value, key).strip()
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as err:
        raise ModelError(f"{key}: cannot parse {excerpt(text)}: {err.msg}") from err
    except (RecursionError, MemoryError, ValueError) as err:
        raise ModelError(f"{key}: cannot parse {excerpt(text)}") from err
    if not isinstance(tree.body, ast.Compare):
        raise ModelError(f"{key}: expected a comparison such as 'x3 <= 0', got {excerpt(text)}")
    # The expression grammar returns values; a Piecewise carries the condition through it.
    wrapped = parse_expression(f"Piecewise(1, {text}, 0)", env, key=key)
    if not isinstance(wrapped, sympy.Piecewise):  # sympy decided the comparison: 1 or 0
        always = "always holds" if wrapped == 1 else "never holds"
        raise ModelError(
            f"{key}: {excerpt(text)} {always}, whatever the states and inputs; a guard must "
            "depend on them"
        )
    condition: sympy.Basic = wrapped.args[0].cond
    if not {str(s) for s in condition.free_symbols} & variables:
        raise ModelError(f"{key}: {excerpt(text)} does not depend on the states or inputs")
    return condition


def _check_guards(modes: tuple[Mode, ...]) -> None:
    """Either every mode has a guard (state-driven switching) or none has."""
    guarded = [m.id for m in modes if m.guard is not None]
    if guarded and len(guarded) != len(modes):
        missing = next(m.id for m in modes if m.guard is None)
        raise ModelError(
            f"{key_path('modes', missing)}.guard: missing; when one mode has a guard every mode "
            "needs one"
        )


def _numeric(matrix: sympy.Matrix) -> FloatArray:
    rows, cols = matrix.shape
    return np.array([[float(matrix[i, j]) for j in range(cols)] for i in range(rows)]).reshape(
        rows, cols
    )


def _matrix(
    spec: Mapping[str, Any],
    name: str,
    shape: tuple[int, int],
    mode_id: str,
    symbols: _Symbols,
    *,
    required: bool,
) -> sympy.Matrix:
    key = f"{key_path('modes', mode_id)}.{name}"
    rows, cols = shape
    if name not in spec:
        if required:
            raise ModelError(f"{key}: matrix {name} of mode '{mode_id}' is missing")
        return sympy.zeros(rows, cols)
    value = spec[name]
    if rows == 1 and isinstance(value, list) and value and not isinstance(value[0], list):
        value = [value]
    if cols == 1 and isinstance(value, list) and value and not isinstance(value[0], list):
        value = [[v] for v in value]
    if not isinstance(value, list) or not all(isinstance(r, list) for r in value):
        raise ModelError(f"{key}: expected a matrix (a list of rows)")
    if len(value) != rows:
        raise ModelError(
            f"{key}: matrix {name} of mode '{mode_id}' has the wrong number of rows; "
            f"expected {rows} instead of {len(value)}"
        )
    for row in value:
        if len(row) != cols:
            raise ModelError(
                f"{key}: matrix {name} of mode '{mode_id}' has the wrong number of columns; "
                f"expected {cols} instead of {len(row)}"
            )
    entries = [
        [_entry(v, f"{key}[{i}][{j}]", symbols) for j, v in enumerate(r)]
        for i, r in enumerate(value)
    ]
    return sympy.Matrix(entries)


def _entry(value: Any, key: str, symbols: _Symbols) -> sympy.Expr:
    """One matrix entry: a number or an expression of parameters (never states or inputs)."""
    if not isinstance(value, str):
        return sympy.Float(as_number(value, key))
    entry = parse_expression(value, symbols.env, key=key)
    if entry.free_symbols:
        names = ", ".join(sorted(str(s) for s in entry.free_symbols))
        raise ModelError(
            f"{key}: a matrix entry may use numbers and parameters only, not {names} "
            "(write a nonlinear mode with f/dx and h)"
        )
    return entry


def _jumps(value: Any, mode_ids: tuple[str, ...], symbols: _Symbols) -> tuple[Jump, ...]:
    """``[jumps."a->b"]``: reset expressions per state (paper 004 eq. (3))."""
    table = as_table(value, "jumps")
    env = {**dict(zip(symbols.states, symbols.x, strict=True)), **symbols.parameters}
    seen: dict[tuple[str, str], str] = {}
    jumps = []
    for raw, spec in table.items():
        shown = json.dumps(raw) if len(raw) <= 130 and raw.isprintable() else excerpt(raw, 40)
        key = f"jumps.{shown}"
        source, arrow, target = (part.strip() for part in raw.partition("->"))
        if not arrow or not source or not target:
            raise ModelError(
                f"{key}: expected 'a->b' (a jump from mode a to mode b, or '*->b' from any mode)"
            )
        for end, wildcard_allowed in ((source, True), (target, False)):
            if end not in mode_ids and not (wildcard_allowed and end == "*"):
                raise ModelError(
                    f"{key}: unknown mode {excerpt(end, 40)} (modes: {', '.join(mode_ids)})"
                )
        if source == target:
            raise ModelError(f"{key}: a mode does not jump to itself")
        if (source, target) in seen:
            raise ModelError(f"{key}: the same switch as {seen[source, target]}")
        seen[source, target] = key
        resets = as_table(spec, key)
        if not resets:
            raise ModelError(f"{key}: no state is reset; list the states the switch resets")
        reset = list(symbols.x)
        for name, text in resets.items():
            if name not in symbols.states:
                raise ModelError(
                    f"{key_path(key, name)}: not a state (states: {', '.join(symbols.states)})"
                )
            reset[symbols.states.index(name)] = parse_expression(
                expression_text(text), env, key=key_path(key, name)
            )
        jumps.append(
            Jump(
                source=None if source == "*" else source,
                target=target,
                reset=tuple(reset),
                key=key,
            )
        )
    return tuple(jumps)


def _initial_modes(initial: Mapping[str, Any], mode_ids: tuple[str, ...]) -> FloatArray:
    n = len(mode_ids)
    if "mode" in initial and "mode_probabilities" in initial:
        raise ModelError("initial: give either mode or mode_probabilities, not both")
    if "mode" in initial:
        written = initial["mode"]
        if isinstance(written, bool) or not isinstance(written, str | int | float):
            raise ModelError(
                f"initial.mode: expected a mode id (a string such as {mode_ids[0]!r}), got "
                f"{spelled(written)}"
            )
        mode = str(written)
        if mode not in mode_ids:
            raise ModelError(
                f"initial.mode: unknown mode {excerpt(mode, 40)} (modes: {', '.join(mode_ids)})"
            )
        probabilities = np.zeros(n)
        probabilities[mode_ids.index(mode)] = 1.0
        return probabilities
    if "mode_probabilities" not in initial:
        return np.full(n, 1.0 / n)
    value = initial["mode_probabilities"]
    key = "initial.mode_probabilities"
    if isinstance(value, dict):
        unknown = set(value) - set(mode_ids)
        if unknown:
            raise ModelError(f"{key_path(key, sorted(unknown)[0])}: unknown mode")
        probabilities = np.array([as_number(value.get(m, 0.0), f"{key}.{m}") for m in mode_ids])
    else:
        probabilities = as_vector(value, n, key)
    if probabilities.min() < 0:
        worst = int(np.argmin(probabilities))
        raise ModelError(
            f"{key}: probabilities must be non-negative; mode {mode_ids[worst]!r} has "
            f"{probabilities[worst]:g}"
        )
    if not math.isclose(probabilities.sum(), 1.0, abs_tol=_SUM_TOLERANCE):
        raise ModelError(
            f"{key}: probabilities must sum to 1; they sum to {probabilities.sum():.10g}"
            + ("" if isinstance(value, dict) else f" (modes in order: {', '.join(mode_ids)})")
        )
    normalised: FloatArray = probabilities / probabilities.sum()
    return normalised


def _transitions(value: Any, mode_ids: tuple[str, ...]) -> FloatArray | None:
    if value is None:
        return None
    table = as_table(value, "transitions")
    check_keys(table, _TRANSITION_KEYS, "transitions")
    n = len(mode_ids)
    if "matrix" in table and "stay" in table:
        raise ModelError("transitions: give either matrix or stay, not both")
    if "stay" in table:
        return markov_matrix(as_probability(table["stay"], "transitions.stay"), n)
    return _markov_rows(required(table, "matrix", "transitions"), mode_ids)


_SUM_TOLERANCE = 1e-9
"""How far from 1 a row of probabilities may sum (rounding of the written decimals)."""


def _markov_rows(value: Any, mode_ids: tuple[str, ...]) -> FloatArray:
    """``transitions.matrix``: one row per mode, non-negative, each summing to 1.

    Written as a list of rows in the order of the modes, or (as ``initial.mode_probabilities``
    may be) keyed by mode id: ``{1 = {1 = 0.9, 2 = 0.1}, 2 = [0.2, 0.8]}``, each mode's row
    given (a row keyed by mode id leaves the modes it does not name at 0).  The keyed form
    was refused as "expected a 2x2 matrix" while the initial probabilities took it.
    """
    key = "transitions.matrix"
    n = len(mode_ids)
    shape = (
        f"{key}: expected a {n}x{n} matrix (one row per mode) or a table of rows keyed by "
        f"mode id (modes: {', '.join(mode_ids)})"
    )
    if isinstance(value, dict):
        _check_mode_keys(value, mode_ids, key)
        missing = [m for m in mode_ids if m not in value]
        if missing:
            raise ModelError(
                f"{key_path(key, missing[0])}: the row of mode {missing[0]!r} is missing "
                "(one row per mode)"
            )
        rows = [(key_path(key, m), value[m]) for m in mode_ids]
    elif isinstance(value, list) and len(value) == n:
        rows = [(f"{key}[{i}]", row) for i, row in enumerate(value)]
    else:
        raise ModelError(shape)
    entries: list[list[float]] = []
    entry_keys: list[list[str]] = []
    for where, row in rows:
        if isinstance(row, dict):
            _check_mode_keys(row, mode_ids, where)
            entry_keys.append([key_path(where, m) for m in mode_ids])
            written = [row.get(m, 0.0) for m in mode_ids]
        elif isinstance(row, list) and len(row) == n:
            entry_keys.append([f"{where}[{j}]" for j in range(n)])
            written = row
        else:
            raise ModelError(
                f"{where}: expected a row of {n} probabilities (modes: "
                f"{', '.join(mode_ids)}), as a list or a table keyed by mode id"
            )
        entries.append([as_number(v, k) for v, k in zip(written, entry_keys[-1], strict=True)])
    matrix = np.array(entries)
    if matrix.min() < 0:
        # The row of the negative entry: a row [1.1, -0.1] sums to 1, so the row whose sum
        # is furthest from 1 was named instead (row 0 of [[0.9, 0.1], [1.1, -0.1]]).
        row, col = (int(i) for i in np.unravel_index(np.argmin(matrix), matrix.shape))
        raise ModelError(
            f"{entry_keys[row][col]}: a probability must be non-negative, got "
            f"{matrix[row, col]:g} (from mode {mode_ids[row]!r} to {mode_ids[col]!r})"
        )
    sums = matrix.sum(axis=1)
    bad = int(np.argmax(np.abs(sums - 1.0)))
    if not math.isclose(sums[bad], 1.0, rel_tol=0.0, abs_tol=_SUM_TOLERANCE):
        # As initial.mode_probabilities: allclose's default relative tolerance let rows
        # summing to 0.99999 through, a Markov chain that loses probability every step.
        raise ModelError(
            f"{rows[bad][0]}: each row must sum to 1; the row of mode {mode_ids[bad]!r} sums to "
            f"{sums[bad]:.10g}"
        )
    return matrix


def _check_mode_keys(table: Mapping[str, Any], mode_ids: tuple[str, ...], key: str) -> None:
    """Refuse a key of ``table`` that is not a mode id, naming it and the modes."""
    for name in table:
        if name not in mode_ids:
            raise ModelError(f"{key_path(key, name)}: unknown mode (modes: {', '.join(mode_ids)})")


_FREE_TEXT_KEYS = {"name", "description", "reference"}
"""Top-level keys whose strings are prose, not expressions."""
_IDENTIFIER = re.compile(r"[^\W\d]\w*")


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
    for value in _strings({k: v for k, v in data.items() if k not in _FREE_TEXT_KEYS}):
        named.update(_IDENTIFIER.findall(unicodedata.normalize("NFKC", value)))
    for name in overrides:
        if name not in named:
            raise ModelError(
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


"""What joins the components' mode ids into a joint mode's id (``m11|m21``,
:func:`hybridlog.model.components.joint_label`)."""


def _refuse_joint_separator(components: tuple[Component, ...]) -> None:
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


def _refuse_log_field_names(groups: Mapping[str, tuple[str, ...]]) -> None:
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


def _check_report_columns(
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


def _paths(
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
    elif name in _TOP_KEYS:  # default_estimator appended below the file's last table
        raise ModelError(_misplaced_top_key(table, name))
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
