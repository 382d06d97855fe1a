"""A log and what a model asks of it → :class:`~hybridlog.signals.AlignedSignals`.

:func:`load_signals` opens the log with the reader of its format (:func:`~.formats.open_log`),
maps the model's symbols to log fields (:mod:`.mapping`: column names or message paths),
reads only those fields, checks their values, and aligns them onto the model's grid
(:mod:`.align`).  What the model asks for is a :class:`SignalSpec`; how to read is one
:class:`~hybridlog.io.options.ReadOptions`.
"""

from __future__ import annotations

import os
import unicodedata
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from hybridlog.errors import LogError
from hybridlog.io.align import align_signals, check_alignment_options
from hybridlog.io.clocks import clocks_disagree
from hybridlog.io.formats import open_log
from hybridlog.io.mapping import (
    TRUTH_MODE,
    TRUTH_PREFIX,
    SignalMap,
    component_truth_symbol,
    parse_maps,
    resolve_signal_map,
)
from hybridlog.io.options import ReadOptions, log_arguments
from hybridlog.io.source import NS_PER_S, FieldError, FieldKey, LabelSeries, Series, format_ns
from hybridlog.io.time_grid import SignalsApartError, clock_tolerance_ns
from hybridlog.signals import MAX_MAGNITUDE, AlignedSignals, IntArray

Locate = Callable[[str, int], str]


class ModelSignals(Protocol):
    """What :meth:`SignalSpec.of` reads of a model (a ``HybridModel`` has all of it)."""

    @property
    def states(self) -> Sequence[str]:
        """State names, in vector order."""
        ...

    @property
    def inputs(self) -> Sequence[str]:
        """Input names, in vector order."""
        ...

    @property
    def outputs(self) -> Sequence[str]:
        """Output names, in vector order."""
        ...

    @property
    def mode_ids(self) -> Sequence[str]:
        """Mode ids, in mode-index order."""
        ...

    @property
    def dt(self) -> float:
        """Sample time in seconds."""
        ...

    @property
    def signals(self) -> Mapping[str, str]:
        """The model's ``[signals]`` table."""
        ...

    @property
    def truth(self) -> Mapping[str, str]:
        """The model's ``[truth]`` table."""
        ...


def _no_paths() -> Mapping[str, str]:
    return MappingProxyType({})


def _no_components() -> Mapping[str, tuple[str, ...]]:
    return MappingProxyType({})


@dataclass(frozen=True, kw_only=True)
class SignalSpec:
    """What a model asks of a log: its symbols, mode ids, sample time and default paths.

    ``io`` and ``model`` are peers: :meth:`of` reads these from any object shaped like a
    ``HybridModel`` (:class:`ModelSignals`) without importing ``model``.

    Attributes
    ----------
    inputs, outputs:
        The model's input and output names, in vector order.
    mode_ids:
        The model's mode ids; true-mode labels must be among them (compared as text).
    dt:
        The model's sample time in seconds.
    states:
        The model's state names, in vector order (for ground truth; default none).
    signals, truth:
        The model's ``[signals]`` and ``[truth]`` tables (symbol → message path).
    components:
        A ``[components]`` model's components and their mode ids (``{name: ids}``, in the
        model's order): their true modes are read where the log has them.
    commands:
        The commands a ``[components]`` model's transition rules name (``when``), in the
        model's order: read where the log has them, like inputs (mapped by ``--map``,
        ``[signals]`` or the default name, held onto the grid), into
        ``AlignedSignals.commands``.
    """

    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    mode_ids: tuple[str, ...]
    dt: float
    states: tuple[str, ...] = ()
    signals: Mapping[str, str] = field(default_factory=_no_paths)
    truth: Mapping[str, str] = field(default_factory=_no_paths)
    components: Mapping[str, tuple[str, ...]] = field(default_factory=_no_components)
    commands: tuple[str, ...] = ()

    @classmethod
    def of(cls, model: ModelSignals) -> SignalSpec:
        """The spec of a model (a ``HybridModel`` or anything shaped like one)."""
        components = tuple(getattr(model, "components", ()))
        named = {c for component in components for rule in component.rules for c in rule.when}
        return cls(
            inputs=tuple(model.inputs),
            outputs=tuple(model.outputs),
            mode_ids=tuple(model.mode_ids),
            dt=model.dt,
            states=tuple(model.states),
            signals=MappingProxyType(dict(model.signals)),
            truth=MappingProxyType(dict(model.truth)),
            components=MappingProxyType(
                {
                    # its modes, the implicit "unknown" too: the keys of its initial probabilities
                    str(c.name): tuple(str(m) for m in c.initial_mode_probabilities)
                    for c in components
                }
            ),
            commands=tuple(c for c in getattr(model, "commands", ()) if c in named),
        )


def check_read_options(spec: SignalSpec, options: ReadOptions) -> dict[str, str]:
    """Check the read options against the model alone; return the parsed ``--map``.

    The alignment options against its ``dt``, ``--map``'s symbols against its symbols:
    nothing of a log.  :func:`load_signals` checks them first; ``batch`` before its first
    log (each log failed alike, losing the report an earlier run made of it).

    Raises
    ------
    OptionError
        For a malformed ``--map``, an unknown symbol, or an unusable ``dt``; a ``path``
        that is no path or ``options`` that are no :class:`ReadOptions`.
    """
    check_alignment_options(spec.dt, options.resample, options.max_gap)
    return parse_maps(
        options.maps,
        inputs=spec.inputs,
        outputs=spec.outputs,
        states=spec.states,
        components=tuple(spec.components),
        commands=spec.commands,
    )


def load_signals(
    path: str | os.PathLike[str],
    spec: SignalSpec,
    options: ReadOptions | None = None,
    *,
    notes: dict[str, Any] | None = None,
) -> AlignedSignals:
    """Read a log and align the model's signals onto its grid ``t0 + k*dt``.

    Parameters
    ----------
    path:
        The log: any format of :data:`~hybridlog.io.formats.FORMATS` (``.csv``,
        ``.parquet``, ``.mcap``, ``.bag``, ``.db3`` or a ROS 2 bag folder).
    spec:
        What the model asks for (:meth:`SignalSpec.of` a model).
    options:
        How to read and align (``--map``, ``--resample``, ``--max-gap``, ``--split-gaps``,
        ``--time``, ``--sort``, ``--drop-nonfinite``, ``--recover``, ``--msg-dir``).  With
        ``drop_nonfinite``, NaN, infinite and out-of-range samples are dropped (counted in
        ``notes``) instead of refusing the log.  Out of range means ``|value| >= 2**480``
        (:data:`~hybridlog.signals.MAX_MAGNITUDE`): no measurement is that large, and the
        squares the metrics sum would overflow float64; corrupt bytes decode to such values.
    notes:
        Filled with what reading did, for the report: the format, the time source, the
        field read for each symbol and where it came from (``fields``: ``{symbol:
        {"field": ..., "from": "--map" | "[signals]" | "[truth]" | "default"}}``), and
        recovery, sorting, dropped samples (and the end of the analysed span a dropped first
        or last sample moved, ``nonfinite_span``) and gap pieces where they apply.

    Returns
    -------
    AlignedSignals

    Raises
    ------
    OptionError
        For a malformed ``--map``, an unknown symbol, or an unusable ``dt``; a ``path``
        that is no path or ``options`` that are no :class:`ReadOptions`.
    LogError
        For a missing or unreadable log, a missing field, a non-numeric, NaN, infinite or
        out-of-range value, time going backwards, an unknown true mode, or an over-long gap.
    """
    options = log_arguments(path, options)
    parsed = check_read_options(spec, options)
    notes = notes if notes is not None else {}
    with open_log(path, options) as source:
        info = source.info
        mapping = resolve_signal_map(
            source.fields(),
            source=info.path,
            inputs=spec.inputs,
            outputs=spec.outputs,
            states=spec.states,
            components=tuple(spec.components),
            signals=spec.signals,
            truth=spec.truth,
            maps=parsed,
            field_word=info.field_word,
            message_paths=info.message_paths,
            explain=source.explain_missing,
            field_key=source.field_key,
            commands=spec.commands,
        )
        symbols = {
            **{field: f"input {u!r}" for u, field in mapping.inputs.items()},
            **{field: f"output {y!r}" for y, field in mapping.outputs.items()},
            **{field: f"command {c!r}" for c, field in mapping.commands.items()},
            **{field: f"truth.{x}" for x, field in mapping.truth_states.items()},
        }
        numeric = list(
            dict.fromkeys(
                [
                    *mapping.inputs.values(),
                    *mapping.outputs.values(),
                    *mapping.commands.values(),
                    *mapping.truth_states.values(),
                ]
            )
        )
        labels = list(
            dict.fromkeys(
                [
                    *([mapping.truth_mode] if mapping.truth_mode is not None else []),
                    *mapping.truth_components.values(),
                ]
            )
        )
        while True:
            try:
                reading = source.read(numeric, labels)
                break
            except FieldError as err:  # named as a field that does not fit the log is
                place = mapping.place(err.name, info.field_word)
                if place is None:
                    raise
                without = _without_unreadable_truth(mapping, err, info.field_word)
                if without is None:
                    raise LogError(f"{err.file}: {place}: {err.reason}") from None
                mapping = without  # read again, without that ground truth
                numeric = [name for name in numeric if name != err.name]
                labels = [name for name in labels if name != err.name]
        numeric_series = dict(reading.numeric)
        dropped: dict[str, int] = {}
        out_of_range: dict[str, int] = {}
        emptied: dict[str, int] = {}  # fields of which --drop-nonfinite dropped every sample
        trimmed: dict[str, Series] = {}  # fields it dropped the first or last sample of
        dropped_at: dict[str, IntArray] = {}  # the times of the samples it dropped
        for name, series in list(numeric_series.items()):
            if _all_usable(series.values):
                continue
            finite = np.isfinite(series.values)
            usable = finite & (np.abs(series.values) < MAX_MAGNITUDE)
            if usable.all():
                continue
            if not options.drop_nonfinite:
                _refuse_nonfinite(info.path, reading.locate, series, symbols[name])
                _refuse_out_of_range(info.path, reading.locate, series, symbols[name], usable)
            if not finite.all():
                dropped[name] = int((~finite).sum())
            if (finite & ~usable).any():
                out_of_range[name] = int((finite & ~usable).sum())
            numeric_series[name] = Series(name, series.time_ns[usable], series.values[usable])
            dropped_at[name] = series.time_ns[~usable]
            if usable.any() and not (usable[0] and usable[-1]):
                trimmed[name] = series
            if not usable.any():
                emptied[name] = int(usable.size)
                needed = [f"input {u!r}" for u, f in mapping.inputs.items() if f == name]
                needed += [f"output {y!r}" for y, f in mapping.outputs.items() if f == name]
                needed += [f"command {c!r}" for c, f in mapping.commands.items() if f == name]
                if needed:
                    raise LogError(
                        f"{info.path}: {needed[0]} ({info.field_word} {name!r}) has no "
                        f"usable samples: {_all_dropped(usable.size)}"
                    )
        notes.update({"format": info.format, "time": options.time})
        notes["fields"] = mapping.fields_read()  # again below, without truth left unused
        notes.update(reading.notes)
        if mapping.unusable_truth:
            notes["truth_unusable"] = [
                f"{symbol} ({why})" for symbol, why in mapping.unusable_truth.items()
            ]
        if dropped:
            notes["nonfinite_dropped"] = dropped
        if out_of_range:
            notes["out_of_range_dropped"] = out_of_range
        mapping = _without_empty_truth(
            mapping,
            numeric_series,
            reading.labels,
            parsed,
            info.path,
            info.field_word,
            notes,
            emptied,
        )
        notes["fields"] = mapping.fields_read()
        shared = _truth_sharing(mapping, source.field_key, spec.inputs, info.field_word)
        if shared:
            notes["truth_shared"] = shared
        truth_mode = None
        if mapping.truth_mode is not None:
            mode_series = reading.labels[mapping.truth_mode]
            codes = _truth_mode_codes(
                info.path,
                reading.locate,
                mode_series,
                spec.mode_ids,
                origin=mapping.origins.get(TRUTH_MODE, "--map"),
            )
            truth_mode = LabelSeries(
                mode_series.name, mode_series.time_ns, codes, tuple(spec.mode_ids)
            )
        truth_components: dict[str, LabelSeries] = {}
        for component, name in mapping.truth_components.items():
            ids = spec.components[component]
            labelled = reading.labels[name]
            symbol = component_truth_symbol(component)
            codes = _truth_mode_codes(
                info.path,
                reading.locate,
                labelled,
                ids,
                symbol=symbol,
                origin=mapping.origins.get(symbol, "--map"),
            )
            truth_components[component] = LabelSeries(labelled.name, labelled.time_ns, codes, ids)
        aligned = _aligned(
            notes.get("stamp_offsets"),
            source=info.path,
            dt=spec.dt,
            inputs={u: numeric_series[f] for u, f in mapping.inputs.items()},
            outputs={y: numeric_series[f] for y, f in mapping.outputs.items()},
            commands={c: numeric_series[f] for c, f in mapping.commands.items()},
            truth_mode=truth_mode,
            truth_components=truth_components,
            states=spec.states,
            truth_states={x: numeric_series[f] for x, f in mapping.truth_states.items()},
            resample=options.resample,
            max_gap=options.max_gap,
            split_gaps=options.split_gaps,
            notes=notes,
            field_word=info.field_word,
            dropped={y: dropped_at[f] for y, f in mapping.outputs.items() if f in dropped_at},
        )
        if trimmed:
            _note_trimmed_span(
                aligned.time, spec.dt, mapping, numeric_series, trimmed, notes, info.field_word
            )
        return aligned


def _aligned(offsets: Mapping[str, float] | None, **arguments: Any) -> AlignedSignals:
    """:func:`~hybridlog.io.align.align_signals`; signals apart in time named with their clocks.

    With ``--time header``, topics stamped by clocks that disagree (``offsets``, the
    reading's ``stamp_offsets``, :func:`~hybridlog.io.clocks.clocks_disagree`) can lie apart
    by the clocks' difference: "signals do not overlap in time" named the two times, not why.
    """
    try:
        return align_signals(**arguments)
    except SignalsApartError as err:
        disagree = clocks_disagree(offsets or {})
        if disagree is None:
            raise
        raise LogError(
            f"{err}; --time header: {disagree}; --time log aligns them as they were recorded"
        ) from None


def _note_trimmed_span(
    time: npt.NDArray[np.float64],
    dt: float,
    mapping: SignalMap,
    kept: Mapping[str, Series],
    trimmed: Mapping[str, Series],
    notes: dict[str, Any],
    word: str,
) -> None:
    """Record an end of the analysed span ``--drop-nonfinite`` moved (``nonfinite_span``).

    The grid starts at the latest first sample of the inputs, commands and outputs and ends
    within half a step of the outputs' earliest last one (SPEC §5): a NaN first or last
    sample dropped moves it, and report.md said only how many samples were dropped, which
    read like samples from inside the log.  ``{"start" | "end": {signal, at, dropped,
    from}}``: the signal whose kept sample at ``at`` (s) bounds the span, and the ``dropped``
    samples before (after) it, from (to) ``from`` (s).  ``trimmed``: the fields as read,
    before dropping; ``kept``: after; ``word``: what the log calls a field.
    """
    if time.size == 0:
        return
    dt_ns = round(dt * NS_PER_S)
    tolerance = clock_tolerance_ns(dt_ns)
    first, last = round(float(time[0]) * NS_PER_S), round(float(time[-1]) * NS_PER_S)
    held = {**mapping.inputs, **mapping.commands}
    bounding = mapping.outputs or held  # what ends the grid (SPEC §5)
    named = [
        (kind, symbol, name)
        for kind, group in (("input", mapping.inputs), ("command", mapping.commands))
        for symbol, name in group.items()
    ] + [("output", symbol, name) for symbol, name in mapping.outputs.items()]
    span: dict[str, dict[str, Any]] = {}
    for kind, symbol, name in named:
        if name not in trimmed or kept[name].time_ns.size == 0:
            continue
        read, times = trimmed[name].time_ns, kept[name].time_ns
        label = f"{kind} {symbol!r} ({word} {name!r})"
        start, end = int(times[0]), int(times[-1])
        if start > int(read[0]) and abs(start - first) <= tolerance and "start" not in span:
            span["start"] = {
                "signal": label,
                "at": start / NS_PER_S,
                "dropped": int(np.count_nonzero(read < start)),
                "from": int(read[0]) / NS_PER_S,
            }
        ends_grid = symbol in bounding and -tolerance <= last - end <= dt_ns // 2 + tolerance
        if end < int(read[-1]) and ends_grid and "end" not in span:
            span["end"] = {
                "signal": label,
                "at": end / NS_PER_S,
                "dropped": int(np.count_nonzero(read > end)),
                "from": int(read[-1]) / NS_PER_S,
            }
    if span:
        notes["nonfinite_span"] = span


def _without_unreadable_truth(
    mapping: SignalMap, err: FieldError, field_word: str
) -> SignalMap | None:
    """``mapping`` without the ground truth of a field whose values cannot be read, or ``None``.

    Ground truth found by default or by the model's ``[truth]`` table that cannot be read as
    asked is no truth, recorded in ``unusable_truth``, whether the mapping saw it from the
    field's definition (a ROS topic without ``header.stamp`` under ``--time header``) or the
    read found it in the messages (a JSON topic, whose schema need not list its fields: a
    message without ``header``; ``FieldError.unusable``).  ``None`` for a bad value (a text
    among numbers is an error, as a CSV cell is), and when the field also feeds an input,
    output or command, or a symbol named with ``--map``: that is an error.
    """
    readers = [s for s, read in mapping.fields_read().items() if read["field"] == err.name]
    if not err.unusable or any(
        not s.startswith(TRUTH_PREFIX) or mapping.origins.get(s) == "--map" for s in readers
    ):
        return None
    why = f"{field_word} {err.name!r}: {err.reason}"
    return replace(
        mapping,
        truth_mode=None if mapping.truth_mode == err.name else mapping.truth_mode,
        truth_states={x: f for x, f in mapping.truth_states.items() if f != err.name},
        truth_components={c: f for c, f in mapping.truth_components.items() if f != err.name},
        unusable_truth={**mapping.unusable_truth, **dict.fromkeys(readers, why)},
    )


def _without_empty_truth(
    mapping: SignalMap,
    numeric: Mapping[str, Series],
    labels: Mapping[str, LabelSeries],
    maps: Mapping[str, str],
    path: str,
    field_word: str,
    notes: dict[str, Any],
    emptied: Mapping[str, int],
) -> SignalMap:
    """``mapping`` without the ground truth whose field has no samples.

    Ground truth is optional: a field found by default or by the model's ``[truth]`` table
    that holds no sample (an empty ``mode`` column, a state column whose every value was
    dropped by ``--drop-nonfinite``) is no truth, as a field that is not there (recorded in
    ``notes["truth_without_samples"]``).  A field the user named with ``--map`` must have
    samples.  ``emptied`` counts the samples of the fields ``--drop-nonfinite`` emptied.

    Raises
    ------
    LogError
        For a ground-truth symbol mapped with ``--map`` to a field without samples.
    """
    empty: list[str] = []

    def has_samples(symbol: str, name: str, count: int) -> bool:
        if count:
            return True
        if symbol in maps:
            why = f"usable samples: {_all_dropped(emptied[name])}" if name in emptied else "samples"
            raise LogError(
                f"{path}: {symbol} ({field_word} {name!r}, from --map {symbol}={name}) has no {why}"
            )
        empty.append(f"{symbol} ({field_word} {name!r})")
        return False

    truth_mode = mapping.truth_mode
    if truth_mode is not None and not has_samples(
        TRUTH_MODE, truth_mode, labels[truth_mode].time_ns.size
    ):
        truth_mode = None
    states = {
        x: name
        for x, name in mapping.truth_states.items()
        if has_samples(f"{TRUTH_PREFIX}{x}", name, numeric[name].time_ns.size)
    }
    components = {
        c: name
        for c, name in mapping.truth_components.items()
        if has_samples(component_truth_symbol(c), name, labels[name].time_ns.size)
    }
    if empty:
        notes["truth_without_samples"] = empty
    return replace(mapping, truth_mode=truth_mode, truth_states=states, truth_components=components)


def _truth_sharing(
    mapping: SignalMap,
    field_key: Callable[[str], FieldKey],
    inputs: Sequence[str],
    field_word: str,
) -> list[str]:
    """Ground truth read from the field of an input or output, one entry each.

    Allowed (a state measured directly), but such truth is the measurement, not independent
    of it: the report says so (``truth_shared``), beside ``reading.fields``.
    """
    signal_of = {
        field_key(name): f"{'input' if symbol in inputs else 'output'} {symbol!r}"
        for symbol, name in {**mapping.inputs, **mapping.outputs}.items()
    }
    truth = {
        **{component_truth_symbol(c): name for c, name in mapping.truth_components.items()},
        **({} if mapping.truth_mode is None else {TRUTH_MODE: mapping.truth_mode}),
        **{f"{TRUTH_PREFIX}{x}": name for x, name in mapping.truth_states.items()},
    }
    return [
        f"{symbol} ({field_word} {name!r}, also {signal_of[field_key(name)]})"
        for symbol, name in truth.items()
        if field_key(name) in signal_of
    ]


def _all_dropped(count: int) -> str:
    """Why a field emptied by ``--drop-nonfinite`` has no samples."""
    return (
        f"--drop-nonfinite dropped all {count} (NaN, infinite, or out of range: |value| >= 2^480)"
    )


def _all_usable(values: npt.NDArray[np.float64]) -> bool:
    """Whether every value is finite and below :data:`MAX_MAGNITUDE` in magnitude.

    From the smallest and largest value (NaN when any is NaN), without the full-size masks
    that are built only to find or drop the bad samples.
    """
    if values.size == 0:
        return True
    lo, hi = float(values.min()), float(values.max())
    return lo > -MAX_MAGNITUDE and hi < MAX_MAGNITUDE


def _canonical(label: str) -> str:
    """``label`` in Unicode's composed form (NFC), as mode ids and labels are compared."""
    return unicodedata.normalize("NFC", label)


def _truth_mode_codes(
    path: str,
    locate: Locate,
    series: LabelSeries,
    mode_ids: Sequence[str],
    *,
    symbol: str = "truth.mode",
    origin: str = "--map",
) -> IntArray:
    """Translate a true-mode label series (of ``symbol``) into indices of ``mode_ids``.

    Labels and mode ids are compared as text after stripping whitespace: ``"1"`` matches mode
    ``"1"``, ``"01"`` does not; the readers give a whole number written as a float (``1.0``,
    in a float column or field, or in a CSV column of numbers) as ``"1"``.  The text is
    compared in Unicode's composed form (NFC): a log writing ``é`` as ``e`` and a combining
    accent names the model's ``é`` (which the loader keeps distinct in that form,
    :func:`~hybridlog.model.values.check_distinct_labels`); it was refused as no mode, the
    error listing an id that looked the same.

    ``origin`` says where the field came from (``SignalMap.origins``): one read as the true
    mode by its name (``"default"``, a CSV column ``mode``) or by the model's ``[truth]``
    table, not by the user, may be a column that means something else (a controller's
    ``AUTO``/``MANUAL``); the refusal then says how to name another field or none.

    Raises
    ------
    LogError
        Naming the first sample whose label is not a mode id, with its location and time.
    """
    index = {_canonical(mode_id.strip()): i for i, mode_id in enumerate(mode_ids)}
    lookup = np.array(
        [index.get(_canonical(label), -1) for label in series.categories], dtype=np.int64
    )
    codes: IntArray = lookup[series.codes] if lookup.size else series.codes.copy()
    bad = codes < 0
    if bad.any():
        first = int(np.argmax(bad))
        label = series.categories[int(series.codes[first])]
        owner = "the model" if symbol == "truth.mode" else f"component {symbol[11:]!r}"
        raise LogError(
            f"{path}, {locate(series.name, first)}: {symbol} {label!r} at "
            f"t={format_ns(int(series.time_ns[first]))} s is not a mode of {owner} "
            f"(mode ids: {', '.join(mode_ids)}; compared as text){_read_as_truth(origin, symbol)}"
        )
    return codes


def _read_as_truth(origin: str, symbol: str) -> str:
    """Why a field nobody named was read as ``symbol``, and the remedy ("" for ``--map``)."""
    if origin == "--map":
        return ""
    why = "by its name" if origin == "default" else f"as the model's {origin} names it"
    return (
        f"; it was read as {symbol} {why}: if it holds something else, rename it in the log, "
        f"or name the true modes' field with --map {symbol}=FIELD"
    )


def _refuse_nonfinite(path: str, locate: Locate, series: Series, symbol: str) -> None:
    """Raise for the first NaN or infinite value of ``series``, if any."""
    bad = ~np.isfinite(series.values)
    if bad.any():
        first = int(np.argmax(bad))
        value = float(series.values[first])
        raise LogError(
            f"{path}, {locate(series.name, first)}: {value} for {symbol} at "
            f"t={format_ns(int(series.time_ns[first]))} s (mapped signals must be finite)"
        )


def _refuse_out_of_range(
    path: str, locate: Locate, series: Series, symbol: str, usable: npt.NDArray[np.bool_]
) -> None:
    """Raise for the first finite value of ``series`` whose magnitude is absurd."""
    first = int(np.argmax(~usable))
    raise LogError(
        f"{path}, {locate(series.name, first)}: {series.values[first]:.6g} for "
        f"{symbol} at t={format_ns(int(series.time_ns[first]))} s is out of range "
        f"(|value| >= 2^480 = {MAX_MAGNITUDE:.3g}: no measurement is that large, corrupt bytes "
        "are; --drop-nonfinite drops such samples)"
    )
