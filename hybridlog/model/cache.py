"""Loaded models on disk: a warm run builds no sympy expression and imports no sympy.

:func:`load_model` is the entry point of every job.  Parsing a model file into sympy
expressions and working out which modes are affine takes about 0.5 s with sympy's import;
the result is the same for the same text, parameters and code, so it is kept in
``<cache>/loaded/model_<key>.json`` (beside the compiled code of
:mod:`hybridlog.model.compiled`).  The key hashes

* the model text (the file's or the built-in's) and the ``--set`` parameter overrides;
* the source of every module of :mod:`hybridlog.model` (the loader, the expression
  grammar, the model types, the compiled-code key), hybridlog's version;
* the versions of sympy, numpy and Python (they shape the expressions and numbers).

So any change gives a new file, and a stale one is never read.  The file holds everything
numeric and textual of the model (names, timebase, noise, priors, Markov matrix, linear
forms, estimator options, simulation settings, the nonlinear keys and the compiled-code
key :func:`~hybridlog.model.compiled.model_key`), as JSON: reading it cannot run code.
The sympy expressions are not stored: the model read from the cache holds them as
:class:`~hybridlog.model.hybrid_model.Deferred` values that parse the model text again, with
the loader, the first time anything reads one (code generation on a cold compiled-code
cache, derivatives, an estimator's capability message).

A file is framed by its key and a checksum of its body; a damaged, truncated or foreign
file is ignored and rewritten.  Files are written to a temporary and linked or renamed into
place, so parallel batch workers never read half a file.  Models with ``[components]``
(paper 002; their automata hold expressions in every part) are not cached.  The origin
(file path or built-in name) is not part of the key: it is set from the current call, so
every error names the file as the user gave it.
"""

from __future__ import annotations

import difflib
import functools
import hashlib
import json
import math
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

import hybridlog
from hybridlog.errors import ModelError, OptionError, excerpt, set_text
from hybridlog.jit import cache_dir
from hybridlog.model.builtins import builtin_names, builtin_text
from hybridlog.model.compiled import framed_module, intact_module, model_key, store
from hybridlog.model.hybrid_model import (
    BooleanAffine,
    Deferred,
    HybridModel,
    Jump,
    LinearForm,
    Mode,
    Timebase,
    stored,
)
from hybridlog.model.keys import remember_key, sympy_release
from hybridlog.model.toml_text import decode_model_file
from hybridlog.numbers import parse_float
from hybridlog.signals import FloatArray

FORMAT = 1
"""Version of the file layout; part of the key."""
KIND = "loaded-model"
"""The kind named in each file's header."""


def load_model(
    name_or_path: str | Path, *, parameters: Mapping[str, float] | None = None
) -> HybridModel:
    """Load a built-in model by name or a model file by path, from the cache when warm.

    Parameters
    ----------
    name_or_path:
        A built-in name (``hybridlog models`` lists them) or the path of a TOML file.
    parameters:
        Overrides of ``[parameters]`` values (``--set NAME=VALUE``); unknown names are errors.

    Raises
    ------
    ModelError
        The file is missing or unreadable, the name is no built-in, or the model is
        invalid (:func:`~hybridlog.model.loader.parse_model`); every message starts with
        the file or built-in name.  Also an argument of the wrong type: ``name_or_path``
        not a non-empty ``str`` or path, ``parameters`` not a mapping of names (a
        ``["A=140"]`` of ``--set`` texts: :func:`load_model_set` takes those).
    """
    if not isinstance(name_or_path, str | os.PathLike) or not os.fspath(name_or_path):
        raise ModelError(
            "model: expected a built-in name or a model file's path (a non-empty str or "
            f"pathlib.Path), got the {type(name_or_path).__name__} {excerpt(name_or_path)}"
        )
    if parameters is not None and not (
        isinstance(parameters, Mapping) and all(isinstance(k, str) for k in parameters)
    ):
        raise ModelError(
            f"{os.fspath(name_or_path)}: parameters: expected a mapping of parameter names to "
            f"numbers, got the {type(parameters).__name__} {excerpt(parameters)}"
        )
    path = model_file(name_or_path)
    if path is not None:
        try:
            text = decode_model_file(path.read_bytes())
        except OSError as err:
            raise ModelError(f"{path}: cannot read model file: {err}") from err
        except ModelError as err:
            raise ModelError(f"{path}: {err}") from err
        return cached_model(text, origin=os.fspath(name_or_path), parameters=parameters)
    name = str(name_or_path)
    return cached_model(builtin_text(name), origin=name, parameters=parameters)


def load_model_set(name_or_path: str | Path, texts: Mapping[str, str]) -> HybridModel:
    """The model with ``--set NAME=VALUE`` values of its ``[parameters]`` (``texts``: as typed).

    Every value is read by :func:`~hybridlog.numbers.parse_float` first.  The file loaded
    with its own values (the caller loaded it to tell parameters from other names), so an
    error of the model now is one the values caused: it starts ``--set A=0: `` (an
    :class:`~hybridlog.errors.OptionError`), where it named the model file alone (``A=0``:
    ``modes.1.f[0] ... is not finite``); one that names its ``--set`` already
    (:attr:`~hybridlog.errors.HybridlogError.named`: a parameter no expression names) is
    raised as it is.

    Raises
    ------
    OptionError
        A value that is no finite number, or that makes the model invalid.
    """
    parameters: dict[str, float] = {}
    for name, text in texts.items():
        try:
            parameters[name] = parse_float(text)
        except ValueError as err:
            raise OptionError(f"{set_text(name, text)}: {err}, got {excerpt(text)}") from None
    try:
        return load_model(name_or_path, parameters=parameters)
    except ModelError as err:
        if err.named:  # names its --set already (a parameter no expression names)
            raise
        given = ", ".join(f"{k}={excerpt(v)[1:-1]}" for k, v in texts.items())
        raise OptionError(f"--set {given}: {err}", named=texts) from None


_LOG_SUFFIXES = (".csv", ".parquet", ".mcap", ".bag", ".db3")
"""Suffixes of the logs hybridlog reads: a file of one given as a model is a log (a log and
its model swapped, ``--model run.mcap MODEL``), which read as TOML said ``line 1: not UTF-8
(byte 0x89); save the file as UTF-8``."""


def model_file(name_or_path: str | Path) -> Path | None:
    """The model file ``name_or_path`` names, or ``None`` when it names a built-in.

    A file of that path; else a built-in of that name, also beside a folder of its name (an
    ``--out`` folder named after the model).

    Raises
    ------
    ModelError
        When it names neither a file nor a built-in (a folder, a missing ``.toml`` file, a
        symbolic link to nothing or a loop: said so, not as an unknown built-in),
        and when a built-in's bare name also names a file that does not hold that built-in
        (:func:`_check_not_shadowing`; ``./NAME`` names the file alone), and a log's file
        (:data:`_LOG_SUFFIXES`).
    """
    path = Path(name_or_path)
    name = str(name_or_path)
    if path.is_file():
        if name in builtin_names():
            _check_not_shadowing(path, name)
        if path.suffix.lower() in _LOG_SUFFIXES:
            raise ModelError(
                f"{path}: a log ({path.suffix}), not a model file (TOML): are the log and "
                "the model swapped?"
            )
        return path
    if name in builtin_names():
        return None
    if path.exists():
        raise ModelError(f"{path}: not a model file (a folder or a special file)")
    if path.is_symlink():  # to nothing, or a loop: the link is there, its file is not
        try:
            path.stat()
        except FileNotFoundError:
            target = excerpt(os.readlink(path))
            raise ModelError(f"{path}: a symbolic link to {target}, which does not exist") from None
        except OSError as err:
            raise ModelError(f"{path}: cannot be read ({err.strerror})") from None
    if path.suffix == ".toml":
        raise ModelError(f"{path}: no such model file")
    known = ", ".join(builtin_names())
    shown = excerpt(name)  # quoted where blanks would not show: '' or ' x'
    shown = shown if name.strip() != name or not name else shown[1:-1]
    raise ModelError(
        f"{shown}: neither a model file nor a built-in model (built-ins: {known})"
        f"{_closest_builtin(name)}"
    )


def _closest_builtin(name: str) -> str:
    """``"; did you mean 'x'?"`` for the built-in most like ``name`` (case and blanks aside).

    ``--model three_tank`` or ``Three_Tank_HSTF`` listed the built-ins without a word, where
    ``--estimator Imm`` suggests ``imm``.
    """
    names = {known.casefold(): known for known in builtin_names()}
    key = name.strip().casefold()
    found = [key] if key in names else difflib.get_close_matches(key, list(names), n=1)
    return f"; did you mean '{names[found[0]]}'?" if found else ""


def _check_not_shadowing(path: Path, name: str) -> None:
    """Refuse a file that a built-in's bare name also names, unless it holds that built-in.

    ``--model three_tank_hstf`` in a folder holding an edited copy named ``three_tank_hstf``
    ran the copy, while the report said ``model: three_tank_hstf``, the built-in's name: two
    models under one name, and which one ran was a guess the user could not see.  A file
    with the built-in's own text (as ``hybridlog models NAME`` prints it) is the same model
    either way; any other is refused, saying how to name each.  An empty one is also refused:
    it is the shell's file of ``hybridlog models NAME > NAME``, made before the command read it.

    Raises
    ------
    ModelError
        The file is empty, unreadable or not the built-in's text.
    """
    save = f"hybridlog models {name} > {name}.toml"
    try:
        held = path.read_bytes()
    except OSError as err:
        raise ModelError(f"{name}: cannot read model file: {err.strerror or err}") from err
    if not held:
        raise ModelError(
            f"{name}: an empty file of that name shadows the built-in model {name}: remove "
            f"or rename the file; to save the built-in, write it to another name, e.g. {save}"
        )
    if held != builtin_text(name).encode("utf-8"):
        raise ModelError(
            f"{name}: names both the file {name} in the working folder and the built-in "
            f"model {name}, which differ: give the file as ./{name} (or its full path), or "
            "rename it to use the built-in"
        )


def cached_model(
    text: str, *, origin: str, parameters: Mapping[str, float] | None = None
) -> HybridModel:
    """The model of ``text`` with ``parameters``: read from the cache, or built and stored."""
    overrides = dict(parameters or {})
    key = loaded_key(text, overrides)
    path = cache_dir() / "loaded" / f"model_{key}.json"
    model = _read(path, key, text, origin, overrides)
    if model is not None:
        return model
    from hybridlog.model.loader import parse_model

    model = parse_model(text, origin=origin, parameters=overrides)
    body = _encode(model)
    if body is not None:
        store(path, framed_module(KIND, key, body), replace=path.exists())
    return model


@functools.cache
def _code_fingerprint() -> str:
    """Hash of what turns a text into a model: this package's code and the libraries."""
    digest = hashlib.sha256(
        f"format {FORMAT}; hybridlog {hybridlog.__version__}; python {sys.version}; "
        f"sympy {sympy_release()}; numpy {np.__version__};".encode()
    )
    for source in sorted(Path(__file__).parent.glob("*.py")):
        digest.update(f"{source.name}:".encode())
        digest.update(source.read_bytes())
    return digest.hexdigest()


def loaded_key(text: str, parameters: Mapping[str, Any]) -> str:
    """Key of a loaded model: its text, the overrides and :func:`_code_fingerprint`."""
    overrides = sorted((str(k), type(v).__name__, repr(v)) for k, v in parameters.items())
    digest = hashlib.sha256(_code_fingerprint().encode())
    digest.update(f"{len(text)}:{text};{overrides!r}".encode())
    return digest.hexdigest()[:32]


class _Source:
    """What a model read from the cache was built from; builds it again on first need.

    Picklable (the built model is not pickled, only the text), so a model read from the
    cache can be sent to another process like one built by the loader.
    """

    def __init__(
        self, text: str, origin: str, overrides: dict[str, Any], body: str, path: Path
    ) -> None:
        self.text = text
        self.path = str(path)
        self.origin = origin
        self.overrides = overrides
        self.body = body
        self.built: HybridModel | None = None

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "built": None}

    def model(self) -> HybridModel:
        """The model built by the loader, checked against the file it was read from."""
        if self.built is None:
            from hybridlog.model.loader import parse_model

            model = parse_model(self.text, origin=self.origin, parameters=self.overrides)
            if _encode(model) != self.body:
                raise ModelError(
                    f"{self.origin}: the cached model {self.path} does not match the model "
                    "file; delete it"
                )
            self.built = model
        return self.built


class _Part:
    """A :class:`Deferred`'s computation: the value at ``steps`` of the model built again."""

    __slots__ = ("source", "steps")

    def __init__(self, source: _Source, steps: tuple[str | int, ...]) -> None:
        self.source = source
        self.steps = steps

    def __call__(self) -> Any:
        value: Any = self.source.model()
        for step in self.steps:
            value = value[step] if isinstance(step, int) else getattr(value, step)
        return value


def _array(value: FloatArray) -> dict[str, Any]:
    """An array as JSON; NaN (an unstated measurement noise covariance) as ``null``."""
    data = [None if math.isnan(v) else v for v in value.ravel().tolist()]
    return {"dtype": value.dtype.str, "shape": list(value.shape), "data": data}


def _optional_array(value: FloatArray | None) -> dict[str, Any] | None:
    return None if value is None else _array(value)


def _from_array(value: Mapping[str, Any]) -> FloatArray:
    dtype = np.dtype(value["dtype"])
    if dtype.kind != "f":
        raise ValueError(f"not a float array: {dtype}")
    data = [math.nan if v is None else v for v in value["data"]]
    array: FloatArray = np.array(data, dtype=dtype).reshape(value["shape"])
    return array


def _from_optional_array(value: Mapping[str, Any] | None) -> FloatArray | None:
    return None if value is None else _from_array(value)


def _encode(model: HybridModel) -> str | None:
    """The file body for ``model``, or ``None`` when it cannot be stored exactly."""
    if model.components:
        return None
    affine = model.boolean_affine
    content = {
        "name": model.name,
        "description": model.description,
        "reference": model.reference,
        "timebase": [
            model.timebase.kind,
            model.timebase.dt,
            model.timebase.step,
            model.timebase.method,
        ],
        "states": list(model.states),
        "inputs": list(model.inputs),
        "outputs": list(model.outputs),
        "parameters": model.parameters,
        "modes": [
            {
                "id": mode.id,
                "process_noise": _array(mode.process_noise),
                "measurement_noise": _array(mode.measurement_noise),
                "linear_form": (
                    None
                    if mode.linear_form is None
                    else {name: _array(getattr(mode.linear_form, name)) for name in _FORM}
                ),
                "nonlinear_key": mode.nonlinear_key,
                "process_noise_key": mode.process_noise_key,
                "measurement_noise_key": mode.measurement_noise_key,
                "guard": mode.has_guard,
            }
            for mode in model.modes
        ],
        "initial_state": _array(model.initial_state),
        "initial_covariance": _array(model.initial_covariance),
        "initial_mode_probabilities": _array(model.initial_mode_probabilities),
        "transitions": _optional_array(model.transitions),
        "signals": model.signals,
        "truth": model.truth,
        "default_estimator": model.default_estimator,
        "estimator_options": model.estimator_options,
        "simulation_state": _optional_array(model.simulation_state),
        "simulation_inputs": bool(stored(model, "simulation_inputs")),
        "simulation_schedule": model.simulation_schedule,
        "simulation_state_min": _optional_array(model.simulation_state_min),
        "jumps": [[jump.source, jump.target, jump.key] for jump in model.jumps],
        "boolean_affine": None if affine is None else [list(affine.booleans), affine.key],
        "variables": list(model.variables),
        "commands": list(model.commands),
        "twin_modes": [list(ids) for ids in model.twin_modes],
        "diagnoses": list(model.diagnoses),
        "outputs_differ": model.outputs_differ_by_mode,
        "model_key": model_key(model),
    }
    try:
        body = json.dumps(content, allow_nan=False)
    except (TypeError, ValueError):  # a TOML date in an option, a NaN: not stored exactly
        return None
    return body


_FORM = ("A", "B", "C", "D", "state_offset", "output_offset")


def _flag(value: object) -> bool:
    """A stored ``true``/``false``; anything else is a damaged file."""
    if not isinstance(value, bool):
        raise TypeError("expected a boolean")
    return value


def _read(
    path: Path, key: str, text: str, origin: str, overrides: dict[str, Any]
) -> HybridModel | None:
    """The model stored at ``path``, or ``None`` when it is missing, damaged or foreign."""
    try:
        framed = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None
    if not intact_module(KIND, key, framed):
        return None
    body = framed.split("\n", 1)[1].rpartition("\n# end ")[0]
    try:
        model = _decode(json.loads(body), _Source(text, origin, overrides, body, path))
    except (ValueError, TypeError, KeyError, IndexError, AttributeError):
        return None
    return model


def _decode(content: dict[str, Any], source: _Source) -> HybridModel:
    """The model of a file body; its expressions deferred to ``source``."""
    kind, dt, step, method = content["timebase"]
    if kind not in ("discrete", "continuous") or method not in (None, "euler", "rk4"):
        raise ValueError(f"bad timebase {kind!r} {method!r}")
    continuous = kind == "continuous"

    def part(*steps: str | int) -> Deferred:
        return Deferred(_Part(source, steps))

    modes = []
    for index, mode in enumerate(content["modes"]):
        form = mode["linear_form"]
        equations = part("modes", index, "dynamics")
        modes.append(
            Mode(
                id=str(mode["id"]),
                process_noise=_from_array(mode["process_noise"]),
                measurement_noise=_from_array(mode["measurement_noise"]),
                f=() if continuous else equations,
                h=part("modes", index, "h"),
                dx=equations if continuous else (),
                guard=part("modes", index, "guard") if mode["guard"] else None,
                linear_form=(
                    None
                    if form is None
                    else LinearForm(**{name: _from_array(form[name]) for name in _FORM})
                ),
                nonlinear_key=str(mode["nonlinear_key"]),
                process_noise_key=str(mode["process_noise_key"]),
                measurement_noise_key=str(mode["measurement_noise_key"]),
            )
        )
    affine = content["boolean_affine"]
    model = HybridModel(
        name=str(content["name"]),
        description=str(content["description"]),
        reference=str(content["reference"]),
        timebase=Timebase(kind=kind, dt=float(dt), step=float(step), method=method),
        states=tuple(map(str, content["states"])),
        inputs=tuple(map(str, content["inputs"])),
        outputs=tuple(map(str, content["outputs"])),
        parameters={str(k): float(v) for k, v in content["parameters"].items()},
        modes=tuple(modes),
        initial_state=_from_array(content["initial_state"]),
        initial_covariance=_from_array(content["initial_covariance"]),
        initial_mode_probabilities=_from_array(content["initial_mode_probabilities"]),
        transitions=_from_optional_array(content["transitions"]),
        signals={str(k): str(v) for k, v in content["signals"].items()},
        truth={str(k): str(v) for k, v in content["truth"].items()},
        default_estimator=(
            None if content["default_estimator"] is None else str(content["default_estimator"])
        ),
        estimator_options={str(k): dict(v) for k, v in content["estimator_options"].items()},
        simulation_state=_from_optional_array(content["simulation_state"]),
        simulation_inputs=(part("simulation_inputs") if content["simulation_inputs"] else {}),
        simulation_schedule=str(content["simulation_schedule"]),
        simulation_state_min=_from_optional_array(content["simulation_state_min"]),
        source=source.text,
        origin=source.origin,
        jumps=tuple(
            Jump(
                source=None if start is None else str(start),
                target=str(target),
                key=str(jump_key),
                reset=part("jumps", index, "reset"),
            )
            for index, (start, target, jump_key) in enumerate(content["jumps"])
        ),
        boolean_affine=(
            None
            if affine is None
            else BooleanAffine(
                booleans=tuple(map(str, affine[0])),
                dynamics=part("boolean_affine", "dynamics"),
                h=part("boolean_affine", "h"),
                key=str(affine[1]),
            )
        ),
        variables=tuple(map(str, content["variables"])),
        commands=tuple(map(str, content["commands"])),
        twin_modes=tuple(tuple(map(str, ids)) for ids in content["twin_modes"]),
        diagnoses=tuple(map(str, content["diagnoses"])),
        outputs_differ=_flag(content["outputs_differ"]),
    )
    stored_key = content["model_key"]
    if not isinstance(stored_key, str):
        raise TypeError("model_key")
    remember_key(model, stored_key)
    return model
