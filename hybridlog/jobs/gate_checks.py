"""The CI gates of a run, parsed and checked against its prepared estimators before any work.

:func:`gates_for` refuses, before any log is read, a gate that a report of the run could not
be read for: one on the smoother's fallbacks where an estimator runs no smoother
(:func:`without_smoother`), one on a mode metric where an estimator reads its modes from the
log (:func:`modes_given`).  Shared by ``analyze``, ``compare`` and ``batch``.
"""

from __future__ import annotations

from collections.abc import Sequence

from hybridlog.estimators import Prepared
from hybridlog.estimators.offline_options import MODE_SEQUENCE_OPTION, SMOOTH_OPTION
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.report import parse_gates, validate_gates
from hybridlog.report.gates import Gate


def gates_for(
    model: HybridModel,
    prepared: Sequence[Prepared],
    fail_under: Sequence[str],
    fail_over: Sequence[str],
) -> list[Gate]:
    """Parse the CI gates and check that every report of the run can be read for them.

    The outputs, states and components they name must exist, a gate on the smoother's
    fallbacks needs a smoother on every estimator of ``prepared`` (:func:`without_smoother`),
    and a gate on a mode metric needs every estimator of ``prepared`` to estimate its modes
    (:func:`modes_given`: ``compare --estimators sliding-mode,switching-observer
    --fail-under mode_accuracy=0.9`` failed switching-observer's gate after every run, as
    its report scores no mode metric).
    """
    gates = parse_gates(fail_under, fail_over)
    validate_gates(
        gates,
        output_names=model.outputs,
        state_names=model.states,
        component_names=[c.name for c in model.components],
        without_smoother=without_smoother(prepared),
        modes_given=modes_given(prepared, model),
    )
    return gates


def modes_given(prepared: Sequence[Prepared], model: HybridModel | None = None) -> dict[str, str]:
    """The estimators of ``prepared`` that read their modes from the log, each with why.

    An estimator that needs the switching signal takes it as its modes, and the log's true
    mode is that signal: its report scores no mode metric (``EstimationResult.modes_given``,
    paper 004), which comparison.md says of it too.  On a one-mode ``model`` its sigma is
    that mode, with or without the signal in the log.
    """
    why = "it reads its modes from the log's switching signal, the log's true mode"
    if model is not None and model.n_modes == 1:
        why = "its model has one mode, which is sigma at every sample"
    return {p.name: why for p in prepared if p.estimator.capabilities.needs_switching_signal}


def without_smoother(prepared: Sequence[Prepared]) -> dict[str, str]:
    """The estimators of ``prepared`` that run no smoother, each with why, in order.

    A smoother runs where the estimator has one and its option ``smooth`` is true
    (``--smooth``, ``--set smooth=true`` or the model file); only then does report.json have
    ``smoothing.fallbacks``.
    """
    missing: dict[str, str] = {}
    for p in prepared:
        capabilities = p.estimator.capabilities
        if not capabilities.supports_smoothing:
            missing[p.name] = "it has none"
        elif not getattr(p.options, SMOOTH_OPTION, False):
            sequence = getattr(p.options, MODE_SEQUENCE_OPTION, "argmax")
            alone = "" if sequence == "argmax" else f", --mode-sequence {sequence} alone"
            missing[p.name] = f"smooth = false{alone}; add --smooth"
    return missing
