"""Benchmarks of hybridlog: one command, one Markdown table (see benchmarks/README.md).

    .venv/bin/python -m benchmarks.run            # full run, writes benchmarks/results.md
    .venv/bin/python -m benchmarks.run --quick    # small sizes, smoke check, writes nothing
    .venv/bin/python -m benchmarks.run --only filterpy

Everything runs in this one process (the compile-time rows start child processes on purpose,
one after the other) with ``NUMBA_NUM_THREADS=1`` (set by ``benchmarks/__init__.py`` before
numba is imported).  Times are the best of ``--repeat`` repetitions, measured with
``time.perf_counter``; estimator times are ``EstimationResult.runtime_s`` (the compiled loop
only, no compilation).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
import tomllib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numba
import numpy as np

from benchmarks import child_environment
from hybridlog.estimators.hstf import HstfOptions, run_hstf
from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.model.loader import load_model, parse_model
from hybridlog.signals import AlignedSignals
from hybridlog.simulate import simulate

RESULTS = Path(__file__).resolve().parent / "results.md"
BENCHMARKS = (
    "three_tank",
    "compile",
    "filterpy",
    "clustering",
    "read",
    "analyze",
    "batch",
    "switching_observer",
    "unknown_mode",
    "sliding_mode",
    "smoothing",
)

HSTF_TARGET_S = 3.0
"""10^6 HSTF steps on the three-tank model must take less than this."""
SPEEDUP_TARGET = 300.0
"""hybridlog's IMM must be at least this many times faster per step than FilterPy's."""
AGREEMENT_TARGET = 1e-8
"""Largest allowed |x̂_hybridlog − x̂_FilterPy| on the compared steps."""

# A linear model with three modes, three states, one input and three outputs.  Every A is
# stable (spectral radius < 1) and the modes differ in A, B and C.
LINEAR_THREE_MODE = """
name = "bench_linear_three_mode"
dt = 0.1
states = ["x1", "x2", "x3"]
inputs = ["u"]
outputs = ["y1", "y2", "y3"]
default_estimator = "imm"

[modes.a]
A = [[0.90, 0.10, 0.00], [0.00, 0.80, 0.10], [0.00, 0.00, 0.70]]
B = [[1.0], [0.0], [0.5]]
C = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]

[modes.b]
A = [[0.60, -0.20, 0.00], [0.20, 0.60, 0.00], [0.00, 0.10, 0.90]]
B = [[0.0], [1.0], [0.2]]
C = [[1.0, 0.5, 0.0], [0.0, 1.0, 0.5], [0.5, 0.0, 1.0]]

[modes.c]
A = [[0.95, 0.00, 0.05], [0.10, 0.50, 0.00], [0.00, -0.10, 0.85]]
B = [[0.3], [0.3], [1.0]]
C = [[2.0, 0.0, 0.0], [0.0, 0.5, 0.0], [1.0, 0.0, 1.0]]

[noise]
process = [0.01, 0.02, 0.01]
measurement = [[0.10, 0.02, 0.00], [0.02, 0.10, 0.00], [0.00, 0.00, 0.20]]

[initial]
state = [0.0, 0.0, 0.0]
covariance = 1.0

[transitions]
stay = 0.95

[simulation]
state = [0.5, -0.5, 0.2]
schedule = "a:200,b:200,c:200"

[simulation.inputs]
u = "sin(0.1*t)"
"""

# Run in a child process to time model compilation from a given cache state.  Signals are
# synthetic so that nothing compiles the model before the first estimator call.
CHILD = r"""
import json, time
start = time.perf_counter()
import numpy as np
from hybridlog.estimators.hstf import HstfOptions, run_hstf
from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.model.loader import load_model
from hybridlog.signals import AlignedSignals
out = {"import_s": time.perf_counter() - start}
model = load_model("three_tank_hstf")
n = 1000
signals = AlignedSignals(
    source="bench",
    time=np.arange(n) * model.dt,
    input_names=model.inputs,
    output_names=model.outputs,
    inputs=np.full((n, 1), 20.0),
    outputs=np.array([15.0, 10.0, 10.0]) + np.random.default_rng(0).standard_normal((n, 3)),
)
t = time.perf_counter()
from hybridlog.jit import set_up
set_up()  # numba's own set-up, once per process (analyze does it while reading the log)
out["numba_setup_s"] = time.perf_counter() - t
t = time.perf_counter()
result = run_hstf(model, signals, HstfOptions())
out["hstf_first_call_s"] = time.perf_counter() - t
out["compile_s"] = result.compile_s
t = time.perf_counter()
run_imm(model, signals, ImmOptions())
out["imm_first_call_s"] = time.perf_counter() - t
out["total_s"] = time.perf_counter() - start
print(json.dumps(out))
"""


@dataclass
class Row:
    benchmark: str
    steps: int | None = None
    time_s: float | None = None
    target: str = ""
    met: bool | None = None
    notes: str = ""

    @property
    def us_per_step(self) -> float | None:
        if self.steps is None or self.time_s is None:
            return None
        return self.time_s / self.steps * 1e6

    @property
    def steps_per_s(self) -> float | None:
        if self.steps is None or not self.time_s:
            return None
        return self.steps / self.time_s


@dataclass(frozen=True)
class Sizes:
    three_tank: tuple[int, ...]
    filterpy_steps: int
    hybridlog_steps: int


FULL = Sizes(three_tank=(10**5, 10**6), filterpy_steps=2_000, hybridlog_steps=10**6)
QUICK = Sizes(three_tank=(10**3, 10**4), filterpy_steps=200, hybridlog_steps=10**4)


def signals_for(model: HybridModel, n_samples: int, seed: int) -> AlignedSignals:
    """``n_samples`` simulated rows (``n_samples − 1`` filter steps)."""
    return simulate(model, steps=n_samples - 1, seed=seed).signals(model, source="bench")


def best_runtime(
    run: Callable[..., Any], model: HybridModel, signals: AlignedSignals, options: Any, repeat: int
) -> float:
    """Best ``runtime_s`` of ``repeat`` runs of the estimator ``run``."""
    return min(run(model, signals, options).runtime_s for _ in range(repeat))


# --------------------------------------------------------------------------------------------
# 1. three-tank throughput


def bench_three_tank(sizes: Sizes, repeat: int) -> list[Row]:
    model = load_model("three_tank_hstf")
    estimators: list[tuple[str, Callable[..., Any], Any]] = [
        ("hstf", run_hstf, HstfOptions()),
        ("imm", run_imm, ImmOptions()),
    ]
    warm_up = signals_for(model, 100, seed=1)
    for _, run, options in estimators:
        run(model, warm_up, options)  # compile (or load) outside the timed runs
    rows = []
    for n in sizes.three_tank:
        signals = signals_for(model, n, seed=1)
        for name, run, options in estimators:
            best = best_runtime(run, model, signals, options, repeat)
            row = Row(f"three_tank_hstf · {name}", steps=n - 1, time_s=best)
            if name == "hstf" and n == 10**6:
                row.target = f"10^6 steps < {HSTF_TARGET_S:g} s"
                row.met = best < HSTF_TARGET_S
            rows.append(row)
    # y2 at half the rate (every other row not measured): the accelerators' masked code,
    # which updates on the measured outputs alone, against the same log fully measured
    n = max(sizes.three_tank)
    signals = signals_for(model, n, seed=1)
    unmeasured = np.zeros(signals.outputs.shape, dtype=bool)
    unmeasured[1::2, 1] = True
    half = replace(signals, unmeasured_outputs=unmeasured)
    for name, run, options in estimators:
        run(model, replace(warm_up, unmeasured_outputs=unmeasured[:100]), options)
        full = best_runtime(run, model, signals, options, repeat)
        best = best_runtime(run, model, half, options, repeat)
        rows.append(
            Row(
                f"three_tank_hstf · {name}, y2 at half rate",
                steps=n - 1,
                time_s=best,
                notes=f"{best / full:.2f}× the fully measured log's {full:.3f} s",
            )
        )
    return rows


# --------------------------------------------------------------------------------------------
# 2. compile time


def run_child(env_overrides: dict[str, str]) -> tuple[dict[str, float], float]:
    """Run :data:`CHILD` in a fresh interpreter; its JSON and the wall time of the process."""
    env = child_environment(**env_overrides)
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", CHILD], env=env, capture_output=True, text=True, check=False
    )
    wall = time.perf_counter() - start
    if done.returncode != 0:
        raise RuntimeError(f"compile-time child failed:\n{done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1]), wall


def compile_row(label: str, child: dict[str, float], wall: float) -> Row:
    notes = (
        f"process wall {wall:.2f} s (imports {child['import_s']:.2f} s, numba's set-up "
        f"{child['numba_setup_s']:.2f} s, first run_hstf "
        f"{child['hstf_first_call_s']:.2f} s, first run_imm {child['imm_first_call_s']:.2f} s)"
    )
    return Row(f"compile · {label}", time_s=child["compile_s"], notes=notes)


def bench_compile() -> list[Row]:
    rows = []
    with tempfile.TemporaryDirectory(prefix="hybridlog-bench-") as folder:
        model_cache = str(Path(folder) / "hybridlog")
        child, wall = run_child({"HYBRIDLOG_CACHE_DIR": model_cache})
        rows.append(compile_row("cold model cache", child, wall))
        child, wall = run_child({"HYBRIDLOG_CACHE_DIR": model_cache})
        row = compile_row("warm model cache", child, wall)
        row.target = "≈ 0 s"
        row.met = child["compile_s"] < 0.5
        rows.append(row)
        # Also cold numba cache: the estimator kernels (compiled on first use, normally
        # cached in the package's __pycache__) are compiled again, inside the first calls.
        child, wall = run_child(
            {
                "HYBRIDLOG_CACHE_DIR": str(Path(folder) / "hybridlog-2"),
                "NUMBA_CACHE_DIR": str(Path(folder) / "numba"),
            }
        )
        rows.append(compile_row("cold model + kernel caches", child, wall))
    return rows


# --------------------------------------------------------------------------------------------
# 3. FilterPy comparison


def filterpy_imm(model: HybridModel) -> Any:
    """FilterPy's IMM with one KalmanFilter per mode, built from the same TOML numbers."""
    from filterpy.kalman import IMMEstimator, KalmanFilter

    spec = tomllib.loads(LINEAR_THREE_MODE)
    filters = []
    for mode in model.modes:
        matrices = spec["modes"][mode.id]
        kf = KalmanFilter(dim_x=model.n_states, dim_z=model.n_outputs, dim_u=model.n_inputs)
        kf.F = np.array(matrices["A"], dtype=float)
        kf.B = np.array(matrices["B"], dtype=float)
        kf.H = np.array(matrices["C"], dtype=float)
        kf.Q = mode.process_noise.copy()
        kf.R = mode.measurement_noise.copy()
        kf.x = model.initial_state.reshape(-1, 1).copy()
        kf.P = model.initial_covariance.copy()
        filters.append(kf)
    assert model.transitions is not None
    return IMMEstimator(filters, model.initial_mode_probabilities.copy(), model.transitions.copy())


def run_filterpy(
    model: HybridModel, signals: AlignedSignals, n: int
) -> tuple[float, np.ndarray, np.ndarray]:
    """Seconds for ``n − 1`` FilterPy IMM steps, and the state means / mode probabilities."""
    imm = filterpy_imm(model)
    inputs, outputs = signals.inputs, signals.outputs
    means = np.full((n, model.n_states), np.nan)
    probabilities = np.full((n, model.n_modes), np.nan)
    start = time.perf_counter()
    for k in range(n - 1):
        imm.predict(inputs[k].reshape(-1, 1))
        imm.update(outputs[k + 1])
        means[k + 1] = imm.x.ravel()
        probabilities[k + 1] = imm.mu
    return time.perf_counter() - start, means, probabilities


def bench_filterpy(sizes: Sizes, repeat: int) -> list[Row]:
    model = parse_model(LINEAR_THREE_MODE, origin="benchmarks/run.py")
    n_fp = sizes.filterpy_steps
    signals = signals_for(model, sizes.hybridlog_steps, seed=7)
    run_imm(model, signals_for(model, 100, seed=7), ImmOptions())  # compile outside the timing

    fp_times, fp_means, fp_probabilities = [], None, None
    for _ in range(repeat):
        seconds, fp_means, fp_probabilities = run_filterpy(model, signals, n_fp)
        fp_times.append(seconds)
    fp_best = min(fp_times)

    result = run_imm(model, signals, ImmOptions())
    hl_best = min(result.runtime_s, best_runtime(run_imm, model, signals, ImmOptions(), repeat))
    assert fp_means is not None and fp_probabilities is not None
    dx = float(np.max(np.abs(result.state_means[1:n_fp] - fp_means[1:n_fp])))
    dmu = float(np.max(np.abs(result.mode_probabilities[1:n_fp] - fp_probabilities[1:n_fp])))
    switches = len(set(result.modes[:n_fp].tolist()))

    fp_row = Row("linear 3-mode · FilterPy IMMEstimator", steps=n_fp - 1, time_s=fp_best)
    hl_row = Row("linear 3-mode · hybridlog imm", steps=sizes.hybridlog_steps - 1, time_s=hl_best)
    assert fp_row.us_per_step is not None and hl_row.us_per_step is not None
    ratio = fp_row.us_per_step / hl_row.us_per_step
    speed_row = Row(
        "linear 3-mode · speed-up hybridlog / FilterPy",
        target=f"≥ {SPEEDUP_TARGET:g}×",
        met=ratio >= SPEEDUP_TARGET,
        notes=f"{ratio:,.0f}× (µs/step ratio)",
    )
    agree_row = Row(
        "linear 3-mode · agreement with FilterPy",
        steps=n_fp - 1,
        target=f"max abs Δx̂ ≤ {AGREEMENT_TARGET:g}",
        met=dx <= AGREEMENT_TARGET,
        notes=(
            f"max abs Δx̂ = {dx:.1e}, max abs Δμ = {dmu:.1e} over the first {n_fp - 1} steps "
            f"({switches} distinct estimated modes)"
        ),
    )
    return [fp_row, hl_row, speed_row, agree_row]


# --------------------------------------------------------------------------------------------
# report


def fmt(value: float | None, spec: str) -> str:
    return "–" if value is None else format(value, spec)


def table(rows: Sequence[Row]) -> str:
    lines = [
        "| Benchmark | Steps | Time (s) | µs/step | Steps/s | Target | Met | Notes |",
        "| --- | ---: | ---: | ---: | ---: | --- | :-: | --- |",
    ]
    for row in rows:
        met = "" if row.met is None else ("yes" if row.met else "**NO**")
        lines.append(
            f"| {row.benchmark} | {fmt(row.steps, ',')} | {fmt(row.time_s, '.3f')} "
            f"| {fmt(row.us_per_step, '.3f')} | {fmt(row.steps_per_s, ',.0f')} "
            f"| {row.target} | {met} | {row.notes} |"
        )
    return "\n".join(lines)


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def header(argv: Sequence[str], repeat: int, load: float) -> str:
    import filterpy

    command = " ".join(["python -m benchmarks.run", *argv])
    return "\n".join(
        [
            "# hybridlog benchmark results",
            "",
            f"- Date: {dt.datetime.now(dt.UTC).strftime('%Y-%m-%d %H:%M UTC')}",
            f"- Command: `{command}`",
            f"- CPU: {cpu_model()} ({os.cpu_count()} logical CPUs; load average {load:.2f} "
            "at start)",
            f"- Python {platform.python_version()}, numba {numba.__version__}, numpy "
            f"{np.__version__}, filterpy {filterpy.__version__}",
            f"- One process, `NUMBA_NUM_THREADS={numba.config.NUMBA_NUM_THREADS}` (the estimator "
            "kernels are single-threaded anyway); times are the best of "
            f"{repeat} repetitions (`time.perf_counter`); estimator times are "
            "`EstimationResult.runtime_s`, compilation excluded.",
        ]
    )


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.run", description=__doc__)
    parser.add_argument("--quick", action="store_true", help="small sizes (smoke check)")
    parser.add_argument(
        "--only",
        action="append",
        choices=BENCHMARKS,
        metavar="NAME",
        help=f"run only this benchmark (repeatable; one of {', '.join(BENCHMARKS)})",
    )
    parser.add_argument("--repeat", type=int, default=None, help="repetitions (default 3; 2 quick)")
    parser.add_argument(
        "--output",
        type=Path,
        default=None,
        help="Markdown file to write (default: benchmarks/results.md for a full run; "
        "--quick and --only runs write nothing unless this is given)",
    )
    raw = list(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(raw)
    sizes = QUICK if args.quick else FULL
    repeat = args.repeat or (2 if args.quick else 3)
    selected = args.only or list(BENCHMARKS)
    output = args.output
    if output is None and not args.quick and not args.only:
        output = RESULTS

    load = os.getloadavg()[0]
    rows: list[Row] = []
    for name in BENCHMARKS:
        if name not in selected:
            continue
        print(f"running {name} ...", file=sys.stderr, flush=True)
        if name == "three_tank":
            rows += bench_three_tank(sizes, repeat)
        elif name == "compile":
            rows += bench_compile()
        elif name == "clustering":
            from benchmarks.clustering import bench_clustering

            rows += [
                Row(
                    label, steps=n, time_s=t, target=target, met=met, notes=f"{n:,} points; {notes}"
                )
                for label, n, t, target, met, notes in bench_clustering(args.quick)
            ]
        elif name == "sliding_mode":
            from benchmarks.sliding_mode import bench_sliding_mode

            rows += [
                Row(label, steps=n, time_s=t, target=target, met=met, notes=notes)
                for label, n, t, target, met, notes in bench_sliding_mode(args.quick, repeat)
            ]
        elif name == "batch":
            from benchmarks.batch import bench_batch

            rows += [
                Row(label, time_s=t, target=target, met=met, notes=notes)  # logs, not steps
                for label, _, t, target, met, notes in bench_batch(args.quick, repeat)
            ]
        elif name == "read":
            from benchmarks.read_logs import bench_read

            rows += [
                Row(label, steps=n, time_s=t, target=target, met=met, notes=notes)
                for label, n, t, target, met, notes in bench_read(args.quick, repeat)
            ]
        elif name == "unknown_mode":
            from benchmarks.unknown_mode import bench_unknown_mode

            rows += [
                Row(label, steps=n, time_s=t, target=target, met=met, notes=notes)
                for label, n, t, target, met, notes in bench_unknown_mode(args.quick, repeat)
            ]
        elif name == "smoothing":
            from benchmarks.smoothing import bench_smoothing

            rows += [
                Row(label, steps=n, time_s=t, target=target, met=met, notes=notes)
                for label, n, t, target, met, notes in bench_smoothing(args.quick, repeat)
            ]
        elif name == "analyze":
            from benchmarks.analyze_e2e import bench_analyze

            rows += [
                Row(label, steps=n, time_s=t, target=target, met=met, notes=notes)
                for label, n, t, target, met, notes in bench_analyze(args.quick, repeat)
            ]
        elif name == "switching_observer":
            from benchmarks.switching_observer import bench_switching_observer

            rows += [
                Row(label, steps=n, time_s=t, target=target, met=met, notes=notes)
                for label, n, t, target, met, notes in bench_switching_observer(args.quick, repeat)
            ]
        else:
            rows += bench_filterpy(sizes, repeat)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    rows.append(
        Row(
            "peak memory (ru_maxrss)",
            notes=f"{peak:,.0f} MiB this process"
            + (f"; largest child {children:,.0f} MiB" if children else ""),
        )
    )

    text = f"{header(raw, repeat, load)}\n\n{table(rows)}\n"
    print(text)
    if output is not None:
        output.write_text(text, encoding="utf-8")
        print(f"wrote {output}", file=sys.stderr)
    failed = [row.benchmark for row in rows if row.met is False]
    if failed:
        print(f"targets missed: {', '.join(failed)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
