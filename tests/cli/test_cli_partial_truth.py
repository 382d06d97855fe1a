"""A true mode that starts late, through the command line."""

import json
from pathlib import Path

import polars as pl

from hybridlog.times import format_time
from tests.cli.test_cli import run
from tests.support.paths import SAMPLE_LOGS


def test_a_switching_signal_that_starts_late_is_refused_to_the_estimator_on_it(
    tmp_path: Path,
) -> None:
    """The mode metrics score a true mode that starts late from its first sample on; but
    switching-observer takes every sample's mode from it, and would take the uncovered
    samples' NO_TRUE_MODE (-1) as the last mode: refused, naming where it starts."""
    frame = pl.read_csv(SAMPLE_LOGS / "ice_clutch.csv", infer_schema=False)
    late = frame.with_columns(
        pl.when(pl.int_range(frame.height) < 30).then(None).otherwise(pl.col("mode")).alias("mode")
    )
    log = tmp_path / "late.csv"
    late.write_csv(log)
    out = tmp_path / "out"
    result = run(["analyze", str(log), "--model", "ice_clutch", "--out", str(out)], expect=2)
    first = frame["t"].cast(pl.Float64)
    message = result.stderr.strip().splitlines()[-1]
    assert message == (
        f"hybridlog: error: {log}: estimator 'switching-observer' needs the switching signal "
        f"at every sample; the true mode starts at t={format_time(first[30])} s (sample 30), "
        f"after the first sample time t={format_time(first[0])} s (map a switching signal "
        "that covers the log with --map truth.mode=PATH)"
    )
    assert not out.exists()


def test_analyze_scores_a_true_mode_that_starts_late_from_its_first_sample(
    tmp_path: Path,
) -> None:
    """It was refused ('truth.mode (column 'mode') starts at t=30 s, after the first sample
    time'), while a true state that starts late was scored over the samples it covers."""
    frame = pl.read_csv(SAMPLE_LOGS / "three_tank_hstf.csv", infer_schema=False).head(120)
    late = frame.with_columns(
        pl.when(pl.int_range(frame.height) < 30).then(None).otherwise(pl.col("mode")).alias("mode")
    )
    log = tmp_path / "late.csv"
    late.write_csv(log)
    out = tmp_path / "out"
    result = run(["analyze", str(log), "--model", "three_tank_hstf", "--out", str(out)])
    assert "% (over the 90 samples with a true mode), " in result.stdout
    report = json.loads((out / "report.json").read_text())
    assert report["modes"]["samples"] == 90
    assert sum(map(sum, (r.values() for r in report["modes"]["confusion"].values()))) == 90
    assert report["reading"]["truth_starts"] == {"mode": {"at": 30.0, "samples": 90, "of": 120}}
    md = (out / "report.md").read_text()
    assert "over 90 of 120 samples (those with a true mode)" in md
    assert "NOTE: the true mode starts at t = 30 s, after the first sample time" in md
