"""Options of paper 001's estimators ``chiu`` and ``kmeans`` (a light module).

The options dataclasses live apart from the estimators, which import numba, scipy and cvxpy,
so that the registry, ``--help`` and ``hybridlog cluster``'s generated options can read them
without loading those libraries; the clustering types they convert to are imported when a
conversion is asked for.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Literal

from hybridlog.errors import OptionError, excerpt
from hybridlog.estimators.options import OptionSource, option, parse_options, shown

if TYPE_CHECKING:
    from hybridlog.cluster.centers_file import CentersFile
    from hybridlog.cluster.kmeans import KMeansParameters
    from hybridlog.cluster.regressors import RegressorSpec
    from hybridlog.cluster.subtractive import ClusteringOptionError, SubtractiveOptions
    from hybridlog.errors import HybridlogError
    from hybridlog.model.hybrid_model import HybridModel

__all__ = [
    "ChiuOptions",
    "KMeansOptions",
    "ObserverOptions",
    "check_centers",
    "check_cluster_modes",
    "clustering_error",
]


def _output_lags(text: str) -> None:
    """``output_lags``' check, so that a bad value is named where it was set."""
    from hybridlog.cluster.regressors import lag_values

    lag_values(text, output=True)


def _input_lags(text: str) -> None:
    """``input_lags``' check (see :func:`_output_lags`)."""
    from hybridlog.cluster.regressors import lag_values

    lag_values(text, output=False)


@dataclass(frozen=True)
class ObserverOptions:
    """Options of paper 001's pipeline shared by ``chiu`` and ``kmeans``."""

    output_lags: str = option(
        "0,1",
        "lags of every output in φ(k), e.g. 0,1; must contain 0",
        check=_output_lags,
        items=int,
    )
    input_lags: str = option(
        "1", "lags of every input in φ(k), e.g. 1", check=_input_lags, items=int
    )
    centers: str = option(
        "",
        "centers.json of hybridlog cluster to use instead of fitting (from a model file's folder)",
        path=True,
    )
    cluster_modes: str = option(
        "",
        "mode ids of the clusters in order, e.g. 2,1 (empty: automatic labelling)",
        items=str,
    )
    decay_rate: float = option(
        1.0, "decay rate ρ of the LMI (15) (1: the paper's condition)", range=(1e-6, 1.0)
    )

    algorithm: ClassVar[str]
    """The clustering's name: its key in a ``centers.json``."""

    def invalid_on(self, model: HybridModel) -> dict[str, str]:
        """Values ``model`` cannot take: name → why (``cluster_modes`` naming no mode of it).

        The running estimator's are checked again with the centres (:func:`check_cluster_modes`);
        this names a model file's key whichever estimator runs.
        """
        from hybridlog.numbers import comma_items

        try:
            ids = comma_items(self.cluster_modes, "mode ids")
        except ValueError as err:
            return {"cluster_modes": str(err)}
        unknown = [mode for mode in ids if mode not in model.mode_ids]
        if unknown:
            return {
                "cluster_modes": f"unknown mode {excerpt(unknown[0])} (modes: "
                f"{', '.join(model.mode_ids)})"
            }
        return {}

    def from_files(self) -> dict[str, str]:
        """Option → the file's key its value is read from, for those the ``centers`` file gives.

        Loaded centres are used as the file records they were fitted (:func:`check_centers`),
        so the report gives the file's clustering options, whose ``origins`` said
        ``default``: ``radius`` 0.3 from centres fitted with it (report.json,
        :func:`hybridlog.jobs.origins.run_values`).
        """
        if not self.centers:
            return {}
        shared = {f.name for f in dataclasses.fields(ObserverOptions)}
        return {
            f.name: f"{self.centers}: {self.algorithm}.parameters.{f.name}"
            for f in dataclasses.fields(self)
            if f.name not in shared
        }

    def regressor_spec(self) -> RegressorSpec:
        """The lags of φ(k) (``output_lags``, ``input_lags``)."""
        from hybridlog.cluster.regressors import RegressorSpec, parse_lags

        return RegressorSpec(
            output_lags=parse_lags(self.output_lags, "output_lags"),
            input_lags=parse_lags(self.input_lags, "input_lags"),
        )


@dataclass(frozen=True)
class ChiuOptions(ObserverOptions):
    """Options of the ``chiu`` estimator (clustering defaults: MATLAB ``subclust``)."""

    algorithm: ClassVar[str] = "chiu"

    radius: float = option(
        0.5, "cluster radius r_a of eq. (5), in unit-box units", range=(1e-3, 100.0)
    )
    squash: float = option(
        1.25,
        "r_b/r_a of the revision eqs. (6)-(7) (r_b must exceed r_a)",
        range=(1.0, 100.0),
        above=True,
    )
    accept: float = option(  # above 0: reject lies between (0 < reject < accept <= 1)
        0.5, "acceptance ratio ε₁ of a new centre", range=(0.0, 1.0), above=True
    )
    reject: float = option(
        0.15,
        "rejection ratio ε₂ of a new centre; below accept",
        range=(0.0, 1.0),
        above=True,
        below=True,  # below accept <= 1: 1 never passes
    )
    self_potential: bool = option(
        True, "count each point in its own potential (false: eq. (5) as printed)"
    )
    method: Literal["auto", "exact", "approximate"] = option(
        "auto", "potentials: exact all-pairs, approximate on a grid, or auto by size"
    )

    def conflicts(self) -> list[tuple[str, str, str]]:
        """``reject`` at or above ``accept``: subtractive clustering needs ε₂ < ε₁.

        Refused only when ``chiu`` ran (after the options were parsed), ``accept = 0.1``
        under ``[estimators.chiu]`` passed when ``kmeans`` ran.
        """
        if self.reject >= self.accept:
            why = f"{shown(self.reject)} is not below {{other}}: need 0 < reject < accept <= 1"
            return [("reject", "accept", why)]
        return []

    def clustering(self) -> SubtractiveOptions:
        """The subtractive-clustering part of the options."""
        from hybridlog.cluster.subtractive import SubtractiveOptions

        return SubtractiveOptions(
            radius=self.radius,
            squash=self.squash,
            accept=self.accept,
            reject=self.reject,
            self_potential=self.self_potential,
            method=self.method,
        )


@dataclass(frozen=True)
class KMeansOptions(ObserverOptions):
    """Options of the ``kmeans`` estimator; the lags, centres and labels are as for ``chiu``."""

    algorithm: ClassVar[str] = "kmeans"

    clusters: int | None = option(
        None, "number of k-means centres (none: the number of modes)", range=(1, 1000)
    )
    restarts: int = option(10, "k-means++ runs; the one of least inertia is kept", range=(1, 1000))
    seed: int = option(0, "seed of the first run (then seed+1, ...)", range=(0, 2**31))

    def clustering(self) -> KMeansParameters:
        """The k-means part of the options."""
        from hybridlog.cluster.kmeans import KMeansParameters

        return KMeansParameters(clusters=self.clusters, restarts=self.restarts, seed=self.seed)


def _check_consistent(
    model: HybridModel, options: ObserverOptions, centers: CentersFile, source: str
) -> None:
    """Refuse a file whose recorded keys contradict its centres (edited by hand).

    ``output_lags``/``input_lags`` must give its ``regressors``, its ``modes`` must give
    centres of the same ``y(k)`` one mode (:func:`~hybridlog.cluster.labels.twin_conflict`),
    ``decision_values`` must be its centres' ``y(k)`` components (eq. (3) decides by those,
    so an edited ``decision_values`` was ignored without a word), and its ``parameters``
    must be values of the options (``"radius": "big"`` was reported as the radius the
    centres were fitted with),
    ``clusters`` the number of centres.
    """
    from hybridlog.cluster.regressors import RegressorSpec

    entry = centers.clusters[options.algorithm]
    try:
        own = RegressorSpec(centers.output_lags, centers.input_lags)
    except OptionError:
        own = None
    if own is None or own.names(model.outputs, model.inputs) != list(centers.regressors):
        raise OptionError(
            f"centers={source}: output_lags {list(centers.output_lags)}, input_lags "
            f"{list(centers.input_lags)} do not give the file's regressors "
            f"{list(centers.regressors)}"
        )
    key = f"{options.algorithm}.decision_values"
    if entry.decision_values is not None:
        columns = own.decision_columns(len(model.outputs))
        if (
            entry.decision_values.shape != (len(entry.centers), len(columns))
            or not (entry.decision_values == entry.centers[:, columns]).all()
        ):
            raise OptionError(
                f"centers={source}: {key}: not the y(k) components of the file's "
                f"{options.algorithm}.centers (eq. (3) decides by those): edit both alike, or "
                f"leave {key} out"
            )
    if entry.modes is not None:  # before the log is read, as stored_classifier refuses it
        import numpy as np

        from hybridlog.cluster.labels import twin_conflict

        modes = [centers.mode_ids.index(mode) for mode in entry.modes]
        decision = entry.centers[:, own.decision_columns(len(model.outputs))]
        conflict = twin_conflict(np.array(modes), decision, centers.mode_ids)
        if conflict is not None:
            raise OptionError(f"centers={source}: {options.algorithm}.modes: {conflict}")
    prefix = f"centers={source}: {options.algorithm}.parameters"
    sources = {k: OptionSource(f"{prefix}.{k}", text=False) for k in entry.parameters}
    parse_options(type(options), entry.parameters, estimator=options.algorithm, sources=sources)
    recorded = entry.parameters.get("clusters")
    if recorded is not None and recorded != len(entry.centers):
        raise OptionError(
            f"{prefix}.clusters: {shown(recorded)}, but the file holds "
            f"{len(entry.centers)} {options.algorithm} centres"
        )


def clustering_error(
    err: ClusteringOptionError, options: ChiuOptions, origins: Mapping[str, str]
) -> HybridlogError:
    """``err`` with each option it names said where its value was set.

    ``origins``: option → ``--set squash=1`` (or a flag, ``--squash 1``: named as it is) or
    ``m.toml: estimators.chiu.squash`` (named with its value); an option without one is
    named as the default.  Subtractive clustering knows no flag or file: its errors said
    ``squash: …`` or ``accept, reject: …``.

    Returns
    -------
    OptionError, ModelError
        A :class:`~hybridlog.errors.ModelError` when only a model file set the values named.
    """
    from hybridlog.errors import ModelError

    named: list[str] = []
    for key in err.keys:
        origin = origins.get(key, "")
        value = shown(getattr(options, key))
        if origin.startswith("--"):
            named.append(origin)
        elif origin:
            named.append(f"{origin} = {value}")
        else:
            named.append(f"{key} {value} (the default)")
    message = f"{', '.join(named)}: {err.reason}"
    given = [origins.get(key, "") for key in err.keys]
    if any(given) and not any(origin.startswith("--") for origin in given):
        return ModelError(message)
    return OptionError(message)


def check_cluster_modes(
    model: HybridModel,
    options: ObserverOptions,
    *,
    clusters: int | None = None,
    origin: str = "",
) -> None:
    """Refuse ``cluster_modes`` that cannot label clusters of ``model``; before any log is read.

    Its mode ids must be the model's, listed with single commas, and (``clusters``: the
    number of centres, loaded or fitted) one per cluster: ``cluster_modes=7,1`` was refused
    only after the log had been read and its clusters fitted, naming neither ``--set`` nor
    the model file's key.  ``origin``
    (:attr:`~hybridlog.estimators.registry.Prepared.origins`) names where the value was set:
    ``--set cluster_modes=7,1`` (an :class:`OptionError`) or
    ``m.toml: estimators.chiu.cluster_modes`` (a :class:`~hybridlog.errors.ModelError`).
    """
    from hybridlog.errors import ModelError
    from hybridlog.numbers import comma_items

    text = options.cluster_modes
    if not text:
        return
    error: type[OptionError] | type[ModelError] = OptionError
    if origin.startswith("--set"):
        given = origin
    elif origin:
        given, error = f"{origin} = {excerpt(text)}", ModelError
    else:
        given = f"cluster_modes={excerpt(text)[1:-1]}"
    try:
        ids = comma_items(text, "mode ids")
    except ValueError as err:
        raise error(f"{given}: {err}") from None
    unknown = [mode for mode in ids if mode not in model.mode_ids]
    if unknown:
        raise error(
            f"{given}: unknown mode {excerpt(unknown[0])} (modes: {', '.join(model.mode_ids)})"
        )
    if clusters is not None and len(ids) != clusters:
        raise error(
            f"{given}: {len(ids)} mode ids for {clusters} {options.algorithm} centres; give "
            "one per centre"
        )


def check_centers(
    model: HybridModel,
    options: ChiuOptions | KMeansOptions,
    *,
    centers: CentersFile | None = None,
    origins: Mapping[str, str] | None = None,
) -> dict[str, Any]:
    """Check a loaded ``centers=FILE`` against the model and the options; before any log is read.

    Loaded centres are used as they are, not refitted, so a clustering option (``radius``,
    ``clusters`` ...) set to other than its default must be the one the file records its
    centres were fitted with: ``--set radius=0.3`` beside centres fitted with 0.5 would have
    run with the file's and been reported as 0.3; one set to its default, when ``origins``
    says it was set, likewise.  A model file's ``[estimators.chiu]`` value
    that ``hybridlog cluster`` fitted the centres with (it starts from that table) agrees.

    ``origins`` (:attr:`~hybridlog.estimators.registry.Prepared.origins`) names where a
    contradicting option was set.

    Returns
    -------
    dict
        The clustering options as the file records them (``None`` for one it does not), which
        the report gives in place of the options' own; empty without a file.

    Raises
    ------
    OptionError
        ``options.centers`` names a file but ``centers`` (its parsed content) is missing (the
        estimator reads no file, the job running it does); or the centres were fitted for
        another model, other modes or other regressors, or with another value of a clustering
        option set here; or ``cluster_modes`` cannot label them (:func:`check_cluster_modes`:
        a :class:`~hybridlog.errors.ModelError` when a model file set it).
    """
    if isinstance(options, ChiuOptions) and origins is not None:
        # the job's check, before the log is read: the estimator found squash = 1 after it,
        # and said 'squash: ...' without --set or the model file's key
        from hybridlog.cluster.subtractive import ClusteringOptionError

        try:
            options.clustering().validate(dimensions=1)
        except ClusteringOptionError as err:
            raise clustering_error(err, options, origins) from None
    cluster_modes = (origins or {}).get("cluster_modes", "")
    if centers is None:
        check_cluster_modes(model, options, origin=cluster_modes)
        if options.centers:
            raise OptionError(
                f"centers={options.centers}: the estimator reads no file; pass the parsed file "
                "as centers= (hybridlog.jobs.centers.read_centers)"
            )
        return {}
    source = options.centers or centers.path
    if centers.model != model.name:
        fitted = (
            f"model {centers.model!r}" if centers.model else "no model (its 'model' key is missing)"
        )
        raise OptionError(
            f"centers={source}: model: the centres were fitted for {fitted}, not "
            f"{model.name!r}; fit them for this model with hybridlog cluster"
        )
    from hybridlog.model.compiled import model_key, plant_key

    if centers.dt is not None and centers.dt != model.dt:
        raise OptionError(
            f"centers={source}: dt: the centres were fitted for model {model.name!r} with "
            f"dt = {centers.dt} s, this one's dt is {model.dt} s (φ(k) spans other sample "
            "times); fit them again for this model with hybridlog cluster"
        )
    spec = options.regressor_spec()
    lags = {"output_lags": spec.output_lags, "input_lags": spec.input_lags}
    names = spec.names(model.outputs, model.inputs)
    entry = centers.entry(options.algorithm, names, lags, model.mode_ids, source, origins)
    # after what can be named (dt, modes, regressors: a renamed output said only "another
    # version of model"): the key says that something else of the model differs
    # plant_key: the simulation's input is no part of what labels the clusters; a file
    # written before recorded model_key, which holds it
    if centers.model_key is not None and centers.model_key not in (
        plant_key(model),
        model_key(model),
    ):
        raise OptionError(
            f"centers={source}: model_key: the centres were fitted for another version of "
            f"model {model.name!r} (its equations, parameters, noise or names differ from "
            "this one's), whose modes label the clusters; fit them again for this model "
            "with hybridlog cluster"
        )
    _check_consistent(model, options, centers, source)
    check_cluster_modes(model, options, clusters=len(entry.centers), origin=cluster_modes)
    shared = {f.name for f in dataclasses.fields(ObserverOptions)}
    recorded: dict[str, Any] = {}
    for field in dataclasses.fields(options):
        if field.name in shared:
            continue
        value = getattr(options, field.name)
        fitted_with = entry.parameters.get(field.name)
        origin = (origins or {}).get(field.name, "")  # --set radius=0.3, or m.toml's key
        # given, even as its default (--set radius=0.5 beside centres fitted with 0.3 ran
        # with 0.3, reported with the origin --set radius=0.5)
        # kmeans' clusters = none is the number of modes, as a file records it
        wanted = len(model.mode_ids) if field.name == "clusters" and value is None else value
        if (origin or value != field.default) and wanted != fitted_with:
            what = (
                f"fitted with {field.name}={excerpt(shown(fitted_with), 40)[1:-1]}"
                if field.name in entry.parameters
                else f"which do not record the {field.name} they were fitted with"
            )
            given = origin if origin.startswith("--set") else f"{field.name}={shown(value)}"
            given += f" ({origin})" if origin and not origin.startswith("--set") else ""
            raise OptionError(
                f"centers={source}: {given} does not match the file's {options.algorithm} "
                f"centres, {what}: loaded centres are used as they are; leave "
                f"{field.name} unset or fit the centres so with hybridlog cluster"
            )
        recorded[field.name] = fitted_with
    return recorded
