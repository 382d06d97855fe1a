"""A batch at scale (issue 9): resumed by content, folders by path, plots on demand.

Library-level, in this process (``jobs=1``), except the one test that kills a batch process.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import polars as pl
import pytest

import hybridlog.jit as jit
import hybridlog.jobs.batch_job as batch_job
from hybridlog.errors import OutputError
from hybridlog.io import ReadOptions
from hybridlog.io.tables import TableSource
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.batch_outcomes import BatchOutcome
from hybridlog.jobs.provenance import library_versions
from hybridlog.model.builtins import builtin_text
from hybridlog.outputs.records import record_folder_files
from tests.support.logfiles import tank_run

TANK = "three_tank_hstf"


def write_logs(folder: Path, names: list[str], steps: int = 40, first_seed: int = 1) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    return [
        write_table(folder / name, tank_run(steps=steps, seed=first_seed + k).columns)
        for k, name in enumerate(names)
    ]


def stamps(out: Path) -> dict[str, int]:
    """The modification time of every finished report.json below ``out``, by folder.

    Temporaries (hidden) are skipped; a folder renamed while we look is taken as it is then.
    """
    found = {}
    for parent, folders, files in os.walk(out):
        folders[:] = [f for f in folders if not f.startswith(".")]
        if "report.json" in files:
            with contextlib.suppress(FileNotFoundError):
                stamp = (Path(parent) / "report.json").stat().st_mtime_ns
                found[Path(parent).relative_to(out).as_posix()] = stamp
    return found


def statuses(outcome: BatchOutcome) -> dict[str, str]:
    return {Path(o.log).name: o.status for o in outcome.logs}


def test_fifty_logs_two_corrupted_give_48_reports_2_failures_and_junit_errors(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    logs = write_logs(tmp_path / "logs", [f"run{k}.csv" for k in range(1, 49)], steps=30)
    garbled = tmp_path / "logs" / "run49.csv"
    garbled.write_bytes(b"t,u,y1\n0,1\n\x00\x00garbage")
    crashing = write_logs(tmp_path / "logs", ["run50.csv"], steps=30)[0]
    read = TableSource.read

    def crash(self: TableSource, *args: object, **kwargs: object) -> object:
        if Path(self.path).name == "run50.csv":
            raise ZeroDivisionError("reader bug")
        return read(self, *args, **kwargs)

    monkeypatch.setattr(TableSource, "read", crash)
    out, junit = tmp_path / "out", tmp_path / "junit.xml"
    outcome = run_batch(
        [crashing, *logs[::-1], garbled],
        TANK,
        out_dir=out,
        estimator="imm",
        fail_under=["vaf=0"],
        fail_over=["mse=1e9"],
        junit=junit,
    )
    assert outcome.failed == 2
    assert len(stamps(out)) == 48
    failed = {Path(o.log).name: o.error for o in outcome.logs if o.status == "failed"}
    assert set(failed) == {"run49.csv", "run50.csv"}
    assert failed["run50.csv"] == "ZeroDivisionError: reader bug"
    # summary.md: failures first, then natural order; the failures listed with their errors
    text = (out / "summary.md").read_text()
    rows = [line.split(" | ")[0][2:] for line in text.splitlines() if line.startswith("| /")]
    assert [Path(r).name for r in rows] == [
        "run49.csv",
        "run50.csv",
        *(f"run{k}.csv" for k in range(1, 49)),
    ]
    assert "## Failed logs (2 of 50)" in text and "ZeroDivisionError: reader bug" in text
    assert "pass (2)" in text
    # summary.csv keeps natural order
    assert [Path(p).name for p in pl.read_csv(out / "summary.csv")["log"]] == [
        f"run{k}.csv" for k in range(1, 51)
    ]
    assert (out / "summary.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # JUnit: a case per analysed log per gate, one error per log not analysed
    root = ET.parse(junit).getroot()
    assert root.tag == "testsuites"
    assert (root.get("tests"), root.get("failures"), root.get("errors")) == ("98", "0", "2")
    errors = [c for c in root.iter("testcase") if c.find("error") is not None]
    assert sorted(Path(c.get("classname", "")).name for c in errors) == ["run49.csv", "run50.csv"]
    names = {c.get("name") for c in root.iter("testcase") if c.find("error") is None}
    assert names == {"--fail-under vaf=0", "--fail-over mse=1e9"}


def test_missed_gates_in_summary_and_junit(tmp_path: Path) -> None:
    logs = write_logs(tmp_path, ["a.csv", "b.csv", "c.csv"])
    first = run_batch(logs, TANK, out_dir=tmp_path / "out", estimator="imm")
    vafs = sorted((o.report.vaf, Path(o.log).name) for o in first.logs if o.report)
    bound = (vafs[0][0] + vafs[1][0]) / 2  # only the worst log is under it
    junit = tmp_path / "out" / "junit.xml"
    outcome = run_batch(
        logs,
        TANK,
        out_dir=tmp_path / "out",
        estimator="imm",
        fail_under=[f"vaf={bound}"],
        plots="failed",
        junit=junit,
    )
    worst = vafs[0][1]
    assert [f.split(":")[0] for f in outcome.gate_failures] == [str(tmp_path / worst)]
    # --plots failed: only the log that missed its gate was redone, to draw its plots
    assert statuses(outcome) == {n: "done" if n == worst else "skipped" for n in statuses(first)}
    assert sorted(p.parent.name for p in (tmp_path / "out").rglob("plots")) == [worst]
    text = (tmp_path / "out" / "summary.md").read_text()
    table = [line for line in text.splitlines() if line.startswith("| /")]
    assert worst in table[0] and "FAIL: vaf = " in table[0]
    assert "## Missed gates (1 of 3)" in text
    root = ET.parse(junit).getroot()
    assert (root.get("tests"), root.get("failures"), root.get("errors")) == ("3", "1", "0")
    (failure,) = root.iter("failure")
    assert "is under the bound" in (failure.get("message") or "")
    # an existing file of someone else's is never replaced by --junit, not even with
    # --force, nor a device or a pipe; a bad --junit is refused before anything is written
    mine = tmp_path / "mine.xml"
    mine.write_text("<mine/>")
    os.mkfifo(tmp_path / "pipe.xml")
    (tmp_path / "a_file").write_text("mine")
    for target, words in (
        (mine, "not a JUnit file hybridlog wrote"),
        (tmp_path / "pipe.xml", "not a JUnit file hybridlog wrote"),
        (tmp_path / "a_file" / "j.xml", "a_file is not a folder"),
        (tmp_path / "new", "--out and --junit both name"),
        (tmp_path / ("j" * 250 + ".xml"), "is too long"),
    ):
        for force in (False, True):
            with pytest.raises(OutputError, match=words):
                run_batch(
                    logs, TANK, out_dir=tmp_path / "new", estimator="imm", junit=target, force=force
                )
            assert not (tmp_path / "new").exists()
    assert mine.read_text() == "<mine/>" and (tmp_path / "pipe.xml").is_fifo()
    # one of hybridlog's is replaced, with or without --force
    run_batch(logs, TANK, out_dir=tmp_path / "out", estimator="imm", junit=junit)


def test_resume_redoes_exactly_what_changed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    model = tmp_path / "tank.toml"
    model.write_text(builtin_text(TANK))
    logs = write_logs(tmp_path / "logs", [f"s{k}.csv" for k in range(1, 6)])
    out = tmp_path / "out"

    def again(**options: object) -> dict[str, str]:
        return statuses(run_batch(logs, model, out_dir=out, estimator="imm", **options))

    assert set(again().values()) == {"done"}
    before = stamps(out)
    time.sleep(0.01)
    assert set(again().values()) == {"skipped"}
    assert stamps(out) == before
    # the same bytes written again (a new modification time) are the same content
    logs[0].write_bytes(logs[0].read_bytes())
    assert set(again().values()) == {"skipped"}
    # one log's content changed (same path): exactly that log is redone
    write_table(logs[2], tank_run(steps=40, seed=99).columns, force=True)
    assert again() == {f"s{k}.csv": "done" if k == 3 else "skipped" for k in range(1, 6)}
    after = stamps(out)
    assert {k for k in after if after[k] != before[k]} == {"s3.csv"}
    # an estimator option, the model file, hybridlog's version: all redone
    assert set(again(sets=["transition_stay=0.9"]).values()) == {"done"}
    assert set(again(sets=["transition_stay=0.9"]).values()) == {"skipped"}
    model.write_text(builtin_text(TANK) + "\n# a comment\n")
    assert set(again().values()) == {"done"}
    monkeypatch.setattr(batch_job, "__version__", "99.0")
    assert set(again().values()) == {"done"}
    assert set(again().values()) == {"skipped"}
    # a report that records no provenance (written by analyze, or an old batch) is redone
    report = out / "s1.csv" / "report.json"
    report.write_text(report.read_text().replace('"batch"', '"other"'))
    record_folder_files(report.parent)  # as hybridlog wrote it (an edit would be the user's)
    assert again()["s1.csv"] == "done"
    # --force redoes everything
    assert set(again(force=True).values()) == {"done"}


def test_an_estimator_edited_without_a_new_version_or_a_library_upgraded_is_redone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a development install (or a patched build) fixed in imm.py, the version unchanged: the
    # nightly batch resumed and showed the old numbers as current
    logs = write_logs(tmp_path / "logs", ["a.csv"])
    out = tmp_path / "out"

    def again() -> set[str]:
        return set(statuses(run_batch(logs, TANK, out_dir=out, estimator="imm")).values())

    assert again() == {"done"}
    source = tmp_path / "hybridlog"
    shutil.copytree(jit.PACKAGE, source, ignore=shutil.ignore_patterns("__pycache__"))
    imm = source / "estimators" / "imm.py"
    imm.write_text(imm.read_text() + "\n# a fix\n")
    with monkeypatch.context() as edited:  # the edited code's hash; the machine code kept
        edited.setattr(jit, "PACKAGE", source)
        jit.package_fingerprint.cache_clear()
        fingerprint = jit.package_fingerprint()
    jit.package_fingerprint.cache_clear()
    monkeypatch.setattr(batch_job, "package_fingerprint", lambda: fingerprint)
    assert again() == {"done"}
    assert again() == {"skipped"}
    # a library upgraded (the filters' machine code, the solvers): redone too
    upgraded = {**library_versions(), "numba": "99.0"}
    monkeypatch.setattr(batch_job, "library_versions", lambda: upgraded)
    assert again() == {"done"}
    assert again() == {"skipped"}


def test_folders_come_from_paths_whatever_the_order(tmp_path: Path) -> None:
    logs = [
        *write_logs(tmp_path / "d1", ["run.csv"]),
        *write_logs(tmp_path / "d2", ["run.csv", "run.parquet"], first_seed=5),
    ]
    first = run_batch(logs, TANK, out_dir=tmp_path / "out", estimator="imm")
    summaries = {n: (tmp_path / "out" / n).read_bytes() for n in ("summary.md", "summary.csv")}
    folders = {o.log: Path(o.folder).relative_to(tmp_path / "out").as_posix() for o in first.logs}
    assert sorted(folders.values()) == ["d1/run.csv", "d2/run.csv", "d2/run.parquet"]
    shuffled = [logs[2], logs[0], logs[1]]
    second = run_batch(shuffled, TANK, out_dir=tmp_path / "out", estimator="imm")
    assert {o.status for o in second.logs} == {"skipped"}
    assert {o.log: o.report.log for o in second.logs if o.report} == {
        str(log): str(log) for log in logs
    }
    third = run_batch(shuffled, TANK, out_dir=tmp_path / "other", estimator="imm")
    assert {
        o.log: Path(o.folder).relative_to(tmp_path / "other").as_posix() for o in third.logs
    } == (folders)
    # summaries do not depend on the order of the arguments
    for name, text in summaries.items():
        assert (tmp_path / "other" / name).read_bytes() == text


def test_a_batch_killed_half_way_is_completed_without_rewriting_finished_logs(
    tmp_path: Path,
) -> None:
    logs = write_logs(tmp_path / "logs", [f"s{k}.csv" for k in range(1, 41)])
    out = tmp_path / "out"
    command = [sys.executable, "-m", "hybridlog", "batch", *map(str, logs), "--model", TANK]
    process = subprocess.Popen(
        [*command, "--estimator", "imm", "--out", str(out), "-q"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 240
        while process.poll() is None and time.monotonic() < deadline:
            if out.is_dir() and len(stamps(out)) >= 10:
                break
            time.sleep(0.02)
        assert process.poll() is None, "the batch finished before it could be killed"
        os.kill(process.pid, signal.SIGKILL)
        process.wait()
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    finished = stamps(out)
    assert 10 <= len(finished) < 40
    outcome = run_batch(logs, TANK, out_dir=out, estimator="imm")
    assert statuses(outcome) == {
        f"s{k}.csv": "skipped" if f"s{k}.csv" in finished else "done" for k in range(1, 41)
    }
    after = stamps(out)
    assert len(after) == 40
    assert {k: after[k] for k in finished} == finished
    hidden = {".hybridlog", ".summary.md.hybridlog", ".summary.csv.hybridlog"}
    hidden.add(".summary.png.hybridlog")  # the marker and the summaries' records
    assert not [p for p in out.iterdir() if p.name.startswith(".") and p.name not in hidden]


def test_junit_replaces_its_own_file_but_not_a_foreign_one(tmp_path: Path) -> None:
    logs = write_logs(tmp_path / "logs", ["a.csv"])
    junit = tmp_path / "junit.xml"
    run_batch(logs, TANK, out_dir=tmp_path / "out", estimator="imm", junit=junit)
    first = junit.read_bytes()
    run_batch(logs, TANK, out_dir=tmp_path / "out", estimator="imm", junit=junit)  # its own
    assert junit.read_bytes().startswith(first[:60])
    foreign = tmp_path / "results.xml"
    foreign.write_text("<mine/>", encoding="utf-8")
    with pytest.raises(OutputError, match=r"^--junit .*results\.xml: exists and is not a JUnit"):
        run_batch(logs, TANK, out_dir=tmp_path / "out2", estimator="imm", junit=foreign)
    assert foreign.read_text(encoding="utf-8") == "<mine/>"
    assert not (tmp_path / "out2").exists()
    before = logs[0].read_bytes()
    with pytest.raises(OutputError, match=r"^--junit .* is the log"):  # not even with force
        run_batch(logs, TANK, out_dir=tmp_path / "out3", estimator="imm", junit=logs[0], force=True)
    assert logs[0].read_bytes() == before


def test_the_same_maps_in_another_order_or_spacing_resume(tmp_path: Path) -> None:
    # a symbol maps once and the maps are read as one dict: the nightly job that listed its
    # --map options in another order (or wrote `y1 = A1`) redid every log of the batch
    folder = tmp_path / "logs"
    folder.mkdir()
    renamed = {"y1": "A1", "y2": "A2"}
    logs = [
        write_table(
            folder / f"s{k}.csv",
            {renamed.get(n, n): c for n, c in tank_run(steps=30, seed=k).columns.items()},
        )
        for k in (1, 2)
    ]
    out = tmp_path / "out"

    def again(*maps: str) -> set[str]:
        outcome = run_batch(logs, TANK, out_dir=out, estimator="imm", read=ReadOptions(maps=maps))
        return set(statuses(outcome).values())

    assert again("y1=A1", "y2=A2") == {"done"}
    assert again("y2=A2", "y1=A1") == {"skipped"}
    assert again(" y2 =A2", "y1\t=A1") == {"skipped"}
    # another column is another reading: redone
    assert again("y1=A1", "y2=A2", "y3=y3") == {"done"}
