"""Whether a mean NIS far below ``m`` parts wrong-unit and degenerate logs from clean ones.

Run from the repository root::

    .venv/bin/python docs/studies/quiet_innovations.py      # ~5 min

:mod:`hybridlog.estimators.consistency` warns when the IMM's mean normalised innovation
squared is too large, never when it is too small.  This study measures the mean NIS over the
settled samples divided by ``m`` (what :class:`~hybridlog.estimators.consistency.Consistency`
reports, ``nis / nis_expected``) of the registry's ``imm`` (what ``analyze`` runs) on logs
simulated from every built-in model ``imm`` runs and from the one-mode linear test model of
``tests/estimators/test_vouch_surprise.py``, seeds 0..9, each log as simulated (``clean``)
and altered: outputs × 1e-3, 1e-2, 0.1 (a log in other units than its model), × 1e3 (the
reverse), × 1e-300, all zero, each output constant at its mean, and the clean log analysed
with a model whose measurement variance is 100× the simulated one (``R×100``).

Scenarios: ``three_tank_hstf`` at its model's noise (``hybridlog simulate``'s default
schedule, 300 steps) and at measurement variance 60 (model and simulation alike, schedule
``1:100,3:90,2:110,1:70,2:90,3:80,1:60`` of ``docs/smoothing.md``), ``double_cart_case1`` and
``_case2`` at their default 100 steps and at 600 steps, and the one-mode model at 600 steps.

A value marked ``*`` is one :mod:`~hybridlog.estimators.consistency` warns of (innovations
smaller than the model's noise predicts: a NIS score below ``−NIS_WARNING`` and a mean NIS
of at most ``NIS_QUIET_EFFECT m``).  A run refused (``hybridlog analyze`` exits 2: no mode
explains a sample) prints ``refused``;
a run with fewer than :data:`~hybridlog.estimators.consistency.MIN_SAMPLES` settled samples
(no test) prints ``untested``.

``per_output`` measures whether one output in other units is seen by its own marginal whitened
innovation ``γ_b / sqrt(S_bb)`` (mean square 1 under the model) where the pooled NIS misses it:
the first output's ``z_1`` on a model whose outputs are reordered to put ``b`` first.
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Callable
from itertools import product
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a file: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from hybridlog.errors import HybridlogError
from hybridlog.estimators.consistency import ConsistencyAccumulator
from hybridlog.estimators.registry import prepare
from hybridlog.model.builtins import builtin_text
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.model.loader import parse_model
from hybridlog.signals import AlignedSignals, FloatArray
from hybridlog.simulate import simulate

SEEDS = range(10)
VARIANCE_60_SCHEDULE = "1:100,3:90,2:110,1:70,2:90,3:80,1:60"
ONE_MODE_MEASUREMENT = "measurement = [[0.05, 0.01], [0.01, 0.08]]"
ONE_MODE = (
    "name = 'one_mode'\ndt = 0.1\nstates = ['p', 'v']\ninputs = ['a']\noutputs = ['y1', 'y2']\n"
    "default_estimator = 'imm'\n\n[modes.slow]\nA = [[1.0, 0.1], [0.0, 0.95]]\n"
    "B = [[0.005], [0.1]]\nC = [[1.0, 0.0], [0.0, 1.0]]\n\n"
    f"[noise]\nprocess = [0.01, 0.02]\n{ONE_MODE_MEASUREMENT}\n\n"
    "[initial]\nstate = [0.5, -0.2]\ncovariance = [[1.0, 0.1], [0.1, 2.0]]\n\n"
    '[simulation]\nstate = [0.0, 0.0]\nschedule = "slow:200"\n\n'
    '[simulation.inputs]\na = "sin(0.7*t)"\n'
)

Alter = Callable[[FloatArray], FloatArray]
ALTERATIONS: dict[str, Alter] = {
    "clean": lambda y: y,
    "x1e-3": lambda y: 1e-3 * y,
    "x1e-2": lambda y: 1e-2 * y,
    "x0.1": lambda y: 0.1 * y,
    "x1e3": lambda y: 1e3 * y,
    "x1e-300": lambda y: 1e-300 * y,
    "zero": np.zeros_like,
    "mean": lambda y: np.broadcast_to(np.nanmean(y, axis=0), y.shape).copy(),
}


def mean_nis_over_m(model: HybridModel, signals: AlignedSignals) -> str:
    """``nis / m`` over the settled samples of the registry's ``imm``, or why there is none.

    A ``*`` after the number: the report warns of innovations smaller than the model's.
    """
    try:
        result = prepare(model, "imm").run(model, signals)
    except HybridlogError:
        return "refused"
    assert result.whitened_innovations is not None
    whole = ConsistencyAccumulator(result.output_names)
    whole.add(result.whitened_innovations, result.mode_probabilities)
    tested = whole.result()
    if tested is None:
        return "untested"
    quiet = any("smaller than the model's noise" in line for line in tested.warnings())
    return f"{tested.nis / tested.nis_expected:.3g}{'*' if quiet else ''}"


Length = tuple[str | None, int | None]
"""simulate's ``schedule`` and ``steps`` (``None``: the model's)."""


def scenarios() -> list[tuple[str, str, str, Length]]:
    """(name, model text, the same model with R × 100, schedule and steps)."""
    tank = builtin_text("three_tank_hstf")
    tank60 = tank.replace("measurement = 0.5 ", "measurement = 60.0")
    out: list[tuple[str, str, str, Length]] = [
        (
            "three_tank_hstf",
            tank,
            tank.replace("measurement = 0.5 ", "measurement = 50.0"),
            (None, None),
        ),
        (
            "three_tank_hstf R=60",
            tank60,
            tank.replace("measurement = 0.5 ", "measurement = 6000.0"),
            (VARIANCE_60_SCHEDULE, None),
        ),
    ]
    for case in (1, 2):
        cart = builtin_text(f"double_cart_case{case}")
        wide = cart.replace("measurement = 1e-6", "measurement = 1e-4")
        out.append((f"double_cart_case{case}", cart, wide, (None, None)))
        out.append((f"double_cart_case{case} 600", cart, wide, (None, 600)))
    wide = ONE_MODE.replace(ONE_MODE_MEASUREMENT, "measurement = [[5.0, 1.0], [1.0, 8.0]]")
    out.append(("one_mode 600", ONE_MODE, wide, (None, 600)))
    return out


def main() -> None:
    """Print one line per scenario and alteration: ``nis / m`` of seeds 0..9."""
    for name, text, wide_text, (schedule, steps) in scenarios():
        model, wide = parse_model(text), parse_model(wide_text)
        wide_r, r = wide.modes[0].measurement_noise, model.modes[0].measurement_noise
        assert np.allclose(wide_r, 100 * r, rtol=1e-12, atol=0)
        rows: dict[str, list[str]] = {key: [] for key in [*ALTERATIONS, "R×100"]}
        for seed in SEEDS:
            signals = simulate(model, schedule=schedule, steps=steps, seed=seed).signals(model)
            for key, alter in ALTERATIONS.items():
                altered = dataclasses.replace(signals, outputs=alter(signals.outputs))
                rows[key].append(mean_nis_over_m(model, altered))
            rows["R×100"].append(mean_nis_over_m(wide, signals))
        print(f"## {name}")
        for key, values in rows.items():
            numbers = [float(v.rstrip("*")) for v in values if v not in ("refused", "untested")]
            span = f"{min(numbers):.3g}-{max(numbers):.3g}" if numbers else "-"
            print(f"  {key:8s} {span:>16s}  [{' '.join(values)}]")
        sys.stdout.flush()


def clean_tails() -> None:
    """The lowest ``nis / m`` of clean short logs over many seeds (the model's own noise)."""
    tank = builtin_text("three_tank_hstf")
    tank60 = tank.replace("measurement = 0.5 ", "measurement = 60.0")
    cart1, cart2 = builtin_text("double_cart_case1"), builtin_text("double_cart_case2")
    cases: list[tuple[str, str, Length, range]] = [
        ("double_cart_case1 100 steps", cart1, (None, None), range(100)),
        ("double_cart_case1 50 steps", cart1, (None, 50), range(100)),
        ("double_cart_case2 100 steps", cart2, (None, None), range(100)),
        ("three_tank_hstf 300 steps", tank, (None, None), range(40)),
        ("three_tank_hstf R=60 700 steps", tank60, (VARIANCE_60_SCHEDULE, None), range(40)),
        ("one_mode 100 steps", ONE_MODE, (None, 100), range(100)),
    ]
    print("## clean logs, many seeds")
    for name, text, (schedule, steps), seeds in cases:
        model = parse_model(text)
        values = [
            mean_nis_over_m(
                model, simulate(model, schedule=schedule, steps=steps, seed=s).signals(model)
            )
            for s in seeds
        ]
        numbers = [float(v.rstrip("*")) for v in values if v not in ("refused", "untested")]
        warned = sum(v.endswith("*") for v in values)
        print(
            f"  {name:32s} seeds 0..{seeds[-1]}: {len(numbers)} tested, "
            f"{min(numbers):.3g}-{max(numbers):.3g}, {warned} warned"
        )


def rotated(name: str, text: str, first: int) -> tuple[str, list[int]]:
    """``text`` with its outputs reordered to put output ``first`` first, and the order.

    A relabelling (each model's ``h`` lists one output per state, its ``R`` is rotated with
    them): the same filter, whose first whitened innovation ``z_1 = γ_1 / sqrt(S_11)`` is
    the output's marginal one.
    """
    if name.startswith("three_tank"):
        order = [first, *(b for b in range(3) if b != first)]
        names = ", ".join(f'"y{b + 1}"' for b in order)
        text = text.replace('outputs = ["y1", "y2", "y3"]', f"outputs = [{names}]")
        for scale in ("", "2*", "3*"):
            old = ", ".join(f'"{scale}x{b + 1}"' for b in range(3))
            new = ", ".join(f'"{scale}x{b + 1}"' for b in order)
            assert f"h = [{old}]" in text, name
            text = text.replace(f"h = [{old}]", f"h = [{new}]")
        return text, order
    if first == 0:
        return text, [0, 1]
    text = text.replace("outputs = ['y1', 'y2']", "outputs = ['y2', 'y1']")
    text = text.replace("C = [[1.0, 0.0], [0.0, 1.0]]", "C = [[0.0, 1.0], [1.0, 0.0]]")
    swapped = "measurement = [[0.08, 0.01], [0.01, 0.05]]"
    return text.replace(ONE_MODE_MEASUREMENT, swapped), [1, 0]


def marginal_mean_square(model: HybridModel, signals: AlignedSignals) -> tuple[float, float] | None:
    """The first output's ``z_1²`` averaged over the settled samples, and its standard score."""
    try:
        result = prepare(model, "imm").run(model, signals)
    except HybridlogError:
        return None
    assert result.whitened_innovations is not None
    first = ConsistencyAccumulator(result.output_names[:1])
    first.add(result.whitened_innovations[:, :1], result.mode_probabilities)
    tested = first.result()
    return None if tested is None else (tested.nis, tested.nis_score)


def per_output() -> None:
    """Each output's marginal mean square ``(γ_b / sqrt(S_bb))²`` (expected 1) and its score.

    On clean logs (seeds 0..39) and on logs with one output alone × 1e-3, 1e-2, 0.1 (seeds
    0..9; ``y1 in y3 x0.001``: y1's where y3 is scaled), of the scenarios with more than one
    output.
    """
    print("## per output: the marginal mean square (standard score), clean and one output scaled")
    for name, text, _, (schedule, steps) in scenarios():
        model = parse_model(text)
        m = model.n_outputs
        if m < 2:
            continue
        found: dict[str, list[tuple[float, float] | None]] = {}
        for seed in range(40):
            signals = simulate(model, schedule=schedule, steps=steps, seed=seed).signals(model)
            for b in range(m):
                rotated_text, order = rotated(name, text, b)
                first = parse_model(rotated_text)
                assert first.outputs == tuple(signals.output_names[c] for c in order)
                base = dataclasses.replace(
                    signals, outputs=signals.outputs[:, order], output_names=first.outputs
                )
                key = f"y{b + 1} clean"
                found.setdefault(key, []).append(marginal_mean_square(first, base))
                for c, scale in product(range(m), (1e-3, 1e-2, 0.1)) if seed < 10 else ():
                    outputs = base.outputs.copy()
                    outputs[:, order.index(c)] *= scale  # y_c in other units: y_b's marginal
                    altered = dataclasses.replace(base, outputs=outputs)
                    key = f"y{b + 1} in y{c + 1} x{scale:g}"
                    found.setdefault(key, []).append(marginal_mean_square(first, altered))
        print(f"## {name}")
        for key, values in found.items():
            numbers = np.array([v for v in values if v is not None]).reshape(-1, 2)
            none = len(values) - numbers.shape[0]
            span = (
                f"{numbers[:, 0].min():.3g}-{numbers[:, 0].max():.3g} "
                f"({numbers[:, 1].min():.1f} to {numbers[:, 1].max():.1f})"
                if numbers.size
                else "-"
            )
            print(f"  {key:18s} {span:>32s}  {none} untested or refused")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
    clean_tails()
    per_output()
