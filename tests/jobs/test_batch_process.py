"""The batch process of ``batch --jobs N``: what it loads, and when its forkserver starts and stops.

It checks, hands out the logs and writes the summaries; its workers read and write the
tables.  So it imports neither polars nor numba (each import costs a core the workers need).
The console script starts the forkserver before the CLI is imported when the command line
asks for local workers (:mod:`hybridlog.launch`), and stops it when the process ends, so a
command that failed early never keeps a caller reading its output waiting for the warm-up.
It makes the summary plot's figure ahead, while it waits, without the garbage collector.
"""

from __future__ import annotations

import gc
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from hybridlog.environment import usable_cores
from hybridlog.jobs import batch
from hybridlog.launch import local_batch_jobs
from tests.jobs.test_batch import write_logs

ROOT = Path(__file__).resolve().parents[2]

BATCH_PROCESS = """
import json, sys
from hybridlog.jobs.batch import run_batch

if __name__ == "__main__":
    folder = sys.argv[1]
    outcome = run_batch(
        [folder + "/logs"], "three_tank_hstf", out_dir=folder + "/out", estimator="imm", jobs=2
    )
    loaded = [m for m in ("polars", "numba", "matplotlib") if m in sys.modules]
    print(json.dumps({"statuses": [o.status for o in outcome.logs], "loaded": loaded}))
"""


def test_the_batch_process_of_workers_loads_no_polars_nor_numba(tmp_path: Path) -> None:
    write_logs(tmp_path / "logs", ["a", "b", "c"])
    script = tmp_path / "batch_process.py"
    script.write_text(textwrap.dedent(BATCH_PROCESS), encoding="utf-8")
    done = subprocess.run(
        [sys.executable, str(script), str(tmp_path)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    )
    facts = json.loads(done.stdout.splitlines()[-1])
    assert facts["statuses"] == ["done"] * 3
    assert facts["loaded"] == ["matplotlib"]  # the summary plot; the workers did the rest
    summary = (tmp_path / "out" / "summary.csv").read_text(encoding="utf-8").splitlines()
    assert summary[0] == (
        "log,status,samples,vaf,mse,mode_accuracy,mode_samples,state_rmse.x1,state_rmse.x2,"
        "state_rmse.x3,gate_failures,warnings,error,folder"
    )
    assert [line.split(",")[1:3] for line in summary[1:]] == [["done", "91"]] * 3


@pytest.mark.parametrize(
    ("line", "jobs"),
    [
        ("batch logs --jobs 2", 2),
        ("-q batch logs --model m --jobs=3", 3),
        ("--debug batch --jobs 2 --jobs 4 logs", 4),  # the last one counts, as in click
        ("batch logs --jobs 2 --scheduler tcp://h:8786", 1),
        ("batch logs --scheduler=tcp://h:8786 --jobs 2", 1),
        ("batch logs -- --jobs 2", 1),  # after "--" a log, not an option
        ("batch logs --jobs two", 1),
        ("batch logs --jobs auto", usable_cores()),
        ("batch logs --jobs=AUTO", usable_cores()),
        ("batch logs --jobs ٣", 1),  # not ASCII: left to the CLI, which starts it later
        ("batch logs --jobs", 1),
        ("analyze log --jobs 2", 1),
        ("--help", 1),
        ("", 1),
    ],
)
def test_the_launcher_glances_at_the_jobs_of_a_local_batch(line: str, jobs: int) -> None:
    assert local_batch_jobs(line.split()) == jobs


SLOW_WARMUP = """
import time
time.sleep(120)
"""

EARLY_FAILURE = """
import sys
import hybridlog.jobs.workers as workers

if __name__ == "__main__":
    workers.WARMUP = "slow_warmup"  # a forkserver that takes two minutes to warm up
    out = sys.argv[1] + "/out"
    sys.argv = ["hybridlog", "batch", "a.csv", "b.csv", "--model", "nonexistent", "--jobs", "2"]
    sys.argv += ["--out", out]
    from hybridlog.launch import main

    main()
"""


def test_a_failed_command_does_not_wait_for_its_forkservers_warm_up(tmp_path: Path) -> None:
    (tmp_path / "slow_warmup.py").write_text(SLOW_WARMUP, encoding="utf-8")
    script = tmp_path / "early_failure.py"
    script.write_text(textwrap.dedent(EARLY_FAILURE), encoding="utf-8")
    # The output read through pipes, as CI does: their end of file waits for every process
    # holding them, the forkserver too.  Before, this waited out the two minutes.
    # the forkserver finds its preload through the environment (it ignores the caller's path)
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}
    done = subprocess.run(
        [sys.executable, str(script), str(tmp_path)],
        cwd=ROOT,
        env=environment,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("hybridlog: error: "), done.stderr
    assert len(done.stderr.splitlines()) == 1, done.stderr


def test_the_summary_plot_is_made_ahead_without_the_collector(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # matplotlib's import and the figure, while the forkserver warms up on the other core:
    # the collector's passes over their objects made it outlast the warm-up
    from hybridlog.report import summary_plot

    seen: list[bool] = []
    monkeypatch.setattr(
        summary_plot, "prepare_summary_figure", lambda n: seen.append(gc.isenabled())
    )
    batch._prepare_summary_plot(3)
    assert seen == [False]
    assert gc.isenabled()  # on again once it is made
