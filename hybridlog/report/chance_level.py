r"""The warning that a mode accuracy is below chance (Cohen's kappa below 0).

Below chance: the estimate agrees with the truth less often than modes drawn independently
of it would.

Chance is the agreement of estimated modes drawn independently of the true ones with the
same frequencies as the estimate's (Cohen's chance agreement),

.. math::

    p_e = \sum_m p_{\mathrm{true}}(m)\, p_{\mathrm{est}}(m), \qquad
    \kappa = \frac{a - p_e}{1 - p_e},

with ``a`` the mode accuracy over the same samples.  An accuracy below ``p_e`` (κ < 0)
means the estimated modes are anti-correlated with the true ones: a labelling the reverse
of the truth, say.  Not the majority share: on a log whose true mode is '1' 98 % of the
time, an estimate that catches every '2' with some false alarms scores below 98 % and is
far from chance.  On a log with a single true mode every estimate is at chance (κ = 0) and
none is warned of.

Paper 001's clustering estimators on the double cart (``chiu``, ``kmeans``;
docs/double_cart.md "Beyond sinusoids") scored 0.26-0.43 on a chirp or a 1 rad/s sine,
exit 0 and no word; :func:`chance_level_warning` says it of a report,
:func:`below_chance` of ``hybridlog cluster``'s decision rule.
"""

from __future__ import annotations

from collections.abc import Mapping
from decimal import Decimal, localcontext

from hybridlog.report.document import Report
from hybridlog.report.markdown import WARNING_PREFIX

__all__ = ["below_chance", "chance_level_warning"]


def below_chance(confusion: Mapping[str, Mapping[str, int]]) -> str | None:
    """``mode accuracy 28.3 % is below chance ...`` when it is, else ``None``.

    ``confusion``: ``{true mode: {estimated mode: samples}}`` over the scored samples.
    """
    scored = sum(sum(row.values()) for row in confusion.values())
    if scored == 0:
        return None
    hits = sum(row.get(mode, 0) for mode, row in confusion.items())
    estimated: dict[str, int] = {}
    for row in confusion.values():
        for mode, count in row.items():
            estimated[mode] = estimated.get(mode, 0) + count
    agree = sum(sum(row.values()) * estimated.get(mode, 0) for mode, row in confusion.items())
    if hits * scored >= agree:  # compared exactly, in integers
        return None
    chance, accuracy = agree / (scored * scored), hits / scored
    kappa = (accuracy - chance) / (1.0 - chance)
    # digits that tell the two apart, and a kappa that is not "-0.00": 50.2 % of random
    # labels against a chance of 50.5 % read "Cohen's kappa -0.00", below chance at zero
    shown: tuple[float | Decimal, float | Decimal] = (accuracy, chance)
    if accuracy == chance:  # apart only beyond float64's digits (some 1e8 samples): exactly
        with localcontext() as exact:
            exact.prec = 60
            shown = (Decimal(hits) / scored, Decimal(agree) / (scored * scored))
            kappa = float((shown[0] - shown[1]) / (1 - shown[1]))  # not 0: -1e-17
    digits = next(d for d in range(1, 40) if f"{shown[0]:.{d + 2}f}" != f"{shown[1]:.{d + 2}f}")
    kappa_shown = f"{kappa:.2f}" if kappa <= -0.005 else f"{kappa:.1g}"
    return (
        f"mode accuracy {100 * shown[0]:.{digits}f} % is below chance: estimated modes drawn "
        f"independently of the true ones, with the same frequencies, would agree on "
        f"{100 * shown[1]:.{digits}f} % of these {scored:,} samples (Cohen's kappa "
        f"{kappa_shown}); the estimated modes are anti-correlated with the true ones"
    )


def chance_level_warning(report: Report) -> str | None:
    """The warning that the joint mode accuracy is below chance, or ``None``.

    ``None`` without a true mode or a confusion table (a ``[components]`` model's
    per-component tables are its components', not the joint one's).
    """
    modes = report.modes
    if modes.accuracy is None or not modes.confusion or modes.components:
        return None
    below = below_chance(modes.confusion)
    return None if below is None else f"{WARNING_PREFIX}{below}"
