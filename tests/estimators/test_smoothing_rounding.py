"""The RTS steps' rounding probe: the backward pass never amplifies its own rounding past use.

With no process noise the RTS gain is ``J = F⁻¹``, which grows by ``1/|λ|`` per step backwards
for a stable mode: the last digits of the forward pass came back as states of 177 at sample 0
of a 600-sample log (1e139 after 5,000 samples), at exit 0, where the filter was within 0.05.
"""

import numpy as np
import pytest

from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.estimators.kernels import cholesky
from hybridlog.estimators.rts_source import _positive_pivots
from hybridlog.estimators.rts_steps import ROUNDING_LIMIT, rts_step, rts_work
from hybridlog.estimators.unrolled import Program
from hybridlog.model.loader import parse_model
from hybridlog.simulate import simulate
from tests.estimators.test_smoothing import assert_smoother_invariants

STABLE_WITHOUT_PROCESS_NOISE = """
name = "stable_without_process_noise"
time = "discrete"
dt = 0.1
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y"]

[modes.only]
f = ["0.9*x1 + 0.1*x2 + u", "0.95*x2 - 0.05*x1"]
h = ["x1"]

[noise]
process = 0.0
measurement = 0.04

[initial]
state = [0.0, 0.0]
covariance = 1.0
mode = "only"

[simulation]
state = [1.0, 0.5]
schedule = "only:1000"

[simulation.inputs]
u = "0.1*sin(t)"
"""


@pytest.mark.parametrize("mode_sequence", ["argmax", "kbest"])
@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_smoothed_states_of_a_plant_without_process_noise_stay_bounded(kernel, mode_sequence):
    model = parse_model(STABLE_WITHOUT_PROCESS_NOISE)
    log = simulate(model, steps=1000, seed=0)
    signals = log.signals(model)
    options = ImmOptions(smooth=True, mode_sequence=mode_sequence)
    result = run_imm(model, signals, options, kernel=kernel)
    filtered = result.post_processing.filtered

    def rmse(means):
        return float(np.sqrt(np.mean((means - log.states) ** 2)))

    # The smoother still smooths (the filter's first samples start from a wrong prior) ...
    assert rmse(result.state_means) < 0.75 * rmse(filtered.state_means)
    # ... and no sample is further from the truth than the filter's worst.
    worst = np.abs(filtered.state_means - log.states).max()
    assert np.abs(result.state_means - log.states).max() <= worst


def _scalar(factor):
    """``f = factor·x`` and its Jacobian, as the compiled model functions are called."""

    def f(mode, x, u, out):
        out[0] = factor * x[0]

    def F(mode, x, u, out):
        out[0, 0] = factor

    return f, F


def _step(P, r_next):
    f, F = _scalar(0.5)  # J = F⁻¹ = 2 without process noise
    x, x_next = np.array([1.0]), np.array([0.5])
    x_out, P_out, r_out = np.full(1, np.nan), np.full((1, 1), np.nan), np.full(1, np.nan)
    taken = rts_step(f, F, 0, x, np.array([[P]]), np.zeros(1), np.zeros((1, 1)), x_next,
                     np.array([[P / 8.0]]), x_out, P_out, rts_work(1), np.array([r_next]),
                     r_out)  # fmt: skip
    return taken, x_out[0], P_out[0, 0], r_out[0]


def test_a_step_whose_rounding_probe_is_within_the_limit_is_taken_and_carries_it():
    taken, x_out, P_out, r_out = _step(1.0, 1e-12)
    assert taken and x_out == pytest.approx(1.0) and 0.0 < P_out < 1.0
    # r = J (r_next + u (|x̂^s(k+1)| + |x̂^-|)) + u |x̂^s(k)| = 2 (1e-12 + 2u·0.5) + u
    assert r_out == pytest.approx(2e-12 + 3 * 2.0**-52)


def test_a_step_whose_rounding_probe_passes_the_limit_leaves_the_forward_estimate():
    # Its standard deviation (1e-20) is far below what the rounding of x ≈ 1 can resolve.
    taken, x_out, P_out, r_out = _step(1e-40, 0.0)
    assert not taken
    assert (x_out, P_out, r_out) == (1.0, 1e-40, 0.0)
    # The limit is relative to the step's own standard deviation.
    taken, *_ = _step(1.0, 0.9 * ROUNDING_LIMIT)
    assert not taken


CONTRACTING_WITHOUT_PROCESS_NOISE = """
name = "contracting_without_process_noise"
dt = 0.1
states = ["x0", "x1", "x2", "x3"]
inputs = ["u"]
outputs = ["y0", "y1"]

[modes.only]
A = [[-0.53, -0.4, -0.67, 0.09], [-0.05, 0.14, -0.08, -0.27], [-0.09, 0.01, -0.17, -0.51],
     [-0.01, 0.23, -0.12, 0.42]]
B = [[1.5], [0.5], [-0.3], [-0.5]]
C = [[-0.17, -1.83, -1.38, 0.81], [1.76, -1.36, -0.27, 0.94]]

[noise]
process = 0.0
measurement = 1e-2

[initial]
state = [0.0, 0.0, 0.0, 0.0]
covariance = 100.0
mode = "only"

[simulation]
state = [0.0, 0.0, 0.0, 0.0]
schedule = "only:20"

[simulation.inputs]
u = "sin(0.7*t)"
"""


@pytest.mark.parametrize("smoother", ["kim", "ec"])
def test_smoothed_covariances_stay_psd_where_the_gain_amplifies_their_rounding(smoother):
    """Without process noise ``J = F⁻¹``; for eigenvalues of ``F`` near 0.1 the rounding of a
    smoothed covariance's smallest eigenvalue grows a hundredfold per step backwards.  It
    came back as a covariance with an eigenvalue of −13 % of its largest entry at sample 2 of
    21 (both smoothers, exit 0); a step whose covariance is not PSD to
    :data:`~hybridlog.estimators.kernels.PSD_TOLERANCE` now leaves the forward estimate."""
    model = parse_model(CONTRACTING_WITHOUT_PROCESS_NOISE)
    signals = simulate(model, steps=20, seed=0, jit=False).signals(model)
    options = ImmOptions(smooth=True, smoother=smoother)
    result = run_imm(model, signals, options, jit=False, kernel="loops", store_covariances=True)
    assert_smoother_invariants(result)
    filtered = result.post_processing.filtered
    assert np.abs(result.state_means - filtered.state_means).max() > 1e-3  # it still smooths


def _pivots_decide(S: np.ndarray) -> bool:
    """The generated code's test of ``S`` (:func:`_positive_pivots`), run as Python."""
    n = S.shape[0]
    names = [[f"s{min(a, b)}_{max(a, b)}" for b in range(n)] for a in range(n)]
    p = Program(indent="")
    condition = _positive_pivots(p, "t", names)
    scope = {f"s{a}_{b}": S[a, b] for a in range(n) for b in range(a, n)}
    with np.errstate(all="ignore"):  # the compiled code's error model: inf and NaN, no raise
        exec("\n".join(p.lines), scope)
        return bool(eval(condition, scope))


def _special_matrices() -> list[np.ndarray]:
    """Zeros, NaN, infinities and exact zeros off the diagonal, of sizes 1 to 4."""
    nan, inf = float("nan"), float("inf")
    cases = [np.zeros((1, 1)), np.array([[nan]]), np.array([[inf]]), np.array([[-inf]])]
    for n in (2, 3, 4):
        base = np.eye(n) + 0.5 * (np.ones((n, n)) - np.eye(n))
        for a, b, value in ((0, 0, nan), (n - 1, n - 1, nan), (0, n - 1, nan), (0, 0, inf),
                            (n - 1, n - 1, inf), (0, 1, inf), (0, 0, 0.0), (1, 1, -1.0),
                            (0, 1, 0.0), (0, 1, 1.0), (0, 1, 2.0)):  # fmt: skip
            S = base.copy()
            S[a, b] = S[b, a] = value
            cases.append(S)
        cases.append(np.zeros((n, n)))
        cases.append(np.diag(np.arange(1.0, n + 1)))
    return cases


def test_the_generated_pivot_test_decides_as_the_cholesky_factor():
    """The straight-line backward pass tests the guard's ``P^- − P^s(k+1)`` and the step's
    covariance by the pivots of ``L D Lᵀ`` (no square root, ``n − 1`` divisions) where the
    generic loop takes a Cholesky factor: the same decision, on matrices of sizes 1 to 4 that
    are positive definite or not by at least 1e-6 of their largest eigenvalue (a decision
    rounding cannot tip), scaled from 1e-150 to 1e150, and on NaN, infinite and zero
    entries."""
    rng = np.random.default_rng(12)
    cases = _special_matrices()
    for _ in range(400):
        n = int(rng.integers(1, 5))
        basis, _r = np.linalg.qr(rng.normal(size=(n, n)))
        magnitudes = 10.0 ** rng.uniform(-6.0, 0.0, size=n)
        signs = np.where(rng.random(n) < 0.25, -1.0, 1.0)
        scale = 10.0 ** rng.uniform(-150.0, 150.0)
        S = scale * (basis * (signs * magnitudes)) @ basis.T
        cases.append((S + S.T) / 2.0)
    decisions = []
    for S in cases:
        expected = cholesky(S.copy(), np.zeros_like(S))
        assert _pivots_decide(S) == expected, S
        decisions.append(expected)
    assert 100 < sum(decisions) < len(decisions) - 100  # both outcomes, often
