"""What both generated backward passes emit alike: their start and their fallback count.

:func:`backward_frame` (the arrays, the carried variables of sample ``k+1`` and the loop
over ``k``), :func:`count_fallbacks` (a sample's refused steps into ``fallbacks``).
"""

from __future__ import annotations

from typing import NamedTuple

from hybridlog.estimators.common import packed_width
from hybridlog.estimators.rts_steps import FALLBACK_WEIGHT
from hybridlog.estimators.unrolled import Matrix, Program, Vector, matrix_names, upper, vector_names
from hybridlog.model.hybrid_model import HybridModel


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


def backward_frame(p: Program, model: HybridModel) -> _Frame:
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


def count_fallbacks(p: Program) -> None:
    """Emit :func:`note_fallbacks` of the sample's ``fell`` into ``fallbacks``, written out."""
    p.emit("if fell:")
    p.emit("    fallbacks[0] += 1")
    for c in range(1, FALLBACK_WEIGHT):
        p.emit(f"    if fell & {1 << (c - 1)}:")
        p.emit(f"        fallbacks[{c}] += 1")
    p.emit(f"    fallbacks[{FALLBACK_WEIGHT}] += min(fell_weight, 1.0)")
