"""The options of the offline passes after a filter (``docs/smoothing.md``), and who has them.

``smooth``, ``mode_sequence``, ``beam`` and ``smoother`` are options of the estimators
whose capabilities declare a smoother (``Capabilities.supports_smoothing``).  Whichever way
one is given to an estimator without it — ``--smooth``, ``--mode-sequence``, ``--set``, or a
key of its ``[estimators.<name>]`` table in a model file — the refusal says why that
estimator has no offline pass (``Capabilities.no_smoothing``) and which estimators do
(:func:`not_offered`): the table's key was refused as "hstf has no option 'smooth'".
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from hybridlog.estimators.registry import Estimator

SMOOTH_OPTION = "smooth"
"""The estimator option ``--smooth`` sets (``smooth = true`` under ``[estimators.<name>]``)."""

MODE_SEQUENCE_OPTION = "mode_sequence"
"""The estimator option ``--mode-sequence`` sets (``argmax``, ``viterbi`` or ``kbest``)."""

OFFLINE_OPTIONS = (SMOOTH_OPTION, MODE_SEQUENCE_OPTION, "beam", "smoother")
"""The options of the offline passes; the forward pass's run depends on none of them."""


def option_names(estimator: Estimator) -> set[str]:
    """The names of the options ``estimator`` declares."""
    return {info.name for info in estimator.describe_options()}


def admits(estimator: Estimator, option: str) -> bool:
    """Whether the estimator has the option (and, for ``smooth``, declares a smoother)."""
    if option == SMOOTH_OPTION:
        return estimator.capabilities.supports_smoothing and option in option_names(estimator)
    return option in option_names(estimator)


def choices(estimator: Estimator, option: str) -> list[str]:
    """The values an estimator's option of a ``Literal`` type takes."""
    return next(i.type for i in estimator.describe_options() if i.name == option).split("|")


def offers(estimator: Estimator, option: str, value: str) -> bool:
    """Whether the estimator has the option and, for ``mode_sequence``, that value of it."""
    if not admits(estimator, option):
        return False
    return option != MODE_SEQUENCE_OPTION or value in choices(estimator, option)


def not_offered(
    estimator: Estimator, option: str, value: object, estimators: Iterable[Estimator]
) -> str:
    """Why ``estimator`` does not offer ``option`` (= ``value``), and which of ``estimators`` do.

    ``"does not offer it: <why> (estimators that do: imm)"``.  The reason answers the value:
    ``mode_sequence = "argmax"`` asks for no offline pass, so its refusal says how the
    estimator decides its modes instead (``Capabilities.mode_rule``, hstf's threshold rule),
    the others why it has no offline pass (``Capabilities.no_smoothing``).
    """
    having = [e.name for e in estimators if offers(e, option, str(value))]
    return f"{lacks(estimator, option, value)} (estimators that do: {', '.join(having) or 'none'})"


def lacks(estimator: Estimator, option: str, value: object) -> str:
    """``"does not offer it: <why>"``: :func:`not_offered` without the estimators that do.

    For a note that names them already: ``compare``'s ``--set smooth=true reaches imm alone``.
    """
    capabilities = estimator.capabilities
    argmax = option == MODE_SEQUENCE_OPTION and str(value) == "argmax"
    why = capabilities.mode_rule if argmax else capabilities.no_smoothing
    return f"does not offer it{': ' + why if why else ''}"
