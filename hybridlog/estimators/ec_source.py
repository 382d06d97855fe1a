"""Straight-line code of expectation correction's backward pass per model.

:func:`generate_ec_smoother_source`, for at most :data:`MAX_EC_UNROLLED_MODES` modes under
``auto``; generated and cached as Kim's (:mod:`hybridlog.estimators.kim_source`), and equal
to the generic loop of :mod:`hybridlog.estimators.ec_loop` to rounding
(``tests/estimators/test_smoothing_ec.py``).  The algorithm is
:mod:`hybridlog.estimators.smoothing`'s docstring.
"""

from __future__ import annotations

from hybridlog.estimators.backward_frame import backward_frame, count_fallbacks
from hybridlog.estimators.branch_tuples import bind, unpack
from hybridlog.estimators.common import upper_pairs
from hybridlog.estimators.ec_loop import (
    LOG_NEGLIGIBLE_WEIGHT,
    density_ceilings,
    ec_order,
    positive_definite_noise,
)
from hybridlog.estimators.generated_helpers import (
    Helper,
    call,
    chosen,
    helper,
    standing,
    step_arguments,
    step_function,
    with_helpers,
)
from hybridlog.estimators.kim_source import LINEAR_FLOOR
from hybridlog.estimators.rts_source import (
    PredictionSource,
    rts_correction_source,
    rts_prediction_source,
)
from hybridlog.estimators.rts_steps import NEGLIGIBLE_WEIGHT, PREDICTION
from hybridlog.estimators.unrolled import (
    Entry,
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

MAX_EC_UNROLLED_MODES = 4
"""Most modes whose expectation correction ``auto`` gives straight-line code: its code grows
with the pairs, ``n_q²``.  Measured 2026-12-05 (AMD EPYC, a cold cache), the loop written as
one function: the three-tank's (3 modes) compiled in 69 s (Kim's 11 s), a linear 4-mode
model's in 68 s, a 5-mode one's in more than two minutes, and an 8-mode one's overflowed
Python's recursion limit.  With the per-mode steps as functions of their own
(:func:`step_function`, :func:`_pair_functions`): 22 s, 23 s and 52 s.  The generic
loop, compiled once for every model, runs 7.5 times longer on the three-tank."""


SCRATCH = "held"
"""The generated expectation correction's array of each pair's prediction, a row per mode
``i`` of the current next mode's pairs: its stage-1 function writes it, its stage-3 function
reads it (:func:`_pair_functions`)."""


def _pair_functions(model: HybridModel, j: int, Q: Matrix) -> tuple[Helper, int, Helper]:
    """Stage 1 and stage 3 of expectation correction for next mode ``j``, as functions.

    ``ec_density_j(x0, P0, u, xn, held, i)`` returns ``(predicted, log N(xn; f_j(x0),
    F P0 Fᵀ + Q_j))``: whether the prediction's covariance is positive definite, and the
    density (``-inf`` where not finite); it writes the prediction's named entries (``x^-``,
    ``F``, ``P^-``, ``L``) into row ``i`` of ``held``.  ``ec_correct_j(x0, P0, xn, Pn, rn,
    held, i)`` reads them back and returns as :func:`step_function` does.  Returns both and
    the number of entries a row holds.  Measured on the three-tank's benchmark log, against
    the loop written as one function (0.40 s): the row 0.41 s (compiled in 22 s); passing
    the entries as a tuple from one call to the other 0.51 s (12 s); predicting each pair
    again in stage 3 0.46 s (12 s).
    """
    a = step_arguments(model)
    body = Program(indent="    ")
    prediction = rts_prediction_source(body, model, j, a.x0, a.P0, a.u, Q)
    gap = [body.difference("gq", a.xn[b], prediction.x_pred[b]) for b in range(len(a.xn))]
    log_density = _log_density_source(body, "ld", gap, prediction.L)
    density = body.assign("dn", f"{log_density} if {log_density} > -math.inf else -math.inf")
    named = _variables(prediction)
    for column, name in enumerate(named):
        body.emit(f"{SCRATCH}[i, {column}] = {name}")
    returned = f"{prediction.predicted}, {density}"
    parameters = [*a.x0, *upper(a.P0), *a.u, *a.xn, SCRATCH, "i"]
    density_function = helper(f"ec_density_{j}", parameters, body, returned)
    body = Program(indent="    ")
    held = [body.assign("h", f"{SCRATCH}[i, {column}]") for column in range(len(named))]
    mapping = dict(zip(named, held, strict=True))

    def rename(entries: Vector) -> Vector:
        return [mapping[e] if isinstance(e, str) else e for e in entries]

    read = PredictionSource(
        rename(prediction.x_pred),
        [rename(row) for row in prediction.F],
        [rename(row) for row in prediction.P_pred],
        [rename(row) for row in prediction.L],
        "True",  # stage 3 corrects only the pairs whose prediction is positive definite
    )
    step = rts_correction_source(body, j, a.x0, a.P0, Q, a.xn, a.Pn, a.rn, read)
    returned = chosen(body, step, a.x0, a.P0)
    parameters = [*a.x0, *upper(a.P0), *a.xn, *upper(a.Pn), *a.rn, SCRATCH, "i"]
    return density_function, len(named), helper(f"ec_correct_{j}", parameters, body, returned)


def _variables(prediction: PredictionSource) -> list[str]:
    """The named entries of a prediction (``x^-``, ``F``, ``P^-``, ``L``), each once, in order."""
    flat = [
        *prediction.x_pred,
        *[e for row in prediction.F for e in row],
        *[e for row in prediction.P_pred for e in row],
        *[e for row in prediction.L for e in row],
    ]
    return list(dict.fromkeys(e for e in flat if isinstance(e, str)))


def _ec_densities(
    p: Program,
    j: int,
    density: Helper,
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
            p.emit(f"{predicted[i]}, {densities[i]} = {call(density.name, arguments)}")
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
    without a density the whole RTS step (:func:`step_function`); and the mode recursion
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
    helpers: list[Helper] = []
    widest = 0
    frame = backward_frame(p, model)
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
            step = step_function(model, j, Q[j])
            helpers.append(step)
            p.emit(f"{weighed} = False")
        kim_linear = [f"{mu_f[i]}*{T[i][j]}" for i in range(n_q)]
        column = [row[j] for row in pair], [row[j] for row in carries]
        _ec_weights(p, prior, kim_linear, densities, weighed, mu_next[j], column)
        for i in range(n_q):
            # the RTS step of a pair that carries weight; elsewhere the forward estimate
            chosen = [str(name) for name in [*X[i][j], *upper(P[i][j]), *R[i][j]]]
            stands = standing(x_f[i], P_f[i])
            bundle, cause = p.fresh("sq"), cause_bit[i][j]
            nexts = [*x_next[j], *upper(P_next[j]), *r_next[j]]
            with p.block(f"if {counts} and {carries[i][j]}:"):
                if predicted is None:  # the whole step: no stage 1 for this mode
                    arguments = [*x_f[i], *upper(P_f[i]), *u, *nexts]
                    p.emit(f"{bundle}, {cause} = {call(step.name, arguments)}")
                else:  # the correction of stage 1's prediction
                    with p.block(f"if {predicted[i]}:"):
                        arguments = [*x_f[i], *upper(P_f[i]), *nexts, SCRATCH, str(i)]
                        p.emit(f"{bundle}, {cause} = {call(step.name, arguments)}")
                    with p.block("else:"):  # left out by stage 1, or its prediction failed
                        bind(p, bundle, stands)
                        p.emit(f"{cause} = {1 << (PREDICTION - 1)}")
            with p.block("else:"):
                bind(p, bundle, stands)
                p.emit(f"{cause} = 0")
            unpack(p, chosen, bundle)
    p.emit("fell = 0")  # the causes of the sample's fallbacks among pairs that carry weight
    p.emit("fell_weight = 0.0")
    for i in range(n_q):
        for j in range(n_q):
            p.emit(f"if {cause_bit[i][j]} and {carries[i][j]}:")
            p.emit(f"    fell |= {cause_bit[i][j]}")
            p.emit(f"    fell_weight += {pair[i][j]}")
    count_fallbacks(p)
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
    return with_helpers(helpers, f"{header}\n{scratch}\n{p.source()}\n")
