"""The smoothers' generated code is keyed by every module whose code or constants shape it.

The straight-line backward passes (``smoother_source.py``) write
``kernels.PSD_TOLERANCE``'s value into their source and lay out their records with
``common.packed_width`` and ``common.upper_pairs``, but their cache key named
``smoother_source``, ``smoother_kernels`` and ``unrolled`` only: a change to either module
kept the generated passes of every cached model as they were.
"""

from __future__ import annotations

import ast
import inspect
from types import SimpleNamespace

import numpy as np
import pytest

from hybridlog.estimators import smoother_source, smoothing
from hybridlog.model.compiled import CODE_MODULES
from hybridlog.model.loader import load_model


class _KeyedError(Exception):
    """Carries the modules the backward pass named (raised before anything compiles)."""


def _imported(module: object) -> set[str]:
    """The modules of the package ``module`` imports names from."""
    tree = ast.parse(inspect.getsource(module))  # type: ignore[arg-type]
    return {
        node.module
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom)
        and node.module is not None
        and node.module.startswith("hybridlog.")
    }


@pytest.mark.parametrize("ec", [False, True])
def test_the_smoothers_code_is_keyed_by_the_modules_it_takes_from(
    monkeypatch: pytest.MonkeyPatch, ec: bool
) -> None:
    def keyed(*args: object) -> None:
        raise _KeyedError(args[3])

    monkeypatch.setattr(smoothing, "compile_generated", keyed)
    model = load_model("three_tank_hstf")
    n = model.n_modes
    with pytest.raises(_KeyedError) as raised:
        smoothing._backward_pass(
            model,
            SimpleNamespace(inputs=np.zeros((3, len(model.inputs)))),  # type: ignore[arg-type]
            SimpleNamespace(mode_probabilities=np.full((3, n), 1 / n)),  # type: ignore[arg-type]
            None,  # type: ignore[arg-type]
            np.full((n, n), 1 / n),
            None,  # type: ignore[arg-type]
            np.zeros(8),
            ec=ec,
            jit=True,
            kernel="unrolled",
        )
    keyed_by = set(raised.value.args[0])
    assert _imported(smoother_source) - set(CODE_MODULES) <= keyed_by
