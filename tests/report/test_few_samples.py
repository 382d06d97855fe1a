"""Metrics over fewer than FEW_SAMPLES samples warn that they describe those samples only.

A 5-sample log of the three-tank got hstf's VAF 5.2 % and mode accuracy 0 (301 samples: 87 %
and 99 %) on the terminal and in report.md without a word that four predicted samples and
the filter's start decide them.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from hybridlog.estimators.registry import prepare
from hybridlog.io import SignalSpec, load_signals
from hybridlog.model.loader import load_model
from hybridlog.report import build_report, render_markdown
from hybridlog.report.few_samples import FEW_SAMPLES
from hybridlog.report.gates import evaluate_gates, met_value, parse_gates
from hybridlog.report.markdown import WARNING_PREFIX
from tests.support.cpha import cpha_truth_log

from .test_report_files import DT, make_run


def _warnings(n: int) -> list[str]:
    result, signals = make_run(n, seed=3)
    report = build_report(result, signals, log="run.csv", model_name="m", dt=DT)
    return [note for note in report.notes if "fewer than" in note]


def test_a_short_run_warns_naming_each_metric_and_its_samples() -> None:
    result, signals = make_run(5, seed=3)
    report = build_report(result, signals, log="run.csv", model_name="m", dt=DT)
    (warning,) = [note for note in report.notes if "fewer than" in note]
    assert warning.startswith(
        f"{WARNING_PREFIX}MSE, VAF and fit over 4 samples; mode accuracy over 5 samples; "
        f"state RMSE of x1, x3 over 5 samples: fewer than {FEW_SAMPLES} samples"
    )
    assert "(82% at 4)" in warning
    # what to do, not only what is wrong (it said the metrics describe these samples only)
    assert warning.endswith(
        f"; judge the estimator on a log that gives each metric at least {FEW_SAMPLES} samples"
    )
    assert "## Warnings" in render_markdown(report)


@pytest.mark.parametrize(("n", "warned"), [(FEW_SAMPLES, True), (FEW_SAMPLES + 1, False)])
def test_the_output_metrics_warn_below_the_threshold_not_at_it(n: int, warned: bool) -> None:
    """Row 0 has no prediction: n samples score n - 1 predictions."""
    assert bool(_warnings(n)) is warned


def test_a_long_run_with_a_short_true_state_warns_of_that_state_only() -> None:
    result, signals = make_run(400, seed=3)
    assert signals.truth_states is not None
    truth = signals.truth_states.copy()
    truth[10:, 0] = np.nan  # x1 known on 10 samples; x3 on all
    report = build_report(
        result,
        dataclasses.replace(signals, truth_states=truth),
        log="run.csv",
        model_name="m",
        dt=DT,
    )
    (warning,) = [note for note in report.notes if "fewer than" in note]
    assert warning.startswith(f"{WARNING_PREFIX}state RMSE of x1 over 10 samples: fewer than")


def test_a_components_accuracy_over_few_samples_warns_without_a_joint_one(
    tmp_path: Path,
) -> None:
    """Without A3's true mode there is no joint accuracy, and A1's and A2's own accuracies,
    over the 12 and 10 samples their true modes cover, were reported with no warning."""
    model_file, log = cpha_truth_log(tmp_path)
    late = pl.int_range(pl.len())
    partial = pl.read_csv(log).drop("mode.A3")
    partial = partial.with_columns(
        pl.when(late >= partial.height - 12).then(pl.col("mode.A1")).alias("mode.A1"),
        pl.when(late >= partial.height - 10).then(pl.col("mode.A2")).alias("mode.A2"),
    )
    partial.write_csv(tmp_path / "partial.csv")
    model = load_model(model_file)
    signals = load_signals(tmp_path / "partial.csv", SignalSpec.of(model))
    result = prepare(model, "imm").run(model, signals)  # with mode.<component>
    report = build_report(result, signals, log="partial.csv", model_name="cpha", dt=model.dt)
    assert report.modes.accuracy is None
    assert {c: m.samples for c, m in report.modes.components.items()} == {"A1": 12, "A2": 10}
    (warning,) = [note for note in report.notes if "fewer than" in note]
    assert warning.startswith(
        f"{WARNING_PREFIX}mode accuracy of components A1, A2 over 12 (A1), 10 (A2): fewer than"
    )
    assert "(47% at 10)" in warning


def test_a_gate_over_few_samples_says_so_in_its_own_line() -> None:
    """``met (vaf = 0.9)`` over 4 samples passed CI with the warning printed apart."""
    result, signals = make_run(5, seed=3)
    report = build_report(result, signals, log="run.csv", model_name="m", dt=DT)
    assert met_value(report, "vaf", 0.5, 0.0).endswith(" over only 4 samples")
    assert met_value(report, "state_rmse.x1", 0.5, 1.0).endswith(" over only 5 samples")
    (missed,) = evaluate_gates(report, parse_gates([], ["mse=0"]))
    assert " over only 4 samples is over the bound 0" in missed
    long_result, long_signals = make_run(FEW_SAMPLES + 1, seed=3)
    long = build_report(long_result, long_signals, log="run.csv", model_name="m", dt=DT)
    assert met_value(long, "vaf", 0.5, 0.0) == "vaf = 0.5"
