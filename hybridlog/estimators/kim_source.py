"""Straight-line code of Kim's backward pass per model (:func:`generate_smoother_source`).

Generated per model as the filters' (:mod:`hybridlog.estimators.unrolled`), cached by the
model's hash, and equal to the generic loop of :mod:`hybridlog.estimators.kim_loop` to
rounding (``tests/estimators/test_smoothing.py``).  The algorithm is
:mod:`hybridlog.estimators.smoothing`'s docstring.
"""

from __future__ import annotations

from hybridlog.estimators.backward_frame import backward_frame, count_fallbacks
from hybridlog.estimators.branch_tuples import bind, unpack
from hybridlog.estimators.common import upper_pairs
from hybridlog.estimators.generated_helpers import (
    call,
    standing,
    step_function,
    with_helpers,
)
from hybridlog.estimators.rts_steps import NEGLIGIBLE_WEIGHT
from hybridlog.estimators.unrolled import (
    Matrix,
    Program,
    Vector,
    matrix_names,
    noise_matrices,
    product,
    term,
    upper,
    vector_names,
)
from hybridlog.model.hybrid_model import HybridModel

LINEAR_FLOOR = 1e-280
"""Smallest ``c̄_j = Σ_i Π_ij μ_i`` whose log the straight-line smoother takes directly (far
above the subnormal range, so every term keeps full precision); below it, the log-sum-exp."""


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


def generate_smoother_source(model: HybridModel) -> str:
    """Straight-line source of :func:`kim_backward` for ``model`` (see ``unrolled.py``).

    Defines ``imm_smooth(inputs, transitions, log_T, mu, store, out, fallbacks)``: the same
    backward pass (``fallbacks`` counted as :func:`kim_backward` counts them)
    with the mode functions, the process noise and the small matrix products written out,
    each next mode's RTS step a function of its own (:func:`step_function`).
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
    steps = [step_function(model, j, Q[j]) for j in range(n_q)]
    p = Program(indent="    ")
    log_next, mu_carried, T, log_T, x_next, P_next, r_next, u = backward_frame(p, model)
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
        stands = standing(x0, P0)
        bundle, cause = p.fresh("sq"), p.fresh("cb")
        arguments = [*x0, *upper(P0), *u, *x_next[j], *upper(P_next[j]), *r_next[j]]
        with p.block(f"if {mu_carried[j]} >= {NEGLIGIBLE_WEIGHT!r}:"):
            p.emit(f"{bundle}, {cause} = {call(steps[j].name, arguments)}")
            p.emit(f"if {cause}:")
            p.emit(f"    fell |= {cause}")
            p.emit(f"    fell_weight += {mu_carried[j]}")
        with p.block("else:"):  # a negligible next mode: the forward prior stands
            bind(p, bundle, stands)
        unpack(p, chosen, bundle)
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
    count_fallbacks(p)
    header = "def imm_smooth(inputs, transitions, log_T, mu, store, out, fallbacks):"
    return with_helpers(steps, f"{header}\n{p.source()}\n")
