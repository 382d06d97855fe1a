"""Monte-Carlo study of the HSTF (paper 000) on the paper's hybrid three-tank scenario.

Run from the repository root::

    .venv/bin/python docs/studies/three_tank.py            # 30 seeds (0..29), ~10 s

It simulates the paper's scenario (``three_tank_hstf``: 300 steps, true modes 1/2/3 for 100
steps each, x(0) = [15, 10, 10], u = 20, noise variances 0.5) once per seed and runs

* ``hstf``            the paper's filter, ρ = 0.95, β = 1, θ = 0.95 (faded likelihood, eq. (35));
* ``hstf-unfaded``    named variant: likelihood covariance S_i from λ_i = 1;
* ``imm-0.95``        IMM/EKF baseline, Markov matrix with 0.95 on the diagonal;
* ``imm-0.99``        the same with 0.99;
* ``hstf-nofade``     DIAGNOSTIC only (not the paper's filter): λ_i ≡ 1 everywhere.

All estimators get the paper's (deliberately wrong) prior x̂(0|0) = [20, 5, 10], P(0|0) = 100 I,
Pr(q(0) = 2) = 1.  Nothing of the algorithms is changed here; the "why" section re-runs the
library's own HSTF loop in plain Python (``jit=False``) and records, without altering it, the
arguments of its likelihood evaluation (γ_i and the Cholesky factor of S_i, eq. (34)).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a file: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import hybridlog.estimators.hstf as hstf_module
from hybridlog.estimators import kernels
from hybridlog.estimators.common import noise_stacks
from hybridlog.estimators.filter_options import HstfOptions, ImmOptions
from hybridlog.estimators.hstf import run_hstf
from hybridlog.estimators.imm import run_imm
from hybridlog.estimators.result import EstimationResult
from hybridlog.model.compiled import compile_model
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.model.loader import load_model
from hybridlog.report import metrics, mode_metrics, state_error
from hybridlog.signals import AlignedSignals
from hybridlog.simulate import SimulatedLog, simulate

SEEDS = range(30)
K0 = 20  # "after the initial transient": samples K0..300
SWITCH_ROWS = (101, 201)  # first rows of true modes 2 and 3
BLOCK_END_ROWS = (100, 200, 300)  # last row of each 100-step block
BLOCKS = ((1, 101), (101, 201), (201, 301))  # row ranges of the true modes 1, 2, 3
PAPER = HstfOptions(rho=0.95, beta=1.0, theta=0.95)

Runner = Callable[[HybridModel, AlignedSignals], EstimationResult]
VARIANTS: dict[str, Runner] = {
    "hstf": lambda m, s: run_hstf(m, s, PAPER),
    "hstf-unfaded": lambda m, s: run_hstf(
        m, s, HstfOptions(rho=0.95, beta=1.0, theta=0.95, likelihood="unfaded")
    ),
    "imm-0.95": lambda m, s: run_imm(m, s, ImmOptions()),
    "imm-0.99": lambda m, s: run_imm(m, s, ImmOptions(transition_stay=0.99)),
    "hstf-nofade (diag)": lambda m, s: run_hstf(
        m, s, HstfOptions(rho=0.95, beta=1.0, theta=0.95, fading=False)
    ),
}


def signals_of(model: HybridModel, log: SimulatedLog) -> AlignedSignals:
    """The simulated log as the estimators' input, with its ground truth."""
    return log.signals(model)


def run_metrics(model: HybridModel, log: SimulatedLog, r: EstimationResult) -> dict[str, float]:
    """The study's metrics of one run (NaN delay = switch missed)."""
    truth = log.modes
    out: dict[str, float] = {
        "acc": mode_metrics.mode_accuracy(r.modes, truth),
        f"acc k>={K0}": mode_metrics.mode_accuracy(r.modes[K0:], truth[K0:]),
        # Diagnostic: argmax of the posterior instead of eq. (40)'s θ-threshold hold.
        "argmax acc (diag)": mode_metrics.mode_accuracy(
            np.argmax(r.mode_probabilities[1:], axis=1), truth[1:]
        ),
    }
    rmse = state_error.state_rmse(r.state_means[K0:], log.states[K0:])
    for name, value in zip(model.states, rmse, strict=True):
        out[f"RMSE {name} k>={K0}"] = float(value)
    out["VAF % (mean of y)"] = metrics.mean_where_defined(
        metrics.vaf(log.outputs, r.output_predictions)
    )
    out["Fit % (mean of y)"] = metrics.mean_where_defined(
        metrics.fit(log.outputs, r.output_predictions)
    )
    out["MSE (mean of y)"] = metrics.mean_where_defined(
        metrics.mse(log.outputs, r.output_predictions)
    )
    det = mode_metrics.detection_delays(log.time, r.modes, truth, model.mode_ids)
    for event in det.events:
        key = f"delay {event.from_mode}->{event.to_mode} s"
        out[key] = float("nan") if event.delay_s is None else float(event.delay_s)
    for b, row in enumerate(BLOCK_END_ROWS, start=1):
        out[f"final of block {b} right"] = float(r.modes[row] == truth[row])
    return out


def fmt(values: np.ndarray, key: str) -> str:
    """Mean ± std [min, max] over seeds (a count for the block-final checks)."""
    finite = values[np.isfinite(values)]
    missed = values.size - finite.size
    if finite.size == 0:
        return f"missed {missed}/{values.size}"
    if key.startswith("final"):
        return f"{int(finite.sum())}/{values.size}"
    digits = 1 if ("VAF" in key or "Fit" in key or "MSE" in key or "delay" in key) else 3
    text = (
        f"{finite.mean():.{digits}f} ± {finite.std():.{digits}f} "
        f"[{finite.min():.{digits}f}, {finite.max():.{digits}f}]"
    )
    return text + (f" (missed {missed})" if missed else "")


def summary_table(rows: dict[str, list[dict[str, float]]]) -> str:
    """Markdown table: one row per metric, one column per variant."""
    names = list(rows)
    keys = list(rows[names[0]][0])
    lines = ["| metric | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for key in keys:
        cells = [fmt(np.array([d[key] for d in rows[n]]), key) for n in names]
        lines.append(f"| {key} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# Why: the posterior around the start and the switches, and the fading factors.


def traced_hstf(
    model: HybridModel, sig: AlignedSignals, options: HstfOptions
) -> tuple[EstimationResult, np.ndarray, np.ndarray]:
    """Run the library's HSTF loop as plain Python and record γ_i and S_i of eq. (34).

    Only the module's reference to ``measured_log_density`` is wrapped for the duration of the
    call; the wrapper passes the arguments through and returns the original value.
    Returns the result, γ of shape (N, n_q, m) and S of shape (N, n_q, m, m) (row 0 NaN).
    """
    original = kernels.measured_log_density  # the function hstf imported; mypy checks the name
    records: list[tuple[np.ndarray, np.ndarray]] = []

    def recording(gamma: np.ndarray, L: np.ndarray, work: np.ndarray, left: int) -> float:
        records.append((gamma.copy(), L @ L.T))
        return float(original(gamma, L, work, left))

    setattr(hstf_module, "measured_log_density", recording)  # noqa: B010
    try:
        result = run_hstf(model, sig, options, jit=False, store_covariances=True)
    finally:
        setattr(hstf_module, "measured_log_density", original)  # noqa: B010
    n, n_q, m = sig.n_samples, model.n_modes, model.n_outputs
    if len(records) != (n - 1) * n_q:
        raise RuntimeError("a likelihood was not evaluated (singular S_i?)")
    gamma = np.full((n, n_q, m), np.nan)
    S = np.full((n, n_q, m, m), np.nan)
    gamma[1:] = np.array([g for g, _ in records]).reshape(n - 1, n_q, m)
    S[1:] = np.array([s for _, s in records]).reshape(n - 1, n_q, m, m)
    return result, gamma, S


def fading_factors(
    model: HybridModel, sig: AlignedSignals, r: EstimationResult, S: np.ndarray
) -> np.ndarray:
    """Fading factors λ_i(k+1) recovered from the recorded S_i of the faded likelihood.

    Eqs. (24), (28), (35) give tr S_i = λ_i tr(H̄_i F̄_i P(k|k) F̄_iᵀ H̄_iᵀ) + tr(H̄_i Q H̄_iᵀ) + tr R.
    """
    c = compile_model(model, jit=False)
    Q, R = noise_stacks(model)
    n, n_q, nx, m = sig.n_samples, model.n_modes, model.n_states, model.n_outputs
    lam = np.full((n, n_q), np.nan)
    assert r.covariances is not None
    for k in range(n - 1):
        x, P = r.state_means[k], r.covariances[k]
        u, u_next = sig.inputs[k], sig.inputs[k + 1]
        x_i = np.empty((n_q, nx))
        for i in range(n_q):
            c.f(i, x, u, x_i[i])
        x_pred = x_i.mean(axis=0)  # eq. (21)
        for i in range(n_q):
            F, H = np.empty((nx, nx)), np.empty((m, nx))
            c.F(i, x, u, F)
            c.H(i, x_pred, u_next, H)
            tr_m = np.trace(H @ F @ P @ F.T @ H.T)
            tr_s = np.trace(S[k + 1, i])
            lam[k + 1, i] = (tr_s - np.trace(H @ Q[i] @ H.T) - np.trace(R[i])) / tr_m
    return lam


Runs = list[tuple[SimulatedLog, dict[str, EstimationResult]]]


def why(model: HybridModel, runs: Runs) -> None:
    """Print the diagnostics of the faithful HSTF's mode posterior and fading factors."""
    theta = PAPER.theta
    print("\n## Why (faithful hstf)\n")
    # 1. Does Pr(q=1 | Y^k) ever reach θ while mode 1 is true (k = 1..100)?
    peak1, peak2, hits, hits2, hits_after = [], [], 0, 0, []
    post_true: dict[str, list[list[float]]] = {"hstf": [], "hstf-unfaded": []}
    after_switch: dict[str, list[np.ndarray]] = {"hstf": [], "hstf-unfaded": []}
    for log, results in runs:
        for name in post_true:
            r = results[name]
            p_true = r.mode_probabilities[np.arange(log.modes.size), log.modes]
            post_true[name].append([float(p_true[a:b].mean()) for a, b in BLOCKS])
            after_switch[name].append(
                np.array([p_true[s : s + 10] for s in SWITCH_ROWS])  # k = s..s+9
            )
            if name == "hstf":
                p1 = r.mode_probabilities[1:101, 0]
                peak1.append(p1.max())
                peak2.append(p1[1:].max())
                hits += bool(p1.max() >= theta)
                hits2 += bool(p1[1:].max() >= theta)
                best = r.mode_probabilities[1:].max(axis=1)
                hits_after.append(int(np.count_nonzero(best >= theta)))
    print(
        f"max_k Pr(q(k)=1|Y^k) over k=1..100: {np.mean(peak1):.3f} ± {np.std(peak1):.3f} "
        f"[{np.min(peak1):.3f}, {np.max(peak1):.3f}]; >= θ={theta} in {hits}/{len(peak1)} seeds"
    )
    print(
        f"  the same over k=2..100: {np.mean(peak2):.3f} ± {np.std(peak2):.3f} "
        f"[{np.min(peak2):.3f}, {np.max(peak2):.3f}]; >= θ in {hits2}/{len(peak2)} seeds"
    )
    print(
        f"samples k=1..300 where any mode's posterior >= θ (so eq. (40) may change q̂): "
        f"{np.mean(hits_after):.1f} ± {np.std(hits_after):.1f} of 300 "
        f"[{np.min(hits_after)}, {np.max(hits_after)}]"
    )
    print("\nmean posterior of the TRUE mode per block (mean over seeds):\n")
    print("| variant | k=1..100 (mode 1) | k=101..200 (mode 2) | k=201..300 (mode 3) |")
    print("|---|---|---|---|")
    for name, values in post_true.items():
        a = np.array(values).mean(axis=0)
        print(f"| {name} | {a[0]:.3f} | {a[1]:.3f} | {a[2]:.3f} |")
    print("\nposterior of the new true mode at k = s..s+9 after each switch (mean over seeds):\n")
    for name, windows in after_switch.items():
        a = np.array(windows).mean(axis=0)
        for j, s in enumerate(SWITCH_ROWS):
            print(f"  {name:13s} k={s}..{s + 9}: " + " ".join(f"{v:.2f}" for v in a[j]))

    # 2. Scale bias of the combined state estimate per block (all seeds).
    print("\nstate scale per block, Σ_k Σ_j x̂_j(k) / Σ_k Σ_j x_j(k) (mean ± std over seeds):\n")
    for name in ("hstf", "hstf-unfaded"):
        ratios = []
        for log, results in runs:
            r = results[name]
            ratios.append([r.state_means[a:b].sum() / log.states[a:b].sum() for a, b in BLOCKS])
        a = np.array(ratios)
        print(
            f"  {name:13s} "
            + "  ".join(
                f"block {j + 1}: {a[:, j].mean():.2f} ± {a[:, j].std():.2f}" for j in range(3)
            )
        )

    # 3. One traced run (seed 0): first steps, fading factors, S_i against |γ_i|².
    log = simulate(model, seed=0)
    sig = signals_of(model, log)
    for name, options in (
        ("hstf", PAPER),
        ("hstf-unfaded", HstfOptions(rho=0.95, beta=1.0, theta=0.95, likelihood="unfaded")),
    ):
        r, gamma, S = traced_hstf(model, sig, options)
        fast = VARIANTS[name](model, sig)
        same = np.allclose(r.mode_probabilities, fast.mode_probabilities, atol=1e-9)
        faded = options.likelihood == "faded"
        # With the unfaded likelihood S_i carries no λ_i, so λ cannot be recovered from it.
        lam = fading_factors(model, sig, r, S) if faded else None
        g2 = np.einsum("kij,kij->ki", gamma, gamma)
        trS = np.einsum("kijj->ki", S)
        maha = _maha(gamma, S)
        floor = options.rho * mixture_residual_trace(sig, r, gamma, S) / (1.0 + options.rho)
        print(f"\n### seed 0, {name} (traced run reproduces the compiled run: {same})\n")
        print(
            "| k | q̂ | Pr(q=1,2,3 given Y^k) | λ_1, λ_2, λ_3 | tr S_i | ρ tr S(k-1)/(1+ρ) "
            "| abs(γ_i)² | γᵀS_i⁻¹γ |"
        )
        print("|---|---|---|---|---|---|---|---|")
        for k in (*range(1, 6), 50, 100, 101, 102, 103, 150, 200, 201, 202, 203, 250, 300):
            lam_text = ", ".join(f"{v:.1f}" for v in lam[k]) if lam is not None else "n/a"
            print(
                f"| {k} | {model.mode_ids[r.modes[k]]} | "
                + ", ".join(f"{p:.3f}" for p in r.mode_probabilities[k])
                + f" | {lam_text} | "
                + ", ".join(f"{v:.0f}" for v in trS[k])
                + f" | {floor[k - 1]:.0f} | "
                + ", ".join(f"{v:.0f}" for v in g2[k])
                + " | "
                + ", ".join(f"{v:.1f}" for v in maha[k])
                + " |"
            )
        print("\nmedian over each block (modes 1, 2, 3):")
        for a, b in BLOCKS:
            lam_text = (
                "λ "
                + ", ".join(f"{v:.1f}" for v in np.median(lam[a:b], axis=0))
                + " (share > 1: "
                + ", ".join(f"{v:.2f}" for v in np.mean(lam[a:b] > 1.0 + 1e-9, axis=0))
                + ") | "
                if lam is not None
                else ""
            )
            print(
                f"  k={a}..{b - 1}: {lam_text}tr S_i "
                + ", ".join(f"{v:.0f}" for v in np.median(trS[a:b], axis=0))
                + " | abs(γ_i)² "
                + ", ".join(f"{v:.0f}" for v in np.median(g2[a:b], axis=0))
                + " | γᵀS_i⁻¹γ "
                + ", ".join(f"{v:.1f}" for v in np.median(maha[a:b], axis=0))
            )


def mixture_residual_trace(
    sig: AlignedSignals, r: EstimationResult, gamma: np.ndarray, S: np.ndarray
) -> np.ndarray:
    """Trace of S(k), eq. (38), from the recorded S_i, γ_i (ŷ_i = y − γ_i) and posteriors.

    Row 0 is the filter's initial S = 0.
    """
    out = np.zeros(sig.n_samples)
    for k in range(1, sig.n_samples):
        mu = r.mode_probabilities[k]
        y_i = sig.outputs[k] - gamma[k]
        y_mix = mu @ y_i
        spread = np.einsum("i,ia,ia->", mu, y_i - y_mix, y_i - y_mix)
        out[k] = float(mu @ np.einsum("ijj->i", S[k])) + spread
    return out


def _maha(gamma: np.ndarray, S: np.ndarray) -> np.ndarray:
    out = np.full(gamma.shape[:2], np.nan)
    solved = np.linalg.solve(S[1:], gamma[1:, ..., None])[..., 0]
    out[1:] = np.einsum("kia,kia->ki", gamma[1:], solved)
    return out


def main() -> None:
    """Run all variants over all seeds, print the summary table and the diagnostics."""
    start = time.perf_counter()
    model = load_model("three_tank_hstf")
    rows: dict[str, list[dict[str, float]]] = {name: [] for name in VARIANTS}
    runs: Runs = []
    for seed in SEEDS:
        log = simulate(model, seed=seed)
        sig = signals_of(model, log)
        results = {name: runner(model, sig) for name, runner in VARIANTS.items()}
        runs.append((log, results))
        for name, r in results.items():
            rows[name].append(run_metrics(model, log, r))
    print(f"# three_tank_hstf, seeds {SEEDS.start}..{SEEDS.stop - 1} ({len(SEEDS)} runs each)\n")
    print("mean ± std [min, max] over seeds; delays over the seeds where the switch was detected\n")
    print(summary_table(rows))
    why(model, runs)
    print(f"\n(total wall time {time.perf_counter() - start:.1f} s)")


if __name__ == "__main__":
    main()
