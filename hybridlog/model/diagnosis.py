r"""What a model says about its own estimability, found when the file is loaded.

A model file can be valid in every key and still promise estimates the log cannot give.
:func:`diagnose` finds, from the matrices of each mode (or, for a nonlinear mode, of its
linearisation at ``[initial] state`` with the inputs at 0, said as such), what a control
engineer checks before running an estimator over thousands of logs:

* **outputs that see no state**: a mode whose ``h`` depends on no state (``C = 0``): while
  in it the log says nothing of the state;
* **observability** of each mode: the states the outputs do not determine are those with a
  component along the unobservable subspace, the null space of
  :math:`\mathcal O = [C; CA; \dots; CA^{n-1}]` (Kalman's rank test; :math:`A` scaled by its
  norm first, which leaves the null space as it is and keeps the powers in range).  The
  eigenvalues of :math:`A` on that subspace (:math:`N^T A N`, :math:`N` its orthonormal
  basis, which :math:`A` leaves invariant) are the modes' unobservable eigenvalues; one on or
  outside the stability boundary makes the mode not *detectable*: an estimator's error
  along it never decays in that mode (paper 001's LMI (15) then has no solution where
  :math:`|\lambda| \ge 1`, and ``chiu``/``kmeans`` refuse the model before any log is
  read; just inside the circle it has one, whose error there shrinks only by
  :math:`|\lambda|` a sample);
* **the switched system's observability**: the states no output determines in any mode nor
  across switches.  With every mode linear and no jump maps, the observable subspace is the
  smallest one holding the rows of every :math:`C_q` (and a unit row per state a guard reads:
  a state-driven switch reveals its sign) and invariant under every :math:`A_q^T`; its
  complement is unobservable under every switching sequence.  Otherwise structurally: a
  state that no output, guard or jump map reads, directly or through any mode's dynamics,
  is unobservable whatever the numbers;
* **undamped components without process noise** (discrete time, where the filters weigh
  ``Q``): an eigenvalue on the unit circle (:math:`|\ln|\lambda|| \le` :data:`MARGIN`) that
  no process noise reaches (PBH: :math:`[\lambda I - A,\ Q^{1/2}]` rank-deficient) makes the
  filter's Riccati recursion converge to a solution that is not stabilising (de Souza,
  Gevers, Goodwin, *IEEE Trans. Automatic Control* 31(9), 1986): the variance of that
  component and so its gain tend to 0, and the estimate stops following the log there.  An
  unreached eigenvalue strictly outside the circle keeps a positive gain where it is
  observable, and is not named;
* **a continuous-time step too long for a mode** (:func:`hybridlog.model.stability.step_flaw`
  of :math:`A`, the check ``simulate`` makes along its run).

The results are lines of text: ``WARNING: ...`` where a run's numbers are then not what
they seem (every report of the model repeats them, ``report/build.py``), ``NOTE: ...``
for what ``hybridlog models FILE`` says beside.  Computed once, when the file is parsed
(sympy is loaded then), without the linearisations of nonlinear modes (notes only), and
kept in the loaded-model cache; ``models FILE`` computes them all.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import sympy

from hybridlog.model.derivatives import jacobian
from hybridlog.model.hybrid_model import HybridModel, Jump, Mode, Timebase
from hybridlog.model.observability import RANK, null_space, unobservable_basis, unseen_eigenvalues
from hybridlog.model.stability import step_flaw
from hybridlog.signals import FloatArray

__all__ = ["MARGIN", "MOST_LINES", "diagnose", "model_diagnoses"]

MARGIN = 1e-3
r"""An eigenvalue counts as on the stability boundary within this much of it per sample:
:math:`|\ln|\lambda|| \le` 1e-3 in discrete time, :math:`|\operatorname{Re}\lambda|\,dt \le`
1e-3 in continuous time (a time constant of more than 1000 samples).  The double cart's
undamped mode 1, printed to 4 digits (paper 001), has :math:`|\lambda| = 1 \pm 3.4 \cdot
10^{-5}`."""


MOST_LINES = 12
"""Most lines of modes' findings :func:`diagnose` gives (the last one counting the others)."""

_MOST_NAMED = 6
"""Most modes (or eigenvalues) a line names one by one."""

_WARNING = "WARNING: "
_NOTE = "NOTE: "


@dataclass(frozen=True)
class _Linearised:
    """A mode's ``A``, ``C`` (exact, or at the initial state) and its process noise ``Q``."""

    A: FloatArray
    C: FloatArray
    Q: FloatArray
    exact: bool

    @property
    def where(self) -> str:
        """How the matrices were found, for a message."""
        return "" if self.exact else " (its linearisation at [initial] state, inputs 0)"


def diagnose(
    modes: Sequence[Mode],
    states: Sequence[str],
    inputs: Sequence[str],
    timebase: Timebase,
    initial_state: FloatArray,
    jumps: Sequence[Jump],
    *,
    linearise: bool,
) -> tuple[str, ...]:
    """The model's diagnoses (module docstring), the switched system's first, then each mode's.

    With ``linearise`` false the nonlinear modes are judged by their structure alone (what
    their expressions read): the Jacobians at the initial state, which only ever give notes,
    cost tens of milliseconds a mode in sympy, too much for every cold load (the loader's
    call, whose warnings every report repeats); ``hybridlog models FILE`` linearises.
    Empty for a components model (no enumerated modes: ``unknown-mode`` analyses its
    structure itself).
    """
    if not modes:
        return ()
    x = [sympy.Symbol(name, real=True) for name in states]
    # sympy numbers: a Jacobian entry that is a bare symbol is replaced by one, not a float
    point = {s: sympy.Float(v) for s, v in zip(x, initial_state.tolist(), strict=True)}
    point.update({sympy.Symbol(name, real=True): sympy.Float(0.0) for name in inputs})
    slopes: dict[sympy.Expr, list[complex]] = {}
    linearised = [
        _linearise(mode, x, point, slopes) if linearise or mode.linear_form is not None else None
        for mode in modes
    ]
    unseen = _system_unobservable(modes, linearised, states, jumps)
    findings: dict[_Finding, list[str]] = {}
    for mode, form in zip(modes, linearised, strict=True):
        for finding in _mode_findings(mode, form, states, timebase, set(unseen), len(modes)):
            findings.setdefault(finding, []).append(mode.id)
    system = [_system_line(unseen, states, len(modes), linearised, jumps)] if unseen else []
    return (*system, *_mode_lines(findings))


@dataclass(frozen=True)
class _Finding:
    """What one mode's equations say (a line without the mode's name), and its weight."""

    warning: bool
    text: str


def model_diagnoses(model: HybridModel) -> tuple[str, ...]:
    """:func:`diagnose` of a loaded model, its nonlinear modes linearised (``models FILE``).

    A components model's joint modes left unchecked when the file was read
    (:func:`~hybridlog.model.component_structure.unchecked_note`) are said too.
    """
    from hybridlog.model.component_structure import ComponentNames, unchecked_note

    names = ComponentNames(model.states, model.inputs, model.outputs, model.variables)
    unchecked = unchecked_note(model.components, names) if model.components else None
    return diagnose(
        model.modes,
        model.states,
        model.inputs,
        model.timebase,
        model.initial_state,
        model.jumps,
        linearise=True,
    ) + (() if unchecked is None else (f"{_NOTE}{unchecked}",))


def _mode_lines(findings: Mapping[_Finding, Sequence[str]]) -> list[str]:
    """A line per finding, naming every mode it holds for, at most :data:`MOST_LINES`.

    A boolean-affine model has up to 1024 modes: the lines past the first ones are counted
    in one more line, a warning where any of them is.
    """
    lines = [
        f"{_WARNING if finding.warning else _NOTE}{_modes_named(ids)}: {finding.text}"
        for finding, ids in findings.items()
    ]
    if len(lines) <= MOST_LINES:
        return lines
    rest = list(findings)[MOST_LINES - 1 :]
    warning = any(finding.warning for finding in rest)
    return [
        *lines[: MOST_LINES - 1],
        f"{_WARNING if warning else _NOTE}{len(rest)} more lines of this kind on other modes "
        "are not shown",
    ]


def _modes_named(ids: Sequence[str]) -> str:
    """``mode 'a'``, ``modes 'a', 'b'``, or the first few of many and their count."""
    quoted = [f"'{m}'" for m in ids]
    if len(ids) == 1:
        return f"mode {quoted[0]}"
    if len(ids) <= _MOST_NAMED:
        return f"modes {', '.join(quoted)}"
    return f"modes {', '.join(quoted[: _MOST_NAMED - 1])}, ... {quoted[-1]} ({len(ids)} modes)"


def _names(indices: Sequence[int], states: Sequence[str]) -> str:
    return ", ".join(states[i] for i in indices)


def _system_line(
    unseen: Sequence[int],
    states: Sequence[str],
    n_modes: int,
    linearised: Sequence[_Linearised | None],
    jumps: Sequence[Jump],
) -> str:
    exact = not jumps and all(form is not None and form.exact for form in linearised)
    how = (
        "the observable subspace of the modes' A and C leaves them out"
        if exact
        else "no output, guard or jump map reads them, directly or through the dynamics"
    )
    where = "in any mode nor across switches" if n_modes > 1 else "of the model"
    return (
        f"{_WARNING}no output determines {_names(unseen, states)} {where} ({how}): their "
        "estimates are the model's prediction from [initial], never corrected by the log, and "
        "their RMSE scores that prediction"
    )


def _mode_findings(
    mode: Mode,
    form: _Linearised | None,
    states: Sequence[str],
    timebase: Timebase,
    unseen: set[int],
    n_modes: int,
) -> list[_Finding]:
    """What one mode says: outputs blind to the state, or unobservable states; noise; step."""
    blind = not _reads_states(mode, states)
    findings = []
    if blind:
        findings.append(
            _Finding(
                True,
                f"the outputs depend on no state (h reads none of {', '.join(states)}): "
                "while in it the log says nothing of the state, whose estimates there are "
                "the model's prediction",
            )
        )
    if form is None:
        return findings
    basis = unobservable_basis(form.A, form.C)
    hidden = _components(basis)
    # a one-mode model's unobservable states are the system's, said once, unless they last
    lasting = form.exact and bool(_lasting(form.A, basis, timebase))
    if not blind and hidden and (n_modes > 1 or bool(set(hidden) - unseen) or lasting):
        findings.append(_observability(form, basis, hidden, states, timebase))
    findings += _undamped(form, timebase)
    if timebase.method is not None:
        flaw = step_flaw(timebase.method, timebase.step, form.A)
        if flaw is not None:
            findings.append(
                _Finding(
                    form.exact,
                    f"integration.step {timebase.step:g} s is too long for it{form.where}: "
                    f"dx has the eigenvalue λ = {_number(flaw.eigenvalue)} 1/s; "
                    f"{flaw.describe(timebase.method)}",
                )
            )
    return findings


def _observability(
    form: _Linearised,
    basis: FloatArray,
    hidden: Sequence[int],
    states: Sequence[str],
    timebase: Timebase,
) -> _Finding:
    n = form.A.shape[0]
    rank = n - basis.shape[1]
    if not form.exact:
        return _Finding(
            False,
            f"the outputs do not determine {_names(hidden, states)} to first order at "
            f"[initial] state (the observability matrix of the linearisation there, inputs "
            f"0, has rank {rank} of {n}): a filter started there learns of them only as the "
            "state moves",
        )
    lasting = _lasting(form.A, basis, timebase)
    what = f"the outputs do not determine {_names(hidden, states)}"
    matrix = f"the observability matrix of A and C has rank {rank} of {n}"
    if not lasting:
        return _Finding(False, f"{what} ({matrix}; the part they miss decays in the mode)")
    refused = ""
    if not timebase.is_continuous:
        # the LMI (15) refuses only what its decay rate, at most 1, cannot beat: an eigenvalue
        # within MARGIN below 1 (0.9999) got a certified gain, while this said "refuse"
        slowest = max(abs(value) for value in lasting)
        refused = (
            ", and chiu and kmeans refuse the mode"
            if slowest >= 1.0
            else f", and chiu's and kmeans' observer error there shrinks by only {slowest:.4g} "
            "a sample"
        )
    return _Finding(
        True,
        f"{what} ({matrix}), and the part they miss does not decay "
        f"({_eigenvalues(lasting, 'unobservable ')}): in the mode an estimate's error there "
        f"never shrinks{refused}",
    )


def _eigenvalues(values: Sequence[complex], kind: str = "") -> str:
    """``the eigenvalue 1.02``, ``the eigenvalues 0.9+0.1j, 0.9-0.1j``: each value once."""
    distinct = list(dict.fromkeys(_number(v) for v in values))
    shown = ", ".join(distinct[:_MOST_NAMED])
    if len(distinct) > _MOST_NAMED:
        shown += f", ... ({len(distinct)} values)"
    return f"the {kind}eigenvalue{'s' if len(distinct) > 1 else ''} {shown}"


def _undamped(form: _Linearised, timebase: Timebase) -> list[_Finding]:
    """The undamped eigenvalues no process noise reaches, in discrete time (module doc)."""
    if timebase.is_continuous:
        return []
    root = _square_root(form.Q)
    n = form.A.shape[0]
    unreached = []
    for value in np.linalg.eigvals(form.A):
        if abs(value) == 0.0 or abs(np.log(abs(value))) > MARGIN:
            continue
        pencil = np.hstack([value * np.eye(n) - form.A, root.astype(np.complex128)])
        singular = np.linalg.svd(pencil, compute_uv=False)
        if singular[-1] <= RANK * max(1.0, float(np.linalg.norm(form.A, 2))):
            unreached.append(complex(value))
    if not unreached:
        return []
    return [
        _Finding(
            False,
            f"no process noise reaches {_eigenvalues(unreached, 'undamped ')} (|λ| ≈ 1)"
            f"{form.where}: a filter's variance of that component, and so its gain, tend to 0 "
            "while in the mode, and its estimate stops following the log there",
        )
    ]


def _lasting(A: FloatArray, basis: FloatArray, timebase: Timebase) -> list[complex]:
    """The eigenvalues of ``A`` on the unobservable subspace that do not decay."""
    return [v for v in unseen_eigenvalues(A, basis) if not _decays(v, timebase)]


def _decays(value: complex, timebase: Timebase) -> bool:
    """Whether an eigenvalue's component decays, by more than :data:`MARGIN` a sample."""
    if timebase.is_continuous:
        return value.real * timebase.dt < -MARGIN
    return abs(value) == 0.0 or bool(np.log(abs(value)) < -MARGIN)


def _number(value: complex) -> str:
    if abs(value.imag) <= RANK * abs(value):
        return f"{value.real:.4g}"
    return f"{value.real:.4g}{'+' if value.imag >= 0 else '-'}{abs(value.imag):.4g}j"


def _square_root(covariance: FloatArray) -> FloatArray:
    """A factor ``G`` with ``G Gᵀ = Q`` (``Q`` symmetric positive semi-definite)."""
    values, vectors = np.linalg.eigh(covariance)
    result: FloatArray = vectors * np.sqrt(np.clip(values, 0.0, None))
    return result


def _components(basis: FloatArray) -> list[int]:
    """The states with a component along the subspace of ``basis``."""
    return [i for i in range(basis.shape[0]) if np.linalg.norm(basis[i]) > RANK]


def _reads_states(mode: Mode, states: Sequence[str]) -> bool:
    if mode.linear_form is not None:
        return bool(np.any(mode.linear_form.C))
    names = set(states)
    return any(str(s) in names for e in mode.h for s in e.free_symbols)


def _linearise(
    mode: Mode,
    x: Sequence[sympy.Symbol],
    point: Mapping[sympy.Symbol, sympy.Float],
    slopes: dict[sympy.Expr, list[complex]],
) -> _Linearised | None:
    """The mode's matrices, or its Jacobians at ``point`` (the initial state, inputs 0).

    ``slopes`` holds each expression's derivatives at the point once found: the modes of a
    boolean-affine model (up to 1024) share most of their expressions.  ``None`` where a
    Jacobian there is not finite (``sqrt`` at 0): it says nothing.
    """
    form = mode.linear_form
    if form is not None:
        return _Linearised(form.A, form.C, mode.process_noise, exact=True)
    matrices = []
    for expressions in (mode.dynamics, mode.h):
        for expression in expressions:
            if expression not in slopes:
                slopes[expression] = _slopes(expression, x, point)
        values = np.array([slopes[e] for e in expressions])
        if not np.all(np.isfinite(values)) or np.any(values.imag != 0.0):
            return None
        matrices.append(values.real)
    return _Linearised(matrices[0], matrices[1], mode.process_noise, exact=False)


def _slopes(
    expression: sympy.Expr, x: Sequence[sympy.Symbol], point: Mapping[sympy.Symbol, sympy.Float]
) -> list[complex]:
    """``∂expression/∂x`` at ``point``; NaN where undefined there (0/0, a Piecewise gap).

    Evaluated in float64, not by sympy: putting the point into ``exp(exp(exp(x)))`` made sympy
    evaluate ``exp(exp(4.9e8))`` exactly, for minutes; in float64 it is inf, a slope that says
    nothing.
    """
    from hybridlog.model.codegen import lambdify  # the printer: not for a warm process

    (row,) = jacobian([expression], x)
    names = list(point)
    slopes = lambdify(names, row, "numpy")
    with np.errstate(all="ignore"):
        try:
            found = np.asarray(slopes(*(float(point[n]) for n in names)), dtype=np.complex128)
        except (TypeError, ValueError, ArithmeticError, NameError):
            return [complex(np.nan)] * len(row)
    return [complex(v) for v in found.reshape(len(row))]


def _system_unobservable(
    modes: Sequence[Mode],
    linearised: Sequence[_Linearised | None],
    states: Sequence[str],
    jumps: Sequence[Jump],
) -> list[int]:
    """The states no output determines under any switching (module docstring)."""
    guarded = _guard_states(modes, states)
    if not jumps and all(form is not None and form.exact for form in linearised):
        exact = [form for form in linearised if form is not None]
        return _components(_joint_unobservable(exact, guarded))
    return _structurally_unseen(modes, states, jumps, guarded)


def _guard_states(modes: Sequence[Mode], states: Sequence[str]) -> set[int]:
    index = {name: i for i, name in enumerate(states)}
    read: set[int] = set()
    for mode in modes:
        if mode.has_guard and mode.guard is not None:
            read |= {index[str(s)] for s in mode.guard.free_symbols if str(s) in index}
    return read


def _joint_unobservable(forms: Sequence[_Linearised], guarded: set[int]) -> FloatArray:
    """A basis of the states' subspace no output sees under any switching.

    The complement of the smallest subspace that holds the rows of every ``C`` and of the
    guards' states and that every ``Aᵀ`` leaves invariant (module docstring).
    """
    n = forms[0].A.shape[0]
    rows = np.vstack([*(form.C for form in forms), np.eye(n)[sorted(guarded)]])
    scaled = [form.A / max(1.0, float(np.linalg.norm(form.A, 2))) for form in forms]
    span = _row_basis(rows)
    while True:
        grown = _row_basis(np.vstack([span, *(span @ a for a in scaled)]))
        if grown.shape[0] == span.shape[0]:
            break
        span = grown
    return null_space(span) if span.shape[0] else np.eye(n)


def _row_basis(matrix: FloatArray) -> FloatArray:
    if matrix.shape[0] == 0:
        return matrix
    _, singular, vt = np.linalg.svd(matrix, full_matrices=False)
    largest = singular[0] if singular.size else 0.0
    rank = int(np.sum(singular > RANK * largest)) if largest > 0.0 else 0
    basis: FloatArray = vt[:rank]
    return basis


def _structurally_unseen(
    modes: Sequence[Mode], states: Sequence[str], jumps: Sequence[Jump], guarded: set[int]
) -> list[int]:
    """States that no output, guard or jump map reads through any chain of dynamics."""
    index = {name: i for i, name in enumerate(states)}
    reads: list[set[int]] = [set() for _ in states]  # reads[i]: the states x_i's update reads
    seen = set(guarded)
    for mode in modes:
        form = mode.linear_form
        if form is not None:
            seen |= set(np.flatnonzero(np.any(form.C != 0.0, axis=0)).tolist())
            for i in range(len(states)):
                reads[i] |= set(np.flatnonzero(form.A[i]).tolist())
            continue
        seen |= {index[str(s)] for e in mode.h for s in e.free_symbols if str(s) in index}
        for i, expression in enumerate(mode.dynamics):
            reads[i] |= {index[str(s)] for s in expression.free_symbols if str(s) in index}
    for jump in jumps:
        for i, expression in enumerate(jump.reset):
            reads[i] |= {index[str(s)] for s in expression.free_symbols if str(s) in index}
    frontier = list(seen)
    while frontier:
        for j in reads[frontier.pop()] - seen:
            seen.add(j)
            frontier.append(j)
    return [i for i in range(len(states)) if i not in seen]
