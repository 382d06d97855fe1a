"""Numbers an estimator cannot vouch for never leave the estimators (hostile models and logs).

Before: a state that stayed finite while its variance overflowed, a negative variance of
-3e283 (``unknown-mode`` with an initial covariance of 1e300), or the generic IMM loop's NaN
predictions where one mode's ``h = sqrt(x)`` left its domain were written into the report
(the metrics silently taken over the rows left); a divergence said only "a Jacobian of the
model may be infinite there".  Now every result is checked where it leaves the estimators
(``estimators/vouch.py``): one line naming the model file, the estimator, the time and
sample, what is wrong and, where it can be told, the mode and expression that broke.
"""

import dataclasses
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hybridlog.errors import ModelError
from hybridlog.estimators import ESTIMATORS, Estimator, prepare
from hybridlog.estimators.filter_options import HstfOptions, ImmOptions
from hybridlog.estimators.hstf import run_hstf
from hybridlog.estimators.imm import run_imm
from hybridlog.estimators.registry import Prepared
from hybridlog.estimators.result import EstimationResult, PostProcessing
from hybridlog.estimators.vouch import check_result, first_flaw
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals
from tests.support.cpha import CPHA_EXAMPLE, cpha_log

N = 12
STATES = ("x1", "x2")
OUTPUTS = ("y",)
MODES = ("a", "b")


def clean(n=N, *, seed=0, estimator="fake"):
    """A result every check accepts: finite states, variances, predictions, distributions."""
    rng = np.random.default_rng(seed)
    p = rng.random((n, len(MODES)))
    p /= p.sum(axis=1, keepdims=True)
    predictions = rng.normal(size=(n, len(OUTPUTS)))
    predictions[0] = np.nan  # the prior predicts nothing
    return EstimationResult(
        estimator=estimator,
        options={},
        time=np.arange(n, dtype=float) * 0.5,
        mode_ids=MODES,
        state_names=STATES,
        output_names=OUTPUTS,
        modes=np.argmax(p, axis=1).astype(np.int64),
        mode_probabilities=p,
        state_means=rng.normal(size=(n, len(STATES))),
        state_variances=rng.random((n, len(STATES))),
        output_predictions=predictions,
    )


def flawed(result, kind, row):
    """``result`` with one flaw of ``kind`` at ``row`` (copies), and what the message says."""
    means, variances = result.state_means.copy(), result.state_variances.copy()
    p, y = result.mode_probabilities.copy(), result.output_predictions.copy()
    said = {
        "mean nan": "the state estimate is not finite",
        "mean inf": "the state estimate is not finite",
        "variance inf": "the variance of x2 is inf",
        "variance nan": "the variance of x2 is nan",
        "variance negative": "the variance of x2 is negative",
        "probability nan": "the mode probabilities are not finite",
        "probabilities sum 2": "the mode probabilities are no distribution (sum 2",
        "probability negative": "the mode probabilities are no distribution",
        "prediction inf": "the output prediction of y is inf",
        "prediction nan": "the output prediction of y is nan",
    }[kind]
    if kind.startswith("mean"):
        means[row, 1] = np.nan if kind.endswith("nan") else np.inf
    elif kind.startswith("variance"):
        variances[row, 1] = {"variance inf": np.inf, "variance nan": np.nan}.get(kind, -1e-3)
    elif kind == "probability nan":
        p[row, 0] = np.nan
    elif kind == "probabilities sum 2":
        p[row] *= 2.0
    elif kind == "probability negative":
        p[row] = [-0.5, 1.5]
    else:
        y[row, 0] = np.inf if kind.endswith("inf") else np.nan
    changed = dataclasses.replace(
        result,
        state_means=means,
        state_variances=variances,
        mode_probabilities=p,
        output_predictions=y,
    )
    return changed, said


KINDS = (
    "mean nan",
    "mean inf",
    "variance inf",
    "variance nan",
    "variance negative",
    "probability nan",
    "probabilities sum 2",
    "probability negative",
    "prediction inf",
    "prediction nan",
)


def _refused(kind, capabilities):
    """Whether an estimator of ``capabilities`` must refuse a flaw of ``kind``."""
    if kind.startswith("variance"):
        return capabilities.state_variances
    if kind == "prediction nan":
        return not capabilities.unpredicted_outputs
    return True


MODEL = parse_model(
    'name = "m"\ndt = 0.5\nstates = ["x1", "x2"]\noutputs = ["y"]\n'
    '[modes.a]\nf = ["x1", "x2"]\nh = ["x1"]\n[modes.b]\nf = ["x2", "x1"]\nh = ["x2"]\n'
    "[noise]\nprocess = 0.1\nmeasurement = 0.1\n[initial]\nstate = [0.0, 0.0]\n",
    origin="models/m.toml",
)
SIGNALS = AlignedSignals(
    source="log.csv",
    time=np.arange(N, dtype=float) * 0.5,
    input_names=(),
    output_names=OUTPUTS,
    inputs=np.zeros((N, 0)),
    outputs=np.zeros((N, 1)),
)


@pytest.mark.parametrize("name", list(ESTIMATORS))
@pytest.mark.parametrize("kind", KINDS)
def test_every_estimator_refuses_a_number_it_cannot_vouch_for(name, kind):
    capabilities = ESTIMATORS[name].capabilities
    result, said = flawed(clean(estimator=name), kind, 7)
    if not capabilities.state_variances:  # such estimators write NaN variances
        result = dataclasses.replace(result, state_variances=np.full((N, 2), np.nan))
    if not _refused(kind, capabilities):
        check_result(
            MODEL,
            SIGNALS,
            result,
            variances=capabilities.state_variances,
            unpredicted=capabilities.unpredicted_outputs,
        )
        return
    with pytest.raises(ModelError) as caught:
        check_result(
            MODEL,
            SIGNALS,
            result,
            variances=capabilities.state_variances,
            unpredicted=capabilities.unpredicted_outputs,
        )
    message = str(caught.value)
    assert message.startswith(f"models/m.toml: {name} diverged at t = 3.5 s (sample 7): {said}")
    assert "\n" not in message


def test_the_prior_row_predicts_nothing_and_a_chunk_names_rows_of_the_log():
    result = clean()
    assert first_flaw(result) is None  # row 0's NaN prediction is the prior's
    later = result.rows(4, N)  # a chunk whose row 0 is sample 4: its NaN is a flaw
    chunk = dataclasses.replace(later, output_predictions=later.output_predictions.copy())
    chunk.output_predictions[0, 0] = np.nan
    assert first_flaw(chunk) is None  # read as the log's first rows: the prior's NaN
    flaw = first_flaw(chunk, first=4)
    assert flaw is not None and flaw.row == 0
    with pytest.raises(ModelError, match=r"at t = 2 s \(sample 4\): the output prediction"):
        check_result(MODEL, SIGNALS, chunk, first=4)


def test_the_filter_s_own_result_inside_an_offline_one_is_checked():
    smoothed = clean()
    filtered, _ = flawed(clean(seed=1), "variance negative", 5)
    result = dataclasses.replace(
        smoothed,
        post_processing=PostProcessing("kim-rts", "argmax", "smoothed", filtered),
    )
    with pytest.raises(ModelError, match=r"\(sample 5\): .*negative.*the filter's own estimate"):
        check_result(MODEL, SIGNALS, result)


def test_rounding_below_zero_is_not_a_negative_variance():
    result = clean()
    variances = result.state_variances.copy()
    variances[3] = [1.0, -1e-17]  # a state known exactly, Joseph form's rounding
    assert first_flaw(dataclasses.replace(result, state_variances=variances)) is None


def test_subnormal_rounding_below_zero_is_not_a_negative_variance():
    """A covariance shrunk into the subnormal numbers rounds to -1e-323 beside 3e-323."""
    result = clean()
    variances = result.state_variances.copy()
    variances[3] = [3e-323, -1e-323]
    assert first_flaw(dataclasses.replace(result, state_variances=variances)) is None
    variances[3] = [3e-323, -1e-300]  # a normal number: a negative variance
    assert first_flaw(dataclasses.replace(result, state_variances=variances)) is not None


@settings(max_examples=60, deadline=None)
@given(
    flaws=st.lists(
        st.tuples(st.sampled_from(KINDS), st.integers(min_value=1, max_value=N - 1)),
        max_size=4,
    ),
    first=st.sampled_from([0, 3]),
)
def test_the_first_flawed_row_is_named(flaws, first):
    result = clean()
    if first:  # a chunk after the first: its row 0 is no prior and has a prediction
        result.output_predictions[0] = 0.0
    for kind, row in flaws:
        result, _ = flawed(result, kind, row)
    found = first_flaw(result, first=first)
    if not flaws:
        assert found is None
    else:
        assert found is not None and found.row == min(row for _, row in flaws)


# --- through the registry: whole results and streamed chunks ---------------------------------


def run_fake(model, signals, options):
    """A result of the fake estimator with its flaw (see ``_fake``)."""
    result, _ = flawed(clean(signals.n_samples, estimator="fake"), "variance inf", 9)
    return result


def stream_fake(model, signals, options, *, rows):
    whole = run_fake(model, signals, options)
    for start in range(0, whole.n_samples, rows):
        yield whole.rows(start, min(start + rows, whole.n_samples))


@dataclasses.dataclass(frozen=True)
class FakeOptions:
    pass


@pytest.mark.parametrize("streamed", [False, True])
def test_the_registry_checks_whole_results_and_every_chunk(streamed):
    entry = Estimator(
        name="fake",
        summary="fake",
        source="none",
        module=__name__,
        options="FakeOptions",
        run="run_fake",
        stream="stream_fake" if streamed else "",
    )
    prepared = Prepared(entry, FakeOptions())
    with pytest.raises(
        ModelError, match=r"^models/m\.toml: fake diverged at t = 4\.5 s \(sample 9\)"
    ):
        if streamed:
            chunks = prepared.stream(MODEL, SIGNALS, rows=4)
            assert next(chunks).n_samples == 4 and next(chunks).n_samples == 4
            next(chunks)
        else:
            prepared.run(MODEL, SIGNALS)


# --- hostile plant models and logs, run for real ---------------------------------------------

SQRT_ONE_MODE = """
name = "sqrt_one_mode"
dt = 1.0
states = ["x1"]
inputs = ["u"]
outputs = ["y"]
[modes.a]
f = ["x1 + u"]
h = ["sqrt(x1)"]
[modes.b]
f = ["x1 - u"]
h = ["x1"]
[noise]
process = 0.1
measurement = 0.1
[initial]
state = [1.0]
covariance = 1.0
"""


def falling(n=60, seed=5):
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    return AlignedSignals(
        source="down.csv",
        time=t,
        input_names=("u",),
        output_names=("y",),
        inputs=np.full((n, 1), 0.1),
        outputs=(1.0 - 0.1 * t + rng.normal(0.0, 0.05, n))[:, None],
    )


@pytest.mark.parametrize("kernel", ["unrolled", "loops"])
def test_an_output_map_out_of_its_domain_names_the_mode_and_expression(kernel):
    # The generic loop ruled mode a out and predicted NaN for the rest of the log: the
    # report took its metrics over the 13 samples before; the straight-line code diverged
    # with "a Jacobian of the model may be infinite there".
    model = parse_model(SQRT_ONE_MODE, origin="models/sqrt.toml")
    with pytest.raises(ModelError) as caught:
        run_imm(model, falling(), ImmOptions(), kernel=kernel)
    message = str(caught.value)
    assert message.startswith("models/sqrt.toml: imm diverged at t = 12 s (sample 12): ")
    assert "modes.a.h[0] = 'sqrt(x1)' is nan at x1 = -" in message, message
    # the HSTF takes every mode's ∂h/∂x at the modes' mean prediction (eq. (12)), below
    # zero where neither mode's own prediction is: the refusal said "every expression of
    # the model is finite at the estimate of sample 10"; it names that Jacobian now
    with pytest.raises(ModelError) as caught:
        run_hstf(model, falling(), HstfOptions(), kernel=kernel)
    message = str(caught.value)
    assert message.startswith("models/sqrt.toml: hstf diverged at t = 11 s (sample 11): ")
    assert "; the derivative by x1 of modes.a.h[0] = 'sqrt(x1)' is nan at x1 = -0.0017" in message
    assert message.endswith(", u = 0.1, the modes' mean prediction (eq. (12))"), message


def test_an_exp_that_overflows_names_its_expression():
    model = parse_model(
        SQRT_ONE_MODE.replace('"x1 + u"', '"exp(x1)"').replace('"sqrt(x1)"', '"x1"'),
        origin="models/exp.toml",
    )
    rising = dataclasses.replace(falling(), outputs=np.exp(np.arange(60.0))[:, None])
    with pytest.raises(ModelError, match=r"modes\.a\.f\[0\] = 'exp\(x1\)' is inf at x1 = "):
        prepare(model, "imm").run(model, rising)


UNSTABLE_UNOBSERVED = """
name = "unstable"
dt = 1.0
states = ["x1"]
inputs = ["u"]
outputs = ["y"]
[modes.a]
f = ["x1**2"]
h = ["u"]
[noise]
process = 1e300
measurement = 0.1
[initial]
state = [1.0]
covariance = 1e300
"""


@pytest.mark.parametrize("name", ["imm", "hstf"])
def test_a_variance_that_overflows_beside_a_finite_state_is_refused(name):
    # The state x1 = 1 stays finite while its variance, which no output bounds, overflows.
    model = parse_model(UNSTABLE_UNOBSERVED, origin="models/unstable.toml")
    signals = dataclasses.replace(falling(), outputs=np.ones((60, 1)))
    with pytest.raises(ModelError, match=rf"{name} diverged at t = \d+ s .*variance of x1 is inf"):
        prepare(model, name).run(model, signals)


def test_unknown_mode_refuses_a_negative_variance():
    # An initial covariance of 1e300: a cluster EKF's update lost every digit and wrote
    # variances of -3e283 into estimates.csv.
    model = parse_model(
        CPHA_EXAMPLE.replace("covariance = 1.0", "covariance = 1e300"), origin="c.toml"
    )
    with pytest.raises(
        ModelError, match=r"unknown-mode diverged at .*variance of xc\d is negative"
    ):
        prepare(model, "unknown-mode").run(model, cpha_log(model, 40, seed=1))


def test_unknown_mode_s_variance_growth_past_double_precision_is_one_line():
    # Held variances multiplied by 1e6 per step overflowed in NumPy: as the commands run
    # (warnings are errors) "numerical trouble in background.py:266".
    model = parse_model(CPHA_EXAMPLE, origin="c.toml")
    signals = cpha_log(model, 200, seed=1)
    noise = np.random.default_rng(0).normal(0.0, 1e6, signals.outputs.shape)
    garbage = dataclasses.replace(signals, outputs=noise)
    prepared = prepare(model, "unknown-mode", {"variance_growth": "1e6"})
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(ModelError) as caught:
            prepared.run(model, garbage)
    message = str(caught.value)
    assert message.startswith("c.toml: ") and "\n" not in message
    # the growth either overflows a variance or, a step earlier, breaks the covariance, said
    # with the variance "too large for double precision" at the sample before (which comes
    # first depends on the last bits of the model's constants)
    assert any(
        cause in message for cause in ("not finite", "is inf", "too large for double precision")
    ), message


def test_a_legitimate_run_of_every_filter_passes(tmp_path):
    model = parse_model(SQRT_ONE_MODE.replace('"sqrt(x1)"', '"x1"'), origin="m.toml")
    rising = dataclasses.replace(falling(), outputs=(1.0 + 0.1 * np.arange(60.0))[:, None])
    for name, sets in (
        ("imm", {}),
        ("imm", {"smooth": "true"}),
        ("imm", {"mode_sequence": "viterbi"}),
        ("imm", {"mode_sequence": "kbest"}),
        ("hstf", {}),
        ("chiu", {}),
    ):
        result = prepare(model, name, sets).run(model, rising)
        assert np.isfinite(result.state_means).all()


def test_a_one_mode_or_identical_modes_or_impossible_switches_are_vouched_for():
    text = SQRT_ONE_MODE.replace('"sqrt(x1)"', '"x1"').replace('"x1 - u"', '"x1 + u"')
    signals = dataclasses.replace(falling(), outputs=(1.0 + 0.1 * np.arange(60.0))[:, None])
    for variant in (
        text,  # two identical modes: ties everywhere
        text + "[transitions]\nstay = 1.0\n",
        text + "[transitions]\nstay = 0.0\n",
        text.replace("process = 0.1\nmeasurement = 0.1", "process = 0.0\nmeasurement = 1e-12"),
    ):
        model = parse_model(variant, origin="m.toml")
        for sets in (
            {},
            {"smooth": "true", "mode_sequence": "viterbi"},
            {"mode_sequence": "kbest"},
        ):
            result = prepare(model, "imm", sets).run(model, signals)
            assert first_flaw(result) is None


def test_analyze_says_it_in_one_line_and_writes_nothing(tmp_path, hybridlog_main):
    model = tmp_path / "sqrt.toml"
    model.write_text(SQRT_ONE_MODE)
    signals = falling()
    rows = ["t,u,y"] + [
        f"{float(t)!r},{float(u)!r},{float(y)!r}"
        for t, u, y in zip(signals.time, signals.inputs[:, 0], signals.outputs[:, 0], strict=True)
    ]
    log = tmp_path / "down.csv"
    log.write_text("\n".join(rows) + "\n")
    out = tmp_path / "out"
    for extra in ([], ["--smooth"], ["--mode-sequence", "kbest"]):
        code, err = hybridlog_main(
            [
                *("analyze", str(log), "--model", str(model), "--estimator", "imm"),
                *("--out", str(out), *extra),
            ]
        )
        assert code == 2 and err.count("\n") == 1, err
        assert "imm diverged at t = " in err and "modes.a.h[0] = 'sqrt(x1)'" in err
        assert "Traceback" not in err and not out.exists()


LOG_OUTPUT = """
name = "log_output"
dt = 1.0
states = ["x1"]
inputs = ["u"]
outputs = ["y"]
[modes.m0]
f = ["exp(x1)"]
h = ["log(x1)"]
[noise]
process = 0.1
measurement = 0.1
[initial]
state = [1.0]
covariance = 1e200
"""


@pytest.mark.parametrize("sets", [{"smooth": "true"}, {"mode_sequence": "viterbi"}])
@pytest.mark.parametrize("rows", [None, 2])
def test_outputs_an_offline_estimate_explains_out_of_h_s_domain_are_refused(sets, rows):
    # The smoothed state left log's domain: the report's smoothing block scored the
    # outputs the estimate explains over the samples left.
    model = parse_model(LOG_OUTPUT, origin="models/log.toml")
    signals = AlignedSignals(
        source="zero.csv",
        time=np.arange(4, dtype=float),
        input_names=("u",),
        output_names=("y",),
        inputs=np.full((4, 1), -1.0),
        outputs=np.zeros((4, 1)),
    )
    prepared = prepare(model, "imm", sets)
    with pytest.raises(ModelError) as caught:
        if rows is None:
            prepared.run(model, signals)
        else:
            list(prepared.stream(model, signals, rows=rows))
    message = str(caught.value)
    assert message.startswith("models/log.toml: imm diverged at t = ")
    assert "modes.m0.h[0] = 'log(x1)' is " in message and "the offline estimate" in message


@pytest.mark.parametrize("rows", [5, 6, 30])
@pytest.mark.parametrize("name", ["imm", "hstf"])
def test_a_division_by_zero_names_the_expression_inside_or_at_the_start_of_a_chunk(name, rows):
    # x(12) = x(11)/u(11) with u(11) = 0; with rows=6 sample 12 opens a chunk, and the
    # estimate it is diagnosed from is the last row of the chunk before.
    from tests.estimators.test_filter_chunks import POLE

    model = parse_model(POLE, origin="models/pole.toml")
    n = 30
    inputs = np.ones((n, 1))
    inputs[11] = 0.0
    signals = AlignedSignals(
        source="sim",
        time=np.arange(n, dtype=float),
        input_names=("u",),
        output_names=("y",),
        inputs=inputs,
        outputs=np.full((n, 1), 2.0),
    )
    with pytest.raises(ModelError) as caught:
        list(prepare(model, name).stream(model, signals, rows=rows))
    assert str(caught.value) == (
        f"models/pole.toml: {name} diverged at t = 12 s (sample 12): the state estimate is not "
        "finite; modes.a.f[0] = 'x/u' is inf at x = 2, u = 0"
    )
