"""``mode_sequence = "kbest"``: the best of the k best mode histories, each with its own EKF.

Checked against things independent of the code:

* the exact most likely mode sequence of a linear switched model, by enumerating every
  sequence with its own Kalman filter (``test_smoothing_modes.exact_posterior``): with a beam
  wide enough to keep every history nothing is pruned and the path must be the exact one,
  also where the state has memory (where the IMM's Viterbi path is only an approximation);
* the chain: the path never takes a transition the Markov matrix forbids;
* the plain-Python path of the same function (``jit=False``) and the compiled one agree.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.model.loader import parse_model
from hybridlog.simulate import simulate
from tests.estimators.test_smoothing_modes import (
    PRIOR_MODES,
    PRIOR_STATE,
    PRIOR_VARIANCE,
    TRANSITIONS,
    _log,
    _model,
    _parameters,
    exact_posterior,
)
from tests.support.models import LINEAR_TWO_MODE

ALL_HISTORIES = 2**9
"""Histories of a 9-sample two-mode log: a beam this wide prunes none."""


def _log_posterior(A, signals, path):
    """The exact log posterior (up to the evidence) of one mode path, by its Kalman filter."""
    params = _parameters(A)
    u, y = signals.inputs[:, 0], signals.outputs[:, 0]
    log_w = math.log(PRIOR_MODES[path[0]])
    x, P = PRIOR_STATE, PRIOR_VARIANCE
    for k in range(1, len(path)):
        a, b, c, q, r = params[path[k]]
        log_w += math.log(TRANSITIONS[path[k - 1]][path[k]])
        x, P = a * x + b * u[k - 1], a * a * P + q
        S = c * c * P + r
        gamma = y[k] - c * x
        log_w += -0.5 * (math.log(2 * math.pi * S) + gamma * gamma / S)
        gain = P * c / S
        x, P = x + gain * gamma, (1 - gain * c) * P
    return log_w


@pytest.mark.parametrize("A", [(0.0, 0.0), (0.9, 0.6), (0.95, 0.95), (0.5, -0.8)])
def test_an_unpruned_beam_gives_the_exact_most_likely_sequence(A):
    model = _model(A)
    viterbi_misses = 0
    for seed in range(12):
        signals = _log(A, seed)
        *_, exact = exact_posterior(A, signals.inputs[:, 0], signals.outputs[:, 0])
        result = run_imm(model, signals, ImmOptions(mode_sequence="kbest", beam=ALL_HISTORIES))
        np.testing.assert_array_equal(result.modes, exact)
        viterbi = run_imm(model, signals, ImmOptions(mode_sequence="viterbi")).modes
        viterbi_misses += not np.array_equal(viterbi, exact)
    if A != (0.0, 0.0):
        # with memory the IMM's likelihoods are not the sequences' own: its Viterbi path
        # misses the exact one on some logs (so the test above is not one Viterbi passes)
        assert viterbi_misses > 0


def test_a_narrow_beam_finds_a_sequence_at_least_as_likely_as_the_truth_mostly():
    """Beam 4 of 512 histories: the path is the exact MAP path on most logs, and where it is
    not, still a likely one (within a few nats of the MAP)."""
    A = (0.9, 0.6)
    model = _model(A)
    exact_hits, gaps = 0, []
    for seed in range(20):
        signals = _log(A, seed)
        *_, exact = exact_posterior(A, signals.inputs[:, 0], signals.outputs[:, 0])
        path = run_imm(model, signals, ImmOptions(mode_sequence="kbest", beam=4)).modes
        exact_hits += np.array_equal(path, exact)
        gaps.append(_log_posterior(A, signals, exact) - _log_posterior(A, signals, path))
    assert min(gaps) >= -1e-9  # nothing beats the MAP path
    assert exact_hits >= 15
    assert max(gaps) < 3.0


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(min_value=0, max_value=2**31 - 1), beam=st.integers(1, 12))
def test_the_path_never_takes_a_forbidden_transition(seed, beam):
    text = LINEAR_TWO_MODE.replace("[[0.97, 0.03], [0.05, 0.95]]", "[[0.97, 0.03], [0.0, 1.0]]")
    model = parse_model(text)
    signals = simulate(model, steps=120, seed=seed).signals(model)
    result = run_imm(model, signals, ImmOptions(mode_sequence="kbest", beam=beam))
    fast, slow = model.mode_ids.index("fast"), model.mode_ids.index("slow")
    assert not ((result.modes[:-1] == fast) & (result.modes[1:] == slow)).any()
    pp = result.post_processing
    assert pp.smoothing is None and pp.mode_sequence == "kbest"
    assert f"{beam} best mode histories" in pp.description
    # only the modes change: states and predictions stay the filter's
    np.testing.assert_array_equal(result.state_means, pp.filtered.state_means)
    np.testing.assert_array_equal(result.output_predictions, pp.filtered.output_predictions)


def test_plain_python_and_compiled_agree():
    model = parse_model(LINEAR_TWO_MODE)
    signals = simulate(model, steps=150, seed=3).signals(model)
    options = ImmOptions(mode_sequence="kbest", beam=6, smooth=True)
    compiled = run_imm(model, signals, options)
    plain = run_imm(model, signals, options, jit=False)
    np.testing.assert_array_equal(compiled.modes, plain.modes)
    assert compiled.post_processing.smoothing == "kim-rts"
    assert np.mean(compiled.modes == signals.truth_modes) > 0.9
