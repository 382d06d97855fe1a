"""Straight-line code of the IMM's backward passes (Kim's, expectation correction's) per model.

Generated per model as the filters' (:mod:`hybridlog.estimators.unrolled`), cached by the
model's hash, and equal to the generic loops of :mod:`hybridlog.estimators.smoother_kernels`
to rounding (``tests/estimators/test_smoothing.py``, ``test_smoothing_ec.py``).  The
algorithms are :mod:`hybridlog.estimators.smoothing`'s docstring.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

from hybridlog.estimators.common import (
    packed_width,
    upper_pairs,
)
from hybridlog.estimators.kernels import (
    PSD_TOLERANCE,
)
from hybridlog.estimators.smoother_kernels import (
    COVARIANCE,
    FALLBACK_WEIGHT,
    GUARD,
    GUARD_TOLERANCE,
    LINEAR_FLOOR,
    LOG_NEGLIGIBLE_WEIGHT,
    NEGLIGIBLE_WEIGHT,
    PREDICTION,
    ROUNDING,
    ROUNDING_LIMIT_SQUARED,
    ROUNDING_UNIT,
    density_ceilings,
    ec_order,
    positive_definite_noise,
)
from hybridlog.estimators.unrolled import (
    Entry,
    Matrix,
    Program,
    Vector,
    matrix_names,
    noise_matrices,
    product,
    reshape,
    term,
    upper,
    vector_names,
)
from hybridlog.model.hybrid_model import HybridModel


def _log_sum_exp_source(p: Program, hint: str, expressions: list[str]) -> str:
    """Emit ``log Σ exp(expressions)`` as :func:`log_sum_exp` computes it; its variable."""
    return _log_sum_exp_parts(p, hint, expressions)[0]


def _log_sum_exp_parts(p: Program, hint: str, expressions: list[str]) -> tuple[str, list[str], str]:
    """``log Σ exp(a_i)`` as :func:`log_sum_exp` computes it (the same operations), with its parts.

    Returns the variables of the result, of ``e_i = exp(a_i − max a)`` and of ``s = Σ e_i``,
    so that the normalised weights ``exp(a_i − log Σ exp a)`` are ``e_i / s`` without another
    ``exp`` (equal to rounding).  When every ``a_i`` is ``-inf``: ``-inf``, zeros and 1.
    """
    terms = [p.assign(hint + "t", e) for e in expressions]
    top = terms[0] if len(terms) == 1 else p.assign(hint + "top", f"max({', '.join(terms)})")
    result = p.fresh(hint)
    exps = [p.fresh(hint + "e") for _ in terms]
    total = p.fresh(hint + "s")
    p.emit(f"if {top} == -math.inf:")
    p.emit(f"    {result} = -math.inf")
    for e in exps:
        p.emit(f"    {e} = 0.0")
    p.emit(f"    {total} = 1.0")
    p.emit("else:")
    for e, t in zip(exps, terms, strict=True):
        p.emit(f"    {e} = math.exp({t} - {top})")
    p.emit(f"    {total} = {' + '.join(exps)}")
    p.emit(f"    {result} = {top} + math.log({total})")
    return result, exps, total


def _select(
    p: Program,
    condition: str,
    bundle: str,
    chosen: Sequence[Entry],
    other: Sequence[Entry],
) -> None:
    """Bind the tuple ``bundle`` to ``chosen`` where ``condition`` holds, else to ``other``."""
    with p.block(f"if {condition}:"):
        _bind(p, bundle, chosen)
    with p.block("else:"):
        _bind(p, bundle, other)


def _bind(p: Program, bundle: str, values: Sequence[Entry]) -> None:
    """``bundle = (values…)``: one tuple where a branch would assign every value's name.

    numba rebuilds SSA form for each variable assigned in more than one place, in a pass
    over every block of the function: a name per value assigned in each branch made that
    pass, not LLVM, most of a straight-line smoother's compile time (expectation
    correction's for three modes: 70 s), where one tuple per branch, unpacked once after
    them (:func:`_unpack`), costs one such variable and no run time.

    The tuple is built under a name of its own, assigned once, and then bound to ``bundle``:
    CPython builds a tuple display of more than 30 entries through a list (a step's values
    for 6 states are 6 + 21 + 6 = 33), and numba's rewrite of that list back into a tuple
    refuses a target assigned in more than one place (an ``AssertionError`` compiling the
    pass).
    """
    built = p.fresh(bundle + "_")
    p.emit(f"{built} = ({', '.join(term(value) for value in values)},)")
    p.emit(f"{bundle} = {built}")


def _unpack(p: Program, names: Sequence[str], bundle: str) -> None:
    """``names… = bundle`` after the branches that bound it (:func:`_bind`)."""
    p.emit(f"{', '.join(names)}, = {bundle}")


def _triangular_solves(
    p: Program, hint: str, L: Matrix, inverse: Sequence[Entry], b: Vector
) -> Vector:
    """``(L Lᵀ)⁻¹ b``: ``L z = b`` then ``Lᵀ y = z``, with ``inverse[i] = 1/L[i][i]``.

    :meth:`~hybridlog.estimators.unrolled.Program.forward_solve` and ``backward_solve``
    with a multiplication by the reciprocal in place of each division.
    """
    size = len(L)
    z: Vector = []
    for i in range(size):
        partial = p.let(hint + "fp", [b[i], *[_negated(product(L[i][k], z[k])) for k in range(i)]])
        z.append(
            partial
            if partial == 0.0
            else p.assign(hint + "f", f"{term(partial)}*{term(inverse[i])}")
        )
    y: Vector = [0.0] * size
    for i in range(size - 1, -1, -1):
        partial = p.let(
            hint + "bp",
            [z[i], *[_negated(product(L[k][i], y[k])) for k in range(i + 1, size)]],
        )
        y[i] = (
            partial
            if partial == 0.0
            else p.assign(hint + "b", f"{term(partial)}*{term(inverse[i])}")
        )
    return y


def _negated(value: Entry | None) -> Entry | None:
    """``−value`` for :meth:`Program.let` (``None`` stays a structural zero)."""
    if value is None:
        return None
    if isinstance(value, float):
        return -value
    return f"-{value}" if "*" not in value else f"-({value})"


def _mode_recursion_source(
    p: Program, T: Matrix, log_T: Matrix, log_next: Vector, mu_next: Vector
) -> tuple[Vector, Vector, list[Vector]]:
    """Emit one step of Kim's mode recursion; variables of ``log μ^s(k)``, ``μ^s(k)``, ``w_{j|i}``.

    ``log_next`` and ``mu_next`` hold ``log μ^s(k+1)`` and ``μ^s(k+1)``; ``mu[k]`` is read.
    Two branches, equal to rounding:

    * linear, when every quantity is in full-precision range -- each ``c̄_j``, each
      ``μ^s_j(k+1)`` (unless ``−inf`` in log space) and each ``μ_i(k)`` and unnormalised
      ``μ^s_i(k)`` (unless ``μ_i(k) = 0``) at least :data:`LINEAR_FLOOR`: ``q_j = μ^s_j(k+1) /
      c̄_j``, ``a_ij = Π_ij q_j`` (``= p_ij / μ_i``), ``s_i = Σ_j a_ij``, ``μ^s_i ∝ μ_i s_i``,
      ``w_{j|i} = a_ij / s_i`` and ``log μ^s_i = log(μ^s_i)``: the log space adds no range
      there (no ``exp``, ``n_q`` ``log``);
    * else the log-space recursion of smoothing's docstring as :func:`kim_backward` computes
      it, with fewer ``exp``: ``log c̄_j`` as the log of the linear sum (``μ(k)`` is stored
      linear) unless it is below :data:`LINEAR_FLOOR`, and ``w_{j|i}``, ``μ^s_i`` as the exps
      each log-sum-exp already took, normalised (:func:`_log_sum_exp_parts`).

    A row with ``μ_i(k) = 0`` (``log μ^s_i(k) = −inf``) takes ``w_{j|i} = μ^s_j(k+1)``, as
    :func:`kim_backward` does.
    """
    n_q = len(T)
    floor = repr(LINEAR_FLOOR)
    mu_k = [p.assign("mk", f"mu[k, {i}]") for i in range(n_q)]
    c_bar = [p.let("cb", [f"{T[i][j]}*{mu_k[i]}" for i in range(n_q)]) for j in range(n_q)]
    ratio = [p.assign("q", f"{mu_next[j]} / {term(c_bar[j])}") for j in range(n_q)]
    a = [[p.assign("a", f"{T[i][j]}*{ratio[j]}") for j in range(n_q)] for i in range(n_q)]
    s = [p.let("s", list(a[i])) for i in range(n_q)]
    b = [p.assign("b", f"{mu_k[i]}*{term(s[i])}") for i in range(n_q)]
    b_total = p.let("bt", list(b))
    conditions = (
        [f"{term(c_bar[j])} >= {floor}" for j in range(n_q)]
        + [f"({log_next[j]} == -math.inf or {mu_next[j]} >= {floor})" for j in range(n_q)]
        + [
            f"({mu_k[i]} == 0.0 or ({mu_k[i]} >= {floor} and {b[i]} >= {floor}))"
            for i in range(n_q)
        ]
        + [f"{term(b_total)} >= {floor}"]
    )
    fast = p.assign("fast", " and ".join(conditions))
    log_new: Vector = [p.fresh("ln") for _ in range(n_q)]
    mu_s: Vector = [p.fresh("ms") for _ in range(n_q)]
    weights: list[Vector] = [[p.fresh("w") for _ in range(n_q)] for _ in range(n_q)]
    p.emit(f"if {fast}:")
    p.indent += "    "
    for i in range(n_q):
        p.emit(f"{mu_s[i]} = {b[i]} / {term(b_total)}")
        p.emit(f"{log_new[i]} = math.log({mu_s[i]}) if {mu_s[i]} > 0.0 else -math.inf")
        for j in range(n_q):
            p.emit(
                f"{weights[i][j]} = {mu_next[j]} if {mu_k[i]} == 0.0 else {a[i][j]} / {term(s[i])}"
            )
    p.indent = p.indent[:-4]
    p.emit("else:")
    p.indent += "    "
    log_mu = [
        p.assign("lmu", f"math.log({mu_k[i]}) if {mu_k[i]} > 0.0 else -math.inf")
        for i in range(n_q)
    ]
    log_c: list[str] = []
    for j in range(n_q):
        result = p.fresh("lc")
        p.emit(f"if {term(c_bar[j])} > {floor}:")
        p.emit(f"    {result} = math.log({term(c_bar[j])})")
        p.emit("else:")
        p.indent += "    "
        exact = _log_sum_exp_source(p, "lc", [f"{log_T[i][j]} + {log_mu[i]}" for i in range(n_q)])
        p.emit(f"{result} = {exact}")
        p.indent = p.indent[:-4]
        log_c.append(result)
    log_pair = [
        [
            p.assign(
                "lp",
                f"-math.inf if ({log_c[j]} == -math.inf or {log_next[j]} == -math.inf) else "
                f"{log_next[j]} + {log_mu[i]} + {log_T[i][j]} - {log_c[j]}",
            )
            for j in range(n_q)
        ]
        for i in range(n_q)
    ]
    rows = [_log_sum_exp_parts(p, "rt", list(log_pair[i])) for i in range(n_q)]
    total, total_exps, total_sum = _log_sum_exp_parts(p, "tot", [row[0] for row in rows])
    p.emit(f"if {total} == -math.inf:")
    for i in range(n_q):
        p.emit(f"    {log_new[i]} = {log_mu[i]}")
        p.emit(f"    {mu_s[i]} = math.exp({log_mu[i]})")
    p.emit("else:")
    for i in range(n_q):
        p.emit(f"    {log_new[i]} = {rows[i][0]} - {total}")
        p.emit(f"    {mu_s[i]} = {total_exps[i]} / {total_sum}")
    for i in range(n_q):
        _, row_exps, row_sum = rows[i]
        for j in range(n_q):
            p.emit(
                f"{weights[i][j]} = {mu_next[j]} if ({log_new[i]} == -math.inf or "
                f"{total} == -math.inf) else {row_exps[j]} / {row_sum}"
            )
    p.indent = p.indent[:-4]
    return log_new, mu_s, weights


def _positive_pivots(p: Program, hint: str, S: Matrix) -> str:
    """Emit the pivots of ``S = L D Lᵀ`` (unit lower ``L``); the condition "each pivot > 0".

    The decision of :func:`~hybridlog.estimators.kernels.cholesky` (and of
    :meth:`~hybridlog.estimators.unrolled.Program.cholesky`'s "every diagonal entry > 0"),
    which the generic loop takes in :func:`rts_correct` and :func:`semidefinite_step`, for
    less: the pivots are the squares of the Cholesky factor's diagonal (``d_j = l_jj²``,
    ``L_ij = l_ij / l_jj``), so the two agree in exact arithmetic, while this form takes no
    square root and ``n − 1`` divisions (one reciprocal a pivot, as
    :func:`_triangular_solves`) in place of ``n`` roots and ``n(n−1)/2`` divisions, which
    sat one after the other on the step's longest chain.  In floating point both are
    backward stable (each decides for a matrix within a few ``n·u·|S|`` of ``S``), so they
    can disagree only on a matrix within that rounding of singular: where the caller's
    ``S`` (the guard's ``P^- − P^s(k+1)``, the step's covariance, each shifted by its
    tolerance, :data:`GUARD_TOLERANCE` of the trace,
    :data:`~hybridlog.estimators.kernels.PSD_TOLERANCE` of the largest variance) sits on
    that tolerance's edge to about 1e-16 of its size, and the Cholesky test decides it by
    its last bits too (the straight-line code and the generic loop already differ there:
    their ``S`` agree to rounding, not bit for bit).  On the sample logs and the
    10⁶-sample benchmark every decision and result is bit-identical with either test
    (docs/smoothing.md, "Speed").  NaN fails both, and infinite entries are decided alike
    (a reciprocal of ``inf`` is 0 as the factor's quotients by it are;
    ``tests/estimators/test_smoothing_rounding.py``).  With ``W_ij = L_ij d_j``:

    .. code-block:: text

        d_j = s_jj − Σ_{k<j} W_jk L_jk,   W_ij = s_ij − Σ_{k<j} W_ik L_jk,   L_ij = W_ij / d_j
    """
    size = len(S)
    W: Matrix = [[0.0] * size for _ in range(size)]
    L: Matrix = [[0.0] * size for _ in range(size)]
    pivots: list[Entry] = []
    for j in range(size):
        pivot = p.let(
            hint + "d", [S[j][j], *[_negated(product(W[j][k], L[j][k])) for k in range(j)]]
        )
        pivots.append(pivot)
        if j == size - 1:
            break
        inverse = p.assign(hint + "r", f"1.0 / {term(pivot)}")
        for i in range(j + 1, size):
            W[i][j] = p.let(
                hint + "w", [S[i][j], *[_negated(product(W[i][k], L[j][k])) for k in range(j)]]
            )
            L[i][j] = (
                W[i][j] if W[i][j] == 0.0 else p.assign(hint + "l", f"{term(W[i][j])}*{inverse}")
            )
    return " and ".join(f"{term(d)} > 0.0" for d in pivots)


class _PredictionSource(NamedTuple):
    """The variables of one generated RTS prediction (:func:`_rts_prediction_source`)."""

    x_pred: Vector
    """``f_j(x̂)``."""
    F: Matrix
    """``∂f_j/∂x`` at ``x̂``."""
    P_pred: Matrix
    """``P^- = F P Fᵀ + Q_j``."""
    L: Matrix
    """The Cholesky factor of ``P^-`` (NaN on its diagonal where it is not positive definite)."""
    predicted: str
    """Whether ``P^-`` is positive definite."""


class _StepSource(NamedTuple):
    """The variables of one generated RTS step (:func:`_rts_step_source`)."""

    taken: str
    """Whether the step was taken (else the forward estimate stands)."""
    cause: str
    """An expression of the cause's bit (``1 << (cause − 1)``, :func:`note_fallbacks`) of a
    step not taken: the first check that refused it, in :func:`rts_cause`'s order."""
    x: Vector
    P: Matrix
    r: Vector
    """The rounding probe."""


def _rts_prediction_source(
    p: Program, model: HybridModel, j: int, x0: Vector, P0: Matrix, u: Vector, Q: Matrix
) -> _PredictionSource:
    """Emit the prediction of next mode ``j``'s RTS step (:func:`rts_predict`) from ``x0, P0``."""
    n = len(x0)
    x_pred = p.mode_values(model, j, "f", x0, u)
    F = reshape(p.mode_values(model, j, "F", x0, u), n, n)
    P_pred = p.congruence(f"pp{j}_", F, P0, add=Q)
    L = p.cholesky(f"lc{j}_", P_pred)
    predicted = p.assign("pd", " and ".join(f"{term(L[a][a])} > 0.0" for a in range(n)))
    return _PredictionSource(x_pred, F, P_pred, L, predicted)


def _rts_step_source(
    p: Program,
    model: HybridModel,
    j: int,
    x0: Vector,
    P0: Matrix,
    u: Vector,
    Q: Matrix,
    xn: Vector,
    Pn: Matrix,
    rn: Vector,
) -> _StepSource:
    """Emit the extended RTS step of next mode ``j`` (:func:`rts_step`); its variables.

    Returns the guard's condition (``P^-_j`` and ``P^-_j − P^s_j(k+1)`` positive definite,
    the rounding probe within :data:`ROUNDING_LIMIT`), the step's mean, covariance and
    rounding probe, from ``x0, P0`` (the mixed prior; expectation correction: mode ``i``'s
    filtered estimate) and the smoothed ``xn, Pn`` (rounding probe ``rn``) of the next
    sample.
    """
    prediction = _rts_prediction_source(p, model, j, x0, P0, u, Q)
    return _rts_correction_source(p, j, x0, P0, Q, xn, Pn, rn, prediction)


def _rts_correction_source(
    p: Program,
    j: int,
    x0: Vector,
    P0: Matrix,
    Q: Matrix,
    xn: Vector,
    Pn: Matrix,
    rn: Vector,
    prediction: _PredictionSource,
) -> _StepSource:
    """Emit the rest of :func:`_rts_step_source` once ``prediction`` is emitted.

    The guard, gain, mean, covariance and rounding probe of :func:`rts_correct`, and
    :func:`semidefinite_step`'s check.
    """
    n = len(x0)
    x_pred, F, P_pred, L, predicted = prediction
    FP = p.matmul(f"fp{j}_", F, P0)
    # J = P⁰Fᵀ(P^-)⁻¹ column by column of F P⁰, two triangular solves each, multiplying by
    # the reciprocals of L's diagonal (n divisions per mode instead of 2n²; equal to rounding).
    inverse = [p.assign(f"rl{j}_", f"1.0 / {term(L[a][a])}") for a in range(n)]
    J: Matrix = [[0.0] * n for _ in range(n)]
    for b in range(n):
        solved = _triangular_solves(p, f"j{j}_", L, inverse, [FP[a][b] for a in range(n)])
        for a in range(n):
            J[b][a] = solved[a]
    trace = p.let("tr", [P_pred[a][a] for a in range(n)])
    D: Matrix = [[0.0] * n for _ in range(n)]
    for a in range(n):
        for b in range(a, n):
            extra = f" + {GUARD_TOLERANCE!r}*{term(trace)}" if a == b else ""
            D[a][b] = D[b][a] = p.assign("dg", f"{term(P_pred[a][b])} - {term(Pn[a][b])}{extra}")
    guard = _positive_pivots(p, f"ld{j}_", D)  # the guard of rts_correct, without roots
    guarded = p.assign("gd", guard)
    gap = [p.difference("gp", xn[b], x_pred[b]) for b in range(n)]
    x_rts = [p.let("xr", [x0[a], *[product(J[a][b], gap[b]) for b in range(n)]]) for a in range(n)]
    JF = p.matmul(f"jF{j}_", J, F)
    IJF: Matrix = [
        [p.difference("ij", 1.0 if a == b else 0.0, JF[a][b]) for b in range(n)] for a in range(n)
    ]
    part: Matrix = [[0.0] * n for _ in range(n)]
    for a in range(n):
        for b in range(a, n):
            part[a][b] = part[b][a] = p.let("qp", [Q[a][b], Pn[a][b]])
    P_rts = p.symmetric_sum(
        f"pr{j}_", [p.congruence(f"c1{j}_", IJF, P0), p.congruence(f"c2{j}_", J, part)]
    )
    # P^(j) PSD to rounding: P^(j) + PSD_TOLERANCE·max_a P_aa·I positive definite
    # (semidefinite_step's decision, by the pivots of L D Lᵀ: _positive_pivots)
    variances = [f"abs({term(P_rts[a][a])})" for a in range(n)]
    spread = p.assign("sa", f"max({', '.join(variances)})" if n > 1 else variances[0])
    shifted: Matrix = [[0.0] * n for _ in range(n)]
    for a in range(n):
        for b in range(a, n):
            extra = f" + {PSD_TOLERANCE!r}*{term(spread)}" if a == b else ""
            shifted[a][b] = shifted[b][a] = p.assign("sh", f"{term(P_rts[a][b])}{extra}")
    semidefinite = _positive_pivots(p, f"ls{j}_", shifted)
    unit = repr(ROUNDING_UNIT)
    rounded = [
        p.assign("ri", f"{term(rn[b])} + {unit}*(abs({term(xn[b])}) + abs({term(x_pred[b])}))")
        for b in range(n)
    ]
    r_rts = [
        p.let(
            "rr",
            [p.assign("ra", f"{unit}*abs({term(x_rts[a])})")]
            + [product(J[a][b], rounded[b]) for b in range(n)],
        )
        for a in range(n)
    ]
    precise = " and ".join(
        f"{term(r_rts[a])}*{term(r_rts[a])} <= "
        f"{ROUNDING_LIMIT_SQUARED!r}*max({term(P_rts[a][a])}, 0.0)"
        for a in range(n)
    )
    semidefinite_ = p.assign("sd", semidefinite)
    precise_ = p.assign("pc", precise)
    taken = p.assign("ok", f"{predicted} and {guarded} and {precise_} and {semidefinite_}")
    bits = [1 << (code - 1) for code in (PREDICTION, GUARD, ROUNDING, COVARIANCE)]
    cause = (
        f"({bits[0]} if not {predicted} else {bits[1]} if not {guarded} else "
        f"{bits[2]} if not {precise_} else {bits[3]})"
    )
    return _StepSource(taken, cause, x_rts, P_rts, r_rts)


class _Frame(NamedTuple):
    """The variables a generated backward pass carries from one sample to the one before."""

    log_next: Vector
    """``log μ^s(k+1)``."""
    mu_next: Vector
    """``μ^s(k+1)``."""
    transitions: Matrix
    log_transitions: Matrix
    x_next: list[Vector]
    """``x̂^s_j(k+1)``."""
    P_next: list[Matrix]
    """``P^s_j(k+1)`` (symmetric names)."""
    r_next: list[Vector]
    """Their rounding probes."""
    u: Vector
    """``u(k)``."""


def _backward_frame(p: Program, model: HybridModel) -> _Frame:
    """Emit the start of a generated backward pass, up to the inputs of sample ``k``.

    The output arrays unpacked, the last sample's filtered estimates (the store's last row)
    and probabilities as the carried ``k+1``, the Markov matrix and its log, then the loop
    over ``k = N−2 … 0`` opened (the lines after it are its body).
    """
    n, n_u, n_q = model.n_states, model.n_inputs, model.n_modes
    p.emit("states = store.states")
    for name, field in (
        ("modes_out", "modes"),
        ("probabilities_out", "mode_probabilities"),
        ("means_out", "state_means"),
        ("variances_out", "state_variances"),
        ("covariances_out", "covariances"),
    ):
        p.emit(f"{name} = out.{field}")
    p.emit("n_samples = states.shape[0]")
    p.emit("store_covariances = covariances_out.shape[0] == n_samples")
    log_next = vector_names("lmn", n_q)  # log μ^s(k+1), carried
    for j in range(n_q):
        last = f"mu[n_samples - 1, {j}]"
        p.emit(f"{log_next[j]} = math.log({last}) if {last} > 0.0 else -math.inf")
    mu_carried = vector_names("mxc", n_q)  # exp(log μ^s(k+1)), carried
    for j in range(n_q):
        p.emit(f"{mu_carried[j]} = math.exp({log_next[j]})")
    log_T = matrix_names("lT", n_q, n_q)
    T = matrix_names("T", n_q, n_q)
    for i in range(n_q):
        for j in range(n_q):
            p.emit(f"{log_T[i][j]} = log_T[{i}, {j}]")
            p.emit(f"{T[i][j]} = transitions[{i}, {j}]")
    # x̂^s_j(k+1), P^s_j(k+1) (upper triangle), carried: the pass keeps them in variables
    # and writes nothing back to the store.
    x_next = [vector_names(f"xn{j}_", n) for j in range(n_q)]
    P_next = [matrix_names(f"pn{j}_", n, n, symmetric=True) for j in range(n_q)]
    packed = range(n, packed_width(n))  # the covariance's entries in a record, upper_pairs order
    r_next = [vector_names(f"rn{j}_", n) for j in range(n_q)]  # their rounding probes
    for j in range(n_q):
        p.carry(x_next[j], [f"states[n_samples - 1, {j}, {a}]" for a in range(n)])
        p.carry(upper(P_next[j]), [f"states[n_samples - 1, {j}, {e}]" for e in packed])
        p.carry(r_next[j], ["0.0"] * n)
    p.emit("for k in range(n_samples - 2, -1, -1):")
    p.indent += "    "
    u = vector_names("u", n_u)
    p.carry(u, [f"inputs[k, {c}]" for c in range(n_u)])
    return _Frame(log_next, mu_carried, T, log_T, x_next, P_next, r_next, u)


class _Helper(NamedTuple):
    """A generated function the backward pass's loop calls for one next mode."""

    name: str
    source: str
    """``@jit``-decorated definition (:data:`HELPER_IMPORT` in scope)."""


HELPER_IMPORT = "import numpy as np\n\nfrom hybridlog.jit import jit"
"""The generated module's imports: the decorator its helper functions carry, and NumPy for
the array expectation correction's stages share (:data:`SCRATCH`)."""


def _helper(name: str, parameters: Sequence[Entry], body: Program, returned: str) -> _Helper:
    """``name(parameters…)`` with ``body``'s lines, returning ``returned``.

    The backward passes' per-mode steps are written as functions of their own, each compiled
    once per next mode, where the loop writes one call per pair: numba's passes over a
    function (SSA form, reaching definitions, liveness) grow with its blocks times its
    variables, and expectation correction's loop for three modes, written out whole,
    spent about 55 of its 70 s of compiling in them.
    """
    body.emit(f"return {returned}")
    listed = ", ".join(str(x) for x in parameters)
    return _Helper(name, f"@jit\ndef {name}({listed}):\n{body.source()}\n")


class _Arguments(NamedTuple):
    """Parameter names of a step function (symmetric matrices by their upper triangle)."""

    x0: Vector
    P0: Matrix
    u: Vector
    xn: Vector
    Pn: Matrix
    rn: Vector


def _step_arguments(model: HybridModel) -> _Arguments:
    """The parameter names of ``model``'s step functions."""
    n, n_u = model.n_states, model.n_inputs
    return _Arguments(
        vector_names("x0", n),
        matrix_names("p0", n, n, symmetric=True),
        vector_names("u", n_u),
        vector_names("xn", n),
        matrix_names("pn", n, n, symmetric=True),
        vector_names("rn", n),
    )


def _standing(x: Vector, P: Matrix) -> list[Entry]:
    """A step's values where it is not taken: ``x``, ``P``'s upper triangle, a zero probe.

    The generated counterpart of :func:`_forward_stands`.
    """
    return [*x, *upper(P), *([0.0] * len(x))]


def _chosen(p: Program, step: _StepSource, x0: Vector, P0: Matrix) -> str:
    """``((x, P upper, r) of the step where taken else the forward estimate, cause bit)``."""
    bundle = p.fresh("sq")
    _select(p, step.taken, bundle, step.x + upper(step.P) + step.r, _standing(x0, P0))
    cause = p.assign("cb", f"0 if {step.taken} else {step.cause}")
    return f"{bundle}, {cause}"


def _step_function(model: HybridModel, j: int, Q: Matrix) -> _Helper:
    """``rts_step_j(x0, P0, u, xn, Pn, rn)``: next mode ``j``'s RTS step (:func:`_rts_step_source`).

    Returns ``(values, cause)``: the step's mean, covariance (upper triangle) and rounding
    probe where it was taken, else ``x0, P0`` and a zero probe; ``cause`` 0 where taken,
    else the bit of the check that refused it (:func:`note_fallbacks`).
    """
    a = _step_arguments(model)
    body = Program(indent="    ")
    step = _rts_step_source(body, model, j, a.x0, a.P0, a.u, Q, a.xn, a.Pn, a.rn)
    returned = _chosen(body, step, a.x0, a.P0)
    parameters = [*a.x0, *upper(a.P0), *a.u, *a.xn, *upper(a.Pn), *a.rn]
    return _helper(f"rts_step_{j}", parameters, body, returned)


SCRATCH = "held"
"""The generated expectation correction's array of each pair's prediction, a row per mode
``i`` of the current next mode's pairs: its stage-1 function writes it, its stage-3 function
reads it (:func:`_pair_functions`)."""


def _pair_functions(model: HybridModel, j: int, Q: Matrix) -> tuple[_Helper, int, _Helper]:
    """Stage 1 and stage 3 of expectation correction for next mode ``j``, as functions.

    ``ec_density_j(x0, P0, u, xn, held, i)`` returns ``(predicted, log N(xn; f_j(x0),
    F P0 Fᵀ + Q_j))``: whether the prediction's covariance is positive definite, and the
    density (``-inf`` where not finite); it writes the prediction's named entries (``x^-``,
    ``F``, ``P^-``, ``L``) into row ``i`` of ``held``.  ``ec_correct_j(x0, P0, xn, Pn, rn,
    held, i)`` reads them back and returns as :func:`_step_function` does.  Returns both and
    the number of entries a row holds.  Measured on the three-tank's benchmark log, against
    the loop written as one function (0.40 s): the row 0.41 s (compiled in 22 s); passing
    the entries as a tuple from one call to the other 0.51 s (12 s); predicting each pair
    again in stage 3 0.46 s (12 s).
    """
    a = _step_arguments(model)
    body = Program(indent="    ")
    prediction = _rts_prediction_source(body, model, j, a.x0, a.P0, a.u, Q)
    gap = [body.difference("gq", a.xn[b], prediction.x_pred[b]) for b in range(len(a.xn))]
    log_density = _log_density_source(body, "ld", gap, prediction.L)
    density = body.assign("dn", f"{log_density} if {log_density} > -math.inf else -math.inf")
    named = _variables(prediction)
    for column, name in enumerate(named):
        body.emit(f"{SCRATCH}[i, {column}] = {name}")
    returned = f"{prediction.predicted}, {density}"
    parameters = [*a.x0, *upper(a.P0), *a.u, *a.xn, SCRATCH, "i"]
    density_function = _helper(f"ec_density_{j}", parameters, body, returned)
    body = Program(indent="    ")
    held = [body.assign("h", f"{SCRATCH}[i, {column}]") for column in range(len(named))]
    mapping = dict(zip(named, held, strict=True))

    def rename(entries: Vector) -> Vector:
        return [mapping[e] if isinstance(e, str) else e for e in entries]

    read = _PredictionSource(
        rename(prediction.x_pred),
        [rename(row) for row in prediction.F],
        [rename(row) for row in prediction.P_pred],
        [rename(row) for row in prediction.L],
        "True",  # stage 3 corrects only the pairs whose prediction is positive definite
    )
    step = _rts_correction_source(body, j, a.x0, a.P0, Q, a.xn, a.Pn, a.rn, read)
    returned = _chosen(body, step, a.x0, a.P0)
    parameters = [*a.x0, *upper(a.P0), *a.xn, *upper(a.Pn), *a.rn, SCRATCH, "i"]
    return density_function, len(named), _helper(f"ec_correct_{j}", parameters, body, returned)


def _variables(prediction: _PredictionSource) -> list[str]:
    """The named entries of a prediction (``x^-``, ``F``, ``P^-``, ``L``), each once, in order."""
    flat = [
        *prediction.x_pred,
        *[e for row in prediction.F for e in row],
        *[e for row in prediction.P_pred for e in row],
        *[e for row in prediction.L for e in row],
    ]
    return list(dict.fromkeys(e for e in flat if isinstance(e, str)))


def _call(name: str, arguments: Sequence[Entry]) -> str:
    """Source of a call of a generated helper."""
    return f"{name}({', '.join(term(x) for x in arguments)})"


def _with_helpers(helpers: Sequence[_Helper], function: str) -> str:
    """The generated module's functions: the helpers, then the loop that calls them."""
    return "\n\n".join([HELPER_IMPORT, *(h.source for h in helpers), function])


def generate_smoother_source(model: HybridModel) -> str:
    """Straight-line source of :func:`kim_backward` for ``model`` (see ``unrolled.py``).

    Defines ``imm_smooth(inputs, transitions, log_T, mu, store, out, fallbacks)``: the same
    backward pass (``fallbacks`` counted as :func:`kim_backward` counts them)
    with the mode functions, the process noise and the small matrix products written out,
    each next mode's RTS step a function of its own (:func:`_step_function`).
    Its mode recursion (:func:`_mode_recursion_source`) takes the linear form of the same
    equations where every probability involved is in full-precision range (no ``exp``, three
    ``log`` per sample for three modes, against 33 ``exp`` and 10 ``log`` of the log-space
    form; 95 % of the three-tank benchmark's samples) and the log-space form elsewhere; the
    gain's triangular solves multiply by the reciprocals of the factor's diagonal; each next
    mode's RTS step sits under a branch that skips it below :data:`NEGLIGIBLE_WEIGHT`, as the
    generic loop does.  Equal to the generic loop up to rounding
    (``tests/estimators/test_smoothing.py``).  It reads the store's packed records
    (:class:`~hybridlog.estimators.common.ModeStore`), carries ``x̂^s_j(k+1)``, ``P^s_j(k+1)``
    and ``μ^s(k+1)`` from one step to the next in variables and writes nothing back to the
    store.
    """
    n, n_q = model.n_states, model.n_modes
    Q, _ = noise_matrices(model)
    steps = [_step_function(model, j, Q[j]) for j in range(n_q)]
    p = Program(indent="    ")
    log_next, mu_carried, T, log_T, x_next, P_next, r_next, u = _backward_frame(p, model)
    p.emit("fell = 0")
    p.emit("fell_weight = 0.0")
    log_new, mu_s, weights = _mode_recursion_source(p, T, log_T, log_next, mu_carried)
    X_s: list[Vector] = []
    P_s: list[Matrix] = []
    R_s: list[Vector] = []
    for j in range(n_q):
        x0: Vector = [p.assign("xz", f"states[k, {j}, {a}]") for a in range(n)]
        P0: Matrix = [[0.0] * n for _ in range(n)]
        for index, (a, b) in enumerate(upper_pairs(n), start=n):
            P0[a][b] = P0[b][a] = p.assign("pz", f"states[k, {j}, {index}]")
        x_sel, P_sel = vector_names(f"xs{j}", n), matrix_names(f"ps{j}", n, n, symmetric=True)
        r_sel = vector_names(f"rs{j}", n)
        chosen = [str(name) for name in [*x_sel, *upper(P_sel), *r_sel]]
        stands = _standing(x0, P0)
        bundle, cause = p.fresh("sq"), p.fresh("cb")
        arguments = [*x0, *upper(P0), *u, *x_next[j], *upper(P_next[j]), *r_next[j]]
        with p.block(f"if {mu_carried[j]} >= {NEGLIGIBLE_WEIGHT!r}:"):
            p.emit(f"{bundle}, {cause} = {_call(steps[j].name, arguments)}")
            p.emit(f"if {cause}:")
            p.emit(f"    fell |= {cause}")
            p.emit(f"    fell_weight += {mu_carried[j]}")
        with p.block("else:"):  # a negligible next mode: the forward prior stands
            _bind(p, bundle, stands)
        _unpack(p, chosen, bundle)
        X_s.append(x_sel)
        P_s.append(P_sel)
        R_s.append(r_sel)
    x_new: list[Vector] = []
    P_new: list[Matrix] = []
    r_new: list[Vector] = []
    for i in range(n_q):
        x_i, P_i = p.mixture(f"nm{i}_", weights[i], X_s, P_s)
        x_new.append(x_i)
        P_new.append(P_i)
        pairs = list(zip(weights[i], R_s, strict=True))
        r_new.append([p.let("rm", [product(w_j, r_j[a]) for w_j, r_j in pairs]) for a in range(n)])
    x, P = p.mixture("cm", mu_s, x_new, P_new)
    p.record("k", p.argmax(mu_s), mu_s, x, P)
    p.carry(log_next, log_new)
    p.carry(mu_carried, mu_s)
    for i in range(n_q):
        p.carry(x_next[i], x_new[i])
        p.carry(upper(P_next[i]), upper(P_new[i]))
        p.carry(r_next[i], r_new[i])
    _count_fallbacks(p)
    header = "def imm_smooth(inputs, transitions, log_T, mu, store, out, fallbacks):"
    return _with_helpers(steps, f"{header}\n{p.source()}\n")


def _count_fallbacks(p: Program) -> None:
    """Emit :func:`note_fallbacks` of the sample's ``fell`` into ``fallbacks``, written out."""
    p.emit("if fell:")
    p.emit("    fallbacks[0] += 1")
    for c in range(1, FALLBACK_WEIGHT):
        p.emit(f"    if fell & {1 << (c - 1)}:")
        p.emit(f"        fallbacks[{c}] += 1")
    p.emit(f"    fallbacks[{FALLBACK_WEIGHT}] += min(fell_weight, 1.0)")


def _ec_densities(
    p: Program,
    j: int,
    density: _Helper,
    x_f: list[Vector],
    P_f: list[Matrix],
    u: Vector,
    prior: list[str],
    x_next: Vector,
    log_next: Entry,
    counts: str,
    ceiling: float,
    weighed: str,
) -> tuple[list[str], list[str]]:
    """Emit stage 1 of :func:`ec_backward` for next mode ``j``: predictions and densities.

    In :func:`ec_order`, each pair whose weight can still reach :data:`NEGLIGIBLE_WEIGHT`
    (its ``prior`` plus ``ceiling`` against the largest prior plus density so far) is
    predicted by a call of ``density`` (:func:`_pair_functions`) under a branch, which
    leaves the prediction in row ``i`` of :data:`SCRATCH`.  ``weighed`` is set False
    where a prediction fails (Kim's weights).  Returns the names of whether each pair's
    prediction is positive definite (false where the pair was left out) and of the
    densities (``-inf`` where left out).
    """
    n_q = len(prior)
    floor = p.assign("fl", "-math.inf")
    p.emit(f"{weighed} = {counts}")
    predicted = [p.fresh("rd") for _ in range(n_q)]
    densities = [p.fresh("dn") for _ in range(n_q)]
    for step in range(n_q):
        i = int(ec_order(j, step))
        reachable = (
            f"{weighed} and {prior[i]} > -math.inf and "
            f"{prior[i]} + {ceiling!r} >= {floor} + {LOG_NEGLIGIBLE_WEIGHT!r} - {term(log_next)}"
        )
        with p.block(f"if {reachable}:"):
            arguments = [*x_f[i], *upper(P_f[i]), *u, *x_next, SCRATCH, str(i)]
            p.emit(f"{predicted[i]}, {densities[i]} = {_call(density.name, arguments)}")
            with p.block(f"if {predicted[i]}:"):
                p.emit(f"{floor} = max({floor}, {prior[i]} + {densities[i]})")
            with p.block("else:"):  # no density for this pair: Kim's weights for mode j
                p.emit(f"{weighed} = False")
        with p.block("else:"):
            p.emit(f"{predicted[i]} = False")
            p.emit(f"{densities[i]} = -math.inf")
    return predicted, densities


DETERMINANT_RANGE = 1e280
"""Where the product of a Cholesky factor's diagonal lies in ``(1/range, range)``, the
generated expectation correction takes one ``log`` of it, else one per entry."""


def _log_density_source(p: Program, hint: str, gap: Vector, L: Matrix) -> str:
    """``log N(gap; 0, L Lᵀ)`` as :meth:`Program.gaussian_log_density`, with one ``log``.

    ``log det`` is ``2 log Π L_aa`` where the product is well inside the range of floats
    (:data:`DETERMINANT_RANGE`), else ``2 Σ log L_aa`` (equal to rounding); NaN where ``L``
    has a NaN.
    """
    z = p.forward_solve(hint + "z", L, gap)
    quadratic = p.assign(
        hint + "q", " + ".join(f"{term(v)}*{term(v)}" for v in z if v != 0.0) or "0.0"
    )
    diagonal = [term(L[a][a]) for a in range(len(L))]
    product_ = p.assign(hint + "dp", "*".join(diagonal))
    bound = repr(DETERMINANT_RANGE)
    logs = " + ".join(f"math.log({d})" for d in diagonal)
    half_log_det = p.assign(
        hint + "hd",
        f"math.log({product_}) if {1.0 / DETERMINANT_RANGE!r} < {product_} < {bound} else ({logs})",
    )
    return p.assign(hint, f"-0.5*{quadratic} - {half_log_det} - {0.5 * len(gap)}*LOG_2PI")


def _ec_weights(
    p: Program,
    prior: list[str],
    kim_linear: list[str],
    densities: list[str] | None,
    weighed: str,
    mu_next: Entry,
    names: tuple[list[str], list[str]],
) -> None:
    """Emit stage 2 of :func:`ec_backward` for one next mode, in linear space.

    ``names``: the variables of ``p_ij(k)`` and of ``p_ij(k) >= NEGLIGIBLE_WEIGHT`` for
    ``i = 0 … n_q − 1``.  ``prior[i] = log Π_ij + log μ_i(k)``; with ``densities`` (a mode
    whose weights may take them) the corrected weights where ``weighed`` holds and some pair
    has a density, each ``exp(prior + density − the largest)`` (one ``exp`` a pair: the logs
    stay logs, as a density far in a tail has no linear form), else Kim's,
    ``μ^s_j Π_ij μ_i / Σ_i Π_ij μ_i`` with no ``exp`` (``kim_linear[i] = μ_i Π_ij``), or
    from the logs where ``Σ_i Π_ij μ_i`` is below :data:`LINEAR_FLOOR` (``weighed`` is
    updated to say which).  The loop's log-space weights to rounding, except where they are
    below some 1e-300 (smoothing's docstring).
    """
    n_q = len(prior)
    pair, carries = names
    if densities is not None:
        with_density = [
            p.assign("td", f"{prior[i]} + {densities[i]} if {weighed} else -math.inf")
            for i in range(n_q)
        ]
        for name in with_density:
            p.emit(f"if not {name} > -math.inf:")
            p.emit(f"    {name} = -math.inf")
        top = with_density[0] if n_q == 1 else p.assign("tt", f"max({', '.join(with_density)})")
        p.emit(f"{weighed} = {weighed} and {top} > -math.inf")
        parts = [p.fresh("ew") for _ in range(n_q)]
        for i in range(n_q):
            relative = (  # no exp of -inf: a pair left out (most of them) costs nothing
                f"(math.exp({with_density[i]} - {top}) if {with_density[i]} > -math.inf else 0.0)"
            )
            p.emit(f"{parts[i]} = {relative} if {weighed} else {kim_linear[i]}")
    else:
        parts = [p.assign("ew", kim_linear[i]) for i in range(n_q)]
    total = p.assign("sw", " + ".join(parts))
    with p.block(f"if {total} < {LINEAR_FLOOR!r}:"):  # Kim's products underflow: from the logs
        top_prior = p.assign("tp", f"max({', '.join(prior)})" if n_q > 1 else prior[0])
        for i in range(n_q):
            relative = f"math.exp({prior[i]} - {top_prior})"
            p.emit(f"{parts[i]} = {relative} if {top_prior} > -math.inf else 0.0")
        p.emit(f"{total} = {' + '.join(parts)}")
    for i in range(n_q):
        p.emit(f"{pair[i]} = {term(mu_next)}*{parts[i]} / {total} if {total} > 0.0 else 0.0")
        p.emit(f"{carries[i]} = {pair[i]} >= {NEGLIGIBLE_WEIGHT!r}")


def generate_ec_smoother_source(model: HybridModel) -> str:
    """Straight-line source of :func:`ec_backward` for ``model`` (see ``unrolled.py``).

    Defines ``imm_smooth_ec(inputs, transitions, log_T, mu, store, out, fallbacks)``,
    counting the samples whose steps fell back into ``fallbacks`` as :func:`ec_backward`
    does: the same backward pass (smoothing's docstring) with the mode functions, the process
    noise and the small matrix products written out, the pair steps as functions of each
    next mode, defined before it and called once per pair that needs them: stage 1's
    prediction and density and stage 3's correction of that prediction, which stage 1 leaves
    in a row of the array :data:`SCRATCH` (:func:`_pair_functions`), or for a next mode
    without a density the whole RTS step (:func:`_step_function`); and the mode recursion
    in log space.  Whether next mode ``j``
    takes the density of the smoothed state (``Q_j`` positive definite,
    :func:`positive_definite_noise`) is decided here, once: the code of a mode without it
    holds no density.  Equal to the generic loop up to
    rounding (``tests/estimators/test_smoothing_ec.py``).
    """
    n, n_q = model.n_states, model.n_modes
    Q, _ = noise_matrices(model)
    corrected = positive_definite_noise(model)
    ceilings = density_ceilings(model)
    p = Program(indent="    ")
    helpers: list[_Helper] = []
    widest = 0
    frame = _backward_frame(p, model)
    _, mu_next, T, log_T, x_next, P_next, r_next, u = frame
    # the loop over k is open: its body follows
    x_f: list[Vector] = []
    P_f: list[Matrix] = []
    mu_f: list[str] = []
    log_mu: list[str] = []
    for i in range(n_q):
        x_f.append([p.assign("xf", f"states[k, {i}, {a}]") for a in range(n)])
        P_i: Matrix = [[0.0] * n for _ in range(n)]
        for index, (a, b) in enumerate(upper_pairs(n), start=n):
            P_i[a][b] = P_i[b][a] = p.assign("pf", f"states[k, {i}, {index}]")
        P_f.append(P_i)
        mu_f.append(p.assign("muf", f"mu[k, {i}]"))
        log_mu.append(p.assign("lmu", f"math.log({mu_f[i]}) if {mu_f[i]} > 0.0 else -math.inf"))
    # pair (i, j): its result (the forward estimate where not taken) and log density
    X: list[list[Vector]] = [
        [vector_names(f"xq{i}{j}_", n) for j in range(n_q)] for i in range(n_q)
    ]
    P: list[list[Matrix]] = [
        [matrix_names(f"pq{i}{j}_", n, n, symmetric=True) for j in range(n_q)] for i in range(n_q)
    ]
    R: list[list[Vector]] = [
        [vector_names(f"rq{i}{j}_", n) for j in range(n_q)] for i in range(n_q)
    ]
    cause_bit = [[p.fresh("cz") for _ in range(n_q)] for _ in range(n_q)]  # 0: taken
    pair = [[p.fresh("pq") for _ in range(n_q)] for _ in range(n_q)]  # p_ij(k)
    carries = [[p.fresh("cq") for _ in range(n_q)] for _ in range(n_q)]  # p_ij(k) >= NEGLIGIBLE
    for j in range(n_q):
        counts = f"{mu_next[j]} >= {NEGLIGIBLE_WEIGHT!r}"  # q(k+1) = j is not negligible
        log_next = p.assign("lnx", f"math.log({mu_next[j]}) if {counts} else -math.inf")
        prior = [p.assign("tk", f"{log_T[i][j]} + {log_mu[i]}") for i in range(n_q)]
        predicted: list[str] | None = None
        densities: list[str] | None = None
        weighed = p.fresh("wd")
        if corrected[j]:
            density, width, step = _pair_functions(model, j, Q[j])
            helpers += [density, step]
            widest = max(widest, width)
            predicted, densities = _ec_densities(
                p, j, density, x_f, P_f, u, prior, x_next[j], log_next, counts,
                float(ceilings[j]), weighed,
            )  # fmt: skip
        else:
            step = _step_function(model, j, Q[j])
            helpers.append(step)
            p.emit(f"{weighed} = False")
        kim_linear = [f"{mu_f[i]}*{T[i][j]}" for i in range(n_q)]
        column = [row[j] for row in pair], [row[j] for row in carries]
        _ec_weights(p, prior, kim_linear, densities, weighed, mu_next[j], column)
        for i in range(n_q):
            # the RTS step of a pair that carries weight; elsewhere the forward estimate
            chosen = [str(name) for name in [*X[i][j], *upper(P[i][j]), *R[i][j]]]
            stands = _standing(x_f[i], P_f[i])
            bundle, cause = p.fresh("sq"), cause_bit[i][j]
            nexts = [*x_next[j], *upper(P_next[j]), *r_next[j]]
            with p.block(f"if {counts} and {carries[i][j]}:"):
                if predicted is None:  # the whole step: no stage 1 for this mode
                    arguments = [*x_f[i], *upper(P_f[i]), *u, *nexts]
                    p.emit(f"{bundle}, {cause} = {_call(step.name, arguments)}")
                else:  # the correction of stage 1's prediction
                    with p.block(f"if {predicted[i]}:"):
                        arguments = [*x_f[i], *upper(P_f[i]), *nexts, SCRATCH, str(i)]
                        p.emit(f"{bundle}, {cause} = {_call(step.name, arguments)}")
                    with p.block("else:"):  # left out by stage 1, or its prediction failed
                        _bind(p, bundle, stands)
                        p.emit(f"{cause} = {1 << (PREDICTION - 1)}")
            with p.block("else:"):
                _bind(p, bundle, stands)
                p.emit(f"{cause} = 0")
            _unpack(p, chosen, bundle)
    p.emit("fell = 0")  # the causes of the sample's fallbacks among pairs that carry weight
    p.emit("fell_weight = 0.0")
    for i in range(n_q):
        for j in range(n_q):
            p.emit(f"if {cause_bit[i][j]} and {carries[i][j]}:")
            p.emit(f"    fell |= {cause_bit[i][j]}")
            p.emit(f"    fell_weight += {pair[i][j]}")
    _count_fallbacks(p)
    # μ^s(k) and the weights v_j|i of each row's mixture
    mu_s = [p.fresh("msq") for _ in range(n_q)]
    weights = [[p.fresh("vq") for _ in range(n_q)] for _ in range(n_q)]
    row_sums = [p.assign("rw", " + ".join(pair[i])) for i in range(n_q)]
    total = p.assign("tw", " + ".join(row_sums))
    with p.block(f"if {total} > 0.0:"):
        for i in range(n_q):
            p.emit(f"{mu_s[i]} = {row_sums[i]} / {total}")
            for j in range(n_q):
                p.emit(
                    f"{weights[i][j]} = {pair[i][j]} / {row_sums[i]} if {row_sums[i]} > 0.0 "
                    f"else {mu_next[j]}"
                )
    with p.block("else:"):  # nothing links the two samples: the filtered probabilities stand
        for i in range(n_q):
            p.emit(f"{mu_s[i]} = {mu_f[i]}")
            for j in range(n_q):  # any finite estimate does for the rows
                p.emit(f"{weights[i][j]} = {mu_next[j]}")
    x_new: list[Vector] = []
    P_new: list[Matrix] = []
    r_new: list[Vector] = []
    for i in range(n_q):
        row: Vector = list(weights[i])
        x_i, P_i = p.mixture(f"nq{i}_", row, X[i], P[i])
        x_new.append(x_i)
        P_new.append(P_i)
        pairs = list(zip(row, R[i], strict=True))
        r_new.append([p.let("rm", [product(w_j, r_j[a]) for w_j, r_j in pairs]) for a in range(n)])
    probabilities: Vector = list(mu_s)
    x, P_out = p.mixture("cm", probabilities, x_new, P_new)
    p.record("k", p.argmax(probabilities), probabilities, x, P_out)
    p.carry(mu_next, probabilities)
    for i in range(n_q):
        p.carry(x_next[i], x_new[i])
        p.carry(upper(P_next[i]), upper(P_new[i]))
        p.carry(r_next[i], r_new[i])
    header = "def imm_smooth_ec(inputs, transitions, log_T, mu, store, out, fallbacks):"
    scratch = f"    {SCRATCH} = np.empty(({n_q}, {max(widest, 1)}))"
    return _with_helpers(helpers, f"{header}\n{scratch}\n{p.source()}\n")
