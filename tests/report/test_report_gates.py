"""CI gates: --fail-under / --fail-over parsing and evaluation against a report."""

from __future__ import annotations

from dataclasses import replace

import pytest

from hybridlog.errors import OptionError
from hybridlog.report.document import Report
from hybridlog.report.gates import (
    Gate,
    GateKind,
    evaluate_gates,
    parse_gate,
    parse_gates,
    validate_gates,
)
from hybridlog.report.mode_metrics import SwitchDetection
from hybridlog.report.report_parts import (
    Detection,
    ModeReport,
    OutputReport,
    Smoothing,
    SmoothingMetrics,
    StateReport,
)


def report(*, truth: bool = True) -> Report:
    detection = Detection(
        mean_s=0.4,
        max_s=0.4,
        events=(
            SwitchDetection(t=1.0, from_mode="a", to_mode="b", detected_t=1.4),
            SwitchDetection(t=3.0, from_mode="b", to_mode="a", detected_t=None, miss_reason="x"),
        ),
    )
    return Report(
        hybridlog_version="0",
        log="run.csv",
        model="m",
        estimator="imm",
        options={},
        samples=41,
        dt=1.0,
        t_start=0.0,
        t_end=40.0,
        outputs={
            "y1": OutputReport(mse=0.02, vaf=87.2, fit=None, samples=40),
            "y2": OutputReport(mse=0.5, vaf=None, fit=None, samples=40),
        },
        mse=0.26,
        vaf=87.2,
        fit=None,
        modes=ModeReport(
            labels=("a", "b"),
            switches=(),
            dwell_s={"a": 5.0, "b": 0.0},
            accuracy=0.93 if truth else None,
            detection=detection if truth else None,
        ),
        states={"x1": StateReport(rmse=0.1 if truth else None)},
        runtime_s=2.0,
        compile_s=None,
        samples_per_s=5000.0,
    )


def test_parse_gate() -> None:
    assert parse_gate(" vaf = 90 ", "under") == Gate("vaf", 90.0, "under", "vaf=90")
    assert parse_gate("state_rmse.x1=0.5", "over").metric == "state_rmse.x1"
    gates = parse_gates(["vaf=90", "mode_accuracy=0.9"], ["mse=1e-3"])
    assert [(g.metric, g.bound, g.kind) for g in gates] == [
        ("vaf", 90.0, "under"),
        ("mode_accuracy", 0.9, "under"),
        ("mse", 1e-3, "over"),
    ]


@pytest.mark.parametrize(
    ("spec", "fragment"),
    [
        ("vaf", "METRIC=VALUE"),
        ("=90", "METRIC=VALUE"),
        ("vaf=", "METRIC=VALUE"),
        ("accuracy=0.9", "unknown metric 'accuracy'"),
        ("vaf.=90", "unknown metric"),
        ("rmse.x1=1", "unknown metric"),
        # summary.csv's filter's own columns: named as such, with the gate that is read
        ("filtered_mode_accuracy=0.9", "is the filter's own value beside an offline pass's"),
        ("filtered_state_rmse.x1=1", "gates read state_rmse.x1, the offline estimates'"),
        ("filtered_=1", "unknown metric 'filtered_'"),
        ("vaf=ninety", "bound 'ninety': expected a finite number"),
        ("vaf=nan", "bound 'nan': expected a finite number"),
        ("mse=inf", "bound 'inf': expected a finite number"),
        ("vaf=9_0", "bound '9_0': expected a finite number"),
        ("vaf=٩٠", "bound '٩٠': expected a finite number"),
    ],
)
def test_bad_spec_is_an_option_error_naming_it(spec: str, fragment: str) -> None:
    with pytest.raises(OptionError, match="--fail-under") as info:
        parse_gate(spec, "under")
    message = str(info.value)
    assert repr(spec) in message
    assert fragment in message
    assert "\n" not in message


@pytest.mark.parametrize(
    ("spec", "kind", "fragment"),
    [
        ("mode_accuracy=99.5", "under", "at most 1 (a fraction: for 99.5 % write 0.995)"),
        ("mode_accuracy=101", "under", "mode_accuracy is at most 1,"),
        ("vaf=101", "under", "vaf is at most 100 %"),
        ("fit.y1=100.5", "under", "fit is at most 100 %"),
        ("mse=-1", "over", "mse is at least 0"),
        ("state_rmse.x1=-0.1", "over", "state_rmse is at least 0"),
        ("vaf=-3", "over", "vaf is at least 0 %"),
        ("missed_switches=-1", "over", "missed_switches is at least 0"),
    ],
)
def test_a_bound_the_metric_can_never_meet_is_refused(
    spec: str, kind: GateKind, fragment: str
) -> None:
    with pytest.raises(OptionError, match=f"--fail-{kind}") as info:
        parse_gate(spec, kind)
    assert fragment in str(info.value) and "could never pass" in str(info.value)


@pytest.mark.parametrize(
    ("spec", "kind", "hint"),
    [
        # a bound that reads as a percentage of a fraction: the hint gives the fraction
        ("mode_accuracy=95", "under", " (a fraction: for 95 % write 0.95)"),
        ("mode_accuracy.c1=100", "under", " (a fraction: for 100 % write 1)"),
        # negative, or beyond 100: no percentage the metric takes, so no hint (it offered
        # "for -1 % write -0.01", a bound refused in turn)
        ("mode_accuracy=-1", "over", ""),
        ("mode_accuracy=-0.5", "over", ""),
        ("mode_accuracy=150", "under", ""),
        ("vaf=101", "under", ""),
        ("vaf=-3", "over", ""),
        ("mse=-1", "over", ""),
    ],
)
def test_the_hint_of_a_bound_never_met_fits_its_value(spec: str, kind: GateKind, hint: str) -> None:
    with pytest.raises(OptionError) as info:
        parse_gate(spec, kind)
    message = str(info.value)
    assert message.endswith(f"{hint}, so this gate could never pass"), message
    assert message.count("(") == hint.count("(")


@pytest.mark.parametrize(
    ("value", "hint"),
    [
        ("vaf=95%", " (vaf is in percent already: write 95)"),
        ("fit.y1=-20 %", " (fit is in percent already: write -20)"),
        ("mode_accuracy=95%", " (mode_accuracy is a fraction: for 95 % write 0.95)"),
        ("mode_accuracy=0.5%", " (mode_accuracy is a fraction: for 0.5 % write 0.005)"),
        # a percentage the metric cannot take, or a metric with no percent: no hint
        ("mode_accuracy=150%", ""),
        ("vaf=150%", ""),
        ("mse=5%", ""),
        ("vaf=%", ""),
        ("vaf=5%%", ""),
    ],
)
def test_a_bound_with_a_percent_sign_gets_a_hint_that_fits(value: str, hint: str) -> None:
    with pytest.raises(OptionError) as info:
        parse_gate(value, "under")
    assert str(info.value).endswith(f"expected a finite number{hint}"), str(info.value)


def test_gates_no_value_can_meet_together_are_refused() -> None:
    """--fail-under vaf=50 --fail-over vaf=40 failed every log of a batch (exit 1)."""
    with pytest.raises(OptionError) as info:
        parse_gates(["vaf=90", "vaf=50"], ["mse=3", "vaf=40"])
    assert str(info.value) == (
        "--fail-under 'vaf=90' and --fail-over 'vaf=40': vaf cannot be at least 90 and at "
        "most 40, so these gates could never both pass"
    )
    # a band, the same bound from both sides, other metrics: gates (the same gate twice is
    # refused: tests/jobs/test_hp_batch_gates.py)
    assert len(parse_gates(["vaf=40", "vaf=30", "fit.y1=70"], ["vaf=40", "fit.y2=60"])) == 5


@pytest.mark.parametrize(
    ("spec", "kind"),
    [("vaf=100", "under"), ("fit=-500", "over"), ("mode_accuracy=1", "under"), ("mse=0", "over")],
)
def test_a_bound_at_the_edge_of_the_range_is_a_gate(spec: str, kind: GateKind) -> None:
    assert parse_gate(spec, kind).bound == float(spec.split("=")[1])


def test_all_gates_met_gives_no_messages() -> None:
    gates = parse_gates(
        ["vaf=80", "vaf.y1=87.2", "mode_accuracy=0.9", "samples_per_s=1000"],
        ["mse=0.3", "mse.y2=0.5", "state_rmse.x1=0.2", "detection_delay_s=1", "missed_switches=1"],
    )
    every_output = replace(
        report(), outputs={**report().outputs, "y2": OutputReport(0.5, 87.2, None, 40)}
    )
    # every true switch detected (a miss fails --fail-over detection_delay_s: below)
    detection = Detection(
        mean_s=0.4, max_s=0.4, events=(SwitchDetection(1.0, "a", "b", detected_t=1.4),)
    )
    every_switch = replace(every_output, modes=replace(every_output.modes, detection=detection))
    assert evaluate_gates(every_switch, gates) == []


def test_a_missed_switch_fails_a_gate_on_the_detection_delay() -> None:
    # hstf on a 2:80,1:120,3:100 log: the switch at 81 s missed, the one at 201 s detected
    # 91 s late; --fail-over detection_delay_s=100 was "met (detection_delay_s = 91)"
    gates = parse_gates(["detection_delay_s=0.1"], ["detection_delay_s=1"])
    assert evaluate_gates(report(), gates) == [
        "detection_delay_s = 0.4 is a mean over the detected switches that leaves out 1 of 2 "
        "true switches, missed: b → a at t=3 s, so the --fail-over bound 1 cannot be met"
    ]
    # a component's detection delay alike
    with_component = replace(
        report(), modes=replace(report().modes, components={"valve": report().modes})
    )
    (message,) = evaluate_gates(with_component, parse_gates([], ["detection_delay_s.valve=1"]))
    assert message.startswith("detection_delay_s.valve = 0.4 is a mean over the detected")


def test_missed_gates_name_metric_value_and_bound() -> None:
    gates = parse_gates(["vaf=90", "mode_accuracy=0.95"], ["mse.y2=0.1", "runtime_s=1"])
    every_output = replace(
        report(), outputs={**report().outputs, "y2": OutputReport(0.5, 87.2, None, 40)}
    )
    assert evaluate_gates(every_output, gates) == [
        "vaf = 87.2 is under the bound 90",
        "mode_accuracy = 0.93 is under the bound 0.95",
        "mse.y2 = 0.5 is over the bound 0.1",
        "runtime_s = 2 is over the bound 1",
    ]


def test_null_metric_fails_the_gate_and_says_why() -> None:
    gates = parse_gates(["mode_accuracy=0.9", "vaf.y2=50"], ["state_rmse.x1=1"])
    messages = evaluate_gates(report(truth=False), gates)
    assert len(messages) == 3
    assert messages[0].startswith("mode_accuracy is not available")
    assert "ground-truth mode" in messages[0]
    assert "0.9" in messages[0]
    assert messages[1].startswith("vaf.y2 is not available")
    assert "ground truth" in messages[2]


def test_unknown_output_or_state_is_an_option_error() -> None:
    with pytest.raises(OptionError, match="'y9' is not an output"):
        evaluate_gates(report(), parse_gates(["vaf.y9=90"]))
    with pytest.raises(OptionError, match="'x9' is not a state"):
        evaluate_gates(report(), parse_gates([], ["state_rmse.x9=1"]))


def test_validate_gates_before_a_run() -> None:
    ok = parse_gates(["vaf.y1=90", "vaf=90"], ["state_rmse.x1=1"])
    validate_gates(ok, output_names=["y1"], state_names=["x1"])
    with pytest.raises(OptionError, match=r"--fail-over 'mse\.q=1'"):
        validate_gates(parse_gates([], ["mse.q=1"]), output_names=["y1"], state_names=["x1"])
    with pytest.raises(OptionError, match="not a state"):
        validate_gates(parse_gates(["state_rmse.y1=1"]), output_names=["y1"], state_names=["x1"])


def test_fit_gates_overall_and_per_output() -> None:
    fitted = replace(
        report(),
        outputs={
            "y1": OutputReport(mse=None, vaf=None, fit=92.5, samples=40),
            "y2": OutputReport(mse=None, vaf=None, fit=None, samples=40),
        },
        fit=92.5,
        null_reasons={"fit.y2": "‖y − mean(y)‖ = 0: the measurement is constant"},
    )
    assert evaluate_gates(fitted, parse_gates(["fit.y1=90"])) == []
    # the mean leaves y2 out (a stuck sensor): a gate on it cannot pass, whatever its value
    assert evaluate_gates(fitted, parse_gates(["fit=80"])) == [
        "fit = 92.5 is a mean that leaves out 1 of 2 outputs: fit.y2 (‖y − mean(y)‖ = 0: the "
        "measurement is constant), so the --fail-under bound 80 cannot be met"
    ]
    (message,) = evaluate_gates(fitted, parse_gates(["fit.y2=50"]))
    # the report's own reason is quoted
    assert message.startswith("fit.y2 is not available (‖y − mean(y)‖ = 0")
    validate_gates(parse_gates(["fit.y1=80"]), output_names=["y1"], state_names=[])
    with pytest.raises(OptionError, match="'y3' is not an output"):
        validate_gates(parse_gates(["fit.y3=80"]), output_names=["y1"], state_names=[])


def _side(accuracy: float | None, missed: int | None, rmse: float) -> SmoothingMetrics:
    return SmoothingMetrics(
        mode_accuracy=accuracy,
        confusion=None,
        detection_delay_s=None,
        detection_max_s=None,
        detected=None,
        missed=missed,
        estimated_switches=3,
        states={"x1": StateReport(rmse=rmse)},
        outputs=None,
        fit=None,
    )


def test_a_missed_gate_of_a_smoothed_run_says_which_estimates_it_read() -> None:
    # batch --smooth --fail-under mode_accuracy=0.95 wrote "mode_accuracy = 0.93 is under
    # the bound 0.95" in summary.csv, summary.md, JUnit and on the terminal: nothing said
    # the gate read the smoothed estimates, nor that mse was the filter's prediction.
    smoothing = Smoothing(
        method="kim-rts",
        mode_sequence="argmax",
        description="d",
        filtered=_side(0.81, 0, 0.3),
        smoothed=_side(0.93, 1, 0.1),
    )
    smoothed = replace(report(), smoothing=smoothing)
    gates = parse_gates(
        ["mode_accuracy=0.95", "state_rmse.x1=0.2"], ["mse=0.1", "missed_switches=0"]
    )
    assert evaluate_gates(smoothed, gates) == [
        "mode_accuracy = 0.93 (of the offline estimates: kim-rts, argmax; the filter's own: "
        "0.81) is under the bound 0.95",
        "state_rmse.x1 = 0.1 (of the offline estimates: kim-rts, argmax; the filter's own: "
        "0.3) is under the bound 0.2",
        "mse = 0.26 (the filter's one-step-ahead prediction) is over the bound 0.1",
        "missed_switches = 1 (of the offline estimates: kim-rts, argmax; the filter's own: 0) "
        "is over the bound 0",
    ]
    viterbi = replace(smoothing, method=None, mode_sequence="viterbi", filtered=_side(None, 0, 0.3))
    (failure,) = evaluate_gates(replace(smoothed, smoothing=viterbi), gates[:1])
    assert failure == (
        "mode_accuracy = 0.93 (of the offline estimates: viterbi; the filter's own: n/a) is "
        "under the bound 0.95"
    )
    # The filter's own report says nothing more than before.
    assert evaluate_gates(report(), gates[:1]) == ["mode_accuracy = 0.93 is under the bound 0.95"]
