"""Batch reprocessing: every log gets its outcome, whatever happens to the others.

A log that fails (bad input, a reader raising an unexpected exception, a worker process that
is killed) is listed with its one-line error while the others finish; workers die with the
batch process; logs are summarised in natural order.
"""

from __future__ import annotations

import io
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import click
import polars as pl
import pytest
from click.testing import CliRunner

from hybridlog.cli import main
from hybridlog.errors import OptionError, OutputError, excerpt
from hybridlog.io.formats import logs_in
from hybridlog.io.tables import TableSource
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.batch_logs import batch_logs, natural_key
from hybridlog.jobs.batch_names import folder_names
from hybridlog.jobs.batch_outcomes import LogOutcome
from hybridlog.outputs import MARKER, write_marker
from tests.support.logfiles import tank_run
from tests.support.paths import SAMPLE_LOGS
from tests.support.processes import descendants, is_worker, kill_and_expect_the_family_gone

TANK = "three_tank_hstf"

RECORDS = [f".summary.{kind}{MARKER}" for kind in ("csv", "md", "png")]
"""The records a batch keeps of the summaries it wrote (a user's edits are not overwritten)."""

SUMMARIES = ["summary.csv", "summary.md", "summary.png"]


class _Main:
    """Click-runner adapter for ``main`` so the error → exit-code mapping is exercised."""

    name = "hybridlog"

    def main(self, args, prog_name=None, standalone_mode=True, **extra):
        try:
            main(list(args))
        except SystemExit as exit_:
            raise SystemExit(exit_.code) from None
        raise SystemExit(0)


def run(args, expect=0):
    result = CliRunner().invoke(_Main(), args, catch_exceptions=False)
    assert result.exit_code == expect, result.output + result.stderr
    return result


def write_logs(folder: Path, names: list[str], steps: int = 90) -> list[Path]:
    return [
        write_table(folder / f"{name}.csv", tank_run(steps=steps, seed=k).columns)
        for k, name in enumerate(names, 1)
    ]


def test_natural_order_and_folder_names() -> None:
    names = ["s10", "s2", "s1", "run_b10", "run_b9", "S3", "s1a"]
    assert sorted(names, key=natural_key) == ["S3", "run_b9", "run_b10", "s1", "s1a", "s2", "s10"]
    # Folder names: the path from the logs' common folder, suffix kept (issue 9; they were
    # "_hidden", "a_x", "b_x", "_csv"), never hidden, never a batch file's name.
    logs = [Path("a/.hidden.csv"), Path("a/x.csv"), Path("b/x.csv"), Path("c/.csv")]
    assert folder_names(logs) == ["a/_.hidden.csv", "a/x.csv", "b/x.csv", "c/_.csv"]
    logs = [Path("d/summary.md"), Path("d/_summary.md"), Path("d/__x"), Path("d/.hybridlog")]
    assert folder_names(logs) == ["_summary.md", "__summary.md", "__x", "_.hybridlog"]
    logs = [Path("d2/run.csv"), Path("d2/run.parquet")]
    assert folder_names(logs) == ["run.csv", "run.parquet"]
    assert folder_names(logs[::-1]) == ["run.parquet", "run.csv"]
    with pytest.raises(OptionError, match="given twice"):
        folder_names([Path("a/x.csv"), Path("a/../a/x.csv")])
    with pytest.raises(OptionError, match="lies inside the log"):
        folder_names([Path("a/bag"), Path("a/bag/x.csv")])


def test_a_folder_of_logs_is_searched_for_its_logs(tmp_path: Path) -> None:
    """``batch FOLDER``: the logs in it and its subfolders (it was read as one ROS 2 bag and
    failed as "a directory without metadata.yaml"); a bag with its metadata.yaml stays one log."""
    runs = tmp_path / "runs"
    for name in ("s10.csv", "s2.CSV", "deep/s1.parquet", "x.mcap", "raw/a.db3"):
        (runs / name).parent.mkdir(parents=True, exist_ok=True)
        (runs / name).write_bytes(b"")
    for name in ("notes.txt", ".hidden.csv", ".git/old.csv", "plot.png"):
        (runs / name).parent.mkdir(parents=True, exist_ok=True)
        (runs / name).write_bytes(b"")
    bag = runs / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    (bag / "bag_0.db3").write_bytes(b"")
    (runs / "loop").symlink_to(runs, target_is_directory=True)  # not followed
    (runs / "report").mkdir()
    write_marker(runs / "report")  # an earlier batch's output: its tables are not logs
    (runs / "report" / "s1.csv").mkdir()
    (runs / "report" / "s1.csv" / "timeline.csv").write_text("t\n")
    found = [p.relative_to(runs).as_posix() for p in logs_in(runs)]
    assert sorted(found) == ["bag", "deep/s1.parquet", "raw/a.db3", "s10.csv", "s2.CSV", "x.mcap"]
    other = tmp_path / "other.csv"
    logs, folders, _ = batch_logs([runs, other, bag])
    assert folders == [str(runs)]
    assert logs == sorted([*(str(runs / f) for f in found), str(other), str(bag)], key=natural_key)
    with pytest.raises(OptionError, match="given twice"):
        folder_names(logs)  # the bag, given as itself and found in its folder
    assert batch_logs([bag]) == ([str(bag)], [], ())
    (tmp_path / "empty" / ".cache").mkdir(parents=True)
    (tmp_path / "empty" / "readme.txt").write_text("")
    with pytest.raises(OptionError, match=r"folder .*empty.* holds no log"):
        batch_logs([tmp_path / "empty"])
    with pytest.raises(OptionError, match=r"^LOGS: '.*report' is a folder hybridlog wrote"):
        batch_logs([runs / "report"])
    # `batch runs/* --out runs/report` again: its own batch folder is among runs/*, left out
    again = batch_logs([runs / "s10.csv", runs / "report"])
    assert again.paths == [str(runs / "s10.csv")]
    assert again.notes == (
        f"LOGS: left out {excerpt(str(runs / 'report'))}: a folder hybridlog wrote (reports or "
        "a batch), not logs",
    )


def test_batch_of_a_folder_names_folders_from_it_and_keeps_out_of_it(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    write_logs(runs, ["b10", "b9"])
    write_logs(runs / "sub", ["b9"])
    out = tmp_path / "out"
    outcome = run_batch([runs], "three_tank_hstf", out_dir=out, estimator="imm")
    assert [o.status for o in outcome.logs] == ["done"] * 3
    assert [Path(o.folder).relative_to(out).as_posix() for o in outcome.logs] == [
        "b9.csv",
        "b10.csv",
        "sub/b9.csv",
    ]
    again = run_batch([runs], "three_tank_hstf", out_dir=out, estimator="imm")
    assert [o.status for o in again.logs] == ["skipped"] * 3
    # named from the folder given, not from the deepest folder holding today's logs
    assert folder_names(*batch_logs([runs / "sub"])[:2]) == ["b9.csv"]
    (runs / "b9.csv").rename(runs / "sub" / "b8.csv")
    (runs / "b10.csv").rename(runs / "sub" / "b10.csv")
    assert folder_names(*batch_logs([runs])[:2]) == ["sub/b8.csv", "sub/b9.csv", "sub/b10.csv"]
    # an output inside the folder would be searched as logs by the next run
    with pytest.raises(OutputError, match="inside the folder of logs"):
        run_batch([runs], "three_tank_hstf", out_dir=runs / "out", estimator="imm")
    assert not (runs / "out").exists()
    # the command counts the logs found, not its arguments (it said "1 of 1 logs failed")
    (runs / "broken.csv").write_text("t,u,y1\n0,1,2\n")
    args = ["batch", str(runs), "--model", "three_tank_hstf", "--out", str(tmp_path / "o2")]
    assert "hybridlog: 1 of 4 logs failed" in run(args, expect=1).stderr


def test_logs_named_with_bytes_and_controls_get_reports_and_summaries(tmp_path: Path) -> None:
    """A log whose name is not UTF-8 crashed the whole batch after its last log (summary.md
    could not be encoded: no summary, exit 2) and its own report (polars took no such
    path); a name with control characters made junit.xml unreadable XML."""
    runs = tmp_path / "runs"
    runs.mkdir()
    odd = Path(os.fsdecode(bytes(runs) + b"/m\xff.mcap"))
    shutil.copyfile(SAMPLE_LOGS / "three_tank_hstf.mcap", odd)
    write_logs(runs, ["ctl\x01\x1b"])
    out, junit = tmp_path / "out", tmp_path / "junit.xml"
    outcome = run_batch([runs], TANK, out_dir=out, estimator="imm", junit=junit)
    assert [o.status for o in outcome.logs] == ["done", "done"]
    summary = (out / "summary.csv").read_text(encoding="utf-8")
    assert "m\\xff.mcap,done," in summary
    assert "\x1b" not in (out / "summary.md").read_text(encoding="utf-8")
    assert "ctl\\x01\\x1b.csv" in outcome.table
    shown = ET.parse(junit).getroot().iter("testcase")  # raised ParseError
    assert [case.get("classname") for case in shown] == [
        f"{runs}/ctl\\x01\\x1b.csv",
        f"{runs}/m\\xff.mcap",
    ]
    report = json.loads((Path(outcome.logs[1].folder) / "report.json").read_text("utf-8"))
    assert report["log"] == f"{runs}/m\\xff.mcap"


def test_the_failed_logs_line_names_the_summary_as_stdout_does(
    tmp_path: Path, hybridlog_main: Callable[[list[str]], tuple[int, str]]
) -> None:
    """The stderr line of failed logs named the summary unescaped: ``o\\udcff/summary.md``
    for a folder named with the byte 0xff, ``o??/summary.md`` for ``oé`` where Python reads
    names as ASCII (``LC_ALL=C``); it is now named as the ``summary:`` line names it."""
    (tmp_path / "broken.csv").write_text("t,u,y1\n0,1,2\n")
    out = os.fsdecode(bytes(tmp_path) + b"/o\xff")
    code, err = hybridlog_main(
        ["batch", str(tmp_path / "broken.csv"), "--model", "three_tank_hstf", "--out", out]
    )
    assert code == 1
    assert (
        err.splitlines()[-1] == f"hybridlog: 1 of 1 logs failed (see {tmp_path}/o\\xff/summary.md)"
    )


def test_batch_keeps_going_skips_finished_and_reports(tmp_path):
    logs = []
    for seed in (1, 2):
        path = tmp_path / f"run{seed}.csv"
        run(["simulate", "three_tank_hstf", "--out", str(path), "--seed", str(seed)])
        logs.append(str(path))
    broken = tmp_path / "broken.csv"
    broken.write_text("t,u,y1\n0,1,2\n")
    out = tmp_path / "batch"
    args = [
        "batch",
        *logs,
        str(broken),
        "--model",
        "three_tank_hstf",
        "--estimator",
        "imm",
        "--out",
        str(out),
    ]
    # A log that cannot be analysed fails the batch like a missed gate: exit 1 (issue 9; it
    # was 2, which SPEC §4 keeps for bad usage or shared input checked before any log).
    result = run(args, expect=1)
    assert "1 of 3 logs failed" in result.stderr
    summary = pl.read_csv(out / "summary.csv")
    # Logs are summarised in natural order: broken.csv before run1.csv.
    assert summary["log"].to_list() == [str(broken), *logs]
    assert summary["status"].to_list() == ["failed", "done", "done"]
    assert "y2" in summary["error"][0]
    # a failed log has no report folder: empty, as summary.md's link is n/a
    assert summary["folder"].to_list() == [None, "run1.csv", "run2.csv"]
    stamp = (out / "run1.csv" / "report.json").stat().st_mtime_ns
    result = run(args, expect=1)
    assert pl.read_csv(out / "summary.csv")["status"].to_list() == ["failed", "skipped", "skipped"]
    assert (out / "run1.csv" / "report.json").stat().st_mtime_ns == stamp
    run(
        [
            "batch",
            *logs,
            "--model",
            "three_tank_hstf",
            "--estimator",
            "imm",
            "--out",
            str(out),
            "--force",
            "--jobs",
            "2",
        ]
    )
    assert pl.read_csv(out / "summary.csv")["status"].to_list() == ["done", "done"]
    assert (out / "run1.csv" / "report.json").stat().st_mtime_ns != stamp


def test_batch_does_not_mix_reports_of_another_estimator(tmp_path):
    log = tmp_path / "run.csv"
    run(["simulate", "three_tank_hstf", "--out", str(log), "--seed", "4"])
    out = tmp_path / "batch"
    run(["batch", str(log), "--model", "three_tank_hstf", "--estimator", "imm", "--out", str(out)])
    before = (out / "run.csv" / "report.json").read_bytes()
    summary = (out / "summary.csv").read_bytes()
    result = run(
        ["batch", str(log), "--model", "three_tank_hstf", "--estimator", "hstf", "--out", str(out)],
        expect=2,
    )
    assert "holds reports of 'imm'" in result.stderr  # refused before any log is analysed
    assert (out / "summary.csv").read_bytes() == summary
    assert (out / "run.csv" / "report.json").read_bytes() == before


def test_a_reader_crash_fails_only_its_log(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    logs = write_logs(tmp_path, ["s10", "s2", "crash", "s1"])
    read = TableSource.read

    def crashing(self: TableSource, *args: object, **kwargs: object) -> object:
        if Path(self.path).name == "crash.csv":
            raise KeyError("reader bug\nsecond line")
        return read(self, *args, **kwargs)

    monkeypatch.setattr(TableSource, "read", crashing)
    out = tmp_path / "out"
    out.mkdir()
    write_marker(out)  # an earlier batch's folder, holding a folder of someone else's
    (out / "s2.csv").mkdir()
    (out / "s2.csv" / "mine.txt").write_text("not hybridlog's")
    outcome = run_batch(logs, TANK, out_dir=out, estimator="imm", force=True)
    assert [Path(o.log).name for o in outcome.logs] == ["crash.csv", "s1.csv", "s2.csv", "s10.csv"]
    assert [o.status for o in outcome.logs] == ["failed", "done", "failed", "done"]
    assert outcome.logs[0].error == "KeyError: 'reader bug\\nsecond line'"
    assert "holds files hybridlog did not write" in (outcome.logs[2].error or "")
    assert (out / "s2.csv" / "mine.txt").read_text() == "not hybridlog's"
    summary = pl.read_csv(out / "summary.csv")
    assert [Path(p).name for p in summary["log"]] == ["crash.csv", "s1.csv", "s2.csv", "s10.csv"]
    text = (out / "summary.md").read_text()
    assert "## Failed logs (2 of 4)" in text and "KeyError: 'reader bug" in text
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [MARKER, *RECORDS, "s1.csv", "s10.csv", "s2.csv", *SUMMARIES]
    )


def test_a_killed_worker_fails_only_its_log(tmp_path: Path) -> None:
    # Six logs, so that the workers still run when the killer, a thread of this busy
    # process, first scans /proc (with three short ones a loaded machine once finished the
    # batch before it looked, and it then looked on for two minutes)
    logs = write_logs(tmp_path, [f"a{k}" for k in range(1, 7)])
    killed: list[int] = []
    finished = threading.Event()

    def kill_the_first_worker() -> None:
        while not killed and not finished.is_set():
            for pid in descendants(os.getpid()):
                if is_worker(pid):
                    os.kill(pid, signal.SIGKILL)
                    killed.append(pid)
                    return
            time.sleep(0.01)

    killer = threading.Thread(target=kill_the_first_worker)
    killer.start()
    try:
        outcome = run_batch(logs, TANK, out_dir=tmp_path / "out", estimator="imm", jobs=2)
    finally:
        finished.set()
        killer.join()
    assert len(killed) == 1
    statuses = [o.status for o in outcome.logs]
    assert sorted(statuses) == ["done"] * 5 + ["failed"]
    failed = outcome.logs[statuses.index("failed")]
    assert failed.error == "worker process died (killed by signal SIGKILL)"
    assert not (Path(failed.folder)).exists()
    assert "worker process died" in (tmp_path / "out" / "summary.md").read_text()


def test_workers_die_with_a_killed_batch_and_the_next_run_cleans_up(tmp_path: Path) -> None:
    # Enough logs that the batch still runs for seconds after both workers have written a
    # report, however slow the machine: copies of one log (each still gets its own folder).
    (first,) = write_logs(tmp_path, ["s1"])
    logs = [first]
    for k in range(2, 151):
        logs.append(tmp_path / f"s{k}.csv")
        shutil.copyfile(first, logs[-1])
    out = tmp_path / "out"
    command = [sys.executable, "-m", "hybridlog", "batch", *map(str, logs), "--model", TANK]
    batch = subprocess.Popen(
        [*command, "--estimator", "imm", "--out", str(out), "--jobs", "2"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        # Wait until both workers have written a report, so both are busy with the next log.
        writers: set[int] = set()
        deadline = time.monotonic() + 240
        while len(writers) < 2 and batch.poll() is None and time.monotonic() < deadline:
            for marker in out.glob(f"s*/{MARKER}"):
                writers.add(json.loads(marker.read_text())["pid"])
            time.sleep(0.05)
        assert len(writers) == 2, "the batch never ran two workers"
        family = descendants(batch.pid)
        assert batch.poll() is None, "the batch ended before it could be killed"
        assert writers <= set(family)
        kill_and_expect_the_family_gone(batch, family)
    finally:
        if batch.poll() is None:
            batch.kill()
            batch.wait()
    finished = {p.name for p in out.iterdir() if not p.name.startswith(".")}
    outcome = run_batch(logs, TANK, out_dir=out, estimator="imm")
    for log in outcome.logs:
        assert log.status == ("skipped" if Path(log.folder).name in finished else "done")
    # Temporaries the killed workers left are gone; only the batch folder's marker and the
    # records of its summaries are hidden.
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == [MARKER, *RECORDS]


PARENT_RUNNER = """
import json, sys
from hybridlog.jobs.batch import run_batch

outcome = run_batch(sys.argv[1:3], "three_tank_hstf", out_dir=sys.argv[3], estimator="imm", jobs=2)
assert [log.status for log in outcome.logs] == ["done", "done"]
print(json.dumps(sorted({name.split(".")[0] for name in sys.modules})))
"""


def test_with_workers_the_batch_process_loads_no_compiler(tmp_path: Path) -> None:
    # numba's set-up is the workers' (done once, in their forkserver): the batch process
    # only plans, waits and summarises, so its start-up stays short
    logs = write_logs(tmp_path, ["a1", "a2"])
    done = subprocess.run(
        [sys.executable, "-c", PARENT_RUNNER, *map(str, logs), str(tmp_path / "out")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    loaded = set(json.loads(done.stdout.splitlines()[-1]))
    assert not loaded & {"numba", "llvmlite", "scipy"}, loaded


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.mark.parametrize("quiet", [False, True])
def test_progress_bar_counts_done_failed_skipped_with_rate(
    monkeypatch: pytest.MonkeyPatch, quiet: bool
) -> None:
    from hybridlog import cli, cli_options, cli_progress

    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    context = click.Context(cli.cli, obj=cli_options._Context(quiet=quiet))
    statuses = ["done", "failed", "skipped", "done"]
    with cli_progress.batch_progress(context, len(statuses), cli_progress.BatchClock()) as advance:
        if quiet:
            assert advance is None
            return
        assert advance is not None
        for status in statuses:
            advance(LogOutcome("log", "folder", status, None, None))
    text = terminal.getvalue()
    assert "4/4" in text and "done 2 · failed 1 · skipped 1 · " in text and "logs/min" in text


def test_progress_rate_and_time_left_leave_out_the_first_compile(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """30 s compiling, then a log in 2 s: 3 logs left take about 6 s, not 96 (click's ETA)."""
    from hybridlog import cli, cli_options, cli_progress

    now = [100.0]
    monkeypatch.setattr(cli_progress.time, "monotonic", lambda: now[0])
    terminal = _Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    context = click.Context(cli.cli, obj=cli_options._Context(quiet=False))
    clock = cli_progress.BatchClock(started=now[0])
    with cli_progress.batch_progress(context, 4, clock) as advance:
        assert advance is not None
        with cli_progress._clocked_wait(clock, False, "imm: compiling", "first run"):
            now[0] += 30.0
        now[0] += 2.0
        advance(LogOutcome("log", "folder", "done", None, None))
        text = terminal.getvalue()
        assert "1/4" in text and "30 logs/min · 6 s left" in text, text
        advance(LogOutcome("log", "folder", "skipped", None, None))
        advance(LogOutcome("log", "folder", "done", None, None))
        advance(LogOutcome("log", "folder", "done", None, None))
    assert "left" not in terminal.getvalue().rsplit("4/4", 1)[1]


def test_progress_counts_a_compile_as_waiting_only_until_a_log_finishes_during_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Two workers: one compiles 10 s and runs a log in 2 s while the other compiles on."""
    from hybridlog import cli_progress

    now = [0.0]
    monkeypatch.setattr(cli_progress.time, "monotonic", lambda: now[0])
    clock = cli_progress.BatchClock(started=0.0)
    with cli_progress._clocked_wait(clock, False, "imm: compiling", "first run"):
        now[0] = 5.0
        assert clock.working() == 0.0  # a wait going on is not work
        now[0] = 12.0
        clock.work()  # the first worker's log finished
        now[0] = 20.0
        assert clock.working() == 8.0
    now[0] = 21.0
    assert clock.working() == 9.0
