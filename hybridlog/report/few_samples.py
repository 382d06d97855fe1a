"""The warning that a report's metrics are over too few samples to judge the estimator by.

:data:`FEW_SAMPLES` and :func:`few_samples_warning`, which names each metric over fewer and
how far off its variance may be; its text ends with :data:`FEW_SAMPLES_REMEDY`.
:func:`few_samples_of` is the count behind one gated metric, for the gate's own line.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from hybridlog.report.document import Report
from hybridlog.report.markdown import WARNING_PREFIX, plural

__all__ = ["FEW_SAMPLES", "FEW_SAMPLES_REMEDY", "few_samples_of", "few_samples_warning"]

FEW_SAMPLES = 30
"""Fewest samples a metric is taken over without a warning that it describes those samples,
not the estimator (:func:`few_samples_warning`): the variance of ``n`` samples of Gaussian
noise is off from the noise's by ``sqrt(2/(n-1))`` of itself (one standard deviation: 82 %
at 4 samples, 26 % at 30), and MSE, VAF and fit are built of such sums; over a short log
the filter's start (its prior, and the samples it takes to find the mode) weighs as much
as the rest (``sample_logs/three_tank_hstf.csv``'s first 5 samples: hstf's VAF 5.2 % and
mode accuracy 0 against 301 samples' 87 % and 99 %).  The threshold of the innovations'
test (:data:`hybridlog.estimators.consistency.MIN_SAMPLES`) for the same reason."""


def _sample_counts(samples: Mapping[str, int | None]) -> str:
    """``4 samples`` when every named count is that, else ``4 (y1), 3 (y2)``."""
    counts = {n for n in samples.values() if n is not None}
    if len(counts) == 1:
        return plural(counts.pop(), "sample")
    return ", ".join(f"{n:,} ({name})" for name, n in samples.items() if n is not None)


FEW_SAMPLES_REMEDY = (
    f"judge the estimator on a log that gives each metric at least {FEW_SAMPLES} samples"
)
"""What to do, ending :func:`few_samples_warning`'s text (so report.md, report.json, the
terminal, comparison.md, the summaries and JUnit, which all carry the note whole)."""


def few_samples_warning(report: Report) -> str | None:
    """The warning that metrics are over fewer than :data:`FEW_SAMPLES` samples, or ``None``.

    A metric counts when it is over at least one sample (a metric over none is ``null`` and
    says why): the output metrics per output, the mode metrics (a ``[components]`` model's
    joint accuracy, and each component's over other samples than the joint one: without
    every component's true mode there is no joint accuracy, and a component's own is over
    the samples its true mode covers), the state RMSE per state.
    """
    outputs = {
        y: o.samples for y, o in report.outputs.items() if o.samples and o.samples < FEW_SAMPLES
    }
    states = {
        x: s.samples for x, s in report.states.items() if s.samples and s.samples < FEW_SAMPLES
    }
    joint = report.modes.samples
    modes = joint if joint and joint < FEW_SAMPLES and report.modes.accuracy is not None else None
    components = {
        c: m.samples
        for c, m in report.modes.components.items()
        if m.accuracy is not None and m.samples and m.samples < FEW_SAMPLES and m.samples != modes
    }
    parts = []
    if outputs:
        every = "" if len(outputs) == len(report.outputs) else f" of {', '.join(outputs)}"
        parts.append(f"MSE, VAF and fit{every} over {_sample_counts(outputs)}")
    if modes:
        parts.append(f"mode accuracy over {plural(modes, 'sample')}")
    if components:
        named = "component" if len(components) == 1 else "components"
        parts.append(
            f"mode accuracy of {named} {', '.join(components)} over {_sample_counts(components)}"
        )
    if states:
        every = "" if len(states) == len(report.states) else f" of {', '.join(states)}"
        parts.append(f"state RMSE{every} over {_sample_counts(states)}")
    if not parts:
        return None
    counted = [
        *outputs.values(),
        *components.values(),
        *states.values(),
        *([modes] if modes else []),
    ]
    least = min(counted, default=0)
    off = math.sqrt(2.0 / (least - 1)) if least > 1 else math.inf
    spread = f" ({off:.0%} at {least})" if math.isfinite(off) else ""
    return (
        f"{WARNING_PREFIX}{'; '.join(parts)}: fewer than {FEW_SAMPLES} samples, they describe "
        "these samples, not the estimator: the filter's start weighs as much as the rest, and "
        f"a variance over n samples is off by sqrt(2/(n-1)) of itself{spread}; {FEW_SAMPLES_REMEDY}"
    )


_OUTPUT_METRICS = frozenset({"vaf", "fit", "mse"})


def few_samples_of(report: Report, name: str) -> int | None:
    """The samples behind the gated metric ``name`` when fewer than :data:`FEW_SAMPLES`.

    ``vaf``, ``fit`` and ``mse`` (a mean over the outputs: its least count), ``vaf.y1``,
    ``mode_accuracy`` (``.c`` a component's) and ``state_rmse.x``, counted as
    :func:`few_samples_warning` counts them; ``None`` for at least that many, a metric over
    none (``null``, which says why) and the metrics not of samples (switch counts, delays).
    A met gate read ``met (vaf = 0.9)`` over 4 samples, the warning printed apart from it.
    """
    base, dot, qualifier = name.partition(".")
    counts: list[int | None] = []
    if base in _OUTPUT_METRICS:
        chosen = [report.outputs.get(qualifier)] if dot else list(report.outputs.values())
        counts = [o.samples for o in chosen if o is not None]
    elif base == "mode_accuracy":
        modes = report.modes.components.get(qualifier) if dot else report.modes
        counts = [None if modes is None else modes.samples]
    elif base == "state_rmse" and qualifier in report.states:
        counts = [report.states[qualifier].samples]
    least = min((n for n in counts if n), default=None)
    return least if least is not None and least < FEW_SAMPLES else None
