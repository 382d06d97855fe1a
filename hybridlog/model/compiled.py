"""Compiled model code and its on-disk cache, keyed by what shapes the code.

Every piece of code generated for a model -- the model's own functions
(:func:`~hybridlog.model.codegen.model_source`: ``f``, ``F``, ``h``, ``H``, the guards and the
simulation inputs) and the straight-line filter loops the estimators may add as
accelerators -- is a Python module written to ``<cache>/models/<kind>_<key>.py`` and
imported from there; numba's cache (``cache=True``) keeps its machine code in the folder of
this code's machine code (:func:`hybridlog.jit.machine_code_dir`).

The key is a hash of

* the model's canonical content (:func:`model_key`): every field of the model that a
  generator reads -- names, the modes' equations (their sympy trees, parameters already
  substituted), guards, noise covariances, simulation inputs -- but not what the compiled
  code receives as arguments at run time (prior, Markov matrix, options);
* the source text of every module that shapes the generated code (the generators
  themselves, :mod:`hybridlog.model.codegen`, :mod:`hybridlog.model.derivatives` ...);
* the sympy version (its printers and ``cse`` write the code).

So a change to anything that shapes the code gives a new file, and a stale module is never
imported; when the file exists it is imported as it is, without running sympy or the
generator.  The key costs about a millisecond (a walk over the expression trees), not the
0.1-0.4 s of generating the code.  The cache folder is ``$HYBRIDLOG_CACHE_DIR`` or
``$XDG_CACHE_HOME/hybridlog`` (``~/.cache/hybridlog``, :func:`hybridlog.jit.cache_dir`).

Importing this module imports neither numba nor sympy; they are imported when code is
compiled or generated.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import os
import sys
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from hybridlog.errors import OutputError
from hybridlog.jit import cache_dir
from hybridlog.limits import remedy
from hybridlog.model.keys import known_key, remember_key, sympy_release
from hybridlog.signals import FloatArray

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

ModelFunction = Callable[[int, FloatArray, FloatArray, FloatArray], None]
"""``(mode index, x, u, out)``: the calling convention of ``f``, ``F``, ``h`` and ``H``."""
GuardFunction = Callable[[FloatArray, FloatArray], int]
"""``guard(x, u)``: index of the first mode whose guard holds; where none holds, -1, or
``-2 - i`` where the guard of mode ``i`` compared a NaN (outside its domain: ``sqrt(x) > 0.5``
at ``x < 0``, which does not hold); ``-2 - n - i`` (``n`` modes) where a side of mode ``i``'s
guard is infinite (a pole, or past float64), which decides nothing."""
InputFunction = Callable[[FloatArray, FloatArray], Any]
"""``input(t, k)``: one simulation input over the time grid (an array or a scalar)."""

CODE_MODULES = (
    "hybridlog.model.codegen",
    "hybridlog.model.derivatives",
    "hybridlog.model.hybrid_model",
)
"""Modules that shape every generated module (the printer, the derivatives, the symbols)."""

RUNTIME_FIELDS = frozenset(
    {
        # Read by no generator: the compiled code receives these as arguments, or never.
        "source",
        "origin",
        "description",
        "reference",
        "initial_state",
        "initial_covariance",
        "initial_mode_probabilities",
        "transitions",
        "signals",
        "truth",
        "default_estimator",
        "estimator_options",
        "simulation_state",
        "simulation_schedule",
        "simulation_state_min",
    }
)
"""Model fields left out of :func:`model_key`; every other field is in it (new ones too).

A generator that starts reading one of these must remove it from this set."""


def store(path: Path, text: str, *, replace: bool) -> None:
    """Write ``text`` into the cache at ``path`` (:func:`_write_once`), its folder made first.

    Raises
    ------
    OutputError
        When the cache folder cannot be written (a read-only or full home, a file in its
        place): one line naming it and what to set, not the system's exception.
    """
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        _write_once(path, text, replace=replace)
    except OSError as err:
        # under ulimit -f 1 a cold cache's first file met the limit, which no folder mends
        advice = remedy(err, "set HYBRIDLOG_CACHE_DIR to a writable folder")
        raise OutputError(
            f"cache folder {cache_dir()}: cannot write {path.name} ({err.strerror or err}); "
            f"{advice}"
        ) from err


def _sympy_text(expression: Any) -> str:
    """The expression tree as text: class names, atoms exactly (like ``sympy.srepr``).

    A sympy tree's arguments are in canonical order once built, so walking them gives the
    same text in every process; ``srepr`` prints the same content but sorts the terms again
    for display, which costs 10-30 ms a model where this walk costs well under one.
    """
    from sympy.core.singleton import Singleton

    parts: list[str] = []

    def walk(node: Any) -> None:
        if node.is_Symbol:
            parts.append(f"Symbol({node.name!r},{sorted(node.assumptions0.items())})")
        elif node.is_Float:
            parts.append(f"Float({node._mpf_},{node._prec})")
        elif node.is_Rational:
            parts.append(f"Rational({node.p},{node.q})")
        elif node.args:
            parts.append(f"{type(node).__name__}(")
            for argument in node.args:
                walk(argument)
            parts.append(")")
        elif isinstance(type(node), Singleton):  # pi, E, oo, nan, true ...
            parts.append(type(node).__name__)
        else:
            import sympy

            parts.append(sympy.srepr(node))

    walk(expression)
    return "sympy:" + "".join(parts) + ";"


def _feed(digest: Any, value: object, left_out: frozenset[str] = RUNTIME_FIELDS) -> None:
    """Feed a canonical, type-tagged serialisation of ``value`` into ``digest``.

    A dataclass's fields named in ``left_out`` are not fed (at any depth).
    """
    import sympy

    if value is None or isinstance(value, bool | int | float | str):
        digest.update(f"{type(value).__name__}:{value!r};".encode())
    elif isinstance(value, np.ndarray):
        array = np.ascontiguousarray(value)
        digest.update(f"ndarray:{array.dtype.str}:{array.shape};".encode())
        digest.update(array.tobytes())
    elif isinstance(value, sympy.Basic):
        digest.update(_sympy_text(value).encode())
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        digest.update(f"{type(value).__qualname__}(".encode())
        for item in dataclasses.fields(value):
            if item.name not in left_out:
                digest.update(f"{item.name}=".encode())
                _feed(digest, getattr(value, item.name), left_out)
        digest.update(b")")
    elif isinstance(value, Mapping):
        digest.update(b"{")
        for name in sorted(value, key=str):
            _feed(digest, name, left_out)
            _feed(digest, value[name], left_out)
        digest.update(b"}")
    elif isinstance(value, frozenset | set):  # e.g. the names an equation uses
        digest.update(b"<")
        for item in sorted(value, key=repr):
            _feed(digest, item, left_out)
        digest.update(b">")
    elif isinstance(value, tuple | list):
        digest.update(b"[")
        for item in value:
            _feed(digest, item, left_out)
        digest.update(b"]")
    else:
        # An object without a canonical form could give a different key in every process.
        raise TypeError(f"model_key cannot serialise a {type(value).__qualname__}")


def model_key(model: HybridModel) -> str:
    """Hash of the model's canonical content: every field but :data:`RUNTIME_FIELDS`.

    Equal models give equal keys in every process (sympy trees are canonical); any
    change to an equation, a parameter (substituted into the equations), a noise
    covariance, a guard, a dimension or a name gives another key.  Computed once per model
    object (:mod:`hybridlog.model.keys`).
    """
    known = known_key(model)
    if known is not None:
        return known
    digest = hashlib.sha256()
    _feed(digest, model)
    key = digest.hexdigest()
    remember_key(model, key)
    return key


SCENARIO_FIELDS = frozenset(
    {
        "simulation_inputs",
        "simulation_state",
        "simulation_schedule",
        "simulation_state_min",
        "scenario",
    }
)
"""Model fields only ``simulate`` reads (the ``[simulation]`` table: its inputs, true initial
state, schedule and clamp; a components model's scenario): in :func:`model_key` (the
compiled code holds the inputs), not in :func:`plant_key`."""


def plant_key(model: HybridModel) -> str:
    """Hash of the plant the estimators see: :func:`model_key`'s content but ``[simulation]``.

    ``centers.json`` records it (:mod:`hybridlog.cluster.centers_file`): the clusters'
    labels depend on the modes' equations, noise and names, not on the input ``simulate``
    drove a log with (nor its true initial state, schedule or clamp).  Centres fitted with a
    copy of ``double_cart_case2`` whose only edit was ``[simulation.inputs] u`` were refused
    on the built-in model as "another version ... (its equations, parameters, noise or
    names differ)", which none did.
    """
    digest = hashlib.sha256()
    _feed(digest, model, RUNTIME_FIELDS | SCENARIO_FIELDS)
    return digest.hexdigest()


_FINGERPRINTS: dict[tuple[str, ...], str] = {}


def code_fingerprint(modules: Sequence[str]) -> str:
    """Hash of what turns a model into code: the source files of ``modules`` and sympy's version.

    The files are found without importing the modules (so without importing sympy).
    """
    names = tuple(sorted({*CODE_MODULES, *modules}))
    known = _FINGERPRINTS.get(names)
    if known is not None:
        return known
    digest = hashlib.sha256(f"sympy {sympy_release()};".encode())
    for name in names:
        module = sys.modules.get(name)
        origin = getattr(module, "__file__", None)
        if origin is None:
            spec = importlib.util.find_spec(name)
            origin = spec.origin if spec is not None else None
        if origin is None:  # pragma: no cover - every listed module is a file of the package
            raise ImportError(f"no source file for {name}")
        digest.update(f"{name}:".encode())
        digest.update(Path(origin).read_bytes())
    fingerprint = digest.hexdigest()
    _FINGERPRINTS[names] = fingerprint
    return fingerprint


def artefact_key(model: HybridModel, kind: str, modules: Sequence[str] = ()) -> str:
    """Key of one generated module: the model's content, the kind and the code that writes it."""
    text = f"{kind}|{model_key(model)}|{code_fingerprint(modules)}"
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def framed_module(kind: str, key: str, body: str) -> str:
    """The module's text: a header naming the key, the body, a trailer with its checksum."""
    checksum = hashlib.sha256(body.encode()).hexdigest()[:16]
    return f"# hybridlog generated {kind} {key}\n{body}\n# end {checksum}\n"


def intact_module(kind: str, key: str, text: str) -> bool:
    """Whether ``text`` is a whole module written by :func:`framed_module` for this key."""
    header = f"# hybridlog generated {kind} {key}\n"
    body, sep, _ = text.removeprefix(header).rpartition("\n# end ")
    return text.startswith(header) and bool(sep) and text == framed_module(kind, key, body)


def _write_once(path: Path, text: str, replace: bool) -> None:
    """Write ``text`` to ``path`` atomically; keep a file another process wrote first.

    A module numba has cached machine code for is never rewritten (that would invalidate
    the cache), unless ``replace`` (the file on disk is damaged).
    """
    temporary = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    temporary.write_text(text, encoding="utf-8")
    try:
        if replace:
            temporary.replace(path)
            return
        try:
            os.link(temporary, path)
        except FileExistsError:
            pass
        except OSError:  # a file system without hard links
            temporary.replace(path)
            return
    finally:
        temporary.unlink(missing_ok=True)


_MODULES: dict[Path, ModuleType] = {}
_LOCK = threading.RLock()


def load_generated(
    model: HybridModel, kind: str, generate: Callable[[], str], modules: Sequence[str] = ()
) -> ModuleType:
    """Import the generated module ``kind`` of ``model``, generating it only when not cached.

    Parameters
    ----------
    model:
        The model the code is for.
    kind:
        What the module holds (``model``, ``hstf``, ...): part of its file name and key.
    generate:
        Writes the module's source; called only when the cache has no valid file.
    modules:
        Names of the modules whose code shapes the source besides :data:`CODE_MODULES`
        (the generator's own module, helpers it uses): their text is part of the key.
    """
    key = artefact_key(model, kind, modules)
    path = cache_dir() / "models" / f"{kind}_{key}.py"
    with _LOCK:
        if path in _MODULES:
            return _MODULES[path]
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):  # missing, unreadable, a folder: written anew
            text = ""
        if not intact_module(kind, key, text):
            store(path, framed_module(kind, key, generate()), replace=path.exists())
        name = f"hybridlog_generated_{kind}_{key}"
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:  # pragma: no cover - the file exists
            raise ImportError(f"cannot import generated module {path}")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        _MODULES[path] = module
        return module


def model_module(model: HybridModel) -> ModuleType:
    """The module of the model's own functions (see :mod:`hybridlog.model.codegen`)."""

    def generate() -> str:
        from hybridlog.model.codegen import model_source

        return model_source(model)

    return load_generated(model, "model", generate)


def _model_signatures() -> dict[str, Any]:
    from numba import types

    vector = types.void(types.int64, types.float64[::1], types.float64[::1], types.float64[::1])
    matrix = types.void(types.int64, types.float64[::1], types.float64[::1], types.float64[:, ::1])
    guard = types.int64(types.float64[::1], types.float64[::1])
    jump = types.void(types.int64, types.int64, types.float64[::1], types.float64[::1])
    return {
        "f": vector,
        "h": vector,
        "F": matrix,
        "H": matrix,
        "guard": guard,
        "dx": vector,
        "DX": matrix,
        "G": vector,
        "D": matrix,
        "jump": jump,
    }


@dataclass(frozen=True)
class CompiledModel:
    """The four mode functions of a model (see :mod:`hybridlog.model.codegen`).

    Each compiled function has one fixed numba signature, so a kernel that takes them as
    arguments is compiled once for every model.  ``compile_s`` is the time spent loading,
    generating and compiling in this process; close to zero when everything was cached.
    """

    f: ModelFunction
    F: ModelFunction
    h: ModelFunction
    H: ModelFunction
    compile_s: float


_COMPILED: dict[tuple[str, str, bool], Any] = {}


def _function(model: HybridModel, name: str, jit: bool) -> Any:
    """One function of the model's module, compiled with its fixed signature when ``jit``."""
    memo = (model_key(model), name, jit)
    with _LOCK:
        if memo not in _COMPILED:
            function = getattr(model_module(model), name)
            if jit:  # scalar code writing into ``out``: nothing to count references of
                from hybridlog.jit import WITHOUT_REFCOUNTS, compile_signature

                signature = _model_signatures()[name]
                function = compile_signature(function, signature, **WITHOUT_REFCOUNTS)
            _COMPILED[memo] = function
        return _COMPILED[memo]


def compile_model(model: HybridModel, *, jit: bool = True) -> CompiledModel:
    """The compiled (``jit=True``) or plain-Python mode functions of ``model``."""
    model.check_supported("the discrete-time mode functions f, F, h, H")
    start = time.perf_counter()
    f, F, h, H = (_function(model, name, jit) for name in ("f", "F", "h", "H"))
    return CompiledModel(f, F, h, H, compile_s=time.perf_counter() - start)


def compile_f_h(model: HybridModel, *, jit: bool = True) -> tuple[ModelFunction, ModelFunction]:
    """``f`` and ``h`` alone, for a run that does not linearise the model (``simulate``).

    Their Jacobians ``F`` and ``H``, ``n_x`` times the code of ``f`` and ``h``, are left
    uncompiled: on a first run of a three-state model they were about half of the 2.3 s
    ``simulate`` spent compiling.
    """
    model.check_supported("the discrete-time mode functions f, h")
    return _function(model, "f", jit), _function(model, "h", jit)


JumpFunction = Callable[[int, int, FloatArray, FloatArray], None]
"""``jump(p, q, x, out)``: ``out = R(p, q, x)`` at a switch from mode ``p`` to ``q``."""


@dataclass(frozen=True)
class CompiledContinuousModel:
    r"""The mode functions of a continuous-time model (see :mod:`hybridlog.model.codegen`).

    ``dx(q, x, u, out)`` writes :math:`\dot x = f_q(x, u)`, ``DX`` its Jacobian in ``x``,
    ``h``, ``H`` the output and its Jacobian, ``jump(p, q, x, out)`` the state after a switch
    (the identity without a jump map).  A boolean-affine model (paper 003, eq. (1)) also
    has ``G(q, x, u, out)`` (``dx`` at δ = 0) and ``D(q, x, u, out)`` (``(n_x, L)``, column
    ``j`` = ∂dx/∂δ_j), derived symbolically; ``q`` is ignored by both.  ``G`` and ``D`` are
    ``None`` for other models.
    """

    dx: ModelFunction
    DX: ModelFunction
    h: ModelFunction
    H: ModelFunction
    jump: JumpFunction
    G: ModelFunction | None
    D: ModelFunction | None
    compile_s: float


def compile_continuous(model: HybridModel, *, jit: bool = True) -> CompiledContinuousModel:
    """The compiled (``jit=True``) or plain-Python functions of a continuous-time model.

    Raises
    ------
    ModelError
        The model is discrete-time (``time``) or a components model.
    """
    if not model.is_continuous:
        raise model.error(
            "time", "the continuous-time mode functions need time = 'continuous' (dx)"
        )
    model.check_supported("the continuous-time mode functions", continuous=True, jumps=True)
    start = time.perf_counter()
    dx, DX, h, H, jump = (_function(model, name, jit) for name in ("dx", "DX", "h", "H", "jump"))
    G = D = None
    if model.has_booleans:
        G, D = (_function(model, name, jit) for name in ("G", "D"))
    return CompiledContinuousModel(dx, DX, h, H, jump, G, D, compile_s=time.perf_counter() - start)


def compile_guard(model: HybridModel, *, jit: bool = True) -> GuardFunction:
    """``guard(x, u)`` of a state-driven model, compiled or as plain Python."""
    if not model.state_driven:
        raise ValueError(f"{model.name} has no mode guards")
    guard: GuardFunction = _function(model, "guard", jit)
    return guard


def input_functions(model: HybridModel) -> dict[str, InputFunction]:
    """The ``[simulation.inputs]`` signals by input name, NumPy-vectorised ``(t, k)``."""
    module = model_module(model)
    return {
        name: getattr(module, f"input_{index}")
        for index, name in enumerate(model.inputs)
        if hasattr(module, f"input_{index}")
    }


def compile_generated(
    model: HybridModel,
    kind: str,
    generate: Callable[[], str],
    modules: Sequence[str],
    function: str,
    arguments: Sequence[Any],
) -> tuple[Callable[..., None], float]:
    """``function`` of a generated module, compiled for the types of ``arguments``.

    Returns the compiled function and the seconds spent generating, loading or compiling it
    (close to zero when the module and its machine code were cached).
    """
    from hybridlog.jit import compile_for

    start = time.perf_counter()
    module = load_generated(model, kind, generate, modules)
    compiled = compile_for(getattr(module, function), arguments)
    return compiled, time.perf_counter() - start
