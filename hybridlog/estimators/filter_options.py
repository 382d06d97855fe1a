"""Options of the filters ``hstf`` (paper 000) and ``imm`` (a light module).

They live apart from the filters, which import numba, so that the registry, ``--help`` and a
batch's planning (which checks every option before a worker starts) read them without
loading the compiler.  ``hybridlog.estimators.hstf`` and ``.imm`` re-export them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args, get_type_hints

from hybridlog.estimators.options import option

__all__ = ["MODE_SEQUENCES", "HstfOptions", "ImmOptions"]


@dataclass(frozen=True)
class HstfOptions:
    """Options of the HSTF (paper 000): ρ, β, θ and the two switches documented above."""

    rho: float = option(0.95, "forgetting factor ρ of eq. (30)", range=(1e-12, 1.0))
    beta: float = option(1.0, "softening factor β of eq. (29)", range=(1.0, 1e12))
    theta: float = option(0.95, "mode decision threshold θ of eq. (40)", range=(0.5, 1.0))
    fading: bool = option(True, "strong tracking fading λ_i (false: λ_i = 1, the plain EKF)")
    likelihood: Literal["faded", "unfaded"] = option(
        "faded", "S_i of eq. (35) from the faded P_i (the paper) or from λ_i = 1 (a variant)"
    )


@dataclass(frozen=True)
class ImmOptions:
    """Options of the IMM: the Markov matrix's diagonal, and the offline pass after it (issue 12).

    ``smooth`` and ``mode_sequence`` are the names ``--smooth`` and ``--mode-sequence`` map to.
    """

    transition_stay: float | None = option(
        None,
        "diagonal of the Markov matrix (none: the model's [transitions], else 0.95)",
        range=(0.0, 1.0),
    )
    smooth: bool = option(
        False,
        "fixed-interval smoother after the filter (Kim 1994, per-mode RTS/extended step)",
    )
    mode_sequence: Literal["argmax", "viterbi", "kbest"] = option(
        "argmax",
        "per-sample mode: argmax of the (smoothed) probabilities, viterbi or kbest (most "
        "likely sequence)",
    )
    beam: int = option(
        20, "mode histories kept by kbest, each with its own EKF (never mixed)", range=(1, 10000)
    )


MODE_SEQUENCES: tuple[str, ...] = get_args(get_type_hints(ImmOptions)["mode_sequence"])
"""How the IMM's mode timeline can be read off, in order: ``--mode-sequence``'s choices and the
values report.json's ``smoothing.mode_sequence`` may hold."""
