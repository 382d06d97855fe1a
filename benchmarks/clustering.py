"""Scale of subtractive clustering (paper 001): approximate, exact, naive, MATLAB port.

    .venv/bin/python -m benchmarks.clustering           # ~2 minutes, prints a Markdown table
    .venv/bin/python -m benchmarks.run --only clustering

Every case runs in a fresh child process on one core (``NUMBA_NUM_THREADS=1``, one BLAS
thread) and reports its wall time and its own peak resident memory (``VmHWM``); the
compiled kernels are warmed (and cached) by a small run inside the child before the timing.
Data: a mixture of four anisotropic Gaussian blobs in ``d`` dimensions (fixed seed),
r_a = 0.5, MATLAB defaults otherwise.

Rows: the approximate (grid) mode in 2-D and 3-D at 10^5 and 10^6 points (target at 10^6
in 3-D: < 2 s, < 500 MB); the exact mode at 10^5 points in 3-D (target < 15 s, memory
independent of N²) and 6-D (where no grid is fine enough: the three-tank model's φ(k)); the
exact mode at 10^6 points in 6-D *estimated* as ``hybridlog cluster`` estimates it, from
the pair rate of its first steps (about 10 s of them) times all ``N(N-1)/2`` pairs (a full
run takes a quarter of an hour); the naive all-pairs NumPy port
(:mod:`hybridlog.cluster.reference`, 8·N² bytes) at 10^4 points; and the pure-Python
MATLAB port of the ``fuzzy-logic-toolbox`` package (``fuzzy_logic.clustering``) at 2,000
points when ``$HYBRIDLOG_FLT_PATH`` names a folder holding it.  It is not a dependency, and
it must not be installed into the venv: its wheel ships a top-level ``tests`` package that
shadows this repository's ``tests``.  To include it::

    .venv/bin/pip install --no-deps --target /tmp/flt fuzzy-logic-toolbox
    HYBRIDLOG_FLT_PATH=/tmp/flt .venv/bin/python -m benchmarks.clustering
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import dataclass

from benchmarks import child_environment

APPROX_N = 10**6
APPROX_TARGET_S = 2.0
APPROX_MEMORY_MB = 500.0
EXACT_N = 10**5
EXACT_TARGET_S = 15.0
NAIVE_N = 10_000
PORT_N = 2_000
ESTIMATE_S = 10.0

CHILD = r"""
import json, sys, time
import numpy as np
def peak_mb():
    # VmHWM is this process's own high-water mark; ru_maxrss would also count what the
    # forked parent had resident before exec.
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
kind, n, d = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rng = np.random.default_rng(0)
def data(n, d):
    centres = np.array([[0, 0, 0], [3, 1, 0], [0, 3, 2], [2, 2, 2]], float)
    scales = np.array([[0.5, 0.3, 0.3], [0.3, 0.6, 0.3], [0.4, 0.4, 0.2], [0.6, 0.6, 0.6]])
    columns = np.arange(d) % 3  # 3-D: as it always was; 6-D: each axis twice, noise apart
    centres, scales = centres[:, columns], scales[:, columns]
    labels = rng.integers(0, 4, n)
    return centres[labels] + rng.standard_normal((n, d)) * scales[labels]
points = data(n, d)
before = peak_mb()
result = {}
if kind == "estimate":
    from hybridlog.cluster.potentials import exact_potential_rows, exact_potentials
    from hybridlog.cluster.subtractive import unit_box
    scaled = np.ascontiguousarray((unit_box(points)[0] / 0.5).T)
    exact_potentials(scaled[:, :2000])  # compile or load the kernel
    steps = exact_potential_rows(scaled, np.empty(n))
    first, total = next(steps)
    start = time.perf_counter()
    for done, _ in steps:
        if time.perf_counter() - start >= float(sys.argv[4]):
            break
    elapsed = time.perf_counter() - start
    result["time_s"] = elapsed * (total - first) / (done - first)
    result["centres"] = []
    result["measured"] = [elapsed, done - first, total]
elif kind in ("approximate", "exact"):
    from hybridlog.cluster.subtractive import SubtractiveOptions, subtractive_clustering
    options = SubtractiveOptions(radius=0.5, method=kind)
    subtractive_clustering(points[:2000], options)  # compile or load the kernels
    start = time.perf_counter()
    found = subtractive_clustering(points, options)
    result["time_s"] = time.perf_counter() - start
    result["centres"] = found.centers.tolist()
elif kind == "naive":
    from hybridlog.cluster.reference import naive_subtractive_clustering
    start = time.perf_counter()
    indices, _ = naive_subtractive_clustering(points, 0.5)
    result["time_s"] = time.perf_counter() - start
    result["centres"] = points[indices].tolist()
else:
    from fuzzy_logic.clustering import SubtractClustering
    start = time.perf_counter()
    centres, _ = SubtractClustering(points.T.copy(), np.array([0.5] * d))()
    result["time_s"] = time.perf_counter() - start
    result["centres"] = np.asarray(centres).T.tolist()
result["peak_mb"] = peak_mb()
result["baseline_mb"] = before
print(json.dumps(result))
"""


@dataclass
class Case:
    label: str
    kind: str
    n: int
    dimensions: int = 3
    time_s: float | None = None
    peak_mb: float | None = None
    centres: list[list[float]] | None = None
    measured: list[float] | None = None
    note: str = ""


def run_case(case: Case, seconds: float = ESTIMATE_S) -> Case:
    env = child_environment(NUMBA_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    if case.kind == "port":
        env["PYTHONPATH"] = os.pathsep.join(
            p for p in (os.environ.get("HYBRIDLOG_FLT_PATH", ""), env.get("PYTHONPATH", "")) if p
        )
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            CHILD,
            case.kind,
            str(case.n),
            str(case.dimensions),
            str(seconds),
        ],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        case.note = done.stderr.strip().splitlines()[-1] if done.stderr.strip() else "failed"
        return case
    out = json.loads(done.stdout.strip().splitlines()[-1])
    case.time_s, case.peak_mb, case.centres = out["time_s"], out["peak_mb"], out["centres"]
    case.measured = out.get("measured")
    return case


def has_port() -> bool:
    folder = os.environ.get("HYBRIDLOG_FLT_PATH", "")
    return bool(folder) and os.path.isfile(os.path.join(folder, "fuzzy_logic", "clustering.py"))


def bench_clustering(
    quick: bool = False,
) -> list[tuple[str, int, float | None, str, bool | None, str]]:
    """Rows ``(benchmark, points, time, target, met, notes)``."""
    scale = 10 if quick else 1
    cases = [
        Case(f"subtractive · approximate (grid), {d}-D", "approximate", n // scale, d)
        for d in (2, 3)
        for n in (APPROX_N // 10, APPROX_N)
    ]
    cases += [
        Case("subtractive · exact (compiled, blocked), 3-D", "exact", EXACT_N // scale, 3),
        Case("subtractive · exact (compiled, blocked), 6-D", "exact", EXACT_N // scale, 6),
        Case(
            "subtractive · exact, 6-D, estimated from its first steps",
            "estimate",
            10 * EXACT_N // scale,
            6,
        ),
        Case("subtractive · naive all-pairs NumPy, 3-D", "naive", NAIVE_N // scale, 3),
    ]
    if has_port():
        cases.append(Case("subtractive · fuzzy-logic-toolbox port", "port", PORT_N // scale))
    rows = []
    for case in cases:
        run_case(case, ESTIMATE_S / scale)
        target, met = "", None
        if case.kind == "approximate" and case.n == APPROX_N and case.dimensions == 3:
            target = f"< {APPROX_TARGET_S:g} s, < {APPROX_MEMORY_MB:g} MB"
            met = (
                case.time_s is not None
                and case.peak_mb is not None
                and case.time_s < APPROX_TARGET_S
                and case.peak_mb < APPROX_MEMORY_MB
            )
        if case.kind == "exact" and case.n == EXACT_N and case.dimensions == 3:
            target = f"< {EXACT_TARGET_S:g} s, memory O(N)"
            met = case.time_s is not None and case.time_s < EXACT_TARGET_S
        notes = case.note or (
            f"peak RSS {case.peak_mb:,.0f} MiB; {len(case.centres or [])} centres"
        )
        if case.kind == "estimate" and case.measured is not None:
            elapsed, pairs, total = case.measured
            notes = (
                f"estimated: {pairs:.3g} of {total:.3g} pairs in {elapsed:.1f} s, "
                f"{pairs / elapsed:.3g} pairs/s; no grid is fine enough in 6-D"
            )
        if case.kind == "naive":
            notes += f"; needs 8·N² bytes: {8 * 40_000**2 / 1e9:.1f} GB at 40,000 points"
        rows.append((case.label, case.n, case.time_s, target, met, notes))
    if not has_port():
        rows.append(
            (
                "subtractive · fuzzy-logic-toolbox port",
                PORT_N,
                None,
                "",
                None,
                "not run: set HYBRIDLOG_FLT_PATH (see benchmarks/clustering.py)",
            )
        )
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    quick = "--quick" in (sys.argv[1:] if argv is None else argv)
    print("| Benchmark | Points | Time (s) | Target | Met | Notes |")
    print("| --- | ---: | ---: | --- | :-: | --- |")
    for label, n, seconds, target, met, notes in bench_clustering(quick):
        shown = "–" if seconds is None else f"{seconds:.3f}"
        flag = "" if met is None else ("yes" if met else "**NO**")
        print(f"| {label} | {n:,} | {shown} | {target} | {flag} | {notes} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
