"""Speed of the IMM's offline passes (issue 12): the smoother and the Viterbi path.

    .venv/bin/python -m benchmarks.smoothing           # ~1 minute, prints a Markdown table
    .venv/bin/python -m benchmarks.run --only smoothing
    .venv/bin/python -m benchmarks.smoothing --breakdown   # where the time goes (~1 minute)

The built-in three-tank model (3 modes, 3 states, 3 outputs), ``simulate(model,
steps=N-1, seed=1)``, N = 10^6 samples (10^4 with ``--quick``).  Times are
``EstimationResult.runtime_s`` (compiled code only, after a warm-up run that compiles or loads
everything), best of ``repeat``, the three runs interleaved, each run's arrays freed before
the next (so from the second round on the runs write into memory the process has used
before; the ratio's notes give the first round's too):

* ``imm filter``: ``run_imm`` with its defaults (the forward pass alone, keeping nothing);
* ``imm smooth=true``: the forward pass keeping the per-mode store, then the backward pass;
  the notes give the backward pass alone (its steps/s) and the store's size;
* ``imm smooth=true smoother=ec``: the same with expectation correction's backward pass
  (Barber 2006: an RTS step per pair of modes that carries weight, up to ``n_q²`` a sample
  against Kim's ``n_q``, 2.7 predictions and 2.2 steps a sample on this log; the forward pass
  keeps the filtered per-mode estimates in a store of the same size);
* ``imm mode_sequence=viterbi``: the forward pass keeping the store, then the Viterbi path;
* ``imm mode_sequence=kbest``: on N/10 samples, the filter, then the best of 20 mode
  histories each with its own EKF and the EKF along its path (``docs/smoothing.md``); and
  with a beam of 2,000 on 301 samples, whose cost per hypothesis kept should stay about that
  of the beam of 20 (a heap keeps the beam's threshold);
* ``ratio``: smoothing ÷ filtering time (target ≤ 2×), Kim's smoother (the default); and the
  same for ``smoother=ec`` (the opt-in, dearer pass; within the target since its negligible
  weight is ``1e-16``);
* ``first use``: in a fresh interpreter and a cold model cache, the first runs of the filter,
  of ``smooth=true`` and of ``smoother=ec`` on a short log (:data:`FIRST_USE`): the compile
  a user waits for once per model.

``--breakdown`` prints, in one process, the wall time (which, unlike the thread's CPU time,
includes what the host spends backing a virtual machine's memory on its first touch) of the
first touch of three store-sized arrays while the process is young (memory it has not used
before), then (best of 7, the runs interleaved) of the pieces: the forward pass keeping
nothing, keeping a fresh store, and keeping a store whose pages are already touched; the
backward pass alone (its output buffers fresh, as in a run); and the first touch of a fresh
array of the store's size (``np.empty`` then ``fill``) once the process has freed memory it
can reuse.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from hybridlog.estimators.common import ModeStore, packed_width, run_filter
from hybridlog.estimators.filter_options import ImmOptions
from hybridlog.estimators.imm import CODE, ImmSettings, run_imm, transition_matrix
from hybridlog.estimators.result import EstimationResult
from hybridlog.estimators.smoothing import post_process
from hybridlog.model.loader import load_model
from hybridlog.simulate import simulate

RATIO_TARGET = 2.0
"""Smoothing (forward + backward) may take at most this many times the filter's time."""

WIDE_BEAM = 2000
WIDE_STEPS = 300
"""kbest with a wide beam on a short log (the sample log's length): its cost per hypothesis."""

BenchRow = tuple[str, int | None, float | None, str, bool | None, str]
"""(label, steps, seconds, target, met, notes), as ``benchmarks.run`` takes them."""


def _times(result: EstimationResult) -> tuple[float, float]:
    """The run's time and its forward pass's (the same for a run with no offline pass)."""
    extra = result.post_processing
    return result.runtime_s, (extra.filtered.runtime_s if extra else result.runtime_s)


FIRST_USE = """
import json, time
from hybridlog.estimators.filter_options import ImmOptions
from hybridlog.estimators.imm import run_imm
from hybridlog.model.loader import load_model
from hybridlog.simulate import simulate
model = load_model("three_tank_hstf")
signals = simulate(model, steps=99, seed=1).signals(model, source="bench")
seconds = {}
for name, options in (("filter", ImmOptions()), ("kim", ImmOptions(smooth=True)),
                      ("ec", ImmOptions(smooth=True, smoother="ec"))):
    start = time.perf_counter()
    run_imm(model, signals, options)
    seconds[name] = time.perf_counter() - start
print(json.dumps(seconds))
"""
"""A fresh interpreter's first run of the filter, then of ``smooth = true`` (Kim's), then of
``smoother = "ec"``, each on a 100-sample log: what a user waits for the first time a model
is smoothed (each offline pass compiles its forward variant, which keeps the store, and its
backward pass)."""


def bench_first_use() -> BenchRow:
    """Seconds of the first smoothed runs in a cold model cache (:data:`FIRST_USE`)."""
    from benchmarks import child_environment

    with tempfile.TemporaryDirectory(prefix="hybridlog-bench-") as folder:
        env = child_environment(HYBRIDLOG_CACHE_DIR=str(Path(folder) / "hybridlog"))
        done = subprocess.run(
            [sys.executable, "-c", FIRST_USE], env=env, capture_output=True, text=True, check=True
        )
    seconds = json.loads(done.stdout.strip().splitlines()[-1])
    return (
        "smoothing · first use, cold model cache",
        None,
        seconds["kim"] + seconds["ec"],
        "",
        None,
        f"after the filter's first run ({seconds['filter']:.1f} s): smooth=true "
        f"{seconds['kim']:.1f} s, then smoother=ec {seconds['ec']:.1f} s (each compiling its "
        "forward variant and its backward pass; cached afterwards, per model)",
    )


def bench_smoothing(quick: bool, repeat: int) -> list[BenchRow]:
    """The rows of the ``smoothing`` section."""
    model = load_model("three_tank_hstf")
    n = 10**4 if quick else 10**6
    smooth, viterbi = ImmOptions(smooth=True), ImmOptions(mode_sequence="viterbi")
    ec = ImmOptions(smooth=True, smoother="ec")
    warm = simulate(model, steps=99, seed=1).signals(model, source="bench")
    for options in (ImmOptions(), smooth, viterbi, ec):
        run_imm(model, warm, options)  # compile (or load) outside the timed runs
    signals = simulate(model, steps=n - 1, seed=1).signals(model, source="bench")
    steps = n - 1
    # Interleaved (filter, smooth, Viterbi, filter, ...): on a shared machine the three see
    # the same spells of load, and the ratio compares like with like.  Only the times are
    # kept: a run's arrays are freed before the next, so from the second round on each run
    # writes into memory the process has used before, as a batch worker does from its second
    # log on.  The first round's pages are the first touches of a young process (on this
    # virtual machine several times dearer); its ratio is reported beside the best.
    times: list[list[tuple[float, float]]] = [[], [], [], []]
    for _ in range(repeat):
        for row, options in zip(times, (ImmOptions(), smooth, viterbi, ec), strict=True):
            row.append(_times(run_imm(model, signals, options)))
    best = [min(r) for r in times]
    (filter_s, _), (smooth_s, forward), (viterbi_s, viterbi_forward), (ec_s, ec_forward) = best
    first_ratio = times[1][0][0] / times[0][0][0]
    ec_first_ratio = times[3][0][0] / times[0][0][0]
    # kbest on a tenth of the samples: beam · n_q EKF predictions per sample (about 100x the
    # filter's work), timed apart
    kbest = ImmOptions(mode_sequence="kbest")
    run_imm(model, warm, kbest)
    few = simulate(model, steps=n // 10 - 1, seed=1).signals(model, source="bench")
    kbest_s, kbest_forward = min(_times(run_imm(model, few, kbest)) for _ in range(repeat))
    search_s = kbest_s - kbest_forward
    # a wide beam on a short log: each hypothesis kept should cost about what one of the
    # default beam costs (the beam's threshold in a heap: log beam a weight, not beam)
    wide = ImmOptions(mode_sequence="kbest", beam=WIDE_BEAM)
    short = simulate(model, steps=WIDE_STEPS, seed=1).signals(model, source="bench")
    wide_s, wide_forward = min(_times(run_imm(model, short, wide)) for _ in range(repeat))
    per_kept = 1e6 * search_s / ((few.n_samples - 1) * kbest.beam)
    wide_per_kept = 1e6 * (wide_s - wide_forward) / (WIDE_STEPS * WIDE_BEAM)
    backward = smooth_s - forward
    ec_backward = ec_s - ec_forward
    store_mb = 8 * n * model.n_modes * packed_width(model.n_states) / 2**20
    ratio = smooth_s / filter_s
    return [
        ("smoothing · three_tank imm filter", steps, filter_s, "", None, ""),
        (
            "smoothing · three_tank imm smooth=true",
            steps,
            smooth_s,
            "",
            None,
            f"forward pass keeping the store {forward:.3f} s; backward pass alone "
            f"{backward:.3f} s = {steps / backward:,.0f} steps/s; store {store_mb:,.0f} MiB",
        ),
        (
            "smoothing · three_tank imm smooth=true smoother=ec",
            steps,
            ec_s,
            "",
            None,
            f"forward pass keeping the store {ec_forward:.3f} s; expectation correction's "
            f"backward pass alone {ec_backward:.3f} s = {steps / ec_backward:,.0f} steps/s",
        ),
        (
            "smoothing · three_tank imm mode_sequence=viterbi",
            steps,
            viterbi_s,
            "",
            None,
            f"Viterbi alone {viterbi_s - viterbi_forward:.3f} s",
        ),
        (
            f"smoothing · three_tank imm mode_sequence=kbest (beam {kbest.beam})",
            few.n_samples - 1,
            kbest_s,
            "",
            None,
            f"{few.n_samples:,} samples; the search and the EKF along its path alone "
            f"{search_s:.3f} s = {1e6 * search_s / (few.n_samples - 1):.1f} µs/step",
        ),
        (
            f"smoothing · three_tank imm mode_sequence=kbest (beam {WIDE_BEAM:,})",
            WIDE_STEPS,
            wide_s,
            "",
            None,
            f"{1e3 * (wide_s - wide_forward) / WIDE_STEPS:.1f} ms/step: {wide_per_kept:.2f} µs "
            f"a hypothesis kept, against {per_kept:.2f} µs at beam {kbest.beam}",
        ),
        (
            "smoothing · ratio smooth / filter",
            None,
            None,
            f"≤ {RATIO_TARGET:g}×",
            ratio <= RATIO_TARGET,
            f"{ratio:.2f}× (first round, on memory the process had not used: "
            f"{first_ratio:.2f}×; load average {os.getloadavg()[0]:.2f})",
        ),
        (
            "smoothing · ratio smooth (smoother=ec) / filter",
            None,
            None,
            f"≤ {RATIO_TARGET:g}×",
            ec_s / filter_s <= RATIO_TARGET,
            f"{ec_s / filter_s:.2f}× (first round: {ec_first_ratio:.2f}×)",
        ),
        bench_first_use(),
    ]


def breakdown(repeat: int = 7) -> list[tuple[str, float]]:
    """Wall seconds (``time.perf_counter``, best of ``repeat``) of the smoother's pieces."""
    model = load_model("three_tank_hstf")
    n = 10**6
    # First, while the process is young: three store-sized arrays touched one after the
    # other and kept (memory the process has not used before, as in a command-line run).
    shape = (n, model.n_modes, packed_width(model.n_states))
    young: list[float] = []
    kept = []
    for _ in range(3):
        start = time.perf_counter()
        array = np.empty(shape)
        array.fill(0.0)
        young.append(time.perf_counter() - start)
        kept.append(array)
    del kept
    signals = simulate(model, steps=n - 1, seed=1).signals(model, source="bench")
    transitions = transition_matrix(model, ImmOptions(smooth=True))
    touched = ModeStore.allocate(model, n, states=True, likelihoods=False)

    def forward(store: ModeStore) -> EstimationResult:
        return run_filter(
            CODE,
            model,
            signals,
            ImmSettings(transitions, store),
            {},
            jit=True,
            kernel="auto",
            store_covariances=False,
        )

    filtered = forward(touched)  # compiles; touches the store's pages

    def backward() -> None:
        post_process(
            model,
            signals,
            filtered,
            touched,
            transitions,
            smooth=True,
            mode_sequence="argmax",
            jit=True,
        )

    def first_touch() -> None:
        np.empty(touched.states.shape).fill(0.0)

    backward()  # compiles
    pieces: list[tuple[str, Callable[[], object]]] = [
        (
            "forward pass keeping nothing (the filter)",
            lambda: forward(ModeStore.allocate(model, n, states=False, likelihoods=False)),
        ),
        (
            "forward pass keeping a fresh store",
            lambda: forward(ModeStore.allocate(model, n, states=True, likelihoods=False)),
        ),
        ("forward pass keeping a store with its pages touched", lambda: forward(touched)),
        ("backward pass alone (fresh output buffers)", backward),
        (f"first touch of {touched.states.nbytes / 2**20:,.0f} MiB (np.empty, fill)", first_touch),
    ]
    best = [float("inf")] * len(pieces)
    for _ in range(repeat):
        for index, (_, run) in enumerate(pieces):
            start = time.perf_counter()
            run()
            best[index] = min(best[index], time.perf_counter() - start)
    size = f"{8 * np.prod(shape) / 2**20:,.0f} MiB"
    return [
        *(
            (f"first touch of {size}, fresh process, array {i + 1} of 3", t)
            for i, t in enumerate(young)
        ),
        *((label, seconds) for (label, _), seconds in zip(pieces, best, strict=True)),
    ]


def main() -> None:
    """Print the section as a Markdown table (``--breakdown``: the pieces' wall times)."""
    if "--breakdown" in sys.argv[1:]:
        print(f"load average {os.getloadavg()[0]:.2f}")
        for label, piece_s in breakdown():
            print(f"| {label} | {piece_s:.3f} s |")
        print(f"load average {os.getloadavg()[0]:.2f}")
        return
    quick = "--quick" in sys.argv[1:]
    print("| benchmark | steps | time s | steps/s | target | met | notes |")
    print("|---|---|---|---|---|---|---|")
    for label, steps, seconds, target, met, notes in bench_smoothing(quick, 2 if quick else 3):
        rate = f"{steps / seconds:,.0f}" if steps and seconds else ""
        shown = f"{seconds:.3f}" if seconds is not None else ""
        ok = "" if met is None else ("yes" if met else "**NO**")
        print(f"| {label} | {steps or ''} | {shown} | {rate} | {target} | {ok} | {notes} |")


if __name__ == "__main__":
    main()
