"""Log reading benchmarks: hybridlog's read + align against rosbags' own loop, CSV rows/s, memory.

    .venv/bin/python -m benchmarks.read_logs           # full sizes, prints a Markdown table
    .venv/bin/python -m benchmarks.read_logs --quick   # small sizes (smoke check)
    .venv/bin/python -m benchmarks.run --only read     # the same rows inside the harness

Files (written once into a temporary folder, not timed):

- two ROS 2 CDR MCAP files of 10^6 messages each, three topics ``/u``, ``/y1``, ``/y2`` at
  100 Hz, zstd chunks: one of ``std_msgs/Float64`` (written by ``hybridlog.io.bag_writers``,
  with CRCs) and one of ``geometry_msgs/PointStamped`` (a struct with a header and a string,
  written with the ``mcap`` writer);
- a CSV of 2·10^6 rows ``t, u, y1, y2`` (dt = 10 ms).

Each measurement runs in a fresh child process (one after the other), so that its peak
memory (``VmHWM``, the resident high-water mark) is its own, reported with the mark right
after the imports; the time is the best of ``--repeat`` runs inside it, and the notes give the
wall time of the whole child process (interpreter start, imports, every repetition):

- *rosbags loop*: ``AnyReader.messages()`` + ``AnyReader.deserialize`` over every message and
  reading the field -- rosbags' own way to read the file;
- *hybridlog*: ``load_signals`` with input ``u`` and outputs ``y1``, ``y2`` (``.data`` or
  ``.point.x``): reading, deserialising every message of the three topics with rosbags'
  deserialiser, reading the paths and aligning onto the 10 ms grid;
- *hybridlog CSV*: ``load_signals`` of the CSV, the same three signals.

A hand-written decoder that read the paths straight from the serialised bytes was measured
here before it was removed: 1.15x the rosbags loop on ``Float64`` (whole process 1.30x of
hybridlog with rosbags' deserialiser), 2.1x on ``PointStamped`` -- not the 2x everywhere that
code re-implementing rosbags' size checks would have to earn.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks import child_environment

MCAP_RATIO_TARGET = 0.8
"""hybridlog must read + align at least this fraction of rosbags' messages/s."""
CSV_ROWS_TARGET = 5_000_000
"""CSV rows/s that reading + aligning must reach."""

FULL = {"messages": 1_000_000, "csv_rows": 2_000_000}
QUICK = {"messages": 30_000, "csv_rows": 100_000}
DT = 0.01
TYPES = {"Float64": ("std_msgs/msg/Float64", ".data"), "PointStamped": (
    "geometry_msgs/msg/PointStamped", ".point.x")}  # fmt: skip

Result = tuple[str, int, float, str, bool | None, str]
"""(label, messages or rows, best time in s, target, met, notes), as ``benchmarks.run`` wants."""

_CHILD = r"""
import json, resource, sys, time
from pathlib import Path
kind, path, field, repeat = sys.argv[1], Path(sys.argv[2]), sys.argv[3], int(sys.argv[4])

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
    from operator import attrgetter
    from rosbags.highlevel import AnyReader
    get = attrgetter(field[1:])
    def once():
        count = 0
        with AnyReader([path]) as reader:
            for connection, _, raw in reader.messages():
                get(reader.deserialize(raw, connection.msgtype))
                count += 1
        return count
else:
    import importlib
    from hybridlog.io import ReadOptions, SignalSpec, load_signals
    from hybridlog.io.formats import log_format
    # Readers are imported when a log of their format is first opened: import it here, as
    # rosbags' reader is imported above, so that the times below are reading alone.
    importlib.import_module(log_format(path).reader.partition(":")[0])
    maps = () if field == "-" else (f"u=/u{field}", f"y1=/y1{field}", f"y2=/y2{field}")
    spec = SignalSpec(inputs=("u",), outputs=("y1", "y2"), mode_ids=("a",), dt=%(dt)r)
    def once():
        signals = load_signals(path, spec, ReadOptions(maps=maps))
        return signals.n_samples
imported = peak_mib()
best, count = float("inf"), 0
for _ in range(repeat):
    start = time.perf_counter()
    count = once()
    best = min(best, time.perf_counter() - start)
print(json.dumps({"time_s": best, "count": count, "imports_mib": imported, "peak_mib": peak_mib()}))
"""


def write_points(path: Path, rows: int) -> Path:
    """The ``PointStamped`` MCAP: three topics, ``rows`` messages each (see the docstring)."""
    from mcap.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.LATEST)
    types = store.types
    msgtype = "geometry_msgs/msg/PointStamped"
    definition = store.generate_msgdef(msgtype, ros_version=2)[0].encode()
    with path.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile="ros2", library="benchmarks")
        schema = writer.register_schema(msgtype, "ros2msg", definition)
        channels = [writer.register_channel(t, "cdr", schema) for t in ("/u", "/y1", "/y2")]
        for k in range(rows):
            t_ns = k * 10_000_000
            stamp = types["builtin_interfaces/msg/Time"](sec=t_ns // 10**9, nanosec=t_ns % 10**9)
            header = types["std_msgs/msg/Header"](stamp=stamp, frame_id="map")
            for j, channel in enumerate(channels):
                point = types["geometry_msgs/msg/Point"](x=float(k + j), y=0.5, z=-1.0)
                message = types[msgtype](header=header, point=point)
                data = bytes(store.serialize_cdr(message, msgtype))
                writer.add_message(channel, t_ns, data, t_ns)
        writer.finish()
    return path


def write_files(folder: Path, sizes: dict[str, int]) -> dict[str, Path]:
    """The benchmark files (see the module docstring)."""
    from hybridlog.io.bag_writers import write_log
    from hybridlog.io.writers import write_table

    rows = -(-sizes["messages"] // 3)
    t = np.arange(rows) * DT
    columns = {"t": t, "u": np.sin(t), "y1": np.cos(t), "y2": 0.5 * t}
    floats = write_log(folder / "floats.mcap", columns)
    points = write_points(folder / "points.mcap", rows)
    n = sizes["csv_rows"]
    t = np.arange(n) * DT
    csv = write_table(
        folder / "bench.csv", {"t": t, "u": np.sin(t), "y1": np.cos(t), "y2": 0.5 * t}
    )
    return {"Float64": floats, "PointStamped": points, "csv": csv}


def measure(kind: str, path: Path, field: str, repeat: int) -> dict[str, Any]:
    """Run one measurement in a child process and return what it printed (+ its wall time)."""
    code = _CHILD % {"dt": DT}
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", code, kind, str(path), field, str(repeat)],
        env=child_environment(),
        capture_output=True,
        text=True,
        check=True,
    )
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    result["process_s"] = time.perf_counter() - start
    return result


def _memory(result: dict[str, Any]) -> str:
    return (
        f"peak RSS {result['peak_mib']:,.0f} MiB ({result['imports_mib']:,.0f} MiB after "
        f"imports); whole process {result['process_s']:.2f} s"
    )


def bench_read(quick: bool = False, repeat: int = 3) -> list[Result]:
    """The rows of the log-reading benchmark."""
    sizes = QUICK if quick else FULL
    messages = 3 * (-(-sizes["messages"] // 3))
    rows: list[Result] = []
    with tempfile.TemporaryDirectory(prefix="hybridlog-bench-") as folder:
        files = write_files(Path(folder), sizes)
        for name, (_, field) in TYPES.items():
            path = files[name]
            mib = path.stat().st_size / 2**20
            base = measure("rosbags", path, field, repeat)
            ours = measure("hybridlog", path, field, repeat)
            base_rate = messages / base["time_s"]
            ratio = base["time_s"] / ours["time_s"]
            rows += [
                (
                    f"read {name} · rosbags AnyReader loop",
                    messages,
                    base["time_s"],
                    "baseline",
                    None,
                    f"{base_rate:,.0f} messages/s; messages() + deserialize + {field} over all "
                    f"{messages:,} messages ({mib:.0f} MiB file); {_memory(base)}",
                ),
                (
                    f"read {name} · hybridlog read + align",
                    messages,
                    ours["time_s"],
                    f"≥ {MCAP_RATIO_TARGET:.0%} of rosbags' messages/s",
                    ratio >= MCAP_RATIO_TARGET,
                    f"{messages / ours['time_s']:,.0f} messages/s = {ratio:.2f} × rosbags; "
                    f"{ours['count']:,} grid samples; {_memory(ours)}",
                ),
            ]
        table = measure("hybridlog", files["csv"], "-", repeat)
        csv_mib = files["csv"].stat().st_size / 2**20
    rows_rate = sizes["csv_rows"] / table["time_s"]
    rows.append(
        (
            "read CSV · hybridlog, 3 signals read + aligned",
            sizes["csv_rows"],
            table["time_s"],
            f"≥ {CSV_ROWS_TARGET / 1e6:g} M rows/s",
            rows_rate >= CSV_ROWS_TARGET,
            f"{rows_rate:,.0f} rows/s ({csv_mib:.0f} MiB file); {_memory(table)}",
        )
    )
    return rows


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
