"""Options of the ``sliding-mode`` estimator (paper 003), a light module (no numba).

Kept apart from :mod:`hybridlog.estimators.sliding_mode`, which imports numba, so that the
registry and ``--help`` read them without loading the compiler.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from hybridlog.estimators.options import option

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["SlidingModeOptions"]


@dataclass(frozen=True)
class SlidingModeOptions:
    """Options of the suboptimal second-order sliding-mode observer, eqs. (10)-(21), (30), (32).

    The observer gain is ``V_M = v_max`` when given, else ``V_M = Γ Φ̄`` (eq. (21)) with
    ``Γ = gamma`` and ``Φ̄ = drift_bound``, the bound (17)/(19) of the drift
    ``|φ_i| ≤ D_1 √n + ε̄_1``; one of ``v_max`` and ``drift_bound`` must be set (the model
    file's ``[estimators.sliding-mode]`` table is the place for the plant's values).
    """

    v_max: float | None = option(
        None,
        "observer gain V_M of eq. (20), in state units/s² (none: gamma·drift_bound)",
        range=(1e-12, 1e12),
    )
    gamma: float = option(1.0, "Γ of eq. (21), V_M = Γ·Φ̄", range=(1e-6, 1e12))
    drift_bound: float | None = option(
        None,
        "Φ̄ of eqs. (17), (19): bound of the drift |φ_i| in state units/s²",
        range=(1e-15, 1e12),
    )
    alpha: float = option(
        1.0,
        "α* of the suboptimal algorithm [19]: gain α*·V_M where (e−½e_M)(e_M−e) > 0 "
        "(1: eq. (20) as printed)",
        range=(1e-3, 1.0),
    )
    channel_gains: Literal["uniform", "rows"] = option(
        "uniform",
        "gain of channel i: uniform V_M (eq. (20)) or rows, V_M·‖D_i‖₁/max_l ‖D_l‖₁ (eq. (17))",
    )
    threshold: float = option(
        0.5,
        "threshold of eq. (32): δ̂_j = 1 where δ̃_j exceeds it (Lemma 1's margin: min(τ, 1−τ))",
        range=(0.0, 1.0),
        above=True,
        below=True,
    )
    max_unvouched: float = option(
        0.5,
        "largest share of samples whose σ̂ Lemma 1 cannot vouch for (33) before a refusal "
        "(1: never)",
        range=(0.0, 1.0),
        above=True,  # 0 never passes: the first samples are never vouched for
    )

    def missing(self) -> str | None:
        """Why these values give no gain ``V_M`` (neither ``v_max`` nor ``drift_bound``), or None.

        Found by :func:`~hybridlog.estimators.registry.prepare`, before any log is read:
        the run found it only once the log had been read and aligned, and ``compare`` once
        the estimators before it had run.
        """
        if self.v_max is not None or self.drift_bound is not None:
            return None
        return (
            "sliding-mode needs the gain V_M: set v_max, or drift_bound (Φ̄ of eq. (19)) and "
            "gamma (Γ of eq. (21)); --set v_max=... works too"
        )

    @classmethod
    def inert_on(cls, model: HybridModel) -> dict[str, str]:
        """Options that ``model`` leaves unread whatever the others say: name → why.

        With one state there is one channel, and ``rows`` gives it V_M as ``uniform`` does.
        """
        if model.n_states == 1:
            return {
                "channel_gains": f"{model.name} has one state, one channel of eq. (16), whose "
                "gain is V_M whether uniform or rows"
            }
        return {}

    def inert(self, model: HybridModel) -> dict[str, str]:
        """Options that have no effect with the others' values on ``model``: name → why.

        ``v_max`` is V_M itself: ``gamma`` and ``drift_bound`` give V_M = Γ·Φ̄ (21) only
        without it; ``--set v_max=0.5 --set gamma=1000`` ran with V_M = 0.5 while
        report.json recorded gamma = 1000 as an option used.  Also :meth:`inert_on`.
        """
        inert = self.inert_on(model)
        if self.v_max is not None:
            why = (
                f"v_max = {self.v_max:g} is V_M itself, and {{}} enters only V_M = Γ·Φ̄ (eq. "
                "(21)) without it; leave it unset, or drop v_max"
            )
            inert["gamma"] = why.format("gamma (Γ)")
            inert["drift_bound"] = why.format("drift_bound (Φ̄)")
        return inert
