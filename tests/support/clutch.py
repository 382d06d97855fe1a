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

    The state jumps by R at the first sample of a new mode, as eq. (4).
    """
    count = modes.shape[0]
    times = np.arange(count) * dt
    alpha = np.asarray(throttle(times), dtype=float) * np.ones(count)
    states = np.empty((count, 3))
    x = np.asarray(x0, dtype=float)
    states[0] = x
    for k in range(count - 1):
        sol = solve_ivp(
            lambda _t, s, q=int(modes[k]), a=float(alpha[k]): plant(q, s, a, p),
            (times[k], times[k + 1]),
            x,
            method="DOP853",
            rtol=rtol,
            atol=rtol * 1e-2,
        )
        x = jump(int(modes[k]), int(modes[k + 1]), sol.y[:, -1], p)
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
