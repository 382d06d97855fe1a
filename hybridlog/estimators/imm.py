r"""Interacting multiple model (IMM) estimator with an extended Kalman filter per mode.

The classic baseline (Blom and Bar-Shalom 1988; Bar-Shalom, Li, Kirubarajan 2001, §11.6.6):

.. math::

    \bar c_j = \sum_i \Pi_{ij}\mu_i,\qquad
    \mu_{i|j} = \Pi_{ij}\mu_i/\bar c_j                           \quad \text{(mixing)}

    \hat x^0_j = \sum_i \mu_{i|j}\hat x_i,\qquad
    P^0_j = \sum_i \mu_{i|j}(P_i + (\hat x_i-\hat x^0_j)(\cdot)^T)

    \text{EKF}_j:\; \hat x_j^- = f_j(\hat x^0_j, u),\;
    P_j^- = F_j P^0_j F_j^T + Q_j,\; \gamma_j = y - h_j(\hat x_j^-)

    \mu_j \propto \bar c_j\, N(\gamma_j; 0, H_j P_j^- H_j^T + R_j)

``Π[i, j] = Pr(q(k+1)=j | q(k)=i)`` comes from the model's ``[transitions]`` or from the
option ``transition_stay`` (default 0.95 on the diagonal, the rest spread evenly).  The
measurement update uses the Joseph form; mode probabilities are normalised in log space.
The mode estimate is the most probable mode; the one-step-ahead output prediction is
``Σ_j c̄_j h_j(x̂_j^-)``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import replace
from functools import partial
from typing import Any, NamedTuple

import numpy as np

from hybridlog.errors import independent_of
from hybridlog.estimators.common import (
    Accelerator,
    CheckedAs,
    Chunk,
    FilterBuffers,
    FilterCode,
    FilterRun,
    Fn,
    ModeStore,
    contiguous,
    run_filter,
    run_filter_chunks,
    upper_pairs,
)
from hybridlog.estimators.filter_options import ImmOptions
from hybridlog.estimators.kernels import (
    Workspace,
    argmax,
    congruence,
    dimensions,
    kalman_update,
    leave_out_unmeasured,
    left_out,
    measured_log_density,
    mixture_moments,
    mixture_moments_of,
    normalize_log,
    possible_sources,
    record,
    weighed,
    workspace,
)
from hybridlog.estimators.mode_pairs import (
    merged_modes,
    pair_mode_model,
    pair_transitions,
    runs_on_pairs,
)
from hybridlog.estimators.offline_options import OFFLINE_OPTIONS
from hybridlog.estimators.options import options_dict
from hybridlog.estimators.result import EstimationResult
from hybridlog.estimators.unrolled import (
    Entry,
    Matrix,
    Program,
    Vector,
    matrix_names,
    noise_matrices,
    product,
    reshape,
    state_slots,
    term,
    upper,
    vector_names,
)
from hybridlog.jit import jit_kernel, jitable_kernel
from hybridlog.model.hybrid_model import HybridModel, markov_matrix
from hybridlog.signals import AlignedSignals, FloatArray, IntArray

NAME = "imm"


class ImmSettings(NamedTuple):
    """The IMM's own settings as its loops take them."""

    transitions: FloatArray
    """The Markov matrix ``Π`` (:func:`transition_matrix`), C-contiguous."""
    store: ModeStore
    """Per-mode estimates and likelihoods for the smoother (no rows: not kept).

    Its rows are the log's: kept only by a run in one chunk (offline passes are not streamed).
    """
    filtered_store: bool = False
    """Whether the store's rows ``k < N−1`` hold the mode-matched filtered ``x̂_i(k|k)``,
    ``P_i(k|k)`` (expectation correction's backward pass, ``smoother = "ec"``) instead of the
    mixed priors ``x̂⁰_j(k)``, ``P⁰_j(k)`` (Kim's); :class:`~.common.ModeStore`."""


class ImmState(NamedTuple):
    """What the IMM carries from one step to the next (a :class:`~.common.Chunk`'s state).

    The mode-matched estimates ``x̂_i(k|k)``, ``P_i(k|k)`` and the mode probabilities
    ``μ(k)``; the combined estimate is made from them at every step.
    """

    x_i: FloatArray
    P_i: FloatArray
    mu: FloatArray

    @classmethod
    def prior(cls, run: FilterRun) -> ImmState:
        """The state before the first step: every mode starts from the model's prior."""
        n_q = run.mu0.shape[0]
        return cls(
            np.repeat(run.x0[None], n_q, axis=0),
            np.repeat(run.P0[None], n_q, axis=0),
            run.mu0.copy(),
        )


@jit_kernel
def pack_state(x: FloatArray, P: FloatArray, out: FloatArray) -> None:
    """Write ``x`` and the upper triangle of ``P`` into one :class:`ModeStore` record ``out``."""
    n = x.shape[0]
    index = n
    for a in range(n):
        out[a] = x[a]
        for b in range(a, n):
            out[index] = P[a, b]
            index += 1


class ImmScratch(NamedTuple):
    """The arrays the IMM's time loop works in (:func:`_imm_steps` allocates them)."""

    x: FloatArray
    P: FloatArray
    c_bar: FloatArray
    weights: FloatArray
    x_mix: FloatArray
    P_mix: FloatArray
    x_pred: FloatArray
    P_pred: FloatArray
    F_j: FloatArray
    H_j: FloatArray
    y_j: FloatArray
    gamma: FloatArray
    R_left: FloatArray
    log_posterior: FloatArray
    work: Workspace
    source_start: IntArray
    """Mode ``j``'s possible previous modes (``Π[i, j] ≠ 0``) are
    ``sources[source_start[j]:source_start[j + 1]]``, in increasing order."""
    sources: IntArray


def _imm_steps(
    f: Fn,
    F: Fn,
    h: Fn,
    H: Fn,
    run: FilterRun,
    settings: ImmSettings,
    chunk: Chunk[ImmState],
    out: FilterBuffers,
) -> None:
    """The generic IMM time loop (compiled on first use; the docstring of the module).

    Computes the rows of ``chunk`` from its :class:`ImmState`, worked on in place: allocates
    the loop's :class:`ImmScratch`, then runs :func:`_imm_rows`, which allocates nothing.
    """
    _, n, m, n_q = dimensions(run)
    source_start, sources = possible_sources(settings.transitions)
    scratch = ImmScratch(
        np.empty(n),
        np.empty((n, n)),
        np.empty(n_q),
        np.empty(n_q),
        np.empty((n_q, n)),
        np.empty((n_q, n, n)),
        np.empty(n),
        np.empty((n, n)),
        np.empty((n, n)),
        np.empty((m, n)),
        np.empty((n_q, m)),
        np.empty(m),
        np.empty((m, m)),
        np.empty(n_q),
        workspace(n, m),
        source_start,
        sources,
    )
    _imm_rows(f, F, h, H, run, settings, chunk, out, scratch)


@jitable_kernel
def _imm_rows(
    f: Fn,
    F: Fn,
    h: Fn,
    H: Fn,
    run: FilterRun,
    settings: ImmSettings,
    chunk: Chunk[ImmState],
    out: FilterBuffers,
    scratch: ImmScratch,
) -> None:
    """The time loop of :func:`_imm_steps`, in its ``scratch``.

    Compiled without reference counts (:data:`~hybridlog.jit.WITHOUT_REFCOUNTS`): it slices
    views freely, and every array copy is a loop.
    """
    inputs, outputs, Q, R = run.inputs, run.outputs, run.Q, run.R
    transitions, store, filtered_store = settings
    first, stop, state = chunk
    keep_states = store.states.shape[0] > 0
    keep_mixed = keep_states and not filtered_store  # Kim's: the mixed priors
    keep_filtered = keep_states and filtered_store  # expectation correction's: x̂_i(k|k)
    keep_likelihoods = store.log_likelihoods.shape[0] > 0
    keep_whitened = out.whitened.shape[0] > 0
    n_samples, n, m, n_q = dimensions(run)

    x_i, P_i, mu = state
    x, P, c_bar, weights, x_mix, P_mix, x_pred, P_pred, F_j, H_j, y_j = scratch[:11]
    gamma, R_left, log_posterior, work, source_start, sources = scratch[11:]
    work_nn, L, vec_m = work.nn, work.L, work.m

    if first == 0 and stop > 0:  # row 0: the prior
        record(out, 0, argmax(mu), mu, run.x0, run.P0)
        if keep_states:  # row 0 when the log has one sample; else the mixing of step 0 replaces it
            for i in range(n_q):
                pack_state(x_i[i], P_i[i], store.states[0, i])
        if keep_likelihoods:
            for i in range(n_q):
                store.log_likelihoods[0, i] = 0.0
    for k in range(max(first, 1) - 1, stop - 1):
        row = k + 1 - first
        u = inputs[k]
        u_next = inputs[k + 1]
        y = outputs[k + 1]
        left = left_out(y)  # outputs not measured at k+1: the update is the others'
        if keep_filtered:  # row k: the mode-matched x̂_i(k|k), P_i(k|k) the step starts from
            for i in range(n_q):
                pack_state(x_i[i], P_i[i], store.states[k, i])
        # Mixing: predicted mode probabilities and mixed initial conditions per mode, over
        # the modes each can follow (kernels.possible_sources: the others' terms are exact zeros).
        for j in range(n_q):
            acc = 0.0
            for index in range(source_start[j], source_start[j + 1]):
                i = sources[index]
                acc += transitions[i, j] * mu[i]
            c_bar[j] = acc
        for j in range(n_q):
            if c_bar[j] > 0.0:
                for index in range(source_start[j], source_start[j + 1]):
                    i = sources[index]
                    weights[i] = transitions[i, j] * mu[i] / c_bar[j]
                possible = sources[source_start[j] : source_start[j + 1]]
                mixture_moments_of(weights, possible, x_i, P_i, x_mix[j], P_mix[j])
            else:  # keeps its own estimate
                for a in range(n):
                    x_mix[j, a] = x_i[j, a]
                    for c in range(n):
                        P_mix[j, a, c] = P_i[j, a, c]
        if keep_mixed:
            for j in range(n_q):
                pack_state(x_mix[j], P_mix[j], store.states[k, j])
        predictions = out.output_predictions[row]
        for b in range(m):
            predictions[b] = 0.0
        nearest = np.nan  # the smallest γᵀ S⁻¹ γ over the modes (FilterBuffers.surprise)
        if keep_whitened:  # the buffers are reused chunk after chunk
            for b in range(m):
                out.whitened[row, b] = np.nan
        for j in range(n_q):
            # EKF prediction of mode j.
            f(j, x_mix[j], u, x_pred)
            F(j, x_mix[j], u, F_j)
            congruence(F_j, P_mix[j], work_nn, P_pred)
            for a in range(n):
                for c in range(n):
                    P_pred[a, c] += Q[j, a, c]
            # EKF update of mode j.
            h(j, x_pred, u_next, y_j[j])
            H(j, x_pred, u_next, H_j)
            for b in range(m):
                gamma[b] = y[b] - y_j[j, b]
                predictions[b] += c_bar[j] * y_j[j, b]
            R_j = R[j]
            if left:
                leave_out_unmeasured(y, H_j, gamma, R_j, R_left)
                R_j = R_left
            if kalman_update(x_pred, P_pred, H_j, R_j, gamma, work, x_i[j], P_i[j]):
                log_likelihood = measured_log_density(gamma, L, vec_m, left)
                distance = 0.0  # vec_m holds L⁻¹ γ (0 for an output left out)
                for b in range(m):
                    distance += vec_m[b] * vec_m[b]
                # a mode the transitions rule out (c̄_j = 0) weighs nothing, nor does S = ∞
                if c_bar[j] > 0.0 and weighed(distance, log_likelihood) and not nearest <= distance:
                    nearest = distance
                    if keep_whitened and distance < np.inf:  # L⁻¹ γ of the nearest mode
                        for b in range(m):
                            out.whitened[row, b] = vec_m[b] if y[b] == y[b] else np.nan
                log_posterior[j] = (
                    math.log(c_bar[j]) if c_bar[j] > 0.0 else -np.inf
                ) + log_likelihood
            else:  # S is not positive definite: the prediction stands, the mode is ruled out
                log_likelihood = -np.inf
                log_posterior[j] = -np.inf
                for a in range(n):
                    x_i[j, a] = x_pred[a]
                    for c in range(n):
                        P_i[j, a, c] = P_pred[a, c]
            if keep_likelihoods:
                store.log_likelihoods[k + 1, j] = log_likelihood
        out.surprise[row] = nearest if left < m else np.nan
        if not normalize_log(log_posterior, mu):
            for j in range(n_q):
                mu[j] = c_bar[j]
        mixture_moments(mu, x_i, P_i, x, P)
        record(out, row, argmax(mu), mu, x, P)
        if keep_states and k == n_samples - 2:  # the last row; the others get the mixing
            for i in range(n_q):
                pack_state(x_i[i], P_i[i], store.states[k + 1, i])


def transition_matrix(model: HybridModel, options: ImmOptions) -> FloatArray:
    """Markov matrix: ``transition_stay`` when set, else the model's, else 0.95 stay."""
    if options.transition_stay is not None:
        return markov_matrix(options.transition_stay, model.n_modes)
    if model.transitions is not None:
        return model.transitions
    return markov_matrix(0.95, model.n_modes)


def unreachable_modes(prior: FloatArray, transitions: FloatArray) -> list[int]:
    """The modes the IMM gives probability 0 at every sample, whatever the log.

    The mixing step gives mode j the predicted probability ``c̄_j = Σ_i Π_ij μ_i`` and the
    update keeps ``μ_j ∝ Λ_j c̄_j``: a mode with prior probability 0 that no mode of
    positive probability can move into (``Π_ij = 0``, as with ``transition_stay = 1``, the
    identity) stays at 0, so its estimate is never that mode.  Returns their indices, the
    closure of the prior's support under ``Π > 0`` left out.
    """
    reached = prior > 0.0
    while True:
        grown = reached | (transitions[reached] > 0.0).any(axis=0)
        if (grown == reached).all():
            return [int(j) for j in np.flatnonzero(~reached)]
        reached = grown


def unreachable_note(
    model: HybridModel, transitions: FloatArray, used: dict[str, Any]
) -> str | None:
    """Why some of ``model``'s modes are never estimated (:func:`unreachable_modes`), or None.

    ``--set transition_stay=1`` with the three-tank prior on mode '2' held mode 2 through
    the whole log, and the report said only that the innovations were large.
    """
    never = unreachable_modes(model.initial_mode_probabilities, transitions)
    if not never:
        return None
    ids = ", ".join(f"'{model.mode_ids[j]}'" for j in never)
    support = ", ".join(
        f"'{model.mode_ids[j]}'" for j in np.flatnonzero(model.initial_mode_probabilities > 0.0)
    )
    stay = used.get("transition_stay")
    matrix = "the model's [transitions]" if stay is None else f"transition_stay = {stay:g}"
    return (
        f"WARNING: mode{'s' if len(never) > 1 else ''} {ids} can never be estimated: the prior "
        f"([initial]) gives {'them' if len(never) > 1 else 'it'} probability 0 and the Markov "
        f"matrix ({matrix}) never moves probability into {'them' if len(never) > 1 else 'it'} "
        f"from {support}, so {'their' if len(never) > 1 else 'its'} probability is 0 at every "
        "sample whatever the log; give a Markov matrix that reaches them, or a prior on them"
    )


def _noted(result: EstimationResult, filtered: _Filtered) -> EstimationResult:
    """``result`` with :func:`unreachable_note` (on a model the IMM runs as it is)."""
    if filtered.paired is not None or filtered.model.has_components:
        return result
    note = unreachable_note(filtered.model, filtered.transitions, filtered.used)
    return result if note is None else replace(result, notes=(*result.notes, note))


class _Filtered(NamedTuple):
    """What :func:`_filtered_model` gives.

    The model the IMM runs on, its Markov matrix, the options the result reports, and the
    model whose modes the result is read back in (``None``: the one it ran on).
    """

    model: HybridModel
    transitions: FloatArray
    used: dict[str, Any]
    paired: HybridModel | None


def _filtered_model(model: HybridModel, options: ImmOptions) -> _Filtered:
    """What the IMM runs ``model`` as (:class:`_Filtered`).

    A ``[components]`` model runs on its enumerated joint known modes
    (:func:`~hybridlog.estimators.cpha.joint.joint_mode_model`); a state-driven model whose
    output equations differ by mode on its mode pairs
    (:func:`~hybridlog.estimators.mode_pairs.pair_mode_model`), the Markov matrix reported
    being the model's own.
    """
    if model.has_components:
        from hybridlog.estimators.cpha.joint import joint_mode_model

        model = joint_mode_model(model)
    transitions = contiguous(transition_matrix(model, options))
    used = options_dict(options)
    used["transition_matrix"] = transitions.tolist()
    if not runs_on_pairs(model):
        return _Filtered(model, transitions, used, None)
    pairs = pair_mode_model(model, transitions)
    return _Filtered(pairs, contiguous(pair_transitions(transitions)), used, model)


def _read_back(result: EstimationResult, filtered: _Filtered, *, argmax: bool) -> EstimationResult:
    """``result`` in the modes of the model given (:func:`~.mode_pairs.merged_modes`)."""
    if filtered.paired is None:
        return result
    return merged_modes(result, filtered.paired, argmax=argmax)


def _checked_as(filtered: _Filtered) -> CheckedAs | None:
    """The filter's results checked in the model's own modes (:class:`~.common.CheckedAs`).

    A run on the pairs refused at a mode's expression named ``modes.down->up.f[0]`` and a
    held mode ``'up->up'`` against the log's true mode named ``'up->up'`` too.
    """
    if filtered.paired is None:
        return None
    return CheckedAs(filtered.paired, partial(_read_back, filtered=filtered, argmax=True))


def _offline(options: ImmOptions) -> bool:
    """Whether an offline pass follows the filter (``smooth``, a ``mode_sequence`` to decode)."""
    return options.smooth or options.mode_sequence != "argmax"


def run_imm(
    model: HybridModel,
    signals: AlignedSignals,
    options: ImmOptions,
    *,
    jit: bool = True,
    kernel: str = "auto",
    store_covariances: bool = False,
) -> EstimationResult:
    """Run the IMM over the aligned signals, then the offline passes its options ask for.

    The mode of sample k is the one under which ``x(k)`` came from ``x(k-1)``; for a
    state-driven model, whose mode of sample k governs the step from ``x(k)``, the registry's
    run (``prepare(model, ...).run``, what the commands use) moves the modes one sample
    earlier (:meth:`~hybridlog.estimators.result.EstimationResult.with_modes_of_the_step_from`).

    ``smooth``: the smoother of :mod:`hybridlog.estimators.smoothing` that ``smoother``
    names, Kim's or expectation correction (the forward pass then keeps its per-mode
    estimates, :class:`~hybridlog.estimators.common.ModeStore`);
    ``mode_sequence="viterbi"``: the Viterbi path as the modes; ``"kbest"``: the mode history
    of the best of ``beam`` hypotheses (:mod:`hybridlog.estimators.mode_hypotheses`).  Each
    sets the result's ``post_processing``; without them the result is the filter's alone.

    ``kernel`` and ``jit`` choose the code path (:func:`~hybridlog.estimators.common.run_filter`):
    :func:`generate_imm_source` for small models, else the generic :func:`_imm_steps`.
    A ``[components]`` model runs on its enumerated joint known modes
    (:func:`~hybridlog.estimators.cpha.joint.joint_mode_model`).  An error of the forward
    pass does not blame the offline passes' options (``offline_options.OFFLINE_OPTIONS``,
    :func:`~hybridlog.errors.independent_of`).
    """
    ran = _filtered_model(model, options)
    model, transitions, used = ran.model, ran.transitions, ran.used
    store = ModeStore.allocate(
        model,
        signals.n_samples,
        states=options.smooth,
        likelihoods=options.mode_sequence == "viterbi",
    )
    with independent_of(OFFLINE_OPTIONS):
        filtered = run_filter(
            CODE,
            model,
            signals,
            ImmSettings(transitions, store, options.smooth and options.smoother == "ec"),
            used,
            jit=jit,
            kernel=kernel,
            store_covariances=store_covariances,
            checked_as=_checked_as(ran),
        )
    if not _offline(options):
        return _noted(_read_back(filtered, ran, argmax=True), ran)
    from hybridlog.estimators.smoothing import post_process

    result = post_process(
        model,
        signals,
        filtered,
        store,
        transitions,
        smooth=options.smooth,
        smoother=options.smoother,
        mode_sequence=options.mode_sequence,
        jit=jit,
        kernel=kernel,
        beam=options.beam,
        paired=ran.paired,
    )
    return _noted(_read_back(result, ran, argmax=options.mode_sequence == "argmax"), ran)


def stream_imm(
    model: HybridModel,
    signals: AlignedSignals,
    options: ImmOptions,
    *,
    rows: int,
    jit: bool = True,
    kernel: str = "auto",
    store_covariances: bool = False,
) -> Iterator[EstimationResult]:
    """:func:`run_imm`'s result in consecutive chunks of at most ``rows`` rows.

    Without an offline pass, the filter's chunks
    (:func:`~hybridlog.estimators.common.run_filter_chunks`: views of buffers the next chunk
    overwrites; no :class:`~hybridlog.estimators.common.ModeStore` kept).  With one, the one
    whole result of :func:`run_imm`: the smoother and the mode-sequence decoders read the
    whole forward pass, so nothing of it is streamed.
    """
    if _offline(options):
        whole = run_imm(
            model,
            signals,
            options,
            jit=jit,
            kernel=kernel,
            store_covariances=store_covariances,
        )
        return iter((whole,))
    ran = _filtered_model(model, options)
    store = ModeStore.allocate(ran.model, signals.n_samples, states=False, likelihoods=False)
    chunks = run_filter_chunks(
        CODE,
        ran.model,
        signals,
        ImmSettings(ran.transitions, store),
        ran.used,
        jit=jit,
        kernel=kernel,
        store_covariances=store_covariances,
        rows=rows,
        checked_as=_checked_as(ran),
    )
    return (_noted(_read_back(chunk, ran, argmax=True), ran) for chunk in chunks)


def _store_record(p: Program, row: str, mode: int, x: Vector, P: Matrix) -> None:
    """Emit the writes of one packed :class:`ModeStore` record (inside an ``if``)."""
    n = len(x)
    for a in range(n):
        p.emit(f"    store.states[{row}, {mode}, {a}] = {term(x[a])}")
    for index, (a, b) in enumerate(upper_pairs(n), start=n):
        p.emit(f"    store.states[{row}, {mode}, {index}] = {term(P[a][b])}")


def generate_imm_source(model: HybridModel, *, masked: bool = False) -> str:
    """Straight-line source of the whole IMM time loop for ``model`` (see ``unrolled.py``).

    Defines ``imm_run(run, settings, chunk, out)``, the frame of :func:`_imm_steps` without
    the model functions, with the same meaning; the mode functions, the noise covariances and
    every small matrix product are written out for the model's dimensions.  The carried
    variables are loaded from the chunk's :class:`ImmState` before the time loop and stored
    back after it.

    ``masked``: the code for a log with outputs not measured at some rows (NaN in
    ``run.outputs``), which updates on the measured ones alone as the generic loop does
    (:func:`~hybridlog.estimators.kernels.leave_out_unmeasured`, written out: the rows of
    ``H`` and ``γ`` of an output left out are 0, its rows and columns of ``R`` the
    identity's); the folded constants of ``H`` and ``R`` become selections, so a log that
    measured everything runs the code without them.
    """
    n, m, n_u, n_q = model.n_states, model.n_outputs, model.n_inputs, model.n_modes
    p = Program(indent="    ")
    X = [vector_names(f"x{i}", n) for i in range(n_q)]
    P = [matrix_names(f"P{i}", n, n, symmetric=True) for i in range(n_q)]
    mu = vector_names("mu", n_q)
    T = matrix_names("T", n_q, n_q)
    Q, R = noise_matrices(model)

    carried = [
        *(pair for i in range(n_q) for pair in state_slots("x_i", X[i], i)),
        *(pair for i in range(n_q) for pair in state_slots("P_i", P[i], i)),
        *state_slots("mu", mu),
    ]

    p.prologue(ImmSettings._fields)
    p.resume(carried)
    for i in range(n_q):
        p.carry(T[i], [f"transitions[{i}, {j}]" for j in range(n_q)])
    p.emit("keep_states = store.states.shape[0] > 0")
    p.emit("keep_mixed = keep_states and not filtered_store")  # Kim's: the mixed priors
    p.emit("keep_filtered = keep_states and filtered_store")  # expectation correction's
    p.emit("keep_likelihoods = store.log_likelihoods.shape[0] > 0")
    p.emit("keep_whitened = whitened_out.shape[0] > 0")
    with p.block("if first == 0 and stop > 0:"):  # row 0: the prior
        p.record("0", p.argmax(mu), mu, X[0], P[0])
        p.emit("if keep_states:")
        pairs = upper_pairs(n)
        for i in range(n_q):
            for a in range(n):
                p.emit(f"    store.states[0, {i}, {a}] = x0[{a}]")
            for index, (a, b) in enumerate(pairs, start=n):
                p.emit(f"    store.states[0, {i}, {index}] = P0[{a}, {b}]")
        p.emit("if keep_likelihoods:")
        for i in range(n_q):
            p.emit(f"    store.log_likelihoods[0, {i}] = 0.0")
    u, v, y = p.open_time_loop(n_u, m, chunk=True)
    measured = p.measured_flags(y) if masked else None
    p.emit("if keep_filtered:")  # row k: the mode-matched x̂_i(k|k), P_i(k|k) (carried)
    for i in range(n_q):
        _store_record(p, "k", i, X[i], P[i])
    # Mixing: c̄_j = Σ_i Π_ij μ_i and μ_{i|j}; a mode with c̄_j = 0 keeps its own estimate.
    c_bar = [p.let("c", [product(T[i][j], mu[i]) for i in range(n_q)]) for j in range(n_q)]
    x_post: list[Vector] = []
    P_post: list[Matrix] = []
    log_posterior: Vector = []
    log_likelihoods: list[str] = []
    distances: list[str] = []
    whitened: list[Vector] = []
    prediction_parts: list[list[Entry | None]] = [[] for _ in range(m)]
    for j in range(n_q):
        weights: Vector = [
            p.assign(
                "w",
                f"{T[i][j]}*{mu[i]}/{term(c_bar[j])} if {term(c_bar[j])} > 0.0 "
                f"else {1.0 if i == j else 0.0}",
            )
            for i in range(n_q)
        ]
        x_mix, P_mix = p.mixture(f"m{j}_", weights, X, P)
        p.emit("if keep_mixed:")  # Kim's smoother's prior of mode j (ModeStore, packed)
        _store_record(p, "k", j, x_mix, P_mix)
        x_mix_names = p.named("xm", x_mix)
        # EKF prediction (mode j).
        x_pred = p.mode_values(model, j, "f", x_mix_names, u)
        F = reshape(p.mode_values(model, j, "F", x_mix_names, u), n, n)
        P_pred = p.congruence(f"pp{j}_", F, P_mix, add=Q[j])
        # EKF update (mode j).
        x_pred_names = p.named("xp", x_pred)
        y_pred = p.mode_values(model, j, "h", x_pred_names, v)
        H = reshape(p.mode_values(model, j, "H", x_pred_names, v), m, n)
        gamma = [p.difference("g", y[b], y_pred[b]) for b in range(m)]
        for b in range(m):
            prediction_parts[b].append(product(c_bar[j], y_pred[b]))
        R_j = R[j]
        if measured is not None:
            H, R_j, gamma = p.left_out(measured, H, R_j, gamma)
        x_update, P_update, L = p.kalman_update(f"u{j}_", x_pred, P_pred, H, R_j, gamma)
        x_post.append(x_update)
        P_post.append(P_update)
        log_likelihood, distance, z = p.gaussian_log_density_whitened(f"ll{j}_", gamma, L)
        if measured is not None:  # the measured sub-vector's density (kernels.measured_log_density)
            p.emit(f"{log_likelihood} = {log_likelihood} + 0.5 * left * LOG_2PI")
            z = [p.assign("wz", f"{term(z[b])} if {measured[b]} else math.nan") for b in range(m)]
        # NaN: no distance, as the loop (a mode the transitions rule out, S = ∞)
        p.weighed_distance(distance, log_likelihood, possible=f"{term(c_bar[j])} > 0.0")
        distances.append(distance)
        whitened.append(z)
        p.minus_inf_if_nan(log_likelihood)
        c = term(c_bar[j])
        posterior = p.assign(
            "lp", f"(math.log({c}) if {c} > 0.0 else -math.inf) + {log_likelihood}"
        )
        p.minus_inf_if_nan(posterior)
        log_posterior.append(posterior)
        log_likelihoods.append(log_likelihood)
    nearest = p.nearest(distances)
    anything = f" if left < {m} else math.nan" if measured is not None else ""  # nothing: none
    p.emit(f"surprise_out[row] = {nearest}{anything}")
    with p.block("if keep_whitened:"):  # L⁻¹ γ of the nearest mode, as the generic loop
        for b in range(m):
            p.emit(f"whitened_out[row, {b}] = math.nan")
        for j in reversed(range(n_q)):  # the first of equally near modes, as the generic loop
            with p.block(f"if {distances[j]} == {nearest} and {nearest} < math.inf:"):
                for b in range(m):
                    p.emit(f"whitened_out[row, {b}] = {term(whitened[j][b])}")
    mu_new = p.normalized_weights(log_posterior, c_bar)
    x_combined, P_combined = p.mixture("cm", mu_new, x_post, P_post)
    for b in range(m):
        prediction = p.let("yp", prediction_parts[b])
        p.emit(f"predictions_out[row, {b}] = {term(prediction)}")
    p.emit("if keep_likelihoods:")
    for j in range(n_q):
        p.emit(f"    store.log_likelihoods[k + 1, {j}] = {log_likelihoods[j]}")
    p.emit("if keep_states and k == n_samples - 2:")  # the last row; the others get the mixing
    for j in range(n_q):
        _store_record(p, "k + 1", j, x_post[j], P_post[j])
    for i in range(n_q):
        p.carry(X[i], x_post[i])
        p.carry(upper(P[i]), upper(P_post[i]))
    p.carry(mu, mu_new)
    p.record("row", p.argmax(mu), mu, x_combined, P_combined)
    p.close_time_loop()
    p.suspend(carried)
    return p.function("imm_run")


CODE = FilterCode(
    NAME,
    _imm_steps,
    ImmState.prior,
    Accelerator(generate_imm_source, "imm_run", masked=partial(generate_imm_source, masked=True)),
    whitened=True,
)
"""The generic loop and its accelerator, run by :func:`~hybridlog.estimators.common.run_filter`."""
