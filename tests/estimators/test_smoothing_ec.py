"""Expectation correction (Barber 2006), ``smoother = "ec"``: reductions, invariants, reference.

The reductions and invariants of Kim's smoother (``test_smoothing.py``) for the other backward
pass; a plain-NumPy reference (``tests/support/ec_reference.py``) on three-tank logs where the
guard, the rounding probe and the skip of negligible modes do not act; the exact posterior of
small linear logs (``test_smoothing_modes.py``); and the fallback to Kim's weights without
process noise.
"""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from hybridlog.errors import DivergenceError
from hybridlog.estimators import ec_loop, ec_source, rts_steps, smoothing
from hybridlog.estimators.common import FilterBuffers, ModeStore, contiguous, run_filter
from hybridlog.estimators.imm import CODE, ImmOptions, ImmSettings, run_imm, transition_matrix
from hybridlog.estimators.vouch import surprise_limit
from hybridlog.jit import compile_for
from hybridlog.model.compiled import compile_model
from hybridlog.model.loader import load_model, parse_model
from hybridlog.simulate import simulate
from tests.estimators.test_filter_properties import with_outliers
from tests.estimators.test_smoothing import (
    KNOWN_MODE_CASES,
    ONE_MODE,
    _filterpy_rts,
    _unforced,
    assert_smoother_invariants,
    known_mode_log,
    long_logs,  # noqa: F401 - the module-scoped fixture, shared
)
from tests.estimators.test_smoothing_modes import _log, _model, exact_posterior
from tests.support import ec_reference

EC = ImmOptions(smooth=True, smoother="ec")


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_ec_with_one_mode_equals_filterpy_rts(kernel):
    model = parse_model(ONE_MODE)
    signals = _unforced(model, 400, seed=2)
    result = run_imm(model, signals, EC, kernel=kernel, store_covariances=True)
    assert result.post_processing.smoothing == "ec-rts"
    x, P = _filterpy_rts(model, 0, signals)
    np.testing.assert_allclose(result.state_means, x, rtol=0, atol=1e-8)
    np.testing.assert_allclose(result.covariances, P, rtol=0, atol=1e-8)
    assert np.abs(result.post_processing.filtered.state_means - x).max() > 1e-3


@pytest.mark.parametrize(("true_mode", "prior"), KNOWN_MODE_CASES)
def test_ec_with_stay_one_and_known_mode_is_the_rts_of_that_mode(true_mode, prior):
    model, signals = known_mode_log(true_mode, prior)
    options = dataclasses.replace(EC, transition_stay=1.0)
    result = run_imm(model, signals, options, store_covariances=True)
    index = model.mode_ids.index(true_mode)
    x, P = _filterpy_rts(model, index, signals)
    np.testing.assert_allclose(result.state_means, x, rtol=0, atol=1e-8)
    np.testing.assert_allclose(result.covariances, P, rtol=0, atol=1e-8)
    assert (result.modes == index).all()
    np.testing.assert_array_equal(result.mode_probabilities[:, index], 1.0)


@settings(
    max_examples=3, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    model_name=st.sampled_from(["linear_two_mode", "three_tank_hstf"]),
    n_outliers=st.integers(min_value=0, max_value=200),
    sigmas=st.sampled_from([10.0, 30.0, 1e3]),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
)
@example(model_name="three_tank_hstf", n_outliers=200, sigmas=30.0, seed=38949)  # refused
def test_ec_covariances_psd_probabilities_normalised_with_outliers(
    long_logs,  # noqa: F811 - the fixture
    model_name,
    n_outliers,
    sigmas,
    seed,
):
    """10^5 steps with outliers: the smoothed probabilities sum to 1, the covariances are
    symmetric PSD, the last sample is the filter's (``assert_smoother_invariants``)."""
    model, log = long_logs[model_name]
    signals = with_outliers(model, log, n_outliers, sigmas, seed)
    try:
        result = run_imm(model, signals, EC, store_covariances=True)
    except DivergenceError as error:  # an outlier no mode explains is refused, never smoothed
        assert "cannot explain the log" in str(error)
        # refused only where the outliers alone could pass the limit (30σ on each of three
        # outputs is 52σ against 40.6), with room for the innovation the sample had anyway
        outlier = sigmas * math.sqrt(model.n_outputs)
        assert n_outliers > 0 and outlier > 0.5 * math.sqrt(surprise_limit(model.n_outputs))
        return
    assert_smoother_invariants(result)


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_ec_last_sample_is_the_filters_and_the_others_moved(kernel):
    model = load_model("three_tank_hstf")
    signals = simulate(model, steps=200, seed=11).signals(model)
    result = run_imm(model, signals, EC, kernel=kernel, store_covariances=True)
    filtered = result.post_processing.filtered
    for field in ("state_means", "covariances", "mode_probabilities", "modes"):
        np.testing.assert_array_equal(getattr(result, field)[-1], getattr(filtered, field)[-1])
    assert np.abs(result.state_means[:-1] - filtered.state_means[:-1]).max() > 1e-3


def _ec_pass(model, signals, kernel, ceilings=None):
    """The forward pass keeping the filtered store, and the compiled EC pass over it.

    Returns the store, the filter's result, the smoothed buffers (row N−1 left as allocated)
    and the pass's ``fallbacks`` (the samples where a weighted pair step's forward estimate
    stood, then by cause).
    """
    transitions = contiguous(transition_matrix(model, ImmOptions()))
    store = ModeStore.allocate(model, signals.n_samples, states=True, likelihoods=False)
    settings_ = ImmSettings(transitions, store, filtered_store=True)
    filtered = run_filter(
        CODE, model, signals, settings_, {}, jit=True, kernel=kernel, store_covariances=True
    )
    buffers = FilterBuffers.allocate(model, signals.n_samples, store_covariances=True)
    compiled = compile_model(model)
    arguments = (
        compiled.f,
        compiled.F,
        contiguous(signals.inputs),
        transitions,
        contiguous(np.stack([m.process_noise for m in model.modes])),
        ec_loop.positive_definite_noise(model),
        ec_loop.density_ceilings(model) if ceilings is None else ceilings,
        filtered.mode_probabilities,
        store,
        buffers,
        np.zeros(rts_steps.FALLBACKS_WIDTH, dtype=np.int64),
    )
    compile_for(ec_loop.ec_backward, arguments)(*arguments)
    return store, filtered, buffers, arguments[-1]


@settings(max_examples=300, deadline=None)
@given(
    n=st.integers(1, 4),
    seed=st.integers(0, 2**32 - 1),
    scale=st.sampled_from([1e-6, 1e-2, 1.0, 1e3, 1e6]),
    rank=st.integers(0, 4),
)
def test_the_density_ceiling_bounds_every_pair_density(n, seed, scale, rank):
    """``log N(x; m, F P Fᵀ + Q) <= density_ceiling(Q)`` for any ``F``, PSD ``P`` (singular too)
    and ``x``, the bound by which expectation correction leaves pairs out: at its largest
    (``x = m``) the density is within the margin of it only when ``F P Fᵀ`` is 0."""
    rng = np.random.default_rng(seed)
    root = rng.normal(size=(n, n)) * scale
    Q = root @ root.T + 1e-3 * scale**2 * np.eye(n)
    F = rng.normal(size=(n, n)) * rng.choice([0.0, 1e-3, 1.0, 10.0])
    A = rng.normal(size=(n, min(rank, n))) * scale
    S = F @ (A @ A.T) @ F.T + Q
    ceiling = ec_loop.density_ceiling(Q)
    sign, log_det = np.linalg.slogdet(S)
    assert sign > 0
    peak = -0.5 * (n * math.log(2 * math.pi) + log_det)
    assert peak <= ceiling - ec_loop.CEILING_MARGIN + 1e-9 * max(1.0, abs(peak))
    assert ec_loop.density_ceiling(np.zeros((n, n))) == math.inf


@pytest.mark.parametrize("outliers", [False, True])
def test_ec_pairs_left_out_unpredicted_change_nothing(outliers):
    """The generic pass with the density ceilings (pairs whose weight cannot reach
    ``NEGLIGIBLE_WEIGHT`` not predicted) against the same pass predicting every pair (ceilings
    ``+inf``): the same smoothed result to rounding, but for what weighs below
    ``n_q² NEGLIGIBLE_WEIGHT`` (probabilities of 1e-38 move), the same fallbacks."""
    model = load_model("three_tank_hstf")
    signals = simulate(model, steps=400, seed=5).signals(model)
    if outliers:
        outputs = signals.outputs.copy()
        outputs[150:160] += 25.0 * np.sqrt(np.diag(model.modes[0].measurement_noise))
        signals = dataclasses.replace(signals, outputs=outputs)
    _, _, bounded, bounded_fallbacks = _ec_pass(model, signals, "unrolled")
    every = np.full(model.n_modes, math.inf)
    _, _, full, full_fallbacks = _ec_pass(model, signals, "unrolled", ceilings=every)
    for field in ("state_means", "covariances", "mode_probabilities"):
        a, b = getattr(bounded, field)[:-1], getattr(full, field)[:-1]
        tolerance = model.n_modes**2 * rts_steps.NEGLIGIBLE_WEIGHT * np.abs(b).max()
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=tolerance, err_msg=field)
    np.testing.assert_array_equal(bounded_fallbacks, full_fallbacks)
    # a bound that is wrong (every pair but the stay left out) shows: the comparison can fail
    _, _, wrong, _ = _ec_pass(
        model, signals, "unrolled", ceilings=np.full(model.n_modes, -math.inf)
    )
    assert np.abs(wrong.mode_probabilities[:-1] - full.mode_probabilities[:-1]).max() > 1e-3


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ec_equals_the_numpy_reference_on_three_tank_logs(seed):
    """Forward store and backward pass against ``tests/support/ec_reference.py`` (moved from the
    prototype of docs/studies/smoothing_ec.py), on logs where no guard or probe acts."""
    model = load_model("three_tank_hstf")
    assert ec_loop.positive_definite_noise(model).all()
    signals = simulate(model, steps=150, seed=seed).signals(model)
    T = transition_matrix(model, ImmOptions())
    forward = ec_reference.imm_forward(model, signals, T)
    mu, x, P = ec_reference.smoothed(model, signals, T, forward)
    kim_mu, _, _ = ec_reference.smoothed(model, signals, T, forward, corrected=False)
    assert np.abs(mu - kim_mu).max() > 1e-3  # the correction changed something
    for kernel in ("unrolled", "loops"):
        store, filtered, buffers, fallbacks = _ec_pass(model, signals, kernel)
        assert not fallbacks.any()  # no guard, no rounding probe, no prediction without a factor
        scale = np.abs(forward[0]).max()
        np.testing.assert_allclose(store.means, forward[0], rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(store.covariances, forward[1], rtol=0, atol=1e-12)
        np.testing.assert_allclose(filtered.mode_probabilities, forward[2], rtol=0, atol=1e-12)
        rows = slice(0, signals.n_samples - 1)
        np.testing.assert_allclose(buffers.mode_probabilities[rows], mu[rows], rtol=0, atol=1e-9)
        np.testing.assert_allclose(buffers.state_means[rows], x[rows], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(buffers.covariances[rows], P[rows], rtol=1e-9, atol=1e-9)
        result = run_imm(model, signals, EC, kernel=kernel, store_covariances=True)
        np.testing.assert_allclose(result.mode_probabilities, mu, rtol=0, atol=1e-9)
        np.testing.assert_allclose(result.state_means, x, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_ec_is_exact_on_a_markov_chain_with_gaussian_emissions(kernel):
    """With ``A = 0`` the density of the next state is the same under every ``q(k)`` and the
    RTS gain is 0: EC is the exact forward-backward smoother, as Kim's is."""
    A = (0.0, 0.0)
    model = _model(A)
    for seed in range(4):
        signals = _log(A, seed)
        result = run_imm(model, signals, EC, kernel=kernel, store_covariances=True)
        _, smoothed, mean, variance, _ = exact_posterior(
            A, signals.inputs[:, 0], signals.outputs[:, 0]
        )
        np.testing.assert_allclose(result.mode_probabilities, smoothed, rtol=0, atol=1e-12)
        np.testing.assert_allclose(result.state_means[:, 0], mean, rtol=0, atol=1e-12)
        np.testing.assert_allclose(result.covariances[:, 0, 0], variance, rtol=0, atol=1e-12)


def test_ec_is_nearer_the_exact_posterior_than_kims_with_memory():
    """A state with memory (``A = (0.9, 0.6)``), 20 logs of 9 samples: measured when written,
    EC's summed distance of the smoothed mode probabilities to the exact ones was 1.68 against
    Kim's 14.83 (the filter's 28.68), nearer on each of the 20 logs, and its smoothed means'
    0.87 against Kim's 4.24; asserted with margin."""
    A = (0.9, 0.6)
    model = _model(A)
    distances = {"kim": [], "ec": []}
    mean_distances = {"kim": 0.0, "ec": 0.0}
    for seed in range(20):
        signals = _log(A, seed)
        _, smoothed, mean, _, _ = exact_posterior(A, signals.inputs[:, 0], signals.outputs[:, 0])
        for name in distances:
            options = ImmOptions(smooth=True, smoother=name)
            result = run_imm(model, signals, options, kernel="loops")
            distances[name].append(np.abs(result.mode_probabilities - smoothed).sum())
            mean_distances[name] += np.abs(result.state_means[:, 0] - mean).sum()
    kim, ec = np.array(distances["kim"]), np.array(distances["ec"])
    assert ec.sum() < 0.25 * kim.sum()
    assert (ec < kim).sum() >= 18
    assert mean_distances["ec"] < 0.5 * mean_distances["kim"]


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_ec_without_process_noise_takes_kims_mode_weights(kernel):
    """The double cart has ``Q = 0``: the density of the smoothed state under ``F P_i Fᵀ`` is
    nearly singular and would decide by rounding, so each next mode takes Kim's weights: the
    smoothed mode probabilities are Kim's (its generic loop: bit for bit)."""
    model = load_model("double_cart_case1")
    assert not ec_loop.positive_definite_noise(model).any()
    signals = simulate(model, steps=600, seed=0).signals(model)
    ec = run_imm(model, signals, EC, kernel=kernel, store_covariances=True)
    kim = run_imm(model, signals, ImmOptions(smooth=True, smoother="kim"), kernel="loops")
    if kernel == "loops":
        np.testing.assert_array_equal(ec.mode_probabilities, kim.mode_probabilities)
    else:  # the forward pass's straight-line code: equal to rounding
        np.testing.assert_allclose(ec.mode_probabilities, kim.mode_probabilities, atol=1e-9)
    np.testing.assert_array_equal(ec.modes, kim.modes)
    assert_smoother_invariants(ec)
    # the states are EC's own (pairwise steps from the filtered estimates), and bounded
    assert np.abs(ec.state_means - kim.state_means).max() > 0.0
    assert np.abs(ec.state_means).max() < 10 * np.abs(ec.post_processing.filtered.state_means).max()


def test_ec_with_kbest_names_both_passes():
    model = load_model("three_tank_hstf")
    signals = simulate(model, steps=120, seed=1).signals(model)
    options = dataclasses.replace(EC, mode_sequence="kbest", beam=4)
    result = run_imm(model, signals, options)
    assert result.post_processing.smoothing == "ec-rts+path-rts"
    assert "mode probabilities: expectation correction" in result.post_processing.description
    alone = run_imm(model, signals, EC)
    np.testing.assert_array_equal(result.mode_probabilities, alone.mode_probabilities)
    assert "Barber 2006" in alone.post_processing.description


def test_smoother_without_smooth_is_inert():
    model = load_model("three_tank_hstf")
    assert "smoother" in ImmOptions(smoother="ec").inert(model)
    assert "smoother" not in EC.inert(model)


@pytest.mark.parametrize("name", ["three_tank_hstf", "double_cart_case1", "outliers"])
def test_ec_straight_line_equals_the_generic_loop(name):
    """The generated pass (``generate_ec_smoother_source``) against ``ec_backward``: a
    three-tank log, the double cart (Kim's weights, the guard acting), and outliers that send
    filtered probabilities to zero (log-space edge cases)."""
    model = load_model("double_cart_case1" if name == "double_cart_case1" else "three_tank_hstf")
    signals = simulate(model, steps=500, seed=3).signals(model)
    if name == "outliers":
        outputs = signals.outputs.copy()
        outputs[200:215] += 30.0 * np.sqrt(np.diag(model.modes[0].measurement_noise))
        signals = dataclasses.replace(signals, outputs=outputs)
    fast = run_imm(model, signals, EC, kernel="unrolled", store_covariances=True)
    plain = run_imm(model, signals, EC, kernel="loops", store_covariances=True)
    if name == "outliers":
        assert (plain.post_processing.filtered.mode_probabilities == 0.0).any()
    for field in ("state_means", "covariances", "mode_probabilities"):
        a, b = getattr(fast, field), getattr(plain, field)
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * np.abs(b).max(), err_msg=field)
    np.testing.assert_array_equal(fast.modes, plain.modes)
    assert np.abs(fast.state_means - fast.post_processing.filtered.state_means).max() > 1e-6
    fallbacks = plain.post_processing.fallbacks  # the same samples fell back on both paths
    assert dataclasses.replace(fast.post_processing.fallbacks, weight=fallbacks.weight) == fallbacks
    assert fast.post_processing.fallbacks.weight == pytest.approx(fallbacks.weight, rel=1e-9)
    if name == "double_cart_case1":
        assert fallbacks.samples > 0 and fallbacks.by_cause["guard"] > 0


def test_kims_recursion_is_what_smooth_runs_by_default_and_ec_is_asked_for():
    """``--smooth`` runs Kim's recursion; expectation correction is ``smoother = "ec"`` (its
    straight-line code compiles in about a minute where Kim's takes seconds)."""
    assert ImmOptions().smoother == "kim"
    model = load_model("three_tank_hstf")
    signals = simulate(model, steps=60, seed=1).signals(model)
    default = run_imm(model, signals, ImmOptions(smooth=True))
    assert default.post_processing.smoothing == "kim-rts"
    kim = run_imm(model, signals, ImmOptions(smooth=True, smoother="kim"))
    np.testing.assert_array_equal(default.state_means, kim.state_means)
    assert run_imm(model, signals, EC).post_processing.smoothing == "ec-rts"


def test_a_model_of_many_modes_runs_the_generic_expectation_correction():
    """Straight-line expectation correction grows with the pairs of modes: 5 modes compiled
    for minutes, 8 overflowed the recursion limit.  Past MAX_EC_UNROLLED_MODES ``auto``
    runs the generic loop (Kim's keeps the filters' rule; ``unrolled`` is obeyed)."""

    def model_of(count):
        modes = "\n".join(
            f"[modes.m{i}]\nA = [[{0.9 - 0.05 * i}]]\nB = [[0.1]]\nC = [[1.0]]\n"
            for i in range(count)
        )
        return parse_model(
            'name = "many"\ndt = 0.1\nstates = ["p"]\ninputs = ["a"]\noutputs = ["y"]\n'
            f"{modes}\n[noise]\nprocess = 0.001\nmeasurement = 0.01\n"
            "[initial]\nstate = [0.0]\ncovariance = 1.0\n"
            '[simulation]\nstate = [0.0]\nschedule = "m0:30,m3:30,m1:30"\n'
            '[simulation.inputs]\na = "sin(0.7*t)"\n'
        )

    limit = ec_source.MAX_EC_UNROLLED_MODES
    many, few = model_of(limit + 1), model_of(limit)
    straight = smoothing.straight_line_backward
    assert not straight(many, "auto", ec=True)
    assert straight(few, "auto", ec=True)
    assert straight(many, "auto", ec=False) and straight(many, "unrolled", ec=True)
    assert not straight(few, "loops", ec=True)
    result = run_imm(many, simulate(many, steps=90, seed=1).signals(many), EC)
    assert result.post_processing.smoothing == "ec-rts"
    assert np.isfinite(result.state_means).all()
