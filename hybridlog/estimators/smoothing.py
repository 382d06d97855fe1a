r"""Offline passes after a filter: the fixed-interval IMM smoother and the Viterbi path (issue 12).

**Smoother: Kim's backward mode recursion with a per-mode extended RTS step on the IMM's mixed
prior.**  Mode probabilities: Kim C.-J., "Dynamic linear models with Markov-switching",
*Journal of Econometrics* 60 (1994) 1-22, eqs. (2.20)-(2.21) (Kim and Nelson, *State-Space
Models with Regime Switching*, 1999, §5.2.2).  States: an RTS step (Rauch, Tung, Striebel
1965) per *next* mode ``j``, from the forward IMM's own mixed prior of mode ``j``, close in
structure to Lopez and Danès' low-complexity IMM smoother (IEEE TAES 2017; their equations
were not checked line by line): what is implemented is written out below.  The forward pass keeps
(:class:`~hybridlog.estimators.common.ModeStore`) the mixed priors ``x̂⁰_j(k)``, ``P⁰_j(k)``
(the estimate of ``x(k)`` given ``q(k+1) = j``, Blom and Bar-Shalom's mixing), the per-mode
estimates of the last sample and the filtered ``μ(k)``.  For ``k = N−2 … 0``:

.. math::

    \log \bar c_j(k+1) = \operatorname{logsumexp}_i(\log\Pi_{ij} + \log\mu_i(k))

    \log p_{ij}(k) = \log\mu^s_j(k+1) + \log\mu_i(k) + \log\Pi_{ij} - \log\bar c_j(k+1)
        \qquad \text{(Kim eq. (2.20))}

    \log\mu^s_i(k) = \operatorname{logsumexp}_j \log p_{ij}(k),\qquad
    w_{j|i} = p_{ij}/\mu^s_i \qquad \text{(eq. (2.21))}

    \hat x^-_j = f_j(\hat x^0_j, u_k),\; F_j = \partial f_j/\partial x|_{\hat x^0_j},\;
    P^-_j = F_j P^0_j F_j^T + Q_j \qquad \text{(the IMM's own prediction of mode } j)

    J_j = P^0_j F_j^T (P^-_j)^{-1},\quad
    \hat x^{(j)} = \hat x^0_j + J_j(\hat x^s_j(k+1) - \hat x^-_j)

    P^{(j)} = (I - J_j F_j) P^0_j (I - J_j F_j)^T + J_j (Q_j + P^s_j(k+1)) J_j^T

    \hat x^s_i(k) = \textstyle\sum_j w_{j|i}\hat x^{(j)},\quad
    P^s_i(k) = \sum_j w_{j|i}(P^{(j)} + (\hat x^{(j)}-\hat x^s_i)(\cdot)^T)

The output is ``Σ_i μ^s_i x̂^s_i = Σ_j Pr(q(k+1)=j|Y^N) E[x(k) | q(k+1)=j, Y^N]`` with its
covariance.  The approximations: Gaussian per mode (as the IMM), and
``E[x(k) | q(k)=i, q(k+1)=j, Y^N] ≈ E[x(k) | q(k+1)=j, Y^N]`` for the per-mode estimates.
Kim's own state step (one RTS step per pair ``(i, j)`` from ``x̂_i(k|k)``) takes ``n_q²``
RTS steps per sample; this one ``n_q``.  Nonlinear modes are linearised where the forward
IMM linearised them (at ``x̂⁰_j``).  The covariance above equals ``P⁰ + J(P^s − P^-)Jᵀ``
for this ``J`` and is a sum of congruences of PSD matrices, so it stays PSD up to rounding;
every covariance is symmetrised.  Mode probabilities are combined in log space and
renormalised at every step (the straight-line code for small models does the same
arithmetic in linear space on the samples where every probability involved is at least
1e-280, where the log space adds no range and the two agree to rounding; see
``_mode_recursion_source``).  At the last sample the smoothed estimate is the filtered one.
A mode whose ``P^-_j`` is not positive definite gets ``J_j = 0``.

Guard: the exact RTS step has ``P^s_j(k+1) ≤ P^-_j`` (the smoothed estimate is no wider than
the prediction).  The collapsed mixture ``P^s_j(k+1)`` holds the spread between the next
modes' hypotheses and can break it; with little process noise ``J_j ≈ F_j⁻¹`` then widens the
estimate at every step backwards, without end (on the double cart, no process noise: states
of 1e29 after 600 steps, docs/smoothing.md).  Where ``P^-_j − P^s_j(k+1)`` is not positive
definite (slack ``1e-9 trace P^-_j``) the step of mode ``j`` is skipped: ``x̂^{(j)} = x̂⁰_j``,
the forward prior, and the backward pass goes on from there.  With one mode, or with the stay
probability at 1 and the true mode known, this is the RTS smoother of that mode (when the
guard holds, as it does for the exact RTS).

Rounding: without process noise ``J_j = F_j⁻¹``, which grows by ``1/|λ|`` per step
backwards for a stable mode, so the backward pass would amplify its own rounding without
end; each step carries a probe of it (:func:`rts_step`), and a step whose probe passes
:data:`ROUNDING_LIMIT` of its standard deviation of a state is skipped in the same way.
The smallest eigenvalue of a covariance grows the same way (by ``1/λ²`` through
``J P^s Jᵀ``): a step whose ``P^{(j)}`` is not positive semi-definite to
:data:`~hybridlog.estimators.kernels.PSD_TOLERANCE` of its largest variance is skipped too.

Negligible next modes: where ``μ^s_j(k+1) <`` :data:`NEGLIGIBLE_WEIGHT` (``1e-16``) the RTS
step of mode ``j`` is skipped in the same way (``x̂^{(j)} = x̂⁰_j``).  Its result enters the
output only with the weight ``Σ_i μ^s_i(k) w_{j|i} = Σ_i p_ij(k) = μ^s_j(k+1)``, so the
smoothed mean moves by at most ``1e-16 |J_j(x̂^s_j(k+1) − x̂^-_j)|``: a double's rounding
(``2^-53`` relative) unless that step moves the mode's estimate by far more than the
estimate's own size.  It is the mode the backward pass skips most (on the three-tank
benchmark log 45 % of the smoothed probabilities are below 1e-30; the skip took Kim's
backward pass from 0.30 to 0.22 s).  Measured 2026-12-05 on the 70 three-tank logs of
``docs/studies/smoothing.py`` (seeds 0..29 and 100..139), expectation correction with the
threshold at 1e-16 against 1e-30: smoothed probabilities within 2.0e-15, states within
1.2e-15 relative, no mode label changed; its backward pass 1.9× against 2.1× the filter's
time (with the filter, CPU time, a loaded machine).

Fallbacks: each backward pass counts the samples where a step that carries weight (a next
mode of at least :data:`NEGLIGIBLE_WEIGHT`; expectation correction: a pair ``p_ij(k)`` of
at least it) was refused, by cause (:data:`PREDICTION`, :data:`GUARD`, :data:`ROUNDING`,
:data:`COVARIANCE`, :func:`note_fallbacks`), into
:attr:`~hybridlog.estimators.result.PostProcessing.fallbacks`; the negligible next modes
above are not counted.

**Expectation correction** (``smoother = "ec"``, :func:`ec_backward`): D. Barber,
"Expectation Correction for Smoothed Inference in Switching Linear Dynamical Systems",
*Journal of Machine Learning Research* 7 (2006) 2515-2540, with one Gaussian per mode and
the "mean" approximation of its expectation over ``x(k+1)``.  Kim's recursion takes
``Pr(q(k)=i | q(k+1)=j, Y^N) ≈ Pr(q(k)=i | q(k+1)=j, Y^k)``; expectation correction
conditions on the smoothed state of ``k+1`` as well, at its mean.  The forward pass keeps the
mode-matched filtered ``x̂_i(k|k)``, ``P_i(k|k)`` in every row of the store instead of the
mixed priors (the IMM's ``filtered_store``; same size).  For ``k = N−2 … 0`` and each pair
``(i, j)``, an extended RTS step (:func:`rts_predict`, :func:`rts_correct`, the guard and the
rounding probe of :func:`rts_step`) from the filtered estimate of mode ``i`` with the
dynamics of mode ``j``:

.. math::

    \hat x^-_{ij} = f_j(\hat x_i(k|k), u_k),\; F_{ij} = \partial f_j/\partial x,\;
    P^-_{ij} = F_{ij} P_i(k|k) F_{ij}^T + Q_j,\;
    J_{ij} = P_i(k|k) F_{ij}^T (P^-_{ij})^{-1}

    \hat x^{(ij)} = \hat x_i(k|k) + J_{ij}(\hat x^s_j(k+1) - \hat x^-_{ij}),\quad
    P^{(ij)} = (I - J_{ij}F_{ij}) P_i(k|k) (\cdot)^T + J_{ij}(Q_j + P^s_j(k+1))J_{ij}^T

    \log w_{i|j} = \log\mu_i(k) + \log\Pi_{ij}
        + \log N(\hat x^s_j(k+1);\ \hat x^-_{ij}, P^-_{ij}) - \text{(normaliser over } i)

    \log p_{ij} = \log w_{i|j} + \log\mu^s_j(k+1),\quad
    \log\mu^s_i(k) = \operatorname{logsumexp}_j \log p_{ij},\quad
    v_{j|i} = p_{ij}/\mu^s_i(k)

    \hat x^s_i(k) = \textstyle\sum_j v_{j|i}\hat x^{(ij)},\quad
    P^s_i(k) = \sum_j v_{j|i}(P^{(ij)} + (\hat x^{(ij)} - \hat x^s_i)(\cdot)^T)

and the output is the mixture over ``i`` with ``μ^s_i(k)``.  The approximations: one
Gaussian per mode (forward and backward, each mixture collapsed to its moments), the
expectation of ``p(q(k) | q(k+1), x(k+1), Y^k)`` over ``x(k+1)`` taken at its mean
``x̂^s_j(k+1)``, and nonlinear modes linearised at ``x̂_i(k|k)``.  ``n_q²`` RTS steps a
sample against Kim's ``n_q``.  Kim's weights (the density term left out) are taken for next
mode ``j`` where ``Q_j`` is not positive definite (without process noise ``P^-_{ij} =
F P_i Fᵀ`` is nearly singular and the density decides by rounding: on the double cart the
prototype of ``docs/studies/smoothing_ec.py`` put 52-83 % of a log's samples in the wrong
mode), where a pair's ``P^-_{ij}`` is not positive definite, where the density is ``-inf`` for
every ``i``, and for a negligible next mode (``μ^s_j(k+1) <`` :data:`NEGLIGIBLE_WEIGHT`, whose
pair steps are skipped: ``x̂^{(ij)} = x̂_i(k|k)``).  A pair step the guard or the probe
refuses leaves ``x̂^{(ij)} = x̂_i(k|k)``, as in Kim's pass.

Pairs that carry no weight: a pair's RTS step is taken only where ``p_ij(k) >=``
:data:`NEGLIGIBLE_WEIGHT` (elsewhere ``x̂^{(ij)} = x̂_i(k|k)``, whose weight in the output is
``p_ij(k)``, and in mode ``i``'s own mixture ``p_ij/μ^s_i``, which matters only where
``μ^s_i(k)`` is itself that small), and a pair's prediction and density only where its weight
can still reach it: the densities are taken in :func:`ec_order` (the stay ``i = j`` first),
and since ``P^-_{ij} ⪰ Q_j`` the density is at most ``c_j`` (:func:`density_ceilings`), so a
pair with ``log μ_i + log Π_ij + c_j`` below ``log NEGLIGIBLE_WEIGHT − log μ^s_j(k+1)`` plus
the largest ``log μ_i' + log Π_i'j + log N_i'j`` found so far has ``p_ij(k)`` below
:data:`NEGLIGIBLE_WEIGHT` whatever its density, and is left out.  On the three-tank
benchmark log that leaves 2.7 predictions and about 2.2 steps a sample of the ``n_q² = 9``.
(Should a prediction fail, the mode takes Kim's weights, and a pair left out that they make
count stands for want of a prediction, counted as a ``prediction`` fallback.)  The
straight-line code computes the weights in linear space (one ``exp`` a pair with a density,
relative to the largest; Kim's weights as products, from the logs only where they underflow):
the loop's log-space weights to rounding, except probabilities below some 1e-300, which it
may flush to zero and which enter nothing that counts (a mode that small is negligible at the
next step back).  With one mode, or the stay
probability at 1 and the true mode known, it is the RTS smoother; where the state forgets
its past (``F = 0``) the density is the same for every ``i`` and it is Kim's, exact on a
Markov chain with Gaussian emissions.  Like Kim's pass, it has straight-line code for small
models (:func:`generate_ec_smoother_source`).

**Viterbi.**  The most likely mode sequence given the forward pass's per-mode log-likelihoods
``ℓ_j(k) = log N(γ_j(k); 0, S_j(k))``: ``δ_j(0) = log μ_j(0)``,
``δ_j(k) = max_i(δ_i(k−1) + log Π_ij) + ℓ_j(k)`` and back-tracking (Rabiner 1989, eqs.
(32a)-(35)), in log space.  The likelihoods are those of the IMM's mode-matched filters, so the
path is exact for the chain only as far as the IMM's Gaussian mixture reduction is.

Both passes are compiled with numba; the smoother calls the model's compiled ``f`` and ``F``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any, cast

import numpy as np

from hybridlog.estimators import (
    backward_frame,
    branch_tuples,
    common,
    ec_loop,
    ec_source,
    generated_helpers,
    kernels,
    kim_source,
    rts_source,
    rts_steps,
    unrolled,
)
from hybridlog.estimators import result as result_module
from hybridlog.estimators.common import (
    FilterBuffers,
    FilterRun,
    ModeStore,
    contiguous,
)
from hybridlog.estimators.ec_loop import (
    density_ceilings,
    ec_backward,
    positive_definite_noise,
)
from hybridlog.estimators.ec_source import (
    MAX_EC_UNROLLED_MODES,
    generate_ec_smoother_source,
)
from hybridlog.estimators.kim_loop import kim_backward
from hybridlog.estimators.kim_source import generate_smoother_source
from hybridlog.estimators.result import (
    FALLBACK_CAUSES,
    EstimationResult,
    Fallbacks,
    PostProcessing,
)
from hybridlog.estimators.rts_steps import (
    FALLBACK_WEIGHT,
    FALLBACKS_WIDTH,
)
from hybridlog.estimators.unrolled import (
    module_source,
    use_unrolled,
)
from hybridlog.estimators.viterbi_path import viterbi
from hybridlog.jit import compile_for
from hybridlog.model.compiled import compile_generated, compile_model
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.prefault import populated_beside
from hybridlog.signals import AlignedSignals, FloatArray, IntArray

__all__ = ["KIM_DESCRIPTION", "post_process"]

KIM = "kim-rts"
"""``PostProcessing.smoothing`` of the IMM smoother."""

KIM_DESCRIPTION = (
    "fixed-interval IMM smoother: Kim (1994) eqs. (2.20)-(2.21) for the mode probabilities "
    "(log space), an extended RTS step per next mode from the IMM's mixed prior for the states"
)
VITERBI_DESCRIPTION = (
    "Viterbi path over the Markov chain with the forward filters' per-mode likelihoods "
    "(Rabiner 1989, eqs. (32)-(35))"
)
KBEST_DESCRIPTION = (
    "modes: the most likely of the {beam} best mode histories, each with its own EKF, never "
    "mixed (k-best trajectory tracking, paper 002 eqs. (4)-(5)); states: {states}"
)
FILTERS_OWN = "states and mode probabilities: the filter's"
"""What a Viterbi path without ``smooth`` leaves as it was: its description says so, as
``kbest``'s without ``smooth`` says its mode probabilities are the filter's (the timeline's
``p_<mode>`` columns equal the ``_filtered`` ones, while its ``mode`` column is the path)."""
PATH_RTS = "kim-rts+path-rts"
"""``PostProcessing.smoothing`` with ``kbest``: Kim's mode probabilities, the states smoothed
along the path."""
EC = "ec-rts"
"""``PostProcessing.smoothing`` of expectation correction (``smoother = "ec"``)."""
EC_PATH_RTS = "ec-rts+path-rts"
"""``PostProcessing.smoothing`` with ``smoother = "ec"`` and ``kbest``: expectation
correction's mode probabilities, the states smoothed along the path."""
EC_DESCRIPTION = (
    "fixed-interval IMM smoother: expectation correction (Barber 2006, JMLR 7, one Gaussian "
    "per mode), an extended RTS step per pair of modes from the filtered estimates, the mode "
    "weights corrected by the density of the smoothed next state (log space)"
)


def _log(values: FloatArray) -> FloatArray:
    with np.errstate(divide="ignore"):
        return contiguous(np.log(values))


def post_process(
    model: HybridModel,
    signals: AlignedSignals,
    filtered: EstimationResult,
    store: ModeStore,
    transitions: FloatArray,
    *,
    smooth: bool,
    mode_sequence: str,
    jit: bool,
    kernel: str = "auto",
    beam: int = 20,
    smoother: str = "kim",
    paired: HybridModel | None = None,
) -> EstimationResult:
    """The result after the offline passes asked for, with the filter's beside it.

    ``smooth``: the Kim smoother's states, variances, probabilities and modes (argmax of the
    smoothed probabilities); ``mode_sequence == "viterbi"``: the Viterbi path as the modes;
    ``"kbest"``: the best of ``beam`` mode histories
    (:func:`hybridlog.estimators.mode_hypotheses.best_history`) as the modes, and the states
    of the EKF along it (``smooth``: of the RTS smoother along it; the mode probabilities are
    then Kim's).
    ``output_predictions`` stay the filter's.  The runtime adds the passes to the filter's.
    ``kernel`` as for the filter: straight-line code (:func:`generate_smoother_source`) where
    it applies, else the generic :func:`kim_backward`.  ``smoother == "ec"``: expectation
    correction in place of Kim's (:func:`generate_ec_smoother_source`, else :func:`ec_backward`);
    ``store`` must then hold the filtered per-mode estimates (the IMM's ``filtered_store``).
    ``paired``: the model ``model`` holds the mode pairs of
    (:func:`~hybridlog.estimators.mode_pairs.pair_mode_model`), whose modes a refusal names.
    """
    start = time.perf_counter()
    compile_s = 0.0
    result = filtered
    descriptions: list[str] = []
    fallbacks = np.zeros(FALLBACKS_WIDTH)
    if smooth:
        n = filtered.n_samples
        # The backward pass writes no output predictions: the filter's array stands in (no
        # 8 N n_y bytes of NaN written per run).
        buffers = FilterBuffers(
            modes=np.zeros(n, dtype=np.int64),
            mode_probabilities=np.zeros((n, model.n_modes)),
            state_means=np.zeros((n, model.n_states)),
            state_variances=np.zeros((n, model.n_states)),
            output_predictions=filtered.output_predictions,
            covariances=np.zeros(
                (n if filtered.covariances is not None else 0, model.n_states, model.n_states)
            ),
            surprise=np.zeros(0),
            whitened=np.zeros((0, model.n_outputs)),
        )
        if n:
            compile_start = time.perf_counter()
            loop, arguments = _backward_pass(
                model, signals, filtered, store, transitions, buffers, fallbacks,
                ec=smoother == "ec", jit=jit, kernel=kernel,
            )  # fmt: skip
            compile_s += time.perf_counter() - compile_start
            with populated_beside(buffers):
                loop(*arguments)
            last = n - 1
            buffers.modes[last] = int(np.argmax(filtered.mode_probabilities[last]))
            buffers.mode_probabilities[last] = filtered.mode_probabilities[last]
            buffers.state_means[last] = filtered.state_means[last]
            buffers.state_variances[last] = filtered.state_variances[last]
            if filtered.covariances is not None:
                buffers.covariances[last] = filtered.covariances[last]
        result = replace(
            filtered,
            modes=buffers.modes,
            mode_probabilities=buffers.mode_probabilities,
            state_means=buffers.state_means,
            state_variances=buffers.state_variances,
            covariances=buffers.covariances if filtered.covariances is not None else None,
        )
        descriptions.append(EC_DESCRIPTION if smoother == "ec" else KIM_DESCRIPTION)
    if mode_sequence == "viterbi":
        inputs_v = (
            _log(transitions),
            _log(model.initial_mode_probabilities),
            contiguous(store.log_likelihoods),
        )
        compile_start = time.perf_counter()
        decode = compile_for(viterbi, inputs_v) if jit else viterbi
        compile_s += time.perf_counter() - compile_start
        path = decode(*inputs_v)
        result = replace(result, modes=path)
        descriptions.append(
            VITERBI_DESCRIPTION if smooth else f"{VITERBI_DESCRIPTION}; {FILTERS_OWN}"
        )
    elif mode_sequence == "kbest":
        fallbacks[:] = 0  # the states are those of the RTS smoother along the path
        result, spent = _kbest(
            model, signals, result, transitions, beam, smooth, jit, kernel, fallbacks, paired
        )
        compile_s += spent
        descriptions = [
            KBEST_DESCRIPTION.format(
                beam=beam,
                states="the extended RTS smoother along that path; mode probabilities: "
                + ("expectation correction" if smoother == "ec" else "Kim's smoother")
                if smooth
                else "the EKF along that path; mode probabilities: the filter's",
            )
        ]
    elapsed = time.perf_counter() - start - compile_s
    return replace(
        result,
        runtime_s=filtered.runtime_s + elapsed,
        compile_s=filtered.compile_s + compile_s,
        post_processing=PostProcessing(
            smoothing=_method(smoother, kbest=mode_sequence == "kbest") if smooth else None,
            mode_sequence=mode_sequence,
            description="; ".join(descriptions),
            filtered=filtered,
            fallbacks=_fallbacks(fallbacks, filtered.n_samples) if smooth else None,
        ),
    )


def straight_line_backward(model: HybridModel, kernel: str, *, ec: bool) -> bool:
    """Whether the backward pass runs straight-line code for ``model`` under ``kernel``.

    As the filters (:func:`~hybridlog.estimators.unrolled.use_unrolled`), but expectation
    correction's with ``auto`` only up to :data:`MAX_EC_UNROLLED_MODES` modes.
    """
    if ec and kernel == "auto" and model.n_modes > MAX_EC_UNROLLED_MODES:
        return False
    return use_unrolled(model, kernel)


def _backward_pass(
    model: HybridModel,
    signals: AlignedSignals,
    filtered: EstimationResult,
    store: ModeStore,
    transitions: FloatArray,
    buffers: FilterBuffers,
    fallbacks: FloatArray,
    *,
    ec: bool,
    jit: bool,
    kernel: str,
) -> tuple[Callable[..., object], tuple[Any, ...]]:
    """The compiled backward pass asked for and its arguments.

    Kim's, or expectation correction's with ``ec``: the straight-line code of the model where
    it applies (:func:`generate_smoother_source`, :func:`generate_ec_smoother_source`; for
    expectation correction with ``auto`` only up to :data:`MAX_EC_UNROLLED_MODES` modes),
    else the generic loop (:func:`kim_backward`, :func:`ec_backward`).
    """
    tail = (filtered.mode_probabilities, store, buffers, fallbacks)
    if jit and straight_line_backward(model, kernel, ec=ec):
        name = "imm_smooth_ec" if ec else "imm_smooth"
        generate = generate_ec_smoother_source if ec else generate_smoother_source
        arguments: tuple[Any, ...] = (
            contiguous(signals.inputs), contiguous(transitions), _log(transitions), *tail
        )  # fmt: skip
        loop, _ = compile_generated(
            model,
            name,
            lambda: module_source(model, generate(model)),
            # every module whose code or constants the source takes: kernels' PSD_TOLERANCE
            # is written into it, common's packed_width and upper_pairs lay out its records,
            # result's FALLBACK_CAUSES make rts_steps' FALLBACK_WEIGHT
            tuple(
                m.__name__
                for m in (
                    kim_source,
                    ec_source,
                    rts_source,
                    generated_helpers,
                    backward_frame,
                    branch_tuples,
                    rts_steps,
                    ec_loop,
                    result_module,
                    unrolled,
                    kernels,
                    common,
                )
            ),
            name,
            arguments,
        )
        return loop, arguments
    compiled = compile_model(model, jit=jit)
    noise = contiguous(np.stack([m.process_noise for m in model.modes]))
    head = (compiled.f, compiled.F, contiguous(signals.inputs), contiguous(transitions), noise)
    generic: Callable[..., object] = ec_backward if ec else kim_backward
    weights = (positive_definite_noise(model), density_ceilings(model))
    arguments = (*head, *weights, *tail) if ec else (*head, *tail)
    return (compile_for(generic, arguments) if jit else generic), arguments


def _fallbacks(counts: FloatArray, n_samples: int) -> Fallbacks:
    """:class:`Fallbacks` of a backward pass's ``fallbacks`` array over ``n_samples``."""
    of = max(n_samples - 1, 0)
    return Fallbacks(
        samples=int(counts[0]),
        of=of,
        by_cause={cause: int(counts[c]) for c, cause in enumerate(FALLBACK_CAUSES, start=1)},
        weight=min(float(counts[FALLBACK_WEIGHT]) / of, 1.0) if of else 0.0,
    )


def _method(smoother: str, *, kbest: bool) -> str:
    """``PostProcessing.smoothing`` of ``smoother`` (``kim``, ``ec``), with ``kbest`` or not."""
    if smoother == "ec":
        return EC_PATH_RTS if kbest else EC
    return PATH_RTS if kbest else KIM


def _kbest(
    model: HybridModel,
    signals: AlignedSignals,
    result: EstimationResult,
    transitions: FloatArray,
    beam: int,
    smooth: bool,
    jit: bool,
    kernel: str,
    fallbacks: FloatArray,
    paired: HybridModel | None,
) -> tuple[EstimationResult, float]:
    """``result`` with the ``kbest`` path as its modes and the states of the EKF along it.

    :mod:`hybridlog.estimators.mode_hypotheses`: the path (straight-line code where
    ``kernel`` asks for it and the log measured every output,
    :func:`~hybridlog.estimators.mode_hypotheses.generate_kbest_source`, else the generic
    loop, which updates on the measured outputs alone), then the EKF that follows it
    (``smooth``: and the extended RTS smoother along it, its fallbacks counted into
    ``fallbacks``).  Returns the compile time too.  ``paired`` as for :func:`post_process`.
    """
    from hybridlog.estimators import mode_hypotheses
    from hybridlog.estimators.mode_hypotheses import best_history, follow_path, smooth_path

    compiled = compile_model(model, jit=jit)
    run = FilterRun.of(model, signals, "imm")
    n, n_x = signals.n_samples, model.n_states
    means = np.zeros((n, n_x))
    covariances = np.zeros((n, n_x, n_x))
    compile_start = time.perf_counter()
    searched: tuple[Any, ...]
    search: Callable[..., Any]
    if jit and use_unrolled(model, kernel) and signals.measures_every_output:
        searched = (run, _log(transitions), beam)
        search, _ = compile_generated(
            model,
            "kbest",
            lambda: module_source(model, mode_hypotheses.generate_kbest_source(model)),
            (mode_hypotheses.__name__, "hybridlog.estimators.unrolled"),
            "kbest_run",
            searched,
        )
    else:
        searched = (compiled.f, compiled.F, compiled.h, compiled.H, run, _log(transitions), beam)
        search = compile_for(best_history, searched) if jit else best_history
    compile_s = time.perf_counter() - compile_start
    path = cast(IntArray, search(*searched))
    followed = (compiled.f, compiled.F, compiled.h, compiled.H, run, path, means, covariances)
    compile_start = time.perf_counter()
    follow = compile_for(follow_path, followed) if jit else follow_path
    compile_s += time.perf_counter() - compile_start
    unweighed = follow(*followed)
    if unweighed >= 0:
        _refuse_unweighed_path(model, signals, path, unweighed, paired)
    if smooth:
        smoothed = (compiled.f, compiled.F, run, path, means, covariances, fallbacks)
        compile_start = time.perf_counter()
        backward = compile_for(smooth_path, smoothed) if jit else smooth_path
        compile_s += time.perf_counter() - compile_start
        backward(*smoothed)
    return (
        replace(
            result,
            modes=path,
            state_means=means,
            state_variances=np.ascontiguousarray(np.diagonal(covariances, axis1=1, axis2=2)),
            covariances=covariances if result.covariances is not None else None,
        ),
        compile_s,
    )


def _refuse_unweighed_path(
    model: HybridModel,
    signals: AlignedSignals,
    path: IntArray,
    row: int,
    paired: HybridModel | None = None,
) -> None:
    """Refuse a ``kbest`` path whose EKF cannot weigh the measurement of sample ``row``.

    There the innovation covariance ``S = H P Hᵀ + R`` of the path's mode, from the path's
    own prior, is not finite and positive definite in double precision (paper 000 eq. (9)):
    no update exists, and its prediction would stand in for an estimate of the log
    (:func:`~hybridlog.estimators.mode_hypotheses.follow_path`).  On the mode pairs of
    ``paired`` the mode is named in ``paired``'s modes: ``'down' (after a step of mode 'up')``,
    not the pair ``'up->down'`` the model file does not have.
    """
    from hybridlog.errors import DivergenceError, excerpt
    from hybridlog.estimators.mode_pairs import pair_named
    from hybridlog.times import format_time

    index = int(path[row])
    mode = excerpt(model.modes[index].id) if paired is None else pair_named(index, paired)
    raise DivergenceError(
        f"{model.origin or model.name}: imm (mode_sequence kbest) cannot weigh the measurement "
        f"at t = {format_time(signals.time[row])} s (sample {row}) along its most likely mode "
        f"path: mode {mode}'s innovation covariance "
        "H P Hᵀ + R is not finite and positive definite in double precision there, so no "
        "update exists"
    )
