"""End to end: ``hybridlog analyze`` of a 10^6-row three-tank log, wall time, peak RSS, stages.

    .venv/bin/python -m benchmarks.analyze_e2e           # full size, prints a Markdown table
    .venv/bin/python -m benchmarks.analyze_e2e --quick   # 10^4 rows (smoke check)
    .venv/bin/python -m benchmarks.run --only analyze    # the same rows inside the harness

The log is written once into a temporary folder by ``hybridlog simulate three_tank_hstf
--steps 1000000 --out big.parquet`` (a child process, not timed).  Then, each in a fresh
child process, one after the other:

1. one warm-up ``hybridlog analyze big.parquet --model three_tank_hstf --table-format
   parquet`` (fills the model and numba caches of a first run; not timed);
2. ``--repeat`` runs of the same command as a user runs it (``python -m hybridlog``): the
   time is the best wall time of the whole process (interpreter start to exit, measured
   around it), the memory the largest peak resident set of those runs (``ru_maxrss`` from
   ``wait4``: the process's ``VmHWM``, the largest of it and of its forked plot child).  Each
   command is started by a small launcher process (:data:`LAUNCHER`), which times it and
   reports its ``ru_maxrss``: Linux carries into that number what the forking process had
   resident when it forked, so started straight from ``benchmarks.run`` (775 MiB by then)
   the command "peaked" at 516-547 MiB where it peaks at 453-460 MiB, and a ``python -c pass``
   started by a process holding 700 MiB reports 726 MiB;
3. one run of the same command under :mod:`benchmarks.analyze_stages`, which wraps each
   stage of the job with a timer: the breakdown (start-up = interpreter start before the
   first line; shutdown = after the command ended (its atexit handlers) until the process is
   gone, measured by this process's clock).  The timers cost next to nothing; the main
   thread's stages add up to that run's wall time, which the notes give; stages run beside
   them (the log read in a thread while numba sets up, the estimator's compiled loop in a
   thread while the report takes its chunks, matplotlib's import and the plots in the
   command's worker process) are listed as such, and the main thread's waits for them as
   ``waiting for a thread``, ``waiting for the filter`` and ``waiting for the worker``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from benchmarks import child_environment

WALL_TARGET_S = 2.0
"""``analyze`` of 10^6 rows with parquet tables, whole process, must take at most this."""
RSS_TARGET_MIB = 400.0
"""... and peak at most this resident memory."""

FULL_ROWS = 1_000_000
QUICK_ROWS = 10_000

Result = tuple[str, int | None, float | None, str, bool | None, str]
"""(label, rows, time in s, target, met, notes), as ``benchmarks.run`` wants."""

ROOT = Path(__file__).resolve().parent.parent


LAUNCHER = r"""
import json, os, subprocess, sys, tempfile, time
with tempfile.TemporaryFile() as errors:
    start = time.time()
    child = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=errors)
    _, status, usage = os.wait4(child.pid, 0)
    end = time.time()
    errors.seek(0)
    stderr = errors.read().decode(errors="replace")
code = os.waitstatus_to_exitcode(status)
print(json.dumps({"start": start, "end": end, "peak": usage.ru_maxrss, "code": code,
                  "stderr": stderr}))
"""
"""Runs ``argv`` to completion; prints its (start, end) on ``time.time()``, its ``ru_maxrss``
in KiB, its exit code and its standard error, as JSON.  A small process (about 10 MiB), so
that its child's ``ru_maxrss`` counts next to nothing of the launcher's memory."""


def _run(argv: Sequence[str], cwd: Path) -> tuple[float, float, float]:
    """Run a child to completion (through :data:`LAUNCHER`): (start, end) on ``time.time()``
    and its peak RSS in MiB."""
    env = child_environment(PYTHONPATH=str(ROOT))
    launched = subprocess.run(
        [sys.executable, "-c", LAUNCHER, *argv],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        check=True,
        text=True,
    )
    run = json.loads(launched.stdout)
    if run["code"] != 0:
        raise RuntimeError(f"{' '.join(argv)} failed ({run['code']}):\n{run['stderr']}")
    return run["start"], run["end"], run["peak"] / 1024


def _analyze_args(log: Path, out: Path, *extra: str) -> list[str]:
    return [
        "analyze",
        str(log),
        "--model",
        "three_tank_hstf",
        "--table-format",
        "parquet",
        "--out",
        str(out),
        "--force",
        *extra,
    ]


SMOOTHING = ("--estimator", "imm", "--smooth")
"""The offline run timed beside the plain one (issue 12: what smoothing costs a user)."""


def measure(rows: int, repeat: int) -> dict[str, Any]:
    """Write the log, run the command: best wall, peak RSS, and the stages of one run."""
    python = sys.executable
    with tempfile.TemporaryDirectory(prefix="hybridlog-bench-") as name:
        folder = Path(name)
        log = folder / "big.parquet"
        simulate = ["simulate", "three_tank_hstf", "--steps", str(rows), "--out", str(log)]
        _run([python, "-m", "hybridlog", *simulate], folder)
        command = [python, "-m", "hybridlog", *_analyze_args(log, folder / "out")]
        _run(command, folder)  # warm-up: caches of a first run
        # the same log with `--estimator imm`, with and without `--smooth`, alternating
        imm = [python, "-m", "hybridlog", *_analyze_args(log, folder / "imm", *SMOOTHING[:2])]
        smooth = [python, "-m", "hybridlog", *_analyze_args(log, folder / "smooth", *SMOOTHING)]
        _run(smooth, folder)  # warm-up: the smoother's caches
        walls, peaks = [], []
        offline: dict[str, list[float]] = {"imm": [], "smooth": [], "smooth_peak": []}
        for _ in range(repeat):
            start, end, peak = _run(command, folder)
            walls.append(end - start)
            peaks.append(peak)
            start, end, _ = _run(imm, folder)
            offline["imm"].append(end - start)
            start, end, peak = _run(smooth, folder)
            offline["smooth"].append(end - start)
            offline["smooth_peak"].append(peak)
        clock = folder / "stages.json"
        staged = [python, "-m", "benchmarks.analyze_stages", str(clock), "--"]
        start, end, staged_peak = _run([*staged, *_analyze_args(log, folder / "out")], folder)
        child = json.loads(clock.read_text(encoding="utf-8"))
        size = log.stat().st_size / 2**20
        tables = sum(p.stat().st_size for p in (folder / "out").glob("*.parquet")) / 2**20
    forked = set(child.get("forked", ()))
    beside = set(child.get("beside", ())) | forked

    def label(stage: str) -> str:
        if stage in forked:
            return f"{stage} (in a worker process, beside the others)"
        return f"{stage} (in a thread, beside the others)" if stage in beside else stage

    stages = {"start-up (interpreter)": child["started"] - start}
    stages |= {label(k): v for k, v in child["stages"].items()}
    command_s = stages.pop("command")
    stages["other (in the command)"] = command_s - sum(
        v for k, v in child["stages"].items() if k not in ("command", "imports", *beside)
    )
    stages["shutdown"] = end - child["finished"]
    return {
        "rows": rows + 1,
        "log_mib": size,
        "tables_mib": tables,
        "wall_s": min(walls),
        "walls": walls,
        "peak_mib": max(peaks),
        "stages": stages,
        "staged_wall_s": end - start,
        "staged_peak_mib": staged_peak,
        "peak_after": child.get("peak_mib", {}),
        "offline": offline,
    }


def bench_analyze(quick: bool = False, repeat: int = 3) -> list[Result]:
    """The rows of the end-to-end ``analyze`` benchmark."""
    m = measure(QUICK_ROWS if quick else FULL_ROWS, repeat)
    n = m["rows"]
    walls = ", ".join(f"{w:.2f}" for w in m["walls"])
    rows: list[Result] = [
        (
            "analyze three-tank log · wall (whole process)",
            n,
            m["wall_s"],
            f"≤ {WALL_TARGET_S:g} s",
            m["wall_s"] <= WALL_TARGET_S if not quick else None,
            f"best of {len(m['walls'])} runs ({walls} s); `hybridlog analyze` of a "
            f"{m['log_mib']:.0f} MiB parquet log, `--table-format parquet` "
            f"({m['tables_mib']:.0f} MiB of tables), warm caches",
        ),
        (
            "analyze three-tank log · peak RSS",
            n,
            None,
            f"≤ {RSS_TARGET_MIB:g} MiB",
            m["peak_mib"] <= RSS_TARGET_MIB if not quick else None,
            f"{m['peak_mib']:,.0f} MiB (largest VmHWM of the timed runs)",
        ),
    ]
    offline = m["offline"]
    smooth, imm = min(offline["smooth"]), min(offline["imm"])
    rows.append(
        (
            "analyze three-tank log --estimator imm --smooth · wall",
            n,
            smooth,
            "",
            None,
            f"best of {len(offline['smooth'])} runs "
            f"({', '.join(f'{w:.2f}' for w in offline['smooth'])} s), "
            f"{smooth / imm:.2f}x `--estimator imm` without `--smooth` (best {imm:.2f} s; "
            f"the runs alternate); peak RSS {max(offline['smooth_peak']):,.0f} MiB",
        )
    )
    total = m["staged_wall_s"]
    for stage, seconds in m["stages"].items():
        peak = m["peak_after"].get(stage)
        rows.append(
            (
                f"analyze stage · {stage}",
                None,
                seconds,
                "",
                None,
                (
                    "overlaps the main thread's stages (not in their sum)"
                    if stage.endswith("beside the others)")
                    else f"{seconds / total:.0%} of the timed run's {total:.2f} s"
                )
                + ("" if peak is None else f"; VmHWM {peak:,.0f} MiB after it"),
            )
        )
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.analyze_e2e", description=__doc__)
    parser.add_argument("--quick", action="store_true", help=f"{QUICK_ROWS:,} rows")
    parser.add_argument("--repeat", type=int, default=3, help="timed runs (default 3)")
    args = parser.parse_args(argv)
    print(f"load average {os.getloadavg()[0]:.2f} at start", file=sys.stderr)
    print("| Benchmark | Rows | Time (s) | Target | Met | Notes |")
    print("| --- | ---: | ---: | --- | :-: | --- |")
    for label, n, t, target, met, notes in bench_analyze(args.quick, args.repeat):
        shown = "" if met is None else ("yes" if met else "**NO**")
        print(
            f"| {label} | {'' if n is None else f'{n:,}'} | "
            f"{'–' if t is None else f'{t:.3f}'} | {target} | {shown} | {notes} |"
        )
    print(f"load average {os.getloadavg()[0]:.2f} at the end", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
