"""Model files (TOML, SPEC §6) → :class:`~hybridlog.model.hybrid_model.HybridModel`.

Every value is validated and every error names the key at fault, e.g.
``model.toml: modes.2.C: matrix C of mode '2' has the wrong number of columns; expected 3
instead of 4``.
"""

from __future__ import annotations

import ast
import math
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import sympy

from hybridlog.errors import ModelError
from hybridlog.model.builtins import builtin_names, builtin_text
from hybridlog.model.expressions import parse_expression
from hybridlog.model.hybrid_model import HybridModel, Mode, markov_matrix
from hybridlog.signals import FloatArray

_TOP_KEYS = {
    "name",
    "description",
    "reference",
    "time",
    "dt",
    "states",
    "inputs",
    "outputs",
    "parameters",
    "modes",
    "noise",
    "initial",
    "transitions",
    "signals",
    "truth",
    "default_estimator",
    "estimators",
    "simulation",
}
_UNSUPPORTED = {
    "booleans": "boolean-affine models",
    "components": "concurrent probabilistic hybrid automata",
    "jumps": "state-reset maps",
    "integration_step": "continuous-time models",
}
_MODE_KEYS = {"f", "h", "A", "B", "C", "D", "process_noise", "measurement_noise", "guard"}
_NOISE_KEYS = {"process", "measurement"}
_INITIAL_KEYS = {"state", "covariance", "mode", "mode_probabilities"}
_TRANSITION_KEYS = {"matrix", "stay"}
_SIMULATION_KEYS = {"state", "state_min", "inputs", "schedule"}


def load_model(
    name_or_path: str | Path, *, parameters: Mapping[str, float] | None = None
) -> HybridModel:
    """Load a built-in model by name or a model file by path.

    Parameters
    ----------
    name_or_path:
        A built-in name (``hybridlog models`` lists them) or the path of a TOML file.
    parameters:
        Overrides of ``[parameters]`` values (``--set NAME=VALUE``); unknown names are errors.
    """
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.exists():
        if not path.is_file():
            raise ModelError(f"{path}: no such model file")
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as err:
            raise ModelError(f"{path}: cannot read model file: {err}") from err
        return parse_model(text, origin=str(path), parameters=parameters)
    name = str(name_or_path)
    if name in builtin_names():
        return parse_model(builtin_text(name), origin=name, parameters=parameters)
    known = ", ".join(builtin_names())
    raise ModelError(f"{name}: neither a model file nor a built-in model (built-ins: {known})")


def parse_model(
    text: str, *, origin: str = "<model>", parameters: Mapping[str, float] | None = None
) -> HybridModel:
    """Parse and validate the text of a model file; ``origin`` prefixes every error."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ModelError(f"{origin}: invalid TOML: {err}") from err
    try:
        return _Builder(data, text, parameters or {}, origin).build()
    except ModelError as err:
        raise ModelError(f"{origin}: {err}") from err


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
        _check_keys(data, _TOP_KEYS, "", unsupported=_UNSUPPORTED)
        time = data.get("time", "discrete")
        if time != "discrete":
            raise ModelError(
                f"time: {time!r} models are not supported by this version (use 'discrete')"
            )
        dt = _positive_number(_required(data, "dt", ""), "dt")
        states = _names(_required(data, "states", ""), "states")
        inputs = _names(data.get("inputs", []), "inputs", allow_empty=True)
        outputs = _names(_required(data, "outputs", ""), "outputs")
        _check_disjoint({"states": states, "inputs": inputs, "outputs": outputs})
        params = self.parameters(set(states) | set(inputs))
        x_syms = {s: sympy.Symbol(s, real=True) for s in states}
        u_syms = {u: sympy.Symbol(u, real=True) for u in inputs}
        env: dict[str, sympy.Expr] = {**x_syms, **u_syms, **params}
        noise = _table(data.get("noise", {}), "noise")
        _check_keys(noise, _NOISE_KEYS, "noise")
        default_q = _covariance(noise.get("process", 0.0), len(states), "noise.process")
        default_r = _covariance(noise.get("measurement", 1.0), len(outputs), "noise.measurement")
        modes_table = _table(_required(data, "modes", ""), "modes")
        if not modes_table:
            raise ModelError("modes: at least one mode is required")
        modes = tuple(
            self.mode(
                str(mode_id),
                _table(spec, f"modes.{mode_id}"),
                env,
                states,
                inputs,
                outputs,
                default_q,
                default_r,
            )
            for mode_id, spec in modes_table.items()
        )
        mode_ids = tuple(m.id for m in modes)
        _check_guards(modes)
        initial = _table(_required(data, "initial", ""), "initial")
        _check_keys(initial, _INITIAL_KEYS, "initial")
        x0 = _vector(_required(initial, "state", "initial"), len(states), "initial.state")
        p0 = _covariance(initial.get("covariance", 1.0), len(states), "initial.covariance")
        mu0 = _initial_modes(initial, mode_ids)
        simulation = _table(data.get("simulation", {}), "simulation")
        _check_keys(simulation, _SIMULATION_KEYS, "simulation")
        sim_state = (
            _vector(simulation["state"], len(states), "simulation.state")
            if "state" in simulation
            else None
        )
        sim_inputs = self.simulation_inputs(simulation, inputs, params)
        if "schedule" in simulation and modes[0].guard is not None:
            raise ModelError(
                "simulation.schedule: the modes switch by their guards (modes.<id>.guard); "
                "a schedule does not apply"
            )
        estimators = _table(data.get("estimators", {}), "estimators")
        return HybridModel(
            name=_string(data.get("name", "unnamed"), "name"),
            description=_string(data.get("description", ""), "description"),
            reference=_string(data.get("reference", ""), "reference"),
            dt=dt,
            states=states,
            inputs=inputs,
            outputs=outputs,
            parameters={k: float(v) for k, v in params.items()},
            modes=modes,
            initial_state=x0,
            initial_covariance=p0,
            initial_mode_probabilities=mu0,
            transitions=_transitions(data.get("transitions"), mode_ids),
            signals=_string_map(
                data.get("signals", {}), "signals", set(states) | set(inputs) | set(outputs)
            ),
            truth=_string_map(data.get("truth", {}), "truth", {"mode", *states}),
            default_estimator=_string(data.get("default_estimator", "imm"), "default_estimator"),
            estimator_options={
                str(k): dict(_table(v, f"estimators.{k}")) for k, v in estimators.items()
            },
            simulation_state=sim_state,
            simulation_inputs=sim_inputs,
            simulation_schedule=_string(simulation.get("schedule", ""), "simulation.schedule"),
            simulation_state_min=(
                _vector(simulation["state_min"], len(states), "simulation.state_min")
                if "state_min" in simulation
                else None
            ),
            source=self.text,
            origin=self.origin,
        )

    def parameters(self, taken: set[str]) -> dict[str, sympy.Float]:
        table = _table(self.data.get("parameters", {}), "parameters")
        values: dict[str, float] = {}
        for name, value in table.items():
            key = f"parameters.{name}"
            if name in taken:
                raise ModelError(f"{key}: the name is already a state or input")
            values[name] = _number(value, key)
        for name, value in self.overrides.items():
            if name not in values:
                known = ", ".join(sorted(values)) or "none"
                raise ModelError(f"parameters.{name}: no such parameter (known: {known})")
            values[name] = _number(value, f"parameters.{name}")
        return {name: sympy.Float(v) for name, v in values.items()}

    def mode(
        self,
        mode_id: str,
        spec: dict[str, Any],
        env: Mapping[str, sympy.Expr],
        states: tuple[str, ...],
        inputs: tuple[str, ...],
        outputs: tuple[str, ...],
        default_q: FloatArray,
        default_r: FloatArray,
    ) -> Mode:
        key = f"modes.{mode_id}"
        _check_keys(spec, _MODE_KEYS, key)
        x = sympy.Matrix([env[s] for s in states])
        u = sympy.Matrix([env[s] for s in inputs])
        linear = any(k in spec for k in ("A", "B", "C", "D"))
        if linear and ("f" in spec or "h" in spec):
            raise ModelError(f"{key}: give either f and h or A, B, C (and D), not both")
        if linear:
            n_x, n_u, n_y = len(states), len(inputs), len(outputs)
            A = _matrix(spec, "A", (n_x, n_x), mode_id, env, required=True)
            B = _matrix(spec, "B", (n_x, n_u), mode_id, env, required=n_u > 0)
            C = _matrix(spec, "C", (n_y, n_x), mode_id, env, required=True)
            D = _matrix(spec, "D", (n_y, n_u), mode_id, env, required=False)
            f = tuple(A * x + B * u) if n_u else tuple(A * x)
            h = tuple(C * x + D * u) if n_u else tuple(C * x)
        else:
            f = _expressions(_required(spec, "f", key), len(states), f"{key}.f", env)
            h = _expressions(_required(spec, "h", key), len(outputs), f"{key}.h", env)
        q = (
            _covariance(spec["process_noise"], len(states), f"{key}.process_noise")
            if "process_noise" in spec
            else default_q
        )
        r = (
            _covariance(spec["measurement_noise"], len(outputs), f"{key}.measurement_noise")
            if "measurement_noise" in spec
            else default_r
        )
        guard = (
            _guard(spec["guard"], f"{key}.guard", env, set(states) | set(inputs))
            if "guard" in spec
            else None
        )
        return Mode(
            id=mode_id,
            f=f,
            h=h,
            process_noise=q,
            measurement_noise=r,
            linear=linear,
            guard=guard,
        )

    def simulation_inputs(
        self, simulation: dict[str, Any], inputs: tuple[str, ...], params: Mapping[str, Any]
    ) -> dict[str, sympy.Expr]:
        table = _table(simulation.get("inputs", {}), "simulation.inputs")
        env = {"t": sympy.Symbol("t", real=True), "k": sympy.Symbol("k", real=True), **params}
        result: dict[str, sympy.Expr] = {}
        for name, text in table.items():
            key = f"simulation.inputs.{name}"
            if name not in inputs:
                raise ModelError(f"{key}: '{name}' is not an input (inputs: {', '.join(inputs)})")
            value = str(text) if isinstance(text, int | float) else text
            result[name] = parse_expression(value, env, key=key)
        return result


def _guard(value: Any, key: str, env: Mapping[str, sympy.Expr], variables: set[str]) -> sympy.Basic:
    """A mode's guard: one comparison of states and inputs, e.g. ``"x3 <= 0"``."""
    text = _string(value, key).strip()
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as err:
        raise ModelError(f"{key}: cannot parse {text!r}: {err.msg}") from err
    if not isinstance(tree.body, ast.Compare):
        raise ModelError(f"{key}: expected a comparison such as 'x3 <= 0', got {text!r}")
    # The expression grammar returns values; a Piecewise carries the condition through it.
    wrapped = parse_expression(f"Piecewise(1, {text}, 0)", env, key=key)
    if not isinstance(wrapped, sympy.Piecewise):
        raise ModelError(f"{key}: {text!r} does not depend on the states or inputs")
    condition: sympy.Basic = wrapped.args[0].cond
    if not {str(s) for s in condition.free_symbols} & variables:
        raise ModelError(f"{key}: {text!r} does not depend on the states or inputs")
    return condition


def _check_guards(modes: tuple[Mode, ...]) -> None:
    """Either every mode has a guard (state-driven switching) or none has."""
    guarded = [m.id for m in modes if m.guard is not None]
    if guarded and len(guarded) != len(modes):
        missing = next(m.id for m in modes if m.guard is None)
        raise ModelError(
            f"modes.{missing}.guard: missing; when one mode has a guard every mode needs one"
        )


def _check_keys(
    table: Mapping[str, Any],
    allowed: set[str],
    where: str,
    *,
    unsupported: Mapping[str, str] | None = None,
) -> None:
    for key in table:
        if unsupported and key in unsupported:
            raise ModelError(f"{key}: {unsupported[key]} are not supported by this version")
        if key not in allowed:
            full = f"{where}.{key}" if where else key
            raise ModelError(f"{full}: unknown key (allowed: {', '.join(sorted(allowed))})")


def _required(table: Mapping[str, Any], key: str, where: str) -> Any:
    if key not in table:
        full = f"{where}.{key}" if where else key
        raise ModelError(f"{full}: required key is missing")
    return table[key]


def _table(value: Any, key: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise ModelError(f"{key}: expected a table, got {type(value).__name__}")
    return value


def _string(value: Any, key: str) -> str:
    if not isinstance(value, str):
        raise ModelError(f"{key}: expected a string, got {type(value).__name__}")
    return value


def _number(value: Any, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ModelError(f"{key}: expected a number, got {value!r}")
    if not math.isfinite(value):
        raise ModelError(f"{key}: non-finite number {value!r}")
    return float(value)


def _positive_number(value: Any, key: str) -> float:
    number = _number(value, key)
    if number <= 0:
        raise ModelError(f"{key}: must be positive, got {number!r}")
    return number


def _names(value: Any, key: str, *, allow_empty: bool = False) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise ModelError(f"{key}: expected a list of names")
    if not value and not allow_empty:
        raise ModelError(f"{key}: at least one name is required")
    for name in value:
        if not name.isidentifier() or name in {"t", "k", "pi", "e"}:
            raise ModelError(f"{key}: '{name}' is not a valid symbol name")
    if len(set(value)) != len(value):
        raise ModelError(f"{key}: names must be unique")
    return tuple(value)


def _check_disjoint(groups: Mapping[str, tuple[str, ...]]) -> None:
    seen: dict[str, str] = {}
    for group, names in groups.items():
        for name in names:
            if name in seen:
                raise ModelError(f"{group}: '{name}' is already one of the {seen[name]}")
            seen[name] = group


def _vector(value: Any, n: int, key: str) -> FloatArray:
    if not isinstance(value, list):
        raise ModelError(f"{key}: expected a list of {n} numbers")
    if len(value) != n:
        raise ModelError(f"{key}: wrong length; expected {n} instead of {len(value)}")
    return np.array([_number(v, f"{key}[{i}]") for i, v in enumerate(value)])


def _covariance(value: Any, n: int, key: str) -> FloatArray:
    """A covariance given as a scalar (times I), a diagonal list, or a full matrix."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        matrix = np.eye(n) * _number(value, key)
    elif isinstance(value, list) and value and all(isinstance(r, list) for r in value):
        if len(value) != n or any(len(r) != n for r in value):
            rows = len(value)
            cols = len(value[0])
            raise ModelError(f"{key}: wrong shape; expected {n}x{n} instead of {rows}x{cols}")
        matrix = np.array(
            [[_number(v, f"{key}[{i}][{j}]") for j, v in enumerate(r)] for i, r in enumerate(value)]
        )
    elif isinstance(value, list):
        matrix = np.diag(_vector(value, n, key))
    else:
        raise ModelError(f"{key}: expected a number, a diagonal list or a matrix")
    if not np.allclose(matrix, matrix.T, rtol=1e-12, atol=0.0):
        raise ModelError(f"{key}: covariance must be symmetric")
    if n and np.linalg.eigvalsh(matrix).min() < -1e-12 * max(1.0, float(np.abs(matrix).max())):
        raise ModelError(f"{key}: covariance must be positive semi-definite")
    return matrix


def _expressions(
    value: Any, n: int, key: str, env: Mapping[str, sympy.Expr]
) -> tuple[sympy.Expr, ...]:
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list):
        raise ModelError(f"{key}: expected a list of {n} expression strings")
    if len(value) != n:
        raise ModelError(
            f"{key}: wrong number of expressions; expected {n} instead of {len(value)}"
        )
    return tuple(
        parse_expression(str(v) if isinstance(v, int | float) else v, env, key=f"{key}[{i}]")
        for i, v in enumerate(value)
    )


def _matrix(
    spec: Mapping[str, Any],
    name: str,
    shape: tuple[int, int],
    mode_id: str,
    env: Mapping[str, sympy.Expr],
    *,
    required: bool,
) -> sympy.Matrix:
    key = f"modes.{mode_id}.{name}"
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
        [
            parse_expression(v, env, key=f"{key}[{i}][{j}]")
            if isinstance(v, str)
            else sympy.Float(_number(v, f"{key}[{i}][{j}]"))
            for j, v in enumerate(row)
        ]
        for i, row in enumerate(value)
    ]
    return sympy.Matrix(entries)


def _initial_modes(initial: Mapping[str, Any], mode_ids: tuple[str, ...]) -> FloatArray:
    n = len(mode_ids)
    if "mode" in initial and "mode_probabilities" in initial:
        raise ModelError("initial: give either mode or mode_probabilities, not both")
    if "mode" in initial:
        mode = str(initial["mode"])
        if mode not in mode_ids:
            raise ModelError(f"initial.mode: unknown mode '{mode}' (modes: {', '.join(mode_ids)})")
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
            raise ModelError(f"{key}.{sorted(unknown)[0]}: unknown mode")
        probabilities = np.array([_number(value.get(m, 0.0), f"{key}.{m}") for m in mode_ids])
    else:
        probabilities = _vector(value, n, key)
    if probabilities.min() < 0 or not math.isclose(probabilities.sum(), 1.0, abs_tol=1e-9):
        raise ModelError(f"{key}: probabilities must be non-negative and sum to 1")
    normalised: FloatArray = probabilities / probabilities.sum()
    return normalised


def _transitions(value: Any, mode_ids: tuple[str, ...]) -> FloatArray | None:
    if value is None:
        return None
    table = _table(value, "transitions")
    _check_keys(table, _TRANSITION_KEYS, "transitions")
    n = len(mode_ids)
    if "matrix" in table and "stay" in table:
        raise ModelError("transitions: give either matrix or stay, not both")
    if "stay" in table:
        stay = _number(table["stay"], "transitions.stay")
        if not 0.0 <= stay <= 1.0:
            raise ModelError(f"transitions.stay: must be a probability in [0, 1], got {stay!r}")
        return markov_matrix(stay, n)
    matrix = _covariance_free_matrix(_required(table, "matrix", "transitions"), n)
    return matrix


def _covariance_free_matrix(value: Any, n: int) -> FloatArray:
    key = "transitions.matrix"
    if (
        not isinstance(value, list)
        or len(value) != n
        or any(not isinstance(r, list) or len(r) != n for r in value)
    ):
        raise ModelError(f"{key}: expected a {n}x{n} matrix (one row per mode)")
    matrix = np.array(
        [[_number(v, f"{key}[{i}][{j}]") for j, v in enumerate(r)] for i, r in enumerate(value)]
    )
    if matrix.min() < 0 or not np.allclose(matrix.sum(axis=1), 1.0, atol=1e-9):
        bad = int(np.argmax(np.abs(matrix.sum(axis=1) - 1.0)))
        raise ModelError(f"{key}[{bad}]: each row must be non-negative and sum to 1")
    return matrix


def _string_map(value: Any, key: str, allowed: set[str]) -> dict[str, str]:
    table = _table(value, key)
    result: dict[str, str] = {}
    for name, path in table.items():
        if name not in allowed:
            raise ModelError(
                f"{key}.{name}: unknown symbol (allowed: {', '.join(sorted(allowed))})"
            )
        result[name] = _string(path, f"{key}.{name}")
    return result
