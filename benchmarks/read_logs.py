"""Log reading benchmarks: MCAP against rosbags' own loop, CSV rows/s, peak memory.

    .venv/bin/python -m benchmarks.read_logs           # full sizes, prints a Markdown table
    .venv/bin/python -m benchmarks.read_logs --quick   # small sizes (smoke check)
    .venv/bin/python -m benchmarks.run --only read     # the same rows inside the harness

Files (written once into a temporary folder, not timed):

- a ROS 2 CDR MCAP of 10^6 messages -- three ``std_msgs/Float64`` topics ``/u``, ``/y1``,
  ``/y2`` at 100 Hz, zstd chunks with CRCs -- written by ``hybridlog.io.bag_writers``;
- a CSV of 2·10^6 rows ``t, u, y1, y2`` (dt = 10 ms).

Each measurement runs in a fresh child process (one after the other), so that its peak
memory (``VmHWM``, the resident high-water mark) is its own, reported with the mark right
after the imports; the time is the best of ``--repeat`` runs inside it:

- *rosbags loop*: ``AnyReader.messages()`` + ``AnyReader.deserialize`` over every message and
  reading ``.data`` -- the baseline;
- *hybridlog MCAP*: ``load_signals`` of the same file with input ``u`` and outputs ``y1``,
  ``y2``: reading, decoding the three paths and aligning onto the 10 ms grid;
- *hybridlog CSV*: ``load_signals`` of the CSV, the same three signals.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

MCAP_RATIO_TARGET = 0.8
"""hybridlog must read + align at least this fraction of rosbags' messages/s."""
CSV_ROWS_TARGET = 5_000_000
"""CSV rows/s that reading + aligning must reach."""

FULL = {"messages": 1_000_000, "csv_rows": 2_000_000}
QUICK = {"messages": 30_000, "csv_rows": 100_000}
DT = 0.01

Result = tuple[str, int, float, str, bool | None, str]
"""(label, messages or rows, best time in s, target, met, notes), as ``benchmarks.run`` wants."""

_CHILD = r"""
import json, resource, sys, time
from pathlib import Path
kind, path, repeat = sys.argv[1], Path(sys.argv[2]), int(sys.argv[3])

def peak_mib():
    # VmHWM is this process's own high-water mark; ru_maxrss would also count the parent's
    # memory at fork time, which Linux carries across exec.
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024

if kind == "rosbags":
    from rosbags.highlevel import AnyReader
    def once():
        count = 0
        with AnyReader([path]) as reader:
            for connection, _, raw in reader.messages():
                reader.deserialize(raw, connection.msgtype).data
                count += 1
        return count
else:
    from hybridlog.io import load_signals
    def once():
        signals = load_signals(
            path, states=(), inputs=("u",), outputs=("y1", "y2"), mode_ids=("a",), dt=%(dt)r
        )
        return signals.n_samples
imported = peak_mib()
best, count = float("inf"), 0
for _ in range(repeat):
    start = time.perf_counter()
    count = once()
    best = min(best, time.perf_counter() - start)
print(json.dumps({"time_s": best, "count": count, "imports_mib": imported, "peak_mib": peak_mib()}))
"""


def write_files(folder: Path, sizes: dict[str, int]) -> tuple[Path, Path]:
    """The benchmark MCAP and CSV (see the module docstring)."""
    from hybridlog.io.bag_writers import write_log
    from hybridlog.io.writers import write_table

    rows = -(-sizes["messages"] // 3)
    t = np.arange(rows) * DT
    columns = {"t": t, "u": np.sin(t), "y1": np.cos(t), "y2": 0.5 * t}
    mcap = write_log(folder / "bench.mcap", columns)
    n = sizes["csv_rows"]
    t = np.arange(n) * DT
    csv = write_table(
        folder / "bench.csv", {"t": t, "u": np.sin(t), "y1": np.cos(t), "y2": 0.5 * t}
    )
    return mcap, csv


def measure(kind: str, path: Path, repeat: int) -> dict[str, Any]:
    """Run one measurement in a child process and return what it printed."""
    code = _CHILD % {"dt": DT}
    done = subprocess.run(
        [sys.executable, "-c", code, kind, str(path), str(repeat)],
        capture_output=True,
        text=True,
        check=True,
    )
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def bench_read(quick: bool = False, repeat: int = 3) -> list[Result]:
    """The rows of the log-reading benchmark."""
    sizes = QUICK if quick else FULL
    with tempfile.TemporaryDirectory(prefix="hybridlog-bench-") as folder:
        mcap, csv = write_files(Path(folder), sizes)
        messages = 3 * (-(-sizes["messages"] // 3))
        base = measure("rosbags", mcap, repeat)
        ours = measure("hybridlog", mcap, repeat)
        table = measure("hybridlog", csv, repeat)
        mcap_mib = mcap.stat().st_size / 2**20
        csv_mib = csv.stat().st_size / 2**20
    base_rate = messages / base["time_s"]
    our_rate = messages / ours["time_s"]
    ratio = our_rate / base_rate
    rows_rate = sizes["csv_rows"] / table["time_s"]

    def memory(result: dict[str, Any]) -> str:
        return (
            f"peak RSS {result['peak_mib']:,.0f} MiB "
            f"({result['imports_mib']:,.0f} MiB after imports)"
        )

    return [
        (
            "read · rosbags AnyReader loop (MCAP)",
            messages,
            base["time_s"],
            "baseline",
            None,
            f"{base_rate:,.0f} messages/s; messages() + deserialize + .data over all "
            f"{messages:,} messages ({mcap_mib:.0f} MiB file); {memory(base)}",
        ),
        (
            "read · hybridlog MCAP, 3 signals read + aligned",
            messages,
            ours["time_s"],
            f"≥ {MCAP_RATIO_TARGET:.0%} of rosbags' messages/s",
            ratio >= MCAP_RATIO_TARGET,
            f"{our_rate:,.0f} messages/s = {ratio:.2f} × rosbags; {ours['count']:,} grid "
            f"samples; {memory(ours)}",
        ),
        (
            "read · hybridlog CSV, 3 signals read + aligned",
            sizes["csv_rows"],
            table["time_s"],
            f"≥ {CSV_ROWS_TARGET / 1e6:g} M rows/s",
            rows_rate >= CSV_ROWS_TARGET,
            f"{rows_rate:,.0f} rows/s ({csv_mib:.0f} MiB file); {memory(table)}",
        ),
    ]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.read_logs", description=__doc__)
    parser.add_argument("--quick", action="store_true", help="small sizes (smoke check)")
    parser.add_argument("--repeat", type=int, default=3, help="repetitions (default 3)")
    args = parser.parse_args(argv)
    print("| Benchmark | Messages/rows | Time (s) | Target | Met | Notes |")
    print("| --- | ---: | ---: | --- | :-: | --- |")
    for label, n, seconds, target, met, notes in bench_read(args.quick, args.repeat):
        flag = "" if met is None else ("yes" if met else "**NO**")
        print(f"| {label} | {n:,} | {seconds:.3f} | {target} | {flag} | {notes} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
