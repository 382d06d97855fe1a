"""Nothing lost (SPEC §9): no output is, contains or sits inside an input; --force replaces
only what hybridlog wrote; every output is checked before anything is written.

Every refused case runs against one workspace of real inputs (a CSV log, a ROS 2 bag folder
written by rosbags, a model file, a centres file, a message-definition folder) and checks
that not one byte of it changed and that nothing was left behind.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import resource
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from hybridlog import __version__
from hybridlog.cli import main
from hybridlog.errors import OptionError, OutputError
from hybridlog.io import ReadOptions
from hybridlog.io.bag_writers import check_log_target, write_log, written_by_hybridlog
from hybridlog.io.writers import write_table
from hybridlog.jobs import cluster as cluster_job
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.batch import run_batch
from hybridlog.jobs.cluster import discover_modes
from hybridlog.jobs.compare import compare
from hybridlog.model.builtins import builtin_text
from hybridlog.outputs import (
    MARKER,
    atomic_files,
    atomic_output_dir,
    check_apart,
    check_dir_target,
    is_ours,
    record_path,
    remove_stale_temporaries,
    staging_dir,
    temporary_name,
    write_marker,
    wrote_file,
)
from hybridlog.report.junit import check_junit_target
from tests.support.logfiles import scene, tank_run, write_msg_dir, write_ros2_bag
from tests.support.paths import SAMPLE_LOGS

TANK = "three_tank_hstf"


def tree(root: Path) -> dict[str, str]:
    """Every entry under ``root`` (hidden ones too): kind and content hash or link target."""
    found: dict[str, str] = {}
    for path in sorted(root.rglob("*")):
        name = str(path.relative_to(root))
        if path.is_symlink():
            found[name] = "link:" + os.readlink(path)
        elif path.is_dir():
            found[name] = "dir"
        else:
            found[name] = hashlib.sha256(path.read_bytes()).hexdigest()
    return found


@pytest.fixture(scope="module")
def ws(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Inputs of every kind, and links to them."""
    root = tmp_path_factory.mktemp("ws")
    write_table(root / "p" / "log.csv", tank_run().columns)
    write_ros2_bag(root / "bag", scene(tank_run()), "sqlite3")
    (root / "m").mkdir()
    (root / "m" / "tank.toml").write_text(builtin_text(TANK))
    (root / "c").mkdir()
    (root / "c" / "centers.json").write_text('{"format": "hybridlog-centers"}\n')
    write_msg_dir(root / "msgs", "pkg", "Reading", "float64 value\n")
    (root / "plink").symlink_to(root / "p", target_is_directory=True)
    (root / "log_link.json").symlink_to(root / "p" / "log.csv")
    (root / "model_link.json").symlink_to(root / "m" / "tank.toml")
    os.link(root / "p" / "log.csv", root / "hard.json")
    (root / "pic.png").symlink_to(root / "c.json")  # dangling: c.json is an output
    (root / "broot").mkdir()  # an earlier batch folder whose summary is a hard link of a log
    write_marker(root / "broot")
    os.link(root / "p" / "log.csv", root / "broot" / "summary.csv")
    (root / "theirs").mkdir()
    (root / "theirs" / "thesis.tex").write_text("years of work\n")
    (root / "theirs_dir.json").mkdir()
    (root / "theirs_dir.mcap").mkdir()
    for name in ("theirs.csv", "theirs.parquet", "theirs.mcap", "theirs.bag", "theirs.json"):
        (root / name).write_text("a file of the user's\n")
    (root / "theirs.png").write_bytes(b"\x89PNG of the user's")
    return root


# (what is tried, expected words of the one-line error); every case is refused with and
# without --force where the flag exists.
REFUSED: list[tuple[str, Callable[[Path, bool], object], str]] = [
    # analyze: output folder vs the log
    (
        "analyze --out holds the log",
        lambda ws, f: analyze(ws / "p/log.csv", TANK, out_dir=ws / "p", force=f),
        "contains the log",
    ),
    (
        "analyze --out is the ROS 2 bag folder",
        lambda ws, f: analyze(ws / "bag", TANK, out_dir=ws / "bag", force=f),
        "is the log",
    ),
    (
        "analyze --out inside the ROS 2 bag folder",
        lambda ws, f: analyze(ws / "bag", TANK, out_dir=ws / "bag" / "report", force=f),
        "is inside the log",
    ),
    (
        "analyze --out through '..'",
        lambda ws, f: analyze(ws / "p/log.csv", TANK, out_dir=ws / "p/sub/..", force=f),
        "contains the log",
    ),
    (
        "analyze --out through a symbolic link",
        lambda ws, f: analyze(ws / "p/log.csv", TANK, out_dir=ws / "plink", force=f),
        "contains the log",
    ),
    (
        "analyze log through a symbolic link",
        lambda ws, f: analyze(ws / "plink/log.csv", TANK, out_dir=ws / "p", force=f),
        "contains the log",
    ),
    (
        "analyze the log itself as --out",
        lambda ws, f: analyze(ws / "p/log.csv", TANK, out_dir=ws / "p/log.csv", force=f),
        "is the log",
    ),
    # analyze: the other inputs
    (
        "analyze --out holds the model file",
        lambda ws, f: analyze(ws / "p/log.csv", ws / "m/tank.toml", out_dir=ws / "m", force=f),
        "contains the model file",
    ),
    (
        "analyze --out holds the centres file",
        lambda ws, f: analyze(
            ws / "p/log.csv",
            "double_cart_case1",  # chiu needs a linear model
            out_dir=ws / "c",
            estimator="chiu",
            sets=(f"centers={ws / 'c/centers.json'}",),
            force=f,
        ),
        "contains the centres file",
    ),
    (
        "analyze --out is the --msg-dir",
        lambda ws, f: analyze(
            ws / "bag",
            TANK,
            out_dir=ws / "msgs",
            read=ReadOptions(msg_dirs=(str(ws / "msgs"),)),
            force=f,
        ),
        "is the --msg-dir folder",
    ),
    (
        "analyze --out inside the --msg-dir",
        lambda ws, f: analyze(
            ws / "bag",
            TANK,
            out_dir=ws / "msgs/pkg",
            read=ReadOptions(msg_dirs=(str(ws / "msgs"),)),
            force=f,
        ),
        "is inside the --msg-dir folder",
    ),
    # compare and batch
    (
        "compare --out holds the log",
        lambda ws, f: compare(ws / "p/log.csv", TANK, ["hstf", "imm"], out_dir=ws / "p", force=f),
        "contains the log",
    ),
    (
        "batch --out holds one of the logs",
        lambda ws, f: run_batch([ws / "bag", ws / "p/log.csv"], TANK, out_dir=ws / "p", force=f),
        "contains the log",
    ),
    (
        "batch --out is a ROS 2 bag folder",
        lambda ws, f: run_batch([ws / "bag"], TANK, out_dir=ws / "bag", force=f),
        "is the log",
    ),
    (
        "batch --out holds the model file",
        lambda ws, f: run_batch([ws / "bag"], ws / "m/tank.toml", out_dir=ws / "m", force=f),
        "contains the model file",
    ),
    (
        "batch summary is a hard link of a log",
        lambda ws, f: run_batch([ws / "p/log.csv"], TANK, out_dir=ws / "broot", force=f),
        "summary.csv is the log",
    ),
    # cluster: --out and --plot
    (
        "cluster --out is a link to the log",
        lambda ws, f: discover_modes(
            ws / "p/log.csv", TANK, out=ws / "log_link.json", plot=ws / "x.png", force=f
        ),
        "is the log",
    ),
    (
        "cluster --out is a hard link of the log",
        lambda ws, f: discover_modes(
            ws / "p/log.csv", TANK, out=ws / "hard.json", plot=ws / "x.png", force=f
        ),
        "is the log",
    ),
    (
        "cluster --out is a link to the model file",
        lambda ws, f: discover_modes(
            ws / "p/log.csv", ws / "m/tank.toml", out=ws / "model_link.json", force=f
        ),
        "is the model file",
    ),
    (
        "cluster --plot inside the ROS 2 bag folder",
        lambda ws, f: discover_modes(
            ws / "bag", TANK, out=ws / "c.json", plot=ws / "bag/c.png", force=f
        ),
        "--plot",
    ),
    (
        "cluster --plot inside the --msg-dir",
        lambda ws, f: discover_modes(
            ws / "bag",
            TANK,
            out=ws / "c.json",
            plot=ws / "msgs/pkg/c.png",
            read=ReadOptions(msg_dirs=(str(ws / "msgs"),)),
            force=f,
        ),
        "is inside the --msg-dir folder",
    ),
    (
        "cluster --out and --plot are one file",
        lambda ws, f: discover_modes(
            ws / "p/log.csv", TANK, out=ws / "plink/../c.json", plot=ws / "pic.png", force=f
        ),
        "both name",
    ),
    # simulate: --out vs the model file
    (
        "simulate --out is the model file",
        lambda ws, f: check_log_target(
            ws / "m/tank.toml", format="mcap", force=f, inputs=[("model file", ws / "m/tank.toml")]
        ),
        "is the model file",
    ),
    (
        "simulate a ROS 2 bag folder over the model's folder",
        lambda ws, f: write_log(
            ws / "m",
            tank_run().columns,
            format="ros2-sqlite3",
            force=f,
            inputs=[("model file", ws / "m/tank.toml")],
        ),
        "contains the model file",
    ),
    # --force replaces only what hybridlog wrote
    (
        "analyze --out is someone's folder",
        lambda ws, f: analyze(ws / "p/log.csv", TANK, out_dir=ws / "theirs", force=f),
        "theirs",
    ),
    (
        "compare --out is someone's folder",
        lambda ws, f: compare(ws / "p/log.csv", TANK, ["imm"], out_dir=ws / "theirs", force=f),
        "theirs",
    ),
    (
        "batch --out is someone's folder",
        lambda ws, f: run_batch([ws / "p/log.csv"], TANK, out_dir=ws / "theirs", force=f),
        "did not write",
    ),
    (
        "simulate a ROS 2 bag over someone's folder",
        lambda ws, f: write_log(ws / "theirs", tank_run().columns, format="ros2-mcap", force=f),
        "theirs",
    ),
    *(
        (
            f"simulate over someone's {name}",
            lambda ws, f, name=name: write_log(ws / name, tank_run().columns, force=f),
            "did not write it",
        )
        for name in ("theirs.csv", "theirs.parquet", "theirs.mcap", "theirs.bag")
    ),
    (
        "cluster --out over someone's file",
        lambda ws, f: discover_modes(
            ws / "p/log.csv", TANK, out=ws / "theirs.json", plot=ws / "new.png", force=f
        ),
        "did not write it",
    ),
    (
        "cluster --plot over someone's file",
        lambda ws, f: discover_modes(
            ws / "p/log.csv", TANK, out=ws / "new.json", plot=ws / "theirs.png", force=f
        ),
        "did not write it",
    ),
    (
        "simulate a file over a folder",
        lambda ws, f: write_log(ws / "theirs_dir.mcap", tank_run().columns, force=f),
        "is a directory",
    ),
    (
        "cluster --out over a folder",
        lambda ws, f: discover_modes(ws / "p/log.csv", TANK, out=ws / "theirs_dir.json", force=f),
        "is a directory",
    ),
    (
        "analyze --out is a link to a folder",
        lambda ws, f: analyze(ws / "bag", TANK, out_dir=ws / "plink", force=f),
        "is a symbolic link",
    ),
]


@pytest.mark.parametrize("force", [False, True], ids=["", "force"])
@pytest.mark.parametrize(
    ("attempt", "words"), [c[1:] for c in REFUSED], ids=[c[0] for c in REFUSED]
)
def test_unsafe_outputs_are_refused_and_nothing_changes(
    ws: Path, attempt: Callable[[Path, bool], object], words: str, force: bool
) -> None:
    before = tree(ws)
    with pytest.raises(OutputError) as info:
        attempt(ws, force)
    message = str(info.value)
    assert "\n" not in message
    if words == "theirs" and not force:
        words = "not empty"
    # a file --force would not replace is said so without it too (it advised --force)
    assert words in message
    assert tree(ws) == before


def test_overlap_names_both_paths_relative_or_absolute(
    ws: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(ws)
    with pytest.raises(OutputError) as info:
        check_apart([("--out", str(ws / "p"))], [("log", "p/log.csv")])
    assert str(info.value) == (
        f"--out {ws / 'p'} contains the log p/log.csv; choose an output path outside every input"
    )
    with pytest.raises(OutputError, match=r"^--out ./bag/../bag/x is inside the log /.*/bag;"):
        check_apart([("--out", "./bag/../bag/x")], [("log", str(ws / "bag"))])
    check_apart([("--out", "p2")], [("log", "p/log.csv"), ("log", "bag")])  # apart: fine


def test_the_cli_refuses_with_one_line_and_exit_2(
    ws: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    before = tree(ws)
    log = str(ws / "p" / "log.csv")
    with pytest.raises(SystemExit) as exit_:
        main(["analyze", log, "--model", TANK, "--out", str(ws / "p"), "--force"])
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert f"--out {ws / 'p'} contains the log {log}" in err
    assert tree(ws) == before


# --- --force replaces what hybridlog wrote -----------------------------------------------------


def test_force_replaces_only_hybridlogs_own_folders(tmp_path: Path) -> None:
    log = write_table(tmp_path / "log.csv", tank_run().columns)
    out = tmp_path / "report"
    analyze(log, TANK, out_dir=out, estimator="imm")
    marker = json.loads((out / MARKER).read_text())
    assert marker["version"] == __version__ and marker["written_by"] == "hybridlog"
    assert marker["pid"] == os.getpid() and isinstance(marker["command"], list)
    with pytest.raises(OutputError, match="not empty; use --force"):
        analyze(log, TANK, out_dir=out, estimator="imm")
    # A file of the user's inside hybridlog's folder is never deleted (its MARKER lists
    # what hybridlog wrote there), at any depth; without it the folder is replaced.
    for mine in (out / "notes.txt", out / "plots" / "extra" / "mine.txt"):
        mine.parent.mkdir(exist_ok=True)
        mine.write_text("mine, but inside hybridlog's folder")
        before = tree(out)
        with pytest.raises(OutputError, match=f"did not write \\('{mine.relative_to(out)}'\\)"):
            analyze(log, TANK, out_dir=out, estimator="imm", force=True)
        assert tree(out) == before
        mine.unlink()
    # nor a folder of the user's, empty or a link to one
    (tmp_path / "theirs").mkdir()
    for folder, shown in ((out / "plots" / "extra", "plots/extra/"), (out / "link", "link/")):
        if shown == "link/":
            folder.symlink_to(tmp_path / "theirs", target_is_directory=True)
        with pytest.raises(OutputError, match=f"did not write \\('{shown}'\\)"):
            analyze(log, TANK, out_dir=out, estimator="imm", force=True)
        folder.unlink() if folder.is_symlink() else folder.rmdir()
    analyze(log, TANK, out_dir=out, estimator="imm", force=True)
    assert (out / MARKER).is_file() and "report.json" in json.loads((out / MARKER).read_text())[
        "files"
    ]
    # A marker without its list of files (edited, or an older version's) or none at all (a
    # report folder from before markers): hybridlog's, but what it wrote there is not known,
    # so --force replaces nothing.
    for marker in ("{", '{"written_by": "hybridlog"}', None):
        if marker is None:
            (out / MARKER).unlink()
        else:
            (out / MARKER).write_text(marker)
        assert is_ours(out)
        with pytest.raises(OutputError, match="does not list what hybridlog wrote there"):
            check_dir_target(out, force=True)
    (tmp_path / "theirs").rmdir()
    (out / "report.json").write_text('{"mine": 1}')
    assert not is_ours(out)
    with pytest.raises(OutputError, match="did not write"):
        check_dir_target(out, force=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == [".log.csv.hybridlog", "log.csv", "report"]


def test_simulate_replaces_its_own_bag_folder_only(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    columns = tank_run(steps=20).columns
    write_log(bag, columns, format="ros2-sqlite3")
    # The bag records its writer in metadata.yaml: no foreign file inside a ROS 2 bag.
    assert sorted(p.name for p in bag.iterdir()) == ["bag.db3", "metadata.yaml"]
    assert written_by_hybridlog(bag)
    with pytest.raises(OutputError, match="not empty"):
        write_log(bag, columns, format="ros2-sqlite3")
    write_log(bag, columns, format="ros2-mcap", force=True)
    assert sorted(p.name for p in bag.iterdir()) == ["bag.mcap", "metadata.yaml"]
    (bag / "notes.txt").write_text("mine")
    with pytest.raises(OutputError, match=r"did not write \('notes.txt'\)"):
        write_log(bag, columns, format="ros2-mcap", force=True)
    (bag / "notes.txt").unlink()
    recorded = write_ros2_bag(tmp_path / "recorded", scene(tank_run(steps=20)), "sqlite3")
    assert not written_by_hybridlog(recorded)
    with pytest.raises(OutputError, match="did not write"):
        write_log(recorded, columns, format="ros2-sqlite3", force=True)
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_force_replaces_only_files_hybridlog_wrote_unchanged(tmp_path: Path) -> None:
    columns, fewer = tank_run(steps=30).columns, tank_run(steps=10).columns
    log = tmp_path / "run.csv"
    write_log(log, columns)
    assert wrote_file(log) and record_path(log).name == ".run.csv.hybridlog"
    with pytest.raises(OutputError, match="already exists"):
        write_log(log, fewer)
    write_log(log, fewer, force=True)  # its own file, unchanged since: replaced
    assert wrote_file(log) and len(log.read_text().splitlines()) == 12

    def refused(why: str) -> None:
        before = tree(tmp_path)
        with pytest.raises(OutputError, match=r"did not write it \(or it changed since\)"):
            write_log(log, columns, force=True)
        assert tree(tmp_path) == before, why

    with log.open("a") as handle:  # edited in place (same file, longer)
        handle.write("# checked by hand\n")
    refused("edited")
    log.unlink()
    write_log(log, fewer)
    mine = tmp_path / "mine.csv"
    mine.write_text(log.read_text())
    os.replace(mine, log)  # the same bytes, but the user's file put in its place
    refused("put in its place")
    log.unlink()
    write_log(log, fewer)
    shutil.copy(log, tmp_path / "copy.csv")
    shutil.copy(record_path(log), record_path(tmp_path / "copy.csv"))
    assert not wrote_file(tmp_path / "copy.csv")  # a copy, record and all, is not ours
    record_path(log).unlink()
    refused("no record")
    # a file of the user's under the record's name is left alone; the output is then
    # simply not replaceable
    record_path(log).write_text("my notes\n")
    log.unlink()
    write_log(log, fewer)
    assert record_path(log).read_text() == "my notes\n" and not wrote_file(log)
    # centres and their picture are recorded too
    centres = tmp_path / "c.json"
    discover_modes(log, TANK, out=centres)
    assert wrote_file(centres) and wrote_file(centres.with_suffix(".png"))
    discover_modes(log, TANK, out=centres, force=True)


# --- every output checked before anything is written -------------------------------------------


@pytest.mark.parametrize(
    ("target", "options", "error", "words"),
    [
        ("run.txt", {}, OptionError, "cannot tell the log format"),
        ("run.parquet", {"format": "csv"}, OptionError, "must be named *.csv"),
        # a bag named otherwise is one reading refuses; another format's suffix misleads
        ("run.mcap", {"format": "bag"}, OptionError, "bag must be named *.bag, not *.mcap"),
        ("run", {"format": "bag"}, OptionError, "a ROS 1 bag must be named *.bag"),
        ("run.bag", {"format": "mcap"}, OptionError, "must be named *.mcap, not *.bag"),
        ("run.db3", {"format": "mcap"}, OptionError, "not *.db3 (the suffix of a ROS 2"),
        ("run.csv", {"encoding": "json"}, OptionError, "only an MCAP file (.mcap) has a choice"),
        # cdr, the MCAP files' default, named for a format without it was ignored
        ("run.csv", {"encoding": "cdr"}, OptionError, "--encoding cdr: only an MCAP file"),
        ("run.bag", {"encoding": "cdr"}, OptionError, "cdr: a ROS 1 bag's messages are ROS 1's"),
        # a ROS 2 bag in MCAP storage was told "only MCAP files have a choice of encoding"
        ("bag", {"format": "ros2-mcap", "encoding": "json"}, OptionError, "are CDR, whatever"),
        ("run.mcap", {"encoding": "yaml"}, OptionError, "--encoding"),
        ("exists.mcap", {}, OutputError, "exists and hybridlog did not write it"),
        ("exists.mcap", {"format": "ros2-mcap", "force": True}, OutputError, "not a directory"),
        # `--out folder` said "cannot tell the log format from suffix '(none)'"
        ("folder", {}, OptionError, "folder: is a folder; name the log in it (" + "{folder}"),
    ],
)
def test_simulate_outputs_are_checked_up_front(
    tmp_path: Path, target: str, options: dict[str, object], error: type, words: str
) -> None:
    (tmp_path / "exists.mcap").write_bytes(b"mine")
    (tmp_path / "folder").mkdir()
    with pytest.raises(error) as info:
        check_log_target(tmp_path / target, **options)  # type: ignore[arg-type]
    assert words.format(folder=tmp_path / "folder" / "log.csv") in str(info.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exists.mcap", "folder"]
    assert not any((tmp_path / "folder").iterdir())


@pytest.mark.parametrize(
    ("target", "options", "chosen"),
    [
        ("run.mcap", {}, "mcap"),
        ("run.mcap", {"encoding": "cdr"}, "mcap"),
        ("bag", {"format": "ros2-mcap", "encoding": "cdr"}, "ros2-mcap"),  # its messages' own
        ("bag", {"format": "ros2-sqlite3"}, "ros2-sqlite3"),
        ("run.bag", {}, "bag"),
        ("run.bag", {"encoding": "ros1"}, "bag"),  # a ROS 1 bag's own, as cdr is a ROS 2 bag's
    ],
)
def test_an_encoding_a_log_has_is_taken(
    tmp_path: Path, target: str, options: dict[str, object], chosen: str
) -> None:
    assert check_log_target(tmp_path / target, **options) == chosen  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("name", "format", "read_as"),
    [
        ("run.bag", "bag", "ros1-bag"),
        ("run.BAG", "bag", "ros1-bag"),
        ("run.mcap", "mcap", "mcap"),
        ("run", "mcap", "mcap"),
        ("run.log", "mcap", "mcap"),
        ("run.csv", "csv", "csv"),
        ("run.parquet", "parquet", "parquet"),
    ],
)
def test_every_log_name_simulate_takes_is_read_back_as_its_format(
    tmp_path: Path, name: str, format: str, read_as: str
) -> None:
    import numpy as np

    from hybridlog.io.formats import log_format

    log = tmp_path / name
    columns = {"t": np.arange(3.0), "u": np.ones(3)}
    write_log(log, columns, format=format)
    assert log_format(log).name == read_as


@pytest.mark.parametrize(
    ("name", "last", "words"),
    [
        ("run.bag", 2.0**32, "t = 4294967296 s is beyond the times a ROS 1 bag holds"),
        ("run.mcap", 1e10, "t = 10000000000 s is beyond the times an MCAP file holds"),
        ("run.csv", 1e10, "t = 10000000000 s is beyond the times a CSV file holds"),
        ("run.mcap", -1.0, "t = -1 s is beyond the times an MCAP file holds (from 0 to"),
    ],
)
def test_times_a_log_cannot_hold_are_refused_before_writing(
    tmp_path: Path, name: str, last: float, words: str
) -> None:
    # A ROS 1 bag's seconds are 32-bit, the others' nanoseconds 64-bit: the writers failed
    # with an internal error part way through, or wrote a CSV hybridlog refused to read.
    import numpy as np

    log = tmp_path / name
    with pytest.raises(OptionError) as error:
        write_log(log, {"t": np.array([0.0, 1.0, last]), "u": np.ones(3)})
    assert str(error.value).startswith(f"{log}: {words}")
    assert list(tmp_path.iterdir()) == []
    write_log(log, {"t": np.array([0.0, 1.0, 2.0**32 - 1]), "u": np.ones(3)})  # just fits


def test_simulate_checks_before_simulating(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def never(*args: object, **kwargs: object) -> None:
        raise AssertionError("simulated before the output was checked")

    monkeypatch.setattr("hybridlog.jobs.simulate.simulate_model", never)
    model = tmp_path / "tank.toml"
    model.write_text(builtin_text(TANK))
    for args in (
        ["--out", str(tmp_path / "run.parquet"), "--format", "csv"],
        ["--out", str(model), "--format", "mcap", "--force"],
        ["--out", str(tmp_path), "--format", "ros2-sqlite3", "--force"],
    ):
        with pytest.raises(SystemExit) as exit_:
            main(["simulate", str(model), *args])
        assert exit_.value.code == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "Traceback" not in err
    assert model.read_text() == builtin_text(TANK)
    assert [p.name for p in tmp_path.iterdir()] == ["tank.toml"]


def test_analyze_checks_its_options_before_reading(tmp_path: Path) -> None:
    with pytest.raises(OptionError, match="--table-format"):
        analyze(tmp_path / "missing.csv", TANK, out_dir=tmp_path / "r", table_format="xlsx")
    assert list(tmp_path.iterdir()) == []


SAMPLE_DC = SAMPLE_LOGS / "double_cart_case1.csv"


def test_cluster_writes_both_outputs_or_neither(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "c.json"
    with pytest.raises(OptionError, match=r"--plot .*x.csv.*\*\.png"):
        discover_modes(SAMPLE_DC, "double_cart_case1", out=out, plot=tmp_path / "x.csv")
    with pytest.raises(OptionError, match=r"\*\.json"):
        discover_modes(SAMPLE_DC, "double_cart_case1", out=tmp_path / "c.csv")
    assert list(tmp_path.iterdir()) == []

    def full_disk(path: Path, **_: object) -> None:
        path.write_bytes(b"half a pic")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(cluster_job, "plot_clusters", full_disk)
    with pytest.raises(OutputError, match="No space left"):
        discover_modes(SAMPLE_DC, "double_cart_case1", out=out)
    assert list(tmp_path.iterdir()) == []
    monkeypatch.undo()
    outcome = discover_modes(SAMPLE_DC, "double_cart_case1", out=out, plot=tmp_path / "c.svg")
    assert json.loads(out.read_text())["format"] == "hybridlog-centers"
    assert outcome.plot_path == tmp_path / "c.svg"
    assert (tmp_path / "c.svg").read_text().lstrip().startswith("<?xml")
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        ".c.json.hybridlog",
        ".c.svg.hybridlog",
        "c.json",
        "c.svg",
    ]


# --- temporaries of dead processes -------------------------------------------------------------


def _dead_pid() -> int:
    done = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        check=True,
        capture_output=True,
        text=True,
    )
    return int(done.stdout)


def test_the_next_run_removes_temporaries_of_dead_processes(tmp_path: Path) -> None:
    dead, alive = _dead_pid(), os.getpid()
    host = temporary_name(tmp_path / "x").name.split("-")[2]  # .x.hybridlog-tmp-<host>-…
    other_host = f"{(int(host, 16) + 1) % 0x10000:04x}"

    def name(base: str, kind: str, pid: int, suffix: str = "", on: str = host) -> Path:
        return tmp_path / f".{base}.hybridlog-{kind}-{on}-{pid}-0123abcd{suffix}"

    stale_dir = name("report", "tmp", dead)
    stale_dir.mkdir()
    (stale_dir / MARKER).write_text("{}")
    (stale_dir / "report.json").write_text("{")
    empty_dir = name("other", "old", dead)
    empty_dir.mkdir()
    stale_file = name("log", "tmp", dead, ".csv")
    stale_file.write_text("t,u\n0,")
    kept = [
        name("busy", "tmp", alive),  # a live process is still writing it
        name("notes", "tmp", dead),  # a folder hybridlog did not make (no marker)
        name(
            "shared", "tmp", dead, on=other_host
        ),  # made on another host: its pid means nothing here
        tmp_path / f".x.tmp-{dead}-0123abcd",  # not hybridlog's pattern
    ]
    for folder in kept:
        folder.mkdir()
        (folder / "file").write_text("x")
        if folder != kept[1]:
            (folder / MARKER).write_text("{}")
    with atomic_output_dir(tmp_path / "report") as tmp:
        (tmp / "a.txt").write_text("a")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["report", *(k.name for k in kept)])
    assert remove_stale_temporaries(tmp_path) == []
    with atomic_files([tmp_path / "t.csv"]) as (temporary,):
        assert temporary.parent == tmp_path and temporary.suffix == ".csv"
        assert f".hybridlog-tmp-{host}-{alive}-" in temporary.name
        temporary.write_text("x\n")
    assert (tmp_path / "t.csv").read_text() == "x\n"


def test_temporaries_of_ended_workers_are_removed_whatever_they_hold(tmp_path: Path) -> None:
    """A batch removes its ended workers' temporaries, even one without its marker (the
    worker was stopped while it removed the folder, a thread of its task still writing)."""
    dead = _dead_pid()
    host = temporary_name(tmp_path / "x").name.split("-")[2]
    left = tmp_path / f".log.csv.hybridlog-tmp-{host}-{dead}-0123abcd"
    left.mkdir()
    (left / "estimates.csv").write_text("t,x\n")
    assert remove_stale_temporaries(tmp_path) == []  # not known to be hybridlog's
    assert remove_stale_temporaries(tmp_path, ours={os.getpid()}) == []
    assert remove_stale_temporaries(tmp_path, ours={dead}) == [left]
    assert list(tmp_path.iterdir()) == []


def test_a_failed_write_leaves_no_folder_behind(tmp_path: Path) -> None:
    with pytest.raises(RuntimeError), atomic_output_dir(tmp_path / "a" / "b" / "out") as tmp:
        (tmp / "report.json").write_text("{")
        raise RuntimeError("disk on fire")
    targets = [tmp_path / "c" / "x.json", tmp_path / "c" / "d" / "x.png"]
    with pytest.raises(RuntimeError), atomic_files(targets) as (first, _):
        first.write_text("{}")
        raise RuntimeError("disk on fire")
    with pytest.raises(RuntimeError), staging_dir(tmp_path / "e" / "bag") as area:
        (area / "bag").mkdir()
        raise RuntimeError("disk on fire")
    assert list(tmp_path.iterdir()) == []


def test_a_batch_folder_name_too_long_for_its_temporaries_is_refused_at_once(
    tmp_path: Path,
) -> None:
    """It was accepted, then every re-run failed on the name: resuming was impossible."""
    log = write_table(tmp_path / "log.csv", tank_run().columns)
    out = tmp_path / ("M" * 230)
    with pytest.raises(OutputError, match="is too long"):
        run_batch([log], TANK, out_dir=out, estimator="imm")
    assert sorted(p.name for p in tmp_path.iterdir()) == [".log.csv.hybridlog", "log.csv"]


@contextlib.contextmanager
def _file_size_limit(limit: int) -> Iterator[None]:
    """``ulimit -f``: a write past ``limit`` bytes fails with EFBIG (Python ignores SIGXFSZ)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))


def test_a_write_the_file_system_refuses_is_one_line_naming_the_output(tmp_path: Path) -> None:
    """A full disk, a quota, ``ulimit -f`` or a read-only remount met while writing: an
    ``OutputError`` naming the output and the system's reason, nothing left behind and the
    previous outputs untouched (it was an 'unexpected OSError ... (a bug ...)', from
    polars' table sink, report.json, the plots' worker, or a ROS 2 bag's sqlite3)."""
    log = write_table(tmp_path / "log.csv", tank_run(steps=3000).columns)
    # the estimators' machine code compiled and cached first: with a cold cache its files
    # met the limit, refused as the cache folder's, not the output's
    compare(log, TANK, ["imm", "hstf"], out_dir=tmp_path / "warm")
    before = tree(tmp_path)
    with _file_size_limit(64 * 1024):
        limit = r"File too large: this process may write files of 65,536 bytes at most: ulimit"
        for run, where, reason in (
            (lambda: analyze(log, TANK, out_dir=tmp_path / "a", estimator="imm"), "/a", limit),
            (lambda: compare(log, TANK, ["imm", "hstf"], out_dir=tmp_path / "c"), r"/c/\w+",
             limit),
            # sqlite3 says "disk I/O error", its errno not told
            (lambda: write_log(tmp_path / "bag", tank_run(steps=3000).columns,
                               format="ros2-sqlite3"), "/bag", ""),
        ):  # fmt: skip
            with pytest.raises(OutputError, match=rf"{where}: cannot be written \({reason}"):
                run()
    assert tree(tmp_path) == before


@pytest.mark.parametrize(
    "error",
    [
        OSError(errno.ENOSPC, "No space left on device"),
        OSError("No space left on device (os error 28)"),  # polars' sinks
        RuntimeError("parquet: underlying IO error: Disk quota exceeded (os error 122)"),
    ],
)
def test_the_system_refusing_a_write_is_an_output_error_naming_where_it_was_to_go(
    tmp_path: Path, error: Exception
) -> None:
    out = tmp_path / "c"
    inner = rf"^{out / 'imm'}: cannot be written \("
    with (
        pytest.raises(OutputError, match=inner) as refused,
        atomic_output_dir(out) as folder,
        atomic_output_dir(folder / "imm"),
    ):
        raise error
    assert refused.value.__cause__ is error
    picture = rf"^{tmp_path / 'x.png'}: cannot be written"
    with (
        pytest.raises(OutputError, match=picture),
        atomic_files([tmp_path / "x.json", tmp_path / "x.png"]) as (_, staged),
    ):
        raise OSError(errno.EROFS, "Read-only file system", str(staged))
    with pytest.raises(RuntimeError), atomic_output_dir(out):  # any other failure: itself
        raise RuntimeError("No such file or directory (os error 2)")
    assert list(tmp_path.iterdir()) == []


def test_force_never_replaces_a_report_folder_whose_files_the_user_edited(tmp_path: Path) -> None:
    """A user annotates report.md (or puts another table under timeline.csv's name) in a
    folder hybridlog wrote: ``--force`` refuses to replace it, naming the file (the folder's
    marker listed names only, and the edit was deleted); a file the user removed is no loss."""
    log = write_table(tmp_path / "log.csv", tank_run().columns)
    out = tmp_path / "out"
    analyze(log, TANK, out_dir=out, estimator="imm")
    with (out / "report.md").open("a") as notes:
        notes.write("\nMy notes: the valve stuck at t = 40 s.\n")
    before = tree(out)
    with pytest.raises(OutputError, match=r"changed since hybridlog wrote them \('report.md'\)"):
        analyze(log, TANK, out_dir=out, estimator="imm", force=True)
    assert tree(out) == before
    (out / "report.md").unlink()
    other = tmp_path / "timeline.csv"
    shutil.copy2(out / "timeline.csv", other)  # another table: same size and time
    with other.open("r+b") as table:
        table.seek(-2, os.SEEK_END)
        digit = table.read(1)
        table.seek(-2, os.SEEK_END)
        table.write(b"1" if digit != b"1" else b"2")
    status = (out / "timeline.csv").stat()
    os.utime(other, ns=(status.st_atime_ns, status.st_mtime_ns))
    os.replace(other, out / "timeline.csv")
    with pytest.raises(OutputError, match=r"\('timeline.csv'\)"):
        analyze(log, TANK, out_dir=out, estimator="imm", force=True)
    (out / "timeline.csv").unlink()
    analyze(log, TANK, out_dir=out, estimator="imm", force=True)  # nothing of the user's
    analyze(log, TANK, out_dir=out, estimator="imm", force=True)  # its own, unchanged
    assert (out / "report.md").is_file()


@pytest.mark.parametrize("out", [".", "/", "..", "runs/..", "./", "runs"])
def test_a_centres_file_named_without_a_file_name_is_refused(tmp_path: Path, out: str) -> None:
    # cluster --out . (or /) failed with an unexpected ValueError making the plot's name
    log = SAMPLE_LOGS / "double_cart_case1.csv"
    with pytest.raises((OptionError, OutputError)) as info:
        cluster_job.check_cluster_outputs(log, "double_cart_case1", out=out, plot=None, force=False)
    said = str(info.value)
    assert said.endswith("which names a folder; name a file to write") or said.endswith(
        "the centres file is JSON; name it *.json"
    ), said


def _cluster_out(target: str) -> object:
    log = SAMPLE_LOGS / "double_cart_case1.csv"
    return cluster_job.check_cluster_outputs(
        log, "double_cart_case1", out=target, plot=None, force=False
    )


def _cluster_plot(target: str) -> object:
    log, out = SAMPLE_LOGS / "double_cart_case1.csv", Path(target).parent / "c.json"
    return cluster_job.check_cluster_outputs(
        log, "double_cart_case1", out=out, plot=target, force=False
    )


@pytest.mark.parametrize(
    ("option", "name", "check"),
    [
        ("--out", "x.json", _cluster_out),
        ("--plot", "p.png", _cluster_plot),
        ("--out", "x.csv", check_log_target),  # simulate's log file
        ("--junit", "j.xml", check_junit_target),
    ],
)
@pytest.mark.parametrize("ending", ["/", "//", "/."])
def test_a_file_output_named_as_a_folder_is_refused(
    tmp_path: Path, option: str, name: str, check: Callable[[str], object], ending: str
) -> None:
    """``cluster --out dir.json/`` (the user meant a folder) wrote a file ``dir.json``:
    ``Path`` drops the ``/``.  Every file output (cluster's centres and picture, simulate's
    log file, batch's JUnit file) refuses the name as given, naming the option."""
    target = f"{tmp_path / name}{ending}"
    with pytest.raises(OutputError) as info:
        check(target)
    assert str(info.value) == (
        f"{option} {target}: ends with {ending!r}, which names a folder; name a file to write"
    )
    assert list(tmp_path.iterdir()) == []
    # a ROS 2 bag is a folder: its "/" is as good as none
    assert check_log_target(f"{tmp_path / 'bag'}/", format="ros2-mcap") == "ros2-mcap"


def _batch_junit(target: str) -> object:
    folder = Path(target).parent.parent  # where j.xml/.. is: the log's folder
    log = folder / "run.csv"
    shutil.copyfile(SAMPLE_LOGS / "double_cart_case1.csv", log)
    return run_batch([log], "double_cart_case1", out_dir=folder / "batch", junit=target)


@pytest.mark.parametrize(
    ("option", "name", "check"),
    [
        ("--out", "x.json", _cluster_out),
        ("--plot", "p.png", _cluster_plot),
        ("--junit", "j.xml", _batch_junit),
    ],
)
def test_a_file_output_ending_in_dot_dot_is_refused_as_a_folders_name(
    tmp_path: Path, option: str, name: str, check: Callable[[str], object]
) -> None:
    """``--out c.json/..`` was refused for its suffix ("name it *.json": it is), ``--plot
    p.png/..`` as "a suffix-less file" and ``batch --junit j.xml/..`` as the folder holding
    the log: the name's ending, checked after them, is what is wrong."""
    target = f"{tmp_path / name}/.."
    with pytest.raises(OutputError) as info:
        check(target)
    assert str(info.value) == (
        f"{option} {target}: ends with '/..', which names a folder; name a file to write"
    )


def test_cluster_names_its_default_plot_path_as_the_default(tmp_path: Path) -> None:
    """No --plot given: an error about the picture (here the user's c.png beside c.json)
    said "--plot", or named c.png alone, a file the user never mentioned."""
    (tmp_path / "c.png").write_bytes(b"mine")
    log, out = SAMPLE_LOGS / "double_cart_case1.csv", tmp_path / "c.json"
    with pytest.raises(OutputError) as info:
        cluster_job.check_cluster_outputs(log, "double_cart_case1", out=out, plot=None, force=False)
    assert str(info.value) == (
        f"the default plot path (--out with .png) {tmp_path / 'c.png'}: exists and hybridlog "
        "did not write it (or it changed since), so --force does not replace it; move it away "
        "or name another file; --plot PATH writes the picture elsewhere"
    )
    # the default is the log: "--plot c.png is the log c.png"
    with pytest.raises(OutputError, match=r"^the default plot path \(--out with \.png\) "):
        cluster_job.check_cluster_outputs(
            tmp_path / "c.png", "double_cart_case1", out=out, plot=None, force=True
        )
    with pytest.raises(OutputError) as given:  # --plot given: the user's own words
        cluster_job.check_cluster_outputs(
            log, "double_cart_case1", out=out, plot=tmp_path / "c.png", force=False
        )
    assert str(given.value).startswith(f"{tmp_path / 'c.png'}: exists and hybridlog did not")


def test_an_output_folder_that_is_a_link_is_refused_saying_so(tmp_path: Path) -> None:
    # a link to a folder, to a file or to nothing was "exists and is not a directory"
    (tmp_path / "folder").mkdir()
    (tmp_path / "file").write_text("mine")
    for pointed, what in (("folder", "a folder"), ("file", "a file"), ("nowhere", "nothing")):
        link = tmp_path / f"to_{pointed}"
        link.symlink_to(tmp_path / pointed)
        for force in (False, True):
            with pytest.raises(OutputError) as raised:
                check_dir_target(link, force=force)
            said = str(raised.value)  # a long target is cut in its middle (excerpt)
            assert said.startswith(f"output path {link} is a symbolic link (to '")
            assert said.endswith(
                f"{pointed}', {what}), which hybridlog does not write through; name the "
                "folder itself or another path"
            )
        assert link.is_symlink() and os.readlink(link) == str(tmp_path / pointed)
    assert (tmp_path / "file").read_text() == "mine"


def test_a_batch_never_writes_into_another_commands_output_folder(tmp_path: Path) -> None:
    # batch --out <an analyze report> put its folders and summaries in among the report's
    # files, without --force and without a word
    log = SAMPLE_LOGS / "three_tank_hstf.csv"
    for kind, make in (
        ("analyze", lambda out: analyze(log, TANK, out_dir=out, estimator="imm")),
        ("compare", lambda out: compare(log, TANK, ["imm"], out_dir=out)),
    ):
        out = tmp_path / kind
        make(out)
        before = tree(out)
        for force in (False, True):
            with pytest.raises(OutputError, match="is the output of another hybridlog command"):
                run_batch([log], TANK, out_dir=out, estimator="imm", force=force)
            assert tree(out) == before


def test_a_batch_does_not_overwrite_a_summary_the_user_changed(tmp_path: Path) -> None:
    # every run rewrote summary.md/.csv/.png: notes added to summary.md were gone at the next
    log = SAMPLE_LOGS / "three_tank_hstf.csv"
    out = tmp_path / "nightly"
    run_batch([log], TANK, out_dir=out, estimator="imm")
    run_batch([log], TANK, out_dir=out, estimator="imm")  # its own summaries: rewritten
    for name in ("summary.md", "summary.csv"):
        summary = out / name
        with summary.open("a", encoding="utf-8") as file:
            file.write("my notes\n")
        before = tree(out)
        for force in (False, True):
            with pytest.raises(OutputError, match=f"{name} changed since a batch wrote it"):
                run_batch([log], TANK, out_dir=out, estimator="imm", force=force)
            assert tree(out) == before
        summary.unlink()
    run_batch([log], TANK, out_dir=out, estimator="imm")
    # a batch folder of an older version (summaries without records) is still the batch's
    for record in out.glob(".summary.*.hybridlog"):
        record.unlink()
    run_batch([log], TANK, out_dir=out, estimator="imm")


def test_force_is_advised_only_where_it_would_replace_the_folder(tmp_path: Path) -> None:
    """A user's folder (``compare --out notes/``) was refused with "is not empty; use --force
    to replace it", and ``--force`` was then refused too ("holds files hybridlog did not
    write"): without ``force`` the folder is checked as with it, and the advice is given
    only to a folder that ``--force`` replaces."""
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "notes.txt").write_text("mine")
    for force in (False, True):
        with pytest.raises(OutputError) as info:
            check_dir_target(theirs, force=force)
        message = str(info.value)
        # the files named, as in a folder of ours the user put a file into (below)
        assert "not empty: it holds files hybridlog did not write ('notes.txt'; no" in message
        assert "use --force" not in message
    # hybridlog's folder with a note of the user's put into it: --force keeps it too
    ours = tmp_path / "ours"
    ours.mkdir()
    (ours / "report.json").write_text("{}")
    (ours / "notes.txt").write_text("mine")
    for force in (False, True):
        with pytest.raises(OutputError, match=r"did not write \('notes.txt'\)") as info:
            check_dir_target(
                ours, force=force, ours=lambda _: True, written=lambda _: ["report.json"]
            )
        assert "use --force" not in str(info.value)
    (ours / "notes.txt").unlink()
    with pytest.raises(OutputError, match=r"is not empty; use --force to replace it$"):
        check_dir_target(ours, force=False, ours=lambda _: True, written=lambda _: ["report.json"])
    assert (
        check_dir_target(ours, force=True, ours=lambda _: True, written=lambda _: ["report.json"])
        == ours
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ours", "theirs"]
