r"""A state-driven model whose output equations differ by mode, as a Markov chain of mode pairs.

A Markov-jump filter (paper 000 eq. (2)) weighs ``y(k)`` with the output equation of the
mode under which ``x(k)`` came from ``x(k-1)``.  In a state-driven model (paper 001 eq. (1))
the mode of sample k governs both ``y(k)`` and the step *from* ``x(k)``:

.. math::

    x(k) = f_{q(k-1)}(x(k-1), u(k-1)) + \xi,\qquad y(k) = h_{q(k)}(x(k), u(k)) + \omega

so where the modes' ``h`` differ the filter applies, at every switch, the output equation of
the mode the plant has just left.  On a guarded model with ``h = x`` in one mode and ``2x`` in
the other the IMM missed 12 of 24 switches (VAF 0 %).

The pair ``(q(k-1), q(k))`` is a Markov chain whose modes have exactly the filter's form:
mode ``a->b`` steps with ``f_a`` and its process noise and measures with ``h_b`` and its
measurement noise; ``a->b`` is followed by ``b->c`` with the original ``Π[b, c]`` and by no
pair that does not start in ``b``.  The filter, its smoothers and its mode-sequence decoders
run on the ``n²`` pairs unchanged (zero entries of the Markov matrix rule a transition out),
and the result is read back in the model's own modes (:func:`merged_modes`): the mode of
sample k is ``b``, the mode of the step from ``x(k)``, as the log's truth records it, so
nothing is moved a sample.  The prior gives each ``a->b`` the model's initial probability
of ``b`` shared alike over ``a``: row 0 is the filter's prior, and from it only ``b``
matters (the first step, into ``b->c``, is ``f_b``'s).
"""

from __future__ import annotations

import dataclasses
import hashlib

import numpy as np

from hybridlog.estimators.capabilities import runs_on_pairs
from hybridlog.estimators.result import EstimationResult
from hybridlog.model.hybrid_model import HybridModel, LinearForm, Mode, replaced, stored
from hybridlog.model.keys import remember_key
from hybridlog.signals import FloatArray, IntArray

__all__ = [
    "PAIRED_MODES_NOTE",
    "merged_modes",
    "pair_mode_model",
    "pair_named",
    "pair_transitions",
    "runs_on_pairs",
]

PAIRED_MODES_NOTE = (
    "state-driven model whose output equations differ by mode: estimated over the pairs "
    "(mode of the step into x(k), mode of the step from it), a Markov chain, so that y(k) is "
    "weighed with the output equation of its own mode (paper 001 eq. (1)); sample k shows "
    "the mode of the step from x(k), the probabilities summed over the pairs"
)
"""The note of a run on :func:`pair_mode_model`'s modes."""

ARROW = "->"


def _linear_form(step: Mode, measure: Mode) -> LinearForm | None:
    """The pair's matrices: ``A``, ``B``, ``c`` of ``step``, ``C``, ``D``, ``d`` of ``measure``."""
    if step.linear_form is None or measure.linear_form is None:
        return None
    return dataclasses.replace(
        step.linear_form,
        C=measure.linear_form.C,
        D=measure.linear_form.D,
        output_offset=measure.linear_form.output_offset,
    )


def _pair(step: Mode, measure: Mode) -> Mode:
    """Mode ``step->measure``: the dynamics of ``step``, the output equations of ``measure``.

    The expressions are carried as they are held (:func:`stored`): a model read from the
    cache keeps them as text until a compilation asks.
    """
    return Mode(
        id=f"{step.id}{ARROW}{measure.id}",
        process_noise=step.process_noise,
        measurement_noise=measure.measurement_noise,
        f=stored(step, "f"),
        h=stored(measure, "h"),
        dx=stored(step, "dx"),
        guard=None,
        linear_form=_linear_form(step, measure),
        nonlinear_key=step.nonlinear_key or measure.nonlinear_key,
        process_noise_key=step.process_noise_key,
        measurement_noise_key=measure.measurement_noise_key,
    )


def pair_transitions(transitions: FloatArray) -> FloatArray:
    """``Π₂[a->b, c->d] = Π[b, d]`` where ``c = b``, else 0 (pairs in row-major order)."""
    n = transitions.shape[0]
    paired = np.zeros((n, n, n, n))
    for b in range(n):
        paired[:, b, b, :] = transitions[b]
    return paired.reshape(n * n, n * n)


def pair_mode_model(model: HybridModel, transitions: FloatArray) -> HybridModel:
    """``model`` over its ``n²`` mode pairs ``a->b`` (row-major), with ``transitions`` paired.

    ``transitions`` is the original modes' Markov matrix.  The pairs have no guards, so the
    model is not state-driven.  Its content key is derived from the original's, the Markov
    matrix and the prior (it is a function of them), so a warm run needs no sympy.
    """
    from hybridlog.model.compiled import model_key

    modes = tuple(_pair(a, b) for a in model.modes for b in model.modes)
    n = model.n_modes
    prior = np.repeat(model.initial_mode_probabilities[np.newaxis, :], n, axis=0).ravel() / n
    paired = pair_transitions(transitions)
    pairs = replaced(  # a model read from the cache keeps its expressions unread
        model,
        modes=modes,
        transitions=paired,
        initial_mode_probabilities=prior,
        twin_modes=(),
        outputs_differ=True,
    )
    digest = hashlib.sha256(f"mode pairs of {model_key(model)}".encode())
    digest.update(np.ascontiguousarray(paired).tobytes())
    digest.update(np.ascontiguousarray(prior).tobytes())
    remember_key(pairs, digest.hexdigest())
    return pairs


def pair_named(index: int, model: HybridModel) -> str:
    """Pair ``index`` of :func:`pair_mode_model`'s pairs of ``model`` in its own modes' ids.

    ``'b' (after a step of 'a')`` for ``a->b``: ``b`` is the mode of the sample, as the log's
    truth records it, whose ``h`` weighs ``y(k)``; ``a``'s ``f`` brought ``x(k)``.  A refusal
    of a run on the pairs names no pair the file does not have.
    """
    from hybridlog.errors import excerpt

    n = model.n_modes
    step, measure = model.modes[index // n], model.modes[index % n]
    return f"{excerpt(measure.id)} (after a step of mode {excerpt(step.id)})"


def merged_modes(result: EstimationResult, model: HybridModel, *, argmax: bool) -> EstimationResult:
    """A result over :func:`pair_mode_model`'s pairs read in ``model``'s own modes.

    Each mode's probability is the sum over the pairs that end in it; the mode of a sample is
    the most probable of them (``argmax``: the pair result's modes were its argmax) or the
    end of the pair the result chose (a Viterbi or k-best path).  The filter's own result
    under :attr:`~EstimationResult.post_processing` is read back alike (as an argmax); the
    outputs explained, which depend on the modes, are left to be computed afresh.
    """
    n = model.n_modes
    probabilities: FloatArray = result.mode_probabilities.reshape(-1, n, n).sum(axis=1)
    ends: IntArray = (
        np.argmax(probabilities, axis=1) if argmax else np.asarray(result.modes % n, np.int64)
    )
    post = result.post_processing
    if post is not None:
        post = dataclasses.replace(
            post,
            filtered=merged_modes(post.filtered, model, argmax=True),
            explained=None,
            filtered_explained=None,
        )
    return dataclasses.replace(
        result,
        mode_ids=model.mode_ids,
        modes=np.ascontiguousarray(ends, dtype=np.int64),
        mode_probabilities=np.ascontiguousarray(probabilities),
        notes=(*result.notes, PAIRED_MODES_NOTE),
        post_processing=post,
    )
