"""``mode_sequence = "kbest"``: the best of the k best mode histories, each with its own EKF.

Checked against things independent of the code:

* the exact most likely mode sequence of a linear switched model, by enumerating every
  sequence with its own Kalman filter (``test_smoothing_modes.exact_posterior``): with a beam
  wide enough to keep every history nothing is pruned and the path must be the exact one,
  also where the state has memory (where the IMM's Viterbi path is only an approximation);
* the chain: the path never takes a transition the Markov matrix forbids;
* the states along the path: with one mode, or the stay probability at 1 and the true mode
  known, they are FilterPy's Kalman filter and ``rts_smoother`` (``smooth = true``) to 1e-8;
  covariances stay symmetric PSD under outliers, and the smoothed last sample is the filtered;
* the plain-Python path of the same function (``jit=False``) and the compiled one agree;
* the search's beam threshold is the beam-th best weight found (its cost per weight, ``log
  beam``, is measured by ``benchmarks/smoothing.py``, not here).
"""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlog.errors import DivergenceError
from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.estimators.mode_hypotheses import note_weight
from hybridlog.model.loader import load_model, parse_model
from hybridlog.simulate import simulate
from tests.estimators.test_filter_properties import assert_filter_invariants
from tests.estimators.test_smoothing import (
    KNOWN_MODE_CASES,
    ONE_MODE,
    _filterpy_rts,
    _unforced,
    known_mode_log,
)
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


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
@pytest.mark.parametrize("A", [(0.0, 0.0), (0.9, 0.6), (0.95, 0.95), (0.5, -0.8)])
def test_an_unpruned_beam_gives_the_exact_most_likely_sequence(A, kernel):
    model = _model(A)
    viterbi_misses = 0
    for seed in range(12):
        signals = _log(A, seed)
        *_, exact = exact_posterior(A, signals.inputs[:, 0], signals.outputs[:, 0])
        options = ImmOptions(mode_sequence="kbest", beam=ALL_HISTORIES)
        result = run_imm(model, signals, options, kernel=kernel)
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
    # the one-step-ahead predictions stay the filter's (the basis of MSE and VAF)
    np.testing.assert_array_equal(result.output_predictions, pp.filtered.output_predictions)


def test_plain_python_and_compiled_agree():
    model = parse_model(LINEAR_TWO_MODE)
    signals = simulate(model, steps=150, seed=3).signals(model)
    options = ImmOptions(mode_sequence="kbest", beam=6, smooth=True)
    compiled = run_imm(model, signals, options)
    plain = run_imm(model, signals, options, jit=False)
    np.testing.assert_array_equal(compiled.modes, plain.modes)
    assert compiled.post_processing.smoothing == "kim-rts+path-rts"
    np.testing.assert_allclose(compiled.state_means, plain.state_means, rtol=1e-12, atol=1e-12)
    assert np.mean(compiled.modes == signals.truth_modes) > 0.9


@pytest.mark.parametrize("smooth", [False, True])
def test_one_mode_states_are_filterpys_kalman_filter_and_rts(smooth):
    model = parse_model(ONE_MODE)
    signals = _unforced(model, 300, seed=6)
    result = run_imm(
        model,
        signals,
        ImmOptions(mode_sequence="kbest", beam=3, smooth=smooth),
        store_covariances=True,
    )
    assert (result.modes == 0).all()
    x, P = _filterpy_rts(model, 0, signals, smoothed=smooth)
    expected = "kim-rts+path-rts" if smooth else None
    assert result.post_processing.smoothing == expected
    np.testing.assert_allclose(result.state_means, x, rtol=0, atol=1e-8)
    np.testing.assert_allclose(result.covariances, P, rtol=0, atol=1e-8)
    np.testing.assert_allclose(result.state_variances, np.diagonal(P, axis1=1, axis2=2), atol=1e-8)


@pytest.mark.parametrize(("true_mode", "prior"), KNOWN_MODE_CASES)
def test_stay_one_and_known_mode_is_the_rts_of_that_mode(true_mode, prior):
    model, signals = known_mode_log(true_mode, prior)
    options = ImmOptions(transition_stay=1.0, smooth=True, mode_sequence="kbest")
    result = run_imm(model, signals, options, store_covariances=True)
    index = model.mode_ids.index(true_mode)
    assert (result.modes == index).all()
    x, P = _filterpy_rts(model, index, signals)
    np.testing.assert_allclose(result.state_means, x, rtol=0, atol=1e-8)
    np.testing.assert_allclose(result.covariances, P, rtol=0, atol=1e-8)


@settings(max_examples=4, deadline=None)
@given(
    n_outliers=st.integers(min_value=0, max_value=40),
    sigmas=st.sampled_from([10.0, 1e3, 1e6]),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
)
def test_path_states_psd_and_last_sample_filtered_with_outliers(n_outliers, sigmas, seed):
    model = load_model("three_tank_hstf")
    log = simulate(model, steps=3000, seed=seed % 1000)
    rng = np.random.default_rng(seed)
    outputs = log.outputs.copy()
    rows = rng.choice(len(outputs), size=n_outliers, replace=False)
    std = np.sqrt(np.diag(model.modes[0].measurement_noise))
    outputs[rows] += rng.choice([-1.0, 1.0], size=(n_outliers, model.n_outputs)) * sigmas * std
    signals = dataclasses.replace(log.signals(model), outputs=outputs)
    try:
        runs = {
            smooth: run_imm(
                model, signals, ImmOptions(mode_sequence="kbest", beam=5, smooth=smooth),
                store_covariances=True,
            )
            for smooth in (False, True)
        }  # fmt: skip
    except DivergenceError as error:  # the filter refuses a sample no mode explains
        assert "cannot explain the log" in str(error)
        assert sigmas >= 1e3 and n_outliers > 0  # 10 σ outliers are noise a model may meet
        return
    for result in runs.values():
        assert_filter_invariants(result)
    np.testing.assert_array_equal(runs[True].modes, runs[False].modes)
    np.testing.assert_array_equal(runs[True].state_means[-1], runs[False].state_means[-1])
    np.testing.assert_array_equal(runs[True].covariances[-1], runs[False].covariances[-1])


@pytest.mark.parametrize("name", ["three_tank_hstf", "double_cart_case1"])
def test_the_straight_line_search_takes_the_generic_loops_path(name):
    """The generated search (``generate_kbest_source``) against the generic loop it writes out:
    the same path, and the same states along it (the path's EKF is one code)."""
    model = load_model(name)
    for seed in range(3):
        signals = simulate(model, steps=400, seed=seed).signals(model)
        options = ImmOptions(mode_sequence="kbest", beam=7)
        unrolled = run_imm(model, signals, options, kernel="unrolled")
        loops = run_imm(model, signals, options, kernel="loops")
        np.testing.assert_array_equal(unrolled.modes, loops.modes)
        np.testing.assert_array_equal(unrolled.state_means, loops.state_means)


@settings(max_examples=60, deadline=None)
@given(
    weights=st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=80),
    width=st.integers(1, 12),
)
def test_the_threshold_is_the_beam_th_best_weight_found(weights, width):
    """``note_weight``: after each weight, the beam-th best so far (``-inf`` until full)."""
    best = np.empty(width)
    found = 0
    for k, weight in enumerate(weights, start=1):
        found, threshold = note_weight(weight, best, found)
        seen = sorted(weights[:k], reverse=True)
        assert found == min(k, width)
        assert threshold == (seen[width - 1] if k >= width else -math.inf)


def test_the_path_smoother_keeps_covariances_psd_without_process_noise():
    """Along one path of the double cart (no process noise, R = 1e-6) the EKF's covariances
    reach a condition of 10^9 and more; the RTS step's rounding of one step's smoothed
    covariance came back amplified at every earlier step, to variances of -3e-8 against 4e-7,
    which the estimators' check refused as a divergence (``analyze --smooth --mode-sequence
    kbest``, exit 2)."""
    from hybridlog.model.builtins import builtin_text

    text = builtin_text("double_cart_case1").replace(
        "state = [0.5, 0.0, -0.5, 0.0]", "state = [0.30446, -0.05242, -0.00088, 0.19774]"
    )
    model = parse_model(text)
    signals = simulate(model, steps=600, seed=4).signals(model)
    options = ImmOptions(mode_sequence="kbest", smooth=True)
    result = run_imm(model, signals, options, store_covariances=True)
    assert result.covariances is not None
    eigenvalues = np.linalg.eigvalsh(result.covariances)
    assert (eigenvalues[:, 0] >= -1e-11 * np.abs(eigenvalues).max(axis=1)).all()
    filtered = run_imm(model, signals, dataclasses.replace(options, smooth=False))
    # the smoothed variances are no wider than the filter's along the path (exact RTS)
    assert (result.state_variances <= filtered.state_variances * (1 + 1e-6) + 1e-15).all()


@pytest.mark.parametrize("poisoned", [(1,), (0, 1)])
def test_an_extension_whose_likelihood_is_nan_is_ruled_out_as_in_the_straight_line_code(
    poisoned,
):
    """The generic loop kept a NaN log weight as a weight: where every extension had one,
    the step kept no hypothesis, and the next read the first of an empty ranking (outside the
    array, unchecked in compiled code).  Now a NaN rules the extension out, as a failed
    Cholesky factor does and as the straight-line code already did."""
    from hybridlog.estimators.common import FilterRun
    from hybridlog.estimators.mode_hypotheses import best_history
    from hybridlog.model.compiled import compile_model

    model = parse_model(LINEAR_TWO_MODE)
    signals = simulate(model, steps=40, seed=3).signals(model)
    compiled = compile_model(model, jit=False)
    calls = [0]

    def h(mode, x, u, out):
        compiled.h(mode, x, u, out)
        calls[0] += 1
        if mode in poisoned and 200 <= calls[0] < 260:  # some steps' extensions
            out[:] = math.nan

    run = FilterRun.of(model, signals, "imm")
    log_transitions = np.log(np.array([[0.97, 0.03], [0.05, 0.95]]))  # its [transitions]
    path = best_history(compiled.f, compiled.F, h, compiled.H, run, log_transitions, 4)
    assert path.shape == (signals.n_samples,) and set(path.tolist()) <= {0, 1}
    clean = best_history(compiled.f, compiled.F, compiled.h, compiled.H, run, log_transitions, 4)
    if poisoned == (1,):  # those steps' extensions into mode 0 decide them
        assert np.mean(path == clean) > 0.8
