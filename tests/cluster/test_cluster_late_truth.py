"""``hybridlog cluster`` on a log whose true mode starts late: over which samples it scores."""

import json
from pathlib import Path

import matplotlib
import polars as pl
import pytest

from hybridlog.jobs.cluster import discover_modes
from hybridlog.times import format_time
from tests.support.paths import SAMPLE_LOGS

UNIX = 1_700_000_000.0
"""Unix-time stamps: where the true mode starts must read as a time of the log."""


def _log(tmp_path: Path, late: int) -> tuple[Path, float]:
    """300 rows of double_cart_case1 in Unix time, the true mode missing from the first
    ``late``; and where it starts."""
    frame = pl.read_csv(SAMPLE_LOGS / "double_cart_case1.csv").head(300)
    frame = frame.with_columns(
        pl.col("t") + UNIX,
        pl.when(pl.int_range(frame.height) < late)
        .then(None)
        .otherwise(pl.col("mode"))
        .alias("mode"),
    )
    path = tmp_path / f"late{late}.csv"
    frame.write_csv(path)
    return path, float(frame["t"][late])


@pytest.mark.parametrize("late", [0, 100])
def test_the_accuracy_says_over_which_samples_as_the_reports_do(tmp_path, late):
    """The accuracy of the decision rule was printed, recorded and (not) drawn as a whole
    log's while it skipped the samples before the true mode: it now says "over 200 of 300
    samples (the true mode starts at t = … s)" in the note, the centres file and the
    picture, in report.md's and the batch summaries' words; nothing more for a whole log."""
    log, start = _log(tmp_path, late)
    out = tmp_path / "c.json"
    with matplotlib.rc_context({"svg.fonttype": "none"}):  # the picture's text as text
        outcome = discover_modes(log, "double_cart_case1", out=out, plot=tmp_path / "c.svg")
    said = [n for n in outcome.notes if "mode accuracy of the decision rule" in n]
    content = json.loads(out.read_text())
    picture = (tmp_path / "c.svg").read_text()
    assert len(said) == 1 and "mode accuracy of the decision rule on this log: chiu" in picture
    if late == 0:
        assert " over " not in said[0] and "mode_accuracy_over" not in content
        assert " over " not in picture
        return
    over = f"200 of 300 samples (the true mode starts at t = {format_time(start)} s)"
    assert format_time(start) == "1700000050"
    assert said[0].endswith(f"on this log {outcome.accuracy['chiu']:.4f} over {over}")
    assert content["mode_accuracy_over"] == over
    assert content["reading"]["truth_starts"]["mode"]["samples"] == 200
    assert f"over {over}" in picture
