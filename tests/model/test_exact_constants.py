"""Every number of a model reaches its compiled code as the double it is.

sympy prints a ``Float`` with 15 significant digits, which does not name every double: a
parameter written with 17 (``0.12345678901234568``, as identification tools write them) was
compiled as ``0.123456789012346``, and the report's ``parameters`` recorded a value the run
did not use.  The model's functions, its simulation inputs and ``unknown-mode``'s cluster
filters are all printed by :mod:`hybridlog.model.codegen`'s exact printers.
"""

import numpy as np
import pytest
import sympy

from hybridlog.estimators.cpha.cluster_filter import compile_cluster
from hybridlog.estimators.cpha.structure import Cluster
from hybridlog.model import compiled
from hybridlog.model.loader import parse_model

A = 0.12345678901234568  # 17 significant digits; "0.123456789012346" is another double
B = 0.30000000000000004  # 0.1 + 0.2
C = 1.0000000000000002  # the double after 1

MODEL = f"""
name = "exact_constants"
dt = 0.5
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y"]

[parameters]
a = {A!r}
b = {B!r}
c = {C!r}

[modes.one]
f = ["a*x1 + u", "b*x2"]
h = ["c*x1"]

[modes.two]
f = ["b*x1", "a*x2 + sin(x1)"]
h = ["c*x2"]

[noise]
process = 0.01
measurement = 0.1

[initial]
state = [0.0, 0.0]
covariance = 1.0

[simulation]
state = [0.0, 0.0]

[simulation.inputs]
u = "a*t"
"""


def test_the_doubles_are_distinct_at_15_digits():
    # the premise: each needs more than 15 significant digits to be named
    assert all(float(f"{v:.15g}") != v for v in (A, B, C))


@pytest.mark.parametrize("jit", [False, True])
def test_a_models_functions_use_its_parameters_doubles(jit):
    model = parse_model(MODEL)
    functions = compiled.compile_model(model, jit=jit)
    x, u = np.array([1.0, 1.0]), np.array([0.0])
    for q, expected_f, expected_h in ((0, [A, B], [C]), (1, [B, A + np.sin(1.0)], [C])):
        f = np.full(2, np.nan)
        functions.f(q, x, u, f)
        assert f.tolist() == expected_f
        h = np.full(1, np.nan)
        functions.h(q, x, u, h)
        assert h.tolist() == expected_h
    F = np.full((2, 2), np.nan)
    functions.F(0, x, u, F)
    assert F.tolist() == [[A, 0.0], [0.0, B]]


def test_simulation_inputs_use_the_parameters_doubles():
    model = parse_model(MODEL)
    (u,) = compiled.input_functions(model).values()
    assert np.asarray(u(np.array([1.0, 2.0]), np.array([0.0, 1.0]))).tolist() == [A, 2.0 * A]


@pytest.mark.parametrize("unrolled", [False, True])
def test_a_cluster_filters_constants_are_the_models_doubles(unrolled):
    x = sympy.Symbol("x", real=True)
    cluster = Cluster(
        states=("x",),
        outputs=("y",),
        inputs=(),
        virtual_inputs=(),
        components=("c",),
        equations=(),
        f=(sympy.Float(A) * x,),
        h=(sympy.Float(B) * x,),
        process_noise=(0.0,),
        measurement_noise=(0.1,),
        virtual_noise=(),
    )
    filt = compile_cluster(cluster, states=("x",), inputs=(), outputs=("y",), unrolled=unrolled)
    none = np.zeros(0)
    # P = 0 and Q = 0: no gain, so x̂(k|k) is f(x̂) and ŷ is h(f(x̂)), each one product
    step = filt.step(
        np.array([1.0]), np.zeros((1, 1)), none, np.array([0.0]), none, np.array([2.0])
    )
    assert step.x.tolist() == [A]
    assert step.y_pred.tolist() == [B * A]


def test_a_whole_number_beyond_64_bits_compiles_as_pythons_double():
    # numba typed the literal 100000000000000000000 as int64: "Int value is too large"
    text = MODEL.replace('"a*x1 + u"', '"100000000000000000000*x1 + u"').replace(
        '"b*x1"', '"x1*100000000000000000001/3"'
    )
    functions = compiled.compile_model(parse_model(text), jit=True)
    x, u = np.array([3.0, 1.0]), np.array([0.0])
    f = np.full(2, np.nan)
    functions.f(0, x, u, f)
    assert f[0] == 100000000000000000000 * 3.0
    functions.f(1, x, u, f)
    assert f[0] == (100000000000000000001 / 3) * 3.0
