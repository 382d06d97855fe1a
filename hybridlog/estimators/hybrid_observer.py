r"""Paper 004's switching observer for nonlinear hybrid automata with jumps, over a whole log.

Germani, Manes, Pepe, *State observation for nonlinear hybrid automata*
(``papers/004_33eb1488165da6c7.txt``).  The switching signal σ(t) is known (the log's true
mode column, ``--map truth.mode=PATH``); per mode the drift-observability map (eq. (7))

.. math::

    \Phi(\sigma, x) = [h, L_f h, \dots, L_f^{n-1} h]^T, \qquad
    Q(\sigma, x) = \partial\Phi(\sigma, x)/\partial x \quad (21)

is taken with sympy (:func:`~hybridlog.model.derivatives.lie_derivative`; ``f`` is the
mode's ``dx`` with the inputs at zero, the drift), and the observer (20)

.. math::

    \dot{\hat x} = f(\sigma, \hat x) + g(\sigma, \hat x) u
        + Q(\sigma, \hat x)^{-1} K \bigl(y - h(\sigma, \hat x)\bigr), \quad t \ne t_j,
    \qquad \hat x(t_j) = R(\sigma(t_j^-), \sigma(t_j), \hat x(t_j^-))

is integrated with the model's fixed step and method (``integration``), the mode's whole
``dx`` standing for ``f + g u``.  ``K = K(Λ)`` places the eigenvalues of ``A_b − K C_b``
(Brunovsky form: ``A_b`` the shift, ``C_b = [1, 0, …, 0]``) at the chosen real values Λ
(Section 5): ``A_b − K C_b`` is a companion matrix whose characteristic polynomial is
``s^n + K_1 s^{n−1} + … + K_n``, so ``K`` is the coefficients of ``∏(s − λ_j)``.

Sampling, as for every estimator and as ``hybridlog simulate`` writes a log (row ``k``:
``u(k)`` applied from ``t_k``, ``y(k)`` measured at ``t_k``, the mode of row ``k + 1``
governing the interval into it): on ``[t_k, t_{k+1})`` σ = σ(k+1) and ``u`` and ``y`` are
held at their sample values (zero-order hold), or, with ``output_hold = "first"`` (the
default), ``y`` is extrapolated from its last two samples,
``y(k) + (t − t_k)(y(k) − y(k−1))/(t_k − t_{k−1})`` (a causal first-order hold; on the
first interval of a mode after its first sample, where ``y`` may have jumped, the slope is
the estimate's own ``ẏ = ∂h/∂x·dx(σ, x̂(t_k), u(k))``).  Either way ``x̂(t_k)`` uses
``y(0) … y(k−1)`` only.  A switch ``σ(k+1) ≠ σ(k)`` happens at ``t_k^+``, where ``R`` is
applied, ``x̂ ← R(σ(k), σ(k+1), x̂(t_k))``; the interval after it runs without output
injection (``y(k)`` measured the state before the jump, and no ``y`` of the new mode is
measured before ``t_{k+1}``).  Applying ``R`` at ``t_{k+1}`` instead, after an interval
in the old mode, left a log of ``simulate`` (which switches at ``t_k^+``) with an error
of 0.2 (relative) after every switch of the engine with clutch, whatever the error
before it: the high gain turned the one interval's small error in ``ω`` into 2–4 N m of
``T``.

A sample the log did not measure (``AlignedSignals.unmeasured_outputs``: a gap bridged, or
a log whose ``y`` is slower than the model's ``dt``) is read as NaN
(:meth:`~hybridlog.signals.AlignedSignals.measured_outputs`), never as the value the
alignment put there.  Over ``[t_k, t_{k+1})`` with ``y(k)`` not measured the output
injection is off: ``dx̂/dt = f(σ, x̂) + g(σ, x̂)u``, observer (20) with ``K = 0`` (the
model integrated open loop).  In the paper's coordinates ``z = Φ(σ, x)`` (Lemmas 5–6,
eqs. (24), (27)) the error ``η = z − ẑ`` then obeys ``η̇ = A_b η + B_b(P̃(z) − P̃(ẑ))``, so
by H₂ it grows at most by ``exp((1 + γ_P̃)(t_{k+1} − t_k))`` over the interval: a bounded
factor, as the jumps' ``μ₁`` of (31)–(32), which the decay (30) of the measured intervals
must outweigh as (35) weighs the jumps against ``T_min``.  Injecting a value the log did not
give instead (a held or extrapolated ``y``) would drive ``η̇ = (A_b − K C_b)η + …`` by
``K`` times that value's error, with the large ``K`` Lemma 4 calls for and no bound in
the paper.  With ``output_hold = "first"`` the slope of a measured ``y(k)`` is taken from
the last sample measured before it in the same mode, ``(y(k) − y(j))/(t_k − t_j)``, two
measurements; with none since the mode began, from the estimate's own ``ẏ`` as above.

The output prediction of row ``k`` is
``h(σ(k), x̂(t_k))``, made before ``y(k)`` is used; row 0 is the prior (the model's initial
state).  Mode probabilities are the one-hot σ; there is no covariance (variances NaN).

The condition number κ₁(Q) (1-norm) is computed at every sample and at the start of every
integration step whose correction uses ``Q⁻¹``, a sample's value the largest over the
interval into it and the sample itself; where it exceeds the ``condition_limit`` option a
note says when and how badly (the correction ``Q⁻¹K(y − h)`` is then inaccurate, and
infinite where Q is singular).  At the samples alone, an estimate that crossed a singular
point of ``Q`` between two of them (``h = x1**3`` as ``x̂1`` crosses 0) was thrown far off
by the correction there, ran away to ``1e40``, and the warning named another time.  The
whole loop -- every integration step, the jumps, the conditioning -- is one compiled
function generated for the model (:func:`observer_source`), cached on disk like the model's
functions.
"""

from __future__ import annotations

import time
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from hybridlog.errors import DivergenceError, LogError, ModelError, OptionError
from hybridlog.estimators.hybrid_observer_options import (
    SwitchingObserverOptions,
    companion_gain,
    gain_flaw,
    step_flaw_of,
)
from hybridlog.estimators.result import EstimationResult
from hybridlog.estimators.vouch import MAX_SHOWN
from hybridlog.signals import FloatArray
from hybridlog.times import format_time

if TYPE_CHECKING:
    import sympy

    from hybridlog.model.escape import Escape, Watch
    from hybridlog.model.hybrid_model import HybridModel
    from hybridlog.signals import AlignedSignals

__all__ = [
    "brunovsky_gain",
    "drift_observability",
    "observer_module",
    "observer_source",
    "run_switching_observer",
]

NAME = "switching-observer"
MODES_GIVEN = (
    "switching-observer takes its modes from the log's switching signal, the log's true mode "
    "(paper 004: sigma is known): they are given, not estimated, so no mode metric is scored"
)
"""``EstimationResult.modes_given`` of a run on a log with a switching signal."""

ONE_MODE_GIVEN = (
    "switching-observer runs a one-mode model, whose sigma is that mode at every sample (the "
    "log has no switching signal, and needs none): the modes are given, not estimated, so no "
    "mode metric is scored"
)
"""``EstimationResult.modes_given`` of a one-mode model's run on a log without the signal."""


def brunovsky_gain(eigenvalues: tuple[float, ...]) -> FloatArray:
    """``K(Λ)`` with ``eig(A_b − K C_b) = Λ`` (paper 004, Section 5).

    ``A_b − K C_b`` is the companion matrix of ``s^n + K_1 s^{n−1} + … + K_n``.

    Raises
    ------
    OptionError
        A coefficient ``K_j`` is not a positive finite float64 (:func:`gain_flaw`).

    Examples
    --------
    >>> brunovsky_gain((-1.0, -2.0)).tolist()
    [3.0, 2.0]
    """
    flaw = gain_flaw(eigenvalues)
    if flaw is not None:
        raise OptionError(f"switching-observer option 'eigenvalues': {flaw}")
    return companion_gain(eigenvalues)


def drift_observability(
    model: HybridModel, mode_index: int
) -> tuple[list[sympy.Expr], list[list[sympy.Expr]]]:
    r"""``Φ = [h, L_f h, …, L_f^{n−1} h]`` (eq. (7)) and ``Q = ∂Φ/∂x`` (eq. (21)) of one mode.

    ``f`` is the drift: the mode's ``dx`` with every input at zero.
    """
    import sympy

    from hybridlog.model.derivatives import jacobian, lie_derivative

    xs, us = model.symbols()
    mode = model.modes[mode_index]
    drift = [sympy.sympify(e).xreplace({u: sympy.S.Zero for u in us}) for e in mode.dx]
    (h,) = mode.h
    phi = [lie_derivative([h], drift, xs, order=k)[0] for k in range(model.n_states)]
    return phi, jacobian(phi, xs)


_LOOP = '''

def _pivot(W, c, n):
    """Partial pivoting at column c: the row of its largest |W[r, c]|, r >= c, swapped into
    row c; its index (c: none swapped), or -1 when the column is 0 there (singular)."""
    p = c
    for r in range(c + 1, n):
        if abs(W[r, c]) > abs(W[p, c]):
            p = r
    if W[p, c] == 0.0:
        return -1
    if p != c:
        for j in range(n):
            W[c, j], W[p, j] = W[p, j], W[c, j]
    return p


def _solve(M, b, n, W, out):
    """``out = M⁻¹ b``, Gaussian elimination with partial pivoting (W: workspace); 0: singular."""
    for i in range(n):
        out[i] = b[i]
        for j in range(n):
            W[i, j] = M[i, j]
    for c in range(n):
        p = _pivot(W, c, n)
        if p < 0:
            for i in range(n):
                out[i] = math.nan
            return 0
        out[c], out[p] = out[p], out[c]
        for r in range(c + 1, n):
            m = W[r, c] / W[c, c]
            for j in range(c, n):
                W[r, j] -= m * W[c, j]
            out[r] -= m * out[c]
    for c in range(n - 1, -1, -1):
        s = out[c]
        for j in range(c + 1, n):
            s -= W[c, j] * out[j]
        out[c] = s / W[c, c]
    return 1


def _condition(M, n, W, e, col):
    """The 1-norm condition number of M (inf when singular): one factorisation, n solves.

    As :func:`_solve` eliminates (partial pivoting), its multipliers kept below W's
    diagonal and the rows' order in ``e``; each column of M^-1 then costs two triangular
    solves, not an elimination of its own (the condition is taken at every integration step).
    """
    norm = 0.0
    for j in range(n):
        s = 0.0
        for i in range(n):
            s += abs(M[i, j])
            W[i, j] = M[i, j]
        norm = max(norm, s)
    for i in range(n):
        e[i] = i
    for c in range(n):
        p = _pivot(W, c, n)
        if p < 0:
            return math.inf
        e[c], e[p] = e[p], e[c]
        for r in range(c + 1, n):
            m = W[r, c] / W[c, c]
            W[r, c] = m
            for j in range(c + 1, n):
                W[r, j] -= m * W[c, j]
    inverse = 0.0
    for j in range(n):
        for i in range(n):  # the unit vector j in the eliminated rows' order, through L
            col[i] = 1.0 if e[i] == j else 0.0
            for a in range(i):
                col[i] -= W[i, a] * col[a]
        s = 0.0
        for i in range(n - 1, -1, -1):  # through U
            t = col[i]
            for a in range(i + 1, n):
                t -= W[i, a] * col[a]
            col[i] = t / W[i, i]
            s += abs(col[i])
        inverse = max(inverse, s)
    return norm * inverse


def _rhs(q, x, u, y, inject, gain, n, out, hv, Qm, W, r, v):
    """Observer (20): out = dx(q, x, u) + Q(q, x)^-1 K (y - h(q, x, u)); dx alone unless inject."""
    dx(q, x, u, out)
    if not inject:
        return
    h(q, x, u, hv)
    Q(q, x, u, Qm)
    e = y - hv[0]
    for i in range(n):
        r[i] = gain[i] * e
    _solve(Qm, r, n, W, v)
    for i in range(n):
        out[i] += v[i]


def observe(time, modes, inputs, outputs, x0, gain, substeps, rk4, first_order, start,
            out_x, out_prediction, out_condition, out_jumped):
    """The run of observer (20) with jumps from row start (x0 there: 0, the whole log)."""
    n = x0.shape[0]
    count = time.shape[0]
    x = x0.copy()
    xt = numpy.empty(n)
    k1 = numpy.empty(n)
    k2 = numpy.empty(n)
    k3 = numpy.empty(n)
    k4 = numpy.empty(n)
    jumped = numpy.empty(n)
    hv = numpy.empty(1)
    Qm = numpy.empty((n, n))
    W = numpy.empty((n, n))
    r = numpy.empty(n)
    v = numpy.empty(n)
    for i in range(n):
        out_x[start, i] = x[i]
    out_prediction[start] = math.nan
    Q(modes[start], x, inputs[start], Qm)
    out_condition[start] = _condition(Qm, n, W, r, v)
    for k in range(start, count - 1):
        q = modes[k + 1]  # the mode of row k + 1 governs the interval into it
        u = inputs[k]
        y = outputs[k, 0]
        out_jumped[k + 1] = 0
        if q != modes[k]:  # the switch at t_k^+: R first, then the interval open loop
            out_jumped[k + 1] = reset(modes[k], q, x, jumped)
            for i in range(n):
                x[i] = jumped[i]
        # y(k) not measured, or measured before the jump: no output injection on the interval
        inject = q == modes[k] and not math.isnan(y)
        step = (time[k + 1] - time[k]) / substeps
        slope = 0.0
        if inject and first_order:
            before = k - 1  # the last sample measured before k, within this mode
            while before >= 0 and modes[before] == q and math.isnan(outputs[before, 0]):
                before -= 1
            if before >= 0 and modes[before] == q:
                slope = (y - outputs[before, 0]) / (time[k] - time[before])
            else:  # none since the mode began: dy/dt = dh/dx dx of the estimate
                dx(q, x, u, k1)
                Q(q, x, u, Qm)  # its first row is dh/dx (Phi_1 = h)
                for i in range(n):
                    slope += Qm[0, i] * k1[i]
        worst = 0.0  # kappa_1 of the Q each integration step's correction starts from
        for s in range(substeps):
            tau = s * step
            _rhs(q, x, u, y + slope * tau, inject, gain, n, k1, hv, Qm, W, r, v)
            if inject:  # Qm is Q at x: between samples the estimate may cross where Q is singular
                kappa = _condition(Qm, n, W, r, v)
                if not kappa <= worst:
                    worst = kappa
            if rk4:
                y_half = y + slope * (tau + 0.5 * step)
                for i in range(n):
                    xt[i] = x[i] + 0.5 * step * k1[i]
                _rhs(q, xt, u, y_half, inject, gain, n, k2, hv, Qm, W, r, v)
                for i in range(n):
                    xt[i] = x[i] + 0.5 * step * k2[i]
                _rhs(q, xt, u, y_half, inject, gain, n, k3, hv, Qm, W, r, v)
                for i in range(n):
                    xt[i] = x[i] + step * k3[i]
                _rhs(q, xt, u, y + slope * (tau + step), inject, gain, n, k4, hv, Qm, W, r, v)
                for i in range(n):
                    x[i] += step / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            else:
                for i in range(n):
                    x[i] += step * k1[i]
        for i in range(n):
            out_x[k + 1, i] = x[i]
        h(q, x, inputs[k + 1], hv)
        out_prediction[k + 1] = hv[0]
        Q(q, x, inputs[k + 1], Qm)
        kappa = _condition(Qm, n, W, r, v)
        out_condition[k + 1] = kappa if not kappa <= worst else worst  # NaN stays NaN
    return None


dx = _jit(dx)
h = _jit(h)
Q = _jit(Q)
reset = _jit(reset)
_pivot = _jit(_pivot)
_solve = _jit(_solve)
_condition = _jit(_condition)
_rhs = _jit(_rhs)
'''


def observer_source(model: HybridModel) -> str:
    """Python source of the observer's module: ``dx``, ``h``, ``Q``, ``reset`` and ``observe``.

    The mode functions are printed by :mod:`hybridlog.model.codegen` (the one printer);
    ``observe`` integrates observer (20) over the whole log (RK4 or Euler, the jumps, κ₁(Q)).
    """
    from hybridlog.model.codegen import jump_function, switched_function

    n = model.n_states
    per_mode = [drift_observability(model, i) for i in range(model.n_modes)]
    lines = [
        f'"""Generated by hybridlog for model {model.name!r}: switching observer (paper 004)."""',
        "",
        "import math",
        "",
        "import numpy",
        "",
        "from hybridlog.jit import jit as _jit",
    ]
    lines += switched_function(
        model, "dx", [list(m.dx) for m in model.modes], [f"out[{i}]" for i in range(n)]
    )
    lines += switched_function(model, "h", [list(m.h) for m in model.modes], ["out[0]"])
    lines += switched_function(
        model,
        "Q",
        [[entry for row in q for entry in row] for _, q in per_mode],
        [f"out[{i}, {j}]" for i in range(n) for j in range(n)],
    )
    lines += jump_function(model)
    return "\n".join(lines) + _LOOP


KIND = "switchobs"
"""File-name prefix and key part of the generated module in the compiled-code cache."""
GENERATORS = ("hybridlog.estimators.hybrid_observer",)
"""Modules whose source shapes the generated module (part of its cache key)."""


def observer_module(model: HybridModel) -> ModuleType:
    """The generated module of ``model`` (:func:`observer_source`), from the cache when there.

    Its ``dx``, ``h``, ``Q`` and ``reset`` are numba functions callable from Python too (the
    benchmark integrates the same right-hand side with SciPy).
    """
    from hybridlog.model.compiled import load_generated

    return load_generated(model, KIND, lambda: observer_source(model), GENERATORS)


def _check_model(model: HybridModel) -> None:
    origin = model.origin or model.name
    if model.n_outputs != 1:
        raise ModelError(
            f"{origin}: estimator '{NAME}' needs a single-output model (paper 004, eq. (1): "
            f"h maps to R); the model has {model.n_outputs} outputs "
            f"({', '.join(model.outputs)})"
        )
    model.check_supported(f"estimator '{NAME}'", continuous=True, jumps=True)


def _check_step(model: HybridModel, eigenvalues: tuple[float, ...]) -> None:
    """Refuse eigenvalues Λ the model's integration step cannot follow (:func:`step_flaw_of`)."""
    flaw = step_flaw_of(model, eigenvalues)
    if flaw is not None:
        raise OptionError(f"switching-observer option 'eigenvalues': {flaw}")


def _last_interval(
    model: HybridModel,
    signals: AlignedSignals,
    modes: Any,
    states: FloatArray,
    predictions: FloatArray,
    first: int,
) -> str:
    """What drove the interval into the first non-finite sample: ``y`` against ``ŷ`` there.

    ``x̂(t_k)`` comes from ``x̂(t_{k-1})`` corrected by ``y(k-1) − h(x̂(t_{k-1}))``: an
    outlier of the log (``1e6`` where ``h`` predicts 140), not the model, is then the cause,
    which the numbers show.  The prior (sample 0) predicts nothing: no ``ŷ`` for it.  Where
    the log did not measure ``y(k-1)`` the interval had no correction (module doc), and the
    value the alignment put there is not shown as a measurement; nor had the interval a
    switch opened (``R`` applied at ``t_{k-1}^+``, module doc).
    """
    if first < 1:
        return ""
    before = first - 1
    values = [
        f"{name} = {value:.6g}"
        for name, value in zip(model.states, states[before].tolist(), strict=True)
    ]
    shown = ", ".join(values[:MAX_SHOWN]) + (", …" if len(values) > MAX_SHOWN else "")
    if modes[before] != modes[first]:
        jump = model.jump_between(int(modes[before]), int(modes[first]))
        mapped = "" if jump is None else f", then {jump.key}"
        return (
            f"; the interval before ran without correction (the switch to mode "
            f"'{model.mode_ids[int(modes[first])]}' just after t = "
            f"{format_time(signals.time[before])} s) from the estimate {shown}{mapped}"
        )
    if signals.unmeasured_outputs is not None and signals.unmeasured_outputs[before, 0]:
        return (
            f"; the interval before ran without correction ({model.outputs[0]} not measured "
            f"at t = {format_time(signals.time[before])} s) from the estimate {shown}"
        )
    predicted = float(predictions[before])
    against = f" against {predicted:.6g} predicted" if np.isfinite(predicted) else ""
    return (
        f"; the interval before corrected with {model.outputs[0]} = "
        f"{float(signals.outputs[before, 0]):.6g} measured{against} at the estimate {shown}"
    )


def _jump_before(
    model: HybridModel, signals: AlignedSignals, arguments: tuple[Any, ...], first: int
) -> str:
    """The jump map that opened the mode diverging at ``first``, when it made the fit worse.

    A map the log does not bear out (``omega = "-omega"`` where the engine speed keeps its
    sign) throws the estimate far from the measurement; the correction ``Q⁻¹K(y − h)`` then
    diverges a few samples later in a mode whose expressions are all finite, and the
    refusal named the gain alone.  Named when a map was applied at the switch that began
    the mode running at ``first`` (eqs. (45)-(46) of paper 004 are such maps; at ``t_k^+``
    after the mode's first row's predecessor ``k``, module doc) and the output error at that
    first row is larger than at ``k``.
    """
    modes, outputs = arguments[1], arguments[3]
    predictions, jumped = arguments[11], arguments[13]
    start = first
    while start > 0 and modes[start - 1] == modes[first]:
        start -= 1
    if start < 2 or not jumped[start]:
        return ""
    jump = model.jump_between(int(modes[start - 1]), int(modes[start]))
    after, before = float(outputs[start, 0]), float(outputs[start - 1, 0])
    error_after = abs(after - float(predictions[start]))
    error_before = abs(before - float(predictions[start - 1]))
    if jump is None or not error_after > error_before:  # NaN (not measured): no claim
        return ""
    samples = first - start + 1
    return (
        f"; the jump map {jump.key}, applied just after t = "
        f"{format_time(signals.time[start - 1])} s, {samples} sample"
        f"{'s' if samples != 1 else ''} before, left the estimate predicting "
        f"{model.outputs[0]} = {float(predictions[start]):.6g} against {after:.6g} measured "
        f"at t = {format_time(signals.time[start])} s"
    )


def _singular_q(
    model: HybridModel,
    signals: AlignedSignals,
    modes: Any,
    states: FloatArray,
    condition: FloatArray,
    first: int,
) -> str:
    """Why the estimate became non-finite, when the cause is ``Q(σ, x̂)`` singular before it.

    ``κ₁(Q)`` of every sample is computed in the loop; infinite at sample ``first − 1``
    means the correction ``Q⁻¹K(y − h)`` of the interval into ``first`` was not defined.
    The symbolic ``Q`` of that mode then tells a singular point of the trajectory from a
    mode that is not drift-observable at all (``det Q ≡ 0``, eq. (21)), naming the states
    that enter none of ``Φ``.  The refusal listed "Q singular, a jump map or the gain ...
    too large" for a mode whose ``Φ = [x1, −x1]`` cannot see ``x2``.  An interval whose
    ``y`` the log did not measure had no correction, so no ``Q⁻¹``: not the cause there.
    """
    if first < 1 or np.isfinite(condition[first - 1]):
        return ""
    if signals.unmeasured_outputs is not None and signals.unmeasured_outputs[first - 1, 0]:
        return ""
    if modes[first - 1] != modes[first]:  # a switch opened the interval: run open loop
        return ""
    time_s = signals.time
    import sympy

    before = first - 1
    mode = int(modes[before])
    mode_id = model.mode_ids[mode]
    values = [
        f"{name} = {value:.6g}"
        for name, value in zip(model.states, states[before].tolist(), strict=True)
    ]
    shown = ", ".join(values[:MAX_SHOWN]) + (", …" if len(values) > MAX_SHOWN else "")
    text = (
        f": Q = dPhi/dx (eq. (21)) of mode '{mode_id}' is singular at t = "
        f"{format_time(time_s[before])} s, at the estimate {shown}"
    )
    _, q = drift_observability(model, mode)
    matrix = sympy.Matrix(q)
    blind = [x for j, x in enumerate(model.states) if all(e == 0 for e in matrix.col(j))]
    if blind:
        text += f", and at every state: {', '.join(blind)} enter(s) no entry of Phi"
    elif sympy.simplify(matrix.det(method="berkowitz")) == 0:
        text += ", and at every state (det Q = 0)"
    else:
        return text + ": Q^-1 K (y - h) of observer (20) is not defined there"
    return text + f": mode '{mode_id}' is not drift-observable from {model.outputs[0]}"


def _replay(
    model: HybridModel, arguments: tuple[Any, ...], first: int
) -> tuple[ModuleType, Escape | None]:
    """The interval into sample ``first`` run again in plain Python, the model watched.

    The generated ``observe`` and its ``_rhs`` run as Python over the rows
    ``first − 2 … first`` from the estimate at ``first − 1`` (``start`` is that row: the
    first-order hold's slope uses the row before it, as in the run), calling the compiled
    ``dx``, ``h``, ``Q`` and ``reset`` through a :class:`~hybridlog.model.escape.Watch`:
    the first of them whose point is finite and value is not is the cause.
    """
    from types import FunctionType

    from hybridlog.model.escape import replayed

    module = observer_module(model)
    low = max(first - 2, 0)
    outputs = arguments[3]
    while low > 0 and np.isnan(outputs[low, 0]):  # the slope's measured sample: replayed too
        low -= 1
    rows = slice(low, first + 1)
    time_s, modes, inputs, outputs, _, gain, substeps, rk4, first_order = arguments[:9]
    states = arguments[10]

    def replay(watch: Watch) -> None:
        namespace = dict(vars(module))
        namespace["dx"] = watch.vector("dx", module.dx)
        namespace["h"] = watch.vector("h", module.h)
        namespace["Q"] = watch.vector("Q", module.Q)
        namespace["reset"] = watch.jump(module.reset)
        namespace["_rhs"] = FunctionType(module._rhs.py_func.__code__, namespace)
        loop = getattr(module.observe, "py_func", module.observe)
        observe = FunctionType(loop.__code__, namespace)
        count = first + 1 - low
        observe(
            time_s[rows],
            modes[rows],
            inputs[rows],
            outputs[rows],
            states[first - 1].copy(),
            gain,
            substeps,
            rk4,
            first_order,
            first - 1 - low,
            np.zeros((count, model.n_states)),
            np.zeros(count),
            np.zeros(count),
            np.zeros(count, dtype=np.int64),
        )

    return module, replayed(replay)


def _rhs_flaw(
    model: HybridModel, module: ModuleType, arguments: tuple[Any, ...], before: int
) -> str:
    """The step against observer (20)'s right-hand side linearised at the estimate ``before``.

    An estimate that outgrew float64 (an expression infinite at it, or none non-finite at
    all) may have been thrown there by the correction ``Q⁻¹K(y − h)`` far from the log:
    its Jacobian at the estimate (central differences, relative steps, of the generated
    ``_rhs``) is what the step has to follow, checked by
    :func:`~hybridlog.model.stability.step_flaw`.  Empty when no eigenvalue is flawed; the
    estimate itself is named by :func:`_last_interval`.
    """
    from hybridlog.model.stability import step_flaw

    _, modes, inputs, outputs, _, gain = arguments[:6]
    n = model.n_states
    x = np.array(arguments[10][before], dtype=np.float64)
    q, u, y = int(modes[before + 1]), inputs[before], float(outputs[before, 0])
    # y not measured there, or a switch opened the interval: it had no correction
    inject = not np.isnan(y) and modes[before] == modes[before + 1]
    if modes[before] != modes[before + 1]:  # the interval ran from the jumped estimate
        jumped = np.empty(n)
        module.reset(int(modes[before]), q, x, jumped)
        x = jumped
    work = (np.empty(1), np.empty((n, n)), np.empty((n, n)), np.empty(n), np.empty(n))
    jacobian = np.empty((n, n))
    high, low = np.empty(n), np.empty(n)
    with np.errstate(all="ignore"):
        for j in range(n):
            delta = 1e-7 * (abs(float(x[j])) or 1.0)  # relative: x = 1e-70 is no zero
            shifted = x.copy()
            shifted[j] += delta
            module._rhs(q, shifted, u, y, inject, gain, n, high, *work)
            shifted[j] -= 2 * delta
            module._rhs(q, shifted, u, y, inject, gain, n, low, *work)
            jacobian[:, j] = (high - low) / (2 * delta)
    timebase = model.timebase
    if timebase.method is None or timebase.step is None:  # discrete: refused before the run
        return ""
    flaw = step_flaw(timebase.method, timebase.step, jacobian)
    if flaw is None:
        return ""
    value = flaw.eigenvalue
    eigenvalue = f"{value.real:.4g}" if value.imag == 0 else f"{value:.4g}"
    return (
        f": observer (20) linearised at t = {format_time(float(arguments[0][before]))} s "
        f"has λ = {eigenvalue} 1/s, which integration.step = {timebase.step:g} s cannot "
        f"follow ({flaw.kind}; at most {flaw.longest_step:.3g} s would)"
    )


def _keyed_escape(module: ModuleType, escape: Escape) -> Escape | None:
    """``dx`` or ``h`` not finite where ``Q`` is not: the expression a user wrote, named first.

    ``Q`` is evaluated first at a sample (its condition number), so ``h = x + x**1.5`` at a
    negative estimate made ``Q`` the first non-finite value, though ``h`` has left its
    domain there too.
    """
    from hybridlog.model.escape import Escape

    for name in ("dx", "h"):
        out = np.empty(escape.x.shape[0] if name == "dx" else 1)
        with np.errstate(all="ignore"):
            getattr(module, name)(escape.mode, escape.x, escape.u, out)
        if not np.isfinite(out).all():
            return Escape(name, escape.mode, -1, escape.x, escape.u, out)
    return None


def _divergence(
    model: HybridModel,
    signals: AlignedSignals,
    arguments: tuple[Any, ...],
    eigenvalues: tuple[float, ...],
    first: int,
) -> DivergenceError:
    """Why the estimate is not finite at sample ``first``, the first such.

    The refusal listed "a jump map, or the gain of eigenvalues -5 too large for the
    integration step" for an estimate whose ``dx = log(h1)`` had stepped below 0.  Named
    in turn: the model expression that turned a finite estimate non-finite (the interval
    replayed, :func:`_replay`: ``dx`` or ``h`` out of its domain, or overflowing; a jump
    map; ``Q``); ``Q`` singular (:func:`_singular_q`); the step against the observer's
    linearisation (:func:`_rhs_flaw`); else the gain, with the interval's numbers.
    """
    from hybridlog.model.escape import escape_error, point

    modes, (states, predictions, condition) = arguments[1], arguments[10:13]
    where = (
        f"{NAME} diverged at t = {format_time(signals.time[first])} s (sample {first}): the "
        "estimate is not finite"
    )
    origin = model.origin or model.name
    last = _last_interval(model, signals, modes, states, predictions, first)
    last += _jump_before(model, signals, arguments, first)
    if first < 1:
        return DivergenceError(f"{origin}: {where}")
    module, escape = _replay(model, arguments, first)
    interval = (
        f"a step of the interval from t = {format_time(signals.time[first - 1])} s to "
        f"{format_time(signals.time[first])} s"
    )
    if escape is not None and escape.function == "Q":  # dx or h out of domain there too?
        escape = _keyed_escape(module, escape) or escape
    if escape is not None and escape.function == "Q":
        mode_id = model.modes[escape.mode].id
        return DivergenceError(
            f"{origin}: {where}: Q = dPhi/dx (eq. (21)) of mode '{mode_id}', derived from its "
            f"dx and h, is not finite at the estimate "
            f"{point(model, escape.x, escape.u)}, {interval}: the estimate left the domain "
            f"of Q there{last}"
        )
    if escape is not None:
        at = interval
        if escape.function == "reset":  # R is applied at t_k^+, k = first - 1 (module doc)
            # (said t = t_first, a sample late: simulate's refusal of the same map, and this
            # one's own "switch ... just after t_k", said t_k)
            at = f"at t = {format_time(signals.time[first - 1])} s"
        flaw = ""
        if escape.function != "reset" and not np.isnan(escape.out).any():  # an overflow
            flaw = _rhs_flaw(model, module, arguments, first - 1)
        error = escape_error(model, escape, at, where + flaw + last, noun="estimate")
        return DivergenceError(str(error))
    singular = _singular_q(model, signals, modes, states, condition, first)
    if singular:
        return DivergenceError(f"{origin}: {where}{singular}")
    flaw = _rhs_flaw(model, module, arguments, first - 1)
    if flaw:
        return DivergenceError(f"{origin}: {where}{flaw}{last}")
    return DivergenceError(
        f"{origin}: {where} (every expression finite along the interval: the correction "
        f"Q^-1 K (y - h) of the gain of eigenvalues "
        f"{', '.join(f'{v:g}' for v in eigenvalues)} outgrew float64){last}"
    )


def _runs(mask: Any) -> list[tuple[int, int]]:
    """``(first, last)`` index of every run of True in ``mask``."""
    padded = np.concatenate(([False], np.asarray(mask, dtype=bool), [False]))
    edges = np.flatnonzero(np.diff(padded.astype(np.int8)))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _notes(
    time_s: FloatArray,
    condition: FloatArray,
    limit: float,
    switches: int | None,
    jumped: int,
    states: FloatArray,
    eigenvalues: tuple[float, ...],
) -> tuple[str, ...]:
    """The run's notes; ``switches`` None where sigma is a one-mode model's (no signal)."""
    if switches is None:
        sigma = "sigma the model's one mode throughout (no switching signal in the log)"
    else:
        times = "once" if switches == 1 else f"{switches} times"
        sigma = f"sigma from the log switched {times}, jump maps R applied at {jumped} of them"
    notes = [
        f"observer (20) of paper 004 with K placing eig(A_b - K C_b) at "
        f"{', '.join(f'{v:g}' for v in eigenvalues)}; {sigma}",
    ]
    if not time_s.size:
        return tuple(notes)
    valid = np.isfinite(states).all(axis=1)  # kappa_1 of a non-finite estimate means nothing
    worst = int(np.argmax(np.where(valid, np.nan_to_num(condition, nan=np.inf), -1.0)))
    finite = valid & np.isfinite(condition)
    notes.append(
        f"condition number kappa_1(Q) along the run: median "
        f"{np.median(condition[finite]) if finite.any() else np.inf:.3g}, "
        f"max {condition[worst]:.3g} at t = {format_time(time_s[worst])} s"
    )
    bad = valid & ~(condition <= limit)
    if bad.any():
        runs = _runs(bad)
        where = "; ".join(
            f"t = {format_time(time_s[a])}..{format_time(time_s[b])} s" for a, b in runs[:3]
        )
        more = f" and {len(runs) - 3} more intervals" if len(runs) > 3 else ""
        notes.append(
            f"WARNING: Q(sigma, x) is ill-conditioned (kappa_1 > {limit:.3g}) on "
            f"{int(bad.sum())} sample{'s' if bad.sum() > 1 else ''} (or the intervals into "
            f"them: {where}{more}; worst {condition[worst]:.3g} at t = "
            f"{format_time(time_s[worst])} s): the correction Q^-1 K (y - h) is unreliable "
            "there"
        )
    return tuple(notes)


def _initial_mode_note(model: HybridModel, first: int) -> tuple[str, ...]:
    """The note of a log whose first mode is not the one the model's ``[initial]`` expects.

    Paper 004's observer takes sigma as known (the log's switching signal), sigma(0) too: the
    prior over the initial mode (``[initial] mode`` or ``mode_probabilities``), which a
    filter weighs against the first outputs, has nothing to decide here.  Nothing said it:
    a log starting in another mode than ``[initial] mode`` ran without a word of it.  The
    estimate starts at ``[initial] state`` in the log's first mode as written: the log shows
    no switch at its start, so no jump map from the model's initial mode is applied.
    ``()`` where the log's first mode is one of the most probable initial modes.
    """
    prior = model.initial_mode_probabilities
    if prior[first] >= prior.max():
        return ()
    expected = model.mode_ids[int(np.argmax(prior))]
    jump = model.jump_between(int(np.argmax(prior)), first)
    jumped = (
        f", and the jump map {jump.key} was not applied (the log shows no switch at its start)"
        if jump is not None
        else ""
    )
    return (
        f"[initial] mode not used: the model's initial mode is '{expected}' (prior "
        f"{prior.max():.3g}), the log's switching signal starts in '{model.mode_ids[first]}' "
        f"(prior {prior[first]:.3g}), which this observer takes as known (paper 004: sigma is "
        "given); the estimate starts from [initial] state in "
        f"'{model.mode_ids[first]}'{jumped}",
    )


def _open_loop_note(signals: AlignedSignals, modes: Any) -> tuple[str, ...]:
    """How many intervals ran without output injection, and a warning where most did.

    An interval runs open loop (observer (20) with ``K = 0``, module doc) where ``y`` was
    not measured at its start, or where a switch opened it (``y(k)`` measured the state
    before the jump).  Only the first were told: a switching signal that changes every
    sample ran the whole log open loop, the model simulated from ``[initial] state``, and
    the report (VAF 0, state RMSE 0.76) said nothing of why.
    """
    intervals = signals.n_samples - 1
    if intervals < 1:
        return ()
    unmeasured = np.zeros(intervals, dtype=bool)
    if signals.unmeasured_outputs is not None:
        unmeasured = np.asarray(signals.unmeasured_outputs[:-1, 0], dtype=bool)
    switched = np.asarray(modes[1:] != modes[:-1], dtype=bool)
    count = int(np.count_nonzero(unmeasured | switched))
    if not count:
        return ()
    why = []
    if unmeasured.any():
        why.append(
            f"the log did not measure {signals.output_names[0]} at the start of "
            f"{int(np.count_nonzero(unmeasured)):,} (a value taken from the samples around is "
            "no measurement)"
        )
    if switched.any():
        why.append(
            f"a switch opened {int(np.count_nonzero(switched)):,} (y measured the state before "
            "the jump)"
        )
    notes = [
        f"{count:,} of {intervals:,} intervals ran without output injection (observer (20) "
        f"with K = 0): {'; '.join(why)}"
    ]
    if 2 * count > intervals:
        notes.append(
            f"WARNING: the observer corrected its estimate on only {intervals - count:,} of "
            f"{intervals:,} intervals: on the others it integrated the model open loop, so the "
            "estimate is mostly the model's run from [initial] state, not an observer's"
        )
    return tuple(notes)


def run_switching_observer(
    model: HybridModel, signals: AlignedSignals, options: SwitchingObserverOptions
) -> EstimationResult:
    """Run observer (20) of paper 004 over the aligned log (see the module doc).

    Raises
    ------
    ModelError
        The model has more than one output, or is not continuous-time; or (its subclass
        :class:`~hybridlog.errors.DivergenceError`) the estimate diverged (not finite at
        some sample: a report of it could vouch for nothing).
    LogError
        The log has no switching signal (the true mode column) and the model more than one
        mode (a one-mode model's sigma is that mode: the signal would tell nothing).
    OptionError
        ``eigenvalues`` is not one or ``n`` negative reals, or the integration step cannot
        follow one of them (:func:`_check_step`).
    """
    from hybridlog.model.compiled import compile_generated
    from hybridlog.signals import IntArray

    _check_model(model)
    if signals.truth_modes is None and model.n_modes > 1:
        raise LogError(
            f"{signals.source}: estimator '{NAME}' needs the switching signal in the log; map "
            "it with --map truth.mode=PATH (or a 'mode' column)"
        )
    eigenvalues = options.eigenvalue_list(model.n_states)
    gain = brunovsky_gain(eigenvalues)
    _check_step(model, eigenvalues)
    count, n = signals.n_samples, model.n_states
    given = signals.truth_modes is not None
    modes: IntArray = (
        np.ascontiguousarray(signals.truth_modes, dtype=np.int64)
        if signals.truth_modes is not None and model.n_modes > 1
        else np.zeros(count, dtype=np.int64)  # one mode: sigma is known without the log
    )
    timebase = model.timebase
    arguments = (
        np.ascontiguousarray(signals.time, dtype=np.float64),
        modes,
        np.ascontiguousarray(signals.inputs, dtype=np.float64).reshape(count, model.n_inputs),
        np.ascontiguousarray(signals.measured_outputs(), dtype=np.float64),
        np.ascontiguousarray(model.initial_state, dtype=np.float64),
        gain,
        np.int64(timebase.substeps),
        timebase.method == "rk4",
        options.output_hold == "first",
        np.int64(0),
        np.zeros((count, n)),
        np.zeros(count),
        np.zeros(count),
        np.zeros(count, dtype=np.int64),
    )
    observe, compile_s = compile_generated(
        model, KIND, lambda: observer_source(model), GENERATORS, "observe", arguments
    )
    start = time.perf_counter()
    if count:
        observe(*arguments)
    runtime = time.perf_counter() - start
    states, predictions, condition, jumped = arguments[10:14]
    broken = ~np.isfinite(states).all(axis=1)
    if broken.any():  # no metric of a diverged run can be vouched for
        first = int(np.argmax(broken))
        raise _divergence(model, signals, arguments, eigenvalues, first)
    probabilities = np.zeros((count, model.n_modes))
    probabilities[np.arange(count), modes] = 1.0
    switches = int(np.count_nonzero(np.diff(modes))) if count else 0
    notes = _notes(
        signals.time,
        condition,
        options.condition_limit,
        switches if given else None,
        int(jumped.sum()),
        states,
        eigenvalues,
    ) + _open_loop_note(signals, modes)
    if given and count:
        notes += _initial_mode_note(model, int(modes[0]))
    from hybridlog.estimators.options import options_dict

    return EstimationResult(
        estimator=NAME,
        options=options_dict(options),
        time=signals.time,
        mode_ids=model.mode_ids,
        state_names=model.states,
        output_names=model.outputs,
        modes=modes.copy(),
        mode_probabilities=probabilities,
        state_means=states,
        state_variances=np.full((count, n), np.nan),
        output_predictions=predictions.reshape(count, 1),
        runtime_s=runtime,
        compile_s=compile_s,
        notes=notes,
        modes_given=MODES_GIVEN if given else ONE_MODE_GIVEN,
    )
