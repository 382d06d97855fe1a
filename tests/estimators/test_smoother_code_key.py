"""The smoothers' generated code is keyed by every module whose code or constants shape it.

The straight-line backward passes (``smoother_source.py`` then) write
``kernels.PSD_TOLERANCE``'s value into their source and lay out their records with
``common.packed_width`` and ``common.upper_pairs``, but their cache key named
``smoother_source``, ``smoother_kernels`` and ``unrolled`` only: a change to either module
kept the generated passes of every cached model as they were.  Since that writer was split
(``kim_source.py``, ``ec_source.py`` and the modules they write with: ``rts_source.py``,
``generated_helpers.py``, ``backward_frame.py``, ``branch_tuples.py``), each module that
writes a pass's source is keyed, and so is every module it imports from, and every module
whose constants decide the value of a constant a writer imports (``backward_frame`` writes
``rts_steps.FALLBACK_WEIGHT``, which is ``1 + len(result.FALLBACK_CAUSES)``: ``result.py`` was
not keyed).
"""

from __future__ import annotations

import ast
import importlib
import inspect
from types import SimpleNamespace

import numpy as np
import pytest

from hybridlog.estimators import smoothing
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


def _writes_source(name: str) -> bool:
    """Whether module ``name`` writes source: it imports ``unrolled.Program``."""
    tree = ast.parse(inspect.getsource(importlib.import_module(name)))
    return any(
        isinstance(node, ast.ImportFrom)
        and node.module == "hybridlog.estimators.unrolled"
        and any(alias.name == "Program" for alias in node.names)
        for node in ast.walk(tree)
    )


def _writers(name: str) -> set[str]:
    """``name`` and the modules it imports from, transitively, that write source too."""
    found: set[str] = set()
    todo = [name]
    while todo:
        module = todo.pop()
        if module in found:
            continue
        found.add(module)
        todo += [m for m in _imported(importlib.import_module(module)) if _writes_source(m)]
    return found


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
    writers = _writers(f"hybridlog.estimators.{'ec_source' if ec else 'kim_source'}")
    assert len(writers) == (6 if ec else 5)  # ec_source takes LINEAR_FLOOR from kim_source
    for writer in writers:
        assert writer in keyed_by
        assert _imported(importlib.import_module(writer)) - set(CODE_MODULES) <= keyed_by
        for module, constant in _constants_imported(writer):
            assert _made_from(module, constant) <= keyed_by, (writer, constant)


def _constants_imported(name: str) -> set[tuple[str, str]]:
    """The package's upper-case names module ``name`` imports, with the module of each."""
    tree = ast.parse(inspect.getsource(importlib.import_module(name)))
    return {
        (node.module, alias.name)
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom)
        and node.module is not None
        and node.module.startswith("hybridlog.")
        for alias in node.names
        if alias.name.isupper()
    }


def _made_from(module: str, constant: str) -> set[str]:
    """The modules whose text decides ``constant``'s value: its own, and those of the
    constants its assignment reads that it imports (``rts_steps.FALLBACK_WEIGHT`` is
    ``1 + len(result.FALLBACK_CAUSES)``), transitively."""
    found = {module}
    tree = ast.parse(inspect.getsource(importlib.import_module(module)))
    read = {
        name.id
        for node in tree.body
        if isinstance(node, ast.Assign | ast.AnnAssign)
        and constant in {t.id for t in ast.walk(node) if isinstance(t, ast.Name)}
        for name in ast.walk(node.value if node.value is not None else node)
        if isinstance(name, ast.Name) and name.id != constant
    }
    for source, name in _constants_imported(module):
        if name in read:
            found |= _made_from(source, name)
    return found
