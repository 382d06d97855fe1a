"""A log analysed in part says on the terminal which part was left out.

``analyze --split-gaps`` of the tank log with rows 140-159 taken out analysed 160 … 300 s
and printed ``imm on cut.csv: 141 samples ..., mode accuracy 100.0 %``, which read as the
whole log's; that 139 s were not analysed was a NOTE at the end of report.md only.  The notes
that a stretch of the log's time was not analysed (``--split-gaps``, a signal that starts
the span late or ends it early, ``--drop-nonfinite`` at an end) are printed as those of
samples not used are (``report.reading_notes.unanalysed_span_notes``).
"""

from pathlib import Path

import polars as pl

from hybridlog.report.reading_notes import unanalysed_span_notes
from tests.cli.test_cli import run
from tests.support.paths import SAMPLE_LOGS

SAID = (
    "hybridlog: note: --split-gaps: 1 output gap longer than max_gap (t = 139 … 160 s) cut "
    "the log into 2 pieces; the longest is analysed, t = 160 … 300 s; not analysed: "
    "t = 0 … 139 s\n"
)


def test_analyze_says_the_piece_split_gaps_left_out(tmp_path: Path) -> None:
    frame = pl.read_csv(SAMPLE_LOGS / "three_tank_hstf.csv")
    log = tmp_path / "cut.csv"
    frame.filter((pl.col("t") < 140) | (pl.col("t") >= 160)).write_csv(log)
    out = tmp_path / "a"
    args = ["analyze", str(log), "--model", "three_tank_hstf", "--estimator", "imm"]
    analyzed = run([*args, "--split-gaps", "--out", str(out)])
    assert analyzed.stderr == SAID
    assert SAID.removeprefix("hybridlog: note: ")[:-1] in (out / "report.md").read_text()


def test_every_note_of_a_stretch_not_analysed_is_one_to_print() -> None:
    reading = {
        "span": {"end": {"at": 99.0, "signal": "output y2", "log": 300.0, "left_out": 201.0}},
        "nonfinite_span": {"start": {"at": 5.0, "signal": "y1", "dropped": 5, "from": 0.0}},
    }
    notes = unanalysed_span_notes(reading)
    assert [n.split(",")[0] for n in notes] == [
        "NOTE: the analysed span ends at t = 99 s",
        "NOTE: the analysed span starts at t = 5 s",
    ]
    assert "201 s of the log not analysed" in notes[0]
    assert unanalysed_span_notes(None) == []
