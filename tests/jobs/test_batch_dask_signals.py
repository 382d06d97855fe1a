"""Ctrl-C of ``batch --scheduler`` in a script that also runs the Dask cluster.

Such a script's processes share one process group: the Ctrl-C reaches the scheduler and
the workers too, which Dask ends; a task still writing left its temporary report folder
(a worker process ends without unwinding its threads), and the closing client logged its
lost connection with tracebacks on the batch's stderr.
"""

from __future__ import annotations

import contextlib
import os
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.support.paths import ROOT

pytest.importorskip("distributed")
DASK = shutil.which("dask", path=str(Path(sys.executable).parent))


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port


@pytest.mark.skipif(DASK is None, reason="no dask command")
def test_ctrl_c_of_a_batch_and_its_cluster_leaves_no_temporaries(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "HYBRIDLOG_CACHE_DIR": str(tmp_path / "cache")}
    first = logs / "l1.csv"
    hybridlog = [sys.executable, "-m", "hybridlog"]
    simulate = ["simulate", "three_tank_hstf", "--out", str(first), "--steps", "300000"]
    subprocess.run([*hybridlog, *simulate], env=env, check=True, capture_output=True)
    for k in range(2, 7):
        shutil.copy(first, logs / f"l{k}.csv")
    out = tmp_path / "out"
    address = f"tcp://127.0.0.1:{_free_port()}"
    port = address.rsplit(":", 1)[1]
    batch = [*hybridlog, "batch", str(logs), "--model", "three_tank_hstf", "--estimator", "imm"]
    batch += ["--out", str(out), "--scheduler", address]
    # a script without job control: its background jobs (the cluster) inherit SIGINT
    # ignored, all its processes share one group, which a Ctrl-C reaches whole; the trap
    # lets the script itself outlive it, to record the batch's exit status
    script = (
        "trap 'true' INT\n"
        f"{DASK} scheduler --host 127.0.0.1 --port {port} --no-dashboard 2>/dev/null &\n"
        f"{DASK} worker {address} --nworkers 1 --nthreads 2 --no-dashboard 2>/dev/null &\n"
        "sleep 4\n"
        f"{shlex.join(batch)} >/dev/null 2>{tmp_path / 'batch.err'}\n"
        f"echo $? >{tmp_path / 'rc'}\n"
    )
    # the test's own processes must not have SIGINT ignored (a test run in the background)
    shell = subprocess.Popen(
        ["sh", "-c", script],
        env=env,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not (
            out.is_dir() and any(".hybridlog-tmp-" in name for name in os.listdir(out))
        ):
            time.sleep(0.02)
        assert out.is_dir(), "the batch never started writing"
        os.killpg(shell.pid, signal.SIGINT)  # Ctrl-C
        shell.wait(timeout=60)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(shell.pid, signal.SIGKILL)
    assert (tmp_path / "rc").read_text().strip() == "130"
    err = (tmp_path / "batch.err").read_text()
    assert err.strip().splitlines()[-1] == "hybridlog: aborted"
    assert "Traceback" not in err
    assert not [name for name in os.listdir(out) if ".hybridlog-tmp-" in name]
