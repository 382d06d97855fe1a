"""Model content keys known in this process, and the sympy release every cache key includes.

The content key of each model object in this process (:func:`.compiled.model_key`), and
sympy's release (:func:`sympy_release`), which every key of generated code or of loaded
models includes.

Computing a key hashes every equation of the model, which a model read from the loaded-model
cache holds only as text until first asked (sympy parses it then): so the key the cache
stores is recorded here for the model object it built (:func:`remember_key`), and travels
with the model when it is pickled to another process (:meth:`HybridModel.__getstate__
<hybridlog.model.hybrid_model.HybridModel.__getstate__>`), where it is recorded again.
"""

from __future__ import annotations

import functools
import importlib.util
import weakref
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["known_key", "remember_key", "sympy_release"]

_KEYS: dict[int, tuple[weakref.ref[HybridModel], str]] = {}


def known_key(model: HybridModel) -> str | None:
    """The key recorded for this very model object, or ``None``."""
    known = _KEYS.get(id(model))
    return known[1] if known is not None and known[0]() is model else None


def remember_key(model: HybridModel, key: str) -> None:
    """Record ``key`` as the content key of ``model`` (forgotten when the model is)."""
    identity = id(model)

    def forget(reference: weakref.ref[HybridModel]) -> None:
        if _KEYS.get(identity, (None, ""))[0] is reference:
            del _KEYS[identity]

    _KEYS[identity] = (weakref.ref(model, forget), key)


@functools.cache
def sympy_release() -> str:
    """The text of sympy's ``release.py`` (its ``__version__``), read without importing sympy.

    What the code sympy writes depends on: part of every cache key of generated code and of
    loaded models.  ``importlib.metadata.version("sympy")`` took 0.033 s a process (importing
    ``importlib.metadata``, then scanning the installed distributions), paid by the command,
    the estimators' worker and the batch workers' forkserver on their way to their work;
    finding sympy's folder (``importlib.util.find_spec``, which imports nothing) and reading
    one file takes 0.3 ms.

    Raises
    ------
    ImportError
        When sympy is not installed.
    """
    spec = importlib.util.find_spec("sympy")
    if spec is None or spec.origin is None:
        raise ImportError("sympy is not installed (hybridlog needs it to read model files)")
    return (Path(spec.origin).parent / "release.py").read_text(encoding="utf-8")
