"""``hybridlog batch --scheduler``: the same batch on a Dask cluster (a LocalCluster here)."""

from __future__ import annotations

import os
import signal
import socket
import sys
import threading
import time
from pathlib import Path

import pytest

import hybridlog.jobs.dask_backend as dask_backend
from hybridlog.errors import OptionError
from hybridlog.io.writers import write_table
from hybridlog.jobs.batch import run_batch
from tests.support.logfiles import tank_run

distributed = pytest.importorskip("distributed")

TANK = "three_tank_hstf"


def test_dask_and_local_batches_write_the_same_summaries(tmp_path: Path) -> None:
    logs = [
        write_table(tmp_path / "logs" / f"s{k}.csv", tank_run(steps=40, seed=k).columns)
        for k in range(1, 7)
    ]
    broken = tmp_path / "logs" / "s7.csv"
    broken.write_text("t,u,y1\n0,1,2\n")
    logs.append(broken)
    gate = ["vaf=0"]
    local = run_batch(logs, TANK, out_dir=tmp_path / "local", estimator="imm", fail_under=gate)
    with distributed.LocalCluster(
        n_workers=1,
        threads_per_worker=2,
        processes=False,  # threads of this process: quick to start, numba already loaded
        protocol="tcp",  # a real address, reached over TCP as a remote scheduler would be
        host="127.0.0.1",
        dashboard_address=":0",  # any free port: 8787 may be taken (by a scheduler)
    ) as cluster:
        remote = run_batch(
            logs,
            TANK,
            out_dir=tmp_path / "dask",
            estimator="imm",
            scheduler=cluster.scheduler_address,
            fail_under=gate,
        )
        summaries = {n: (tmp_path / "dask" / n).read_bytes() for n in ("summary.md", "summary.csv")}
        again = run_batch(
            logs,
            TANK,
            out_dir=tmp_path / "dask",
            estimator="imm",
            scheduler=cluster.scheduler_address,
        )
    assert [o.status for o in remote.logs] == [o.status for o in local.logs]
    assert [o.status for o in remote.logs] == ["done"] * 6 + ["failed"]
    assert [o.status for o in again.logs] == ["skipped"] * 6 + ["failed"]
    # the workers wrote the report folders, the client the summaries: the same bytes
    for name, text in summaries.items():
        assert text == (tmp_path / "local" / name).read_bytes()
    for log in logs[:-1]:
        dask_report = tmp_path / "dask" / log.name / "estimates.csv"
        assert (
            dask_report.read_bytes()
            == (tmp_path / "local" / log.name / "estimates.csv").read_bytes()
        )
    assert not [p for p in (tmp_path / "dask").iterdir() if ".hybridlog-tmp" in p.name]


def test_a_smoothed_batch_on_dask_writes_the_same_filtered_and_offline_columns(
    tmp_path: Path,
) -> None:
    """The summaries' offline columns come from the reports the workers return."""
    logs = [
        write_table(tmp_path / "logs" / f"s{k}.csv", tank_run(steps=40, seed=k).columns)
        for k in (1, 2)
    ]
    broken = tmp_path / "logs" / "s3.csv"
    broken.write_text("t,u,y1\n0,1,2\n")
    logs.append(broken)
    run_batch(logs, TANK, out_dir=tmp_path / "local", estimator="imm", smooth=True)
    with distributed.LocalCluster(
        n_workers=1,
        threads_per_worker=2,
        processes=False,
        protocol="tcp",
        host="127.0.0.1",
        dashboard_address=":0",  # any free port: 8787 may be taken (by a scheduler)
    ) as cluster:
        run_batch(
            logs,
            TANK,
            out_dir=tmp_path / "dask",
            estimator="imm",
            scheduler=cluster.scheduler_address,
            smooth=True,
        )
    for name in ("summary.md", "summary.csv"):
        text = (tmp_path / "dask" / name).read_text()
        assert text == (tmp_path / "local" / name).read_text()
        assert "filtered_mode_accuracy" in text and "state_rmse.x1" in text


def test_scheduler_errors_are_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    monkeypatch.setattr(dask_backend, "CONNECT_TIMEOUT_S", 0.5)
    with pytest.raises(OptionError, match=r"--scheduler tcp://127.0.0.1:9: cannot reach") as err:
        run_batch([log], TANK, out_dir=tmp_path / "out", scheduler="tcp://127.0.0.1:9")
    assert "\n" not in str(err.value)
    assert not (tmp_path / "out").exists()  # refused before anything was written
    # an address that is none is not a connection that timed out (it said "cannot reach")
    # a port no socket can have: its connection "timed out" after CONNECT_TIMEOUT_S too
    for address, why in (
        ("host:xx", "invalid literal"),
        ("foo://h:1", "unknown address"),
        ("tcp://127.0.0.1:99999", "port 99999 is not 1 to 65535"),
        ("tcp://[::1]:0", "port 0 is not 1 to 65535"),
    ):
        with pytest.raises(OptionError, match=f"not a scheduler address \\({why}.*tcp://host"):
            run_batch([log], TANK, out_dir=tmp_path / "out", scheduler=address)
    assert not (tmp_path / "out").exists()
    # a blank around the address was taken as part of it ("unknown address scheme ' tcp'", or
    # a 5 s wait for "tcp://127.0.0.1:1 "); an address ending in a colon was shown "tcp://::"
    for address, said in (
        (" tcp://127.0.0.1:9", "--scheduler ' tcp://127.0.0.1:9': the address has a blank"),
        ("tcp://127.0.0.1:9\t", "--scheduler 'tcp://127.0.0.1:9\\t': the address has a blank"),
        ("tcp://:", "--scheduler 'tcp://:': not a scheduler address"),
    ):
        with pytest.raises(OptionError) as refused:
            run_batch([log], TANK, out_dir=tmp_path / "out", scheduler=address)
        assert str(refused.value).startswith(said), str(refused.value)
    assert not (tmp_path / "out").exists()
    monkeypatch.setitem(sys.modules, "distributed", None)  # as if Dask were not installed
    with pytest.raises(OptionError, match=r"pip install 'hybridlog\[dask\]'"):
        run_batch([log], TANK, out_dir=tmp_path / "out", scheduler="tcp://127.0.0.1:9")


def test_a_port_that_answers_but_not_in_dask_is_refused_in_one_line(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A dashboard's port kept the batch waiting forever; an HTTP reply said "cannot reach"."""
    monkeypatch.setattr(dask_backend, "CONNECT_TIMEOUT_S", 0.3)
    with (
        socket.create_server(("127.0.0.1", 0)) as silent,
        socket.create_server(("127.0.0.1", 0)) as http,
    ):

        def reply() -> None:
            conn, _ = http.accept()
            with conn:
                conn.sendall(b"HTTP/1.1 404 Not Found\r\ncontent-length: 0\r\n\r\n")
                conn.recv(1)  # open until the client lets go

        threading.Thread(target=reply, daemon=True).start()
        # the kernel accepts a connection to ``silent``, which never says a word
        for server, why in ((http, "its reply is not Dask's"), (silent, "no Dask handshake")):
            address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
            with pytest.raises(
                OptionError, match=f"^--scheduler {address}: .* not a Dask sch"
            ) as err:
                dask_backend.connect(address)
            assert why in str(err.value)


def test_ctrl_c_while_waiting_for_a_handshake_ends_at_once(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Not after the handshake's wait (2 x CONNECT_TIMEOUT_S)."""
    monkeypatch.setattr(dask_backend, "CONNECT_TIMEOUT_S", 2.0)
    with socket.create_server(("127.0.0.1", 0)) as silent:
        threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT)).start()
        started = time.monotonic()
        with pytest.raises(KeyboardInterrupt):
            dask_backend.connect(f"tcp://127.0.0.1:{silent.getsockname()[1]}")
        assert time.monotonic() - started < 1.5


def test_jobs_with_a_scheduler_is_refused(tmp_path: Path) -> None:
    """``--jobs 4 --scheduler ADDR`` ran on the cluster as it pleased, the 4 silently ignored."""
    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    with pytest.raises(OptionError, match=r"^--jobs 4: has no effect with --scheduler \("):
        run_batch([log], TANK, out_dir=tmp_path / "out", jobs=4, scheduler="tcp://127.0.0.1:9")
    assert not (tmp_path / "out").exists()  # refused before connecting or writing


@pytest.mark.parametrize("jobs", [1, "auto"])
def test_any_jobs_given_with_a_scheduler_is_refused(tmp_path: Path, jobs: int | str) -> None:
    """``--jobs 1 --scheduler ADDR`` was taken, as if it held the cluster to one log at a time.

    The cluster ran as many logs at once as its workers have threads; a ``--jobs`` left out
    is ``None``, so that the 1 the user wrote is told from the default.
    """
    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    with pytest.raises(OptionError, match=rf"^--jobs {jobs}: has no effect with --scheduler \("):
        run_batch([log], TANK, out_dir=tmp_path / "out", jobs=jobs, scheduler="tcp://127.0.0.1:9")
    assert not (tmp_path / "out").exists()


def test_the_command_refuses_jobs_1_with_a_scheduler(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from hybridlog.cli import main

    log = write_table(tmp_path / "s1.csv", tank_run(steps=20, seed=1).columns)
    line = [str(log), "--model", TANK, "--out", str(tmp_path / "out"), "--jobs", "1"]
    with pytest.raises(SystemExit) as exit_:
        main(["batch", *line, "--scheduler", "tcp://127.0.0.1:9"])
    assert exit_.value.code == 2
    assert "--jobs 1: has no effect with --scheduler" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
