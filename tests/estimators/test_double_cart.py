"""Paper 001's double cart: state-driven switching, the chiu/kmeans estimators, the CLI."""

import dataclasses
import json
import time

import numpy as np
import pytest
from click.testing import CliRunner

from hybridlog.cli import main
from hybridlog.cluster.centers_file import centers_json, parse_centers
from hybridlog.errors import LogError, ModelError, OptionError
from hybridlog.estimators.chiu import (
    ChiuOptions,
    chiu_options,
    design_observer,
    mode_classifier,
    run_chiu,
)
from hybridlog.estimators.kmeans import KMeansOptions, run_kmeans
from hybridlog.estimators.switched_observer import LinearModes, linear_modes, run_observer
from hybridlog.jobs.analysis import analyze
from hybridlog.model.loader import load_model, parse_model
from hybridlog.simulate import simulate
from tests.support.paths import SAMPLE_LOGS
from tests.support.unmeasured import assert_same, with_stand_ins

SAMPLE = SAMPLE_LOGS / "double_cart_case1.csv"


def signals_of(model, log):
    return log.signals(model)


@pytest.mark.parametrize("name", ["double_cart_case1", "double_cart_case2"])
def test_state_driven_simulation_follows_the_guards(name):
    model = load_model(name)
    assert model.state_driven and model.mode_ids == ("1", "2")
    log = simulate(model, steps=400, seed=1)
    np.testing.assert_array_equal(log.modes, (log.states[:, 2] > 0).astype(int))
    linear = linear_modes(model)
    # paper 001 eq. (1): the mode of row k governs the step from x(k) (noise-free states)
    for k in range(400):
        q = log.modes[k]
        expected = linear.A[q] @ log.states[k] + linear.B[q] @ log.inputs[k]
        np.testing.assert_allclose(log.states[k + 1], expected, atol=1e-12)
    plain = simulate(model, steps=60, seed=1, jit=False)
    np.testing.assert_allclose(plain.states, simulate(model, steps=60, seed=1).states)


def test_ten_thousand_steps_simulate_fast():
    model = load_model("double_cart_case1")
    simulate(model, steps=100, seed=0)  # compile or load from the cache
    start = time.perf_counter()
    simulate(model, steps=10_000, seed=0)
    assert time.perf_counter() - start < 1.0


GUARDED = """
name = "g"
dt = 1.0
states = ["x"]
inputs = ["u"]
outputs = ["y"]
[modes.low]
A = [[0.5]]
B = [[1.0]]
C = [[1.0]]
{low}
[modes.high]
A = [[0.9]]
B = [[1.0]]
C = [[1.0]]
{high}
[noise]
measurement = 1.0
[initial]
state = [0.0]
[simulation]
state = [0.0]
{simulation}
[simulation.inputs]
u = "sin(t)"
"""


@pytest.mark.parametrize(
    ("low", "high", "simulation", "message"),
    [
        ('guard = "x <= 0"', "", "", "modes.high.guard: missing"),
        ('guard = "x"', 'guard = "x > 0"', "", "modes.low.guard: expected a comparison"),
        ('guard = "z <= 0"', 'guard = "x > 0"', "", "modes.low.guard: unknown symbol 'z'"),
        ('guard = "x <="', 'guard = "x > 0"', "", "modes.low.guard: cannot parse"),
        ('guard = "1 < 2"', 'guard = "x > 0"', "", "always holds, whatever the states and inputs"),
        ('guard = "x <= 0"', 'guard = "x > 0"', 'schedule = "low:3"', "simulation.schedule"),
        ("guard = 3", 'guard = "x > 0"', "", "modes.low.guard: expected a string"),
    ],
)
def test_bad_guards_name_the_key(low, high, simulation, message):
    with pytest.raises(ModelError, match=message):
        parse_model(GUARDED.format(low=low, high=high, simulation=simulation))


def test_guards_first_wins_none_is_an_error_schedule_refused():
    model = parse_model(
        GUARDED.format(low='guard = "x <= 0.5"', high='guard = "x > 0"', simulation="")
    )
    log = simulate(model, steps=50)
    assert np.all(log.modes[log.states[:, 0] <= 0.5] == 0)
    with pytest.raises(OptionError, match="--schedule"):
        simulate(model, schedule="low:3")
    gap = parse_model(GUARDED.format(low='guard = "x < -5"', high='guard = "x > 5"', simulation=""))
    with pytest.raises(ModelError, match="no mode's guard"):
        simulate(gap, steps=5)


def test_observer_with_true_modes_converges_and_plain_path_agrees():
    model = load_model("double_cart_case1")
    log = simulate(model, steps=600, seed=4)
    linear, gains = design_observer(model, 1.0)
    means, predictions = run_observer(
        linear, gains.gains, log.inputs, log.outputs, log.modes, model.initial_state
    )
    assert np.abs(means[-100:] - log.states[-100:]).max() < 0.02
    assert np.isnan(predictions[0, 0]) and np.all(np.isfinite(predictions[1:]))
    plain = run_observer(
        linear, gains.gains, log.inputs, log.outputs, log.modes, model.initial_state, jit=False
    )
    np.testing.assert_allclose(plain[0], means, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("jit", [True, False])
def test_an_unmeasured_output_corrects_nothing_and_with_none_the_step_is_open_loop(jit):
    # paper 001 eq. (8) with the innovation of an output the log did not measure (NaN) 0:
    # the stand-in the alignment put there was used as a fresh measurement
    rng = np.random.default_rng(7)
    s, n, m, p, count = 2, 3, 1, 2, 6
    A, B = 0.5 * rng.normal(size=(s, n, n)), rng.normal(size=(s, n, m))
    C, D = rng.normal(size=(s, p, n)), rng.normal(size=(s, p, m))
    c, d, L = rng.normal(size=(s, n)), rng.normal(size=(s, p)), rng.normal(size=(s, n, p))
    linear = LinearModes(A=A, B=B, C=C, D=D, state_offsets=c, output_offsets=d)
    inputs, outputs = rng.normal(size=(count, m)), rng.normal(size=(count, p))
    outputs[2, :] = np.nan  # no output measured at step 2
    outputs[4, 1] = np.nan  # y_1 alone at step 4
    modes = np.array([0, 1, 1, 0, 1, 0])
    means, _ = run_observer(linear, L, inputs, outputs, modes, rng.normal(size=n), jit=jit)
    assert np.isfinite(means).all()
    q, x, u = modes[2], means[2], inputs[2]
    np.testing.assert_allclose(means[3], A[q] @ x + B[q] @ u + c[q], rtol=1e-13, atol=1e-15)
    q, x, u = modes[4], means[4], inputs[4]
    innovation = outputs[4, 0] - (C[q, 0] @ x + D[q, 0] @ u + d[q, 0])
    expected = A[q] @ x + B[q] @ u + c[q] + L[q, :, 0] * innovation
    np.testing.assert_allclose(means[5], expected, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("runner", ["chiu", "kmeans"])
def test_the_stand_ins_of_unmeasured_outputs_change_nothing(runner):
    # the observer updated on the value the alignment put where the log measured nothing,
    # and the nearest-centre decision read it: another stand-in, another result
    model = load_model("double_cart_case1")
    signals = signals_of(model, simulate(model, steps=300, seed=5))
    unmeasured = (np.arange(signals.n_samples) % 4 == 2)[:, None]
    run, options = (run_chiu, ChiuOptions()) if runner == "chiu" else (run_kmeans, KMeansOptions())
    before = np.roll(signals.outputs, 1, axis=0)  # the sample before, as the alignment takes
    first = run(model, with_stand_ins(signals, unmeasured, before), options)
    assert_same(first, run(model, with_stand_ins(signals, unmeasured, -7.5), options))
    (vouched,) = first.timeline_columns
    np.testing.assert_array_equal(vouched.values == 0.0, unmeasured[:, 0])
    # the decision of a sample without a measured output is the one of the sample before
    rows = np.flatnonzero(unmeasured[:, 0])
    np.testing.assert_array_equal(first.modes[rows], first.modes[rows - 1])


@pytest.mark.parametrize("runner", ["chiu", "kmeans"])
def test_estimators_on_the_double_cart(runner):
    model = load_model("double_cart_case2")
    log = simulate(model, steps=500, seed=2)
    signals = signals_of(model, log)
    run = run_chiu if runner == "chiu" else run_kmeans
    result = run(model, signals, ChiuOptions() if runner == "chiu" else KMeansOptions())
    assert result.estimator == runner
    accuracy = np.mean(result.modes == log.modes)
    assert accuracy > 0.85  # ground truth is never used: labels come from prediction fit
    np.testing.assert_array_equal(result.mode_probabilities.sum(axis=1), 1.0)
    assert np.all(np.isnan(result.state_variances))
    assert any("->" in note and "mode" in note for note in result.notes)
    assert "lmi_margin" in result.options["observer"]


@pytest.mark.parametrize("scale", [0.0, 1e-300])
def test_a_log_that_does_not_tell_the_modes_apart_is_refused_not_labelled_by_order(scale):
    # a cart at rest (y = u = 0), or every signal near 1e-300 (squared errors underflow to
    # 0): every cluster -> mode map scores SSE 0, and the map was the search's first, its
    # mode accuracy reported (chiu 33.7 % on a log at rest, where kmeans refused it)
    model = load_model("double_cart_case1")
    log = simulate(model, steps=100, seed=1)
    still = dataclasses.replace(log, outputs=log.outputs * scale, inputs=log.inputs * scale)
    signals = still.signals(model, source="rest.csv")
    with pytest.raises(LogError, match=r"rest\.csv: chiu cannot label its clusters as modes"):
        run_chiu(model, signals, ChiuOptions())
    if scale:  # at rest kmeans finds a single distinct point and says so before labelling
        with pytest.raises(LogError, match="kmeans cannot label its clusters as modes"):
            run_kmeans(model, signals, KMeansOptions())
    # the labels given by hand are the user's, not a guess
    given = run_chiu(model, signals, ChiuOptions(cluster_modes="1" if not scale else "1,1,1,2"))
    assert not any(note.startswith("WARNING: the one-step") for note in given.notes)


BLIND = """
name = "blind"
dt = 0.1
states = ["x1", "x2"]
inputs = ["u"]
outputs = ["y"]
[parameters]
g = 1.0
[modes.lo]
guard = "x2 <= 0"
A = [[0.5, 0.3], [-0.3, 0.9]]
B = [0.1, 0.2]
C = ["g", 0.0]
[modes.hi]
guard = "x2 > 0"
A = [[0.9, 0.1], [-0.2, 0.5]]
B = [0.1, 0.3]
C = ["g", 0.0]
[noise]
measurement = 1e-6
[initial]
state = [0.0, 0.0]
covariance = 1.0
[simulation]
state = [0.1, -0.1]
inputs = { u = "sin(0.5*t)" }
"""
"""Two stable modes seen through a sensor of gain ``g``."""


@pytest.mark.parametrize("runner", ["chiu", "kmeans"])
def test_a_model_whose_outputs_read_no_state_is_named_not_the_log(runner):
    # its sensor gain set to 0 (--set g=0: C = 0 in both modes), every labelling predicts
    # y = 0 whatever the log; the log was blamed ("a plant at rest") for one that moved
    signals = signals_of(parse_model(BLIND), simulate(parse_model(BLIND), steps=200, seed=1))
    blind = parse_model(BLIND.replace("g = 1.0", "g = 0.0"))
    run = run_chiu if runner == "chiu" else run_kmeans
    refused = f"{runner} cannot label its clusters as modes: the outputs read no state in any"
    with pytest.raises(ModelError, match=refused):
        run(blind, signals, ChiuOptions() if runner == "chiu" else KMeansOptions())


def test_manual_labels_and_option_errors():
    model = load_model("double_cart_case1")
    signals = signals_of(model, simulate(model, steps=300, seed=1))
    swapped = run_kmeans(model, signals, KMeansOptions(cluster_modes="1,2"))
    assert any("cluster_modes=1,2" in note for note in swapped.notes)
    with pytest.raises(OptionError, match="cluster_modes=1,7: unknown mode '7'"):
        run_kmeans(model, signals, KMeansOptions(cluster_modes="1,7"))
    with pytest.raises(OptionError, match="output_lags: must contain 0"):
        run_chiu(model, signals, ChiuOptions(output_lags="1,2"))
    with pytest.raises(OptionError, match="chiu option 'method'"):
        chiu_options({"method": "fast"})
    with pytest.raises(ModelError, match="not linear"):
        run_chiu(load_model("three_tank_hstf"), signals, ChiuOptions())


def test_the_estimator_takes_parsed_centres_and_reads_no_file(tmp_path):
    model = load_model("double_cart_case1")
    signals = signals_of(model, simulate(model, steps=300, seed=1))
    fitted = run_chiu(model, signals, ChiuOptions())
    classifier = mode_classifier(model, signals, ChiuOptions(), observer=design_observer(model, 1))
    content = {
        "model": model.name,
        "mode_ids": list(model.mode_ids),
        "regressors": list(classifier.regressors),
        "output_lags": list(classifier.spec.output_lags),
        "input_lags": list(classifier.spec.input_lags),
        "scaling": {"lower": classifier.lower, "upper": classifier.upper},
        "chiu": {
            "centers": classifier.centers,
            "modes": [model.mode_ids[m] for m in classifier.cluster_modes],
        },
    }
    text = centers_json(content)
    missing = str(tmp_path / "never_written.json")
    options = ChiuOptions(centers=missing)
    with pytest.raises(OptionError, match=r"^centers=.*never_written.json: the estimator reads no"):
        run_chiu(model, signals, options)
    stored = run_chiu(model, signals, options, centers=parse_centers(text, missing))
    np.testing.assert_array_equal(stored.modes, fitted.modes)
    np.testing.assert_array_equal(stored.state_means, fitted.state_means)
    assert f"chiu: {len(classifier.centers)} centres loaded from {missing}" in stored.notes
    # centres fitted for another model (or for none named) are refused, not applied
    for other, words in (("double_cart_case2", "model 'double_cart_case2'"), ("", "no model")):
        wrong = parse_centers(centers_json(dict(content, model=other)), missing)
        with pytest.raises(OptionError, match=rf"model: the centres were fitted for {words}"):
            run_chiu(model, signals, options, centers=wrong)
    # a clustering option beside loaded centres would be ignored (and reported as used):
    # refused unless it is the one the file records its centres were fitted with (this
    # file records none)
    loaded = parse_centers(text, missing)
    for option, value, text_ in (
        ("radius", 0.3, "0.3"),
        ("method", "exact", "exact"),
        ("self_potential", False, "false"),
    ):
        with pytest.raises(
            OptionError,
            match=rf"^centers=.*never_written.json: {option}={text_} does not match the file's "
            rf"chiu centres, which do not record the {option} they were fitted with",
        ):
            run_chiu(
                model, signals, chiu_options({"centers": missing, option: value}), centers=loaded
            )
    kmeans_loaded = parse_centers(text.replace('"chiu"', '"kmeans"'), missing)
    for option, value in (("clusters", 2), ("restarts", 3), ("seed", 1)):
        with pytest.raises(OptionError, match=rf"{option}={value} does not match"):
            run_kmeans(
                model,
                signals,
                KMeansOptions(centers=missing, **{option: value}),
                centers=kmeans_loaded,
            )
    # ... and taken where the file records it; the report gives the file's values
    recorded = dict(content, chiu={**content["chiu"], "parameters": {"radius": 0.3}})
    with_radius = parse_centers(centers_json(recorded), missing)
    same = run_chiu(
        model, signals, chiu_options({"centers": missing, "radius": 0.3}), centers=with_radius
    )
    np.testing.assert_array_equal(same.modes, stored.modes)
    assert same.options["radius"] == 0.3
    assert same.options["squash"] is None  # not recorded: not known, not the default
    with pytest.raises(OptionError, match=r"radius=0.4 does not match .* fitted with radius=0.3"):
        run_chiu(
            model, signals, chiu_options({"centers": missing, "radius": 0.4}), centers=with_radius
        )
    run_kmeans(model, signals, KMeansOptions(centers=missing), centers=kmeans_loaded)
    assert list(tmp_path.iterdir()) == []


def run_cli(args, expect=0):
    runner = CliRunner()

    class _Main:
        name = "hybridlog"

        def main(self, args, prog_name=None, standalone_mode=True, **extra):
            try:
                main(list(args))
            except SystemExit as exit_:
                raise SystemExit(exit_.code) from None
            raise SystemExit(0)

    result = runner.invoke(_Main(), args, catch_exceptions=False)
    assert result.exit_code == expect, result.output + result.stderr
    return result


def test_cluster_command_then_analyze_with_the_centres(tmp_path):
    out = tmp_path / "c.json"
    result = run_cli(
        [
            "cluster",
            str(SAMPLE),
            "--model",
            "double_cart_case1",
            "--out",
            str(out),
            "--compare-kmeans",
        ]
    )
    assert "| chiu | 1 |" in result.output and "kmeans" in result.output
    assert (tmp_path / "c.png").stat().st_size > 10_000
    content = json.loads(out.read_text())
    assert content["regressors"] == ["y(k)", "y(k-1)", "u(k-1)"]
    assert content["chiu"]["modes"] and content["kmeans"]["modes"]
    assert content["chiu"]["parameters"]["squash"] == 1.25
    run_cli(["cluster", str(SAMPLE), "--model", "double_cart_case1", "--out", str(out)], expect=2)
    for estimator in ("chiu", "kmeans"):
        outcome = analyze(
            SAMPLE,
            "double_cart_case1",
            out_dir=tmp_path / estimator,
            estimator=estimator,
            sets=(f"centers={out}",),
        )
        report = outcome.report
        assert report.modes.accuracy > 0.8 and report.vaf > 99.0
        assert any("loaded from" in n for n in report.notes)
    # the fitted-on-the-log run gives the same decisions as the stored classifier
    fitted = analyze(SAMPLE, "double_cart_case1", out_dir=tmp_path / "fit", estimator="chiu")
    assert fitted.report.modes.accuracy == pytest.approx(
        json.loads((tmp_path / "chiu" / "report.json").read_text())["modes"]["accuracy"]
    )


def test_cluster_command_errors(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(
        '{"format": "hybridlog-centers", "version": 1, "mode_ids": ["1", "2"], '
        '"regressors": ["y(k)"]}'
    )
    result = run_cli(
        [
            "analyze",
            str(SAMPLE),
            "--model",
            "double_cart_case1",
            "--estimator",
            "chiu",
            "--set",
            f"centers={bad}",
            "--out",
            str(tmp_path / "r"),
        ],
        expect=2,
    )
    assert "scaling" in result.stderr and result.stderr.count("\n") == 1
    result = run_cli(
        [
            "cluster",
            str(SAMPLE),
            "--model",
            "double_cart_case1",
            "--radius",
            "0",
            "--out",
            str(tmp_path / "x.json"),
        ],
        expect=2,
    )
    assert "radius" in result.stderr
