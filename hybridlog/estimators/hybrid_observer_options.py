"""Options of paper 004's ``switching-observer`` (a light module: no numba, sympy, scipy).

The estimator (:mod:`hybridlog.estimators.hybrid_observer`) imports sympy and numba; its
options live here so that the registry, ``--help`` and a batch's planning read them without
loading either.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from hybridlog.errors import OptionError, excerpt
from hybridlog.estimators.options import option
from hybridlog.numbers import parse_float

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    from hybridlog.model.hybrid_model import HybridModel

__all__ = [
    "CONDITION_CEILING",
    "DEFAULT_EIGENVALUES",
    "SwitchingObserverOptions",
    "companion_gain",
    "eigenvalue_values",
    "gain_flaw",
    "step_flaw_of",
]

DEFAULT_EIGENVALUES = "-5"
"""One value ``λ``: the eigenvalues ``λ, 2λ, …, nλ`` of ``A_b − K C_b`` (distinct, real)."""


def eigenvalue_values(text: str) -> list[float]:
    """The numbers of an ``eigenvalues`` text: negative reals separated by commas.

    Raises
    ------
    ValueError
        With the reason, for text that is not that.
    """
    if not text.strip():  # an empty TOML array reads as this text (``eigenvalues = []``)
        raise ValueError(
            "expected one negative number, or one per state, got none "
            f"(default {DEFAULT_EIGENVALUES})"
        )
    values: list[float] = []
    for part in text.split(","):
        try:
            values.append(parse_float(part))
        except ValueError as err:
            # '-1e-400' is a number, but one a double does not hold: say so
            why = "" if str(err) == "expected a finite number" else f" ({part.strip()}: {err})"
            raise ValueError(
                f"expected negative numbers separated by commas, got {excerpt(text)}{why}"
            ) from None
    if not all(v < 0.0 for v in values):
        raise ValueError(
            f"every eigenvalue must be a finite negative real (Hurwitz A_b - K C_b), got "
            f"{excerpt(text)}"
        )
    return values


CONDITION_CEILING = 2.0**52
"""The largest ``condition_limit``: ``1/ε`` of float64.  A correction solved with ``Q`` of
``κ₁(Q)`` past it may hold no correct digit, so a larger limit (``1e300`` was accepted) only
silenced the warning where it matters most."""


@dataclass(frozen=True)
class SwitchingObserverOptions:
    """Options of the ``switching-observer`` estimator (paper 004, observer (20)).

    ``eigenvalues`` is the set Λ of Section 5: the gain ``K(Λ)`` places the eigenvalues of
    the Brunovsky pair's ``A_b − K C_b`` at these real values.  One value ``λ`` stands for
    ``λ, 2λ, …, nλ`` (distinct, ``λ`` the slowest, as Lemma 4's ``λ_n < … < λ_1 < 0``); a
    comma-separated list gives all ``n`` of them.
    """

    eigenvalues: str = option(
        DEFAULT_EIGENVALUES,
        "eigenvalues of A_b - K C_b (sec. 5): n negative reals 'l1,l2,...', "
        "or one value l for l, 2l, ..., nl",
        check=eigenvalue_values,
        items=float,
    )
    output_hold: Literal["first", "zero"] = option(
        "first",
        "y between samples: first = extrapolated from the last two samples (causal), zero = held",
    )
    condition_limit: float = option(
        1e6,
        "warn where kappa_1 of Q(sigma, x) = dPhi/dx (eq. (21)) exceeds this (up to 1/eps = 2^52)",
        range=(1.0, CONDITION_CEILING),
    )

    def eigenvalue_list(self, n_states: int) -> tuple[float, ...]:
        """The ``n_states`` eigenvalues Λ, slowest (largest) first.

        Raises
        ------
        OptionError
            The text is not one negative number or ``n_states`` comma-separated ones.
        """
        try:
            values = _eigenvalues_for(self.eigenvalues, n_states)
        except ValueError as err:
            raise OptionError(f"switching-observer option 'eigenvalues': {err}") from None
        return tuple(sorted(values, reverse=True))

    def invalid_on(self, model: HybridModel) -> dict[str, str]:
        """Values ``model`` cannot take: name → why.

        ``eigenvalues``: one or ``n`` of them; a gain ``K(Λ)`` float64 holds
        (:func:`gain_flaw`); each inside the stability region of the model's integration
        step (:func:`step_flaw_of`).  Found only as the estimator ran, three eigenvalues for
        a two-state model were refused naming neither the model file nor its key, and passed
        when another estimator ran; so were ``"-1e300"`` and ``"-1e4"`` (too fast for a 1 ms
        RK4 step) until the gain and step checks were made here too.
        """
        try:
            values = _eigenvalues_for(self.eigenvalues, model.n_states)
        except ValueError as err:
            return {"eigenvalues": str(err)}
        eigenvalues = tuple(sorted(values, reverse=True))
        flaw = gain_flaw(eigenvalues) or step_flaw_of(model, eigenvalues)
        return {"eigenvalues": flaw} if flaw else {}


def companion_gain(eigenvalues: tuple[float, ...]) -> npt.NDArray[np.float64]:
    """``K(Λ)``: the coefficients ``K_1 … K_n`` of ``∏(s − λ_j)`` after its leading 1.

    ``A_b − K C_b`` is the companion matrix of ``s^n + K_1 s^{n−1} + … + K_n``; entries may
    overflow to ``inf`` or underflow to 0 (:func:`gain_flaw` says so).
    """
    import numpy as np  # not at import: --help reads these options without numpy

    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        gain = np.poly(np.asarray(eigenvalues, dtype=np.float64))[1:].real
    return np.ascontiguousarray(gain, dtype=np.float64)


def gain_flaw(eigenvalues: tuple[float, ...]) -> str | None:
    """Why ``K(Λ)`` is not a gain placing Λ, or ``None``.

    Every ``λ_j < 0`` makes every ``K_j > 0``; a coefficient that is not a positive finite
    float64 (it overflows, or underflows to 0) places other eigenvalues than Λ (``K_n = 0``
    puts one at 0), which a report would still name.
    """
    import numpy as np

    gain = companion_gain(eigenvalues)
    wrong = np.flatnonzero(~(np.isfinite(gain) & (gain > 0.0)))
    if not wrong.size:
        return None
    j = int(wrong[0])
    return (
        f"the gain K_{j + 1} of {', '.join(f'{v:g}' for v in eigenvalues)} (the coefficient "
        f"of s^{len(gain) - j - 1} in the product of (s - l_j)) is {gain[j]:g}, not a positive "
        "float64: A_b - K C_b would not have these eigenvalues; choose them nearer to 1 in size"
    )


def step_flaw_of(model: HybridModel, eigenvalues: tuple[float, ...]) -> str | None:
    """Why the model's integration step cannot follow an eigenvalue of Λ, or ``None``.

    Linearised, observer (20)'s error decays in the coordinates Φ with ``A_b − K C_b``,
    whose eigenvalues are Λ; the fixed step of ``integration`` must keep each of them
    inside its method's stability region (:mod:`hybridlog.model.stability`), or the
    estimate grows, or rings, where the design has it decay.
    """
    import numpy as np

    from hybridlog.model.stability import step_flaw

    timebase = model.timebase
    if timebase.method is None:
        return None
    flaw = step_flaw(timebase.method, timebase.step, np.diag(eigenvalues))
    if flaw is None:
        return None
    return (
        f"λ = {flaw.eigenvalue.real:g} 1/s is too fast for integration.step = "
        f"{timebase.step:g} s of {model.origin or model.name}: {flaw.describe(timebase.method)}"
    )


def _eigenvalues_for(text: str, n_states: int) -> list[float]:
    """The ``n_states`` eigenvalues of an ``eigenvalues`` text (one stands for ``l, ..., nl``).

    Raises
    ------
    ValueError
        With the reason: not negative numbers, neither one nor ``n_states`` of them, or
        ``n_states`` times the one overflowing a float64.
    """
    values = eigenvalue_values(text)
    if len(values) == 1:
        values = [values[0] * (j + 1) for j in range(n_states)]
        if not math.isfinite(values[-1]):
            raise ValueError(
                f"one value l stands for l, 2l, ..., {n_states}l, and "
                f"{n_states}*({excerpt(text)}) overflows a float64"
            )
    elif len(values) != n_states:
        raise ValueError(
            f"the model has {n_states} states, so give {n_states} eigenvalues or one, not "
            f"{len(values)} ({excerpt(text)})"
        )
    return values
