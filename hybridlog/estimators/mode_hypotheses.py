r"""The most likely mode sequence from the k best mode histories, each with its own EKF.

The IMM merges its hypotheses every step: each mode's filter starts from a mixture of all
of them (:mod:`hybridlog.estimators.imm`).  Where two modes explain the outputs about
equally well for a while (with ``h_q = q·x`` a wrong mode ``q'`` fits with its state moved
to ``x q/q'``), the mixing moves every mode's state there, and the true mode's filter, started
from the mixture, is no more likely than the wrong one: the evidence that the dynamics give
over many samples is lost, and neither Kim's backward recursion nor a Viterbi path over the
IMM's per-mode likelihoods can bring it back (``docs/smoothing.md``).

Here every hypothesis is a whole mode history ``q(0..k)`` with its own extended Kalman
filter, never mixed with another, and its log posterior

.. math::

    \log w_h(k) = \log \Pr(q(0)) + \sum_{l=1}^{k}
        \bigl(\log \Pi_{q(l-1) q(l)} + \log N(\gamma_h(l); 0, S_h(l))\bigr)

(the prediction-error decomposition of the sequence's likelihood, exact for linear modes).
Each step extends each of the ``beam`` hypotheses by every mode (EKF prediction with
``f_j, F_j`` from the hypothesis' own estimate, update with ``h_j, H_j``) and keeps the
``beam`` best extensions: the k-best trajectory tracking of paper 002 (Hofbaur and Williams,
``papers/002``, eqs. (4)-(5)) applied to an enumerated-mode model, or a beam search over
mode sequences (a list Viterbi whose survivors carry their own filter, Raheli, Polydoros and
Tzou, IEEE Trans. Commun. 43(2/3/4), 1995).  The path is the history of the best hypothesis at
the last sample: the maximum a posteriori mode sequence when the beam keeps it, exactly so
with ``beam ≥ n_q^(N-1)`` or when no mode's state remembers the past (then the likelihood of
a step depends on its own mode only and the search is the Viterbi algorithm).

Memory: the back pointer (int32) and mode (int16) of every kept hypothesis at every sample,
``6 N beam`` bytes (120 MB for 10^6 samples at beam 20); time: ``beam · n_q`` EKF predictions
and likelihoods per sample and ``beam`` updates, less what an exact bound rules out; for small
models the search is straight-line code per model (:func:`generate_kbest_source`): about
5 µs per sample for the three-tank model at beam 20, 38 µs with the generic loop
(``docs/smoothing.md``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from hybridlog.estimators.common import FilterRun
from hybridlog.estimators.kernels import (
    cholesky,
    congruence,
    gain,
    joseph_update,
    kalman_update,
    keep_psd,
    leave_out_unmeasured,
    left_out,
    measured_log_density,
    workspace,
)
from hybridlog.estimators.rts_steps import TAKEN, note_fallbacks, rts_cause, rts_work
from hybridlog.estimators.unrolled import (
    Program,
    matrix_names,
    noise_matrices,
    product,
    reshape,
    term,
    upper,
    vector_names,
)
from hybridlog.jit import jit, jit_kernel, jitable_kernel
from hybridlog.model.compiled import ModelFunction
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import FloatArray, IntArray

__all__ = ["best_history", "follow_path", "generate_kbest_source", "smooth_path"]


class Scratch(NamedTuple):
    """Scratch arrays of :func:`predict` (:func:`scratch_for`)."""

    F: FloatArray
    y: FloatArray
    nn: FloatArray


@jit
def scratch_for(n: int, m: int) -> Scratch:
    """The scratch arrays of :func:`predict` for ``n`` states and ``m`` outputs."""
    return Scratch(np.empty((n, n)), np.empty(m), np.empty((n, n)))


@jitable_kernel
def predict(
    f: ModelFunction,
    F: ModelFunction,
    h: ModelFunction,
    H: ModelFunction,
    mode: int,
    x: FloatArray,
    P: FloatArray,
    u: FloatArray,
    u_next: FloatArray,
    y: FloatArray,
    Q: FloatArray,
    x_pred: FloatArray,
    P_pred: FloatArray,
    H_out: FloatArray,
    gamma: FloatArray,
    scratch: Scratch,
) -> None:
    """EKF prediction of ``mode`` from ``x̂(k|k), P(k|k)`` and its innovation at ``k+1``.

    ``x̂⁻ = f(x̂, u(k))``, ``P⁻ = F P Fᵀ + Q``, ``H`` at ``x̂⁻`` and ``γ = y(k+1) − h(x̂⁻,
    u(k+1))`` (paper 000 eqs. (7)-(8), (31) in the NOTES' reading; the IMM's mode-matched
    prediction without the mixing).
    """
    F_x, y_hat, work = scratch
    f(mode, x, u, x_pred)
    F(mode, x, u, F_x)
    congruence(F_x, P, work, P_pred)
    for a in range(P.shape[0]):
        for b in range(P.shape[0]):
            P_pred[a, b] += Q[a, b]
    h(mode, x_pred, u_next, y_hat)
    H(mode, x_pred, u_next, H_out)
    for b in range(y.shape[0]):
        gamma[b] = y[b] - y_hat[b]


class Beam(NamedTuple):
    """The search's arrays (:func:`beam_for`).

    The kept hypotheses (``_h``: estimate, covariance, mode, log weight), one step's
    extensions (``_c``: prediction, its covariance, ``H``, innovation, Cholesky factor of
    ``S``, log weight and prior log weight; extension ``c = i n_q + j`` extends hypothesis
    ``i`` by mode ``j``), the beam best log weights found in a step (a min-heap), and the
    history (each kept hypothesis' parent and mode at every sample).
    """

    x_h: FloatArray
    P_h: FloatArray
    mode_h: IntArray
    weight_h: FloatArray
    x_c: FloatArray
    P_c: FloatArray
    H_c: FloatArray
    gamma_c: FloatArray
    L_c: FloatArray
    weight_c: FloatArray
    prior_c: FloatArray
    best_found: FloatArray
    parent: npt.NDArray[np.int32]
    modes: npt.NDArray[np.int16]


@jit
def beam_for(n_samples: int, n: int, m: int, n_q: int, width: int) -> Beam:
    """The arrays of a search of ``width`` hypotheses (:class:`Beam`).

    For ``n`` states, ``m`` outputs and ``n_q`` modes over ``n_samples`` samples.
    """
    candidates = width * n_q
    return Beam(
        np.zeros((width, n)),
        np.zeros((width, n, n)),
        np.zeros(width, dtype=np.int64),
        np.full(width, -math.inf),
        np.zeros((candidates, n)),
        np.zeros((candidates, n, n)),
        np.zeros((candidates, m, n)),
        np.zeros((candidates, m)),
        np.zeros((candidates, m, m)),
        np.full(candidates, -math.inf),
        np.full(candidates, -math.inf),
        np.empty(width),
        np.zeros((n_samples, width), dtype=np.int32),
        np.zeros((n_samples, width), dtype=np.int16),
    )


@jit
def start(
    x0: FloatArray,
    P0: FloatArray,
    mu0: FloatArray,
    x_h: FloatArray,
    P_h: FloatArray,
    mode_h: IntArray,
    weight_h: FloatArray,
    modes: npt.NDArray[np.int16],
) -> int:
    """The first hypotheses: one per mode the prior allows (the likeliest first), at ``x0``."""
    order = np.argsort(-mu0, kind="mergesort")
    kept = 0
    for r in range(min(x_h.shape[0], mu0.shape[0])):
        j = order[r]
        if mu0[j] > 0.0:
            x_h[kept] = x0
            P_h[kept] = P0
            mode_h[kept] = j
            weight_h[kept] = math.log(mu0[j])
            modes[0, kept] = j
            kept += 1
    return kept


@jit
def likelihood_caps(R: FloatArray, y: FloatArray) -> FloatArray:
    """``cap_j = −(m log 2π + log det R_j)/2``, at least every ``log N(γ; 0, S)`` with ``S ⪰ R_j``.

    Of the outputs ``y`` measured (NaN: not measured, :func:`leave_out_unmeasured`): ``m``
    and ``R_j`` theirs.  ``+inf`` for an ``R_j`` that is not positive definite (no bound).
    An extension whose prior plus ``cap_j`` is below the beam-th best log weight already
    found cannot be kept, and is not computed: exact pruning, the path is the same as
    without it.
    """
    n_q, m, _ = R.shape
    caps = np.full(n_q, math.inf)
    L = np.zeros((m, m))
    R_left = np.empty((m, m))
    no_rows = np.zeros((m, 0))
    gamma = np.zeros(m)
    measured = m - left_out(y)
    for j in range(n_q):
        leave_out_unmeasured(y, no_rows, gamma, R[j], R_left)
        if cholesky(R_left, L):
            log_det = 0.0
            for a in range(m):
                log_det += 2.0 * math.log(L[a, a])  # 0 for an output left out
            caps[j] = -0.5 * (measured * math.log(2.0 * math.pi) + log_det)
    return caps


@jit
def extension_priors(
    kept: int,
    weight_h: FloatArray,
    mode_h: IntArray,
    log_transitions: FloatArray,
    prior_c: FloatArray,
    weight_c: FloatArray,
) -> IntArray:
    """Each extension's prior log weight (hypothesis, then its Markov step); their order.

    Extension ``c = i n_q + j`` extends hypothesis ``i`` by mode ``j``; its log weight is
    reset to ``-inf`` until computed.  Returns the extensions by decreasing prior.
    """
    n_q = log_transitions.shape[0]
    for i in range(kept):
        for j in range(n_q):
            c = i * n_q + j
            prior_c[c] = weight_h[i] + log_transitions[mode_h[i], j]
            weight_c[c] = -math.inf
    return np.argsort(-prior_c[: kept * n_q], kind="mergesort")


@jit_kernel
def note_weight(weight: float, best_found: FloatArray, found: int) -> tuple[int, float]:
    """Record a computed log weight among the beam best of the step; (found, threshold).

    The threshold is the beam-th best once ``beam`` weights were found, else ``-inf``.
    ``best_found[:found]`` is a binary min-heap (the least weight first), so that a weight
    costs ``O(log beam)``: a scan for the least on every weight made each step of the search
    cost ``O(n_q beam²)`` (126 s for the 301 samples of the three-tank sample log at beam
    10,000).
    """
    width = best_found.shape[0]
    if found < width:
        i = found  # sift the new weight up from the heap's end
        while i > 0:
            up = (i - 1) // 2
            if best_found[up] <= weight:
                break
            best_found[i] = best_found[up]
            i = up
        best_found[i] = weight
        found += 1
        return found, (best_found[0] if found == width else -math.inf)
    if weight > best_found[0]:
        i = 0  # the new weight replaces the least, sifted down
        while True:
            child = 2 * i + 1
            if child >= width:
                break
            if child + 1 < width and best_found[child + 1] < best_found[child]:
                child += 1
            if best_found[child] >= weight:
                break
            best_found[i] = best_found[child]
            i = child
        best_found[i] = weight
    return found, best_found[0]


@jit
def backtrack(modes: npt.NDArray[np.int16], parent: npt.NDArray[np.int32]) -> IntArray:
    """The mode history of the best hypothesis at the last sample (hypothesis 0 there)."""
    n_samples = modes.shape[0]
    path = np.zeros(n_samples, dtype=np.int64)
    index = 0
    for k in range(n_samples - 1, -1, -1):
        path[k] = modes[k, index]
        index = parent[k, index]
    return path


def best_history(
    f: ModelFunction,
    F: ModelFunction,
    h: ModelFunction,
    H: ModelFunction,
    run: FilterRun,
    log_transitions: FloatArray,
    beam: int,
) -> IntArray:
    """Mode path of the most likely of the ``beam`` best mode histories (module docstring).

    Row ``k`` of the signals is ``u(k)``, ``y(k)``; row 0 is the prior (``run.x0``,
    ``run.P0``, ``run.mu0``), as in the IMM.  A hypothesis whose innovation covariance is not
    positive definite, or whose log likelihood is NaN (a model function's NaN), is ruled out
    at that step, as in the straight-line code; if every extension is ruled out, the
    hypotheses carry on with their predictions and the sample's likelihoods are left out.
    Ties go to the lower (hypothesis, mode) index.  Plain Python that numba compiles on first
    use (``jit.compile_for``).
    """
    inputs, outputs, Q, R, x0, P0, mu0 = run
    n_samples, m = outputs.shape
    n = x0.shape[0]
    n_q = mu0.shape[0]
    if n_samples == 0:
        return np.zeros(0, dtype=np.int64)
    width = max(1, beam)
    # the gain and the Joseph update are computed only for the extensions kept
    x_h, P_h, mode_h, weight_h, x_c, P_c, H_c, gamma_c, L_c, weight_c, prior_c, best_found, \
        parent, modes = beam_for(n_samples, n, m, n_q, width)  # fmt: skip
    kept = start(x0, P0, mu0, x_h, P_h, mode_h, weight_h, modes)
    S = np.empty((m, m))
    scratch = scratch_for(n, m)
    work_nn = np.empty((n, n))
    work_mn = np.empty((m, n))
    work_nm = np.empty((n, m))
    IKH = np.empty((n, n))
    gain_k = np.empty((n, m))
    vec_m = np.empty(m)
    vec_m2 = np.empty(m)
    every_cap = likelihood_caps(R, np.zeros(m))
    R_left = np.empty((m, m))
    for k in range(n_samples - 1):
        u = inputs[k]
        u_next = inputs[k + 1]
        y = outputs[k + 1]
        left = left_out(y)  # outputs not measured at k+1: the update is the others'
        cap = likelihood_caps(R, y) if left else every_cap
        any_finite = False
        used = kept * n_q
        by_prior = extension_priors(kept, weight_h, mode_h, log_transitions, prior_c, weight_c)
        found = 0
        threshold = -math.inf  # the beam-th best of best_found once it is full
        for r in range(used):
            c = by_prior[r]
            i = c // n_q
            j = c % n_q
            prior = prior_c[c]
            if not prior > -math.inf:
                break  # sorted: none of the rest is possible either
            if found == width and prior + cap[j] < threshold:
                continue
            predict(f, F, h, H, j, x_h[i], P_h[i], u, u_next, y, Q[j], x_c[c], P_c[c],
                    H_c[c], gamma_c[c], scratch)  # fmt: skip
            R_j = R[j]
            if left:
                leave_out_unmeasured(y, H_c[c], gamma_c[c], R_j, R_left)
                R_j = R_left
            congruence(H_c[c], P_c[c], work_mn, S)
            for a in range(m):
                for b in range(m):
                    S[a, b] += R_j[a, b]
            if cholesky(S, L_c[c]):
                weight = prior + measured_log_density(gamma_c[c], L_c[c], vec_m, left)
                if weight == weight:  # NaN (a model function's): ruled out, as by Cholesky
                    weight_c[c] = weight
                    any_finite = True
                    found, threshold = note_weight(weight, best_found, found)
        # every extension ruled out: rank by the prior alone, carry the predictions on
        scores = weight_c[:used] if any_finite else prior_c[:used]
        order = np.argsort(-scores, kind="mergesort")
        top = scores[order[0]]
        kept = 0
        for r in range(min(width, used)):
            c = order[r]
            if not scores[c] > -math.inf:
                break
            if any_finite:  # the EKF update of the kept extension (Joseph form)
                gain(P_c[c], H_c[c], L_c[c], work_nm, vec_m, vec_m2, gain_k)
                for a in range(n):
                    acc = x_c[c, a]
                    for b in range(m):
                        acc += gain_k[a, b] * gamma_c[c, b]
                    x_h[r, a] = acc
                joseph_update(P_c[c], gain_k, H_c[c], R[c % n_q], IKH, work_nn, work_nm, P_h[r])
            else:
                x_h[r] = x_c[c]
                P_h[r] = P_c[c]
            mode_h[r] = c % n_q
            weight_h[r] = scores[c] - top  # relative to the best: no drift to -inf
            parent[k + 1, r] = c // n_q
            modes[k + 1, r] = c % n_q
            kept = r + 1
    return backtrack(modes, parent)


def follow_path(
    f: ModelFunction,
    F: ModelFunction,
    h: ModelFunction,
    H: ModelFunction,
    run: FilterRun,
    path: IntArray,
    means: FloatArray,
    covariances: FloatArray,
) -> int:
    """The EKF that follows one mode path: ``x̂(k|k)``, ``P(k|k)`` into ``means``, ``covariances``.

    The best hypothesis' own filter, computed again along its path (the search keeps only
    modes and back pointers): prediction with ``f, F`` of ``path[k]`` from ``x̂(k−1|k−1)``,
    update with ``h, H`` (Joseph form).  Returns the first sample measuring an output
    where ``S`` is not finite and positive definite (no update exists; the prediction is
    written there and the caller refuses the run), or -1.  Row 0 is the prior.  Each
    covariance is kept PSD (:func:`keep_psd`): along one path of a plant without process noise
    the covariance shrinks geometrically into the subnormal range, where the rounding of the
    update left a variance of -1e-323 beside others of 1e-320 (double_cart_case2, 1,200 samples:
    ``--mode-sequence kbest`` was refused as a diverged filter at sample 1123).
    """
    inputs, outputs, Q, R, x0, P0, _ = run
    n_samples, m = outputs.shape
    n = x0.shape[0]
    unweighed = -1
    if n_samples == 0:
        return unweighed
    means[0] = x0
    covariances[0] = P0
    work = workspace(n, m)
    x_pred = np.empty(n)
    P_pred = np.empty((n, n))
    scratch = scratch_for(n, m)
    H_j = np.empty((m, n))
    gamma = np.empty(m)
    R_left = np.empty((m, m))
    shifted = np.empty((n, n))
    factor = np.empty((n, n))
    for k in range(1, n_samples):
        j = path[k]
        predict(f, F, h, H, j, means[k - 1], covariances[k - 1], inputs[k - 1], inputs[k],
                outputs[k], Q[j], x_pred, P_pred, H_j, gamma, scratch)  # fmt: skip
        R_j = R[j]
        left = left_out(outputs[k])
        if left:  # an update on the measured outputs alone
            leave_out_unmeasured(outputs[k], H_j, gamma, R_j, R_left)
            R_j = R_left
        positive = kalman_update(x_pred, P_pred, H_j, R_j, gamma, work, means[k], covariances[k])
        if positive:
            for b in range(m):
                positive = positive and work.L[b, b] < np.inf
        if not positive:
            means[k] = x_pred
            covariances[k] = P_pred
            if unweighed < 0 and left < m:
                unweighed = k
        keep_psd(covariances[k], shifted, factor)
    return unweighed


def smooth_path(
    f: ModelFunction,
    F: ModelFunction,
    run: FilterRun,
    path: IntArray,
    means: FloatArray,
    covariances: FloatArray,
    fallbacks: FloatArray,
) -> None:
    """Extended RTS smoother along one mode path, in place over :func:`follow_path`'s output.

    Each step is :func:`hybridlog.estimators.rts_steps.rts_step` with ``f, F`` of mode
    ``path[k+1]`` linearised at ``x̂(k|k)`` (Rauch, Tung, Striebel 1965); where it does not
    apply (``P^-(k+1)`` not positive definite, its guard, or the rounding it would carry
    back: its rounding probe) the filtered estimate stands.  The
    last row is the filter's.  Each smoothed covariance is kept PSD (:func:`keep_psd`): along
    one path of a plant without process noise the EKF's covariances shrink to a condition of
    10^9 and more, the gain ``J`` grows, and the rounding of one step's ``P^s(k+1)`` (an
    eigenvalue of -1e-18 against 1e-9) came back through ``J P^s Jᵀ`` amplified at every step
    before it, to variances of -3e-8 against 4e-7 a hundred steps earlier.  ``fallbacks``
    (:data:`~hybridlog.estimators.rts_steps.FALLBACKS_WIDTH` zeros) gets the samples
    where the filtered estimate stood, by cause
    (:func:`~hybridlog.estimators.rts_steps.note_fallbacks`).
    """
    inputs, _, Q, _, _, _, _ = run
    n_samples, n = means.shape
    w = rts_work(n)
    x_f = np.empty(n)
    P_f = np.empty((n, n))
    shifted = np.empty((n, n))
    factor = np.empty((n, n))
    r_next = np.zeros(n)  # the rounding probes of rts_step
    r_out = np.zeros(n)
    for k in range(n_samples - 2, -1, -1):
        j = path[k + 1]
        x_f[:] = means[k]
        P_f[:, :] = covariances[k]
        cause = rts_cause(f, F, j, x_f, P_f, inputs[k], Q[j], means[k + 1], covariances[k + 1],
                          means[k], covariances[k], w, r_next, r_out)  # fmt: skip
        if cause == TAKEN:
            keep_psd(covariances[k], shifted, factor)
        else:
            note_fallbacks(1 << (cause - 1), 1.0, fallbacks)  # the path's one estimate
        r_next[:] = r_out


def generate_kbest_source(model: HybridModel) -> str:
    """Straight-line source of :func:`best_history`'s loop for ``model`` (see ``unrolled.py``).

    Defines ``kbest_run(run, log_transitions, beam)`` with :func:`best_history`'s meaning
    (its model functions, noise covariances and small matrix products written out per mode);
    the fixed parts are the same kernels (:func:`beam_for`, :func:`start`,
    :func:`extension_priors`, :func:`note_weight`, :func:`backtrack`).  A Cholesky factor
    that fails (a non-positive pivot) gives NaN, taken as a ruled-out extension as in the
    generic loop.
    """
    n, m, n_u, n_q = model.n_states, model.n_outputs, model.n_inputs, model.n_modes
    Q, R = noise_matrices(model)
    p = Program(indent="    ")
    for line in (
        "inputs = run.inputs",
        "outputs = run.outputs",
        "n_samples = outputs.shape[0]",
        "if n_samples == 0:",
        "    return np.zeros(0, dtype=np.int64)",
        "width = max(1, beam)",
        "x_h, P_h, mode_h, weight_h, x_c, P_c, _, gamma_c, L_c, weight_c, prior_c, best_found, "
        f"parent, modes = beam_for(n_samples, {n}, {m}, {n_q}, width)",
        "kept = start(run.x0, run.P0, run.mu0, x_h, P_h, mode_h, weight_h, modes)",
        f"cap = likelihood_caps(run.R, np.zeros({m}))",  # every output measured
    ):
        p.emit(line)
    u, v, y = p.open_time_loop(n_u, m)
    p.emit("any_finite = False")
    p.emit(f"used = kept * {n_q}")
    p.emit(
        "by_prior = extension_priors(kept, weight_h, mode_h, log_transitions, prior_c, weight_c)"
    )
    p.emit("found = 0")
    p.emit("threshold = -math.inf")
    p.emit("for r in range(used):")
    p.indent += "    "
    p.emit("c = by_prior[r]")
    p.emit(f"i = c // {n_q}")
    p.emit(f"j = c % {n_q}")
    p.emit("prior = prior_c[c]")
    p.emit("if not prior > -math.inf:")
    p.emit("    break")
    p.emit("if found == width and prior + cap[j] < threshold:")
    p.emit("    continue")
    X = vector_names("x", n)
    P = matrix_names("P", n, n, symmetric=True)
    p.carry(X, [f"x_h[i, {a}]" for a in range(n)])
    p.carry(upper(P), [f"P_h[i, {a}, {b}]" for a in range(n) for b in range(a, n)])
    p.emit("ll = -math.inf")
    for j in range(n_q):  # prediction, innovation and likelihood of an extension by mode j
        p.emit(f"{'if' if j == 0 else 'elif'} j == {j}:")
        p.indent += "    "
        x_pred = p.mode_values(model, j, "f", X, u)
        F = reshape(p.mode_values(model, j, "F", X, u), n, n)
        P_pred = p.congruence(f"pp{j}_", F, P, add=Q[j])
        x_names = p.named("xp", x_pred)
        y_pred = p.mode_values(model, j, "h", x_names, v)
        H = reshape(p.mode_values(model, j, "H", x_names, v), m, n)
        gamma = [p.difference("g", y[b], y_pred[b]) for b in range(m)]
        L = p.cholesky(f"l{j}_", p.congruence(f"s{j}_", H, P_pred, add=R[j]))
        p.emit(f"ll = {p.gaussian_log_density(f'd{j}_', gamma, L)}")
        for a in range(n):
            p.emit(f"x_c[c, {a}] = {term(x_names[a])}")
            for b in range(n):
                p.emit(f"P_c[c, {a}, {b}] = {term(P_pred[a][b])}")
        for b in range(m):
            p.emit(f"gamma_c[c, {b}] = {term(gamma[b])}")
            for e in range(b + 1):
                p.emit(f"L_c[c, {b}, {e}] = {term(L[b][e])}")
        p.indent = p.indent[:-4]
    p.emit("if ll == ll and ll > -math.inf:")  # NaN: a failed Cholesky factor
    p.emit("    weight = prior + ll")
    p.emit("    weight_c[c] = weight")
    p.emit("    any_finite = True")
    p.emit("    found, threshold = note_weight(weight, best_found, found)")
    p.indent = p.indent[:-4]
    p.emit("scores = weight_c[:used] if any_finite else prior_c[:used]")
    p.emit('order = np.argsort(-scores, kind="mergesort")')
    p.emit("top = scores[order[0]]")
    p.emit("kept = 0")
    p.emit("for r in range(min(width, used)):")
    p.indent += "    "
    p.emit("c = order[r]")
    p.emit("if not scores[c] > -math.inf:")
    p.emit("    break")
    p.emit(f"j = c % {n_q}")
    p.emit("if not any_finite:")
    p.emit("    x_h[r] = x_c[c]")
    p.emit("    P_h[r] = P_c[c]")
    XP = vector_names("xq", n)
    PP = matrix_names("Pq", n, n, symmetric=True)
    G = vector_names("gq", m)
    LL = [[f"Lq_{b}_{e}" if e <= b else 0.0 for e in range(m)] for b in range(m)]
    for j in range(n_q):  # the EKF update (Joseph form) of a kept extension by mode j
        p.emit(f"elif j == {j}:")
        p.indent += "    "
        p.carry(XP, [f"x_c[c, {a}]" for a in range(n)])
        p.carry(upper(PP), [f"P_c[c, {a}, {b}]" for a in range(n) for b in range(a, n)])
        p.carry(G, [f"gamma_c[c, {b}]" for b in range(m)])
        p.carry(
            [LL[b][e] for b in range(m) for e in range(b + 1)],
            [f"L_c[c, {b}, {e}]" for b in range(m) for e in range(b + 1)],
        )
        H = reshape(p.mode_values(model, j, "H", XP, v), m, n)
        K = p.gain(f"k{j}_", PP, H, LL)
        for a in range(n):
            x_new = p.let("xn", [XP[a], *[product(K[a][b], G[b]) for b in range(m)]])
            p.emit(f"x_h[r, {a}] = {term(x_new)}")
        P_new = p.joseph(f"j{j}_", PP, K, H, R[j])
        for a in range(n):
            for b in range(n):
                p.emit(f"P_h[r, {a}, {b}] = {term(P_new[a][b])}")
        p.indent = p.indent[:-4]
    p.emit("mode_h[r] = j")
    p.emit("weight_h[r] = scores[c] - top")
    p.emit(f"parent[k + 1, r] = c // {n_q}")
    p.emit("modes[k + 1, r] = j")
    p.emit("kept = r + 1")
    p.indent = "    "
    p.emit("return backtrack(modes, parent)")
    body = p.source()
    return (
        "import numpy as np\n\n"
        "from hybridlog.estimators.mode_hypotheses import (\n"
        "    backtrack,\n    beam_for,\n    extension_priors,\n    likelihood_caps,\n"
        "    note_weight,\n"
        "    start,\n)\n\n\n"
        f"def kbest_run(run, log_transitions, beam):\n{body}\n"
    )
