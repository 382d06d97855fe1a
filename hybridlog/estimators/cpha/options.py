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
    """``mode_sequence = "kbest"``: each step's kept hypotheses, to read the winner's history.

    Their means, variances and parents, about ``8 · beam · 2 n_x`` bytes per sample
    (:attr:`~hybridlog.estimators.cpha.hypotheses.Tracker.parents`), and their assignments.
    """
    if options.mode_sequence != "kbest":
        return []
    per_hypothesis = 8 * (2 * model.n_states + 2)
    return [("the kept hypotheses of every step", n * options.beam * per_hypothesis)]
