"""The other report folders of a batch folder are named by what they are.

summary.md and the note called every folder of no log of the run a report "of logs not in
this batch (renamed, moved or left out since an earlier run)", also a report ``analyze``
wrote there, each estimator's report of a comparison (``cmp/hstf``, ``cmp/imm``: two logs
left out?), and the reports of another batch whose folder lies inside this one, which
besides made every later run of the outer batch refused, exit 2, "holds reports of imm
...; use --force to replace them" (``--force`` replaced nothing of it).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.compare import compare
from tests.jobs.test_batch_resume import write_logs

TANK = "three_tank_hstf"


def test_each_kind_of_other_folder_is_named_as_what_it_is(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    write_logs(Path("runs"), ["a.csv", "b.csv"], steps=10)
    run_batch(["runs"], TANK, out_dir="out", estimator="imm")
    analyze("runs/a.csv", TANK, out_dir="out/mine", estimator="imm")
    compare("runs/a.csv", TANK, ["imm", "hstf"], out_dir="out/cmp")
    Path("runs/b.csv").rename("runs/b2.csv")

    again = run_batch(["runs"], TANK, out_dir="out", estimator="imm")

    assert [o.status for o in again.logs] == ["skipped", "done"]
    assert again.notes == [
        "--out holds a report folder of logs not in this batch ('b.csv'; renamed, moved or "
        "left out since an earlier run), a report hybridlog analyze wrote into it ('mine') "
        "and a comparison hybridlog compare wrote into it ('cmp'): kept, and not in its "
        "summaries"
    ]
    summary = Path("out/summary.md").read_text()
    assert summary[summary.index("## Other report folders") :].splitlines() == [
        "## Other report folders (3)",
        "",
        "Of logs not in this batch (renamed, moved or left out since an earlier run into "
        "this folder): kept, not summarised here.",
        "",
        "- b.csv",
        "",
        "Reports `hybridlog analyze` wrote into this folder: kept, not summarised here.",
        "",
        "- mine",
        "",
        "Comparisons `hybridlog compare` wrote into this folder: kept, not summarised here.",
        "",
        "- cmp",
    ]


def test_a_batch_folder_inside_the_batch_folder_is_named_once_and_refuses_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    write_logs(Path("runs"), ["a.csv"], steps=10)
    run_batch(["runs"], TANK, out_dir="out", estimator="imm")
    run_batch(["runs/a.csv"], TANK, out_dir="out/nested", estimator="hstf")  # another estimator

    again = run_batch(["runs"], TANK, out_dir="out", estimator="imm")

    assert [o.status for o in again.logs] == ["skipped"]
    assert again.notes == [
        "--out holds another batch's folder ('nested'; a batch's own summaries name its "
        "reports): kept, and not in its summaries"
    ]
    summary = Path("out/summary.md").read_text()
    assert summary[summary.index("## Other report folders") :].splitlines() == [
        "## Other report folders (1)",
        "",
        "Folders of other batches inside this one: kept, not summarised here (their own "
        "summaries name their reports).",
        "",
        "- nested",
    ]
    assert Path("out/nested/a.csv/report.json").is_file()


def test_a_logs_folder_inside_a_comparison_names_the_comparison(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """It was called "the report an earlier run wrote for another log (since renamed...)"."""
    import hybridlog.jobs.batch_outcomes as batch_outcomes

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(batch_outcomes, "_ERROR_LIMIT", 1000)  # pytest's folders: not cut
    write_logs(Path("runs"), ["a.csv"], steps=10)
    run_batch(["runs"], TANK, out_dir="out", estimator="imm")
    compare("runs/a.csv", TANK, ["imm", "hstf"], out_dir="out/cmp")
    analyze("runs/a.csv", TANK, out_dir="out/mine", estimator="imm")
    write_logs(Path("runs/cmp"), ["c.csv"], steps=10, first_seed=3)
    write_logs(Path("runs/mine"), ["d.csv"], steps=10, first_seed=4)
    write_logs(Path("runs/cmp/hstf"), ["e.csv"], steps=10, first_seed=5)

    again = run_batch(["runs"], TANK, out_dir="out", estimator="imm")

    errors = {o.log: o.error for o in again.logs if o.status == "failed"}
    assert errors["runs/cmp/c.csv"] is not None and errors["runs/cmp/c.csv"].endswith(
        "/out/cmp', a comparison hybridlog compare wrote there; move that folder out of "
        "--out, or choose another --out"
    )
    assert errors["runs/mine/d.csv"] is not None and errors["runs/mine/d.csv"].endswith(
        "/out/mine', a report hybridlog analyze wrote there; move that folder out of "
        "--out, or choose another --out"
    )
    # an estimator's report inside a comparison was "a report hybridlog analyze wrote there"
    assert errors["runs/cmp/hstf/e.csv"] is not None and errors["runs/cmp/hstf/e.csv"].endswith(
        "/out/cmp/hstf', one estimator's report of a comparison hybridlog compare wrote there "
        f"('{Path('out/cmp').absolute()}'); move that folder out of --out, or choose another --out"
    )
