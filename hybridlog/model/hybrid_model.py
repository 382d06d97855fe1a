"""The hybrid model: what a model file describes, with symbolic mode equations.

Four kinds of model share :class:`HybridModel` (SPEC §6); flags say which one a model is:

- discrete or continuous time (:attr:`HybridModel.timebase`, :attr:`HybridModel.is_continuous`);
- modes written one by one (``[modes.<id>]``) or as the combinations of booleans
  (:attr:`HybridModel.boolean_affine`, paper 003);
- optional state-reset maps at switches (:attr:`HybridModel.jumps`, paper 004);
- concurrent component automata with an unknown mode (:attr:`HybridModel.components`,
  paper 002), whose modes are not enumerated (:attr:`HybridModel.modes` is empty).

The loader accepts every kind; an estimator that cannot handle one refuses it.
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Generic, Literal, TypeVar, overload

import numpy as np

from hybridlog.errors import ModelError
from hybridlog.model.keys import known_key, remember_key
from hybridlog.signals import FloatArray

if TYPE_CHECKING:
    import sympy

    from hybridlog.model.components import Component
    from hybridlog.model.scenario import Scenario

T = TypeVar("T")
D = TypeVar("D")

WEIGHS_OUTPUTS = " weighs the outputs by their measurement noise covariance"
"""What a filter does with ``R``, in the refusal of a model whose file gives none."""

DEFAULT_ESTIMATOR = "imm"
"""The estimator ``analyze`` runs without ``--estimator`` on a model that writes no
``default_estimator``."""


class Deferred:
    """Stands for a :class:`Symbolic` field's value until it is first read.

    A model read from the loaded-model cache (:mod:`hybridlog.model.cache`) holds its
    sympy expressions as ``Deferred`` values that rebuild the model from its text on first
    use, so a run that never reads an expression never imports sympy.
    """

    __slots__ = ("compute",)

    def __init__(self, compute: Callable[[], Any]) -> None:
        self.compute = compute


_MISSING: Any = object()


class Symbolic(Generic[T]):
    """Dataclass field (a data descriptor) holding sympy objects, or a :class:`Deferred`.

    Reading the field returns the value, computing a :class:`Deferred` once on first
    read; :func:`stored` peeks at what is held without computing it.
    """

    def __init__(self, default: T = _MISSING) -> None:
        self.default = default
        self.name = ""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    @overload
    def __get__(self, instance: None, owner: type) -> T: ...

    @overload
    def __get__(self, instance: object, owner: type) -> T: ...

    def __get__(self, instance: object | None, owner: type) -> T:
        if instance is None:  # the dataclass asks for the default
            if self.default is _MISSING:
                raise AttributeError(self.name)
            return self.default
        value = instance.__dict__[self.name]
        if isinstance(value, Deferred):
            value = value.compute()
            instance.__dict__[self.name] = value
        result: T = value
        return result

    def __set__(self, instance: object, value: T | Deferred) -> None:
        instance.__dict__[self.name] = value


def stored(instance: object, name: str) -> Any:
    """The value a :class:`Symbolic` field holds, a :class:`Deferred` left as it is."""
    return instance.__dict__[name]


def replaced(instance: D, **changes: Any) -> D:
    """:func:`dataclasses.replace` that carries the :class:`Symbolic` fields as held.

    ``dataclasses.replace`` reads every field it is not given, which computes a
    :class:`Deferred` (on a model read from the cache: sympy and the loader, 2 s of a warm
    run); here a field not in ``changes`` is passed on as :func:`stored` holds it.  The
    field's descriptor is looked up along the class's bases (a dataclass that extends one
    with a :class:`Symbolic` field inherits the descriptor, not its entry in ``__dict__``).
    """
    cls = type(instance)
    held = {
        item.name: stored(instance, item.name)
        for item in dataclasses.fields(instance)  # type: ignore[arg-type]
        if item.init
        and item.name not in changes
        and isinstance(inspect.getattr_static(cls, item.name, None), Symbolic)
    }
    return dataclasses.replace(instance, **held, **changes)  # type: ignore[type-var]


class _NoInputs(Mapping[str, Any]):
    """The empty, immutable (so hashable) default of ``simulation_inputs``."""

    def __getitem__(self, key: str) -> Any:
        raise KeyError(key)

    def __iter__(self) -> Iterator[str]:
        return iter(())

    def __len__(self) -> int:
        return 0

    def __hash__(self) -> int:
        return 0

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Mapping) and not other


NO_INPUTS: Mapping[str, Any] = _NoInputs()


TimeKind = Literal["discrete", "continuous"]
IntegrationMethod = Literal["euler", "rk4"]
INTEGRATION_METHODS: tuple[IntegrationMethod, ...] = ("euler", "rk4")


@dataclass(frozen=True)
class Timebase:
    r"""How the model's time advances.

    Discrete time (``time = "discrete"``): ``x(k+1) = f_q(x(k), u(k))`` every ``dt`` seconds.
    Continuous time (``time = "continuous"``): :math:`\dot x = f_q(x, u)` integrated with a
    fixed step ``step`` by ``method`` (``"euler"`` or classical ``"rk4"``), inputs held
    between samples, outputs sampled every ``dt`` seconds; ``dt`` is an integer multiple of
    ``step``.

    Attributes
    ----------
    kind:
        ``"discrete"`` or ``"continuous"``.
    dt:
        Sample time of inputs and outputs, in seconds.
    step:
        Integration step in seconds (``dt`` for a discrete model).
    method:
        Integration method of a continuous model; ``None`` for a discrete one.
    """

    kind: TimeKind
    dt: float
    step: float
    method: IntegrationMethod | None

    @property
    def is_continuous(self) -> bool:
        """True for ``time = "continuous"``."""
        return self.kind == "continuous"

    @property
    def substeps(self) -> int:
        """Integration steps per sample, ``dt / step`` (1 for a discrete model)."""
        return max(1, round(self.dt / self.step))


@dataclass(frozen=True)
class LinearForm:
    r"""Numeric matrices of a mode that is affine in the states and inputs.

    .. math::

        x^+ = A x + B u + c, \qquad y = C x + D u + d

    where :math:`x^+` is ``x(k+1)`` in discrete time and :math:`\dot x` in continuous time.

    Attributes
    ----------
    A, B, C, D:
        Shapes ``(n_x, n_x)``, ``(n_x, n_u)``, ``(n_y, n_x)``, ``(n_y, n_u)``.
    state_offset, output_offset:
        The affine terms ``c`` ``(n_x,)`` and ``d`` ``(n_y,)``; zero for a mode given as
        matrices.
    """

    A: FloatArray
    B: FloatArray
    C: FloatArray
    D: FloatArray
    state_offset: FloatArray
    output_offset: FloatArray


@dataclass(frozen=True)
class Mode:
    r"""One discrete mode of a switched system.

    .. math::

        x(k+1) = f_q(x(k), u(k)) + \xi(k), \qquad y(k) = h_q(x(k), u(k)) + \omega(k)

    (paper 000, eq. (2)) in discrete time, or :math:`\dot x = f_q(x, u)` in continuous time
    (papers 003 eq. (1), 004 eq. (2)).  Expressions are sympy expressions in the model's
    state and input symbols with every parameter already substituted.

    Attributes
    ----------
    id:
        The mode id as written in the model file (``"1"``, ``"valve_open"`` ...).
    f:
        Next-state expressions, one per state, of a discrete-time model; empty in
        continuous time.
    h:
        Output expressions, one per output.
    process_noise:
        Covariance ``Q_q = g_q R_ξ g_qᵀ`` of the additive process noise, ``(n_x, n_x)``.
    measurement_noise:
        Covariance ``R_q`` of the measurement noise, ``(n_y, n_y)``; NaN throughout when
        the model file gives none (neither ``[noise] measurement`` nor the mode's own
        ``measurement_noise``): a covariance no estimator may guess
        (:meth:`HybridModel.unstated_measurement_noise`).
    dx:
        Time derivatives, one per state, of a continuous-time model; empty in discrete
        time.
    guard:
        Condition on the states and inputs under which the mode is active (``guard =
        "x3 <= 0"``), a sympy relational; ``None`` when the model is switched by a schedule.
    linear_form:
        The mode's matrices when ``f`` (or ``dx``) and ``h`` are affine in the states and
        inputs (given as ``A``, ``B``, ``C``, ``D`` or as expressions whose Jacobian is
        constant); ``None`` for a nonlinear mode.
    nonlinear_key:
        For a nonlinear mode, the key of its first expression that is not affine
        (``modes.2.f[0]``); empty for a linear one.
    process_noise_key, measurement_noise_key:
        The model-file keys the two covariances came from (``noise.process`` or
        ``modes.2.process_noise``), so later errors about them name the key to change.
    """

    id: str
    process_noise: FloatArray
    measurement_noise: FloatArray
    f: Symbolic[tuple[sympy.Expr, ...]] = Symbolic()
    h: Symbolic[tuple[sympy.Expr, ...]] = Symbolic()
    dx: Symbolic[tuple[sympy.Expr, ...]] = Symbolic(())
    guard: Symbolic[sympy.Basic | None] = Symbolic(None)
    linear_form: LinearForm | None = None
    nonlinear_key: str = ""
    process_noise_key: str = "noise.process"
    measurement_noise_key: str = "noise.measurement"

    @property
    def dynamics(self) -> tuple[sympy.Expr, ...]:
        """``f`` of a discrete-time mode or ``dx`` of a continuous-time one."""
        return self.dx if self.dx else self.f

    @property
    def measurement_noise_stated(self) -> bool:
        """True when the model file gives this mode's measurement noise covariance."""
        return not bool(np.isnan(self.measurement_noise).any())

    @property
    def has_guard(self) -> bool:
        """True when the mode has a guard (known without building the guard's expression)."""
        return stored(self, "guard") is not None


@dataclass(frozen=True)
class Jump:
    r"""A state-reset map applied when the mode switches (paper 004, eq. (3)).

    .. math::

        x(t_j) = R(\sigma(t_j^-), \sigma(t_j), x(t_j^-))

    Written ``[jumps."a->b"]`` with one expression per reset state; states not listed keep
    their value.  ``"*->b"`` applies to every switch into ``b`` that has no map of its own.

    Attributes
    ----------
    source:
        Mode id before the switch, or ``None`` for ``*`` (any other mode).
    target:
        Mode id after the switch.
    reset:
        ``R``: the new value of every state (the identity for states not listed), as
        expressions in the states before the switch and the parameters.
    key:
        The model-file key (``jumps."1->2"``).
    """

    source: str | None
    target: str
    key: str
    reset: Symbolic[tuple[sympy.Expr, ...]] = Symbolic()


@dataclass(frozen=True)
class BooleanAffine:
    r"""A boolean-affine switched system (paper 003, eq. (1)).

    .. math::

        \dot x = G(x, u) + D(x, u)\,\delta(\sigma), \qquad \delta \in \{0, 1\}^L

    written once with the booleans as symbols; the model's modes are the ``2^L``
    combinations, numbered by eq. (48): :math:`\sigma = \sum_j \delta_j 2^{L-j}` (the first
    boolean is the most significant bit), mode id ``str(σ)``.  ``G`` and ``D`` are derived
    by the estimators that need them; the loader only checks that the expressions are
    affine in the booleans.

    Attributes
    ----------
    booleans:
        The boolean names ``δ_1 … δ_L``, in the file's order.
    dynamics:
        ``dx`` (or ``f`` in discrete time) with the boolean symbols, one per state.
    h:
        Output expressions, which may use the booleans too.
    key:
        The model-file key of the equations (``dynamics``).
    """

    booleans: tuple[str, ...]
    dynamics: Symbolic[tuple[sympy.Expr, ...]] = Symbolic()
    h: Symbolic[tuple[sympy.Expr, ...]] = Symbolic()
    key: str = "dynamics"

    def symbols(self) -> tuple[sympy.Symbol, ...]:
        """Sympy symbols of the booleans (real)."""
        import sympy

        return tuple(sympy.Symbol(b, real=True) for b in self.booleans)

    def delta(self, sigma: int) -> tuple[int, ...]:
        """The boolean vector δ(σ) of mode σ, eq. (48): δ_1 is the most significant bit."""
        n = len(self.booleans)
        if not 0 <= sigma < 2**n:
            raise ValueError(f"sigma must be in 0..{2**n - 1}, got {sigma}")
        return tuple((sigma >> (n - 1 - j)) & 1 for j in range(n))


_KEY_STATE = "__content_key__"
"""Where a pickled :class:`HybridModel` carries its content key (:mod:`hybridlog.model.keys`)."""


def outputs_differ(modes: Sequence[Mode]) -> bool:
    """True when some of ``modes`` have different output equations ``h``.

    Compared as matrices (``C``, ``D`` and the offset) where every mode is affine, so a
    large linear model builds no expressions; as expressions otherwise.  False without
    modes (a ``[components]`` model, whose joint modes are enumerated later).
    """
    forms = [m.linear_form for m in modes]
    if forms and all(form is not None for form in forms):
        first, *others = [f for f in forms if f is not None]
        return any(
            not (
                np.array_equal(f.C, first.C)
                and np.array_equal(f.D, first.D)
                and np.array_equal(f.output_offset, first.output_offset)
            )
            for f in others
        )
    written = [tuple(m.h) for m in modes]
    return any(not _same_expressions(written[0], other) for other in written[1:])


_EXPANDED_OPS = 200
"""The size (``sympy.count_ops``) up to which two written forms are compared expanded."""


def _same_expressions(a: tuple[sympy.Expr, ...], b: tuple[sympy.Expr, ...]) -> bool:
    """Whether two tuples of expressions are the same functions, as far as expanding tells.

    As written first; then the expansion of each difference (``sin(x)*(x + 1)`` and
    ``sin(x)*x + sin(x)``), for expressions small enough that expanding cannot blow up
    (``(x + 1)**1000``); larger ones that differ as written count as different.
    """
    if a == b:
        return True
    if len(a) != len(b):
        return False
    import sympy  # parsing a model imported it already; a warm run keeps the answer

    for left, right in zip(a, b, strict=True):
        if left == right:
            continue
        if sympy.count_ops(left) + sympy.count_ops(right) > _EXPANDED_OPS:
            return False
        if sympy.expand(left - right) != 0:
            return False
    return True


@dataclass(frozen=True)
class HybridModel:
    """A hybrid (switched) system read from a model file.

    Attributes
    ----------
    name, description, reference:
        Free text from the model file; ``reference`` names paper and equations.
    timebase:
        Discrete or continuous time, the sample time and the integration step.
    states, inputs, outputs:
        Symbol names, in the order of the state, input and output vectors.
    parameters:
        Parameter values (after ``--set`` overrides), already substituted into the modes.
    modes:
        The modes, in the order of the file; their index is the mode index used everywhere.
        Empty for a components model (its modes are per component).
    initial_state, initial_covariance, initial_mode_probabilities:
        The estimators' prior ``x̂(0|0)``, ``P(0|0)`` and ``Pr(q(0))``.
    transitions:
        Markov matrix ``Π[i, j] = Pr(q(k+1)=j | q(k)=i)``, or ``None`` when the file has none.
    signals, truth:
        The model file's log paths (``[signals]``, ``[truth]``): ``signals`` of inputs and
        outputs, ``truth`` of the true mode (``mode``; ``mode.<component>`` in a components
        model) and of states.  No other key (the loader refuses them).
    default_estimator:
        Estimator used by ``analyze`` when none is named; ``None`` where the file writes
        none, and ``analyze`` then runs :data:`DEFAULT_ESTIMATOR`
        (:attr:`estimator_by_default`).
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
    jumps:
        State-reset maps at switches (``[jumps."a->b"]``), see :meth:`reset_map`.
    boolean_affine:
        The boolean-affine form when the model has ``booleans``; ``None`` otherwise.
    components:
        The component automata of a ``[components.*]`` model (paper 002); empty otherwise.
    variables, commands:
        A components model's internal variables (neither states nor measured) and its
        command (discrete input) names.
    scenario:
        A components model's ``[simulation]`` scenario (:mod:`hybridlog.model.scenario`);
        ``None`` for the other kinds.
    twin_modes:
        Groups of modes with the same equations, noise, guard and jump maps
        (:func:`hybridlog.model.twins.twin_modes`), which no log can tell apart; empty
        when every mode differs.
    component_twin_modes:
        A ``[components]`` model's twins: ``(component, mode ids)`` for each group of one
        component's modes with the same equations and noise
        (:func:`hybridlog.model.twins.component_twin_modes`); empty otherwise.
    diagnoses:
        What the model's equations say of its estimability (outputs that see no state,
        unobservable states, undamped components without process noise, an integration
        step too long for a mode), one line each, ``WARNING: `` or ``NOTE: ``
        (:func:`hybridlog.model.diagnosis.diagnose`, without the linearisations of nonlinear
        modes, which give notes only); every report repeats the warnings.
    outputs_differ:
        :func:`outputs_differ` of the modes, found when the file was parsed and kept in the
        cache, so that a warm run answers without sympy; ``None``: found when asked.
    """

    name: str
    description: str
    reference: str
    timebase: Timebase
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
    default_estimator: str | None = None
    estimator_options: dict[str, dict[str, Any]] = field(default_factory=dict)
    simulation_state: FloatArray | None = None
    simulation_inputs: Symbolic[Mapping[str, sympy.Expr]] = Symbolic(NO_INPUTS)
    simulation_schedule: str = ""
    simulation_state_min: FloatArray | None = None
    source: str = ""
    origin: str = ""
    jumps: tuple[Jump, ...] = ()
    boolean_affine: BooleanAffine | None = None
    components: tuple[Component, ...] = ()
    variables: tuple[str, ...] = ()
    commands: tuple[str, ...] = ()
    scenario: Scenario | None = None
    twin_modes: tuple[tuple[str, ...], ...] = ()
    component_twin_modes: tuple[tuple[str, tuple[str, ...]], ...] = ()
    diagnoses: tuple[str, ...] = ()
    outputs_differ: bool | None = field(default=None, compare=False, repr=False)

    def __getstate__(self) -> dict[str, Any]:
        """The fields, and the content key when this process knows it.

        The key is what a process that receives the model pickled (the estimators' worker)
        would otherwise compute again, parsing every equation with sympy (about 0.5 s for
        the three-tank model) before it can load the model's compiled code.
        """
        return {**self.__dict__, _KEY_STATE: known_key(self)}

    def __setstate__(self, state: dict[str, Any]) -> None:
        """Restore the fields; record the content key that came with them."""
        key = state.pop(_KEY_STATE, None)
        self.__dict__.update(state)
        if key is not None:
            remember_key(self, key)

    @property
    def dt(self) -> float:
        """Sample time in seconds (of the outputs, for a continuous-time model)."""
        return self.timebase.dt

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
        """Number of discrete modes (0 for a components model)."""
        return len(self.modes)

    @property
    def state_driven(self) -> bool:
        """True when the modes switch by their guards (state-driven switching)."""
        return any(m.has_guard for m in self.modes)

    @property
    def outputs_differ_by_mode(self) -> bool:
        """True when some modes' output equations ``h`` differ (:func:`outputs_differ`).

        The answer kept when the file was parsed (:attr:`outputs_differ`): a nonlinear
        model's ``h`` loaded from the cache is parsed with sympy when asked, 0.4 s of every
        warm ``hstf`` run.
        """
        if self.outputs_differ is not None:
            return self.outputs_differ
        return outputs_differ(self.modes)

    @property
    def is_continuous(self) -> bool:
        """True for a continuous-time model (``time = "continuous"``)."""
        return self.timebase.is_continuous

    @property
    def estimator_by_default(self) -> str:
        """The estimator ``analyze`` runs without ``--estimator``.

        The file's ``default_estimator``, else :data:`DEFAULT_ESTIMATOR`.
        """
        return self.default_estimator or DEFAULT_ESTIMATOR

    @property
    def has_jumps(self) -> bool:
        """True when the model has state-reset maps (``[jumps."a->b"]``)."""
        return bool(self.jumps)

    @property
    def has_booleans(self) -> bool:
        """True for a boolean-affine model (``booleans = [...]``)."""
        return self.boolean_affine is not None

    @property
    def has_components(self) -> bool:
        """True for a concurrent-automata model (``[components.*]``)."""
        return bool(self.components)

    @property
    def mode_ids(self) -> tuple[str, ...]:
        """Mode ids in index order."""
        return tuple(m.id for m in self.modes)

    def mode_index(self, mode_id: str) -> int:
        """Index of the mode with id ``mode_id``; raises ``KeyError`` when there is none."""
        return self.mode_ids.index(mode_id)

    def symbols(self) -> tuple[list[sympy.Symbol], list[sympy.Symbol]]:
        """Sympy symbols of the states and of the inputs."""
        import sympy

        return (
            [sympy.Symbol(s, real=True) for s in self.states],
            [sympy.Symbol(u, real=True) for u in self.inputs],
        )

    def error(self, key: str, message: str) -> ModelError:
        """A :class:`ModelError` naming the model file (or built-in) and ``key``.

        For errors found after loading (a covariance a filter cannot use, a nonlinear mode
        given to a linear estimator), so that they read like the loader's own.
        """
        return ModelError(f"{self.origin or self.name}: {key}: {message}")

    def unstated_measurement_noise(self) -> str | None:
        """Where the model file gives no measurement noise covariance, or None.

        ``the model gives no measurement noise covariance for mode '2': add [noise]
        measurement (or modes.2.measurement_noise)``, for the first mode (or component
        mode and output) without one.  The loader records a covariance the file does not
        give as NaN instead of guessing one; what weighs the outputs by it (the filters,
        ``simulate``'s noise) refuses such a model with this.
        """
        from hybridlog.model.toml_text import key_path

        mode_id = next((m.id for m in self.modes if not m.measurement_noise_stated), None)
        if mode_id is not None:
            where = f"mode '{mode_id}'"
            own = (
                "dynamics.measurement_noise"
                if self.has_booleans
                else f"{key_path('modes', mode_id)}.measurement_noise"
            )
        else:
            unstated = (
                (component.name, spec, output)
                for component in self.components
                for spec in component.modes
                for output, variance in spec.measurement_noise.items()
                if np.isnan(variance)
            )
            first = next(unstated, None)
            if first is None:
                return None
            name, spec, output = first
            where = f"output '{output}' in mode '{spec.id}' of component '{name}'"
            own = f"{spec.key}.measurement_noise"
        return (
            f"the model gives no measurement noise covariance for {where}: add "
            f"[noise] measurement (or {own})"
        )

    def require_measurement_noise(self, needs: str) -> None:
        """Refuse a model whose file gives no measurement noise covariance ``needs`` uses.

        ``needs`` says who uses it and how (``"estimator 'imm' weighs the outputs by their
        measurement noise covariance"``).

        Raises
        ------
        ModelError
            ``"<file>: noise.measurement: <needs>; the model gives no measurement noise
            covariance for mode '1': add [noise] measurement (or ...)"``.
        """
        problem = self.unstated_measurement_noise()
        if problem is not None:
            raise self.error("noise.measurement", f"{needs}; {problem}")

    def check_supported(
        self,
        what: str,
        *,
        continuous: bool = False,
        jumps: bool = False,
        components: bool = False,
    ) -> None:
        """Refuse a model with a feature ``what`` cannot handle, naming the file and key.

        Code written for discrete-time models with enumerated modes would silently compute
        wrong numbers on the other kinds (a continuous model has no ``f``, a components
        model no ``modes``, jump maps would be ignored); it calls this first.

        Parameters
        ----------
        what:
            What refuses, for the message (``"simulate"``, ``"estimator 'hstf'"``).
        continuous, jumps, components:
            Whether ``what`` handles continuous time, jump maps, components models.

        Raises
        ------
        ModelError
            ``"<file>: time: simulate needs a discrete-time model; ..."`` and the like.
        """
        if self.has_components and not components:
            raise self.error(
                "components",
                f"{what} does not handle components models (paper 002); they have no "
                "enumerated modes",
            )
        if self.is_continuous and not continuous:
            raise self.error(
                "time",
                f"{what} needs a discrete-time model; this one is continuous-time (dx)",
            )
        if self.has_jumps and not jumps:
            raise self.error(self.jumps[0].key, f"{what} does not apply jump maps")

    def linear_modes(self) -> tuple[LinearForm, ...]:
        """The matrices of every mode, for estimators that need a linear switched model.

        In continuous time they are the matrices of ``dx`` (``ẋ = A x + B u + c``), not of
        a sampled system; check :attr:`is_continuous`.

        Raises
        ------
        ModelError
            Naming the model file, the first nonlinear mode and its first expression that
            is not affine in the states and inputs (``modes.2.f[1]``).
        """
        if not self.modes:
            raise self.error("components", "a components model has no enumerated modes")
        forms = []
        for mode in self.modes:
            if mode.linear_form is None:
                raise self.error(
                    mode.nonlinear_key,
                    f"mode '{mode.id}' is not linear (not affine in the states and inputs)",
                )
            forms.append(mode.linear_form)
        return tuple(forms)

    def jump_between(self, source: int, target: int) -> Jump | None:
        """The jump applied at a switch from mode index ``source`` to ``target``, if any.

        A map written for the pair (``"a->b"``) wins over one for any source (``"*->b"``);
        ``None`` means the state is continuous across this switch (``R`` is the identity).
        """
        if source == target:
            return None
        source_id, target_id = self.modes[source].id, self.modes[target].id
        wildcard = None
        for jump in self.jumps:
            if jump.target != target_id:
                continue
            if jump.source == source_id:
                return jump
            if jump.source is None:
                wildcard = jump
        return wildcard

    def reset_map(self, source: int, target: int) -> tuple[sympy.Expr, ...] | None:
        """The jump map ``R`` of :meth:`jump_between`; ``None``: the identity."""
        jump = self.jump_between(source, target)
        return None if jump is None else jump.reset


def markov_matrix(stay: float, n_modes: int) -> FloatArray:
    """Markov matrix with ``stay`` on the diagonal and the rest spread evenly over the others."""
    if n_modes == 1:
        return np.ones((1, 1))
    off = (1.0 - stay) / (n_modes - 1)
    return np.full((n_modes, n_modes), off) + np.eye(n_modes) * (stay - off)
