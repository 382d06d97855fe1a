"""Paper 004's switching observer (``switching-observer``) against independent references.

* One mode, no jumps: the observer of Ciccarella, Dalla Mora and Germani (1993, paper 004's
  ref. [8], eq. (18)) on a Van der Pol oscillator with a nonlinear output, written here by
  hand (Φ, Q, K) and integrated with SciPy's ``solve_ivp``; hybridlog's fixed-step RK4 must
  agree within its own step error (estimated by halving the step: Richardson).
* The engine with clutch (``ice_clutch``, paper 004 §6): a plant made with SciPy
  (``tests/support/clutch.py``), switches with the jumps (45)-(46).  The error decays
  exponentially between switches and across jumps at the rate the linearised error
  dynamics predict; the jump maps are applied at the switching samples.
"""

import re

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hybridlog.errors import LogError, ModelError, OptionError
from hybridlog.estimators import prepare
from hybridlog.estimators.hybrid_observer import brunovsky_gain, run_switching_observer
from hybridlog.estimators.hybrid_observer_options import SwitchingObserverOptions
from hybridlog.model.builtins import builtin_text
from hybridlog.model.loader import load_model, parse_model
from hybridlog.signals import NO_TRUE_MODE, AlignedSignals
from hybridlog.simulate import simulate
from hybridlog.times import format_time
from tests.support import clutch, model_kinds
from tests.support.unmeasured import assert_same, with_stand_ins

MU = 1.0
VAN_DER_POL = f"""
name = "van_der_pol"
time = "continuous"
dt = 0.01
integration = {{method = "rk4", step = 0.002}}
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y"]

[modes.only]
dx = ["x2", "{MU}*(1 - x1**2)*x2 - x1 + u"]
h = ["x1 + x1**3/3"]

[initial]
state = [0.5, -0.5]
mode = "only"
"""
EIGENVALUES = (-3.0, -6.0)


def vdp_field(x, u):
    return np.array([x[1], MU * (1 - x[0] ** 2) * x[1] - x[0] + u])


def vdp_observer(x, u, y):
    """Eq. (18) written by hand: Φ = [x1 + x1³/3, (1 + x1²) x2], Q = ∂Φ/∂x."""
    q = np.array([[1 + x[0] ** 2, 0.0], [2 * x[0] * x[1], 1 + x[0] ** 2]])
    gain = np.array([-(EIGENVALUES[0] + EIGENVALUES[1]), EIGENVALUES[0] * EIGENVALUES[1]])
    return vdp_field(x, u) + np.linalg.solve(q, gain * (y - (x[0] + x[0] ** 3 / 3)))


@pytest.fixture(scope="module")
def vdp_log():
    dt, count = 0.01, 400
    times = np.arange(count) * dt
    u = 0.5 * np.sin(times)
    x, states = np.array([2.0, 0.0]), [np.array([2.0, 0.0])]
    for k in range(count - 1):
        sol = solve_ivp(
            lambda _t, s, a=u[k]: vdp_field(s, a), (times[k], times[k + 1]), x, rtol=1e-11
        )
        x = sol.y[:, -1]
        states.append(x)
    states = np.array(states)
    y = states[:, :1] + states[:, :1] ** 3 / 3
    return AlignedSignals(
        source="vdp.csv",
        time=times,
        input_names=("u",),
        output_names=("y",),
        inputs=u.reshape(-1, 1),
        outputs=y,
        truth_modes=np.zeros(count, dtype=np.int64),
        state_names=("x1", "x2"),
        truth_states=states,
    )


def reference_run(signals, x0, hold, unmeasured=None):
    """Observer (18) integrated by solve_ivp (rtol 1e-10) over each sample interval.

    ``unmeasured``: samples whose interval runs without injection (``vdp_field`` alone),
    and which the first-order hold's slope skips.
    """
    t, u, y = signals.time, signals.inputs[:, 0], signals.outputs[:, 0]
    skip = np.zeros(len(t), dtype=bool) if unmeasured is None else unmeasured
    x, out = np.asarray(x0, dtype=float), [np.asarray(x0, dtype=float)]
    for k in range(len(t) - 1):
        measured = np.flatnonzero(~skip[:k])
        if hold == "first":
            if measured.size:
                j = measured[-1]
                slope = (y[k] - y[j]) / (t[k] - t[j])
            else:  # the estimate's own dy/dt: dh/dx f(x̂(t_0), u(0))
                slope = (1 + x[0] ** 2) * vdp_field(x, u[k])[0]
        else:
            slope = 0.0

        def field(s, z, k=k, slope=slope):
            if skip[k]:
                return vdp_field(z, u[k])
            return vdp_observer(z, u[k], y[k] + slope * (s - t[k]))

        sol = solve_ivp(
            field,
            (t[k], t[k + 1]),
            x,
            method="DOP853",
            rtol=1e-10,
            atol=1e-12,
        )
        x = sol.y[:, -1]
        out.append(x)
    return np.array(out)


@pytest.mark.parametrize("hold", ["zero", "first"])
def test_one_mode_equals_the_observer_of_ciccarella_dalla_mora_germani(vdp_log, hold):
    options = SwitchingObserverOptions(eigenvalues="-3,-6", output_hold=hold)
    result = run_switching_observer(parse_model(VAN_DER_POL), vdp_log, options)
    halved = parse_model(VAN_DER_POL.replace("step = 0.002", "step = 0.001"))
    finer = run_switching_observer(halved, vdp_log, options).state_means
    reference = reference_run(vdp_log, [0.5, -0.5], hold)
    # RK4's global error at step h is about 16/15 |x_h - x_{h/2}| (Richardson); the reference
    # itself is good to ~1e-10.
    tolerance = 2.0 * np.abs(result.state_means - finer).max() + 1e-9
    assert np.abs(result.state_means - reference).max() <= tolerance
    assert tolerance < 1e-6
    # the observer converges: of the initial error of 1.5 after 3 s remains the error of the
    # hold, about dt·max|ẏ| (≈ 0.03) when y is held, far less when it is extrapolated
    late = np.abs(result.state_means[300:] - vdp_log.truth_states[300:]).max()
    step_of_y = np.abs(np.diff(vdp_log.outputs[:, 0])).max()
    assert late < (1e-3 if hold == "first" else step_of_y)
    np.testing.assert_array_equal(result.modes, 0)
    assert np.isnan(result.state_variances).all() and np.isnan(result.output_predictions[0, 0])
    x_hat = result.state_means[1:, 0]
    np.testing.assert_allclose(result.output_predictions[1:, 0], x_hat + x_hat**3 / 3)


def test_a_one_mode_model_needs_no_switching_signal_in_the_log(vdp_log, tmp_path):
    """A one-mode model's sigma is that mode: a log without the signal was refused
    ("needs the switching signal in the log"), for a column that could hold one value."""
    import polars as pl

    from hybridlog.jobs.analysis import analyze
    from hybridlog.jobs.gate_checks import modes_given

    model = parse_model(VAN_DER_POL)
    blind = AlignedSignals(**{**vdp_log.__dict__, "truth_modes": None})
    prepared = prepare(model, "switching-observer")
    prepared.check_signals(model, blind)  # refused it
    options = SwitchingObserverOptions(eigenvalues="-3,-6")
    given = run_switching_observer(model, vdp_log, options)
    result = run_switching_observer(model, blind, options)
    np.testing.assert_array_equal(result.state_means, given.state_means)
    np.testing.assert_array_equal(result.modes, 0)
    assert result.modes_given.startswith("switching-observer runs a one-mode model")
    assert "no switching signal in the log" in result.notes[0]
    # and a signal that switched once said "switched 1 times"
    once = vdp_log.truth_modes.copy()
    once[200:] = 1
    two = parse_model(
        VAN_DER_POL.replace(
            "[initial]", '[modes.other]\ndx = ["x2", "-x1 + u"]\nh = ["x1 + x1**3/3"]\n\n[initial]'
        )
    )
    switched_once = AlignedSignals(**{**vdp_log.__dict__, "truth_modes": once})
    note = run_switching_observer(two, switched_once, options).notes[0]
    assert note.endswith("sigma from the log switched once, jump maps R applied at 0 of them")
    assert given.modes_given.startswith("switching-observer takes its modes from the log")
    # the gate's reason is the model's one mode, not a signal the log need not have
    assert modes_given([prepared], model) == {
        "switching-observer": "its model has one mode, which is sigma at every sample"
    }
    model_file = tmp_path / "vdp.toml"
    model_file.write_text(VAN_DER_POL)
    log = tmp_path / "vdp.csv"
    columns = {"time": vdp_log.time, "u": vdp_log.inputs[:, 0], "y": vdp_log.outputs[:, 0]}
    pl.DataFrame(columns).write_csv(log)
    out = tmp_path / "out"
    run = analyze(
        log, model_file, out_dir=out, estimator="switching-observer", sets=["eigenvalues=-3,-6"]
    )
    report = run.report
    assert report.modes.accuracy is None
    text = (out / "report.md").read_text()
    assert "0 mode switches.\n" in text and "runs a one-mode model" in text


def test_a_one_mode_model_runs_whatever_gaps_its_mode_column_has(vdp_log):
    """The same log ran without its mode column but was refused with it where the column had
    a gap ("needs the switching signal at every sample"): a one-mode model's sigma is that
    mode, which no gap can hide a switch of; the gap's NO_TRUE_MODE is no mode to run in."""
    model = parse_model(VAN_DER_POL)
    gapped = vdp_log.truth_modes.copy()
    gapped[1::2] = NO_TRUE_MODE
    with_gaps = AlignedSignals(**{**vdp_log.__dict__, "truth_modes": gapped})
    prepare(model, "switching-observer").check_signals(model, with_gaps)  # refused it
    options = SwitchingObserverOptions(eigenvalues="-3,-6")
    result = run_switching_observer(model, with_gaps, options)
    np.testing.assert_array_equal(result.modes, 0)
    np.testing.assert_array_equal(
        result.state_means, run_switching_observer(model, vdp_log, options).state_means
    )


def test_the_gain_places_the_eigenvalues_of_the_brunovsky_pair():
    eigenvalues = (-1.5, -4.0, -7.0, -20.0)
    gain = brunovsky_gain(eigenvalues)
    a_b, c_b = np.eye(4, k=1), np.eye(1, 4)
    placed = np.sort(np.linalg.eigvals(a_b - gain.reshape(-1, 1) @ c_b).real)
    np.testing.assert_allclose(placed, sorted(eigenvalues), rtol=1e-9)
    assert SwitchingObserverOptions(eigenvalues="-2").eigenvalue_list(3) == (-2.0, -4.0, -6.0)
    assert SwitchingObserverOptions(eigenvalues="-9, -1,-4").eigenvalue_list(3) == (-1, -4, -9)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("10,20,30", "every eigenvalue must be a finite negative real"),
        ("a,b", "separated by"),
        # a gain float64 cannot hold, and one too fast for the 1 ms RK4 step: were refused
        # only as switching-observer ran, naming neither the file nor the key
        ("-1e300", r"the gain K_2 of -1e\+300, .* is inf, not a positive float64"),
        ("-1e-300", r"the gain K_2 of -1e-300, .* is 0, not a positive float64"),
        ("-1e4", r"λ = -30000 1/s is too fast for integration\.step = 0\.001 s of clutch\.toml"),
    ],
)
def test_bad_eigenvalues_in_a_model_file_name_file_and_key_before_any_log(text, words):
    """Checked when the options are parsed (was: at run time, naming neither)."""
    bad = builtin_text("ice_clutch").replace(
        'eigenvalues = "-10,-20,-30"', f'eigenvalues = "{text}"'
    )
    model = parse_model(bad, origin="clutch.toml")
    with pytest.raises(
        ModelError, match=rf"^clutch\.toml: estimators\.switching-observer\.eigenvalues: .*{words}"
    ):
        prepare(model, "switching-observer")
    good = parse_model(builtin_text("ice_clutch"), origin="clutch.toml")
    with pytest.raises(OptionError, match=rf"^--set eigenvalues={re.escape(text)}: .*{words}"):
        prepare(good, "switching-observer", {"eigenvalues": text})


@pytest.mark.parametrize(
    ("array", "words"),
    [
        ("[-10, nan, -30]", "item 2 of the array: expected a finite number, got 'nan'"),
        ('[-10, "a", -30]', "item 2 of the array: expected a finite number, got the string 'a'"),
        ("[-10, true, -30]", "item 2 of the array: expected a finite number, got 'true'"),
        ("[-20.0, -30.0]", r"3 states, so give 3 eigenvalues or one, not 2 \('-20\.0,-30\.0'\)"),
        ("[-10, -20, 30]", "every eigenvalue must be a finite negative real"),
        ("{a = 1}", "expected an array of numbers or their text separated by commas, got a table"),
        ("[]", r"expected one negative number, or one per state, got none \(default -5\)$"),
    ],
)
def test_eigenvalues_in_a_model_file_may_be_a_toml_array(array, words):
    # `eigenvalues = [-10.0, -20.0, -30.0]`, as an engineer writes them, was refused as
    # "expected text"; an array is read as its text is, with the same checks and errors
    def table(value):
        text = builtin_text("ice_clutch").replace(
            'eigenvalues = "-10,-20,-30"', f"eigenvalues = {value}"
        )
        return parse_model(text, origin="clutch.toml")

    for value in ("[-10.0, -20.0, -30.0]", "[-10, -20, -30]"):
        options = prepare(table(value), "switching-observer").options
        assert options.eigenvalue_list(3) == (-10.0, -20.0, -30.0)
    assert prepare(table("-5"), "switching-observer").options.eigenvalue_list(3) == (-5, -10, -15)
    with pytest.raises(
        ModelError, match=rf"^clutch\.toml: estimators\.switching-observer\.eigenvalues: .*{words}"
    ):
        prepare(table(array), "switching-observer")


CLUTCH_DT = 0.01
DWELL = 25  # samples between switches: 0.25 s
SCALE = np.array([0.1, 100.0, 10.0])  # g, rad/s, N m: the error norm is ‖e / SCALE‖


def clutch_run(text, eigenvalues, schedule, x0=(0.08, 140.0, 15.0)):
    model = parse_model(text, origin="ice_clutch")
    values = {k: float(v) for k, v in model.parameters.items()}
    modes = clutch.schedule_modes(schedule)
    times, alpha, states = clutch.trajectory(
        values, modes, x0, lambda t: 0.4 + 0.1 * np.sin(2 * t), CLUTCH_DT
    )
    signals = clutch.signals(times, alpha, states, modes)
    prepared = prepare(model, "switching-observer", {"eigenvalues": eigenvalues})
    return model, values, signals, prepared.run(model, signals)


@pytest.fixture(scope="module")
def switched():
    schedule = [(0, DWELL), (1, DWELL)] * 6
    return clutch_run(builtin_text("ice_clutch"), "-4,-8,-12", schedule)


def expected_rates(values, signals, eigenvalues, window):
    """Frozen-time spectral abscissa of the linearised error dynamics M(σ, x, α) on ``window``."""
    matrices = clutch.linearised_error(values, brunovsky_gain(eigenvalues))
    return np.array(
        [
            np.linalg.eigvals(
                matrices(
                    int(signals.truth_modes[k]), signals.truth_states[k], signals.inputs[k, 0]
                )[2]
            ).real.max()
            for k in window
        ]
    )


def fitted_rate(times, norm):
    """Slope of log ‖e‖ and 3 standard errors of it (the resolution of the fit)."""
    (slope, _), cov = np.polyfit(times, np.log(norm), 1, cov=True)
    return float(slope), 3.0 * float(np.sqrt(cov[0, 0]))


def decay_window(norm):
    """From the peak of the initial transient to the last sample 30x above the floor."""
    floor = np.median(norm[-len(norm) // 5 :])
    start = int(np.argmax(norm))
    end = int(np.flatnonzero(norm > 30.0 * floor).max())
    assert end - start > 2 * DWELL, "the run must decay over several switches"
    return np.arange(start, end + 1), floor


def test_the_clutch_error_decays_across_switches_and_jumps_at_the_predicted_rate(switched):
    _, values, signals, result = switched
    norm = np.linalg.norm((result.state_means - signals.truth_states) / SCALE, axis=1)
    window, floor = decay_window(norm)
    rate, resolution = fitted_rate(signals.time[window], norm[window])
    # The error obeys ė = M e with M = ∂(f + gα)/∂x − Q⁻¹K ∂h/∂x near x̂ = x: its slowest
    # eigenvalue is λ1 = -4 moved by the plant's own Jacobian (for this engine by the air
    # dynamics p·ω ≈ 15 1/s), computed along the true trajectory.  Each jump multiplies
    # ‖e/SCALE‖ by at most the largest and at least the smallest gain of ∂R/∂x (eqs. (45),
    # (46): diagonal), spread over the window.
    abscissa = expected_rates(values, signals, (-4.0, -8.0, -12.0), window)
    switches = np.flatnonzero(np.diff(signals.truth_modes[window])) + 1
    engaged = int(np.sum(signals.truth_modes[window][switches] == 1))
    released = len(switches) - engaged
    length = signals.time[window[-1]] - signals.time[window[0]]
    jump_up = (engaged * np.log(5 / 3) + released * np.log(1.0)) / length
    jump_down = (engaged * np.log(2 / 3) + released * np.log(0.6)) / length
    low = abscissa.min() + jump_down - resolution
    high = abscissa.max() + jump_up + resolution
    assert len(switches) >= 3
    assert low <= rate <= high < 0.0, (low, rate, high)
    # and so within the plant's shift of the placed slowest eigenvalue
    shift = np.abs(abscissa + 4.0).max() + max(jump_up, -jump_down) + resolution
    assert abs(rate + 4.0) <= shift
    assert norm[window[-1]] < 1e-2 * norm[window[0]]  # two decades at least over the window
    assert floor < 1e-3


def test_between_switches_each_mode_decays_at_its_own_predicted_rate():
    for mode in (0, 1):
        _, values, signals, result = clutch_run(
            builtin_text("ice_clutch"), "-4,-8,-12", [(mode, 120)]
        )
        norm = np.linalg.norm((result.state_means - signals.truth_states) / SCALE, axis=1)
        floor = np.median(norm[-20:])
        window = np.arange(int(np.argmax(norm)), int(np.flatnonzero(norm > 30 * floor).max()) + 1)
        rate, resolution = fitted_rate(signals.time[window], norm[window])
        abscissa = expected_rates(values, signals, (-4.0, -8.0, -12.0), window)
        assert abscissa.min() - resolution <= rate <= abscissa.max() + resolution, (
            mode,
            abscissa.min(),
            rate,
            abscissa.max(),
        )


def test_jump_maps_are_applied_exactly_at_the_switching_samples():
    started = builtin_text("ice_clutch").replace(
        "state = [0.1, 150.0, 12.0]", "state = [0.08, 140.0, 15.0]"
    )
    assert started != builtin_text("ice_clutch")
    schedule = [(0, DWELL), (1, DWELL)] * 3
    _, _, signals, exact = clutch_run(started, "-4,-8,-12", schedule)
    error = np.abs(exact.state_means - signals.truth_states) / SCALE
    assert "jump maps R applied at 5 of them" in exact.notes[0]
    # without the maps the estimate is off by the jump (ω × J_L/(J_E+J_L)) right after
    without = started.split('[jumps."0->1"]')[0] + "[noise]" + started.split("[noise]")[1]
    _, _, _, ignored = clutch_run(without, "-4,-8,-12", schedule)
    first = DWELL  # the first engaging sample
    wrong = np.abs(ignored.state_means[first] - signals.truth_states[first]) / SCALE
    omega = signals.truth_states[first - 1, 1]
    np.testing.assert_allclose(wrong[1], omega / 3 / SCALE[1], rtol=0.05)  # J_L/(J_E+J_L) = 1/3
    # started on the truth, the estimate with the maps stays on it across all five jumps: its
    # error (the hold's and the integration's) is 30 times below that one jump's
    assert error.max() < wrong[1] / 30
    assert error[first].max() < wrong[1] / 30


def test_a_log_of_simulate_is_switched_where_simulate_switched():
    """simulate's row k + 1 mode runs (t_k, t_{k+1}], its jump at t_k^+: so does the observer.

    Applied at t_{k+1} after an interval in the old mode, the jump left an error of 0.2-0.37
    (2-4 N m of T) after each switch of a ``simulate`` log, whatever the error before it.
    """
    started = builtin_text("ice_clutch").replace(
        "state = [0.1, 150.0, 12.0]", "state = [0.08, 140.0, 15.0]"
    )
    model = parse_model(started, origin="ice_clutch")
    log = simulate(model, schedule="0:60,1:60,0:60,1:60", noise=False)
    signals = log.signals(model)
    result = prepare(model, "switching-observer", {}).run(model, signals)
    norm = np.linalg.norm((result.state_means - signals.truth_states) / SCALE, axis=1)
    assert "jump maps R applied at 3 of them" in result.notes[0]
    # started on the truth: the first-order hold's error of the start (0.02) has decayed
    # to 2.5e-4 before the first switch, and stays below 1e-2 across all three
    assert norm[60:].max() < 1e-2, norm[60:].max()


def test_mode_probabilities_are_the_known_switching_signal(switched):
    _, _, signals, result = switched
    np.testing.assert_array_equal(result.modes, signals.truth_modes)
    np.testing.assert_array_equal(result.mode_probabilities[:, 1], signals.truth_modes)
    assert any("kappa_1(Q)" in note for note in result.notes)
    assert not any(note.startswith("WARNING") for note in result.notes)


def test_logs_of_one_and_no_sample(switched):
    model, _, signals, _ = switched
    for count in (1, 0):
        short = AlignedSignals(
            **{
                **signals.__dict__,
                **{k: getattr(signals, k)[:count] for k in ("time", "inputs", "outputs")},
                "truth_modes": signals.truth_modes[:count],
                "truth_states": signals.truth_states[:count],
            }
        )
        result = prepare(model, "switching-observer").run(model, short)
        assert result.state_means.shape == (count, 3)
        np.testing.assert_array_equal(result.state_means, np.tile(model.initial_state, (count, 1)))


def test_ill_conditioned_q_is_a_warning_naming_time_and_value(switched):
    model, _, signals, _ = switched
    prepared = prepare(model, "switching-observer", {"condition_limit": "2e4"})
    result = prepared.run(model, signals)
    (warning,) = [n for n in result.notes if n.startswith("WARNING")]
    assert "ill-conditioned (kappa_1 > 2e+04)" in warning and "t = " in warning
    assert "worst" in warning


def test_a_condition_limit_that_would_hide_no_correct_digit_is_refused(switched):
    # condition_limit = 1e300 was in range: it silenced the warning even where κ₁(Q) is past
    # 1/ε, where the correction Q⁻¹K(y − h) may hold no correct digit, and the run said nothing
    model, _, signals, _ = switched
    with pytest.raises(
        OptionError,
        match=r"^--set condition_limit=1e300: switching-observer option 'condition_limit': "
        r"1e\+300 is outside \[1, 4503599627370496\]$",
    ):
        prepare(model, "switching-observer", {"condition_limit": "1e300"})
    ceiling = prepare(model, "switching-observer", {"condition_limit": str(2.0**52)})
    assert ceiling.options.condition_limit == 2.0**52
    assert ceiling.run(model, signals).state_means.shape[0] == signals.n_samples


def test_refusals_name_the_model_and_why(switched, tmp_path):
    model, _, signals, _ = switched
    two_outputs = VAN_DER_POL.replace('outputs = ["y"]', 'outputs = ["y", "v"]').replace(
        'h = ["x1 + x1**3/3"]', 'h = ["x1", "x2"]'
    )
    path = tmp_path / "two.toml"
    path.write_text(two_outputs)
    with pytest.raises(
        ModelError,
        match=rf"^{path}: estimator 'switching-observer' needs a "
        r"single-output model .* 2 outputs \(y, v\)$",
    ):
        run_switching_observer(load_model(path), signals, SwitchingObserverOptions())
    # refused when prepared, before any log is read
    with pytest.raises(
        ModelError,
        match=rf"^{path}: estimator 'switching-observer' needs a single-output model; the "
        r"model has 2 outputs \(y, v\)",
    ):
        prepare(load_model(path), "switching-observer")
    blind = AlignedSignals(**{**signals.__dict__, "truth_modes": None})
    with pytest.raises(LogError, match="needs the switching signal in the log; map it with --map"):
        prepare(model, "switching-observer").run(model, blind)
    with pytest.raises(LogError, match="needs the switching signal"):
        run_switching_observer(model, blind, SwitchingObserverOptions())
    # a switching signal that starts late: its first samples have no mode to take (-1)
    late_modes = signals.truth_modes.copy()
    late_modes[:5] = NO_TRUE_MODE
    late = AlignedSignals(**{**signals.__dict__, "truth_modes": late_modes})
    with pytest.raises(
        LogError,
        match=rf"needs the switching signal at every sample; the true mode starts at "
        rf"t={format_time(signals.time[5])} s \(sample 5\), after the first sample time",
    ):
        list(prepare(model, "switching-observer").stream(model, late))
    with pytest.raises(OptionError, match=r"'eigenvalues': the model has 3 states, so give 3"):
        run_switching_observer(model, signals, SwitchingObserverOptions(eigenvalues="-1,-2"))
    with pytest.raises(OptionError, match=r"'eigenvalues': every eigenvalue must be .* negative"):
        run_switching_observer(model, signals, SwitchingObserverOptions(eigenvalues="-1,2,-3"))
    with pytest.raises(ModelError, match="needs a continuous-time model"):
        prepare(load_model("three_tank_hstf"), "switching-observer")
    assert prepare(parse_model(model_kinds.CLUTCH_JUMPS), "switching-observer")


def test_analyze_a_clutch_log_end_to_end_and_without_the_mode_column(switched, tmp_path):
    import polars as pl

    from hybridlog.jobs.analysis import analyze

    _, _, signals, _ = switched
    columns = {"time": signals.time, "alpha": signals.inputs[:, 0], "y": signals.outputs[:, 0]}
    log = tmp_path / "clutch.csv"
    pl.DataFrame({**columns, "mode": signals.truth_modes}).write_csv(log)
    outcome = analyze(log, "ice_clutch", out_dir=tmp_path / "out", sets=["eigenvalues=-4,-8,-12"])
    report = outcome.report
    # its modes are the log's switching signal, the true mode: nothing to score (it said 1.0)
    assert report.modes.accuracy is None and report.modes.detection is None
    assert report.null_reasons["mode_accuracy"].startswith("switching-observer takes its modes")
    text = (tmp_path / "out" / "report.md").read_text()
    assert "11 mode switches in the switching signal." in text
    assert "given, not estimated, so no mode metric is scored." in text
    assert any("jump maps R applied at 11 of them" in note for note in report.notes)
    blind = tmp_path / "blind.csv"
    pl.DataFrame(columns).write_csv(blind)
    with pytest.raises(LogError, match=r"blind\.csv: estimator 'switching-observer' needs the "):
        analyze(blind, "ice_clutch", out_dir=tmp_path / "none")
    assert not (tmp_path / "none").exists()


def test_a_diverged_estimate_is_an_error_naming_the_time():
    # A stalled engine as the prior: at m = ω = T = 0, det Q = (β̄e/J²)(pω − (e'/e) L_f h) = 0
    stalled = builtin_text("ice_clutch").replace(
        "state = [0.1, 150.0, 12.0]", "state = [0.0, 0.0, 0.0]"
    )
    with pytest.raises(
        ModelError, match=r"switching-observer diverged at t = 0\.01 s \(sample 1\)"
    ) as caught:
        clutch_run(stalled, "-4,-8,-12", [(0, 30), (1, 30)])
    # the loop's kappa_1(Q) names the cause: Q singular at the prior, not everywhere
    assert "of mode '0' is singular at t = 0 s, at the estimate m = 0, omega = 0, T = 0: Q^-1" in (
        str(caught.value)
    )
    assert "drift-observable" not in str(caught.value)
    # a gain too large for the integration step: was exit 0 with the prior's error as RMSE;
    # refused before the run, naming the eigenvalue RK4's step cannot follow
    with pytest.raises(OptionError, match=r"λ = -30000 1/s is too fast for integration.step"):
        clutch_run(builtin_text("ice_clutch"), "-1e4", [(0, 30), (1, 30)])


@pytest.mark.parametrize(
    ("eigenvalues", "words"),
    [
        # one value expanded to l, 2l, 3l: 3l was -inf, which the step check let through,
        # and the run "diverged" naming eigenvalues "-1e+308, -inf, -inf"
        ("-1e308", r"one value l stands for l, 2l, \.\.\., 3l, and 3\*\('-1e308'\) overflows"),
        # K = [6e-200, 0, 0] placed eigenvalues at 0, not Λ: exit 0 with a note naming Λ
        ("-1e-200", r"the gain K_2 of -1e-200, -2e-200, -3e-200 .* is 0, not a positive"),
        # K_3 = 1e600 overflows (the step check itself overflowed: a traceback)
        ("-1e200,-1e200,-1e200", r"the gain K_2 of .* is inf, not a positive"),
        # R(h·λ) of RK4 overflows a Python complex in the step check: was a traceback
        (
            "-1e80",
            r"λ = -3e\+80 1/s is too fast .* by more than float64 holds a step .* 6\.97e-81 s",
        ),
    ],
)
def test_eigenvalues_whose_gain_float64_cannot_hold_are_refused(switched, eigenvalues, words):
    model, _, signals, _ = switched
    with pytest.raises(OptionError, match=rf"^switching-observer option 'eigenvalues': {words}"):
        run_switching_observer(model, signals, SwitchingObserverOptions(eigenvalues=eigenvalues))


UNOBSERVABLE = """
name = "blind"
time = "continuous"
dt = 0.01
integration = {method = "rk4", step = 0.002}
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y"]

[modes.a]
dx = [%s]
h = [%s]

[modes.b]
dx = ["x2 - x1", "-x1 - x2 + u"]
h = ["x1"]

[initial]
state = [0.5, 0.5]
mode = "a"
"""


@pytest.mark.parametrize(
    ("dx", "h", "words"),
    [
        # x2 enters neither h nor L_f h: a zero column of Q
        ('"-x1 + u", "-2*x2"', '"x1"', "and at every state: x2 enter(s) no entry of Phi"),
        # Phi = [x1 + x2, -2 (x1 + x2)]: no zero column, det Q = 0 for every state
        ('"-x1 - x2 + u", "-x1 - x2"', '"x1 + x2"', "and at every state (det Q = 0)"),
    ],
)
def test_a_mode_that_is_not_drift_observable_is_named_as_the_cause(dx, h, words):
    """A mode whose Q is singular everywhere: named, not a list of possible causes.

    The refusal said "the estimate is not finite (Q singular, a jump map or the gain of
    eigenvalues -5, -10 too large for the integration step)" whichever it was.
    """
    model = parse_model(UNOBSERVABLE % (dx, h), origin="blind.toml")
    count = 20
    signals = AlignedSignals(
        source="blind.csv",
        time=np.arange(count) * 0.01,
        input_names=("u",),
        output_names=("y",),
        inputs=np.zeros((count, 1)),
        outputs=np.ones((count, 1)),
        truth_modes=np.array([0] * 10 + [1] * 10),
        state_names=("x1", "x2"),
        truth_states=np.zeros((count, 2)),
    )
    with pytest.raises(ModelError) as caught:
        run_switching_observer(model, signals, SwitchingObserverOptions())
    message = str(caught.value)
    assert message.startswith("blind.toml: switching-observer diverged at t = 0.01 s")
    assert "Q = dPhi/dx (eq. (21)) of mode 'a' is singular at t = 0 s" in message
    assert words in message and message.endswith("mode 'a' is not drift-observable from y")
    assert "jump map" not in message


KINDS = """
name = "kinds"
time = "continuous"
dt = 0.1
integration = {method = "rk4", step = 0.01}
states = ["h1"]
inputs = ["u"]
outputs = ["y"]

[modes.calm]
dx = ["-h1"]
h = ["h1"]

[modes.dom]
dx = ["-h1 + 0.01*log(h1)"]
h = ["h1"]

[modes.hdom]
dx = ["-h1"]
h = ["sqrt(h1)"]

[modes.over]
dx = ["exp(1000*h1)"]
h = ["h1"]

[modes.qdom]
dx = ["-h1"]
h = ["h1*sqrt(abs(h1))"]

[modes.cube]
dx = ["-h1"]
h = ["h1**3"]

[jumps."calm->dom"]
h1 = "sqrt(h1 - 2)"

[initial]
state = [%s]
mode = "calm"
"""


@pytest.mark.parametrize(
    ("modes", "start", "measured", "words"),
    [
        # dx = log(h1) at an estimate driven below 0: was "(a jump map, or the gain of
        # eigenvalues -5 too large for the integration step)", naming neither key nor dx
        (
            ["dom"] * 4,
            "0.5",
            -1.0,
            r"^kinds\.toml: modes\.dom\.dx\[0\]: '-h1 \+ 0\.01\*log\(h1\)' is nan at h1 = -"
            r"[0-9.]+, u = 0, a step of the interval from t = 0 s to 0\.1 s \(the estimate left "
            r"the domain of dx there\): switching-observer diverged at t = 0\.1 s \(sample 1\)",
        ),
        (
            ["hdom"] * 4,
            "0.5",
            -10.0,
            r"^kinds\.toml: modes\.hdom\.h\[0\]: 'sqrt\(h1\)' is nan at h1 = -[0-9.]+, u = 0, "
            r".*\(the estimate left the domain of h there\)",
        ),
        (
            ["over"] * 4,
            "0.5",
            0.5,
            r"^kinds\.toml: modes\.over\.dx\[0\]: 'exp\(1000\*h1\)' is inf at h1 = .*\(more "
            r"than float64 holds: the estimate ran away\)",
        ),
        (
            ["calm", "calm", "dom", "dom"],
            "0.5",
            0.5,
            # the switch is at t_1^+ (R applied just after t = 0.1 s), the estimate not
            # finite at the next sample: the switch's time was said as 0.2 s
            r"^kinds\.toml: jumps\.\"calm->dom\": the jump map gives h1 = nan at the switch "
            r"from 'calm' to 'dom' at t = 0\.1 s, from h1 = 0\.4[0-9]+: switching-observer "
            r"diverged at t = 0\.2 s \(sample 2\)",
        ),
        # h finite at 0, dh/dx = 0/0 there: Q, derived, is named with its mode
        (
            ["qdom"] * 4,
            "0.0",
            1.0,
            r"diverged at t = 0\.1 s \(sample 1\): the estimate is not finite: Q = dPhi/dx "
            r"\(eq\. \(21\)\) of mode 'qdom', derived from its dx and h, is not finite at the "
            r"estimate h1 = 0, u = 0",
        ),
        # Q = 3 h1^2 at 1e-70: the correction's Jacobian is -3e210, which no step follows
        (
            ["cube"] * 4,
            "1e-70",
            1.0,
            r"the estimate ran away\): .*: observer \(20\) linearised at t = 0 s has "
            r"λ = -3\.333e\+210 1/s, which integration\.step = 0\.01 s cannot follow "
            r"\(unstable; at most 6\.27e-211 s would\); the interval before corrected with "
            r"y = 1 measured at the estimate h1 = 1e-70$",
        ),
        # every expression finite, the RK4 sum of a state near float64's end overflows
        (
            ["calm"] * 4,
            "1e307",
            1.0,
            r"the estimate is not finite \(every expression finite along the interval: the "
            r"correction Q\^-1 K \(y - h\) of the gain of eigenvalues -5 outgrew float64\)",
        ),
    ],
)
def test_a_divergence_names_its_cause(modes, start, measured, words):
    """The interval into the first non-finite estimate is replayed with the model watched."""
    model = parse_model(KINDS % start, origin="kinds.toml")
    count = len(modes)
    signals = AlignedSignals(
        source="kinds.csv",
        time=np.arange(count) * 0.1,
        input_names=("u",),
        output_names=("y",),
        inputs=np.zeros((count, 1)),
        outputs=np.full((count, 1), measured),
        truth_modes=np.array([model.mode_ids.index(m) for m in modes]),
    )
    with pytest.raises(ModelError) as caught:
        run_switching_observer(model, signals, SwitchingObserverOptions())
    message = str(caught.value)
    assert re.search(words, message), message
    assert "\n" not in message


def test_an_interval_without_its_measurement_names_no_stand_in_as_measured():
    # the refusal said "the interval before corrected with y = 12345 measured" of a value
    # the alignment had put where the log measured nothing
    model = parse_model(KINDS % "0.5", origin="kinds.toml")
    count = 4
    signals = AlignedSignals(
        source="kinds.csv",
        time=np.arange(count) * 0.1,
        input_names=("u",),
        output_names=("y",),
        inputs=np.zeros((count, 1)),
        outputs=np.full((count, 1), 12345.0),
        truth_modes=np.full(count, model.mode_ids.index("over")),
        unmeasured_outputs=np.ones((count, 1), dtype=bool),
    )
    with pytest.raises(ModelError) as caught:
        run_switching_observer(model, signals, SwitchingObserverOptions())
    message = str(caught.value)
    assert message.endswith(
        "; the interval before ran without correction (y not measured at t = 0 s) from the "
        "estimate h1 = 0.5"
    ), message
    assert "12345" not in message and "measured at the estimate" not in message


@pytest.mark.parametrize("hold", ["zero", "first"])
def test_an_unmeasured_sample_turns_the_injection_off_for_its_interval(vdp_log, hold):
    # paper 004 observer (18)/(20) with K = 0 over [t_k, t_k+1) where y(k) was not measured,
    # the first-order hold's slope from the last measured sample: solve_ivp by hand; the
    # observer integrated the value the alignment put there as a measurement
    unmeasured = np.zeros((vdp_log.n_samples, 1), dtype=bool)
    unmeasured[1::3] = unmeasured[2::7] = True
    options = SwitchingObserverOptions(eigenvalues="-3,-6", output_hold=hold)
    model = parse_model(VAN_DER_POL)
    result = run_switching_observer(model, with_stand_ins(vdp_log, unmeasured, 40.0), options)
    other = run_switching_observer(model, with_stand_ins(vdp_log, unmeasured, -3.0), options)
    assert_same(result, other)
    halved = parse_model(VAN_DER_POL.replace("step = 0.002", "step = 0.001"))
    finer = run_switching_observer(halved, with_stand_ins(vdp_log, unmeasured, 40.0), options)
    reference = reference_run(vdp_log, [0.5, -0.5], hold, unmeasured[:, 0])
    tolerance = 2.0 * np.abs(result.state_means - finer.state_means).max() + 1e-9
    assert np.abs(result.state_means - reference).max() <= tolerance < 1e-6
    assert "ran without output injection" in "\n".join(result.notes)


def test_the_stand_ins_on_the_clutch_change_nothing(switched):
    # every other sample of y not measured, across switches and jump maps
    model, _, signals, _ = switched
    unmeasured = (np.arange(signals.n_samples) % 2 == 1)[:, None]
    options = SwitchingObserverOptions(eigenvalues="-4,-8,-12")
    held = np.roll(signals.outputs, 1, axis=0)
    first = run_switching_observer(model, with_stand_ins(signals, unmeasured, held), options)
    again = run_switching_observer(model, with_stand_ins(signals, unmeasured, 0.0), options)
    assert_same(first, again)
    error = np.abs(first.state_means - signals.truth_states)[-DWELL:] / SCALE
    assert error.max() < 5e-3  # from 1.3 at the start: the measured half drives it home


def test_a_log_starting_in_another_mode_than_initial_mode_is_said_so():
    # the model's [initial] mode is '0'; a log starting engaged ran without a word of it
    schedule = [(1, DWELL), (0, DWELL)]
    _, _, signals, result = clutch_run(builtin_text("ice_clutch"), "-4,-8,-12", schedule)
    assert signals.truth_modes is not None and signals.truth_modes[0] == 1
    (note,) = [n for n in result.notes if n.startswith("[initial] mode not used")]
    assert "initial mode is '0' (prior 1)" in note and "starts in '1' (prior 0)" in note
    assert 'the jump map jumps."0->1" was not applied' in note
    _, _, _, expected = clutch_run(builtin_text("ice_clutch"), "-4,-8,-12", schedule[::-1])
    assert not any(n.startswith("[initial]") for n in expected.notes)


def test_a_state_no_derivative_of_the_output_reads_is_refused_before_any_log():
    """x2 enters neither h nor, through dx, L_f h: Q is singular at every state.

    Read off the model alone, as ``hybridlog models FILE`` prepares it: such a model was
    passed there and refused by ``analyze`` as diverged at its first sample.  A state that
    is reached but cancels (det Q = 0 with no zero column) is left to the run's diagnosis.
    """
    blind = parse_model(UNOBSERVABLE % ('"-x1 + u", "-2*x2"', '"x1"'), origin="blind.toml")
    with pytest.raises(ModelError) as caught:
        prepare(blind, "switching-observer")
    message = str(caught.value)
    assert message == (
        "blind.toml: estimator 'switching-observer' needs every mode drift-observable from its "
        "output; x2 enter(s) neither modes.a.h nor, through its dx, any time derivative of it: "
        "Q = dPhi/dx (eq. (21)) of mode 'a' is singular at every state"
    )
    # the input is no path: u reads no state, and the drift takes it at zero
    reached = parse_model(UNOBSERVABLE % ('"-x1 + x2*u", "-2*x2"', '"x1"'), origin="u.toml")
    with pytest.raises(ModelError, match="x2 enter"):
        prepare(reached, "switching-observer")
    cancelled = parse_model(
        UNOBSERVABLE % ('"-x1 - x2 + u", "-x1 - x2"', '"x1 + x2"'), origin="c.toml"
    )
    prepare(cancelled, "switching-observer")
    prepare(load_model("ice_clutch"), None)


def test_intervals_a_switch_opened_are_counted_and_a_log_of_them_warned_of(switched):
    # An interval a switch opens runs without output injection (module doc); only those whose
    # y was not measured were told, so a switching signal changing every sample ran the whole
    # log open loop (the model's run from [initial] state) to exit 0 with no word of why.
    from dataclasses import replace

    model, _, signals, result = switched
    switches = int(np.count_nonzero(np.diff(signals.truth_modes)))
    intervals = signals.n_samples - 1
    assert (
        f"{switches:,} of {intervals:,} intervals ran without output injection (observer (20) "
        f"with K = 0): a switch opened {switches:,} (y measured the state before the jump)"
    ) in result.notes
    assert not any(note.startswith("WARNING") for note in result.notes)
    every = replace(signals, truth_modes=np.arange(signals.n_samples) % 2)
    options = SwitchingObserverOptions(eigenvalues="-4,-8,-12")
    notes = run_switching_observer(model, every, options).notes
    assert f"{intervals:,} of {intervals:,} intervals ran without output injection" in notes[-2]
    assert notes[-1].startswith(
        f"WARNING: the observer corrected its estimate on only 0 of {intervals:,} intervals"
    )


CUBIC = """
name = "cubic"
time = "continuous"
dt = 0.01
integration = {method = "rk4", step = 0.001}
states = ["x1", "x2"]
outputs = ["y"]
inputs = []

[modes.a]
dx = ["x2", "-x1"]
h = ["x1**3"]

[initial]
state = [1.0, %s]
mode = "a"

[estimators.switching-observer]
eigenvalues = "-5,-6"
"""


@pytest.mark.parametrize("x2", ["0.5", "0.3", "-0.4"])
def test_q_singular_between_samples_is_warned_where_the_estimate_crossed(x2):
    """Q = [[3x1², 0], [6x1x2, 3x1²]] is singular at x1 = 0, which x̂1 crosses between samples.

    κ₁(Q) was taken at the samples only: the correction of the integration steps next to the
    crossing, with κ₁ past 1e8, threw the estimate off (to 1e40 by 10 s, still finite, so no
    divergence), and the warning named a sample of 1e6 elsewhere, or nothing.  Every
    crossing of 0 by x̂1 must lie in an interval the warning names.
    """
    model = parse_model(CUBIC % x2, origin="cubic.toml")
    times = np.arange(1001) * 0.01
    signals = AlignedSignals(
        source="cubic.csv",
        time=times,
        input_names=(),
        output_names=("y",),
        inputs=np.zeros((times.size, 0)),
        outputs=(np.cos(times) ** 3).reshape(-1, 1),
    )
    result = prepare(model, "switching-observer").run(model, signals)
    (warning,) = [n for n in result.notes if n.startswith("WARNING: Q(sigma, x)")]
    spans = [(float(a), float(b)) for a, b in re.findall(r"t = ([0-9.]+)\.\.([0-9.]+) s", warning)]
    estimate = result.state_means[:, 0]
    crossings = np.flatnonzero(np.sign(estimate[:-1]) != np.sign(estimate[1:])) + 1
    assert crossings.size, "the estimate never crossed the singular line"
    for k in crossings[:3]:  # the warning names the first three runs of samples
        assert any(a <= times[k] <= b for a, b in spans), (times[k], warning)
    worst = float(re.search(r"worst ([0-9.e+]+) at", warning).group(1))
    assert worst > 1e8
