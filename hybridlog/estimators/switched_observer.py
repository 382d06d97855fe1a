r"""The switched Luenberger observer of paper 001, eq. (8), over a whole log.

.. math::

    \hat x(k+1) = A_i\,\hat x(k) + B_i\,u(k) + c_i + L_i\,\bigl(y(k) - \hat y(k)\bigr),
    \qquad \hat y(k) = C_i\,\hat x(k) + D_i\,u(k) + d_i ,\qquad i = \hat q(k)       \quad (8)

with the mode ``q̂(k)`` decided from ``y(k)`` (eqs. (2)–(3)) and gains ``L_i`` from the LMI
(15) (:mod:`hybridlog.estimators.lmi`).  The affine terms ``c_i``, ``d_i`` are zero for the
paper's model (1) and kept for generality.  ``x̂(k)`` uses ``y(0) … y(k−1)`` only.

An output the log did not measure at ``t_k`` (NaN in the outputs given:
``AlignedSignals.measured_outputs()``, a sample bridged across a gap or a slower output of a
multi-rate log) has the innovation 0 in eq. (8): its column of ``L_i`` corrects nothing at
that step, and with no output measured the step is the open-loop model step
``x̂(k+1) = A_i x̂(k) + B_i u(k) + c_i``.  That is the choice: eq. (8) corrects by a
measurement, and the value the alignment took from the samples around (one used twice, or
interpolated) is none; the error then evolves by ``A_i`` alone for that step, which the
poly-quadratic Lyapunov function of LMI (15) does not bound, so the decay it certifies
holds over the measured steps only.

Output prediction: the one-step-ahead prediction of ``y(k)`` must be made before ``y(k)``
is used, but ``q̂(k)`` is decided *from* ``y(k)``; so ``ŷ(k) = C_j x̂(k) + D_j u(k) + d_j``
with ``j = q̂(k−1)``, the mode that produced ``x̂(k)``.  When all ``C_i`` are equal (the
double cart) this is the paper's ``ŷ(k) = C_i x̂(k)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from hybridlog.errors import ModelError
from hybridlog.jit import jit
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.signals import FloatArray, IntArray

if TYPE_CHECKING:
    import sympy

__all__ = ["LinearModes", "linear_modes", "run_observer"]


@dataclass(frozen=True)
class LinearModes:
    """Numeric matrices of a linear (affine) switched model, stacked over the modes.

    ``x(k+1) = A_i x(k) + B_i u(k) + c_i`` and ``y(k) = C_i x(k) + D_i u(k) + d_i``.

    Attributes
    ----------
    A, B, C, D:
        Shapes ``(s, n, n)``, ``(s, n, m)``, ``(s, p, n)``, ``(s, p, m)``.
    state_offsets, output_offsets:
        ``c_i`` ``(s, n)`` and ``d_i`` ``(s, p)``.
    """

    A: FloatArray
    B: FloatArray
    C: FloatArray
    D: FloatArray
    state_offsets: FloatArray
    output_offsets: FloatArray


def _constant_matrix(
    matrix: sympy.Matrix, symbols: list[sympy.Symbol], what: str, model: HybridModel, mode: str
) -> FloatArray:
    depends = sorted(str(s) for s in matrix.free_symbols & set(symbols))
    if depends:
        raise ModelError(
            f"{model.name}: mode '{mode}' is not linear ({what} depends on "
            f"{', '.join(depends)}); the chiu and kmeans estimators need a linear switched model"
        )
    return np.array(matrix.evalf(), dtype=np.float64).reshape(matrix.shape)


def linear_modes(model: HybridModel) -> LinearModes:
    """``A_i, B_i, C_i, D_i`` (and affine terms) from the model's mode equations.

    The loader's :attr:`~hybridlog.model.hybrid_model.Mode.linear_form` when every mode has
    one (no sympy: a model from the loaded-model cache keeps its expressions unbuilt);
    otherwise the Jacobians of the expressions, naming the first mode that is not affine.

    Raises
    ------
    ModelError
        When a mode's ``f`` or ``h`` is not affine in the states and inputs (names the mode).
    """
    forms = [mode.linear_form for mode in model.modes]
    if forms and not model.is_continuous and all(form is not None for form in forms):
        return LinearModes(
            *(
                np.ascontiguousarray(np.stack([getattr(form, name) for form in forms]))
                for name in ("A", "B", "C", "D", "state_offset", "output_offset")
            )
        )
    import sympy

    xs, us = model.symbols()
    symbols = [*xs, *us]
    zero = {s: 0 for s in symbols}
    stacks: dict[str, list[FloatArray]] = {k: [] for k in ("A", "B", "C", "D", "c", "d")}
    for mode in model.modes:
        f = sympy.Matrix(list(mode.f))
        h = sympy.Matrix(list(mode.h))
        for name, expressions, wrt in (("A", f, xs), ("B", f, us), ("C", h, xs), ("D", h, us)):
            if wrt:
                jacobian = expressions.jacobian(wrt)
                label = f"{'f' if name in 'AB' else 'h'}'s Jacobian {name}"
                stacks[name].append(_constant_matrix(jacobian, symbols, label, model, mode.id))
            else:
                stacks[name].append(np.zeros((expressions.shape[0], 0)))
        stacks["c"].append(_constant_matrix(f.subs(zero), symbols, "f", model, mode.id).ravel())
        stacks["d"].append(_constant_matrix(h.subs(zero), symbols, "h", model, mode.id).ravel())
    return LinearModes(
        A=np.ascontiguousarray(np.stack(stacks["A"])),
        B=np.ascontiguousarray(np.stack(stacks["B"])),
        C=np.ascontiguousarray(np.stack(stacks["C"])),
        D=np.ascontiguousarray(np.stack(stacks["D"])),
        state_offsets=np.ascontiguousarray(np.stack(stacks["c"])),
        output_offsets=np.ascontiguousarray(np.stack(stacks["d"])),
    )


def _observer_steps(
    A: FloatArray,
    B: FloatArray,
    C: FloatArray,
    D: FloatArray,
    c: FloatArray,
    d: FloatArray,
    L: FloatArray,
    inputs: FloatArray,
    outputs: FloatArray,
    modes: IntArray,
    x0: FloatArray,
    means_out: FloatArray,
    predictions_out: FloatArray,
) -> None:  # compiled as run_observer
    n_samples = outputs.shape[0]
    n = x0.shape[0]
    p = outputs.shape[1]
    m = inputs.shape[1]
    x = x0.copy()
    x_next = np.empty(n)
    innovation = np.empty(p)
    means_out[0, :] = x
    for b in range(p):
        predictions_out[0, b] = np.nan
    for k in range(n_samples - 1):
        q = modes[k]
        # eq. (8): innovation y(k) - ŷ(k) in the decided mode, then the state update; an
        # output not measured at t_k (NaN) corrects nothing: its innovation is 0.
        for b in range(p):
            acc = d[q, b]
            for a in range(n):
                acc += C[q, b, a] * x[a]
            for j in range(m):
                acc += D[q, b, j] * inputs[k, j]
            measured = outputs[k, b]
            innovation[b] = 0.0 if np.isnan(measured) else measured - acc
        for a in range(n):
            acc = c[q, a]
            for e in range(n):
                acc += A[q, a, e] * x[e]
            for j in range(m):
                acc += B[q, a, j] * inputs[k, j]
            for b in range(p):
                acc += L[q, a, b] * innovation[b]
            x_next[a] = acc
        x[:] = x_next
        means_out[k + 1, :] = x
        # one-step-ahead prediction of y(k+1), made before y(k+1) is used
        for b in range(p):
            acc = d[q, b]
            for a in range(n):
                acc += C[q, b, a] * x[a]
            for j in range(m):
                acc += D[q, b, j] * inputs[k + 1, j]
            predictions_out[k + 1, b] = acc


_observer_loop = jit(_observer_steps)


def run_observer(
    linear: LinearModes,
    gains: FloatArray,
    inputs: FloatArray,
    outputs: FloatArray,
    modes: IntArray,
    initial_state: FloatArray,
    *,
    jit: bool = True,
) -> tuple[FloatArray, FloatArray]:
    """Run eq. (8) over a log with a given mode sequence.

    Parameters
    ----------
    linear:
        The model's matrices.
    gains:
        ``L_i``, shape ``(s, n, p)``.
    inputs, outputs:
        ``u`` ``(N, m)`` and ``y`` ``(N, p)``, NaN where the log did not measure an output
        (``AlignedSignals.measured_outputs()``): no correction by it at that step.
    modes:
        ``q̂(k)`` as mode indices, shape ``(N,)``.
    initial_state:
        ``x̂(0)``.
    jit:
        Compiled loop (default) or the same code in plain Python.

    Returns
    -------
    tuple
        ``(x̂, ŷ)`` of shapes ``(N, n)`` and ``(N, p)``; ``ŷ[0]`` is NaN.
    """
    n_samples = outputs.shape[0]
    means = np.zeros((n_samples, initial_state.shape[0]))
    predictions = np.full((n_samples, outputs.shape[1]), np.nan)
    loop = _observer_loop if jit else _observer_steps
    loop(
        linear.A,
        linear.B,
        linear.C,
        linear.D,
        linear.state_offsets,
        linear.output_offsets,
        np.ascontiguousarray(gains, dtype=np.float64),
        np.ascontiguousarray(inputs, dtype=np.float64),
        np.ascontiguousarray(outputs, dtype=np.float64),
        np.ascontiguousarray(modes, dtype=np.int64),
        np.ascontiguousarray(initial_state, dtype=np.float64),
        means,
        predictions,
    )
    return means, predictions
