"""Options of the ``unknown-mode`` estimator (a light module: no scipy, sympy or numba).

The registry, ``--help`` and a batch's planning read them without loading the estimator.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from hybridlog.estimators.footprint import Parts
from hybridlog.estimators.options import option

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["UnknownModeOptions", "unknown_mode_memory"]


@dataclass(frozen=True)
class UnknownModeOptions:
    """Options of ``unknown-mode`` (paper 002): beam width, work bound, held variance, unknown."""

    beam: int = option(20, "number of hypotheses (trajectories) kept per step", range=(1, 10000))
    candidates: int | None = option(
        None,
        "most successors filtered per step, at least beam (none: 10 x beam); the beam is "
        "exact below it",
        range=(1, 1000000),
    )
    variance_growth: float = option(
        1.1,
        "factor on the variance of an unobservable or undetermined state per step (§3.1)",
        range=(1.0, 1e6),
    )
    unknown_mode: bool = option(
        True, "every component has the unknown mode (false: only the modelled modes)"
    )
    mode_sequence: Literal["argmax", "kbest"] = option(
        "argmax",
        "per-sample mode: each step's most likely hypothesis, or kbest (the final one's history)",
    )

    def conflicts(self) -> list[tuple[str, str, str]]:
        """``candidates`` below ``beam``: fewer successors filtered than hypotheses kept.

        The tracker raised the bound to the beam without a word while report.json recorded
        the smaller value as the one used (:func:`~hybridlog.estimators.options.parse_options`
        refuses the pair instead).
        """
        if self.candidates is not None and self.candidates < self.beam:
            return [
                (
                    "candidates",
                    "beam",
                    f"{self.candidates} is below the beam, {{other}}: fewer successors would "
                    "be filtered per step than hypotheses kept; give candidates >= beam, or "
                    "none for 10 x beam",
                )
            ]
        return []


def unknown_mode_memory(model: HybridModel, options: UnknownModeOptions, n: int) -> Parts:
    """The run's records of every step, beyond the result.

    Each step's summed belief per joint assignment kept (at most ``beam`` of them, or as many
    as there are joint assignments), 24 bytes each, and their probabilities in the result,
    whatever ``mode_sequence``; with
    ``"kbest"`` also each step's kept hypotheses, to read the winner's history: their means,
    variances, parents and assignments, ``8 · (2 n_x + 2)`` bytes each
    (:attr:`~hybridlog.estimators.cpha.hypotheses.Tracker.parents`).
    """
    joint = 1
    for component in model.components:
        joint *= len(component.modes) + (1 if options.unknown_mode else 0)
        if joint >= options.beam:
            break
    kept = min(options.beam, joint)
    parts: Parts = [
        ("the kept assignments' beliefs of every step", n * kept * 24),
        # result_bytes counts no mode of a components model: the joint ones are found as
        # the run goes, at least as many as are kept at one step
        ("the joint assignments' probabilities", n * kept * 8),
    ]
    if options.mode_sequence == "kbest":
        per_hypothesis = 8 * (2 * model.n_states + 2)
        parts.insert(0, ("the kept hypotheses of every step", n * options.beam * per_hypothesis))
    return parts
