"""batch and compare say which logs (estimators) warn: one line on the terminal, not per log.

``analyze`` printed imm's innovations warning for a log whose sensor is scaled by 1.5;
``batch`` and ``compare`` of the same log said nothing, on the terminal or in their
summaries, and a resumed batch (reports reused) had nothing else to show either.
"""

from __future__ import annotations

import csv
from collections.abc import Callable
from pathlib import Path

from tests.conftest import Main


def _scaled(source: Path, target: Path) -> Path:
    """``source`` with ``y1`` scaled by 1.5: imm's innovations test warns (NIS score 10)."""
    with source.open(newline="") as file:
        rows = list(csv.DictReader(file))
    with target.open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows({**r, "y1": repr(1.5 * float(r["y1"]))} for r in rows)
    return target


def test_batch_says_once_how_many_logs_warn_and_so_does_a_resumed_one(
    hybridlog_main: Main, sample_copy: Callable[[str], Path], tmp_path: Path
) -> None:
    clean = sample_copy("three_tank_hstf.csv")
    scaled = _scaled(clean, tmp_path / "scaled.csv")
    broken = tmp_path / "broken.csv"
    broken.write_text("t,u\n")  # not analysed: not counted
    out = tmp_path / "out"
    args = ["batch", str(clean), str(scaled), str(broken), "--model", "three_tank_hstf"]
    args += ["--estimator", "imm", "--out", str(out)]
    for status in ("done", "skipped"):
        code, err = hybridlog_main(args)
        assert code == 1, err
        assert f"hybridlog: 1 of 2 analysed logs has warnings; see {out / 'summary.md'}" in err
        assert "innovations" not in err  # the warning itself: in summary.md, not per log
        with (out / "summary.csv").open() as file:
            table = list(csv.DictReader(file))
        assert {Path(r["log"]).name: (r["status"], r["warnings"]) for r in table} == {
            "three_tank_hstf.csv": (status, "0"),
            "scaled.csv": (status, "1"),
            "broken.csv": ("failed", ""),
        }
        text = (out / "summary.md").read_text(encoding="utf-8")
        assert "scaled.csv (1 warning): the innovations are larger than the model's" in text
    code, err = hybridlog_main(["-q", *args])
    assert code == 1 and "warnings" not in err


def test_compare_says_how_many_estimators_warn(
    hybridlog_main: Main, sample_copy: Callable[[str], Path], tmp_path: Path
) -> None:
    scaled = _scaled(sample_copy("three_tank_hstf.csv"), tmp_path / "scaled.csv")
    out = tmp_path / "cmp"
    args = ["compare", str(scaled), "--model", "three_tank_hstf", "--estimators", "imm,hstf"]
    code, err = hybridlog_main([*args, "--out", str(out)])
    assert code == 0, err
    assert f"hybridlog: 1 of 2 estimators has warnings; see {out / 'comparison.md'}" in err
    with (out / "comparison.csv").open() as file:
        assert {r["estimator"]: r["warnings"] for r in csv.DictReader(file)} == {
            "imm": "1",
            "hstf": "0",
        }
    assert "- `imm` (1 warning): the innovations" in (out / "comparison.md").read_text()
