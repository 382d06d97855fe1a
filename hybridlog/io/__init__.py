"""Logs → aligned signals.

:func:`load_signals` is the one entry point the commands use: it opens a log with the reader
for its format (:func:`open_log`), maps model symbols to log fields (:mod:`.mapping`), reads
only those fields, checks them, and aligns them onto the model's grid (:mod:`.align`).
Readers implement :class:`~hybridlog.io.source.LogSource`; a new format only has to register
an opener in :data:`~hybridlog.io.readers.READERS`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence

from hybridlog.io.align import align_signals, check_alignment_options
from hybridlog.io.inspect import format_inspection, inspect_log
from hybridlog.io.mapping import SignalMap, parse_maps, resolve_signal_map
from hybridlog.io.readers import READERS, open_log
from hybridlog.io.source import (
    LabelSeries,
    LogSource,
    Series,
    check_finite,
    labels_to_codes,
)
from hybridlog.io.writers import write_table
from hybridlog.signals import AlignedSignals

__all__ = [
    "READERS",
    "LabelSeries",
    "LogSource",
    "Series",
    "SignalMap",
    "format_inspection",
    "inspect_log",
    "load_signals",
    "open_log",
    "write_table",
]


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
) -> AlignedSignals:
    """Read a log and align the model's signals onto its grid ``t0 + k*dt``.

    Parameters
    ----------
    path:
        The log (``.csv`` or ``.parquet``).
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

    Returns
    -------
    AlignedSignals

    Raises
    ------
    OptionError
        For a malformed ``--map``, an unknown symbol, an unknown ``resample`` or a bad
        ``max_gap``.
    LogError
        For a missing or unreadable log, a missing field, a non-numeric, NaN or infinite
        value, time going backwards, an unknown true mode, or an over-long gap.
    """
    check_alignment_options(dt, resample, max_gap)
    parsed = parse_maps(maps, inputs=inputs, outputs=outputs, states=states)
    with open_log(path) as source:
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
        for name, series in numeric_series.items():
            check_finite(source, series, symbols[name])
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
        )
