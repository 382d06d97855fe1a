"""Compiled mode functions: generated source, compiled with numba and cached on disk.

The generated module for a model is written to ``<cache>/models/m_<hash>.py`` where the hash
covers the model's equations, the code generator and the numba version; numba's own cache
(``cache=True``) then keeps the machine code beside it, so a second run of the same model
pays no compilation.  The cache folder is ``$HYBRIDLOG_CACHE_DIR`` or
``$XDG_CACHE_HOME/hybridlog`` (``~/.cache/hybridlog``).

Every function has one of two signatures known to the estimator kernels, so the kernels are
compiled (and cached) once for all models and receive the model functions as first-class
function values.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numba
from numba import types

from hybridlog.model.codegen import CODEGEN_VERSION, FUNCTION_NAMES, generate_source
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import FloatArray

VECTOR_SIGNATURE = types.void(
    types.int64, types.float64[::1], types.float64[::1], types.float64[::1]
)
"""``f``/``h``: (mode index, x, u, out vector)."""
MATRIX_SIGNATURE = types.void(
    types.int64, types.float64[::1], types.float64[::1], types.float64[:, ::1]
)
"""``F``/``H``: (mode index, x, u, out matrix)."""
VECTOR_FUNCTION = types.FunctionType(VECTOR_SIGNATURE)
MATRIX_FUNCTION = types.FunctionType(MATRIX_SIGNATURE)


ModelFunction = Callable[[int, FloatArray, FloatArray, FloatArray], None]
"""``(mode index, x, u, out)``: the calling convention of ``f``, ``F``, ``h`` and ``H``."""


@dataclass(frozen=True)
class CompiledModel:
    """The four mode functions of a model (see :mod:`hybridlog.model.codegen`).

    ``compile_s`` is the time spent generating and compiling in this process; it is close
    to zero when the machine code came from the on-disk cache.
    """

    f: ModelFunction
    F: ModelFunction
    h: ModelFunction
    H: ModelFunction
    compile_s: float
    jit: bool


def cache_dir() -> Path:
    """Folder holding generated model modules and their numba caches."""
    override = os.environ.get("HYBRIDLOG_CACHE_DIR")
    if override:
        return Path(override)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "hybridlog"


_LOADED: dict[str, CompiledModel] = {}


def compile_model(model: HybridModel, *, jit: bool = True) -> CompiledModel:
    """Return the compiled (``jit=True``) or plain-Python mode functions of ``model``."""
    source = generate_source(model)
    memo = hashlib.sha256(f"{CODEGEN_VERSION}|{jit}|{source}".encode()).hexdigest()
    if memo in _LOADED:
        return _LOADED[memo]
    start = time.perf_counter()
    if jit:
        module = load_generated(source)
        functions = [getattr(module, name) for name in FUNCTION_NAMES]
        signatures = {
            "f": VECTOR_SIGNATURE,
            "h": VECTOR_SIGNATURE,
            "F": MATRIX_SIGNATURE,
            "H": MATRIX_SIGNATURE,
        }
        functions = [
            numba.njit(signatures[name], cache=True, error_model="numpy")(function)
            for name, function in zip(FUNCTION_NAMES, functions, strict=True)
        ]
    else:
        namespace: dict[str, Any] = {}
        exec(compile(source, f"<hybridlog model {model.name}>", "exec"), namespace)
        functions = [namespace[name] for name in FUNCTION_NAMES]
    f, F, h, H = functions
    compiled = CompiledModel(f, F, h, H, compile_s=time.perf_counter() - start, jit=jit)
    _LOADED[memo] = compiled
    return compiled


def load_generated(source: str) -> ModuleType:
    """Write generated source (once, named by its hash) and import it from that file.

    Importing from a real file is what lets numba's ``cache=True`` keep the machine code.
    """
    key = hashlib.sha256(f"{numba.__version__}|{source}".encode()).hexdigest()[:24]
    folder = cache_dir() / "models"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"m_{key}.py"
    if not path.exists() or path.read_text(encoding="utf-8") != source:
        temporary = path.with_suffix(f".{os.getpid()}.tmp")
        temporary.write_text(source, encoding="utf-8")
        temporary.replace(path)
    name = f"hybridlog_generated_{key}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:  # pragma: no cover - the file was just written
        raise ImportError(f"cannot import generated model module {path}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def compile_generated(
    source: str, function: str, arguments: tuple[Any, ...]
) -> tuple[Callable[..., None], float]:
    """Compile ``function`` of generated ``source`` for the types of ``arguments``.

    Returns the compiled function and the seconds spent loading or compiling it (close to
    zero when numba's on-disk cache already holds it).
    """
    start = time.perf_counter()
    module = load_generated(source)
    signature = types.void(*(numba.typeof(argument) for argument in arguments))  # type: ignore[no-untyped-call]
    compiled = numba.njit(signature, cache=True, error_model="numpy", nogil=True)(
        getattr(module, function)
    )
    return compiled, time.perf_counter() - start
