"""report.md's statements of whose states a report holds agree with its estimates table.

``kbest`` without ``smooth`` has no smoother, yet brings its own states (the EKF along its
path); report.md said "smoother: none (the filter's estimates)" under a States table of
those other estimates, whose ``_hat`` columns in estimates.csv differ from the
``_hat_filtered`` ones; nor did its description, or the Viterbi path's, say that the
timeline's mode probabilities stay the filter's.  Here each offline pass is run and what
report.md says is checked against the tables.
"""

from __future__ import annotations

from pathlib import Path

import polars as pl
import pytest

from tests.cli.test_cli import run
from tests.support.paths import TANK_CSV

FILTERS_OWN = "The causal filter's own: the Viterbi path changes only the modes."


@pytest.mark.parametrize(
    "flags",
    [
        ["--mode-sequence", "viterbi"],
        ["--mode-sequence", "kbest", "--set", "beam=4"],
        ["--mode-sequence", "kbest", "--set", "beam=4", "--smooth"],
        ["--smooth"],
    ],
    ids=["viterbi", "kbest", "kbest-smooth", "smooth"],
)
def test_report_md_says_the_states_are_the_filters_only_when_they_are(
    tmp_path: Path, flags: list[str]
) -> None:
    out = tmp_path / "out"
    run(["analyze", str(TANK_CSV), "--model", "three_tank_hstf", "--estimator", "imm",
         *flags, "--out", str(out)])  # fmt: skip
    table = pl.read_csv(out / "estimates.csv")
    states = [c.removesuffix("_hat") for c in table.columns if c.endswith("_hat")]
    states = [x for x in states if f"{x}_hat_filtered" in table.columns]
    assert states
    same = all(table[f"{x}_hat"].equals(table[f"{x}_hat_filtered"]) for x in states)
    text = (out / "report.md").read_text()
    smoother = next(line for line in text.splitlines() if line.startswith("- smoother: "))
    states_section = text.split("## States\n", 1)[1].split("\n## ", 1)[0]
    says_filters = "(the filter's estimates)" in smoother
    assert says_filters == same, smoother
    assert (FILTERS_OWN in states_section) == same, states_section
    assert same == (flags == ["--mode-sequence", "viterbi"])
    # the description says whose mode probabilities the timeline's p_<mode> columns hold
    timeline = pl.read_csv(out / "timeline.csv")
    probabilities = [
        c for c in timeline.columns if c.startswith("p_") and f"{c}_filtered" in timeline.columns
    ]
    assert probabilities
    kept = all(timeline[p].equals(timeline[f"{p}_filtered"]) for p in probabilities)
    description = text.split(smoother + "\n- ", 1)[1].splitlines()[0]
    says_kept = "mode probabilities: the filter's" in description
    assert says_kept == kept, description
    assert kept == ("--smooth" not in flags)
