"""The three code paths of each filter compute the same thing.

``unrolled`` (the filter's accelerator: straight-line code generated per model) is what runs
by default where it applies; ``loops`` (generic compiled loops) serves large models;
``jit=False`` runs the generic loops as plain Python on plain-Python mode functions.
"""

import importlib
import pkgutil

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import hybridlog.estimators
from hybridlog.errors import ModelError
from hybridlog.estimators.common import FilterBuffers, FilterCode
from hybridlog.estimators.hstf import HstfOptions, run_hstf
from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.estimators.kernels import kalman_update, record, workspace
from hybridlog.estimators.unrolled import unrolled_work, use_unrolled
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.model.loader import load_model, parse_model
from hybridlog.signals import AlignedSignals
from hybridlog.simulate import simulate
from tests.support.models import LINEAR_TWO_MODE, PENDULUM_ONE_MODE

MODELS = {
    "three_tank_hstf": lambda: load_model("three_tank_hstf"),
    "linear_two_mode": lambda: parse_model(LINEAR_TWO_MODE),
    "pendulum": lambda: parse_model(PENDULUM_ONE_MODE),
}
RUNS = {
    "hstf": lambda m, s, **kw: run_hstf(m, s, HstfOptions(), **kw),
    "hstf-unfaded": lambda m, s, **kw: run_hstf(m, s, HstfOptions(likelihood="unfaded"), **kw),
    "hstf-no-fading": lambda m, s, **kw: run_hstf(m, s, HstfOptions(fading=False), **kw),
    "imm": lambda m, s, **kw: run_imm(m, s, ImmOptions(), **kw),
}


def _signals(model, steps):
    return simulate(model, steps=steps, seed=4).signals(model)


def _assert_same(a, b, tolerance):
    np.testing.assert_allclose(a.state_means, b.state_means, rtol=tolerance, atol=tolerance)
    np.testing.assert_allclose(a.state_variances, b.state_variances, rtol=tolerance, atol=tolerance)
    np.testing.assert_allclose(
        a.mode_probabilities, b.mode_probabilities, rtol=tolerance, atol=tolerance
    )
    np.testing.assert_allclose(
        a.output_predictions, b.output_predictions, rtol=tolerance, atol=tolerance
    )
    np.testing.assert_array_equal(a.modes, b.modes)
    np.testing.assert_allclose(a.covariances, b.covariances, rtol=tolerance, atol=tolerance)


@pytest.mark.parametrize("model_name", sorted(MODELS))
@pytest.mark.parametrize("run_name", sorted(RUNS))
def test_unrolled_loops_and_plain_python_agree(model_name, run_name):
    model = MODELS[model_name]()
    run = RUNS[run_name]
    signals = _signals(model, steps=400)
    unrolled = run(model, signals, kernel="unrolled", store_covariances=True)
    loops = run(model, signals, kernel="loops", store_covariances=True)
    _assert_same(unrolled, loops, 1e-9)
    short = AlignedSignals(
        source="sim",
        time=signals.time[:60],
        input_names=model.inputs,
        output_names=model.outputs,
        inputs=signals.inputs[:60],
        outputs=signals.outputs[:60],
    )
    plain = run(model, short, jit=False, store_covariances=True)
    compiled = run(model, short, kernel="loops", store_covariances=True)
    _assert_same(plain, compiled, 1e-12)


def _filter_codes():
    """Every filter of every estimator module, found without a list to keep up to date."""
    codes = []
    for info in pkgutil.iter_modules(hybridlog.estimators.__path__):
        module = importlib.import_module(f"hybridlog.estimators.{info.name}")
        codes += [value for value in vars(module).values() if isinstance(value, FilterCode)]
    return codes


def test_every_accelerator_is_checked_against_the_plain_path():
    accelerated = {code.name for code in _filter_codes() if code.accelerator is not None}
    assert accelerated >= {"hstf", "imm"}
    # Each one must have a row in RUNS, which the test above compares path by path.
    assert accelerated <= {name.split("-")[0] for name in RUNS}


def test_auto_takes_straight_line_code_for_small_models_only():
    model = load_model("three_tank_hstf")
    assert use_unrolled(model, "auto")
    assert not use_unrolled(model, "loops")
    wide = parse_model(
        "dt = 1\nstates = [" + ", ".join(f'"s{i}"' for i in range(7)) + ']\noutputs = ["y"]\n'
        "[modes.a]\nA = " + str(np.eye(7).tolist()) + "\nC = [" + str([1.0] * 7) + "]\n"
        "[initial]\nstate = " + str([0.0] * 7) + "\n"
    )
    assert not use_unrolled(wide, "auto")
    assert use_unrolled(wide, "unrolled")


def _linear_modes(states: int, modes: int) -> HybridModel:
    names = ", ".join(f'"s{i}"' for i in range(states))
    matrices = "".join(
        f"[modes.m{k}]\nA = {(np.eye(states) * (0.9 - 0.05 * k)).tolist()}\n"
        f"C = {np.eye(states).tolist()}\n"
        for k in range(modes)
    )
    return parse_model(
        f"dt = 1\nstates = [{names}]\noutputs = [{names.replace('s', 'y')}]\n{matrices}"
        f"[initial]\nstate = {[0.0] * states}\n"
    )


@pytest.mark.parametrize(
    ("states", "modes", "straight"), [(3, 8, True), (6, 2, True), (6, 4, True), (6, 5, False)]
)
def test_auto_weighs_the_straight_line_codes_size_by_modes_and_states(
    states: int, modes: int, straight: bool
) -> None:
    # 8 modes of 6 states were given straight-line code within both bounds: 190 s to compile
    # the IMM's filter, 363 s and 1.9 GB for a first --mode-sequence kbest, to run 10 % faster
    # than the compiled loops (MAX_UNROLLED_WORK)
    model = _linear_modes(states, modes)
    assert unrolled_work(model) == modes**2 * states**2 + modes * states**3
    assert use_unrolled(model, "auto") is straight
    assert use_unrolled(model, "unrolled")


def test_a_diverging_filter_is_an_error_naming_the_model_file_estimator_and_time():
    # Issue 7: the message names the model file (not the model's internal name).
    model = parse_model(
        'name = "kink"\ndt = 1\nstates = ["x"]\noutputs = ["y"]\n'
        '[modes.a]\nf = ["x + sqrt(abs(x - 2))"]\nh = ["x"]\n'
        "[noise]\nprocess = 0.1\nmeasurement = 0.1\n[initial]\nstate = [2.0]\n",
        origin="models/kink.toml",
    )
    signals = AlignedSignals(
        source="sim",
        time=np.arange(5.0),
        input_names=(),
        output_names=("y",),
        inputs=np.zeros((5, 0)),
        outputs=np.full((5, 1), 2.0),
    )
    for kernel in ("unrolled", "loops"):
        with pytest.raises(
            ModelError, match=r"^models/kink\.toml: hstf diverged at t = 1 s \(sample 1\)"
        ):
            run_hstf(model, signals, HstfOptions(), kernel=kernel)


def test_the_shared_ekf_update_is_the_joseph_form_and_flags_a_singular_innovation():
    # kalman_update serves both generic loops (paper 000 eqs. (9), (11), (32); the IMM's EKF).
    rng = np.random.default_rng(3)
    n, m = 4, 2
    A = rng.normal(size=(n, n))
    P = A @ A.T + np.eye(n)
    H = rng.normal(size=(m, n))
    B = rng.normal(size=(m, m))
    R = B @ B.T + 0.1 * np.eye(m)
    x, gamma = rng.normal(size=n), rng.normal(size=m)
    work = workspace(n, m)
    x_out, P_out = np.empty(n), np.empty((n, n))
    assert kalman_update(x, P, H, R, gamma, work, x_out, P_out)
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    I_KH = np.eye(n) - K @ H
    np.testing.assert_allclose(x_out, x + K @ gamma, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(P_out, I_KH @ P @ I_KH.T + K @ R @ K.T, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(work.L @ work.L.T, S, rtol=1e-12, atol=1e-12)
    assert not kalman_update(x, P, H, -S - np.eye(m), gamma, work, x_out, P_out)


@pytest.mark.parametrize("store_covariances", [False, True])
def test_record_writes_one_output_row_and_covariances_only_where_kept(store_covariances):
    model = parse_model(LINEAR_TWO_MODE)
    out = FilterBuffers.allocate(model, 3, store_covariances=store_covariances)
    n = model.n_states
    mu = np.linspace(0.2, 0.8, model.n_modes)
    x = np.arange(1.0, n + 1.0)
    P = np.arange(float(n * n)).reshape(n, n)
    record(out, 1, 1, mu, x, P)
    assert out.modes.tolist() == [0, 1, 0]
    np.testing.assert_array_equal(out.mode_probabilities[1], mu)
    np.testing.assert_array_equal(out.state_means[1], x)
    np.testing.assert_array_equal(out.state_variances[1], np.diag(P))
    assert not out.state_means[[0, 2]].any()
    if store_covariances:
        np.testing.assert_array_equal(out.covariances[1], P)
        assert not out.covariances[[0, 2]].any()
    else:
        assert out.covariances.shape[0] == 0


ALLOCATING_KERNELS = {"workspace", "keep_psd", "possible_sources"}
"""The kernels that allocate (scratch; ``keep_psd``'s rare eigendecomposition)."""


def test_the_kernels_take_no_reference_counts_and_are_inlined():
    """Compiled with numba's runtime, each kernel took a reference to every array it was given
    on entry and dropped it on return, an atomic ``lock inc``/``lock dec`` each: 60 % of the
    IMM's generic loop on nine mode pairs (16 on every ``kalman_update``).  Every kernel but
    those that allocate is compiled without them, and inlined (``jit.jit_kernel``)."""
    from numba.core.dispatcher import Dispatcher

    from hybridlog.estimators import imm, kernels
    from hybridlog.jit import WITHOUT_REFCOUNTS

    compiled = {
        name: value for name, value in vars(kernels).items() if isinstance(value, Dispatcher)
    }
    assert {"kalman_update", "mixture_moments", "record", "congruence"} <= set(compiled)
    for name, dispatcher in [*compiled.items(), ("pack_state", imm.pack_state)]:
        options = dispatcher.targetoptions
        if name in ALLOCATING_KERNELS:
            assert options.get("_nrt", True), name
            continue
        assert {**options, **WITHOUT_REFCOUNTS} == options, name
        assert options.get("forceinline"), name


def test_a_mixture_over_the_possible_modes_alone_is_the_whole_mixture_to_the_bit():
    """The IMM's mixing of mode ``j`` sums over the modes ``i`` with ``Π[i, j] ≠ 0`` alone
    (a model's nine mode pairs: three each); the terms left out are exact zeros."""
    from hybridlog.estimators.kernels import mixture_moments, mixture_moments_of, possible_sources
    from hybridlog.estimators.mode_pairs import pair_transitions

    transitions = pair_transitions(np.array([[0.9, 0.05, 0.05], [0.1, 0.8, 0.1], [0.0, 0.3, 0.7]]))
    start, sources = possible_sources(transitions)
    # pair b->c follows the three pairs a->b with Π[b, c]; none where Π[b, c] = 0 (2->0)
    assert list(np.diff(start)) == [3, 3, 3, 3, 3, 3, 0, 3, 3]
    rng = np.random.default_rng(3)
    n_q, n = transitions.shape[0], 3
    means = rng.normal(size=(n_q, n))
    factors = rng.normal(size=(n_q, n, n))
    covariances = factors @ factors.transpose(0, 2, 1)
    mu = rng.dirichlet(np.ones(n_q))
    for j in range(n_q):
        if start[j] == start[j + 1]:
            continue
        weights = transitions[:, j] * mu / (transitions[:, j] @ mu)
        possible = sources[start[j] : start[j + 1]]
        assert set(possible) == set(np.flatnonzero(transitions[:, j]))
        whole = np.empty(n), np.empty((n, n))
        alone = np.empty(n), np.empty((n, n))
        mixture_moments(weights, means, covariances, *whole)
        mixture_moments_of(weights, possible, means, covariances, *alone)
        for a, b in zip(whole, alone, strict=True):
            np.testing.assert_array_equal(a, b)


@settings(max_examples=50, deadline=None)
@given(
    st.lists(st.one_of(st.floats(-800.0, 800.0), st.just(-np.inf)), min_size=1, max_size=12),
    st.integers(0, 2**12 - 1),
)
def test_a_log_sum_exp_over_the_possible_terms_is_the_whole_one_to_the_bit(
    values: list[float], extra: int
) -> None:
    """Expectation correction's sums over the pairs ``Π_ij ≠ 0`` alone (``log p_ij = −∞``
    elsewhere): leaving out any ``−∞`` terms, whichever, changes no bit."""
    from hybridlog.estimators.log_space import log_sum_exp, log_sum_exp_of

    array = np.array(values)
    members = np.array(
        [i for i, v in enumerate(values) if v > -np.inf or (extra >> i) & 1], dtype=np.int64
    )
    whole, alone = log_sum_exp(array), log_sum_exp_of(array, members)
    assert whole == alone or (np.isnan(whole) and np.isnan(alone))


SMOOTHERS_STEPS = {
    "log_space": ("safe_log", "log_sum_exp", "log_sum_exp_of"),
    "rts_steps": ("unpack_state", "note_fallbacks"),
    "kim_loop": ("mixed_probe", "mixed_probe_of"),
    "mode_hypotheses": ("note_weight",),
}


@pytest.mark.parametrize(("module", "names"), SMOOTHERS_STEPS.items())
def test_the_offline_passes_small_steps_take_no_reference_counts(
    module: str, names: tuple[str, ...]
) -> None:
    """Kim's backward loop (``kim_loop._kim_rows``) runs without numba's reference
    counts, as the IMM's; its small steps, compiled with them, took and dropped one on each array
    they were given (``log_sum_exp`` of a row of ``log p_ij``, 1.7x its pass on nine mode
    pairs with the other counts), as ``kbest``'s ``note_weight`` in its search."""
    import importlib

    from hybridlog.jit import WITHOUT_REFCOUNTS

    found = importlib.import_module(f"hybridlog.estimators.{module}")
    for name in names:
        options = getattr(found, name).targetoptions
        assert {**options, **WITHOUT_REFCOUNTS} == options, name
        assert options.get("forceinline"), name


OFFLINE_LOOPS = {
    "kim_loop": ("_kim_rows",),
    "ec_loop": ("_ec_rows",),
    "imm": ("_imm_rows",),
    "hstf": ("_hstf_rows",),
}
"""The generic loops that run in scratch their callers allocate (``jit.jitable_kernel``)."""


@pytest.mark.parametrize(("module", "names"), OFFLINE_LOOPS.items())
def test_the_generic_loops_are_compiled_without_reference_counts(
    module: str, names: tuple[str, ...]
) -> None:
    """Each generic loop is compiled into its allocating caller without numba's runtime.

    Expectation correction's pass (``ec_loop.ec_backward``) took and dropped an atomic
    reference on every array its steps were given and every view it sliced (a pair's
    ``x_pair[i, j]``, ``store.states[k, i]``), as Kim's did before ``_kim_rows``: its loop
    is now ``_ec_rows``, 1.2-1.4x faster on the tank's 9 and the ladder's 16 mode pairs.
    """
    import importlib

    from numba.core.typing.templates import builtin_registry

    from hybridlog.jit import WITHOUT_REFCOUNTS

    found = importlib.import_module(f"hybridlog.estimators.{module}")
    for name in names:
        function = getattr(found, name)
        options = [
            template._jit_options
            for value, typed in builtin_registry.globals
            if value is function
            for template in typed.templates
        ]
        assert options, name  # registered for compiled callers (jit.jitable)
        assert all({**o, **WITHOUT_REFCOUNTS} == o for o in options), name
