"""The hybrid model: what a model file describes, with symbolic mode equations."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy

from hybridlog.signals import FloatArray


@dataclass(frozen=True)
class Mode:
    r"""One discrete mode of a discrete-time switched system.

    .. math::

        x(k+1) = f_q(x(k), u(k)) + \xi(k), \qquad y(k) = h_q(x(k), u(k)) + \omega(k)

    (paper 000, eq. (2)).  ``f`` and ``h`` are sympy expressions in the model's state and
    input symbols with every parameter already substituted.

    Attributes
    ----------
    id:
        The mode id as written in the model file (``"1"``, ``"valve_open"`` ...).
    f:
        Next-state expressions, one per state.
    h:
        Output expressions, one per output.
    process_noise:
        Covariance ``Q_q = g_q R_ξ g_qᵀ`` of the additive process noise, ``(n_x, n_x)``.
    measurement_noise:
        Covariance ``R_q`` of the measurement noise, ``(n_y, n_y)``.
    linear:
        True when the mode was given as ``A``, ``B``, ``C``, ``D`` matrices.
    guard:
        Condition on the states and inputs under which the mode is active (``guard =
        "x3 <= 0"``), a sympy relational; ``None`` when the model is switched by a schedule.
    """

    id: str
    f: tuple[sympy.Expr, ...]
    h: tuple[sympy.Expr, ...]
    process_noise: FloatArray
    measurement_noise: FloatArray
    linear: bool = False
    guard: sympy.Basic | None = None


@dataclass(frozen=True)
class HybridModel:
    """A discrete-time hybrid (switched) system read from a model file.

    Attributes
    ----------
    name, description, reference:
        Free text from the model file; ``reference`` names paper and equations.
    dt:
        Sample time in seconds.
    states, inputs, outputs:
        Symbol names, in the order of the state, input and output vectors.
    parameters:
        Parameter values (after ``--set`` overrides), already substituted into the modes.
    modes:
        The modes, in the order of the file; their index is the mode index used everywhere.
    initial_state, initial_covariance, initial_mode_probabilities:
        The estimators' prior ``x̂(0|0)``, ``P(0|0)`` and ``Pr(q(0))``.
    transitions:
        Markov matrix ``Π[i, j] = Pr(q(k+1)=j | q(k)=i)``, or ``None`` when the file has none.
    signals, truth:
        Default message paths for symbols, and for ground truth (``mode`` and state names).
    default_estimator:
        Estimator used by ``analyze`` when none is named.
    estimator_options:
        Default options per estimator name, from ``[estimators.<name>]``.
    simulation_state:
        True initial state used by ``simulate`` (``[simulation] state``); ``None`` means
        ``initial_state``.
    simulation_inputs:
        Input signals for ``simulate`` as expressions in ``t`` (seconds) and ``k`` (step).
    simulation_schedule:
        Default mode schedule for ``simulate``, e.g. ``"1:100,2:100,3:100"``.
    simulation_state_min:
        Lower bounds of the true states in ``simulate`` (e.g. tank levels at 0), or ``None``.
    source:
        The model file's text (or the built-in's), printed by ``hybridlog models NAME``.
    origin:
        Where the model came from: the file's path as the user gave it, or the built-in's
        name.  Errors about the model name it, so the user knows which file to change.
    """

    name: str
    description: str
    reference: str
    dt: float
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    parameters: dict[str, float]
    modes: tuple[Mode, ...]
    initial_state: FloatArray
    initial_covariance: FloatArray
    initial_mode_probabilities: FloatArray
    transitions: FloatArray | None
    signals: dict[str, str] = field(default_factory=dict)
    truth: dict[str, str] = field(default_factory=dict)
    default_estimator: str = "imm"
    estimator_options: dict[str, dict[str, Any]] = field(default_factory=dict)
    simulation_state: FloatArray | None = None
    simulation_inputs: dict[str, sympy.Expr] = field(default_factory=dict)
    simulation_schedule: str = ""
    simulation_state_min: FloatArray | None = None
    source: str = ""
    origin: str = ""

    @property
    def n_states(self) -> int:
        """Length of the continuous state vector."""
        return len(self.states)

    @property
    def n_inputs(self) -> int:
        """Length of the input vector."""
        return len(self.inputs)

    @property
    def n_outputs(self) -> int:
        """Length of the output vector."""
        return len(self.outputs)

    @property
    def n_modes(self) -> int:
        """Number of discrete modes."""
        return len(self.modes)

    @property
    def state_driven(self) -> bool:
        """True when the modes switch by their guards (state-driven switching)."""
        return any(m.guard is not None for m in self.modes)

    @property
    def mode_ids(self) -> tuple[str, ...]:
        """Mode ids in index order."""
        return tuple(m.id for m in self.modes)

    def mode_index(self, mode_id: str) -> int:
        """Index of the mode with id ``mode_id``; raises ``KeyError`` when there is none."""
        return self.mode_ids.index(mode_id)

    def symbols(self) -> tuple[list[sympy.Symbol], list[sympy.Symbol]]:
        """Sympy symbols of the states and of the inputs."""
        return (
            [sympy.Symbol(s, real=True) for s in self.states],
            [sympy.Symbol(u, real=True) for u in self.inputs],
        )


def markov_matrix(stay: float, n_modes: int) -> FloatArray:
    """Markov matrix with ``stay`` on the diagonal and the rest spread evenly over the others."""
    if n_modes == 1:
        return np.ones((1, 1))
    off = (1.0 - stay) / (n_modes - 1)
    return np.full((n_modes, n_modes), off) + np.eye(n_modes) * (stay - off)
