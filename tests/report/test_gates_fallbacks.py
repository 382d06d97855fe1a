"""CI gates on the smoother's fallbacks: ``smoothing_fallback_weight``, ``_samples``.

``--fail-over smoothing_fallback_weight=0.5`` was refused as an unknown metric: a CI job could
not fail a run whose "smoothed" estimate was mostly the filter's (the double cart: 0.991 of
the weight).  The gates read report.json's ``smoothing.fallbacks``; a run configured without
a smoother is refused before it starts, as a gate on an unknown output is; a gate that could
only pass (``=50`` meant as 50 %) is refused as one that could only fail is.
"""

from __future__ import annotations

import csv
import json
from dataclasses import replace
from pathlib import Path

import pytest

from hybridlog.errors import OptionError
from hybridlog.estimators.result import Fallbacks
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.compare import compare
from hybridlog.jobs.gate_checks import gates_for
from hybridlog.jobs.overrides import parse_sets, prepare_estimators
from hybridlog.report.gates import (
    METRICS,
    GateKind,
    evaluate_gates,
    metric,
    null_reason,
    parse_gate,
    parse_gates,
)
from hybridlog.report.report_parts import Smoothing
from tests.cli.test_cli import run
from tests.report.test_report_gates import _side, report
from tests.support.paths import SAMPLE_LOGS, TANK_CSV

CART = SAMPLE_LOGS / "double_cart_case1.csv"
FELL_BACK = Fallbacks(3, 4, {"prediction": 0, "guard": 3, "rounding": 0, "covariance": 0}, 0.6)
SMOOTHING = Smoothing(
    method="kim-rts",
    mode_sequence="argmax",
    description="d",
    filtered=_side(0.81, 0, 0.3),
    smoothed=_side(0.93, 1, 0.1),
    fallbacks=FELL_BACK,
)


def test_the_fallback_metrics_are_gated_and_read_from_the_report() -> None:
    assert {"smoothing_fallback_weight", "smoothing_fallback_samples"} <= set(METRICS)
    smoothed = replace(report(), smoothing=SMOOTHING)
    assert metric(smoothed, "smoothing_fallback_weight") == 0.6
    assert metric(smoothed, "smoothing_fallback_samples") == 3
    gates = parse_gates(
        ["smoothing_fallback_samples=0"],
        ["smoothing_fallback_weight=0.5", "smoothing_fallback_samples=2"],
    )
    assert evaluate_gates(smoothed, gates) == [
        "smoothing_fallback_weight = 0.6 (kim-rts, argmax: fell back on 3 of 4 samples) is "
        "over the bound 0.5",
        "smoothing_fallback_samples = 3 (kim-rts, argmax: of 4 samples, carrying 60.0 % of the "
        "weight) is over the bound 2",
    ]
    assert evaluate_gates(smoothed, parse_gates([], ["smoothing_fallback_weight=0.6"])) == []


@pytest.mark.parametrize(
    ("smoothing", "why"),
    [
        (None, "no smoother ran: the estimates are the filter's own"),
        (
            replace(SMOOTHING, method=None, mode_sequence="viterbi", fallbacks=None),
            "no smoother ran: mode sequence viterbi alone",
        ),
        (
            replace(SMOOTHING, fallbacks=None),
            "the report (kim-rts) does not count the smoother's fallbacks: one of an earlier "
            "version",
        ),
    ],
    ids=["filter", "viterbi", "earlier-version"],
)
def test_a_report_without_fallbacks_fails_the_gate_saying_why(
    smoothing: Smoothing | None, why: str
) -> None:
    """As ``mode_accuracy`` of a log without a true mode: ``null``, the gate fails with why."""
    without = replace(report(), smoothing=smoothing)
    assert metric(without, "smoothing_fallback_weight") is None
    assert null_reason(without, "smoothing_fallback_samples") == why
    assert evaluate_gates(without, parse_gates([], ["smoothing_fallback_weight=0.5"])) == [
        f"smoothing_fallback_weight is not available ({why}), so the --fail-over bound 0.5 "
        "cannot be met"
    ]


@pytest.mark.parametrize(
    ("spec", "kind", "message"),
    [
        # meant as 50 %: passed every run, the CI gate never failing
        (
            "smoothing_fallback_weight=50",
            "over",
            "smoothing_fallback_weight is at most 1 (a fraction: for 50 % write 0.5), so this "
            "gate could never fail",
        ),
        (
            "smoothing_fallback_weight=99.5",
            "under",
            "smoothing_fallback_weight is at most 1 (a fraction: for 99.5 % write 0.995), so "
            "this gate could never pass",
        ),
        (
            "smoothing_fallback_weight=50%",
            "over",
            "bound '50%': expected a finite number (smoothing_fallback_weight is a fraction: "
            "for 50 % write 0.5)",
        ),
        ("smoothing_fallback_samples=-1", "over", "is at least 0, so this gate could never pass"),
        # the same for every fraction: a percentage where it could only pass
        (
            "mode_accuracy=95",
            "over",
            "(a fraction: for 95 % write 0.95), so this gate could never fail",
        ),
    ],
)
def test_a_bound_beyond_the_metrics_values_is_refused(
    spec: str, kind: GateKind, message: str
) -> None:
    with pytest.raises(OptionError) as info:
        parse_gate(spec, kind)
    text = str(info.value)
    assert text.startswith(f"--fail-{kind} {spec!r}: ") and text.endswith(message), text


@pytest.mark.parametrize(
    ("spec", "kind"),
    [
        ("smoothing_fallback_weight=1", "over"),
        ("smoothing_fallback_weight=0", "under"),
        # at the edge: fails only where the metric is null, the way to a gated column
        ("smoothing_fallback_samples=0", "under"),
        ("vaf=0", "under"),
        ("mode_accuracy.c1=1", "over"),
        ("fit=-1e9", "under"),  # fit has no lower end: this gate can fail
    ],
)
def test_a_bound_at_the_edge_is_a_gate(spec: str, kind: GateKind) -> None:
    assert parse_gate(spec, kind).bound == float(spec.split("=")[1])


@pytest.mark.parametrize(
    ("spec", "kind", "edge"),
    [
        # a sign typed wrong: the gate passed every run, a CI gate doing nothing
        ("mode_accuracy=-0.1", "under", "mode_accuracy is at least 0"),
        ("mse.y1=-1", "under", "mse is at least 0"),
        ("vaf=-1e9", "under", "vaf is at least 0 %"),
        ("smoothing_fallback_samples=-1", "under", "smoothing_fallback_samples is at least 0"),
        ("state_rmse.x1=-0.5", "under", "state_rmse is at least 0"),
        ("detection_delay_s=-1", "under", "detection_delay_s is at least 0"),
        # beyond the top, and no percentage
        ("smoothing_fallback_weight=150", "over", "smoothing_fallback_weight is at most 1"),
        ("mode_accuracy.c1=150", "over", "mode_accuracy is at most 1"),
        ("vaf.y2=101", "over", "vaf is at most 100 %"),
    ],
)
def test_a_bound_every_value_meets_is_refused_as_one_none_meets(
    spec: str, kind: GateKind, edge: str
) -> None:
    """The range check of a gate that could never pass, on the other side: one mechanism
    (each metric's range), the refusal naming the bound at the edge that checks only that
    the metric is defined."""
    with pytest.raises(OptionError) as info:
        parse_gate(spec, kind)
    metric = spec.partition("=")[0]
    end = edge.split()[-2] if edge.endswith("%") else edge.split()[-1]
    assert str(info.value) == (
        f"--fail-{kind} {spec!r}: {edge}, so this gate could never fail; "
        f"--fail-{kind} {metric}={end} checks only that it is defined"
    )


@pytest.mark.parametrize(
    ("estimators", "sets", "smooth", "sequence", "why"),
    [
        (["imm"], [], False, None, "estimator 'imm' runs no smoother (smooth = false; add --smoo"),
        (["imm"], [], False, "viterbi", "(smooth = false, --mode-sequence viterbi alone; add"),
        (["hstf"], [], False, None, "estimator 'hstf' runs no smoother (it has none)"),
        # compare's gates apply to every estimator: hstf's report never has fallbacks
        (["imm", "hstf"], ["smooth=true"], False, None, "estimator 'hstf' runs no smoother"),
    ],
)
def test_a_fallback_gate_without_a_smoother_is_refused_before_the_run(
    estimators: list[str], sets: list[str], smooth: bool, sequence: str | None, why: str
) -> None:
    model, overrides = parse_sets(sets, "double_cart_case1")
    prepared = prepare_estimators(model, estimators, overrides, mode_sequence=sequence)
    with pytest.raises(OptionError) as info:
        gates_for(model, prepared, [], ["smoothing_fallback_weight=0.5"])
    assert str(info.value).startswith("--fail-over 'smoothing_fallback_weight=0.5': ")
    assert why in str(info.value)
    assert str(info.value).endswith(
        "so its report has no smoothing_fallback_weight and this gate could never pass"
    )
    # other gates of such a run stay gates
    assert gates_for(model, prepared, ["vaf=1"], [])


@pytest.mark.parametrize("sequence", [None, "viterbi", "kbest"])
def test_a_fallback_gate_with_a_smoother_is_a_gate(sequence: str | None) -> None:
    model, overrides = parse_sets([], "double_cart_case1")
    prepared = prepare_estimators(model, ["imm"], overrides, smooth=True, mode_sequence=sequence)
    gates = gates_for(model, prepared, ["smoothing_fallback_samples=0"], [])
    assert [g.metric for g in gates] == ["smoothing_fallback_samples"]


def test_analyze_gates_the_fallbacks_of_its_own_report(tmp_path: Path) -> None:
    """The double cart's smoothed estimate is mostly the filter's; the three tank's is not.

    The values are report.json's own, not the default smoother's numbers (which may change).
    """
    gates = ["smoothing_fallback_weight=0.5"]
    cart = analyze(
        CART, "double_cart_case1", out_dir=tmp_path / "c", estimator="imm", smooth=True,
        fail_over=gates,
    )  # fmt: skip
    stored = json.loads((tmp_path / "c" / "report.json").read_text())["smoothing"]["fallbacks"]
    assert stored["weight"] > 0.5  # clearly: the guard refuses nearly every step
    (failure,) = cart.gate_failures
    assert failure.startswith(f"smoothing_fallback_weight = {stored['weight']:.6g} (kim-rts")
    assert f"fell back on {stored['samples']:,} of {stored['of']:,} samples" in failure
    tank = analyze(
        TANK_CSV, "three_tank_hstf", out_dir=tmp_path / "t", estimator="imm", smooth=True,
        fail_over=gates,
    )  # fmt: skip
    assert tank.report.smoothing is not None and tank.report.smoothing.fallbacks is not None
    assert tank.report.smoothing.fallbacks.weight < 0.01
    assert tank.gate_failures == []


def test_compare_gated_on_the_fallback_weight_shows_it_once(tmp_path: Path) -> None:
    """comparison.csv has ``smoothing_fallback_weight`` among its smoothing columns; a gate
    on it added it a second time as a gated column."""
    out = tmp_path / "cmp"
    compare(
        CART, "double_cart_case1", ["imm"], out_dir=out, smooth=True,
        fail_over=["smoothing_fallback_weight=0.5", "smoothing_fallback_samples=0"],
    )  # fmt: skip
    with (out / "comparison.csv").open(newline="") as file:
        reader = csv.DictReader(file)
        (row,) = reader
        header = reader.fieldnames or []
    assert header.count("smoothing_fallback_weight") == 1
    assert header.count("smoothing_fallback_samples") == 1
    stored = json.loads((out / "imm" / "report.json").read_text())["smoothing"]["fallbacks"]
    assert row["smoothing_fallback_weight"] == repr(stored["weight"])
    assert row["smoothing_fallback_samples"] == str(stored["samples"])
    assert row["gates"].startswith("FAIL: smoothing_fallback_weight = ")


def test_cli_fallback_gate_fails_a_mostly_forward_batch_and_refuses_one_without_smoother(
    tmp_path: Path,
) -> None:
    common = [
        "batch", str(CART), "--model", "double_cart_case1", "--estimator", "imm",
        "--fail-over", "smoothing_fallback_weight=0.5",
    ]  # fmt: skip
    refused = run([*common, "--out", str(tmp_path / "plain")], expect=2)
    assert "runs no smoother (smooth = false; add --smooth)" in refused.stderr
    assert not (tmp_path / "plain").exists()
    out = tmp_path / "b"
    result = run([*common, "--smooth", "--out", str(out), "--junit", str(tmp_path / "j.xml")],
                 expect=1)  # fmt: skip
    with (out / "summary.csv").open(newline="") as file:
        reader = csv.DictReader(file)
        (row,) = reader
        header = reader.fieldnames or []
    assert header.count("smoothing_fallback_weight") == 1
    assert float(row["smoothing_fallback_weight"]) > 0.5
    assert row["gate_failures"].startswith(
        f"smoothing_fallback_weight = {float(row['smoothing_fallback_weight']):.6g} (kim-rts"
    )
    assert "gate failed" in result.stderr and "smoothing_fallback_weight = " in result.stderr
    junit = (tmp_path / "j.xml").read_text()
    assert 'name="--fail-over smoothing_fallback_weight=0.5"' in junit
    assert '<failure message="smoothing_fallback_weight = ' in junit
