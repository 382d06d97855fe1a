r"""Whether a continuous-time model's integration step suits its modes (linear stability).

A fixed-step explicit method applied to :math:`\dot x = f_q(x, u)` near a point advances
each eigen-direction of the Jacobian :math:`J = \partial f_q / \partial x` by the method's
*stability function* :math:`R(z)`, :math:`z = h\lambda`, per step (Hairer and Wanner,
*Solving Ordinary Differential Equations II*, §IV.2), where the exact solution advances by
:math:`e^{z}`:

* ``euler``: :math:`R(z) = 1 + z`;
* ``rk4``: :math:`R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24`.

Three outcomes make every later number the integration gives one hybridlog cannot vouch for,
whatever the tolerance a user would choose, and :func:`step_flaw` names them:

* **unstable**: :math:`\operatorname{Re}\lambda < 0` (the mode decays there) but
  :math:`|R(z)| > 1`: the integration grows where the model decays;
* **alternating**: :math:`\lambda` real and negative, but :math:`R(z) < 0` with
  :math:`|R(z)| > e^{z}`: the integration flips the sign of the mode's transient every step
  and lets it die out more slowly than the model does (explicit Euler with
  :math:`-2 < h\lambda < -1.278`: ``dx = -1990*(x - 1)`` from 0 at a 1 ms step reaches 0.096
  after ten steps where the model reaches 1.0).  A flip that dies out faster than the model
  (Euler at :math:`h\lambda = -1.1`: :math:`R = -0.1` against :math:`e^{z} = 0.33`) damps the
  transient more than the model, as implicit methods do, and is accepted;
* **lingering**: :math:`\operatorname{Re} z < -1` (the mode's time constant is shorter than
  a step: its transient is over within one) but :math:`|R(z)| > e^{-1}` (the integration's
  time constant, :math:`-h/\ln|R|`, is longer than a step): the step draws out over several
  samples a transient the model ends within one step (RK4, positive on the real axis, from
  :math:`h\lambda = -2.09` to its stability boundary at :math:`-2.785`:
  ``dx = -2780*(x - 1)`` from 0 at a 1 ms step reaches 0.077 after ten steps where the model
  reaches 1.0).  Both time constants are measured against the step itself, the one scale
  the integration has: RK4 at :math:`h\lambda = -1.99`, :math:`R = 0.335`, is accepted.

A growing component (:math:`\operatorname{Re}\lambda > 0`, an unstable mode, or
:math:`\dot x = x^2` blowing up in finite time) is followed as long as the method keeps its
growth; one more outcome is named:

* **misgrown**: one step's factor :math:`|R(z)|` misses the mode's :math:`e^{\operatorname{Re} z}`
  by more than a factor e, either way (:math:`|\operatorname{Re} z - \ln|R(z)|| > 1`): every
  step's growth is off by more than the mode's whole growth over a time constant (RK4 from
  :math:`h\lambda = 5.5` on, explicit Euler from 2.15; ``dx = a*x**2`` from 1 at a 10 ms step
  wrote x = 5.1e12 at t = 1 s with ``a = 1.01``, where the model had blown up at 0.99 s).

An eigenvalue within rounding of the imaginary axis (an undamped oscillator) keeps its
component's size, :math:`|e^{z}| = 1`; one more outcome is named there:

* **undamped**: :math:`|R(z)| > 1` although a shorter step would give :math:`|R| \le 1`
  (:data:`IMAGINARY_REACH`):
  the integration grows an oscillation the mode keeps, by a factor that does not shrink as
  the run goes on (RK4 beyond :math:`h|\lambda| = 2\sqrt2`, fewer than 2.2 steps a period:
  ``dx = [v, -90000*p]`` at 10 ms reaches 2.6e17 in a second).  Explicit Euler grows every
  undamped oscillation at every step (:math:`|1 + iy| > 1`), by :math:`(h\omega)^2/2` a
  step, its first-order error that a shorter step shrinks: that is accuracy, which no step
  cures outright, and is accepted.

The longest step that avoids each outcome is found by bisection of the same conditions, so
the message can say what step would do.  Where that step is shorter than the run's clock
can take (:math:`t + h` rounds to :math:`t`), no step would do: the state has run away, and
the Jacobian is stiff only because the state is huge.  ``omega = "-omega"`` as ice_clutch's
jump map at 1.5 s made ``m`` grow by the mode's own, faithfully integrated, instability to
-5.7e131 at 6 s, where the message asked for a step of 3.75e-122 s; the run is then refused
naming the state and the switch since which it grew past float64's precision
(:func:`_runaway`).  Pure NumPy: the caller evaluates the Jacobian (the
model's compiled ``DX``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hybridlog.model.compiled import CompiledContinuousModel, ModelFunction
from hybridlog.model.hybrid_model import HybridModel, IntegrationMethod
from hybridlog.model.integration import METHOD_CODES, integrate_step, work_buffer
from hybridlog.signals import FloatArray, IntArray
from hybridlog.times import format_time

__all__ = ["StepFlaw", "amplification", "check_step", "step_flaw"]

_ROUNDING = 1e-9
"""An eigenvalue's real part within this fraction of its modulus counts as zero, and an
imaginary part as zero for the sign test: ``eigvals`` of an undamped oscillator's Jacobian
returns real parts of about 1e-16 × its modulus."""

IMAGINARY_REACH: dict[IntegrationMethod, float] = {"euler": 0.0, "rk4": 2.0 * np.sqrt(2.0)}
r"""The stretch :math:`|y| \le` reach of the imaginary axis where :math:`|R(iy)| \le 1`:
none for explicit Euler (:math:`|1 + iy|^2 = 1 + y^2`), :math:`2\sqrt2` for RK4
(:math:`|R(iy)|^2 = 1 - y^6/72 + y^8/576`; Hairer and Wanner, §IV.2).  Exact, where a
bisection of :math:`|R| > 1` would stop at rounding (:math:`|1 + 10^{-9}i|` is 1.0)."""

_SHOWN = 6
"""Most states an error shows of the point where the step fails."""

_PRECISION = 2.0**52
"""A growth past this factor (``1/ε`` of float64) is a runaway: the value before it is below
the rounding of the value after, as a state's own scale is lost in it."""

_BISECTIONS = 60
"""Halvings of the interval of steps searched for the longest admissible one."""


def amplification(method: IntegrationMethod, z: complex) -> complex:
    r"""The stability function :math:`R(z)` of ``method``: one step's factor on ``e^{λt}``.

    Beyond float64 (RK4's :math:`z^4/24` past :math:`|z| \approx 10^{77}`) it is not finite,
    which :func:`_flaw_kind` takes as growth; Python's complex power raised ``OverflowError``.
    """
    if method == "euler":
        return 1.0 + z
    w = np.complex128(z)
    with np.errstate(over="ignore", invalid="ignore"):
        return complex(1.0 + w + w * w / 2.0 + w**3 / 6.0 + w**4 / 24.0)


def _flaw_kind(method: IntegrationMethod, step: float, eigenvalue: complex) -> str | None:
    """The outcome (module docstring) or ``None``: one eigenvalue, one step."""
    size = abs(eigenvalue)
    if abs(eigenvalue.real) <= _ROUNDING * size:
        reach = IMAGINARY_REACH[method]
        return "undamped" if reach > 0.0 and step * abs(eigenvalue.imag) > reach else None
    factor = amplification(method, step * eigenvalue)
    if eigenvalue.real > _ROUNDING * size:
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            shortfall = step * eigenvalue.real - float(np.log(abs(factor)))
        return "misgrown" if not abs(shortfall) <= 1.0 else None
    if not abs(factor) <= 1.0:  # NaN or infinite too: beyond float64, it grows
        return "unstable"
    real = abs(eigenvalue.imag) <= _ROUNDING * size
    if real and factor.real < 0.0 and abs(factor) > np.exp(step * eigenvalue.real):
        return "alternating"
    if step * eigenvalue.real < -1.0 and abs(factor) > np.exp(-1.0):
        return "lingering"
    return None


def _longest_step(method: IntegrationMethod, step: float, eigenvalue: complex) -> float:
    """The longest step up to ``step`` at which ``eigenvalue`` has no flaw (bisection).

    Halved first until a step has none (``λ = -1e80``: about 270 halvings of 1 ms), then
    bisected between that step and its double.
    """
    good, bad = step, step
    while good > 0.0 and _flaw_kind(method, good, eigenvalue) is not None:
        bad, good = good, good / 2.0
    for _ in range(_BISECTIONS):
        middle = 0.5 * (good + bad)
        if _flaw_kind(method, middle, eigenvalue) is None:
            good = middle
        else:
            bad = middle
    return good


@dataclass(frozen=True)
class StepFlaw:
    r"""An eigenvalue of a mode's Jacobian the integration step mistreats.

    Attributes
    ----------
    kind:
        ``"unstable"``, ``"alternating"``, ``"lingering"``, ``"undamped"`` or ``"misgrown"``
        (module docstring).
    eigenvalue:
        The eigenvalue :math:`\lambda` (1/s).
    factor:
        The method's factor per step, :math:`R(h\lambda)`.
    exact:
        The model's own factor per step, :math:`e^{h\lambda}`.
    longest_step:
        The longest step (s) at which this eigenvalue has no flaw.
    """

    kind: str
    eigenvalue: complex
    factor: complex
    exact: complex
    longest_step: float

    def describe(self, method: IntegrationMethod) -> str:
        """One clause: what the method does to the eigenvalue's component, the step that would do.

        The caller names the eigenvalue and where it comes from.
        """
        name = "explicit Euler" if method == "euler" else "RK4"
        what = {
            "unstable": "grows where it should decay",
            "alternating": "flips its sign every step and decays more slowly than it should",
            "undamped": "grows an oscillation that should keep its size",
            "lingering": ("takes more than a step to decay by e where it should within one step"),
            "misgrown": "misses the growth of a growing component by more than a factor e",
        }[self.kind]
        factor = _number(self.factor) if np.isfinite(self.factor) else "more than float64 holds"
        exact = _number(self.exact) if np.isfinite(self.exact) else "more than float64 holds"
        return (
            f"{name} multiplies its component by {factor} a step where "
            f"e^(h·λ) = {exact}: the integration {what}; a step of at most "
            f"{self.longest_step:.3g} s avoids it"
        )


def _number(value: complex) -> str:
    """A real or complex number to four significant digits."""
    if value.imag == 0.0:
        return f"{value.real:.4g}"
    sign = "+" if value.imag >= 0 else "-"
    return f"{value.real:.4g}{sign}{abs(value.imag):.4g}j"


def step_flaw(method: IntegrationMethod, step: float, jacobian: FloatArray) -> StepFlaw | None:
    """The worst-treated eigenvalue of ``jacobian`` at ``step``, or ``None`` when none is.

    A Jacobian that is not finite (``sqrt`` at 0) gives ``None``: its linearisation says
    nothing about the step.  Of several flawed eigenvalues, the one needing the shortest
    step is named.
    """
    if not np.all(np.isfinite(jacobian)):
        return None
    worst: StepFlaw | None = None
    for eigenvalue in np.linalg.eigvals(jacobian):
        value = complex(eigenvalue)
        kind = _flaw_kind(method, step, value)
        if kind is None:
            continue
        longest = _longest_step(method, step, value)
        if worst is None or longest < worst.longest_step:
            z = step * value
            with np.errstate(over="ignore", invalid="ignore"):
                exact = complex(np.exp(np.complex128(z)))
            worst = StepFlaw(kind, value, amplification(method, z), exact, longest)
    return worst


MAX_POINTS = 256
"""Most samples of a nonlinear mode :func:`check_step` linearises at (evenly spaced among
the mode's samples, its first included): stiffness lives mostly in a model's linear part,
and 256 evaluations of the Jacobian and its eigenvalues cost milliseconds.  Taken per mode,
so a mode the run visits for a few samples of millions is linearised all the same; a mode
whose ``dx`` is affine (``Mode.linear_form``) has one Jacobian, linearised once."""

TOTAL_POINTS = 4096
"""Most samples :func:`check_step` linearises at in all (about 80 ms), shared among the
nonlinear modes the run visits, one each at least: a boolean-affine model's 1024 modes all
visited would otherwise cost 262,144 evaluations, seconds on a run that takes one."""


def _rows(model: HybridModel, modes: IntArray) -> IntArray:
    """The rows :func:`check_step` linearises at: some of every mode the run visits.

    Row ``k`` stands for the interval :math:`(t_{k-1}, t_k]` run in mode ``modes[k]``.
    """
    visited = np.unique(modes[1:])
    nonlinear = sum(1 for q in visited if model.modes[int(q)].linear_form is None)
    share = min(MAX_POINTS, max(1, TOTAL_POINTS // max(nonlinear, 1)))
    chosen: list[IntArray] = []
    for q in visited:
        rows = np.flatnonzero(modes[1:] == q) + 1
        count = 1 if model.modes[int(q)].linear_form is not None else share
        picks = np.unique(np.linspace(0, rows.size - 1, count).astype(np.int64))
        chosen.append(rows[picks])
    return np.unique(np.concatenate(chosen))


def _flaw_at(
    model: HybridModel,
    jacobian: ModelFunction,
    q: int,
    x: FloatArray,
    u: FloatArray,
    out: FloatArray,
) -> StepFlaw | None:
    """:func:`step_flaw` of mode ``q``'s Jacobian at ``x``, ``u``; ``None`` where not finite."""
    method = model.timebase.method
    if method is None or not np.all(np.isfinite(x)):
        return None
    try:
        jacobian(q, x, u, out)
    except ZeroDivisionError:  # plain Python (``jit=False``); compiled, an inf or NaN
        return None
    return step_flaw(method, model.timebase.step, out)


def _stays(
    model: HybridModel,
    functions: CompiledContinuousModel,
    q: int,
    x: FloatArray,
    u: FloatArray,
    state_min: FloatArray,
    out: FloatArray,
) -> bool:
    """Whether one step from ``x`` keeps a flaw found at ``x``: lands where it is one too.

    A linearisation's flaw compounds only while the steps stay where it holds.  A step
    that leaves that region at once (a tank emptying: ``-c*sqrt(h)`` has the Jacobian
    ``-c/(2√h)``, as stiff as one likes just above 0, and the step that lands at 0 is the
    last) is one step of a bounded error, and the run is what the model says.  A step that
    overflows, or takes the state out of the model's domain, stays flawed.
    """
    method = model.timebase.method or "rk4"
    after = x.copy()
    try:
        integrate_step(
            functions.dx,
            METHOD_CODES[method],
            q,
            after,
            u,
            model.timebase.step,
            work_buffer(x.shape[0]),
        )
    except (ZeroDivisionError, OverflowError, ValueError):  # plain Python's inf or NaN
        return True
    after = np.maximum(after, state_min)
    if not np.all(np.isfinite(after)):
        return True
    return _flaw_at(model, functions.DX, q, after, u, out) is not None


def check_step(
    model: HybridModel,
    functions: CompiledContinuousModel,
    modes: IntArray,
    states: FloatArray,
    inputs: FloatArray,
    time: FloatArray,
    state_min: FloatArray,
) -> None:
    """Refuse a run whose integration step mistreats a mode where the run went.

    The interval :math:`(t_{k-1}, t_k]` runs in mode ``modes[k]`` with ``inputs[k-1]`` held,
    from ``states[k-1]``, or at a switch from the state the jump map ``functions.jump``
    gives, each step bounded below by ``state_min``
    (:func:`hybridlog.simulation_kernels.simulate_continuous_steps`); the Jacobian
    ``functions.DX`` is evaluated at up to :data:`MAX_POINTS` such starts of each mode
    (:func:`_rows`) whose state is finite, and at the run's end (in the last interval's mode
    and input), and a flaw there refused when one step of the method from there lands where
    it is one too (:func:`_stays`).

    Raises
    ------
    ModelError
        Naming ``integration.step``, the mode, the time and state, and the eigenvalue
        (:meth:`StepFlaw.describe`).
    """
    timebase = model.timebase
    if timebase.method is None or states.shape[0] < 2:
        return
    out = np.zeros((model.n_states, model.n_states))
    jumped = np.zeros(model.n_states)
    last = states.shape[0]
    for row in [*_rows(model, modes).tolist(), last]:
        # the row past the last stands for the run's end, where the last interval's steps
        # ended: a mode blowing up in finite time does so within an interval, not at a start
        q = int(modes[min(row, last - 1)])
        start = np.ascontiguousarray(states[row - 1])
        if row < last and q != int(modes[row - 1]):
            functions.jump(int(modes[row - 1]), q, start, jumped)
            start = jumped.copy()
        u = np.ascontiguousarray(inputs[row - 1 if row < last else last - 2])
        flaw = _flaw_at(model, functions.DX, q, start, u, out)
        if flaw is not None and _stays(model, functions, q, start, u, state_min, out):
            clock = float(np.spacing(max(abs(float(time[row - 1])), float(time[-1] - time[0]))))
            if flaw.longest_step < clock:  # t + h rounds to t: no step can be taken
                _refuse_runaway(model, functions, modes, states, time, row, start, flaw)
            pairs = list(zip(model.states, start, strict=True))[:_SHOWN]
            shown = ", ".join(f"{name} = {value:.4g}" for name, value in pairs)
            if model.n_states > _SHOWN:
                shown += ", …"
            where = (
                f"just after the switch from '{model.modes[int(modes[row - 1])].id}'"
                if row < last and q != int(modes[row - 1])
                else ""
            )
            raise model.error(
                "integration.step",
                f"{timebase.step:g} s is too long for mode '{model.modes[q].id}' at t = "
                f"{format_time(float(time[row - 1]))} s{' ' + where if where else ''} "
                f"({shown}): the Jacobian of dx there has "
                f"the eigenvalue λ = {_number(flaw.eigenvalue)} 1/s; "
                f"{flaw.describe(timebase.method)}",
            )


def _pieces(
    modes: IntArray,
    states: FloatArray,
    row: int,
    at: FloatArray,
) -> list[tuple[int, FloatArray, FloatArray]]:
    """The run up to the point ``at`` (row ``row``'s start) cut at its switches.

    Each piece ``(k, before, end)``: its first row ``k`` (1 for the run's start, else a row
    whose mode differs from the one before, the jump applied at ``states[k - 1]``), the state
    before its jump and the state at its end (before the next jump; ``at`` for the last).
    """
    n = min(row, modes.shape[0] - 1)  # the row past the last stands for the run's end
    ks = [1, *(int(k) for k in np.flatnonzero(modes[2 : n + 1] != modes[1:n]) + 2)]
    pieces = []
    for i, k in enumerate(ks):
        end = at if i == len(ks) - 1 else states[ks[i + 1] - 1]
        pieces.append((k, states[k - 1], end))
    return pieces


def _refuse_runaway(
    model: HybridModel,
    functions: CompiledContinuousModel,
    modes: IntArray,
    states: FloatArray,
    time: FloatArray,
    row: int,
    at: FloatArray,
    flaw: StepFlaw,
) -> None:
    """Refuse the run as a runaway when a state grew past :data:`_PRECISION` before ``at``.

    Walking back from the piece of the run (:func:`_pieces`) that ends at ``at``, pieces
    over which the state grew by more than :data:`_PRECISION` each are the runaway's; it
    began at the first of them: the run's start, or a switch (named with its jump map's key
    where one applies, and the state the map put there).  Of the states that ran away, the
    one grown most is named.  Returns without raising when none did: the step is then what
    is wrong (a stiff mode at a state of its own scale).

    Raises
    ------
    ModelError
        Naming the key, the state, the switch and times, and the step the flaw asked for.
    """
    pieces = _pieces(modes, states, row, at)
    tiny = float(np.finfo(np.float64).tiny)
    found: tuple[float, int, int] | None = None  # (log growth, state, first piece)
    for j in range(model.n_states):
        first = len(pieces) - 1
        while first > 0:
            _, before, end = pieces[first - 1]
            if not abs(end[j]) > _PRECISION * abs(before[j]):
                break
            first -= 1
        base = abs(pieces[first][1][j])
        if not abs(at[j]) > _PRECISION * base:
            continue
        growth = float(np.log(abs(at[j])) - np.log(max(base, tiny)))
        if found is None or growth > found[0]:
            found = (growth, j, first)
    if found is None:
        return
    _, j, first = found
    k = pieces[first][0]
    name = model.states[j]
    grown_from = float(states[k - 1][j])
    shown = ", ".join(
        f"{n} = {v:.4g}" for n, v in list(zip(model.states, states[k - 1], strict=True))[:_SHOWN]
    )
    if first == 0 and int(modes[k]) == int(modes[k - 1]):
        key = _dx_key(model, int(modes[k]))
        since = f"since the run's start at t = {format_time(float(time[0]))} s ({shown})"
    else:
        source, target = int(modes[k - 1]), int(modes[k])
        jump = model.jump_between(source, target)
        after = states[k - 1].copy()
        functions.jump(source, target, np.ascontiguousarray(states[k - 1]), after)
        grown_from = float(after[j])
        landed = ", ".join(
            f"{n} = {v:.4g}" for n, v in list(zip(model.states, after, strict=True))[:_SHOWN]
        )
        switch = (
            f"the switch from '{model.modes[source].id}' to '{model.modes[target].id}' at "
            f"t = {format_time(float(time[k - 1]))} s"
        )
        if jump is not None:
            key = jump.key
            since = f"since the jump at {switch}, which put it at {landed}"
        else:
            key = _dx_key(model, target)
            since = f"since {switch} ({landed})"
    method = "explicit Euler" if model.timebase.method == "euler" else "RK4"
    q = int(modes[min(row, len(modes) - 1)])
    raise model.error(
        key,
        f"the state ran away {since}: {name} grew by the modes' own dynamics, which {method} "
        f"followed, from {grown_from:.4g} to {at[j]:.4g} at "
        f"t = {format_time(float(time[row - 1]))} s, by more than float64's precision (2^52); "
        f"there the Jacobian of mode '{model.modes[q].id}''s dx has the eigenvalue "
        f"λ = {_number(flaw.eigenvalue)} 1/s, which only a step of {flaw.longest_step:.3g} s "
        "would follow, shorter than the run's clock can take: change the model's motion, not "
        "integration.step; nothing was written",
    )


def _dx_key(model: HybridModel, mode: int) -> str:
    """The key of a mode's ``dx``: ``modes.<id>.dx``, or ``dynamics.dx`` of a model of booleans."""
    return "dynamics.dx" if model.has_booleans else f"modes.{model.modes[mode].id}.dx"
