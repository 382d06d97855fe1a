"""Logs → aligned signals.

:func:`load_signals` is the one entry point the commands use: it opens a log with the reader
for its format (:func:`open_log`: CSV/Parquet, MCAP, ROS 1 and ROS 2 bags), maps model symbols
to log fields (:mod:`.mapping`: column names or message paths), reads only those fields,
checks them, and aligns them onto the model's grid (:mod:`.align`).  Readers implement
:class:`~hybridlog.io.source.LogSource`; a new format registers in :mod:`.readers`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from hybridlog.errors import LogError, OptionError
from hybridlog.lazy import lazy_exports

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    from hybridlog.io.inspect import format_inspection, inspect_log
    from hybridlog.io.mapping import SignalMap
    from hybridlog.io.readers import FORMATS, open_log
    from hybridlog.io.source import LabelSeries, LogSource, ReadSettings, Series
    from hybridlog.io.writers import write_table
    from hybridlog.signals import AlignedSignals

__all__ = [
    "FORMATS",
    "LabelSeries",
    "LogSource",
    "ReadSettings",
    "Series",
    "SignalMap",
    "format_inspection",
    "inspect_log",
    "load_signals",
    "open_log",
    "write_table",
]

# Imported on first use, so that importing a light module of io/ (``hybridlog simulate
# --help`` reads the log formats) loads no numpy, polars, mcap or rosbags.
__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        ".inspect": ["format_inspection", "inspect_log"],
        ".mapping": ["SignalMap"],
        ".readers": ["FORMATS", "open_log"],
        ".source": ["LabelSeries", "LogSource", "ReadSettings", "Series"],
        ".writers": ["write_table"],
    },
)


def load_signals(
    path: str | os.PathLike[str],
    *,
    states: Sequence[str],
    inputs: Sequence[str],
    outputs: Sequence[str],
    mode_ids: Sequence[str],
    dt: float,
    signals: Mapping[str, str] | None = None,
    truth: Mapping[str, str] | None = None,
    maps: Sequence[str] = (),
    resample: str = "nearest",
    max_gap: float | None = None,
    settings: ReadSettings | None = None,
    split_gaps: bool = False,
    drop_nonfinite: bool = False,
    notes: dict[str, Any] | None = None,
) -> AlignedSignals:
    """Read a log and align the model's signals onto its grid ``t0 + k*dt``.

    Parameters
    ----------
    path:
        The log: ``.csv``, ``.parquet``, ``.mcap``, ``.bag``, ``.db3`` or a ROS 2 bag folder.
    states, inputs, outputs:
        The model's symbol names, in vector order.
    mode_ids:
        The model's mode ids; true-mode labels must be among them (compared as text).
    dt:
        The model's sample time in seconds.
    signals, truth:
        The model's ``[signals]`` and ``[truth]`` tables (symbol → message path).
    maps:
        ``--map SYMBOL=PATH`` option values.
    resample:
        ``"nearest"`` (default) or ``"linear"``, for outputs and true states.
    max_gap:
        Longest tolerated gap in the outputs, in seconds; default ``5*dt``.
    settings:
        How the reader takes samples (``--time``, ``--sort``, ``--recover``, ``--msg-dir``).
    split_gaps:
        Analyse the longest piece between over-long output gaps instead of refusing the log.
    drop_nonfinite:
        Drop NaN, infinite and out-of-range samples (counted in ``notes``) instead of
        refusing the log.  Out of range means ``|value| >= 2**480``
        (:data:`~hybridlog.signals.MAX_MAGNITUDE`): no measurement is that large, and the
        squares the metrics sum would overflow float64; corrupt bytes decode to such values.
    notes:
        Filled with what reading did, for the report: the format, the time source, and
        recovery, sorting, dropped samples and gap pieces where they apply.

    Returns
    -------
    AlignedSignals

    Raises
    ------
    OptionError
        For a malformed ``--map``, an unknown symbol, an unknown ``resample`` or a bad
        ``max_gap``.
    LogError
        For a missing or unreadable log, a missing field, a non-numeric, NaN, infinite or
        out-of-range value, time going backwards, an unknown true mode, or an over-long gap.
    """
    import numpy as np

    from hybridlog.io.align import align_signals, check_alignment_options
    from hybridlog.io.mapping import parse_maps, resolve_signal_map
    from hybridlog.io.readers import open_log
    from hybridlog.io.source import (
        TIME_SOURCES,
        LabelSeries,
        ReadSettings,
        Series,
        check_finite,
        labels_to_codes,
    )
    from hybridlog.signals import MAX_MAGNITUDE

    check_alignment_options(dt, resample, max_gap)
    settings = settings or ReadSettings()
    if settings.time not in TIME_SOURCES:
        raise OptionError(
            f"--time: expected one of {', '.join(TIME_SOURCES)}, got {settings.time!r}"
        )
    parsed = parse_maps(maps, inputs=inputs, outputs=outputs, states=states)
    notes = notes if notes is not None else {}
    with open_log(path, settings) as source:
        mapping = resolve_signal_map(
            source.fields(),
            source=source.path,
            inputs=inputs,
            outputs=outputs,
            states=states,
            signals=signals,
            truth=truth,
            maps=parsed,
            field_word=source.field_word,
            message_paths=source.message_paths,
            explain=source.explain_missing,
        )
        symbols = {
            **{field: f"input {u!r}" for u, field in mapping.inputs.items()},
            **{field: f"output {y!r}" for y, field in mapping.outputs.items()},
            **{field: f"truth.{x}" for x, field in mapping.truth_states.items()},
        }
        numeric = list(
            dict.fromkeys(
                [
                    *mapping.inputs.values(),
                    *mapping.outputs.values(),
                    *mapping.truth_states.values(),
                ]
            )
        )
        labels = [mapping.truth_mode] if mapping.truth_mode is not None else []
        numeric_series, label_series = source.read(numeric, labels)
        dropped: dict[str, int] = {}
        out_of_range: dict[str, int] = {}
        for name, series in list(numeric_series.items()):
            finite = np.isfinite(series.values)
            usable = finite & (np.abs(series.values) < MAX_MAGNITUDE)
            if usable.all():
                continue
            if not drop_nonfinite:
                check_finite(source, series, symbols[name])
                _refuse_out_of_range(source, series, symbols[name], usable)
            if not finite.all():
                dropped[name] = int((~finite).sum())
            if (finite & ~usable).any():
                out_of_range[name] = int((finite & ~usable).sum())
            numeric_series[name] = Series(name, series.time_ns[usable], series.values[usable])
        notes.update({"format": source.format, "time": settings.time})
        notes.update(source.notes())
        if dropped:
            notes["nonfinite_dropped"] = dropped
        if out_of_range:
            notes["out_of_range_dropped"] = out_of_range
        truth_mode = None
        if mapping.truth_mode is not None:
            mode_series = label_series[mapping.truth_mode]
            codes = labels_to_codes(source, mode_series, mode_ids, "truth.mode")
            truth_mode = LabelSeries(mode_series.name, mode_series.time_ns, codes, tuple(mode_ids))
        return align_signals(
            source=source.path,
            dt=dt,
            inputs={u: numeric_series[f] for u, f in mapping.inputs.items()},
            outputs={y: numeric_series[f] for y, f in mapping.outputs.items()},
            truth_mode=truth_mode,
            states=states,
            truth_states={x: numeric_series[f] for x, f in mapping.truth_states.items()},
            resample=resample,
            max_gap=max_gap,
            split_gaps=split_gaps,
            notes=notes,
        )


def _refuse_out_of_range(
    source: LogSource, series: Series, symbol: str, usable: npt.NDArray[np.bool_]
) -> None:
    """Raise for the first finite value of ``series`` whose magnitude is absurd."""
    import numpy as np

    from hybridlog.io.source import format_ns
    from hybridlog.signals import MAX_MAGNITUDE

    first = int(np.argmax(~usable))
    raise LogError(
        f"{source.path}, {source.locate(series.name, first)}: {series.values[first]:.6g} for "
        f"{symbol} at t={format_ns(int(series.time_ns[first]))} s is out of range "
        f"(|value| >= 2^480 = {MAX_MAGNITUDE:.3g}: no measurement is that large, corrupt bytes "
        "are; --drop-nonfinite drops such samples)"
    )
