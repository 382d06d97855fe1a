"""``unknown-mode`` solves each algebraic system of a cluster once, not once per assignment.

A component's mode recurs in many joint assignments with the same algebraic equations; every
decomposition solved every SCC again with sympy (about 3 ms each): a model of 14 independent
components spent 21 s compiling (13,693 solves of 42 distinct systems) for 0.7 s estimating.
"""

import itertools

import pytest

from hybridlog.estimators.cpha import structure
from hybridlog.estimators.cpha.structure import StructureCache, decompose
from hybridlog.model.loader import parse_model


def _independent(n: int) -> str:
    """``n`` components, each its own state, an internal variable and an output; 2 modes."""
    states = ", ".join(f'"x{i}"' for i in range(n))
    outputs = ", ".join(f'"y{i}"' for i in range(n))
    variables = ", ".join(f'"w{i}"' for i in range(n))
    text = f"""
name = "independent"
dt = 1.0
states = [{states}]
inputs = ["u"]
outputs = [{outputs}]
variables = [{variables}]

[noise]
process = 0.01
measurement = 0.04

[initial]
state = [{", ".join("0.0" for _ in range(n))}]
covariance = 0.1
"""
    for i in range(n):
        text += f"""
[components.c{i}]
unknown = 0.01
initial = "a"

[components.c{i}.modes.a]
equations = ["x{i}[k] = 0.5*x{i}[k-1] + w{i}[k-1]", "w{i} = u + x{i}", "y{i} = 2*w{i}"]

[components.c{i}.modes.b]
equations = ["x{i}[k] = 0.8*x{i}[k-1] + w{i}[k-1]", "w{i} = u - x{i}", "y{i} = w{i} + x{i}"]
"""
    return text


@pytest.fixture(scope="module")
def model():
    return parse_model(_independent(4))


def test_each_algebraic_system_is_solved_once_across_assignments(model, monkeypatch):
    calls = []
    solve = structure.solve_explicitly

    def counted(*args, **kwargs):
        calls.append(tuple(sorted(args[1])))
        return solve(*args, **kwargs)

    monkeypatch.setattr(structure, "solve_explicitly", counted)
    names = {
        "states": model.states,
        "inputs": model.inputs,
        "outputs": model.outputs,
        "variables": model.variables,
    }
    cache = StructureCache(model.components, **names)
    assignments = list(itertools.product(("a", "b", "unknown"), repeat=4))
    found = {a: cache.get(a) for a in assignments}
    # per component and known mode two systems (w_i, then y_i with w_i substituted),
    # whatever the other components do: 4 x 2 x 2 solves for the 81 assignments (was 432)
    assert len(calls) == 16
    assert len(set(calls)) == 8  # each target in its component's two modes
    # the same clusters as a decomposition that keeps nothing
    monkeypatch.setattr(structure, "solve_explicitly", solve)
    for assignment in assignments[:: len(assignments) // 7]:
        alone = decompose(model.components, assignment, **names)
        assert found[assignment].clusters == alone.clusters
