"""The outputs an estimate explains: ``ŷ(k) = h_q̂(k)(x̂(k), u(k))`` through the model's ``h``.

A smoothed run (``--smooth``) has no one-step-ahead prediction of its own: the smoothed state
``x̂(k|N)`` used every measurement, ``y(k)`` included.  How well the estimated mode and state
explain the measured outputs is reported instead, for the filter's estimates and the
smoothed ones alike (``smoothing.filtered.outputs`` and ``smoothing.smoothed.outputs`` of
``report.json``), by passing each estimate through the output map of its estimated mode.
This is an a-posteriori fit, not a prediction: it is never the basis of the top-level MSE,
VAF and fit, which stay the filter's one-step-ahead prediction (paper 001, section 5).

The loop over samples is compiled (numba) around the model's own compiled ``h``
(:func:`hybridlog.model.compiled.compile_model`): the kernel takes ``h`` as a first-class
function of one fixed signature, so it is compiled once for every model and cached on disk.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from hybridlog.errors import ModelError
from hybridlog.signals import AlignedSignals, FloatArray, IntArray

if TYPE_CHECKING:
    from hybridlog.estimators.result import EstimationResult
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["explained_outputs", "with_explained_outputs"]


def _through_h(h: Any, modes: IntArray, x: FloatArray, u: FloatArray, out: FloatArray) -> None:
    """``out[k] = h(modes[k], x[k], u[k])`` for every sample (the model's output map)."""
    for k in range(modes.shape[0]):
        h(modes[k], x[k], u[k], out[k])


def explained_outputs(
    model: HybridModel, result: EstimationResult, signals: AlignedSignals, *, jit: bool = True
) -> FloatArray | None:
    """``ŷ(k) = h_q̂(k)(x̂(k), u(k))`` for every sample of ``result``, shape ``(N, n_y)``.

    Parameters
    ----------
    model:
        The model the result was estimated with.
    result:
        Its estimated modes ``q̂`` and states ``x̂`` (filtered or smoothed).
    signals:
        The aligned signals (the inputs ``u``).
    jit:
        Compile the loop (``False``: plain Python, the tests' reference).

    Returns
    -------
    numpy.ndarray or None
        The outputs; NaN where a state is not finite.  ``None`` when the model's ``h``
        cannot be evaluated here: its modes, states or outputs are not the result's, or it
        has no discrete-time mode functions (a continuous-time, jump or components model).

    """
    if (
        tuple(str(m) for m in model.mode_ids) != tuple(str(m) for m in result.mode_ids)
        or tuple(model.states) != tuple(result.state_names)
        or tuple(model.outputs) != tuple(result.output_names)
        or signals.inputs.shape != (result.n_samples, model.n_inputs)
    ):
        return None
    from hybridlog.model.compiled import compile_model

    try:
        compiled = compile_model(model, jit=jit)
    except ModelError:
        return None
    arguments = (
        compiled.h,
        np.ascontiguousarray(result.modes, dtype=np.int64),
        np.ascontiguousarray(result.state_means, dtype=np.float64),
        np.ascontiguousarray(signals.inputs, dtype=np.float64),
        np.zeros((result.n_samples, len(result.output_names)), dtype=np.float64),
    )
    if jit:
        from hybridlog.jit import compile_for

        compile_for(_through_h, arguments)(*arguments)
    else:
        _through_h(*arguments)
    out: FloatArray = arguments[-1]
    return out


def with_explained_outputs(
    model: HybridModel, result: EstimationResult, signals: AlignedSignals
) -> EstimationResult:
    """``result`` with the outputs its offline estimate and its filter's explain.

    For a result with ``post_processing`` (a smoothed or re-sequenced run): its ``explained``
    and ``filtered_explained`` (:func:`explained_outputs` of the result and of the filter's
    result inside it).  The registry's run (:meth:`hybridlog.estimators.Prepared.run`) calls
    it where the estimate is made, in the estimators' worker of a command, which has the
    model's compiled ``h`` loaded already.  Other results are returned as they are.
    """
    post = result.post_processing
    if post is None:
        return result
    return replace(
        result,
        post_processing=replace(
            post,
            explained=explained_outputs(model, result, signals),
            filtered_explained=explained_outputs(model, post.filtered, signals),
        ),
    )
