"""What every report of a model says of the model: its twin modes and its warnings.

:func:`model_notes`: a note per group of modes (of the model, or of one component) no log can
tell apart, and the ``WARNING:`` lines of the model's diagnoses.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from hybridlog.report.markdown import WARNING_PREFIX

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["model_notes"]


_MOST_TWINS_NAMED = 10
"""Most modes of one group of twins a note names (the rest counted)."""


def model_notes(model: HybridModel | None) -> tuple[str, ...]:
    """What report.md must say of the model: modes no log can tell apart, and its warnings.

    Twin modes (``twin_modes``) give the same log, so an estimate picks among them by their
    order or their Markov rows, never by the data, and the mode metrics score the log's
    samples of the one not picked as errors; said in every report of such a model, whatever
    the estimator.  The warnings of the model's diagnoses (``diagnoses``: states no output
    determines, a mode whose outputs read no state, a continuous mode too stiff for its
    step) follow: after them the state estimates are not what they seem.
    """
    if model is None:
        return ()
    notes = []
    for twins in model.twin_modes:
        quoted = [f"'{m}'" for m in twins]
        if len(twins) <= _MOST_TWINS_NAMED:
            names = ", ".join(quoted[:-1]) + f" and {quoted[-1]}"
        else:  # many twins (booleans no equation uses): the first and the last named
            shown = ", ".join(quoted[: _MOST_TWINS_NAMED - 1])
            names = f"{shown}, ... and {quoted[-1]} ({len(twins)} modes)"
        notes.append(
            f"NOTE: modes {names} have the same equations and noise (f, h, process and "
            "measurement noise; guards and jump maps alike): no log can tell them apart"
            + (
                ""
                if _interchangeable(model, twins)
                else " (their [transitions] rows or initial probabilities differ: only the "
                "estimators' priors on the switches set them apart)"
            )
            + ". Between them the estimate follows the modes' order and Markov rows, not the "
            f"data (where their probabilities or errors tie, '{twins[0]}', the first listed, "
            "is taken), so the mode accuracy, confusion and detection delays count "
            "the log's samples of the one not picked as errors; merge them, or give them "
            "different equations or noise if they are to be told apart"
        )
    for component, twins in model.component_twin_modes:
        quoted = [f"'{m}'" for m in twins]
        notes.append(
            f"NOTE: component '{component}': modes {', '.join(quoted[:-1])} and {quoted[-1]} "
            "have the same equations and noise (process and measurement): no log can tell "
            "them apart. Between them the estimate follows the modes' order, initial and "
            "transition probabilities, not the data, so the mode accuracy, confusion and "
            f"detection delays of component '{component}' count the log's samples of the one "
            "not picked as errors; merge them, or give them different equations or noise if they "
            "are to be told apart"
        )
    notes += [line for line in model.diagnoses if line.startswith(WARNING_PREFIX)]
    return tuple(notes)


def _interchangeable(model: HybridModel, twins: tuple[str, ...]) -> bool:
    """Whether swapping the first twin with any other leaves the priors as they are.

    The priors: ``[transitions]`` and ``[initial]``; when they are symmetric in the twins,
    nothing at all sets the twins apart.
    """
    first = model.mode_index(twins[0])
    markov, prior = model.transitions, model.initial_mode_probabilities
    for twin in twins[1:]:
        order = np.arange(model.n_modes)
        other = model.mode_index(twin)
        order[[first, other]] = order[[other, first]]
        if not np.array_equal(prior[order], prior):
            return False
        if markov is not None and not np.array_equal(markov[np.ix_(order, order)], markov):
            return False
    return True
