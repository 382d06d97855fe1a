"""The smoothed mode probabilities against the exact posterior (issue 12, point 2).

For a linear switched model and a short log the exact posterior over the mode sequences is
computable: one Kalman filter and RTS smoother per sequence (``n_q ** N`` of them; 2 modes and
9 samples make 512).  It is independent of hybridlog's code and checks

* where Kim's recursion is exact: with ``A_j = 0`` the state forgets its past at every step,
  the model is a hidden Markov chain with Gaussian emissions, the IMM's per-mode filters are
  exact and Kim's backward recursion is the exact forward-backward smoother (the mixed prior
  ``x̂⁰_j(k)`` is then exactly ``E[x(k) | q(k+1)=j, Y^N]``).  The IMM's filtered and smoothed
  mode probabilities and the smoothed state mean and variance equal the exact ones to
  rounding, on both code paths: a wrong index, a transposed Markov matrix or a dropped term
  of the recursion breaks it; the Viterbi path is the exact most likely sequence;
* where it is an approximation (a state with memory): the smoothed probabilities are nearer
  the exact smoothed ones than the filter's are, summed over a batch of logs.
"""

import itertools
import math

import numpy as np
import pytest

from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals

MODES = {  # per mode: B, C, process and measurement noise variance (A is the test's)
    "a": (0.5, 1.0, 0.4, 0.3),
    "b": (-0.4, 2.0, 0.6, 0.8),
}
PRIOR_STATE, PRIOR_VARIANCE = 0.7, 1.5
PRIOR_MODES = [0.3, 0.7]
TRANSITIONS = [[0.8, 0.2], [0.35, 0.65]]


def _model(A):
    """The scalar two-mode model with ``A_a, A_b = A``."""
    modes = "".join(
        f"[modes.{name}]\nA = [[{a!r}]]\nB = [[{b!r}]]\nC = [[{c!r}]]\n"
        f"process_noise = [[{q!r}]]\nmeasurement_noise = [[{r!r}]]\n\n"
        for a, (name, (b, c, q, r)) in zip(A, MODES.items(), strict=True)
    )
    return parse_model(
        'name = "scalar_two_mode"\ndt = 1.0\nstates = ["x"]\ninputs = ["u"]\n'
        'outputs = ["y"]\ndefault_estimator = "imm"\n\n'
        f"{modes}[noise]\nprocess = 1.0\nmeasurement = 1.0\n\n"
        f"[initial]\nstate = [{PRIOR_STATE!r}]\ncovariance = {PRIOR_VARIANCE!r}\n"
        f"mode_probabilities = {PRIOR_MODES!r}\n\n[transitions]\nmatrix = {TRANSITIONS!r}\n"
    )


def _parameters(A):
    return [(a, *values) for a, values in zip(A, MODES.values(), strict=True)]


def exact_posterior(A, inputs, outputs):
    """Exact filtered and smoothed mode marginals, smoothed state mean and variance, MAP path.

    Brute force over every mode sequence ``q(0..N-1)``: ``q(0) ~ μ(0)``, ``x(0) ~ N(x̂0, P0)``
    (no measurement at sample 0, as in the IMM), and for ``k >= 1``
    ``x(k) = A_q x(k-1) + B_q u(k-1) + w``, ``y(k) = C_q x(k) + v`` with ``q = q(k)``.  Each
    sequence gets a scalar Kalman filter (its weight: its prior times the likelihood of
    ``y(1..N-1)``) and an RTS smoother.
    """
    params = _parameters(A)
    n, n_q = outputs.size, len(A)
    T = np.array(TRANSITIONS)
    sequences = np.array(list(itertools.product(range(n_q), repeat=n)))
    log_prefix = np.empty((len(sequences), n))  # log p(q(0..k), y(1..k))
    log_future = np.zeros((len(sequences), n))  # log p(q(k+1..N-1) | q(k))
    means = np.empty((len(sequences), n))
    variances = np.empty((len(sequences), n))
    for s, sequence in enumerate(sequences):
        log_w = math.log(PRIOR_MODES[sequence[0]])
        x, P = PRIOR_STATE, PRIOR_VARIANCE
        xf, Pf, xp, Pp = [x], [P], [x], [P]
        log_prefix[s, 0] = log_w
        for k in range(1, n):
            a, b, c, q, r = params[sequence[k]]
            log_w += math.log(T[sequence[k - 1], sequence[k]])
            x, P = a * x + b * inputs[k - 1], a * a * P + q
            xp.append(x)
            Pp.append(P)
            S = c * c * P + r
            gamma = outputs[k] - c * x
            log_w += -0.5 * (math.log(2 * math.pi * S) + gamma * gamma / S)
            gain = P * c / S
            x, P = x + gain * gamma, (1 - gain * c) * P
            xf.append(x)
            Pf.append(P)
            log_prefix[s, k] = log_w
        xs, Ps = list(xf), list(Pf)
        for k in range(n - 2, -1, -1):
            log_future[s, k] = log_future[s, k + 1] + math.log(T[sequence[k], sequence[k + 1]])
            J = Pf[k] * params[sequence[k + 1]][0] / Pp[k + 1]
            xs[k] = xf[k] + J * (xs[k + 1] - xp[k + 1])
            Ps[k] = Pf[k] + J * J * (Ps[k + 1] - Pp[k + 1])
        means[s], variances[s] = xs, Ps
    filtered = np.empty((n, n_q))
    smoothed = np.empty((n, n_q))
    joint = log_prefix + log_future  # filtered: each prefix once (the futures sum to 1)
    w = np.exp(log_prefix[:, -1] - log_prefix[:, -1].max())
    w /= w.sum()
    for k in range(n):
        p = np.exp(joint[:, k] - joint[:, k].max())
        for m in range(n_q):
            filtered[k, m] = p[sequences[:, k] == m].sum() / p.sum()
            smoothed[k, m] = w[sequences[:, k] == m].sum()
    mean = w @ means
    variance = w @ (variances + (means - mean) ** 2)
    return filtered, smoothed, mean, variance, sequences[np.argmax(log_prefix[:, -1])]


def _log(A, seed, n=9):
    """``n`` samples drawn from the model (modes from its chain), as aligned signals."""
    rng = np.random.default_rng(seed)
    params = _parameters(A)
    u = rng.normal(0.0, 1.0, n)
    y = np.zeros(n)
    modes = np.zeros(n, dtype=np.int64)
    modes[0] = rng.choice(len(A), p=PRIOR_MODES)
    x = rng.normal(PRIOR_STATE, math.sqrt(PRIOR_VARIANCE))
    for k in range(1, n):
        modes[k] = rng.choice(len(A), p=TRANSITIONS[modes[k - 1]])
        a, b, c, q, r = params[modes[k]]
        x = a * x + b * u[k - 1] + rng.normal(0.0, math.sqrt(q))
        y[k] = c * x + rng.normal(0.0, math.sqrt(r))
    return AlignedSignals(
        source="exact-enumeration",
        time=np.arange(n, dtype=np.float64),
        input_names=("u",),
        output_names=("y",),
        inputs=u[:, None],
        outputs=y[:, None],
        truth_modes=modes,
    )


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_kim_smoother_is_exact_on_a_markov_chain_with_gaussian_emissions(kernel):
    A = (0.0, 0.0)
    model = _model(A)
    for seed in range(4):
        signals = _log(A, seed)
        result = run_imm(
            model,
            signals,
            ImmOptions(smooth=True, smoother="kim", mode_sequence="viterbi"),
            kernel=kernel,
            store_covariances=True,
        )
        filtered, smoothed, mean, variance, path = exact_posterior(
            A, signals.inputs[:, 0], signals.outputs[:, 0]
        )
        before = result.post_processing.filtered
        np.testing.assert_allclose(before.mode_probabilities, filtered, rtol=0, atol=1e-12)
        np.testing.assert_allclose(result.mode_probabilities, smoothed, rtol=0, atol=1e-12)
        np.testing.assert_allclose(result.state_means[:, 0], mean, rtol=0, atol=1e-12)
        np.testing.assert_allclose(result.covariances[:, 0, 0], variance, rtol=0, atol=1e-12)
        # The Viterbi path is the most likely sequence (the IMM's likelihoods are exact here).
        np.testing.assert_array_equal(result.modes, path)
        # The smoothing mattered here (a copy of the filter's would not pass).
        assert np.abs(smoothed - filtered).max() > 0.05


def test_kim_smoother_nearer_the_exact_posterior_than_the_filter_with_memory():
    A = (0.9, 0.6)
    model = _model(A)
    kim, filter_ = 0.0, 0.0
    for seed in range(20):
        signals = _log(A, seed)
        result = run_imm(model, signals, ImmOptions(smooth=True, smoother="kim"))
        _, smoothed, _, _, _ = exact_posterior(A, signals.inputs[:, 0], signals.outputs[:, 0])
        kim += np.abs(result.mode_probabilities - smoothed).sum()
        filter_ += np.abs(result.post_processing.filtered.mode_probabilities - smoothed).sum()
    assert kim < filter_
