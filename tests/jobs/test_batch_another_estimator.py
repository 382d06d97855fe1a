"""A batch re-run into a folder of another estimator's (or model's) reports is refused first.

Before, every log failed with "use --force" (its folder is never replaced without it), exit 1,
and then the summaries of that run, every log failed, replaced the previous run's summary.md,
summary.csv and summary.png: the user's summaries lost for a run that wrote nothing.  Now the
run stops before any log is read, exit 2, naming the folder and what differs.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import hybridlog.jobs.batch as batch
from hybridlog.errors import OutputError
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from tests.support.logfiles import tank_run

TANK = "three_tank_hstf"
SUMMARIES = ("summary.md", "summary.csv", "summary.png")


def _batch_folder(tmp_path: Path) -> tuple[list[Path], Path]:
    (tmp_path / "logs").mkdir()
    logs = [
        write_table(tmp_path / "logs" / f"s{k}.csv", tank_run(steps=30, seed=k).columns)
        for k in (1, 2)
    ]
    run_batch(logs, TANK, out_dir=tmp_path / "out", estimator="imm")
    return logs, tmp_path / "out"


def _contents(out: Path) -> dict[str, bytes]:
    return {
        path.relative_to(out).as_posix(): path.read_bytes()
        for path in sorted(out.rglob("*"))
        if path.is_file()
    }


@pytest.mark.parametrize(
    ("model", "estimator", "named"),
    [
        (TANK, "hstf", "reports of 'imm' with model 'three_tank_hstf'"),
        ("double_cart_case1", "imm", "not of imm with model double_cart_case1"),
    ],
)
def test_another_estimator_or_model_is_refused_before_any_log_is_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, model: str, estimator: str, named: str
) -> None:
    logs, out = _batch_folder(tmp_path)
    before = _contents(out)
    analysed: list[str] = []
    monkeypatch.setattr(batch, "analyze_log", lambda job, log, folder: analysed.append(log))
    with pytest.raises(OutputError, match="use --force to replace them, or another --out") as err:
        run_batch(logs, model, out_dir=out, estimator=estimator)
    assert named in str(err.value) and str(out) in str(err.value)
    assert "\n" not in str(err.value)
    assert analysed == []
    assert _contents(out) == before  # the previous run's summaries are intact
    assert all(name in before for name in SUMMARIES)


def test_force_replaces_them_and_other_options_redo_as_before(tmp_path: Path) -> None:
    logs, out = _batch_folder(tmp_path)
    changed = run_batch(logs, TANK, out_dir=out, estimator="imm", sets=["transition_stay=0.9"])
    assert {o.status for o in changed.logs} == {"done"}  # same estimator: redone, not refused
    replaced = run_batch(logs, TANK, out_dir=out, estimator="hstf", force=True)
    assert {o.status for o in replaced.logs} == {"done"}
    assert "· hstf" in (out / "summary.md").read_text(encoding="utf-8")


def test_another_estimator_over_other_logs_is_refused_too(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Before, only the folders of this run's logs were looked at: a run over other logs (a
    new night's) into a folder of another estimator's batch passed, exit 0, and its summaries
    replaced that batch's, whose report folders stayed there unsummarised."""
    _, out = _batch_folder(tmp_path)
    before = _contents(out)
    (tmp_path / "new").mkdir()
    other = write_table(tmp_path / "new" / "n1.csv", tank_run(steps=30, seed=7).columns)
    analysed: list[str] = []
    monkeypatch.setattr(batch, "analyze_log", lambda job, log, folder: analysed.append(log))
    with pytest.raises(OutputError, match=r"reports of 'imm' .*\(s1\.csv and 1 more\)"):
        run_batch([other], TANK, out_dir=out, estimator="hstf")
    assert analysed == [] and _contents(out) == before


def test_a_comparison_written_into_the_batch_folder_does_not_stop_the_batch(
    tmp_path: Path,
) -> None:
    """``compare --out <batch>/cmp`` is allowed (it replaces nothing the summaries name), but
    its reports, of other estimators by nature, made every later run of the batch refused,
    exit 2, "use --force to replace them" (which replaced nothing of it either).  Only a
    batch's reports count now; the comparison is named among the other report folders, once."""
    from hybridlog.jobs.compare import compare

    logs, out = _batch_folder(tmp_path)
    compare(logs[0], TANK, estimators=["hstf", "imm"], out_dir=out / "cmp")
    again = run_batch(logs, TANK, out_dir=out, estimator="imm")
    assert {o.status for o in again.logs} == {"skipped"}
    assert "a comparison hybridlog compare wrote into it ('cmp')" in again.notes[-1]
    assert (out / "cmp" / "hstf" / "report.json").is_file()  # kept
