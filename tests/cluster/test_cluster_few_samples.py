"""``hybridlog cluster`` on a log too short to fit centres or score them on."""

import json
from pathlib import Path

import polars as pl
import pytest

from hybridlog.jobs.cluster import discover_modes
from tests.support.paths import SAMPLE_LOGS


def _head(tmp_path: Path, rows: int) -> Path:
    path = tmp_path / f"head{rows}.csv"
    pl.read_csv(SAMPLE_LOGS / "double_cart_case1.csv").head(rows).write_csv(path)
    return path


@pytest.mark.parametrize("rows", [3, 40])
def test_centres_fitted_on_a_few_samples_are_a_warning(tmp_path, rows):
    """A 3-row log gave 2 centres from 2 regression vectors and "mode accuracy of the
    decision rule on this log 0.3333" (over 3 samples), without the warning analyze gives
    of metrics over fewer than 30 samples; the centres file, which analyze decides by,
    held nothing of it.  Now on stderr and in the file's notes; nothing at 40 rows."""
    out = tmp_path / "c.json"
    outcome = discover_modes(_head(tmp_path, rows), "double_cart_case1", out=out)
    notes = json.loads(out.read_text())["chiu"]["notes"]
    warned = [a for a in outcome.alerts if "fewer than 30" in a]
    if rows == 40:
        assert not warned and not any("fewer than 30" in n for n in notes)
        return
    assert warned == [
        "warning: centres fitted on 2 regression vectors; mode accuracy of the decision rule "
        "over 3 samples: fewer than 30, they describe these samples, not the plant's modes; "
        "fit the clusters on a log that gives at least 30 regression vectors"
    ]
    assert notes[-1] == f"WARNING: {warned[0].removeprefix('warning: ')}"


def test_each_part_is_said_alone():
    """Enough vectors but a true mode over few samples, and the reverse; no accuracy."""
    from hybridlog.jobs.cluster import few_vectors_warning

    assert few_vectors_warning(30, 29) is not None
    assert "regression vector" not in (few_vectors_warning(30, 29) or "")[:40]
    assert "centres fitted on 1 regression vector;" not in (few_vectors_warning(1, None) or "")
    assert "centres fitted on 1 regression vector:" in (few_vectors_warning(1, None) or "")
    assert few_vectors_warning(30, None) is None and few_vectors_warning(30, 30) is None


def test_analyze_by_such_centres_repeats_the_warning(tmp_path):
    """``analyze --set centers=FILE`` said only "2 centres loaded from FILE": the file's
    warning that they rest on 2 regression vectors was in its notes, never read back."""
    from hybridlog.jobs.analysis import analyze

    centres = tmp_path / "c.json"
    discover_modes(_head(tmp_path, 3), "double_cart_case1", out=centres)
    log = SAMPLE_LOGS / "double_cart_case1.csv"
    report = analyze(
        log,
        "double_cart_case1",
        estimator="chiu",
        sets=[f"centers={centres}"],
        out_dir=tmp_path / "r",
    ).report
    (said,) = [n for n in report.notes if "says:" in n]
    assert said == (
        f"WARNING: {centres} says: centres fitted on 2 regression vectors; mode accuracy of "
        "the decision rule over 3 samples: fewer than 30, they describe these samples, not "
        "the plant's modes; fit the clusters on a log that gives at least 30 regression vectors"
    )


def test_a_hand_written_files_warnings_are_repeated_bounded():
    """A centres file is JSON anyone may write: a warning of 200,000 characters, or 5,000
    of them, were repeated whole into the report's notes (and report.md), line breaks kept.
    Each is one printable line of at most 300 characters now, the first 3 only, the others
    counted; an empty one, or a notes that is no list, says none."""
    from hybridlog.cluster.centers_file import centers_json, parse_centers

    def warned(notes: object) -> tuple[str, ...]:
        table = {"centers": [[4.0], [0.0]], "notes": notes}
        stored = {
            "mode_ids": ["a", "b"],
            "regressors": ["y(k)"],
            "output_lags": [0],
            "input_lags": [],
            "scaling": {"lower": [-0.5], "upper": [4.5]},
            "chiu": table,
        }
        return parse_centers(centers_json(stored), "mem.json").clusters["chiu"].warnings

    (huge,) = warned(["WARNING: " + "x" * 200_000])
    assert len(huge) <= 300 and "…" in huge
    assert warned(["WARNING: two\nlines\x1b[31m", "WARNING: ", "WARNING:x", "notes"]) == (
        "two lines\\x1b[31m",
    )
    many = warned([f"WARNING: number {i}" for i in range(5000)])
    assert many == ("number 0", "number 1", "number 2", "4,997 more warnings in its notes")
    assert warned([f"WARNING: number {i}" for i in range(4)])[-1] == "1 more warning in its notes"
    assert warned({"a": "WARNING: x"}) == ()


def test_a_huge_hand_written_warning_is_repeated_without_copying_it_word_by_word():
    """A warning of 3 million words (``ab ab ...``, 9 MB) was split into words and escaped a
    character at a time before being cut to 300 characters: about 30 bytes a character (a
    90 MB centres file took 2.6 GB, one of 1 GB the machine's memory).  Now its two ends
    only are split and escaped: the peak is a few copies of the text at most."""
    import tracemalloc

    from hybridlog.cluster.centers_file import parse_centers

    note = "WARNING: " + "ab " * 3_000_000
    text = json.dumps(
        {
            "format": "hybridlog-centers",
            "version": 1,
            "mode_ids": ["a", "b"],
            "regressors": ["y(k)"],
            "output_lags": [0],
            "input_lags": [],
            "scaling": {"lower": [-0.5], "upper": [4.5]},
            "chiu": {"centers": [[4.0], [0.0]], "notes": [note]},
        }
    )
    tracemalloc.start()
    try:
        (said,) = parse_centers(text, "mem.json").clusters["chiu"].warnings
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert said.startswith("ab ab ") and said.endswith(" ab ab") and "…" in said
    assert len(said) <= 300
    assert peak < 4 * len(text)
