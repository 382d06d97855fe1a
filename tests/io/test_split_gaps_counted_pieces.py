"""--split-gaps finds a piece sampled at ``dt`` in a log mostly sampled slowly.

Whether the outputs left "no piece of more than one sample" was judged from their median
step: a log sampled every second for 30 s and then every 0.1 s for 2 s (a model with
``dt = 0.1``) has a median step of 1 s, longer than ``max_gap`` (0.5 s), and was refused
with "leaves no piece of more than one sample" though it held a 2 s piece of 21 samples.
The pieces are now counted: the log is refused only when every step is a gap.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=0.1)


def write(path: Path, times: list[float]) -> Path:
    path.write_text("t,u,y\n" + "".join(f"{t:.1f},{k},{10 * k}\n" for k, t in enumerate(times)))
    return path


def test_a_dense_piece_after_a_slow_stretch_is_analysed(tmp_path: Path) -> None:
    times = [float(k) for k in range(31)] + [30 + 0.1 * k for k in range(1, 21)]
    log = write(tmp_path / "log.csv", times)
    notes: dict[str, Any] = {}
    signals = load_signals(log, SPEC, ReadOptions(split_gaps=True), notes=notes)
    np.testing.assert_allclose(signals.time, [30 + 0.1 * k for k in range(21)])
    np.testing.assert_array_equal(signals.outputs[:, 0], 10 * np.arange(30, 51))
    np.testing.assert_array_equal(signals.inputs[:, 0], np.arange(30, 51))
    assert notes["segments"][notes["analysed_segment"]] == {
        "start": 30.0,
        "end": 32.0,
        "duration": 2.0,
    }


def test_a_log_whose_every_step_is_a_gap_is_still_refused(tmp_path: Path) -> None:
    log = write(tmp_path / "log.csv", [float(k) for k in range(10)])
    with pytest.raises(
        LogError,
        match=r"--split-gaps: output 'y' \(column 'y'\) leaves no piece of more than one "
        r"sample; it is sampled every 1 s",
    ):
        load_signals(log, SPEC, ReadOptions(split_gaps=True))


def test_a_max_gap_under_dt_cuts_no_step_of_dt(tmp_path: Path) -> None:
    """--max-gap 0 --split-gaps refused a log sampled at dt ('leaves no piece of more than
    one sample'), which --max-gap 0 alone reads whole; and every input sample held for its
    one step was recorded as a hold longer than max_gap."""
    log = write(tmp_path / "log.csv", [0.1 * k for k in range(10)])
    for split in (False, True):
        notes: dict[str, Any] = {}
        signals = load_signals(log, SPEC, ReadOptions(max_gap=0.0, split_gaps=split), notes=notes)
        np.testing.assert_array_equal(signals.outputs[:, 0], 10 * np.arange(10))
        assert notes == {
            "format": "csv",
            "time": "log",
            "fields": {
                "u": {"field": "u", "from": "default"},
                "y": {"field": "y", "from": "default"},
            },
        }


def test_a_max_gap_under_dt_still_cuts_a_real_gap(tmp_path: Path) -> None:
    times = [0.1 * k for k in range(5)] + [1.0 + 0.1 * k for k in range(8)]
    log = write(tmp_path / "log.csv", times)
    notes: dict[str, Any] = {}
    signals = load_signals(log, SPEC, ReadOptions(max_gap=0.0, split_gaps=True), notes=notes)
    np.testing.assert_allclose(signals.time, [1.0 + 0.1 * k for k in range(8)])
    assert notes["gaps"] == [{"start": 0.4, "end": 1.0}]


def test_report_json_lists_the_first_pieces_counted_and_flagged(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A log cut into 20,000 pieces had every piece and gap listed in report.json (2 MB per
    report); the first MAX_LISTED_GAPS are listed now, each list counted and flagged as cut,
    and the piece analysed is recorded whole even when it lies past the listed ones."""
    from hybridlog.io import log_pieces

    monkeypatch.setattr(log_pieces, "MAX_LISTED_GAPS", 3)
    # 8 gaps of 1 s between pieces of 0.5 s; the last piece, 2 s, is the longest
    times = [1.5 * k + 0.1 * j for k in range(8) for j in range(6)]
    times += [12.0 + 0.1 * j for j in range(21)]
    log = write(tmp_path / "log.csv", times)
    notes: dict[str, Any] = {}
    signals = load_signals(log, SPEC, ReadOptions(split_gaps=True), notes=notes)
    np.testing.assert_allclose(signals.time, [12.0 + 0.1 * j for j in range(21)])
    assert [len(notes["segments"]), notes["segment_count"], notes["segments_truncated"]] == [
        3,
        9,
        True,
    ]
    assert [len(notes["gaps"]), notes["gap_count"], notes["gaps_truncated"]] == [3, 8, True]
    assert notes["analysed_segment"] == 8
    assert notes["analysed"] == {"start": 12.0, "end": 14.0, "duration": 2.0}
    # a list not cut says so too: a reader never guesses
    monkeypatch.setattr(log_pieces, "MAX_LISTED_GAPS", 1000)
    whole: dict[str, Any] = {}
    load_signals(log, SPEC, ReadOptions(split_gaps=True), notes=whole)
    assert [len(whole["segments"]), whole["segment_count"], whole["segments_truncated"]] == [
        9,
        9,
        False,
    ]
    assert [len(whole["gaps"]), whole["gap_count"], whole["gaps_truncated"]] == [8, 8, False]


def test_the_note_counts_every_piece_with_thousands_separators() -> None:
    """'19,999 output gaps ... and 19994 more': one count formatted, the other not, and the
    counts were those of report.json's lists, which no longer hold every piece."""
    from hybridlog.report.reading_notes import report_reading_notes

    gaps = [{"start": 10.0 + 2 * k, "end": 11.0 + 2 * k} for k in range(5)]
    pieces = [{"start": 9.0 + 2 * k, "end": 10.0 + 2 * k, "duration": 1.0} for k in range(5)]
    reading = {
        "segments": pieces,
        "segment_count": 20_000,
        "segments_truncated": True,
        "analysed_segment": 12_345,
        "analysed": {"start": 100.0, "end": 400.0, "duration": 300.0},
        "gaps": gaps,
        "gap_count": 19_999,
        "gaps_truncated": True,
    }
    (note,) = report_reading_notes(reading)
    assert note.startswith("NOTE: --split-gaps: 19,999 output gaps longer than max_gap (t = 10")
    assert "… 19 s and 19,994 more) cut the log into 20,000 pieces; the longest is " in note
    assert note.endswith(
        "analysed, t = 100 … 400 s; not analysed: t = 9 … 10 s, t = 11 … 12 s, "
        "t = 13 … 14 s, t = 15 … 16 s, t = 17 … 18 s and 19,994 more"
    )


def test_the_documented_number_of_listed_pieces_is_the_constant() -> None:
    from click.testing import CliRunner

    from hybridlog.cli import cli
    from hybridlog.io.summary import MAX_LISTED_GAPS

    help_text = " ".join(CliRunner().invoke(cli, ["analyze", "--help"]).output.split())
    assert f"the first {MAX_LISTED_GAPS} of them and how many" in help_text
    readme = " ".join((Path(__file__).parents[2] / "README.md").read_text().split())
    assert f"the first {MAX_LISTED_GAPS} pieces, as `reading.gaps` the first" in readme
