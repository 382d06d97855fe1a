"""A batch's summaries say where the smoother left the forward estimate standing (issue 12).

report.json had ``smoothing.fallbacks`` (the double cart: 999 of 1,000 samples, 99.1 % of the
smoothed estimates' weight), but summary.csv, summary.md and JUnit did not: a user batching
thousands of logs could not find the logs whose "smoothed" estimate is mostly the filter's.
"""

from __future__ import annotations

import csv
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

from hybridlog.estimators.result import FALLBACK_CAUSES, Fallbacks
from hybridlog.report.junit import write_junit
from hybridlog.report.summary import batch_markdown, batch_rows_csv
from hybridlog.report.summary_notes import MAX_NAMED
from hybridlog.report.summary_offline import FALLBACK_COLUMNS, fallback_logs
from hybridlog.report.summary_rows import BatchRow
from tests.report.test_summary_offline import METRICS, row

HEADING = "### Logs where the smoother fell back to the forward estimate"


def fell_back(log: str, samples: int, weight: float, *, method: str | None = "kim-rts") -> BatchRow:
    """An analysed, smoothed log whose smoother refused ``samples`` of 1,000 (the guard)."""
    base = row(log, (0.5, 1.0), (0.6, 0.8))
    assert base.report is not None and base.report.smoothing is not None
    by_cause = dict.fromkeys(FALLBACK_CAUSES, 0) | {"guard": samples}
    fallbacks = None if method is None else Fallbacks(samples, 1000, by_cause, weight)
    smoothing = replace(base.report.smoothing, method=method, fallbacks=fallbacks)
    return replace(base, report=replace(base.report, smoothing=smoothing))


FAILED = BatchRow("f.csv", "f.csv", "failed", None, "f.csv: broken", ())


def test_summary_csv_gives_each_logs_fallbacks_after_smoothing(tmp_path: Path) -> None:
    path = tmp_path / "summary.csv"
    rows = [fell_back("a.csv", 999, 0.991), fell_back("b.csv", 0, 0.0), FAILED]
    rows.append(fell_back("v.csv", 0, 0.0, method=None))  # --mode-sequence viterbi alone
    batch_rows_csv(path, rows, METRICS)
    with path.open() as file:
        table = list(csv.DictReader(file))
    header = list(table[0])
    at = header.index("smoothing")
    assert header[at + 1 : at + 3] == list(FALLBACK_COLUMNS) == [
        "smoothing_fallback_samples", "smoothing_fallback_weight",
    ]  # fmt: skip
    assert header[at + 3] == "gate_failures"  # the columns after the group kept their order
    cells = [[r[c] for c in FALLBACK_COLUMNS] for r in table]
    assert cells == [["999", "0.991"], ["0", "0.0"], ["", ""], ["", ""]]
    batch_rows_csv(path, rows)  # without an offline pass: no column added
    with path.open() as file:
        assert not set(FALLBACK_COLUMNS) & set(next(csv.reader(file)))


def test_summary_md_lists_the_logs_that_fell_back_the_largest_share_first() -> None:
    rows = [
        fell_back("small.csv", 3, 0.0003),
        fell_back("none.csv", 0, 0.0),
        FAILED,
        fell_back("cart.csv", 999, 0.991),
        fell_back("tie.csv", 5, 0.0003),  # the same share on more samples: before small.csv
    ]
    _, text = batch_markdown("m · imm · kim-rts, argmax", rows, [], METRICS)
    section = text.split(f"{HEADING} (3 of 4)\n")[1].split("\n## ")[0]
    named = [line for line in section.splitlines() if line.startswith("- ")]
    assert named == [
        "- cart.csv: 99.1 % of the weight, on 999 of 1,000 samples",
        "- tie.csv: 0.03 % of the weight, on 5 of 1,000 samples",
        "- small.csv: 0.03 % of the weight, on 3 of 1,000 samples",
    ]
    assert fallback_logs(rows)[0] == 4  # the failed log is not counted among the smoothed
    # more than MAX_NAMED: the worst named, the others counted
    many = [fell_back(f"w{k:02}.csv", k, k / 1000) for k in range(1, MAX_NAMED + 6)]
    _, text = batch_markdown("m", many, [], METRICS)
    section = text.split(f"{HEADING} ({MAX_NAMED + 5} of {MAX_NAMED + 5})\n")[1]
    named = [line for line in section.splitlines() if line.startswith("- ")]
    assert named[0].startswith(f"- w{MAX_NAMED + 5}.csv: ")
    assert len(named) == MAX_NAMED + 1 and named[-1] == "- and 5 more (summary.csv)"


def test_summary_md_says_a_smoother_never_fell_back_and_nothing_without_one() -> None:
    _, text = batch_markdown("m", [fell_back("a.csv", 0, 0.0), FAILED], [], METRICS)
    assert HEADING not in text
    assert "The smoother never fell back to the forward estimate (1 log smoothed)." in text
    viterbi = [fell_back("a.csv", 0, 0.0, method=None)]
    _, text = batch_markdown("m", viterbi, [], METRICS)
    assert "fell back" not in text
    _, text = batch_markdown("m", [fell_back("a.csv", 999, 0.991)], [])  # no offline pass
    assert "fell back" not in text


def test_summary_md_lists_fallbacks_of_logs_without_a_true_mode_or_state() -> None:
    # the section's comparison with the filter needs a truth; where the smoother fell back
    # does not
    cart = fell_back("cart.csv", 999, 0.991)
    assert cart.report is not None and cart.report.smoothing is not None
    smoothing = cart.report.smoothing
    unknown = replace(smoothing.filtered, mode_accuracy=None, states={})
    smoothing = replace(smoothing, filtered=unknown, smoothed=unknown)
    cart = replace(cart, report=replace(cart.report, smoothing=smoothing))
    _, text = batch_markdown("m", [cart], [], METRICS)
    assert "No analysed log has a true mode or state" in text
    assert f"{HEADING} (1 of 1)" in text
    assert "- cart.csv: 99.1 % of the weight, on 999 of 1,000 samples" in text


def test_junit_says_where_the_smoother_fell_back(tmp_path: Path) -> None:
    path = tmp_path / "junit.xml"
    rows = [fell_back("cart.csv", 999, 0.991), fell_back("none.csv", 0, 0.0)]
    write_junit(path, "hybridlog batch: m", rows, METRICS)
    outputs = {
        case.get("classname"): case.findtext("system-out", "")
        for case in ET.parse(path).getroot().iter("testcase")
    }
    assert outputs["cart.csv"].splitlines()[-1] == (
        "the smoother fell back to the forward estimate on 999 of 1,000 samples (guard 999), "
        "which carry 99.1 % of the smoothed estimates' weight"
    )
    assert "fell back" not in outputs["none.csv"]
