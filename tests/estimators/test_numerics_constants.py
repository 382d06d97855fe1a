"""Constants the straight-line code folds past the range of floats (hostile plant models).

The accelerators fold products of the model's constant Jacobians and noise covariances at
generation time (``estimators/unrolled.py``); ``H Q Hᵀ`` of ``h = 1e200*x`` overflows there.
It was written ``inf`` into the generated module, which numba refused to compile
(``NameError: name 'inf' is not defined``): the user saw "unexpected TypingError".
"""

import math

import numpy as np
import pytest

from hybridlog.errors import DivergenceError
from hybridlog.estimators.filter_options import HstfOptions, ImmOptions
from hybridlog.estimators.hstf import run_hstf
from hybridlog.estimators.imm import run_imm
from hybridlog.estimators.unrolled import Program, product, term
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals

HUGE_GAIN = """
name = "huge_gain"
dt = 1.0
states = ["x"]
inputs = ["u"]
outputs = ["y"]
[modes.a]
f = ["x + u"]
h = ["1e200*x"]
[modes.b]
f = ["0.5*x + u"]
h = ["1e200*x"]
[noise]
process = 0.1
measurement = 0.1
[initial]
state = [1.0]
covariance = 1.0
"""


def _signals(n: int = 30) -> AlignedSignals:
    rng = np.random.default_rng(4)
    return AlignedSignals(
        source="sim",
        time=np.arange(n, dtype=float),
        input_names=("u",),
        output_names=("y",),
        inputs=np.full((n, 1), 0.1),
        outputs=rng.normal(1.0, 0.1, (n, 1)),
    )


@pytest.mark.parametrize(
    ("run", "options"),
    [
        (run_hstf, HstfOptions()),
        (run_imm, ImmOptions()),
        (run_imm, ImmOptions(mode_sequence="kbest")),
    ],
    ids=["hstf", "imm", "imm-kbest"],
)
def test_a_constant_that_overflows_compiles_and_does_what_the_loops_do(run, options):
    """Both kernels refuse the samples no mode can weigh: ``S`` is infinite at every one.

    They had kept every mode's prediction and the predicted mode probabilities (the gain
    ``P Hᵀ S⁻¹`` is 0 and every likelihood -inf), and agreed on those numbers, which nobody
    can vouch for as estimates of the log.
    """
    model = parse_model(HUGE_GAIN, origin="huge_gain.toml")
    signals = _signals()
    messages = []
    for kernel in ("unrolled", "loops"):
        with pytest.raises(DivergenceError) as caught:
            run(model, signals, options, kernel=kernel)
        messages.append(str(caught.value))
    assert messages[0] == messages[1]
    assert messages[0].startswith(
        "huge_gain.toml: " + ("hstf" if run is run_hstf else "imm") + " cannot weigh the "
        "measurement at t = 1 s (sample 1): no mode's innovation covariance H P Hᵀ + R is "
        "finite and positive definite in double precision"
    )
    assert "'1.0e+200*x' is 1e+200" in messages[0]


def test_non_finite_literals_are_written_with_math():
    inf = float("inf")
    assert term(inf) == "math.inf"
    assert term(-inf) == "(-math.inf)"
    assert term(float("nan")) == "math.nan"
    assert term(1e200 * 1e200) == "math.inf"
    folded = product(1e200, 1e200)
    assert folded == inf and term(folded) == "math.inf"
    p = Program()
    total = p.let("s", ["a", 1e308, 1e308])
    assert p.lines == [f"{p.indent}{total} = a + math.inf"]
    assert eval(term(-inf), {"math": math}) == -inf
