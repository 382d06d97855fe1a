"""Paper 001's double cart beyond sinusoids: ``chiu`` against ``kmeans`` on other inputs.

Run from the repository root::

    .venv/bin/python docs/studies/double_cart_inputs.py        # ~1 min

The scenarios below were fixed before the study first ran (none added or dropped after),
and the estimators run at their defaults (nothing here was tuned).  Each scenario edits
the built-in model as a user would: the input ``[simulation.inputs] u``, and for four of
them the sensor noise ``[noise] measurement`` or the number of steps.  Seeds 1, 2, 3; a
periodic input's phase is ``0.7·seed`` (as in ``double_cart.py``), so the seeds differ in
more than the sensor noise.  Both cases, both estimators; clusters are fitted on each log
and labelled without ground truth.

Printed per scenario (mean over the seeds, with min–max of the mode accuracy): the
majority share (the accuracy of always answering the more frequent true mode), each
estimator's mode accuracy, the best accuracy any labelling of the same clusters would
reach (read off the truth, which the estimators never see: where it is high and the
estimate's low, the labelling failed, not the clusters' threshold on y), the number of Chiu
clusters (k-means has 2), VAF and MSE of the one-step prediction; per case, how many runs
each estimator won and how many scored below chance (the agreement of modes drawn
independently of the true ones with the estimate's frequencies: Cohen's kappa < 0).
A refusal is printed with its message.  It prints the tables of ``docs/double_cart.md``
"Beyond sinusoids".
"""

from __future__ import annotations

import itertools
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a file: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from hybridlog.errors import HybridlogError
from hybridlog.estimators.chiu import ChiuOptions, run_chiu
from hybridlog.estimators.kmeans import KMeansOptions, run_kmeans
from hybridlog.estimators.result import EstimationResult
from hybridlog.model.builtins import builtin_text
from hybridlog.model.loader import parse_model
from hybridlog.report import metrics, mode_metrics
from hybridlog.signals import AlignedSignals
from hybridlog.simulate import simulate

CASES = ("double_cart_case1", "double_cart_case2")
SEEDS = (1, 2, 3)
DEFAULT_INPUT = 'u = "sin(0.3*t)"'
DEFAULT_NOISE = "measurement = 1e-6"


@dataclass(frozen=True)
class Scenario:
    """One edit of the built-in model: input ``u`` (``{p}``: the phase 0.7·seed), noise, steps."""

    name: str
    u: str
    measurement: float = 1e-6
    steps: int = 1000


SCENARIOS = (
    Scenario("sine (the model's input)", "sin(0.3*t + {p})"),
    Scenario("small amplitude 0.05", "0.05*sin(0.3*t + {p})"),
    Scenario("large amplitude 5", "5*sin(0.3*t + {p})"),
    Scenario("offset sine +0.3", "sin(0.3*t + {p}) + 0.3"),
    Scenario("offset sine +1", "sin(0.3*t + {p}) + 1"),
    Scenario("fast sine 1.0 rad/s", "sin(1.0*t + {p})"),
    Scenario("square wave", "sign(sin(0.3*t + {p}))"),
    Scenario("two sines", "sin(0.2*t + {p}) + 0.5*sin(0.7*t)"),
    Scenario("chirp 0.1 -> 0.1+0.002 t rad/s", "sin(0.1*t + 0.001*t*t + {p})"),
    Scenario("random-like steps", "sign(sin(0.37*t + {p}) + sin(0.23*t) + sin(0.11*t + 1))"),
    Scenario("slow ramp -1 -> 1", "-1 + 0.002*k"),
    Scenario("sine, sensor sigma 0.01", "sin(0.3*t + {p})", measurement=1e-4),
    Scenario("sine, sensor sigma 0.05", "sin(0.3*t + {p})", measurement=2.5e-3),
    Scenario("sine, 200 steps", "sin(0.3*t + {p})", steps=200),
    Scenario("sine, 5000 steps", "sin(0.3*t + {p})", steps=5000),
)


@dataclass(frozen=True)
class Outcome:
    """One estimator on one log: scores, cluster count, or the refusal's message."""

    mse: float = float("nan")
    vaf: float = float("nan")
    accuracy: float = float("nan")
    oracle: float = float("nan")
    below_chance: bool = False
    clusters: int = 0
    refused: str = ""


def scenario_log(case: str, scenario: Scenario, seed: int) -> tuple[object, AlignedSignals]:
    """The built-in model edited as ``scenario`` says, simulated with ``seed``."""
    text = builtin_text(case)
    assert DEFAULT_INPUT in text and DEFAULT_NOISE in text
    u = scenario.u.replace("{p}", f"{0.7 * seed:g}")
    text = text.replace(DEFAULT_INPUT, f'u = "{u}"')
    text = text.replace(DEFAULT_NOISE, f"measurement = {scenario.measurement:g}")
    model = parse_model(text, origin=case)
    log = simulate(model, steps=scenario.steps, seed=seed)
    return model, log.signals(model, source=f"{case} {scenario.name} seed {seed}")


def oracle_accuracy(result: EstimationResult, signals: AlignedSignals) -> float:
    """The best mode accuracy any cluster → mode map of the same clusters reaches (truth-read).

    The decision (2)–(3) is kept (nearest ``y_i*``); only the labels change.  It separates
    the two ways the estimate can fail: the clusters' threshold on y (this is low too) or
    their labelling by the prediction fit (this is high, the chosen map's accuracy low).
    """
    truth = signals.truth_modes
    assert truth is not None
    values = np.asarray(result.options["classifier"]["decision_values"])[:, 0]
    decided = np.argmin(np.abs(signals.outputs[:, :1] - values[None, :]), axis=1)
    best = 0.0
    for labels in itertools.product(range(2), repeat=values.size):
        best = max(best, mode_metrics.mode_accuracy(np.array(labels)[decided], truth))
    return best


def outcome(result: EstimationResult, signals: AlignedSignals) -> Outcome:
    """Scores of one run (paper 001 §5 metrics; the mode accuracy over all samples)."""
    ok = np.isfinite(result.output_predictions[:, 0])
    y, y_hat = signals.outputs[ok], result.output_predictions[ok]
    truth = signals.truth_modes
    assert truth is not None
    return Outcome(
        mse=float(metrics.mse(y, y_hat)[0]),
        vaf=float(metrics.vaf(y, y_hat)[0]),
        accuracy=mode_metrics.mode_accuracy(result.modes, truth),
        oracle=oracle_accuracy(result, signals),
        below_chance=int(np.count_nonzero(result.modes == truth)) * truth.size
        < int(np.bincount(truth, minlength=2) @ np.bincount(result.modes, minlength=2)),
        clusters=len(result.options["classifier"]["centers"]),
    )


def run(estimator: str, model: object, signals: AlignedSignals) -> Outcome:
    """``chiu`` or ``kmeans`` at its defaults; a refusal kept as its message."""
    from hybridlog.model.hybrid_model import HybridModel

    assert isinstance(model, HybridModel)
    try:
        if estimator == "chiu":
            return outcome(run_chiu(model, signals, ChiuOptions()), signals)
        return outcome(run_kmeans(model, signals, KMeansOptions()), signals)
    except HybridlogError as err:
        return Outcome(refused=str(err))


def summary(runs: list[Outcome], *, clusters: bool) -> str:
    """``acc mean [min–max] | best labels | (clusters |) VAF | MSE`` cells."""
    done = [r for r in runs if not r.refused]
    if not done:
        return "refused | | " + ("| " if clusters else "") + "|"
    acc = np.array([r.accuracy for r in done])
    refused = f" ({len(runs) - len(done)} refused)" if len(done) < len(runs) else ""
    counts = "/".join(map(str, sorted({r.clusters for r in done})))
    return (
        f"{acc.mean():.2f} [{acc.min():.2f}–{acc.max():.2f}]{refused} | "
        f"{np.mean([r.oracle for r in done]):.2f} | "
        + (f"{counts} | " if clusters else "")
        + f"{np.mean([r.vaf for r in done]):.2f} | {np.mean([r.mse for r in done]):.1e}"
    )


LABELLINGS = (("square wave", "chiu"), ("fast sine 1.0 rad/s", "kmeans"))
"""Case 2, seed 1: the runs whose labels :func:`labelling_scores` prints."""


def prediction_sse(result: EstimationResult, signals: AlignedSignals) -> float:
    """The labelling's score: one-step prediction SSE after the first 100 samples (chiu.py)."""
    error = signals.outputs[100:, 0] - result.output_predictions[100:, 0]
    return float(np.sum(error * error))


def labelling_scores() -> None:
    """Prediction SSE and mode accuracy of the chosen labels, the truth's best, and one mode."""
    from hybridlog.model.hybrid_model import HybridModel

    print("\n## Labellings compared (case 2, seed 1)\n")
    print("| scenario | estimator | labels (cluster 1, 2, ...) | prediction SSE | mode accuracy |")
    print("|---|---|---|---|---|")
    for name in LABELLINGS:
        scenario = next(s for s in SCENARIOS if s.name == name[0])
        model, signals = scenario_log("double_cart_case2", scenario, 1)
        truth = signals.truth_modes
        assert isinstance(model, HybridModel) and truth is not None
        runner = run_chiu if name[1] == "chiu" else run_kmeans
        options = ChiuOptions if name[1] == "chiu" else KMeansOptions
        chosen = runner(model, signals, options())  # type: ignore[arg-type]
        classifier = chosen.options["classifier"]
        values = np.asarray(classifier["decision_values"])[:, 0]
        decided = np.argmin(np.abs(signals.outputs[:, :1] - values[None, :]), axis=1)
        best = max(
            itertools.product(range(2), repeat=values.size),
            key=lambda m: mode_metrics.mode_accuracy(np.array(m)[decided], truth),
        )
        maps = {
            "chosen": ",".join(classifier["cluster_modes"]),
            "most accurate": ",".join(model.mode_ids[m] for m in best),
            "every cluster '2'": ",".join(["2"] * values.size),
        }
        for what, labels in maps.items():
            result = runner(model, signals, options(cluster_modes=labels))  # type: ignore[arg-type]
            accuracy = mode_metrics.mode_accuracy(result.modes, truth)
            print(
                f"| {name[0]} | {name[1]} | {what}: {labels} | "
                f"{prediction_sse(result, signals):.4g} | {accuracy:.2f} |"
            )


def main() -> None:
    """Print one table per case."""
    refusals: list[str] = []
    for case in CASES:
        print(f"\n## {case}: {len(SCENARIOS)} scenarios × seeds {SEEDS}\n")
        print(
            "| scenario | majority | `chiu` acc [min–max] | best labels | clusters | VAF (%) "
            "| MSE | `kmeans` acc [min–max] | best labels | VAF (%) | MSE |"
        )
        print("|---" * 11 + "|")
        totals = {"chiu": 0, "kmeans": 0, "runs": 0}
        below = {"chiu": 0, "kmeans": 0}
        for scenario in SCENARIOS:
            outcomes: dict[str, list[Outcome]] = {"chiu": [], "kmeans": []}
            majority: list[float] = []
            for seed in SEEDS:
                model, signals = scenario_log(case, scenario, seed)
                assert signals.truth_modes is not None
                share = float(np.mean(signals.truth_modes == 1))
                majority.append(max(share, 1.0 - share))
                for estimator, runs in outcomes.items():
                    runs.append(run(estimator, model, signals))
                    if runs[-1].refused:
                        refusals.append(
                            f"{case}, {scenario.name}, seed {seed}, {estimator}: {runs[-1].refused}"
                        )
                c, k = outcomes["chiu"][-1], outcomes["kmeans"][-1]
                if not c.refused and not k.refused:
                    totals["runs"] += 1
                    totals["chiu"] += c.accuracy > k.accuracy
                    totals["kmeans"] += k.accuracy > c.accuracy
            print(
                f"| {scenario.name} | {np.mean(majority):.2f} | "
                f"{summary(outcomes['chiu'], clusters=True)} | "
                f"{summary(outcomes['kmeans'], clusters=False)} |"
            )
            for estimator, runs in outcomes.items():
                below[estimator] += sum(r.below_chance for r in runs if not r.refused)
        print(
            f"\nchiu more accurate in {totals['chiu']} of {totals['runs']} runs, "
            f"kmeans in {totals['kmeans']}; below chance (Cohen's kappa < 0): "
            f"chiu {below['chiu']}, kmeans {below['kmeans']} runs"
        )
    labelling_scores()
    if refusals:
        print("\nRefusals:")
        print("\n".join(f"- {line}" for line in refusals))


if __name__ == "__main__":
    main()
