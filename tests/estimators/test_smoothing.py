"""The IMM's offline passes (issue 12): the Kim smoother and the Viterbi mode sequence."""

import dataclasses
import itertools

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hybridlog.errors import DivergenceError
from hybridlog.estimators import kim_loop, smoothing
from hybridlog.estimators.common import ModeStore, packed_width, run_filter
from hybridlog.estimators.imm import (
    CODE,
    ImmOptions,
    ImmSettings,
    pack_state,
    run_imm,
    transition_matrix,
)
from hybridlog.estimators.result import Fallbacks
from hybridlog.estimators.rts_steps import unpack_state
from hybridlog.estimators.viterbi_path import viterbi
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.model.loader import load_model, parse_model
from hybridlog.simulate import simulate
from tests.estimators.test_filter_properties import assert_filter_invariants, with_outliers
from tests.estimators.test_reductions import _linear_matrices
from tests.support.models import LINEAR_TWO_MODE
from tests.support.paths import TANK_CSV

ONE_MODE = LINEAR_TWO_MODE.replace(
    """[modes.fast]
A = [[1.0, 0.1], [-0.3, 0.7]]
B = [[0.0], [0.2]]
C = [[1.0, 0.0], [0.5, 2.0]]
process_noise = [[0.02, 0.005], [0.005, 0.03]]
""",
    "",
).replace("mode_probabilities = [0.6, 0.4]", "mode_probabilities = [1.0]")
ONE_MODE = ONE_MODE.replace("matrix = [[0.97, 0.03], [0.05, 0.95]]", "matrix = [[1.0]]")
ONE_MODE = ONE_MODE.replace(
    'schedule = "slow:120,fast:80,slow:150,fast:150"', 'schedule = "slow:300"'
)


def _unforced(model, steps, seed):
    """A simulated log with its inputs replaced by zeros (FilterPy's RTS has no ``B u``)."""
    log = simulate(model, steps=steps, seed=seed)
    signals = log.signals(model)
    return dataclasses.replace(signals, inputs=np.zeros_like(signals.inputs))


def _filterpy_rts(model, mode_index, signals, *, smoothed=True):
    """FilterPy's Kalman filter and ``rts_smoother`` on one linear mode (hybridlog's rows).

    ``smoothed=False``: the filter's own ``x̂(k|k)``, ``P(k|k)`` instead.
    """
    A, _, C = _linear_matrices(model, mode_index)
    mode = model.modes[mode_index]
    kf = KalmanFilter(dim_x=model.n_states, dim_z=model.n_outputs)
    kf.F, kf.H = A, C
    kf.Q, kf.R = mode.process_noise.copy(), mode.measurement_noise.copy()
    kf.x = model.initial_state.copy()
    kf.P = model.initial_covariance.copy()
    means, covariances = [kf.x.copy()], [kf.P.copy()]
    for k in range(1, signals.n_samples):
        kf.predict()
        kf.update(signals.outputs[k])
        means.append(kf.x.copy())
        covariances.append(kf.P.copy())
    if not smoothed:
        return np.array(means), np.array(covariances)
    n = signals.n_samples
    x, P, _, _ = kf.rts_smoother(np.array(means), np.array(covariances), [A] * n, [kf.Q] * n)
    return x, P


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_one_mode_smoother_equals_filterpy_rts(kernel):
    model = parse_model(ONE_MODE)
    assert model.n_modes == 1
    signals = _unforced(model, 400, seed=2)
    result = run_imm(
        model,
        signals,
        ImmOptions(smooth=True, smoother="kim"),
        kernel=kernel,
        store_covariances=True,
    )
    x, P = _filterpy_rts(model, 0, signals)
    np.testing.assert_allclose(result.state_means, x, rtol=0, atol=1e-8)
    np.testing.assert_allclose(result.covariances, P, rtol=0, atol=1e-8)
    np.testing.assert_allclose(result.state_variances, np.diagonal(P, axis1=1, axis2=2), atol=1e-8)
    # The smoother changed the estimates (the test would not notice a copy of the filter's).
    filtered = result.post_processing.filtered
    assert np.abs(filtered.state_means - x).max() > 1e-3


KNOWN_MODE_CASES = [("slow", [1.0, 0.0]), ("fast", [0.0, 1.0])]
"""The true mode of a whole log and the prior that puts all weight on it."""


def known_mode_log(true_mode, prior):
    """The linear two-mode model with that prior, and a 300-sample log in that one mode."""
    text = LINEAR_TWO_MODE.replace(
        "mode_probabilities = [0.6, 0.4]", f"mode_probabilities = {prior}"
    )
    text = text.replace('"slow:120,fast:80,slow:150,fast:150"', f'"{true_mode}:300"')
    model = parse_model(text)
    return model, _unforced(model, 300, seed=4)


@pytest.mark.parametrize(("true_mode", "prior"), KNOWN_MODE_CASES)
def test_two_modes_with_stay_one_and_known_mode_is_the_rts_of_that_mode(true_mode, prior):
    model, signals = known_mode_log(true_mode, prior)
    result = run_imm(
        model,
        signals,
        ImmOptions(transition_stay=1.0, smooth=True, smoother="kim"),
        store_covariances=True,
    )
    index = model.mode_ids.index(true_mode)
    x, P = _filterpy_rts(model, index, signals)
    np.testing.assert_allclose(result.state_means, x, rtol=0, atol=1e-8)
    np.testing.assert_allclose(result.covariances, P, rtol=0, atol=1e-8)
    assert (result.modes == index).all()
    np.testing.assert_array_equal(result.mode_probabilities[:, index], 1.0)


STEPS = 100_000


@pytest.fixture(scope="module")
def long_logs():
    logs = {}
    for name, model in (
        ("three_tank_hstf", load_model("three_tank_hstf")),
        ("linear_two_mode", parse_model(LINEAR_TWO_MODE)),
    ):
        logs[name] = (model, simulate(model, steps=STEPS - 1, seed=5))
    return logs


def assert_smoother_invariants(result):
    """Filter invariants on the smoothed result, and the last sample is the filter's."""
    assert_filter_invariants(result)
    filtered = result.post_processing.filtered
    assert_filter_invariants(filtered)
    np.testing.assert_array_equal(result.state_means[-1], filtered.state_means[-1])
    np.testing.assert_array_equal(result.covariances[-1], filtered.covariances[-1])
    np.testing.assert_array_equal(result.mode_probabilities[-1], filtered.mode_probabilities[-1])
    np.testing.assert_array_equal(result.output_predictions, filtered.output_predictions)


@settings(
    max_examples=3, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    model_name=st.sampled_from(["linear_two_mode", "three_tank_hstf"]),
    n_outliers=st.integers(min_value=0, max_value=200),
    sigmas=st.sampled_from([10.0, 1e3, 1e6]),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
)
def test_smoothed_covariances_psd_probabilities_normalised_with_outliers(
    long_logs, model_name, n_outliers, sigmas, seed
):
    model, log = long_logs[model_name]
    signals = with_outliers(model, log, n_outliers, sigmas, seed)
    try:
        result = run_imm(
            model,
            signals,
            ImmOptions(smooth=True, smoother="kim", mode_sequence="viterbi"),
            store_covariances=True,
        )
    except DivergenceError as error:  # an outlier no mode explains is refused, never smoothed
        assert "cannot explain the log" in str(error)
        assert sigmas >= 1e3 and n_outliers > 0  # 10 σ outliers are noise a model may meet
        return
    assert_smoother_invariants(result)


def test_a_burst_of_outliers_no_mode_explains_is_refused_at_its_first_sample(long_logs):
    model, log = long_logs["three_tank_hstf"]
    outputs = log.outputs.copy()
    outputs[1000:1020] += 1e6 * np.sqrt(np.diag(model.modes[0].measurement_noise))
    signals = dataclasses.replace(log.signals(model), outputs=outputs)
    for options in (ImmOptions(smooth=True, smoother="kim"), ImmOptions(mode_sequence="viterbi")):
        with pytest.raises(
            DivergenceError, match=r"cannot explain the log at t = .*\(sample 1000\)"
        ):
            run_imm(model, signals, options)


def test_smoother_invariants_with_a_burst_of_outliers(long_logs):
    model, log = long_logs["three_tank_hstf"]
    outputs = log.outputs.copy()
    outputs[1000:1020] += 20.0 * np.sqrt(np.diag(model.modes[0].measurement_noise))
    signals = dataclasses.replace(log.signals(model), outputs=outputs)
    result = run_imm(
        model, signals, ImmOptions(smooth=True, smoother="kim"), store_covariances=True
    )
    assert_smoother_invariants(result)
    # Smoothing is offline: away from the burst, the smoothed modes are at least as right.
    truth = log.modes
    smoothed = np.mean(result.modes[2000:] == truth[2000:])
    filtered = np.mean(result.post_processing.filtered.modes[2000:] == truth[2000:])
    assert smoothed >= filtered


def _brute_force(log_T, log_prior, log_likelihoods):
    n_samples, n_q = log_likelihoods.shape
    best, best_path = -np.inf, None
    for path in itertools.product(range(n_q), repeat=n_samples):
        score = log_prior[path[0]] + sum(
            log_T[path[k - 1], path[k]] + log_likelihoods[k, path[k]] for k in range(1, n_samples)
        )
        if score > best:
            best, best_path = score, path
    return best, best_path


def _score(path, log_T, log_prior, log_likelihoods):
    return log_prior[path[0]] + sum(
        log_T[path[k - 1], path[k]] + log_likelihoods[k, path[k]] for k in range(1, len(path))
    )


@settings(max_examples=60, deadline=None)
@given(
    n_q=st.integers(min_value=1, max_value=3),
    n_samples=st.integers(min_value=1, max_value=6),
    seed=st.integers(min_value=0, max_value=2**32 - 1),
    forbid=st.booleans(),
)
def test_viterbi_equals_brute_force_enumeration(n_q, n_samples, seed, forbid):
    rng = np.random.default_rng(seed)
    T = rng.dirichlet(np.ones(n_q), size=n_q)
    if forbid and n_q > 1:
        T[0, 1] = 0.0  # an impossible transition
        T[0] /= T[0].sum()
    with np.errstate(divide="ignore"):
        log_T = np.log(T)
        log_prior = np.log(rng.dirichlet(np.ones(n_q)))
    log_likelihoods = rng.normal(scale=3.0, size=(n_samples, n_q))
    path = viterbi(log_T, log_prior, log_likelihoods)
    best, best_path = _brute_force(log_T, log_prior, log_likelihoods)
    assert _score(path, log_T, log_prior, log_likelihoods) == pytest.approx(best, abs=1e-9)
    assert tuple(path.tolist()) == best_path  # continuous random scores: no ties


def test_imm_viterbi_modes_are_a_path_of_the_chain():
    """With a forbidden transition, the Viterbi modes never take it; the argmax modes may."""
    text = LINEAR_TWO_MODE.replace("[[0.97, 0.03], [0.05, 0.95]]", "[[0.97, 0.03], [0.0, 1.0]]")
    text = text.replace('"slow:120,fast:80,slow:150,fast:150"', '"slow:150,fast:150"')
    model = parse_model(text)
    signals = simulate(model, steps=300, seed=8).signals(model)
    result = run_imm(model, signals, ImmOptions(mode_sequence="viterbi"))
    pp = result.post_processing
    assert pp.smoothing is None and pp.mode_sequence == "viterbi"
    fast, slow = model.mode_ids.index("fast"), model.mode_ids.index("slow")
    back = (result.modes[:-1] == fast) & (result.modes[1:] == slow)
    assert not back.any()
    # Without smoothing only the modes change.
    np.testing.assert_array_equal(result.state_means, pp.filtered.state_means)
    assert np.mean(result.modes == signals.truth_modes) > 0.9


def test_without_the_options_the_result_is_the_filters():
    model = parse_model(LINEAR_TWO_MODE)
    signals = simulate(model, steps=200, seed=1).signals(model)
    result = run_imm(model, signals, ImmOptions())
    assert result.post_processing is None
    assert result.options["smooth"] is False and result.options["mode_sequence"] == "argmax"
    smoothed = run_imm(model, signals, ImmOptions(smooth=True, smoother="kim"))
    assert smoothed.options["smooth"] is True
    assert smoothed.post_processing.smoothing == "kim-rts"
    assert smoothed.post_processing.mode_sequence == "argmax"
    np.testing.assert_array_equal(smoothed.post_processing.filtered.state_means, result.state_means)
    np.testing.assert_array_equal(smoothed.modes, np.argmax(smoothed.mode_probabilities, axis=1))


def test_smoother_stays_bounded_without_process_noise():
    """Regression: with Q = 0, mixing the modes' hypotheses once widened the estimate at every
    step backwards (through F⁻¹) until the states reached 1e29; the guard stops it."""
    model = load_model("double_cart_case1")
    assert not model.modes[0].process_noise.any()
    log = simulate(model, steps=600, seed=0)
    signals = log.signals(model)
    result = run_imm(
        model, signals, ImmOptions(smooth=True, smoother="kim"), store_covariances=True
    )
    assert_smoother_invariants(result)

    def rmse(means):
        return np.sqrt(np.mean((means[1:] - log.states[1:]) ** 2))

    assert rmse(result.state_means) <= 2 * rmse(result.post_processing.filtered.state_means)


@pytest.mark.parametrize("name", ["three_tank_hstf", "double_cart_case1"])
def test_straight_line_smoother_equals_the_generic_loop(name):
    model = load_model(name)
    signals = simulate(model, steps=500, seed=3).signals(model)
    options = ImmOptions(smooth=True, smoother="kim")
    fast = run_imm(model, signals, options, kernel="unrolled", store_covariances=True)
    plain = run_imm(model, signals, options, kernel="loops", store_covariances=True)
    for field in ("state_means", "covariances", "mode_probabilities"):
        a, b = getattr(fast, field), getattr(plain, field)
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * np.abs(b).max(), err_msg=field)
    np.testing.assert_array_equal(fast.modes, plain.modes)
    assert np.abs(fast.state_means - fast.post_processing.filtered.state_means).max() > 1e-6
    # the samples where a step fell back to the forward estimate: the same on both paths,
    # and on the double cart (no process noise) the guard refuses steps
    fallbacks = plain.post_processing.fallbacks
    assert dataclasses.replace(fast.post_processing.fallbacks, weight=fallbacks.weight) == fallbacks
    assert fast.post_processing.fallbacks.weight == pytest.approx(fallbacks.weight, rel=1e-9)
    assert fallbacks.of == signals.n_samples - 1
    if name == "double_cart_case1":
        assert fallbacks.samples > 0 and fallbacks.by_cause["guard"] > 0


def test_fallbacks_of_the_sample_log_are_the_one_step_the_guard_refuses():
    """The three-tank sample log: one step refused, the guard's at sample 1 (next mode 1,
    smoothed probability 0.08; the prior's width is in the mixed prior of sample 1); the
    negligible next modes skipped on 45 % of the samples are not counted.  Without the count
    nothing said that part of that sample's "smoothed" estimate is the filter's."""
    model = load_model("three_tank_hstf")
    signals = load_signals(TANK_CSV, SignalSpec.of(model), ReadOptions())
    expected = Fallbacks(1, 300, {"prediction": 0, "guard": 1, "rounding": 0, "covariance": 0})
    for kernel in ("unrolled", "loops"):
        result = run_imm(model, signals, ImmOptions(smooth=True, smoother="kim"), kernel=kernel)
        fallbacks = result.post_processing.fallbacks
        assert dataclasses.replace(fallbacks, weight=0.0) == expected
        # the refused step's weight: next mode index 1's smoothed probability at sample 2,
        # over the 300 samples smoothed
        refused = result.mode_probabilities[2, 1]
        assert 0.05 < refused < 0.1 and fallbacks.weight == pytest.approx(refused / 300, rel=1e-9)
        ec = run_imm(model, signals, ImmOptions(smooth=True, smoother="ec"), kernel=kernel)
        assert ec.post_processing.fallbacks.samples == 0
    kbest = ImmOptions(smooth=True, smoother="kim", mode_sequence="kbest", beam=4)
    assert run_imm(model, signals, kbest, jit=False).post_processing.fallbacks.samples == 0
    for unsmoothed in (ImmOptions(mode_sequence="viterbi"), ImmOptions(mode_sequence="kbest")):
        assert run_imm(model, signals, unsmoothed).post_processing.fallbacks is None


@pytest.mark.parametrize("n", [1, 2, 3, 6])
def test_mode_store_record_round_trips(n):
    """A packed record (mean, then the covariance's upper triangle) gives back x and P exactly."""
    rng = np.random.default_rng(n)
    x = rng.normal(size=n)
    A = rng.normal(size=(n, n))
    P = A @ A.T
    record = np.full(packed_width(n), np.nan)
    pack_state(x, P, record)
    assert np.isfinite(record).all()
    x_back, P_back = np.empty(n), np.empty((n, n))
    unpack_state(record, x_back, P_back)
    np.testing.assert_array_equal(x_back, x)
    np.testing.assert_array_equal(P_back, P)
    store = ModeStore(record.reshape(1, 1, -1), np.empty((0, 1)))
    assert store.n_states == n
    np.testing.assert_array_equal(store.means[0, 0], x)
    np.testing.assert_array_equal(store.covariances[0, 0], P)


def test_both_forward_code_paths_write_the_same_store():
    """The straight-line and the generic IMM write the same packed records; the last row holds
    the mode-matched filtered estimates, whose mixture is the filter's last estimate."""
    model = load_model("three_tank_hstf")
    signals = simulate(model, steps=300, seed=6).signals(model)
    transitions = np.ascontiguousarray(transition_matrix(model, ImmOptions()), dtype=float)
    stores, results = [], []
    for kernel in ("unrolled", "loops"):
        store = ModeStore.allocate(model, signals.n_samples, states=True, likelihoods=True)
        settings = ImmSettings(transitions, store)
        results.append(
            run_filter(
                CODE, model, signals, settings, {}, jit=True, kernel=kernel, store_covariances=True
            )
        )
        stores.append(store)
    fast, plain = stores
    assert fast.states.shape == (signals.n_samples, model.n_modes, packed_width(model.n_states))
    scale = np.abs(plain.states).max()
    np.testing.assert_allclose(fast.states, plain.states, rtol=1e-12, atol=1e-13 * scale)
    np.testing.assert_allclose(fast.log_likelihoods, plain.log_likelihoods, rtol=1e-12)
    for store, result in zip(stores, results, strict=True):
        mu = result.mode_probabilities[-1]
        x_j, P_j = store.means[-1], store.covariances[-1]
        x = mu @ x_j
        spread = x_j - x
        P = np.einsum("j,jab->ab", mu, P_j + spread[:, :, None] * spread[:, None, :])
        np.testing.assert_allclose(x, result.state_means[-1], rtol=1e-12)
        np.testing.assert_allclose(P, result.covariances[-1], rtol=1e-12, atol=1e-15)


def test_straight_line_smoother_equals_the_generic_loop_where_probabilities_underflow():
    """Outliers drive filtered mode probabilities to 0 and below 1e-280: the straight-line
    pass then takes its log-space branch (its linear branch elsewhere); both equal the loop.
    (30 σ: far enough to rule modes out, near enough for the filter to explain; 1e4 σ is a
    sample no mode explains, refused by the filter, test_a_burst_of_outliers_no_mode_...)"""
    model = load_model("three_tank_hstf")
    signals = simulate(model, steps=1500, seed=7).signals(model)
    outputs = signals.outputs.copy()
    outputs[400:420] += 30.0 * np.sqrt(np.diag(model.modes[0].measurement_noise))
    signals = dataclasses.replace(signals, outputs=outputs)
    options = ImmOptions(smooth=True, smoother="kim")
    fast = run_imm(model, signals, options, kernel="unrolled", store_covariances=True)
    plain = run_imm(model, signals, options, kernel="loops", store_covariances=True)
    filtered = plain.post_processing.filtered.mode_probabilities
    assert (filtered == 0.0).any() and ((filtered > 0.0) & (filtered < 1e-280)).any()
    for field in ("state_means", "covariances", "mode_probabilities"):
        a, b = getattr(fast, field), getattr(plain, field)
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * np.abs(b).max(), err_msg=field)
    np.testing.assert_array_equal(fast.modes, plain.modes)


def test_skipping_negligible_next_modes_changes_nothing(monkeypatch):
    """The RTS step of a next mode whose smoothed probability is below NEGLIGIBLE_WEIGHT is
    skipped; its result would enter the output with that weight only.  Against the same pass
    taking every step (the plain-Python loop, the threshold set to 0), on a log where a third
    of the steps are skipped, both code paths agree to rounding."""
    model = load_model("three_tank_hstf")
    signals = simulate(model, steps=300, seed=2).signals(model)
    options = ImmOptions(smooth=True, smoother="kim")
    skipping = run_imm(model, signals, options, kernel="unrolled", store_covariances=True)
    looped = run_imm(model, signals, options, jit=False, kernel="loops", store_covariances=True)
    monkeypatch.setattr(kim_loop, "NEGLIGIBLE_WEIGHT", 0.0)
    every = run_imm(model, signals, options, jit=False, kernel="loops", store_covariances=True)
    skipped = (every.mode_probabilities[1:] < 1e-30).mean()
    assert skipped > 0.2, skipped
    for field in ("state_means", "covariances", "mode_probabilities"):
        b = getattr(every, field)
        for result in (skipping, looped):
            a = getattr(result, field)
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * np.abs(b).max(), err_msg=field)
    np.testing.assert_array_equal(skipping.modes, every.modes)


SIX_STATES = """
name = "six_states"
dt = 0.1
states = ["x1", "x2", "x3", "x4", "x5", "x6"]
inputs = ["u"]
outputs = ["y1", "y2"]

[modes.only]
f = ["0.9*x1 + 0.1*x2", "0.9*x2 + 0.1*u", "0.9*x3 + 0.1*x4", "0.9*x4 - 0.1*x3",
     "0.8*x5 + 0.1*x6", "0.8*x6 + 0.1*x1"]
h = ["x1", "x3 + x5"]

[noise]
process = 0.01
measurement = 0.01

[initial]
state = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
covariance = 1.0

[simulation]
state = [1.0, 0.5, -1.0, 0.5, 1.0, -0.5]

[simulation.inputs]
u = "sin(t)"
"""


@pytest.mark.parametrize("smoother", ["kim", "ec"])
def test_straight_line_smoother_of_six_states_compiles_and_equals_the_generic_loop(smoother):
    """A step's values travel as one tuple bound in each branch (``bind``): with 6 states that
    is 6 + 21 + 6 = 33 entries, past the 30 CPython writes as one tuple display (longer ones are
    built through a list), and numba's rewrite of that list refused a name assigned in two
    branches: an ``AssertionError`` compiling the pass of every 6-state model, to which
    ``auto`` gives straight-line code (``MAX_UNROLLED_SIZE``).  Both passes on one forward
    store."""
    model = parse_model(SIX_STATES)
    assert smoothing.straight_line_backward(model, "auto", ec=smoother == "ec")
    signals = simulate(model, steps=40, seed=0).signals(model)
    transitions = np.ascontiguousarray(transition_matrix(model, ImmOptions()), dtype=float)
    store = ModeStore.allocate(model, signals.n_samples, states=True, likelihoods=False)
    filtered = run_filter(
        CODE, model, signals, ImmSettings(transitions, store, smoother == "ec"), {}, jit=True,
        kernel="loops", store_covariances=True,
    )  # fmt: skip
    options = {"smooth": True, "smoother": smoother, "mode_sequence": "argmax", "jit": True}
    fast, plain = [
        smoothing.post_process(model, signals, filtered, store, transitions, **options, kernel=k)
        for k in ("unrolled", "loops")
    ]
    for field in ("state_means", "covariances"):
        a, b = getattr(fast, field), getattr(plain, field)
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * np.abs(b).max(), err_msg=field)
    assert np.abs(plain.state_means - filtered.state_means).max() > 1e-3
