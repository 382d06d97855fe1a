"""Straight-line code for small fixed-size filter steps.

For a model with a handful of states the fastest filter step is scalar code with every small
matrix product written out (no loops, no array views): about 5x faster than compiled loops over
3x3 arrays.  :class:`Program` writes such code: matrices are lists of *entries*, each a float
literal (folded at generation time, so structural zeros of Jacobians and noise covariances
cost nothing) or the name of a scalar variable of the generated function.

The estimators build their accelerators from these pieces (``imm.py``, ``hstf.py``); the
generic compiled kernels (``kernels.py``) compute the same thing and are what the tests
compare the generated code against.  The model's own functions are written inline by
:func:`hybridlog.model.codegen.emit_mode_function` (the one place sympy is printed).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import TYPE_CHECKING

from hybridlog.signals import FloatArray

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = [
    "MAX_UNROLLED_MODES",
    "MAX_UNROLLED_SIZE",
    "MAX_UNROLLED_WORK",
    "Entry",
    "Matrix",
    "Program",
    "Vector",
    "constant_matrix",
    "fits_unrolled",
    "matrix_names",
    "module_source",
    "noise_matrices",
    "product",
    "reshape",
    "state_slots",
    "term",
    "unrolled_work",
    "upper",
    "use_unrolled",
    "vector_names",
]

Entry = float | str
"""A literal value or the name of a scalar variable in the generated code."""
Matrix = list[list[Entry]]
Vector = list[Entry]


def _literal(value: float) -> str:
    """Source text of a float; a constant folded past the range of floats is ``math.inf``.

    ``repr`` writes it ``inf``/``nan``, names the generated module does not define (a model
    whose ``H Q Hᵀ`` overflowed at generation failed to compile with numba's ``NameError``);
    written so, the code computes what the generic loops compute.
    """
    number = float(value)
    if not math.isfinite(number):
        text = "math.nan" if math.isnan(number) else f"{'-' if number < 0 else ''}math.inf"
    else:
        text = repr(number)
    return f"({text})" if text.startswith("-") else text


def term(entry: Entry) -> str:
    """Source text of one entry."""
    return _literal(entry) if isinstance(entry, float) else entry


def product(a: Entry, b: Entry) -> Entry | None:
    """``a*b`` folded: ``None`` for a structural zero."""
    if isinstance(a, float) and isinstance(b, float):
        return a * b if a * b != 0.0 else None
    if a == 0.0 or b == 0.0:
        return None
    if a == 1.0:
        return b
    if b == 1.0:
        return a
    return f"{term(a)}*{term(b)}"


class Program:
    """Lines of a generated function body, with fresh variable names and constant folding."""

    def __init__(self, indent: str = "        ") -> None:
        self.lines: list[str] = []
        self.indent = indent
        self._counter = 0

    def emit(self, line: str) -> None:
        """Append one line at the current indentation."""
        self.lines.append(f"{self.indent}{line}")

    @contextmanager
    def block(self, header: str) -> Iterator[None]:
        """Lines emitted inside the ``with`` are the body of ``header`` (an ``if …:``)."""
        self.emit(header)
        self.indent += "    "
        yield
        self.indent = self.indent[:-4]

    def fresh(self, hint: str) -> str:
        """A new variable name."""
        self._counter += 1
        return f"{hint}{self._counter}"

    def let(self, hint: str, parts: Sequence[Entry | None], constant: float = 0.0) -> Entry:
        """Bind ``constant + Σ parts`` (``None`` parts are zeros) to a new variable.

        Returns the folded literal instead when every part is a literal.
        """
        total = constant
        names: list[str] = []
        for part in parts:
            if part is None:
                continue
            if isinstance(part, float):
                total += part
            else:
                names.append(part)
        if not names:
            return total
        expression = " + ".join(names)
        if total != 0.0:
            expression = f"{expression} + {_literal(total)}"
        name = self.fresh(hint)
        self.emit(f"{name} = {expression}")
        return name

    def assign(self, hint: str, expression: str) -> str:
        """Bind an arbitrary expression to a new variable."""
        name = self.fresh(hint)
        self.emit(f"{name} = {expression}")
        return name

    def difference(self, hint: str, a: Entry, b: Entry) -> Entry:
        """``a - b``."""
        if isinstance(a, float) and isinstance(b, float):
            return a - b
        if b == 0.0:
            return a
        return self.assign(hint, f"{term(a)} - {term(b)}")

    def matmul(self, hint: str, A: Matrix, B: Matrix, *, transpose_b: bool = False) -> Matrix:
        """``A @ B`` (or ``A @ Bᵀ``)."""
        inner = len(A[0]) if A else 0
        cols = len(B) if transpose_b else len(B[0])
        result: Matrix = []
        for i in range(len(A)):
            row: list[Entry] = []
            for j in range(cols):
                parts = [
                    product(A[i][k], B[j][k] if transpose_b else B[k][j]) for k in range(inner)
                ]
                row.append(self.let(hint, parts))
            result.append(row)
        return result

    def congruence(self, hint: str, A: Matrix, P: Matrix, add: Matrix | None = None) -> Matrix:
        """``A P Aᵀ (+ add)`` for symmetric ``P`` and ``add``: upper triangle, mirrored."""
        W = self.matmul(hint + "w", A, P)
        rows = len(A)
        result: Matrix = [[0.0] * rows for _ in range(rows)]
        for i in range(rows):
            for j in range(i, rows):
                parts = [product(W[i][k], A[j][k]) for k in range(len(P))]
                if add is not None:
                    parts.append(add[i][j])
                result[i][j] = result[j][i] = self.let(hint, parts)
        return result

    def symmetric_sum(self, hint: str, terms: Sequence[Matrix]) -> Matrix:
        """Sum of symmetric matrices (upper triangle computed, mirrored)."""
        size = len(terms[0])
        result: Matrix = [[0.0] * size for _ in range(size)]
        for i in range(size):
            for j in range(i, size):
                result[i][j] = result[j][i] = self.let(hint, [t[i][j] for t in terms])
        return result

    def cholesky(self, hint: str, S: Matrix) -> Matrix:
        """Lower Cholesky factor; a non-positive pivot gives NaN (caught by the caller)."""
        size = len(S)
        L: Matrix = [[0.0] * size for _ in range(size)]
        for j in range(size):
            pivot = self.let(
                hint + "p", [S[j][j], *[self._negated_product(L[j][k], L[j][k]) for k in range(j)]]
            )
            L[j][j] = self.assign(hint, f"math.sqrt({term(pivot)})")
            for i in range(j + 1, size):
                partial = self.let(
                    hint + "p",
                    [S[i][j], *[self._negated_product(L[i][k], L[j][k]) for k in range(j)]],
                )
                L[i][j] = (
                    partial
                    if partial == 0.0
                    else self.assign(hint, f"{term(partial)} / {term(L[j][j])}")
                )
        return L

    def _negated_product(self, a: Entry, b: Entry) -> Entry | None:
        value = product(a, b)
        if value is None:
            return None
        if isinstance(value, float):
            return -value
        return f"-{value}" if "*" not in value else f"-({value})"

    def forward_solve(self, hint: str, L: Matrix, b: Vector) -> Vector:
        """Solve ``L z = b`` for lower-triangular ``L``."""
        z: Vector = []
        for i in range(len(L)):
            partial = self.let(
                hint + "p", [b[i], *[self._negated_product(L[i][k], z[k]) for k in range(i)]]
            )
            z.append(
                partial
                if partial == 0.0
                else self.assign(hint, f"{term(partial)} / {term(L[i][i])}")
            )
        return z

    def backward_solve(self, hint: str, L: Matrix, b: Vector) -> Vector:
        """Solve ``Lᵀ z = b`` for lower-triangular ``L``."""
        size = len(L)
        z: Vector = [0.0] * size
        for i in range(size - 1, -1, -1):
            partial = self.let(
                hint + "p",
                [b[i], *[self._negated_product(L[k][i], z[k]) for k in range(i + 1, size)]],
            )
            z[i] = (
                partial
                if partial == 0.0
                else self.assign(hint, f"{term(partial)} / {term(L[i][i])}")
            )
        return z

    def gaussian_log_density(self, hint: str, gamma: Vector, L: Matrix) -> str:
        """``log N(γ; 0, L Lᵀ)``."""
        return self.gaussian_log_density_and_distance(hint, gamma, L)[0]

    def gaussian_log_density_and_distance(
        self, hint: str, gamma: Vector, L: Matrix
    ) -> tuple[str, str]:
        """``log N(γ; 0, L Lᵀ)`` and ``γᵀ (L Lᵀ)⁻¹ γ``, the squared distance in it."""
        density, quadratic, _ = self.gaussian_log_density_whitened(hint, gamma, L)
        return density, quadratic

    def gaussian_log_density_whitened(
        self, hint: str, gamma: Vector, L: Matrix
    ) -> tuple[str, str, Vector]:
        """As :meth:`gaussian_log_density_and_distance`, and the whitened ``z = L⁻¹ γ``."""
        z = self.forward_solve(hint + "z", L, gamma)
        quadratic = self.assign(
            hint + "q", " + ".join(f"{term(v)}*{term(v)}" for v in z if v != 0.0) or "0.0"
        )
        log_det = " + ".join(f"math.log({term(L[i][i])})" for i in range(len(L)))
        density = self.assign(hint, f"-0.5*{quadratic} - ({log_det}) - {0.5 * len(gamma)}*LOG_2PI")
        return density, quadratic, z

    def gain(self, hint: str, P: Matrix, H: Matrix, L: Matrix) -> Matrix:
        """Kalman gain ``P Hᵀ (L Lᵀ)⁻¹``, row by row."""
        PHt = self.matmul(hint + "ph", P, H, transpose_b=True)
        return [self.backward_solve(hint, L, self.forward_solve(hint + "f", L, row)) for row in PHt]

    def joseph(self, hint: str, P: Matrix, K: Matrix, H: Matrix, R: Matrix) -> Matrix:
        """``(I − K H) P (I − K H)ᵀ + K R Kᵀ`` (symmetric by construction)."""
        KH = self.matmul(hint + "kh", K, H)
        size = len(P)
        IKH: Matrix = [
            [self.difference(hint + "i", 1.0 if i == j else 0.0, KH[i][j]) for j in range(size)]
            for i in range(size)
        ]
        KRK = self.congruence(hint + "r", K, R)
        return self.congruence(hint, IKH, P, add=KRK)

    def kalman_update(
        self, hint: str, x: Vector, P: Matrix, H: Matrix, R: Matrix, gamma: Vector
    ) -> tuple[Vector, Matrix, Matrix]:
        """Measurement update with residual ``γ``: ``x + Kγ``, Joseph ``P``, and ``chol(S)``.

        ``S = H P Hᵀ + R`` and ``K = P Hᵀ S⁻¹``; the Cholesky factor of ``S`` is returned for
        callers whose likelihood uses this ``S``.
        """
        L = self.cholesky(hint + "l", self.congruence(hint + "s", H, P, add=R))
        K = self.gain(hint + "k", P, H, L)
        x_post = [
            self.let(hint + "x", [x[a], *[product(K[a][b], gamma[b]) for b in range(len(gamma))]])
            for a in range(len(x))
        ]
        return x_post, self.joseph(hint + "p", P, K, H, R), L

    def measured_flags(self, y: Vector) -> list[str]:
        """Emit whether each output of ``y`` was measured (not NaN) and ``left``, how many not.

        For an accelerator's ``masked`` code
        (:class:`~hybridlog.estimators.common.Accelerator`).
        """
        flags = [self.assign("ok", f"{term(value)} == {term(value)}") for value in y]
        self.emit("left = " + " + ".join(f"(0 if {flag} else 1)" for flag in flags))
        return flags

    def select(self, entry: Entry, flag: str, otherwise: float) -> Entry:
        """``entry if flag else otherwise``; ``entry`` itself where it is ``otherwise``."""
        if entry == otherwise:
            return entry
        return self.assign("lo", f"{term(entry)} if {flag} else {term(otherwise)}")

    def left_out_matrix(self, measured: Sequence[str], R: Matrix) -> Matrix:
        """``R`` with the rows and columns of the outputs not ``measured`` the identity's."""
        size = len(R)
        return [
            [
                self.select(R[b][c], measured[b], 1.0)
                if b == c
                else self.select(R[b][c], f"{measured[b]} and {measured[c]}", 0.0)
                for c in range(size)
            ]
            for b in range(size)
        ]

    def left_out(
        self, measured: Sequence[str], H: Matrix, R: Matrix, gamma: Vector
    ) -> tuple[Matrix, Matrix, Vector]:
        """``H``, ``R`` and ``γ`` of an update on the ``measured`` outputs alone.

        :func:`~hybridlog.estimators.kernels.leave_out_unmeasured` written out: the rows of
        ``H`` and ``γ`` of an output left out are 0, its rows and columns of ``R`` the
        identity's; structural zeros stay literals, every other entry is a selection.
        """
        H_left = [
            [self.select(entry, flag, 0.0) for entry in row]
            for row, flag in zip(H, measured, strict=True)
        ]
        gamma_left = [self.select(g, flag, 0.0) for g, flag in zip(gamma, measured, strict=True)]
        return H_left, self.left_out_matrix(measured, R), gamma_left

    def weighed_distance(self, distance: str, log_likelihood: str, possible: str = "") -> None:
        """``distance`` (``γᵀ S⁻¹ γ``) stays where the mode weighed the sample, else NaN.

        A mode weighs it where its ``S`` has a Cholesky factor and is finite (``S = ∞`` has
        log-likelihood ``-∞`` and a distance of 0 or NaN), ``possible`` (a condition, such as
        the IMM's ``c̄_j > 0``: a mode the transitions rule out weighs nothing) holding.  A
        distance that overflowed to ``∞`` (log-likelihood ``-∞``) is kept: the sample is too
        far from the mode for double precision, not unweighed
        (:func:`hybridlog.estimators.kernels.weighed_distance`, as the loops).
        """
        weighed = (
            f"({distance} < math.inf and {log_likelihood} > -math.inf or {distance} == math.inf)"
        )
        condition = f"{possible} and {weighed}" if possible else weighed
        self.emit(f"if not ({condition}): {distance} = math.nan")

    def nearest(self, distances: Sequence[str]) -> str:
        """The smallest of ``distances`` that is not NaN (NaN: all are), assigned to a name."""
        near = self.fresh("near")
        self.emit(f"{near} = math.nan")
        for distance in distances:
            self.emit(
                f"if {distance} == {distance} and not {near} <= {distance}: {near} = {distance}"
            )
        return near

    def minus_inf_if_nan(self, name: str) -> None:
        """A NaN (from a failed Cholesky factor) becomes ``-inf``: no weight for that mode."""
        self.emit(f"if {name} != {name}:")
        self.emit(f"    {name} = -math.inf")

    def mixture(
        self, hint: str, weights: Vector, means: Sequence[Vector], covariances: Sequence[Matrix]
    ) -> tuple[Vector, Matrix]:
        """Mean and covariance of a Gaussian mixture: ``Σ w_i (P_i + (x_i − x̄)(x_i − x̄)ᵀ)``."""
        size = len(means[0])
        mean = [
            self.let(hint + "m", [product(w, x[a]) for w, x in zip(weights, means, strict=True)])
            for a in range(size)
        ]
        deviations = [
            [self.difference(hint + "d", x[a], mean[a]) for a in range(size)] for x in means
        ]
        covariance: Matrix = [[0.0] * size for _ in range(size)]
        for a in range(size):
            for b in range(a, size):
                parts: list[Entry | None] = []
                for w, P, d in zip(weights, covariances, deviations, strict=True):
                    spread = self.let(hint + "s", [P[a][b], product(d[a], d[b])])
                    parts.append(product(w, spread))
                covariance[a][b] = covariance[b][a] = self.let(hint + "c", parts)
        return mean, covariance

    def scaled(self, hint: str, factor: Entry, matrix: Matrix) -> Matrix:
        """``factor · matrix`` for a symmetric matrix."""
        size = len(matrix)
        result: Matrix = [[0.0] * size for _ in range(size)]
        for a in range(size):
            for b in range(a, size):
                result[a][b] = result[b][a] = self.let(hint, [product(factor, matrix[a][b])])
        return result

    # -- the frame of a generated time loop ------------------------------------------------

    def prologue(self, settings: Sequence[str]) -> None:
        """First lines of every generated loop function: its frame, unpacked.

        The function takes the generic loop's frame without the model functions,
        ``(run, settings, chunk, out)`` (:class:`~hybridlog.estimators.common.FilterCode`);
        the ``settings`` record's fields are bound to their names, the chunk's rows to
        ``first`` and ``stop`` and its loop-carried state to ``state``
        (:class:`~hybridlog.estimators.common.Chunk`).
        """
        for name in ("inputs", "outputs", "x0", "P0", "mu0"):
            self.emit(f"{name} = run.{name}")
        for name in settings:
            self.emit(f"{name} = settings.{name}")
        for name in ("first", "stop", "state"):
            self.emit(f"{name} = chunk.{name}")
        for name, field in _OUTPUT_NAMES:
            self.emit(f"{name} = out.{field}")
        self.emit("n_samples = outputs.shape[0]")
        self.emit("store_covariances = covariances_out.shape[0] > 0")

    def function(self, name: str) -> str:
        """The emitted lines as the source of ``name(run, settings, chunk, out)``."""
        return f"def {name}(run, settings, chunk, out):\n{self.source()}\n"

    def resume(self, carried: Sequence[tuple[str, Entry]]) -> None:
        """Load the loop-carried variables from the chunk's state: ``(slot, name)`` pairs.

        A name given twice (both triangles of a symmetric matrix, :func:`state_slots`) is
        loaded once.
        """
        loaded: set[Entry] = set()
        for slot, name in carried:
            if name not in loaded:
                loaded.add(name)
                self.emit(f"{term(name)} = {slot}")

    def suspend(self, carried: Sequence[tuple[str, Entry]]) -> None:
        """Store the loop-carried variables into the chunk's state, for the next chunk."""
        for slot, name in carried:
            self.emit(f"{slot} = {term(name)}")

    def open_time_loop(
        self, n_inputs: int, n_outputs: int, *, chunk: bool = False
    ) -> tuple[Vector, Vector, Vector]:
        """Open the time loop and load ``u(k)``, ``u(k+1)`` and ``y(k+1)`` into scalars.

        Over every step of the log, or with ``chunk`` over the steps that compute the rows
        ``first … stop−1`` past row 0 (:meth:`prologue`), with ``row``, the output row of
        sample ``k+1`` in the chunk's buffers.
        """
        u, v, y = (
            vector_names("u", n_inputs),
            vector_names("v", n_inputs),
            vector_names("y", n_outputs),
        )
        steps = "range(max(first, 1) - 1, stop - 1)" if chunk else "range(n_samples - 1)"
        self.emit(f"for k in {steps}:")
        self.indent += "    "
        if chunk:
            self.emit("row = k + 1 - first")
        self.carry(u, [f"inputs[k, {c}]" for c in range(n_inputs)])
        self.carry(v, [f"inputs[k + 1, {c}]" for c in range(n_inputs)])
        self.carry(y, [f"outputs[k + 1, {b}]" for b in range(n_outputs)])
        return u, v, y

    def close_time_loop(self) -> None:
        """End the time loop: the lines after it run once, after the last step."""
        self.indent = self.indent[:-4]

    def carry(self, targets: Sequence[Entry], values: Sequence[Entry | str]) -> None:
        """Assign the new values to the loop-carried variables (``targets`` are names)."""
        for target, value in zip(targets, values, strict=True):
            self.emit(f"{term(target)} = {term(value)}")

    def named(self, hint: str, entries: Vector) -> list[str]:
        """Entries as variable names (literals are bound to variables), for model functions."""
        return [e if isinstance(e, str) else self.assign(hint, _literal(e)) for e in entries]

    def normalized_weights(self, log_weights: Vector, fallback: Vector) -> Vector:
        """``exp(w − logsumexp(w))``; ``fallback`` when no weight is finite."""
        top = self.assign("top", f"max({', '.join(term(w) for w in log_weights)})")
        out = [self.fresh("mu") for _ in log_weights]
        exps = [self.fresh("e") for _ in log_weights]
        inner = "    "
        self.emit(f"if -math.inf < {top} < math.inf:")
        for e, w in zip(exps, log_weights, strict=True):
            self.emit(f"{inner}{e} = math.exp({term(w)} - {top})")
        total = " + ".join(exps)
        for name, e in zip(out, exps, strict=True):
            self.emit(f"{inner}{name} = {e} / ({total})")
        self.emit("else:")
        for name, f in zip(out, fallback, strict=True):
            self.emit(f"{inner}{name} = {term(f)}")
        return list(out)

    def argmax(self, values: Vector) -> str:
        """Index of the largest value (the first on ties)."""
        best = self.fresh("best")
        top = self.fresh("top")
        self.emit(f"{best} = 0")
        self.emit(f"{top} = {term(values[0])}")
        for index, value in enumerate(values[1:], start=1):
            self.emit(f"if {term(value)} > {top}:")
            self.emit(f"    {best} = {index}")
            self.emit(f"    {top} = {term(value)}")
        return best

    def record(
        self, row: str, mode: str, probabilities: Vector, mean: Vector, covariance: Matrix
    ) -> None:
        """Write one row of the estimator's output arrays (``row``: its index there)."""
        self.emit(f"modes_out[{row}] = {mode}")
        for i, value in enumerate(probabilities):
            self.emit(f"probabilities_out[{row}, {i}] = {term(value)}")
        for a, value in enumerate(mean):
            self.emit(f"means_out[{row}, {a}] = {term(value)}")
            self.emit(f"variances_out[{row}, {a}] = {term(covariance[a][a])}")
        self.emit("if store_covariances:")
        for a in range(len(mean)):
            for b in range(len(mean)):
                self.emit(f"    covariances_out[{row}, {a}, {b}] = {term(covariance[a][b])}")

    def mode_values(
        self,
        model: HybridModel,
        mode: int,
        kind: str,
        states: Sequence[Entry],
        inputs: Sequence[Entry],
    ) -> Vector:
        """Emit one mode function (``f``, ``F``, ``h``, ``H``) at named states and inputs."""
        from hybridlog.model.codegen import emit_mode_function

        lines, entries = emit_mode_function(
            model,
            mode,
            kind,
            [term(x) for x in states],
            [term(x) for x in inputs],
            self.fresh(kind),
            self.indent,
        )
        self.lines.extend(lines)
        return entries

    def source(self) -> str:
        """The body as text."""
        return "\n".join(self.lines)


_OUTPUT_NAMES = (
    ("modes_out", "modes"),
    ("probabilities_out", "mode_probabilities"),
    ("means_out", "state_means"),
    ("variances_out", "state_variances"),
    ("predictions_out", "output_predictions"),
    ("covariances_out", "covariances"),
    ("surprise_out", "surprise"),
    ("whitened_out", "whitened"),
)
"""The generated code's names of the output arrays and their fields in ``FilterBuffers``."""


def reshape(entries: Sequence[Entry], rows: int, cols: int) -> Matrix:
    """Row-major entries as a matrix."""
    return [list(entries[i * cols : (i + 1) * cols]) for i in range(rows)]


def upper(matrix: Matrix) -> list[Entry]:
    """Upper-triangle entries, row by row."""
    return [matrix[i][j] for i in range(len(matrix)) for j in range(i, len(matrix))]


def matrix_names(prefix: str, rows: int, cols: int, *, symmetric: bool = False) -> Matrix:
    """Variable names ``prefix_i_j`` (upper-triangle names reused below the diagonal)."""
    return [
        [
            f"{prefix}_{min(i, j)}_{max(i, j)}" if symmetric else f"{prefix}_{i}_{j}"
            for j in range(cols)
        ]
        for i in range(rows)
    ]


def vector_names(prefix: str, size: int) -> Vector:
    """Variable names ``prefix_i``."""
    return [f"{prefix}_{i}" for i in range(size)]


def state_slots(
    field: str, entries: Sequence[Entry] | Matrix, *leading: int
) -> list[tuple[str, Entry]]:
    """``(slot, name)`` pairs of loop-carried variables and their places in ``state.<field>``.

    ``entries`` are the names of a vector or matrix (every entry of a matrix, so the state
    holds a symmetric one whole), stored at ``state.<field>[*leading, ...]`` (``leading``:
    the mode, for per-mode arrays); for :meth:`Program.resume` and :meth:`Program.suspend`.
    """
    head = "".join(f"{index}, " for index in leading)
    pairs: list[tuple[str, Entry]] = []
    for a, item in enumerate(entries):
        if isinstance(item, list):
            pairs += [(f"state.{field}[{head}{a}, {b}]", name) for b, name in enumerate(item)]
        else:
            pairs.append((f"state.{field}[{head}{a}]", item))
    return pairs


def constant_matrix(values: FloatArray) -> Matrix:
    """Literal entries of a numeric matrix."""
    return [[float(v) for v in row] for row in values.tolist()]


def noise_matrices(model: HybridModel) -> tuple[list[Matrix], list[Matrix]]:
    """Per-mode process and measurement covariances as literal matrices.

    A model whose file gives no measurement noise covariance is refused
    (:meth:`~hybridlog.model.hybrid_model.HybridModel.require_measurement_noise`): its
    NaN would be written into the code.
    """
    from hybridlog.model.hybrid_model import WEIGHS_OUTPUTS

    model.require_measurement_noise(f"the generated filter code{WEIGHS_OUTPUTS}")
    return (
        [constant_matrix(mode.process_noise) for mode in model.modes],
        [constant_matrix(mode.measurement_noise) for mode in model.modes],
    )


MAX_UNROLLED_SIZE = 6
"""Largest state or output dimension given straight-line code: the code grows with the cube
of the dimension, and beyond this the compiled loops of ``kernels.py`` compile faster."""


MAX_UNROLLED_MODES = 8
"""Most modes given straight-line code: the IMM's mixing and the searches grow with the
square of the mode count; a 30-mode model's code took minutes to compile, then overflowed
Python's recursion limit, where the compiled loops take seconds."""


MAX_UNROLLED_WORK = 1500
"""Largest :func:`unrolled_work` given straight-line code.  The IMM's straight-line filter,
first run of a model of ``q`` linear modes and ``n`` states and outputs, on 2 cores:

=====  ===========  ========  ==========  ==========
q × n  work          compile   µs/sample  loops' µs
=====  ===========  ========  ==========  ==========
3 × 3  162           8.6 s     4.3         9.0
4 × 4  512           17 s      4.5         10
2 × 6  576           19 s      11          25
4 × 6  1,440         48 s      9.5         26
8 × 6  4,032         190 s     26          29
=====  ===========  ========  ==========  ==========

The compile time grows with the work, the gain does not: past this bound the first run of a
model (``--mode-sequence kbest`` of 8 modes of 6 states: 363 s and 1.9 GB) waits minutes
for code that is hardly faster than the compiled loops, which compile once for every model."""


def unrolled_work(model: HybridModel) -> int:
    """``q² n² + q n³`` for ``q`` modes and ``n`` the larger of the state and output counts.

    The size of the straight-line code: the IMM's mixing writes out each pair of modes'
    covariance terms, each mode's update its matrix products.
    """
    n, q = max(model.n_states, model.n_outputs), model.n_modes
    return q * q * n * n + q * n**3


def fits_unrolled(model: HybridModel) -> bool:
    """Whether straight-line code pays for ``model``: it is small enough.

    At most :data:`MAX_UNROLLED_SIZE` states and outputs, :data:`MAX_UNROLLED_MODES` modes and
    :data:`MAX_UNROLLED_WORK` of :func:`unrolled_work`.
    """
    return (
        max(model.n_states, model.n_outputs) <= MAX_UNROLLED_SIZE
        and model.n_modes <= MAX_UNROLLED_MODES
        and unrolled_work(model) <= MAX_UNROLLED_WORK
    )


def use_unrolled(model: HybridModel, kernel: str) -> bool:
    """Whether a filter with straight-line code runs it for ``model`` under ``kernel``."""
    if kernel not in ("auto", "unrolled", "loops"):
        raise ValueError(f"unknown kernel {kernel!r}")
    if kernel == "auto":
        return fits_unrolled(model)
    return kernel == "unrolled"


def module_source(model: HybridModel, function_source: str) -> str:
    """A complete module around one generated function (``math`` and ``LOG_2PI`` in scope)."""
    return (
        f'"""Generated by hybridlog for model {model.name!r}: straight-line filter loop."""\n\n'
        "import math\n\nLOG_2PI = math.log(2.0 * math.pi)\n\n\n"
        f"{function_source}"
    )
