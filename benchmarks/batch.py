"""Batch throughput: logs per minute of a whole ``hybridlog batch`` command (issue 9).

    .venv/bin/python -m benchmarks.batch            # 200 logs, prints a Markdown table
    .venv/bin/python -m benchmarks.batch --quick    # 40 logs (smoke check)
    .venv/bin/python -m benchmarks.run --only batch # the same rows inside the harness

200 distinct three-tank logs of 300 samples (``simulate`` with seeds 1..200, schedule
``1:100,2:100,3:100``, written as CSV into a temporary folder; not timed).  Then the command

    hybridlog batch LOGS --model three_tank_hstf --estimator imm --out OUT --force -q --jobs J

runs as a child process for J = 1 and J = 2, alternately, ``repeat`` times each, after one
untimed run of two logs that fills the compiled-code caches.  The time is the wall time of the
whole command (interpreter start, imports, loading the model, every log, the summaries), the
best of the repetitions.  Targets: at least 1,000 logs per minute with ``--jobs 2`` and a
speed-up of at least 1.7 over ``--jobs 1``.  The load average before each run is in the notes:
on a machine shared with other work the two processes of ``--jobs 2`` do not get two cores.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

LOGS_PER_MIN_TARGET = 1000.0
SPEEDUP_TARGET = 1.7
SAMPLES = 300

Result = tuple[str, int | None, float | None, str, bool | None, str]


def write_logs(folder: Path, count: int) -> list[Path]:
    """``count`` distinct 300-sample three-tank logs (seeds 1..count) in ``folder``."""
    from hybridlog.io.writers import write_table
    from hybridlog.model.loader import load_model
    from hybridlog.simulate import simulate

    model = load_model("three_tank_hstf")
    logs = []
    for seed in range(1, count + 1):
        log = simulate(model, schedule="1:100,2:100,3:100", steps=SAMPLES - 1, seed=seed)
        logs.append(write_table(folder / f"run{seed}.csv", log.columns(model)))
    return logs


def run_batch_command(logs: list[Path], out: Path, jobs: int) -> float:
    """Wall time of one whole ``hybridlog batch`` command in a child process."""
    command = [sys.executable, "-m", "hybridlog", "batch", *map(str, logs)]
    command += ["--model", "three_tank_hstf", "--estimator", "imm", "--out", str(out)]
    command += ["--force", "-q", "--jobs", str(jobs)]
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def bench_batch(quick: bool, repeat: int) -> list[Result]:
    """Rows ``(label, logs, seconds, target, met, notes)`` for ``--jobs 1``, ``2`` and the ratio."""
    count = 40 if quick else 200
    with tempfile.TemporaryDirectory(prefix="hybridlog-bench-batch-") as tmp:
        folder = Path(tmp)
        logs = write_logs(folder / "logs", count)
        run_batch_command(logs[:2], folder / "warm", 1)
        best: dict[int, float] = {}
        loads: dict[int, list[float]] = {1: [], 2: []}
        for _ in range(repeat):
            for jobs in (1, 2):
                loads[jobs].append(os.getloadavg()[0])
                seconds = run_batch_command(logs, folder / f"out{jobs}", jobs)
                best[jobs] = min(best.get(jobs, seconds), seconds)
    rows: list[Result] = []
    for jobs in (1, 2):
        rate = count / best[jobs] * 60
        target = f"≥ {LOGS_PER_MIN_TARGET:,.0f} logs/min" if jobs == 2 else "–"
        met = rate >= LOGS_PER_MIN_TARGET if jobs == 2 else None
        notes = (
            f"{rate:,.0f} logs/min ({count} logs of {SAMPLES} samples, whole command); "
            f"load average before the runs {', '.join(f'{v:.2f}' for v in loads[jobs])}"
        )
        rows.append((f"batch · --jobs {jobs}", count, best[jobs], target, met, notes))
    speedup = best[1] / best[2]
    rows.append(
        (
            "batch · speed-up --jobs 2",
            None,
            None,
            f"≥ {SPEEDUP_TARGET}x",
            speedup >= SPEEDUP_TARGET,
            f"{speedup:.2f}x (best --jobs 1 time / best --jobs 2 time)",
        )
    )
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.batch", description=__doc__)
    parser.add_argument("--quick", action="store_true", help="40 logs instead of 200")
    parser.add_argument("--repeat", type=int, default=2, help="runs of each command (best kept)")
    args = parser.parse_args()
    print("| benchmark | logs | time (s) | target | met | notes |")
    print("|---|---:|---:|---|---|---|")
    for label, n, seconds, target, met, notes in bench_batch(args.quick, args.repeat):
        shown = "" if seconds is None else f"{seconds:.2f}"
        verdict = "" if met is None else ("yes" if met else "**NO**")
        print(f"| {label} | {n or ''} | {shown} | {target} | {verdict} | {notes} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
