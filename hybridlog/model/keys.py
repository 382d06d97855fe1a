"""The content key of each model object in this process (:func:`.compiled.model_key`).

Computing a key hashes every equation of the model, which a model read from the loaded-model
cache holds only as text until first asked (sympy parses it then): so the key the cache
stores is recorded here for the model object it built (:func:`remember_key`), and travels
with the model when it is pickled to another process (:meth:`HybridModel.__getstate__
<hybridlog.model.hybrid_model.HybridModel.__getstate__>`), where it is recorded again.
"""

from __future__ import annotations

import weakref
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["known_key", "remember_key"]

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
