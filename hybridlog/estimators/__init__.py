"""Hybrid estimators: pure algorithms from (model, aligned signals) to one result type.

A new estimator plugs in by adding an :class:`Estimator` entry to :data:`ESTIMATORS`: a
name, a one-line summary, and a function ``run(model, signals, options) -> EstimationResult``
that validates its own options (see :func:`hybridlog.estimators.options.parse_options`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

from hybridlog.errors import OptionError
from hybridlog.estimators.chiu import chiu_options, kmeans_options, run_chiu, run_kmeans
from hybridlog.estimators.hstf import hstf_options, run_hstf
from hybridlog.estimators.imm import imm_options, run_imm
from hybridlog.estimators.result import EstimationResult
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import AlignedSignals

Runner = Callable[[HybridModel, AlignedSignals, Mapping[str, object]], EstimationResult]


@dataclass(frozen=True)
class Estimator:
    """A registered estimator: its name, a one-line summary and how to run it."""

    name: str
    summary: str
    run: Runner


ESTIMATORS: dict[str, Estimator] = {
    "hstf": Estimator(
        "hstf",
        "hybrid strong tracking filter, paper 000 eqs. (5)-(40)",
        lambda model, signals, options: run_hstf(model, signals, hstf_options(dict(options))),
    ),
    "imm": Estimator(
        "imm",
        "interacting multiple model with an EKF per mode",
        lambda model, signals, options: run_imm(model, signals, imm_options(dict(options))),
    ),
    "chiu": Estimator(
        "chiu",
        "Chiu subtractive clustering + switched Luenberger observer, paper 001",
        lambda model, signals, options: run_chiu(model, signals, chiu_options(dict(options))),
    ),
    "kmeans": Estimator(
        "kmeans",
        "k-means clustering + switched Luenberger observer, paper 001's baseline",
        lambda model, signals, options: run_kmeans(model, signals, kmeans_options(dict(options))),
    ),
}

PLANNED = ("unknown-mode", "sliding-mode", "switching-observer")
"""Estimator names of SPEC §7 that this version does not provide yet."""


def get_estimator(name: str) -> Estimator:
    """The registered estimator called ``name``; :class:`OptionError` otherwise."""
    if name in ESTIMATORS:
        return ESTIMATORS[name]
    available = ", ".join(ESTIMATORS)
    if name in PLANNED:
        raise OptionError(
            f"--estimator: '{name}' is not available in this version (available: {available})"
        )
    raise OptionError(f"--estimator: unknown estimator '{name}' (available: {available})")


def estimator_options(
    model: HybridModel, name: str, overrides: Mapping[str, object]
) -> dict[str, object]:
    """Options for ``name``: the model's ``[estimators.<name>]`` defaults, then overrides."""
    merged: dict[str, object] = dict(model.estimator_options.get(name, {}))
    merged.update(overrides)
    return merged
