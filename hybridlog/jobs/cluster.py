"""The ``hybridlog cluster`` job: fit the mode classifier of paper 001 on one log.

Reads the log for the model (with ``analyze``'s read options, :class:`~hybridlog.io.ReadOptions`),
builds the regression vectors, runs subtractive clustering (and k-means with
``compare_kmeans``), labels the clusters as modes (when the model is linear: see
:func:`hybridlog.estimators.chiu.mode_classifier`), writes ``centers.json``
(:mod:`hybridlog.cluster.centers_file`; what reading did under ``reading``) and a plot
(:mod:`hybridlog.jobs.cluster_plot`), and returns a table for the terminal.  Prints nothing;
errors are ``HybridlogError``.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from hybridlog.cluster.centers_file import centers_json
from hybridlog.cluster.classifier import ModeClassifier, manual_labels
from hybridlog.cluster.regressors import (
    RegressorSpec,
    measured_rows,
    parse_lags,
    regression_vectors,
)
from hybridlog.cluster.subtractive import ClusteringOptionError
from hybridlog.errors import (
    DataShortError,
    HybridlogError,
    LogError,
    ModelError,
    OptionError,
    OutputError,
    as_text,
    excerpt,
)
from hybridlog.estimators.capabilities import Capabilities, ModelTraits
from hybridlog.estimators.chiu import ChiuOptions, design_observer, mode_classifier
from hybridlog.estimators.kmeans import KMeansOptions
from hybridlog.estimators.lmi import ObserverGains
from hybridlog.estimators.observer_options import check_cluster_modes, clustering_error
from hybridlog.estimators.options import OptionSource, parse_options, read_value, shown
from hybridlog.estimators.registry import resolve_estimator
from hybridlog.estimators.switched_observer import LinearModes
from hybridlog.io import ReadOptions
from hybridlog.jobs import arguments
from hybridlog.jobs.cluster_plot import plot_clusters
from hybridlog.jobs.estimation import input_paths, read_log
from hybridlog.model.cache import load_model
from hybridlog.model.compiled import plant_key
from hybridlog.model.hybrid_model import HybridModel
from hybridlog.outputs import (
    PathLike,
    atomic_files,
    check_apart,
    check_distinct,
    check_file_name,
    check_file_target,
)
from hybridlog.report.chance_level import below_chance
from hybridlog.report.coverage import samples_coverage
from hybridlog.report.few_samples import FEW_SAMPLES
from hybridlog.report.markdown import WARNING_PREFIX, plural
from hybridlog.report.reading_notes import (
    bridged_cause,
    log_reading_notes,
    unused_sample_notes,
)
from hybridlog.report.summary_tables import markdown_table
from hybridlog.signals import NO_TRUE_MODE, AlignedSignals, FloatArray

__all__ = [
    "PLOT_SUFFIXES",
    "ClusterOutcome",
    "check_cluster_outputs",
    "discover_modes",
    "reading_said",
]

_Options = TypeVar("_Options", ChiuOptions, KMeansOptions)

#: Picture formats of ``--plot`` (written by matplotlib's Agg canvas, no external tools).
PLOT_SUFFIXES = (".png", ".svg", ".pdf")


@dataclass(frozen=True)
class ClusterOutcome:
    """What ``hybridlog cluster`` produced."""

    centers_path: Path
    plot_path: Path | None
    table: str
    notes: tuple[str, ...]
    chiu: ModeClassifier
    kmeans: ModeClassifier | None
    accuracy: dict[str, float | None]
    alerts: tuple[str, ...] = ()
    """Lines for stderr, each ``warning: …`` or ``note: …``: outputs the regression vectors
    took from the samples around (bridged), samples of the log not used, holds — what
    ``analyze`` prints on stderr of a log so read (:func:`reading_said`)."""


def reading_said(
    reading: Mapping[str, Any], left_out: Mapping[str, tuple[int, int]] | None = None
) -> tuple[list[str], list[str]]:
    """What reading the log did, in words: lines for stderr, and notes for the table.

    The same log analysed printed ``hybridlog: warning: output y has no sample within dt/2
    of 500 of 1001 sample times`` (a log at half the model's rate) and notes of samples not
    used (one at twice it); ``hybridlog cluster`` said none of it, and fitted centres on
    measurements used twice (``y(k) = y(k-1)``) without a word.  Warnings and the notes of
    samples not used go to stderr (``warning: …``, ``note: …``), the other notes of
    :func:`~hybridlog.report.reading_notes.log_reading_notes` (the user's repairs, the span) below
    the table.

    ``left_out``: per bridged output, how many regression vectors hold a value of it the log
    did not measure, and of how many (those vectors are not clustered:
    :func:`~hybridlog.cluster.regressors.measured_rows`).
    """
    alerts = []
    for symbol, count in (reading.get("bridged") or {}).items():
        vectors, of = (left_out or {}).get(symbol, (0, 0))
        alerts.append(
            f"warning: output {symbol} has no sample within dt/2 of {count['points']:,} of "
            f"{count['of']:,} sample times ({bridged_cause(count)}): the value there is taken "
            "from the samples around (a measurement used more than once, or interpolated), "
            f"and the {vectors:,} of {of:,} regression vectors φ(k) holding it were left out "
            "of the clusters' fit"
        )
    unused = set(unused_sample_notes(reading))
    notes: list[str] = []
    for note in log_reading_notes(reading):
        if note.startswith("WARNING: "):
            alerts.append(f"warning: {note.removeprefix('WARNING: ')}")
        elif note in unused:
            alerts.append(f"note: {note.removeprefix('NOTE: ')}")
        else:
            notes.append(note)
    return alerts, notes


def _left_out(signals: AlignedSignals, spec: RegressorSpec) -> dict[str, tuple[int, int]]:
    """Per bridged output: the regression vectors holding a value of it the log did not measure.

    Counted as :func:`~hybridlog.cluster.regressors.measured_rows` leaves them out of the fit
    (of every vector φ(k) of the log).
    """
    unmeasured = signals.unmeasured_outputs
    if unmeasured is None:
        return {}
    counts: dict[str, tuple[int, int]] = {}
    for j, symbol in enumerate(signals.output_names):
        kept = measured_rows(unmeasured[:, j : j + 1], spec, signals.n_samples)
        if not kept.all():
            counts[symbol] = (int(kept.size - np.count_nonzero(kept)), int(kept.size))
    return counts


def _accuracy(
    classifier: ModeClassifier, model: HybridModel, signals: AlignedSignals
) -> float | None:
    if classifier.cluster_modes is None or signals.truth_modes is None:
        return None
    decided = classifier.cluster_modes[classifier.decide(signals.measured_outputs())]
    known = signals.truth_modes != NO_TRUE_MODE  # a true mode that starts late: from its first
    return float(np.mean(decided[known] == signals.truth_modes[known])) if known.any() else None


def _scored(signals: AlignedSignals) -> int | None:
    """How many samples the accuracy of :func:`_accuracy` is over (those with a true mode)."""
    if signals.truth_modes is None:
        return None
    return int(np.count_nonzero(signals.truth_modes != NO_TRUE_MODE))


def _accuracy_words(accuracy: dict[str, float | None], over: str | None) -> str | None:
    """``mode accuracy of the decision rule on this log: chiu 0.9500, kmeans 0.9100 over …``.

    ``over``: :func:`~hybridlog.report.coverage.samples_coverage`'s words, for a true mode
    that starts late; ``None`` without any accuracy.
    """
    said = [f"{name} {value:.4f}" for name, value in accuracy.items() if value is not None]
    if not said:
        return None
    return (
        "mode accuracy of the decision rule on this log: "
        + ", ".join(said)
        + (f" over {over}" if over else "")
    )


def _below_chance(
    fitted: dict[str, ModeClassifier], model: HybridModel, signals: AlignedSignals
) -> list[str]:
    """A warning per algorithm whose decision rule's mode accuracy is below chance.

    As ``analyze`` warns of its report's (:mod:`hybridlog.report.chance_level`): ``cluster``
    printed ``kmeans: mode accuracy of the decision rule on this log 0.2827`` where modes
    drawn independently of the true ones would agree on 49 %, and wrote the centres,
    without a word.  Over the samples :func:`_accuracy` scores.
    """
    if signals.truth_modes is None:
        return []
    known = signals.truth_modes != NO_TRUE_MODE
    truth = signals.truth_modes[known]
    said = []
    for name, classifier in fitted.items():
        if classifier.cluster_modes is None:
            continue
        decided = classifier.cluster_modes[classifier.decide(signals.measured_outputs())][known]
        confusion = {
            model.mode_ids[t]: {
                model.mode_ids[e]: int(np.count_nonzero((truth == t) & (decided == e)))
                for e in range(model.n_modes)
            }
            for t in range(model.n_modes)
        }
        below = below_chance(confusion)
        if below is not None:
            rule = below.replace("mode accuracy", "the decision rule's mode accuracy", 1)
            said.append(f"warning: {name}: {rule}")
    return said


def few_vectors_warning(vectors: int, scored: int | None) -> str | None:
    """The warning that the centres or their accuracy rest on fewer than 30 samples, or ``None``.

    ``vectors``: the regression vectors the centres were fitted on; ``scored``: the samples
    the mode accuracy of the decision rule is over (``None``: no accuracy).  ``analyze``
    warns of metrics over fewer than :data:`~hybridlog.report.few_samples.FEW_SAMPLES` samples;
    ``cluster`` fitted centres on 2 vectors of a 3-row log and printed their accuracy,
    0.3333 over those 3 samples, without a word, and wrote them for ``analyze`` to use.
    """
    parts = []
    if vectors < FEW_SAMPLES:
        parts.append(f"centres fitted on {plural(vectors, 'regression vector')}")
    if scored is not None and scored < FEW_SAMPLES:
        parts.append(f"mode accuracy of the decision rule over {plural(scored, 'sample')}")
    if not parts:
        return None
    return (
        f"{WARNING_PREFIX}{'; '.join(parts)}: fewer than {FEW_SAMPLES}, they describe these "
        "samples, not the plant's modes; fit the clusters on a "
        f"log that gives at least {FEW_SAMPLES} regression vectors"
    )


def _entry(classifier: ModeClassifier, model: HybridModel) -> dict[str, Any]:
    modes = (
        None
        if classifier.cluster_modes is None
        else [model.mode_ids[m] for m in classifier.cluster_modes]
    )
    return {
        **{k: v for k, v in classifier.details.items() if k != "labelling_scores"},
        "centers": classifier.centers,
        "decision_values": classifier.decision_values,
        "modes": modes,
        "labelling": list(classifier.labelling),
        "notes": list(classifier.notes),
    }


def _rows(classifier: ModeClassifier, model: HybridModel) -> list[list[object]]:
    rows: list[list[object]] = []
    ratios = classifier.details.get("potential_ratios")
    sizes = classifier.details.get("sizes")
    texts = _centre_texts(classifier.centers)
    for c in range(len(classifier.centers)):
        mode = (
            "-" if classifier.cluster_modes is None else model.mode_ids[classifier.cluster_modes[c]]
        )
        rows.append(
            [
                classifier.algorithm,
                c + 1,
                mode,
                None if sizes is None else int(sizes[c]),
                None if ratios is None else float(ratios[c]),
                ", ".join(texts[c]),
            ]
        )
    return rows


def _centre_texts(centers: FloatArray) -> list[list[str]]:
    """Each centre's components to 4 significant digits, more where a column needs them.

    Centres of a log near 1e12 (a position in micrometres from an origin far away) printed
    ``1e+12, 1e+12, 0.7454`` and ``1e+12, 1e+12, -0.762``: different centres, alike in
    every output.  A column whose distinct values print alike gets the digits that tell
    them apart (up to the 17 of a float), as the gates' messages do.

    Told apart as values, not as floats: ``0.0`` and ``-0.0`` are one value, as every ``nan``
    is (a set of ``column.tolist()`` counted each ``nan`` apart, and a ``-0`` beside a ``0``
    printed apart: either gave every centre of that column 17 digits,
    ``0.33333333333333331``).
    """
    columns = []
    for column in np.asarray(centers, dtype=np.float64).T:
        values = (column + 0.0).tolist()  # -0.0 + 0.0 is 0.0
        distinct = np.unique(values).size  # one nan
        for digits in range(4, 18):
            if len({f"{v:.{digits}g}" for v in values}) == distinct:
                break
        columns.append([f"{v:.{digits}g}" for v in column])
    return [list(row) for row in zip(*columns, strict=True)] if columns else []


def _model_defaults(
    model: HybridModel, estimator: str, options: _Options, given: Collection[str]
) -> _Options:
    """``options`` with the values the model file sets under ``[estimators.<estimator>]``.

    The options in ``given`` (the user's) and ``centers`` are kept: ``hybridlog cluster``
    fits what the estimator would fit on this log (it ignored ``radius = 0.3`` there and
    fitted 0.5), and fits it rather than loading it.

    Raises
    ------
    ModelError
        A value of the table is not one of the option (naming the file and key).
    """
    names = {f.name for f in dataclasses.fields(options)} - {"centers", *given}
    table = {k: v for k, v in model.estimator_options.get(estimator, {}).items() if k in names}
    if not table:
        return options
    origin = model.origin or model.name
    sources = {k: OptionSource.model_file(origin, estimator, k) for k in table}
    parsed = parse_options(type(options), table, estimator=estimator, sources=sources)
    return dataclasses.replace(options, **{k: getattr(parsed, k) for k in table})


def _values_read(options: _Options | None, parameter: str) -> _Options | None:
    """A caller's options object with each value read as its option reads a model file's.

    A dataclass takes any value: ``ChiuOptions(radius="0.3")`` clustered with 0.3 and wrote
    ``"radius": "0.3"`` into centers.json, and ``radius=1e-9``, outside the range ``--radius``
    is held to, ran.  The command line's and the model file's values were read so already.

    Raises
    ------
    OptionError
        ``chiu.radius: expected a finite number, got ...``: the parameter and its field.
    """
    if options is None:
        return None
    values = {}
    for field in dataclasses.fields(options):
        try:
            values[field.name] = read_value(type(options), field.name, getattr(options, field.name))
        except ValueError as err:
            raise OptionError(f"{parameter}.{field.name}: {err}") from None
    return dataclasses.replace(options, **values)


def _check_clustering(
    chiu: ChiuOptions, model: HybridModel, given: Collection[str], *, flags: bool
) -> None:
    """Refuse clustering options out of bounds, naming where each value came from.

    Their declared ranges are wider than what the algorithm takes (``squash`` 1, ``accept``
    0, ``reject`` no smaller than ``accept``): the error said ``squash: …`` or ``accept,
    reject: …``, naming neither the flag nor the model file's key that set the value.
    ``flags``: ``given`` are the command line's options (else a library caller's
    :class:`ChiuOptions`, whose fields the error names as they are).

    Raises
    ------
    OptionError
        A value given on the command line (``--squash 1``), or a default beside one.
    ModelError
        Only values of the model file's ``[estimators.chiu]`` table (``m.toml:
        estimators.chiu.squash``).
    """
    try:
        chiu.clustering().validate(dimensions=1)
    except ClusteringOptionError as err:
        raise _named(err, chiu, model, given, flags=flags) from None


def _named(
    err: ClusteringOptionError,
    chiu: ChiuOptions,
    model: HybridModel,
    given: Collection[str],
    *,
    flags: bool,
) -> HybridlogError:
    """``err`` with each of its options named where its value came from (see above).

    A library caller's options (``flags`` false) are named as ``err`` names them, unless a
    model file set one of them.
    """
    table = model.estimator_options.get("chiu", {})
    if not flags and not any(key in table and key not in given for key in err.keys):
        return err
    origin = model.origin or model.name
    origins: dict[str, str] = {}
    for key in err.keys:
        value = shown(getattr(chiu, key))
        if key in given:  # --exact, --approximate: the switches of method
            origins[key] = f"--{value}" if key == "method" else f"--{key.replace('_', '-')} {value}"
        elif key in table:
            origins[key] = f"{origin}: estimators.chiu.{key}"
    if flags:
        err = ClusteringOptionError(err.keys, str(err).replace("method=exact", "--exact"))
    return clustering_error(err, chiu, origins)


def _kmeans_options(
    model: HybridModel, kmeans: KMeansOptions | None, chiu: ChiuOptions
) -> KMeansOptions:
    """``kmeans`` (else the model file's ``[estimators.kmeans]``) with ``chiu``'s lags.

    Raises
    ------
    ModelError
        The model file's ``[estimators.kmeans]`` sets lags other than ``chiu``'s: the file
        holds one φ(k), so its k-means centres were fitted on chiu's and the kmeans estimator,
        which takes that table's lags, refused them (after cluster had said nothing).
    """
    if kmeans is None:
        kmeans = _model_defaults(model, "kmeans", KMeansOptions(), ())
        table = model.estimator_options.get("kmeans", {})
        for key in ("output_lags", "input_lags"):
            mine = parse_lags(getattr(kmeans, key), key)
            theirs = parse_lags(getattr(chiu, key), key)
            if key in table and mine != theirs:
                raise ModelError(
                    f"{model.origin or model.name}: estimators.kmeans.{key} = "
                    f"{excerpt(getattr(kmeans, key))}: --compare-kmeans fits k-means on "
                    f"chiu's φ(k) ({key} {','.join(map(str, theirs)) or '(none)'}), the one "
                    "the centres file holds; set the same lags for chiu and kmeans"
                )
    options = kmeans
    return KMeansOptions(
        clusters=options.clusters,
        restarts=options.restarts,
        seed=options.seed,
        cluster_modes=options.cluster_modes,
        output_lags=chiu.output_lags,
        input_lags=chiu.input_lags,
        decay_rate=chiu.decay_rate,
    )


def _labels_origin(
    model: HybridModel, options: ChiuOptions | KMeansOptions, given: Collection[str]
) -> str:
    """Where ``cluster_modes`` was set: the model file's key, or ``""`` (a library caller's)."""
    table = model.estimator_options.get(options.algorithm, {})
    if "cluster_modes" not in table or (options.algorithm == "chiu" and "cluster_modes" in given):
        return ""
    return f"{model.origin or model.name}: estimators.{options.algorithm}.cluster_modes"


def _classifier(
    model: HybridModel,
    signals: AlignedSignals,
    options: _Options,
    observer: tuple[LinearModes, ObserverGains] | str,
    given: Collection[str],
) -> ModeClassifier:
    """The clusters of ``options`` fitted on the log, labelled (see ``mode_classifier``).

    Labels given by ``cluster_modes`` are checked against the number of clusters fitted
    here, naming where they were set (``m.toml: estimators.chiu.cluster_modes = '2,1': 2 mode
    ids for 3 chiu centres``; the estimator's own message named neither the file nor the
    key); the automatic labelling is not run for them.
    """
    text = options.cluster_modes
    if not text:
        return mode_classifier(model, signals, options, observer=observer)
    fitted = mode_classifier(model, signals, dataclasses.replace(options, cluster_modes=""))
    origin = _labels_origin(model, options, given)
    check_cluster_modes(model, options, clusters=len(fitted.centers), origin=origin)
    modes = manual_labels(
        text, model.mode_ids, len(fitted.centers), decision_values=fitted.decision_values
    )
    return fitted.labelled(modes, (f"labels given by cluster_modes={text}",))


DEFAULT_PLOT = "the default plot path (--out with .png)"
"""What errors call the picture of ``cluster`` when no ``--plot`` named it."""


def check_cluster_outputs(
    log: PathLike,
    model_ref: PathLike,
    *,
    out: PathLike,
    plot: PathLike | None,
    force: bool,
    read: ReadOptions | None = None,
) -> tuple[Path, Path]:
    """Check both outputs of ``hybridlog cluster`` before anything is read or written.

    ``read`` names the ``--msg-dir`` folders, inputs like the log and the model file.

    Returns
    -------
    tuple of pathlib.Path
        The centres file and the picture (``out`` with ``.png`` when ``plot`` is ``None``).

    Raises
    ------
    OptionError
        For a centres file not named ``*.json`` or a picture not named as one of
        :data:`PLOT_SUFFIXES`.
    OutputError
        When an output is, contains or sits inside the log, the model file or a ``--msg-dir``
        folder, both name the same file, or one exists without ``force`` (see
        :mod:`hybridlog.outputs`).
    """
    # first, on the text given: Path drops the "/" of --out dir.json/ (then refused as a
    # name without .json, shown as "dir.json"), and --out c.json/.. has no suffix
    check_file_name(out, "--out")
    if plot is not None:
        check_file_name(plot, "--plot")
    target = Path(out)
    if target.suffix.lower() != ".json":
        raise OptionError(f"--out {target}: the centres file is JSON; name it *.json")
    picture = target.with_suffix(".png") if plot is None else Path(plot)
    if picture.suffix.lower() not in PLOT_SUFFIXES:
        raise OptionError(
            f"--plot {picture}: cannot draw a {picture.suffix or 'suffix-less'} file; "
            f"name it *{', *'.join(PLOT_SUFFIXES)}"
        )
    # the picture the user did not name is not called --plot (it was: "--plot run.png is
    # the log run.png", "c.png: already exists" of a c.png nobody asked for)
    label = "--plot" if plot is not None else DEFAULT_PLOT
    outputs = [("--out", target), (label, picture)]
    check_distinct(outputs)
    inputs = input_paths([log], model_ref, [], read or ReadOptions())
    check_apart(outputs[:1], inputs)
    check_file_target(target, force=force)
    try:
        check_apart(outputs[1:], inputs)
        check_file_target(picture, force=force)
    except OutputError as err:
        if plot is not None:
            raise
        said = str(err) if str(err).startswith(label) else f"{label} {err}"
        raise OutputError(f"{said}; --plot PATH writes the picture elsewhere") from None
    return target, picture


def discover_modes(
    log: str | os.PathLike[str],
    model_ref: str | os.PathLike[str],
    *,
    out: str | os.PathLike[str] = "centers.json",
    chiu: ChiuOptions | None = None,
    given: Collection[str] | None = None,
    compare_kmeans: bool = False,
    kmeans: KMeansOptions | None = None,
    plot: str | os.PathLike[str] | None = None,
    read: ReadOptions | None = None,
    force: bool = False,
) -> ClusterOutcome:
    """Fit, label and save the clusters of one log (``hybridlog cluster``).

    Parameters
    ----------
    log, model_ref:
        The log and the model (built-in name or file).
    out:
        ``centers.json`` to write.
    chiu:
        Subtractive-clustering options (radius, squash, method, lags …).
    given:
        The options of ``chiu`` the user set (``None``: all of them, or none when ``chiu``
        is ``None``); the others come from the model file's ``[estimators.chiu]`` table
        where it sets them, as the ``chiu`` estimator takes them (but ``centers``: the
        clusters are fitted here).
    compare_kmeans:
        Also fit k-means (same lags) and store it in the file.
    kmeans:
        k-means options (its lags are taken from ``chiu``); ``None``: the model file's
        ``[estimators.kmeans]`` values, else the defaults.
    plot:
        PNG to draw; ``None`` for ``out`` with the suffix ``.png``.
    read:
        How to read the log (``--map``, ``--time``, ``--sort``, ``--drop-nonfinite``,
        ``--recover``, ``--msg-dir``, …: the read options of ``analyze``); what reading did
        is stored under ``reading`` in the centres file.
    force:
        Replace existing output files.

    Raises
    ------
    ModelError
        The model file's ``[estimators.<x>]`` tables name an unknown estimator or option
        (as ``analyze`` refuses them), or a value there is wrong.
    LogError
        For a log that cannot be read for the model, or whose regression vectors cannot be
        clustered (too few samples for the lags, fewer distinct vectors than k-means
        clusters); the message names the log.
    """
    arguments.path(log, "log")
    arguments.path(model_ref, "model_ref")
    arguments.path(out, "out")
    arguments.path(plot, "plot", optional=True)
    arguments.flag(compare_kmeans, "compare_kmeans")
    arguments.flag(force, "force")
    arguments.instance(chiu, ChiuOptions, "chiu", "hybridlog.estimators.chiu.ChiuOptions")
    kind = "hybridlog.estimators.kmeans.KMeansOptions"
    arguments.instance(kmeans, KMeansOptions, "kmeans", kind)
    arguments.names(given, "given", [f.name for f in dataclasses.fields(ChiuOptions)])
    chiu, kmeans = _values_read(chiu, "chiu"), _values_read(kmeans, "kmeans")
    read = arguments.read_options(read)
    target, picture = check_cluster_outputs(
        log, model_ref, out=out, plot=plot, force=force, read=read
    )
    model = load_model(os.fspath(model_ref))
    # every [estimators.<x>] table as analyze checks it: cluster read only the chiu (and
    # kmeans) keys it knew, so a misspelt `radiuss = 0.3` fitted 0.5 without a word
    resolve_estimator(model, "chiu")
    flags = given is not None  # the command line's: named as its flags in errors
    if given is None:
        given = () if chiu is None else [f.name for f in dataclasses.fields(ChiuOptions)]
    chiu = _model_defaults(model, "chiu", chiu or ChiuOptions(), given)
    # paper 001's regressors need a discrete-time model of enumerated modes (linear ones only
    # to label the clusters as modes): refused before the log is read
    problem = Capabilities().mismatch(ModelTraits(model))
    if problem is not None:
        raise ModelError(f"{model.origin or model.name}: hybridlog cluster {problem}")
    # the lags and the clustering settings too: --squash 1 or --output-lags 1 was refused
    # only after a long log had been read and the observer's LMI solved
    chiu.regressor_spec()
    _check_clustering(chiu, model, given, flags=flags)
    kmeans = _kmeans_options(model, kmeans, chiu) if compare_kmeans else None
    for options in (chiu, kmeans):
        if options is not None:
            check_cluster_modes(model, options, origin=_labels_origin(model, options, given))
    reading: dict[str, Any] = {}
    signals = read_log(os.fspath(log), model, read, reading)
    notes: list[str] = []
    observer: tuple[LinearModes, ObserverGains] | str
    try:
        observer = design_observer(model, chiu.decay_rate)
    except ModelError as err:
        observer = str(err)  # each algorithm's labelling says why (centers.json too)
    try:  # the grid of method = approximate is chosen on the data
        fitted = _classifier(model, signals, chiu, observer, given)
    except ClusteringOptionError as err:
        raise _named(err, chiu, model, given, flags=flags) from None
    baseline, compared = None, []
    if kmeans is not None:
        try:
            baseline = _classifier(model, signals, kmeans, observer, given)
        except LogError as err:
            if not isinstance(err.__cause__, DataShortError):
                raise
            # a log whose φ(k) are all one point: chiu found its one centre, and k-means
            # stopped the command (chiu's result unwritten) for want of 2 distinct points
            compared = [f"kmeans: not compared, k-means could not run: {err.__cause__}"]
    accuracy = {"chiu": _accuracy(fitted, model, signals)}
    if baseline is not None:
        accuracy["kmeans"] = _accuracy(baseline, model, signals)
    # a true mode that starts late: the accuracy is of the samples from its first on, said as
    # report.md and the batch summaries say it
    over = samples_coverage(_scored(signals), signals.time.size, reading)
    fitted_on = measured_rows(signals.unmeasured_outputs, fitted.spec, signals.n_samples)
    scored = _scored(signals) if any(v is not None for v in accuracy.values()) else None
    few = few_vectors_warning(int(np.count_nonzero(fitted_on)), scored)
    content: dict[str, Any] = {
        "model": model.name,
        "model_key": plant_key(model),
        "dt": model.dt,
        "log": as_text(log),
        "mode_ids": list(model.mode_ids),
        "regressors": list(fitted.regressors),
        "output_lags": list(fitted.spec.output_lags),
        "input_lags": list(fitted.spec.input_lags),
        "scaling": {"lower": fitted.lower, "upper": fitted.upper},
        "chiu": {
            "parameters": {
                "radius": chiu.radius,
                "squash": chiu.squash,
                "accept": chiu.accept,
                "reject": chiu.reject,
                "self_potential": chiu.self_potential,
                "method": chiu.method,
            },
            **_entry(fitted, model),
        },
        "mode_accuracy_on_log": accuracy,
    }
    if over is not None and any(v is not None for v in accuracy.values()):
        content["mode_accuracy_over"] = over
    if baseline is not None and kmeans is not None:
        content["kmeans"] = {
            "parameters": {
                "clusters": len(baseline.centers),
                "restarts": kmeans.restarts,
                "seed": kmeans.seed,
            },
            **_entry(baseline, model),
        }
    if few is not None:  # in the file too: the centres analyze would decide by
        for name in ("chiu", "kmeans"):
            if name in content:
                content[name]["notes"].append(few)
    content["reading"] = reading
    phi = regression_vectors(signals.outputs, signals.inputs, fitted.spec)
    lag = fitted.spec.max_lag
    clusters = fitted.decide(signals.measured_outputs())[lag:]
    cluster_modes = (
        None if fitted.cluster_modes is None else [model.mode_ids[m] for m in fitted.cluster_modes]
    )
    truth = (
        None
        if signals.truth_modes is None
        else [None if q == NO_TRUE_MODE else model.mode_ids[q] for q in signals.truth_modes[lag:]]
    )
    with atomic_files([target, picture], force=force) as (centers_file, picture_file):
        try:
            centers_file.write_text(centers_json(content), encoding="utf-8")
            plot_clusters(
                picture_file,
                time=signals.time[lag:],
                phi=phi,
                names=fitted.regressors,
                clusters=clusters,
                centers=fitted.centers,
                cluster_modes=cluster_modes,
                decision_values=fitted.decision_values[:, 0],
                mode_ids=model.mode_ids,
                kmeans_centers=None if baseline is None else baseline.centers,
                truth=truth,
                accuracy=_accuracy_words(accuracy, over),
            )
        except OSError as err:
            raise OutputError(f"cannot write {target} and {picture}: {err.strerror}") from err
    rows = _rows(fitted, model) + ([] if baseline is None else _rows(baseline, model))
    table = markdown_table(
        (
            "algorithm",
            "cluster",
            "mode",
            "samples",
            "P*/P1*",
            f"centre [{', '.join(fitted.regressors)}]",
        ),
        rows,
        escape_header=False,  # the terminal's: P*/P1* as it is
    )
    alerts, read_notes = reading_said(reading, _left_out(signals, fitted.spec))
    if few is not None:
        alerts.append(f"warning: {few.removeprefix(WARNING_PREFIX)}")
    alerts += _below_chance(
        {"chiu": fitted} | ({} if baseline is None else {"kmeans": baseline}), model, signals
    )
    notes += [*fitted.notes, *fitted.labelling, *read_notes]
    if baseline is not None:
        compared = [*baseline.notes, *baseline.labelling]
    notes += compared
    for name, value in accuracy.items():
        if value is not None:
            notes.append(
                f"{name}: mode accuracy of the decision rule on this log {value:.4f}"
                + (f" over {over}" if over else "")
            )
    return ClusterOutcome(
        centers_path=target,
        plot_path=picture,
        table=table,
        notes=tuple(notes),
        chiu=fitted,
        kmeans=baseline,
        accuracy=accuracy,
        alerts=tuple(alerts),
    )
