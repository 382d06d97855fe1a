r"""Expectation correction (Barber 2006, ``smoother = "ec"``) against Kim's smoother and the filter.

Run from the repository root::

    .venv/bin/python docs/studies/smoothing_ec.py              # ~1 min: 120 + 40 logs
    .venv/bin/python docs/studies/smoothing_ec.py --reference  # + the NumPy reference, ~4 min

hybridlog's compiled passes through the registry's ``imm`` (what ``analyze`` runs), once per
variant: ``filter`` (the IMM alone), ``kim`` (``smooth = true``, Kim's smoother) and ``ec``
(``smooth = true``, ``smoother = "ec"``: D. Barber, "Expectation Correction for Smoothed
Inference in Switching Linear Dynamical Systems", *JMLR* 7 (2006) 2515-2540, one Gaussian
per mode, the "mean" approximation; the equations are in the docstring of
``hybridlog/estimators/smoothing.py``).  Kim's recursion takes
``Pr(q(k)=i | q(k+1)=j, Y^N) ≈ Pr(q(k)=i | q(k+1)=j, Y^k)``; expectation correction
conditions on the smoothed state of ``k+1`` as well:

.. math::

    \Pr(q(k)=i \mid q(k+1)=j, Y^N) \propto \mu_i(k)\,\Pi_{ij}\,
        N\bigl(\hat x^s_j(k+1);\ f_j(\hat x_i(k|k)),\ F P_i(k|k) F^T + Q_j\bigr)

with an extended RTS step per pair ``(i, j)`` from ``x̂_i(k|k)``.

Scenarios of ``docs/studies/smoothing.py``: three-tank seeds 0..29 and 100..139 (its
schedule), 200..229 (random schedules), 501..520 (80-step segments); the double cart, cases 1
and 2, seeds 0..19 (no process noise: there ``ec`` takes Kim's weights, so its modes are
Kim's, and its states its own pairwise steps).  ``--reference`` also runs the plain-NumPy
prototype this began as (``tests/support/ec_reference.py``: the forward IMM and the backward
pass without guard, rounding probe or skip of negligible modes) on the three-tank logs and
counts the samples where its smoothed modes differ from the compiled pass's.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a file: make the repository root and the study importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    sys.path.insert(0, str(Path(__file__).resolve().parent))

import smoothing as study  # docs/studies/smoothing.py

from hybridlog.estimators.filter_options import ImmOptions
from hybridlog.estimators.imm import transition_matrix
from hybridlog.estimators.registry import ESTIMATORS, Prepared
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.model.loader import load_model
from hybridlog.signals import AlignedSignals
from hybridlog.simulate import simulate
from tests.support import ec_reference

VARIANTS = {
    "filter": ImmOptions(),
    "kim": ImmOptions(smooth=True, smoother="kim"),
    "ec": ImmOptions(smooth=True, smoother="ec"),
}


def schedule(seed: int) -> str:
    """The schedule of a seed's scenario in docs/studies/smoothing.py."""
    if 200 <= seed < 300:
        return study.random_schedule(seed)
    return study.SHORT_SCHEDULE if seed > 500 else study.THREE_TANK_SCHEDULE


def reference_differences(model: HybridModel, signals: AlignedSignals, ec_modes: np.ndarray) -> int:
    """Samples where the NumPy reference's smoothed modes differ from the compiled pass's."""
    T = transition_matrix(model, ImmOptions())
    forward = ec_reference.imm_forward(model, signals, T)
    mu, _, _ = ec_reference.smoothed(model, signals, T, forward)
    return int(np.sum(mu.argmax(1) != ec_modes))


def summary(title: str, rows: dict[str, list[dict[str, float]]]) -> str:
    """One line per scenario: each smoother against the filter, and ec against kim.

    Per smoother the median mode error, the logs below, above and at most half the filter's,
    and the median state RMSE.
    """
    filt = [r["mode error %"] for r in rows["filter"]]
    parts = [f"- {title} ({len(filt)} logs): filter median {statistics.median(filt):.2f} %"]
    for name in ("kim", "ec"):
        errors = [r["mode error %"] for r in rows[name]]
        pairs = list(zip(errors, filt, strict=True))
        rmse = statistics.median(r["state RMSE"] for r in rows[name])
        parts.append(
            f"{name} median {statistics.median(errors):.2f} %, below the filter on "
            f"{sum(a < b for a, b in pairs)}, above on {sum(a > b for a, b in pairs)}, at most "
            f"half of it on {sum(a <= 0.5 * b for a, b in pairs)}, state RMSE median {rmse:.3g}"
        )
    pairs = [
        (e["mode error %"], k["mode error %"]) for e, k in zip(rows["ec"], rows["kim"], strict=True)
    ]
    filter_rmse = statistics.median(r["state RMSE"] for r in rows["filter"])
    parts.append(
        f"filter state RMSE median {filter_rmse:.3g}; ec vs kim: below on "
        f"{sum(a < b for a, b in pairs)}, equal on {sum(a == b for a, b in pairs)}, above on "
        f"{sum(a > b for a, b in pairs)}"
    )
    return "; ".join(parts)


def run(
    model: HybridModel, logs: list[AlignedSignals], reference: bool
) -> tuple[dict[str, list[dict[str, float]]], int]:
    """Every variant on every log: scores, and the reference's differing samples (or -1)."""
    rows: dict[str, list[dict[str, float]]] = {name: [] for name in VARIANTS}
    differing = 0 if reference else -1
    for signals in logs:
        for name, options in VARIANTS.items():
            result = Prepared(ESTIMATORS["imm"], options).run(model, signals)
            rows[name].append(study.scores(result, signals))
            if reference and name == "ec":
                differing += reference_differences(model, signals, result.modes)
    return rows, differing


def main() -> None:
    """Print, per scenario, how each smoother's mode error compares with the filter's."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--reference", action="store_true", help="also run the NumPy reference")
    reference = parser.parse_args().reference
    tank = study.three_tank()
    scenarios = {
        "seeds 0..29": range(30),
        "seeds 100..139": range(100, 140),
        "random schedules, seeds 200..229": range(200, 230),
        "80-step segments, seeds 501..520": range(501, 521),
    }
    for title, seeds in scenarios.items():
        logs = [simulate(tank, schedule=schedule(seed), seed=seed).signals(tank) for seed in seeds]
        rows, differing = run(tank, logs, reference)
        line = summary(f"three_tank, {title}", rows)
        if differing >= 0:
            line += f"; samples where the NumPy reference's modes differ: {differing}"
        print(line, flush=True)
    for case in ("double_cart_case1", "double_cart_case2"):
        cart = load_model(case)
        logs = [study.double_cart_log(cart, seed).signals(cart) for seed in range(20)]
        rows, _ = run(cart, logs, reference=False)
        print(summary(case, rows), flush=True)


if __name__ == "__main__":
    main()
