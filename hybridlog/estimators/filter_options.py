"""Options of the filters ``hstf`` (paper 000) and ``imm`` (a light module).

They live apart from the filters, which import numba, so that the registry, ``--help`` and a
batch's planning (which checks every option before a worker starts) read them without
loading the compiler.  ``hybridlog.estimators.hstf`` and ``.imm`` re-export them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal, get_args, get_type_hints

from hybridlog.estimators.footprint import Parts
from hybridlog.estimators.options import option

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["MODE_SEQUENCES", "SMOOTHERS", "HstfOptions", "ImmOptions", "imm_memory"]

_ONE_MODE = "{} has one mode, and {}"
"""Why an option that weighs modes against each other does nothing on a one-mode model."""


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

    @classmethod
    def inert_on(cls, model: HybridModel) -> dict[str, str]:
        """Options that ``model`` leaves unread whatever the others say: name → why.

        With one mode, ``theta`` decides between no modes (eq. (40)).
        """
        if model.n_modes == 1:
            return {"theta": _ONE_MODE.format(model.name, "θ decides between modes (eq. (40))")}
        return {}

    def inert(self, model: HybridModel) -> dict[str, str]:
        """Options that have no effect with the others' values on ``model``: name → why.

        ``fading = false`` fixes λ_i = 1: ``rho`` and ``beta`` enter only the fading factor
        (eqs. (26)-(30)), and ``likelihood`` chooses between the faded and the λ_i = 1
        covariance, then equal.  ``--set rho=0.5 --set fading=false`` ran the plain EKF while
        report.json recorded rho = 0.5 as the option used.  Also :meth:`inert_on`.
        """
        inert = self.inert_on(model)
        if self.fading:
            return inert
        why = "fading = false fixes λ_i = 1, {}; leave it unset, or drop fading=false"
        return inert | {
            "rho": why.format("and rho enters only λ_i (eq. (30))"),
            "beta": why.format("and beta enters only λ_i (eq. (29))"),
            "likelihood": why.format("so the faded and unfaded S_i of eq. (35) are the same"),
        }


@dataclass(frozen=True)
class ImmOptions:
    """Options of the IMM: the Markov matrix's diagonal, and the offline pass after it (issue 12).

    ``smooth`` and ``mode_sequence`` are the names ``--smooth`` and ``--mode-sequence`` map to;
    ``smoother`` chooses the backward pass ``smooth`` runs (``docs/smoothing.md``).
    """

    transition_stay: float | None = option(
        None,
        "diagonal of the Markov matrix (none: the model's [transitions], else 0.95)",
        range=(0.0, 1.0),
    )
    smooth: bool = option(
        False,
        "fixed-interval smoother after the filter (extended RTS; smoother weighs the modes)",
    )
    smoother: Literal["kim", "ec"] = option(
        "kim",
        "backward pass of smooth: kim (Kim 1994) or ec (expectation correction, Barber 2006)",
    )
    mode_sequence: Literal["argmax", "viterbi", "kbest"] = option(
        "argmax",
        "per-sample mode: argmax of the (smoothed) probabilities, viterbi or kbest (most "
        "likely sequence)",
    )
    beam: int = option(
        20, "mode histories kept by kbest, each with its own EKF (never mixed)", range=(1, 10000)
    )

    @classmethod
    def inert_on(cls, model: HybridModel) -> dict[str, str]:
        """Options that ``model`` leaves unread whatever the others say: name → why.

        With one mode the Markov matrix is ``[[1]]`` whatever ``transition_stay`` says, and
        every way of reading off the mode sequence gives that mode at every sample:
        ``viterbi`` and ``kbest`` (of any ``beam``: one history, its EKF the filter's) ran and
        reported a "viterbi" pass whose modes, states and probabilities were the filter's.
        """
        if model.n_modes == 1:
            sequence = _ONE_MODE.format(
                model.name,
                "its mode sequence is that mode at every sample: argmax, viterbi and kbest "
                "read off the same modes, and kbest's one history is the filter's EKF",
            )
            return {
                "transition_stay": _ONE_MODE.format(
                    model.name, "the Markov matrix is [[1]] whatever its diagonal"
                ),
                "mode_sequence": sequence,
                "beam": sequence,
            }
        return {}

    def inert(self, model: HybridModel) -> dict[str, str]:
        """Options that have no effect with the others' values on ``model``: name → why.

        ``beam`` is read by ``mode_sequence = "kbest"`` alone; ``--set beam=N`` without it
        ran the same pass while report.json recorded the beam as the option used.  A model
        file's ``beam`` stays the default for ``--mode-sequence kbest``.  ``smoother`` is
        read by ``smooth = true`` alone (a model file's stays the default for ``--smooth``).
        Also :meth:`inert_on`.
        """
        inert = self.inert_on(model)
        if not self.smooth:
            inert["smoother"] = (
                "only smooth = true runs a smoother (here smooth = false); add --smooth, or "
                "leave smoother unset"
            )
        if self.mode_sequence != "kbest":
            inert.setdefault(  # a one-mode model's reason stands: kbest would not read it either
                "beam",
                f"only mode_sequence = kbest keeps mode histories (here "
                f"{self.mode_sequence}); add --mode-sequence kbest, or leave beam unset",
            )
        return inert


SMOOTHERS: tuple[str, ...] = get_args(get_type_hints(ImmOptions)["smoother"])
"""The backward passes of ``smooth``: ``kim`` (the default) and ``ec``."""

MODE_SEQUENCES: tuple[str, ...] = get_args(get_type_hints(ImmOptions)["mode_sequence"])
"""How the IMM's mode timeline can be read off, in order: ``--mode-sequence``'s choices and the
values report.json's ``smoothing.mode_sequence`` may hold."""


def imm_memory(model: HybridModel, options: ImmOptions, n: int) -> Parts:
    """The arrays of the IMM's offline passes over ``n`` samples, beyond the filter's result.

    ``smooth``: the smoothed modes, probabilities, means and variances, and the per-mode
    store of the forward pass, ``8 n n_q (n_x + n_x(n_x+1)/2)`` bytes (``docs/smoothing.md``);
    ``viterbi``: the path, and the per-mode likelihoods and back pointers, ``16 n n_q``;
    ``kbest``: each sample's kept histories (a 4-byte parent and a 2-byte mode per history)
    and the path's modes, means, variances and full covariances.  The filter's result is
    kept beside them (its output prediction is the report's).  On a model it runs on the
    mode pairs (:mod:`hybridlog.estimators.mode_pairs`) ``n_q`` is the pairs' count, and the
    pairs' probabilities of the forward pass are kept until they are summed.
    """
    from hybridlog.estimators.capabilities import runs_on_pairs

    n_q, n_x = model.n_modes, model.n_states
    parts: Parts = []
    if runs_on_pairs(model):
        n_q *= n_q
        parts.append(("the mode pairs' probabilities", 8 * n * n_q))
    if options.smooth:
        parts.append(("the smoothed estimates", 8 * n * (1 + n_q + 2 * n_x)))
        parts.append(("the smoother's per-mode store", 8 * n * n_q * (n_x + n_x * (n_x + 1) // 2)))
    if options.mode_sequence == "viterbi":
        parts.append(("the Viterbi path, likelihoods and back pointers", 8 * n * (1 + 2 * n_q)))
    if options.mode_sequence == "kbest":
        parts.append(("the k-best histories", 6 * n * options.beam))
        parts.append(("the k-best path's estimates", 8 * n * (1 + 2 * n_x + n_x * n_x)))
    return parts
