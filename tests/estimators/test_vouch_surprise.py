"""A sample no mode explains is refused, never filtered (hybridlog.estimators.vouch.check_surprise).

A 1e6 spike in a three-tank level (about 20 cm) made the IMM put the level at 305220 cm with
a variance of 0.05 and every mode probability at exactly 0 or 1 (whichever impossible
likelihood was least so), and the run passed with exit 0.  Now the filter records each
sample's smallest ``γᵀ S⁻¹ γ`` over the modes and the run is refused at the first past
:func:`~hybridlog.estimators.vouch.surprise_limit`, naming the time, the sample and each
output beside its prediction.
"""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from hybridlog.cli import main
from hybridlog.errors import DivergenceError
from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.estimators.vouch import surprise_limit
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals
from hybridlog.simulate import simulate
from tests.estimators.test_reductions import _linear_matrices
from tests.support.models import LINEAR_TWO_MODE

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "sample_logs"
ONE_MODE = LINEAR_TWO_MODE.split("[modes.fast]")[0] + (
    "[noise]\nprocess = [0.01, 0.02]\nmeasurement = [[0.05, 0.01], [0.01, 0.08]]\n\n"
    "[initial]\nstate = [0.5, -0.2]\ncovariance = [[1.0, 0.1], [0.1, 2.0]]\n\n"
    '[simulation]\nstate = [0.0, 0.0]\nschedule = "slow:200"\n\n'
    '[simulation.inputs]\na = "sin(0.7*t)"\n'
)


def _filterpy_distances(model, signals):
    """Each sample's ``γᵀ S⁻¹ γ`` of FilterPy's Kalman filter (row 0: the prior, NaN)."""
    mode = model.modes[0]
    kf = KalmanFilter(dim_x=model.n_states, dim_z=model.n_outputs, dim_u=model.n_inputs)
    kf.x = model.initial_state.copy()
    kf.P = model.initial_covariance.copy()
    kf.F, kf.B, kf.H = _linear_matrices(model, 0)
    kf.Q, kf.R = mode.process_noise, mode.measurement_noise
    distances = [np.nan]
    for k in range(signals.n_samples - 1):
        kf.predict(u=signals.inputs[k])
        kf.update(signals.outputs[k + 1])
        distances.append(float(kf.mahalanobis) ** 2)
    return np.array(distances)


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_the_refusal_is_at_the_first_sample_past_the_limit_as_filterpy_computes_it(kernel):
    model = parse_model(ONE_MODE)
    signals = simulate(model, steps=199, seed=3).signals(model)
    outputs = signals.outputs.copy()
    outputs[[60, 120], 1] += [12.0, 1e6]  # 12 σ(R): explained; 1e6: not
    signals = dataclasses.replace(signals, outputs=outputs)
    distances = _filterpy_distances(model, signals)
    beyond = np.flatnonzero(distances > surprise_limit(model.n_outputs))
    assert beyond[0] == 120 and distances[60] > 100.0  # the 12 σ sample is surprising, no more
    with pytest.raises(DivergenceError) as refused:
        run_imm(model, signals, ImmOptions(), kernel=kernel)
    message = str(refused.value)
    assert "cannot explain the log at t = 12 s (sample 120)" in message
    assert "y2 = 1e+06" in message
    assert f"{np.sqrt(distances[120]):.3g} standard deviations" in message
    outputs[120, 1] -= 1e6
    kept = dataclasses.replace(signals, outputs=outputs)  # the 12 σ sample alone: vouched for
    assert np.nanmax(_filterpy_distances(model, kept)) <= surprise_limit(model.n_outputs)
    run_imm(model, kept, ImmOptions(), kernel=kernel)


def test_a_spike_in_a_three_tank_log_is_one_line_and_exit_2(tmp_path, capsys):
    text = (SAMPLES / "three_tank_hstf.csv").read_text().splitlines()
    header = text[0].split(",")
    row = text[151].split(",")  # t = 150 s
    row[header.index("y1")] = "1e6"
    text[151] = ",".join(row)
    path = tmp_path / "spike.csv"
    path.write_text("\n".join(text) + "\n")
    out = tmp_path / "out"
    argv = ["-q", "analyze", str(path), "--model", "three_tank_hstf", "--estimator", "imm"]
    for extra in ([], ["--smooth"], ["--mode-sequence", "viterbi"], ["--mode-sequence", "kbest"]):
        with pytest.raises(SystemExit) as exit_:
            main([*argv, "--out", str(out), *extra])
        assert exit_.value.code == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1, err
        assert "cannot explain the log at t = 150 s (sample 150): y1 = 1e+06" in err
        assert not out.exists()


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_the_hstf_refuses_the_same_sample(kernel):
    # one mode and no fading: the HSTF is the Kalman filter, its distance FilterPy's; the
    # spike was filtered at exit 0 (x1 off by 19212 on the three-tank log)
    from hybridlog.estimators.hstf import HstfOptions, run_hstf

    model = parse_model(ONE_MODE)
    signals = simulate(model, steps=199, seed=3).signals(model)
    outputs = signals.outputs.copy()
    outputs[120, 1] += 1e6
    signals = dataclasses.replace(signals, outputs=outputs)
    distances = _filterpy_distances(model, signals)
    with pytest.raises(DivergenceError) as refused:
        run_hstf(model, signals, HstfOptions(fading=False), kernel=kernel)
    message = str(refused.value)
    assert "hstf cannot explain the log at t = 12 s (sample 120)" in message
    assert f"{np.sqrt(distances[120]):.3g} standard deviations" in message
    # with fading the likelihood's S_i is the paper's faded one (eq. (35)), whose λ_i grows
    # with the innovations (eqs. (26)-(30)) and here absorbs the spike; the unfaded S_i of
    # likelihood=unfaded still tells it
    with pytest.raises(DivergenceError, match=r"cannot explain the log at t = 12 s"):
        run_hstf(model, signals, HstfOptions(likelihood="unfaded"), kernel=kernel)


def test_an_estimate_that_had_lost_the_plant_is_said_so_where_the_log_has_its_true_mode():
    """The IMM following mode 3's levels as mode 1's at three times the state (h_i = i·x).

    10^7 samples simulated from three_tank_hstf (seed 1) were refused at t = 1844101 s as
    "an outlier, a stuck or offset sensor or another plant's log?": the IMM had held mode 1 at
    three times the levels over the 100 samples of mode 3 before, and the plant's switch to
    mode 1 was one no mode explained from there.  The log's true mode tells it.
    """
    text = (ROOT / "hybridlog" / "model" / "builtin" / "three_tank_hstf.toml").read_text()
    text = text.replace("state = [15.0, 10.0, 10.0]", "state = [28.0, 2.7, 2.5]")
    text = text.replace('schedule = "1:100,2:100,3:100"', 'schedule = "3:100,1:100"')
    prior = 'state = [20.0, 5.0, 10.0]\ncovariance = 100.0\nmode = "2"'
    assert prior in text
    text = text.replace(prior, 'state = [84.0, 8.1, 7.5]\ncovariance = 0.5\nmode = "1"')
    model = parse_model(text, origin="tank.toml")
    signals = simulate(model, steps=199, seed=0).signals(model)
    with pytest.raises(DivergenceError) as refused:
        run_imm(model, signals, ImmOptions())
    message = str(refused.value)
    assert "tank.toml: imm cannot explain the log at t = 101 s (sample 101)" in message
    assert message.endswith(
        "the estimate had lost the plant before it: it held mode '1' over the 100 samples "
        "before, where the log's true mode was '3' (a wrong mode whose outputs another state "
        "matched); the log may be sound, and another estimator or its options may follow it"
    )
    without_truth = dataclasses.replace(signals, truth_modes=None)
    with pytest.raises(DivergenceError) as refused:
        run_imm(model, without_truth, ImmOptions())
    assert str(refused.value).endswith(
        "an outlier, a stuck or offset sensor, another plant's log, or an estimate that had "
        "lost the plant before it (a wrong mode whose outputs another state matched)?"
    )


def test_a_log_no_mode_explains_at_its_first_sample_is_not_said_to_be_lost_by_the_prior():
    """Every output of the three-tank sample log at 1e6: refused at sample 1, where the
    estimate before is the prior (mode 2, the log's true mode 1).  The refusal said "the
    estimate had lost the plant before it ... the log may be sound" of a broken log."""
    from hybridlog.io import ReadOptions, SignalSpec, load_signals
    from hybridlog.model.cache import load_model

    model = load_model("three_tank_hstf")
    signals = load_signals(SAMPLES / "three_tank_hstf.csv", SignalSpec.of(model), ReadOptions())
    assert signals.truth_modes is not None and signals.truth_modes[0] == 0  # '1'; the prior '2'
    constant = dataclasses.replace(signals, outputs=np.full_like(signals.outputs, 1e6))
    with pytest.raises(DivergenceError) as refused:
        run_imm(model, constant, ImmOptions())
    message = str(refused.value)
    assert "cannot explain the log at t = 1 s (sample 1)" in message
    assert "lost the plant before it:" not in message
    assert message.endswith("(a wrong mode whose outputs another state matched)?")


def _signals(outputs, inputs=None):
    n = len(outputs)
    return AlignedSignals(
        source="log.csv",
        time=np.arange(n, dtype=float),
        input_names=("u",),
        output_names=("y",),
        inputs=np.zeros((n, 1)) if inputs is None else np.asarray(inputs, float)[:, None],
        outputs=np.asarray(outputs, float)[:, None],
    )


RULED_OUT = """dt = 1.0
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[modes.a]
f = ["x"]
h = ["x"]

[modes.b]
f = ["x"]
h = ["x + u"]

[noise]
process = 0.01
measurement = 0.01

[initial]
state = [10.0]
covariance = 0.01
mode = "a"

[transitions]
matrix = [[1.0, 0.0], [0.0, 1.0]]
"""


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_a_mode_the_transitions_rule_out_explains_no_sample(kernel):
    # mode b is impossible (prior 0, never entered): its filter explained the jump at t = 21 s
    # (y = x + u), so the smallest distance was its own and the IMM's estimate, mode a pulled
    # 10 (70 σ) towards the jump, was written out at exit 0
    model = parse_model(RULED_OUT, origin="ruled_out.toml")
    u = np.where(np.arange(41) <= 20, 0.0, 10.0)
    y = 10.0 + u + np.random.default_rng(1).normal(0.0, 0.1, 41)
    with pytest.raises(DivergenceError) as refused:
        run_imm(model, _signals(y, u), ImmOptions(), kernel=kernel)
    assert "imm cannot explain the log at t = 21 s (sample 21)" in str(refused.value)
    assert "standard deviations from every possible mode's prediction" in str(refused.value)


OVERFLOWING = """dt = 1.0
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[modes.a]
f = ["x"]
h = ["x"]

[modes.b]
f = ["0.5*x"]
h = ["x"]

[noise]
process = 1e-30
measurement = 1e-30

[initial]
state = [1.0]
covariance = 1e-30
"""


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
@pytest.mark.parametrize("estimator", ["imm", "hstf"])
def test_a_measurement_too_far_for_double_precision_is_unexplained_not_unweighed(kernel, estimator):
    # γᵀ S⁻¹ γ = 1e280 / 2e-30 overflows: every mode's likelihood was -inf though S was
    # finite and positive definite, and the IMM said no mode's S was (the HSTF: its state
    # estimate not finite, the update's outcome)
    from hybridlog.estimators.hstf import HstfOptions, run_hstf

    model = parse_model(OVERFLOWING, origin="tiny.toml")
    y = np.ones(30)
    y[20] = 1e140
    signals = _signals(y)
    with pytest.raises(DivergenceError) as refused:
        if estimator == "imm":
            run_imm(model, signals, ImmOptions(), kernel=kernel)
        else:
            run_hstf(model, signals, HstfOptions(fading=False), kernel=kernel)
    assert str(refused.value).startswith(
        f"tiny.toml: {estimator} cannot explain the log at t = 20 s (sample 20): y = 1e+140 "
    )
    assert "over 1.34e+154 standard deviations from every possible mode's" in str(refused.value)
