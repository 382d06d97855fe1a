"""A true mode with a stretch of blank cells, through the command line (``batch``).

The blank stretch of a sampled true mode was held at its last label and scored: mode
accuracy 0.72 where the same log whole read 0.99, with a NOTE in report.md alone and
nothing in summary.md.  Those samples now have no true mode, are not scored, and every
summary says over how many samples the accuracy is, and where the true mode has none.
"""

import csv
import json
from pathlib import Path

import polars as pl

from tests.cli.test_cli import run
from tests.support.paths import SAMPLE_LOGS

WHERE = "the true mode has no sample from t = 99 to 181 s"


def test_a_blank_stretch_of_the_true_mode_is_not_scored_and_is_said(tmp_path: Path) -> None:
    frame = pl.read_csv(SAMPLE_LOGS / "three_tank_hstf.csv", infer_schema=False)
    seconds = frame["t"].cast(pl.Float64)
    blank = frame.with_columns(
        pl.when((seconds >= 100) & (seconds <= 180))
        .then(None)
        .otherwise(pl.col("mode"))
        .alias("mode")
    )
    logs = tmp_path / "logs"
    logs.mkdir()
    frame.write_csv(logs / "whole.csv")
    blank.write_csv(logs / "blank.csv")
    out = tmp_path / "out"
    run(
        ["batch", str(logs), "--model", "three_tank_hstf", "--estimator", "imm", "--out",
         str(out), "-q"]
    )  # fmt: skip
    whole = json.loads((out / "whole.csv" / "report.json").read_text())["modes"]
    report = json.loads((out / "blank.csv" / "report.json").read_text())
    modes = report["modes"]
    assert (whole["samples"], modes["samples"]) == (301, 220)
    assert report["reading"]["truth_gaps"] == {
        "mode": {"start": 99.0, "end": 181.0, "seconds": 82.0, "gaps": 1, "points": 81, "of": 301}
        | {"every": 1.0, "steps": 1.0}
    }
    assert "truth_held" not in report["reading"]
    # the confusion is the whole log's less the samples blanked (estimates of 100..180 s)
    scored = sum(sum(row.values()) for row in modes["confusion"].values())
    assert scored == 220 and modes["accuracy"] >= whole["accuracy"] - 0.01
    # the true switch at 101 s, inside the blank stretch, has no event; the one at 201 s has
    assert [e["t"] for e in whole["detection"]["events"]] == [101.0, 201.0]
    assert [e["t"] for e in modes["detection"]["events"]] == [201.0]
    md = (out / "blank.csv" / "report.md").read_text()
    assert "over 220 of 301 samples (those with a true mode)" in md
    assert (
        "WARNING: the true mode has no sample within dt/2 of 81 of 301 sample times, from "
        "t = 99 to 181 s (82 s)"
    ) in md
    with (out / "summary.csv").open() as file:
        samples = {Path(r["log"]).name: r["mode_samples"] for r in csv.DictReader(file)}
    assert samples == {"blank.csv": "220", "whole.csv": "301"}
    summary = (out / "summary.md").read_text()
    assert f"blank.csv: over 220 of 301 samples ({WHERE})" in summary
    assert "whole.csv: over" not in summary


def test_analyze_prints_every_warning_of_its_report_on_the_terminal(tmp_path: Path) -> None:
    """Every ``WARNING:`` note of report.md on stderr, not only the innovations' test's."""
    frame = pl.read_csv(SAMPLE_LOGS / "three_tank_hstf.csv", infer_schema=False)
    seconds = frame["t"].cast(pl.Float64)
    blank = frame.with_columns(
        pl.when((seconds >= 100) & (seconds <= 180))
        .then(None)
        .otherwise(pl.col("mode"))
        .alias("mode")
    )
    log = tmp_path / "blank.csv"
    blank.write_csv(log)
    args = ["analyze", str(log), "--model", "three_tank_hstf", "--estimator", "imm"]
    result = run([*args, "--out", str(tmp_path / "out")])
    assert "hybridlog: warning: the true mode has no sample within dt/2 of 81" in result.stderr
    assert "from t = 99 to 181 s (82 s)" in result.stderr
    quiet = run(["-q", *args, "--out", str(tmp_path / "quiet")])
    assert "warning" not in quiet.stderr


def test_a_switching_signal_with_a_gap_is_refused_to_the_estimator_on_it(
    tmp_path: Path,
) -> None:
    """switching-observer takes every sample's mode from the true mode: the gap's samples
    have none (-1, which as an index is the last mode), so it is refused, naming where."""
    frame = pl.read_csv(SAMPLE_LOGS / "ice_clutch.csv", infer_schema=False)
    rows = pl.int_range(frame.height)
    gap = frame.with_columns(
        pl.when((rows >= 100) & (rows < 200)).then(None).otherwise(pl.col("mode")).alias("mode")
    )
    log = tmp_path / "gap.csv"
    gap.write_csv(log)
    out = tmp_path / "out"
    result = run(["analyze", str(log), "--model", "ice_clutch", "--out", str(out)], expect=2)
    message = result.stderr.strip().splitlines()[-1]
    assert message.startswith(
        f"hybridlog: error: {log}: estimator 'switching-observer' needs the switching signal "
        "at every sample; the true mode has none within dt/2 of t="
    )
    assert "a gap in it may hide a switch" in message and "--max-gap" not in message
    assert not out.exists()


def test_a_switching_signal_slower_than_dt_is_said_to_be_the_log_s_sample_time(
    tmp_path: Path,
) -> None:
    """Every other row of the clutch log (sampled every 20 ms, the model's dt 10 ms) was told of
    "a gap" at its second sample and to map another switching signal."""
    frame = pl.read_csv(SAMPLE_LOGS / "ice_clutch.csv", infer_schema=False)
    log = tmp_path / "every_other.csv"
    frame.gather_every(2).write_csv(log)
    out = tmp_path / "out"
    result = run(["analyze", str(log), "--model", "ice_clutch", "--out", str(out)], expect=2)
    message = result.stderr.strip().splitlines()[-1]
    assert message == (
        f"hybridlog: error: {log}: estimator 'switching-observer' needs the switching signal "
        "at every sample; the true mode has none within dt/2 of 400 of 801 sample times, the "
        "first at t=0.01 s (sample 1): it is sampled every 2 steps of dt = 0.01 s (median), so "
        "a switch between its samples would go unseen: use a model whose dt is the log's "
        "sample time (or map a switching signal sampled every dt with --map truth.mode=PATH)"
    )
    assert not out.exists()


def test_rows_missing_around_a_switch_leave_the_true_mode_unscored_there(
    tmp_path: Path,
) -> None:
    """Rows t = 20..22 s missing (3 s, under max_gap), the true switch 1 -> 2 at 21 s.

    The true mode was held at 1 over them: scored as three samples of mode 1, the switch
    placed at 23 s and called missed, without a word, where the true states beside it were
    left out of their RMSE with a WARNING.  Now those samples have no true mode, as theirs.
    """
    log = tmp_path / "full.csv"
    run(["simulate", "three_tank_hstf", "--out", str(log), "--schedule", "1:20,2:30", "-q"])
    frame = pl.read_csv(log)
    assert frame.filter(pl.col("t") == 21.0)["mode"].to_list() == [2]
    gap = tmp_path / "gap.csv"
    frame.filter(~pl.col("t").is_in([20.0, 21.0, 22.0])).write_csv(gap)
    out = tmp_path / "out"
    args = ["analyze", str(gap), "--model", "three_tank_hstf", "--set", "likelihood=unfaded"]
    result = run([*args, "--out", str(out)])
    report = json.loads((out / "report.json").read_text())
    assert report["reading"]["truth_gaps"] == {
        "mode": {"start": 19.0, "end": 23.0, "seconds": 4.0, "gaps": 1, "points": 3, "of": 51}
        | {"every": 1.0, "steps": 1.0}
    }
    modes = report["modes"]
    assert modes["samples"] == 48  # was 51
    assert sum(sum(row.values()) for row in modes["confusion"].values()) == 48
    assert modes["detection"]["events"] == []  # was a switch at 23 s, missed
    warning = "the true mode has no sample within dt/2 of 3 of 51 sample times, from t = 19"
    assert f"hybridlog: warning: {warning}" in result.stderr
    md = (out / "report.md").read_text()
    assert f"WARNING: {warning}" in md
    assert "over 48 of 51 samples" in md
