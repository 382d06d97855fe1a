"""A batch that ends without writing its summaries leaves none of the run before.

Before, a nightly run with new options killed (or interrupted) half way left the previous
run's summary.csv and JUnit file beside the reports it had replaced already: summary.csv said
VAF 46.7 % for a log whose report.json said 10.4 %, and the JUnit file a CI step publishes
after a failure showed the earlier run's gates, passed.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

import hybridlog.jobs.batch as batch
from hybridlog.errors import HybridlogError
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch_job import BatchJob
from hybridlog.jobs.batch_outcomes import LogOutcome
from tests.support.logfiles import tank_run

TANK = "three_tank_hstf"


def _vafs(out: Path) -> dict[str, tuple[float, float]]:
    """summary.csv's VAF and report.json's, by report folder."""
    with (out / "summary.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    return {
        row["folder"]: (
            float(row["vaf"]),
            json.loads((out / row["folder"] / "report.json").read_text(encoding="utf-8"))["vaf"],
        )
        for row in rows
    }


def test_a_batch_stopped_half_way_leaves_no_summary_of_the_run_before(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "logs").mkdir()
    logs = [
        write_table(tmp_path / "logs" / f"s{k}.csv", tank_run(steps=30, seed=k).columns)
        for k in (1, 2, 3)
    ]
    out, junit = tmp_path / "out", tmp_path / "junit.xml"
    options: dict[str, object] = {"out_dir": out, "estimator": "imm", "junit": junit}
    batch.run_batch(logs, TANK, fail_under=["vaf=0"], **options)
    assert all(a == b for a, b in _vafs(out).values())
    analysed = batch.analyze_log

    def stopped_at_the_third(job: BatchJob, log: str, folder: str) -> LogOutcome:
        if log.endswith("s3.csv"):
            raise KeyboardInterrupt
        return analysed(job, log, folder)

    monkeypatch.setattr(batch, "analyze_log", stopped_at_the_third)
    with pytest.raises(KeyboardInterrupt):
        batch.run_batch(logs, TANK, sets=["transition_stay=0.8"], **options)
    # s1 and s2 were redone with other numbers: no summary of the run before stays
    assert sorted(p.name for p in out.iterdir()) == [".hybridlog", "s1.csv", "s2.csv", "s3.csv"]
    assert not junit.exists()
    monkeypatch.setattr(batch, "analyze_log", analysed)
    outcome = batch.run_batch(logs, TANK, sets=["transition_stay=0.8"], **options)
    assert [o.status for o in outcome.logs] == ["skipped", "skipped", "done"]
    assert all(a == b for a, b in _vafs(out).values()) and junit.is_file()
    # a run refused before it starts keeps the summaries it would have replaced
    with pytest.raises(HybridlogError):
        batch.run_batch(logs, TANK, sets=["transition_stay=2"], **options)
    assert (out / "summary.csv").is_file() and junit.is_file()
