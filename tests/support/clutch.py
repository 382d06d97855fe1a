"""The engine-with-clutch plant of paper 004 §6 written by hand with NumPy and SciPy.

Independent of hybridlog's code generation: only the parameter *values* come from the model
(so a test can vary them); the equations (40)-(46) are written here again.  Used by the
switching observer's tests, its benchmark and ``docs/studies/ice_clutch.py``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from scipy.integrate import solve_ivp

from hybridlog.signals import AlignedSignals


def plant(sigma: int, x: np.ndarray, alpha: float, p: Mapping[str, float]) -> np.ndarray:
    """ẋ of eq. (44) in mode ``sigma`` (0 disengaged, 1 engaged)."""
    m, omega, torque = x
    inertia = p["JE"] + sigma * p["JL"]
    friction = p["fE"] + sigma * p["fL"]
    m_ss = (p["m0"] + p["m1"] * omega) * alpha + p["q0"]
    beta = p["beta_bar"] * m * np.exp(-p["gamma"] * (omega - p["omega_bar"]) ** 4)
    return np.array(
        [-p["p"] * omega * (m - m_ss), (beta - friction * omega - torque) / inertia, 0.0]
    )


def jump(before: int, after: int, x: np.ndarray, p: Mapping[str, float]) -> np.ndarray:
    """R(σ⁻, σ, x) of eqs. (45)-(46)."""
    m, omega, torque = x
    if (before, after) == (0, 1):
        return np.array(
            [m, p["JE"] / (p["JE"] + p["JL"]) * omega, (p["TE"] + p["TL"]) / p["TE"] * torque]
        )
    if (before, after) == (1, 0):
        return np.array([m, omega, p["TE"] / (p["TE"] + p["TL"]) * torque])
    return np.asarray(x, dtype=float)


def schedule_modes(schedule: Sequence[tuple[int, int]]) -> np.ndarray:
    """Mode of every sample from ``[(mode, samples), ...]``."""
    return np.concatenate([np.full(count, mode, dtype=np.int64) for mode, count in schedule])


def trajectory(
    p: Mapping[str, float],
    modes: np.ndarray,
    x0: Sequence[float],
    throttle: Callable[[np.ndarray], np.ndarray],
    dt: float,
    rtol: float = 1e-10,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sample times, throttle samples (held over each interval) and true states.

    As ``hybridlog simulate``: the mode of row ``k + 1`` governs the interval into it, and
    the state jumps by R at its start ``t_k^+`` (eq. (4)); row ``k`` keeps the state before.
    """
    count = modes.shape[0]
    times = np.arange(count) * dt
    alpha = np.asarray(throttle(times), dtype=float) * np.ones(count)
    states = np.empty((count, 3))
    x = np.asarray(x0, dtype=float)
    states[0] = x
    for k in range(count - 1):
        sol = solve_ivp(
            lambda _t, s, q=int(modes[k + 1]), a=float(alpha[k]): plant(q, s, a, p),
            (times[k], times[k + 1]),
            jump(int(modes[k]), int(modes[k + 1]), x, p),
            method="DOP853",
            rtol=rtol,
            atol=rtol * 1e-2,
        )
        x = sol.y[:, -1]
        states[k + 1] = x
    return times, alpha, states


def signals(
    times: np.ndarray, alpha: np.ndarray, states: np.ndarray, modes: np.ndarray | None
) -> AlignedSignals:
    """The log of a clutch run: throttle in, engine speed out, σ as the true mode."""
    return AlignedSignals(
        source="clutch.csv",
        time=times,
        input_names=("alpha",),
        output_names=("y",),
        inputs=alpha.reshape(-1, 1).copy(),
        outputs=states[:, 1:2].copy(),
        truth_modes=None if modes is None else modes.copy(),
        state_names=("m", "omega", "T"),
        truth_states=states.copy(),
    )


def linearised_error(p: Mapping[str, float], gain: np.ndarray) -> Callable[..., np.ndarray]:
    """``M(σ, x, α)``: the observer's error dynamics ė = M e linearised at x̂ = x.

    Differentiating observer (20) at x̂ = x (where y − h = 0) gives
    ``M = ∂(f + g α)/∂x − Q(σ, x)⁻¹ K ∂h/∂x``; the frozen-time eigenvalues of M are what
    the placed Λ becomes once the plant's own nonlinearity is added.  Written again here with
    sympy from eqs. (42)-(44) (not through hybridlog's derivatives).
    """
    import sympy

    m, omega, torque, alpha = sympy.symbols("m omega T alpha", real=True)
    xs = [m, omega, torque]
    functions = []
    for sigma in (0, 1):
        inertia = p["JE"] + sigma * p["JL"]
        friction = p["fE"] + sigma * p["fL"]
        beta = p["beta_bar"] * m * sympy.exp(-p["gamma"] * (omega - p["omega_bar"]) ** 4)
        m_ss = (p["m0"] + p["m1"] * omega) * alpha + p["q0"]
        field = [-p["p"] * omega * (m - m_ss), (beta - friction * omega - torque) / inertia, 0]
        drift = [sympy.sympify(e).subs(alpha, 0) for e in field]
        phi = [omega]
        for _ in range(2):
            phi.append(sum(sympy.diff(phi[-1], x) * f for x, f in zip(xs, drift, strict=True)))
        q = sympy.Matrix(phi).jacobian(xs)
        jac = sympy.Matrix(field).jacobian(xs)
        functions.append(
            tuple(sympy.lambdify([xs, alpha], e, "numpy") for e in (sympy.Matrix(phi), q, jac))
        )
    c = np.array([[0.0, 1.0, 0.0]])

    def matrices(sigma: int, x: np.ndarray, a: float) -> tuple[np.ndarray, ...]:
        """Φ(σ, x), Q(σ, x) and M(σ, x, α)."""
        phi_fn, q_fn, jac_fn = functions[sigma]
        phi_value = np.asarray(phi_fn(list(x), a), dtype=float).ravel()
        q_value = np.asarray(q_fn(list(x), a), dtype=float)
        jac_value = np.asarray(jac_fn(list(x), a), dtype=float)
        m_value = jac_value - np.linalg.solve(q_value, gain.reshape(-1, 1)) @ c
        return phi_value, q_value, m_value

    return matrices


def decay_rate(time: np.ndarray, error: np.ndarray) -> float:
    """Least-squares slope of ``log(error)`` against time (the exponential rate, 1/s)."""
    slope, _ = np.polyfit(time, np.log(error), 1)
    return float(slope)
