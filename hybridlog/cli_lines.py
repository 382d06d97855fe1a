"""What the commands print: lines on stdout and stderr, safe for a terminal and bounded.

The summary line of a report (:func:`summary_line`), the lines naming what a command wrote
(:func:`path_text`), notes, warnings and gate failures on stderr (:func:`one_line`: one
printable line of at most :data:`MAX_MESSAGE` characters), ``--quiet`` respected
(:func:`say`).
"""

from __future__ import annotations

import re
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING

import click

from hybridlog.cli_options import is_quiet
from hybridlog.errors import as_text, excerpt, on_one_line, printable, shortened

if TYPE_CHECKING:
    from hybridlog.report.document import Report


MAX_MESSAGE = 1000
"""Longest error or warning line the CLI prints (longer ones are cut in the middle, between
words: :func:`~hybridlog.errors.shortened`); a warning of 550 characters (``analyze`` on
bioplex_pgc) lost its middle at 400."""


def say(ctx: click.Context, text: str) -> None:
    """``text`` on stdout (:func:`for_terminal`), unless ``--quiet`` was given."""
    if not is_quiet(ctx):
        click.echo(for_terminal(text))


def path_text(path: object) -> str:
    r"""A path on one line: a line break or tab in it escaped too (``\n``), as errors show it.

    The lines naming what a command wrote (``report: ...``) are one a path, for scripts
    that read them; :func:`for_terminal` keeps a text's line breaks.
    """
    return "".join(c if c.isprintable() else excerpt(c)[1:-1] for c in as_text(path))


def for_terminal(text: str) -> str:
    r"""Lines for stdout: names as the system gave them, but nothing a terminal acts on.

    A log named with bytes that are not UTF-8 or with control characters (an escape
    sequence) is shown ``\xNN`` (:func:`~hybridlog.errors.as_text`, :func:`excerpt`'s
    escapes); line breaks and tabs stay.
    """
    return "\n".join(
        "".join(c if c.isprintable() or c == "\t" else excerpt(c)[1:-1] for c in as_text(line))
        for line in text.split("\n")
    )


def one_line(text: str) -> str:
    r"""The final guard on everything printed to stderr: one printable, bounded line.

    A byte that is not UTF-8 in what the user typed is shown ``\xNN``, as
    :func:`~hybridlog.errors.excerpt` shows it, also where a message quoted the value with
    ``repr`` (click's choices, ``--fail-under``, ``--map``'s column, a library's reason):
    those read ``'\udcff'`` for the ``\xff`` typed, beside ``'\xff'`` in the same line.
    """
    line = _ESCAPED_BYTE.sub(r"\\x\1", printable(on_one_line(str(text))))
    return shortened(line, MAX_MESSAGE)


_ESCAPED_BYTE = re.compile(r"(?<!\\)\\udc([89a-f][0-9a-f])")
"""``repr``'s text of a byte that is not UTF-8 (a lone surrogate U+DC80-U+DCFF, as Python
decodes such bytes of the command line), not preceded by a backslash of its own."""


def summary_line(report: Report) -> str:
    """``analyze``'s line of a report: the estimator, the log, VAF, fit, MSE, mode accuracy.

    With what each number is over where it is not the whole log, the filter's own mode
    accuracy beside a smoothed one, the switches detected and where the smoother fell back.
    """
    from hybridlog.report.markdown import duration, format_number, format_percent, plural

    def percent(value: float | None, decimals: int) -> str:
        return "n/a" if value is None else f"{format_percent(value, decimals)} %"

    text = (
        f"{report.estimator} on {path_text(report.log)}: {plural(report.samples, 'sample')} "
        f"in {duration(report.runtime_s)}, VAF {percent(report.vaf, 2)}"
        f"{_part_of_the_outputs(report, 'vaf')}, fit {percent(report.fit, 2)}"
        f"{_part_of_the_outputs(report, 'fit')}, MSE {format_number(report.mse, '.4g')}"
        f"{_part_of_the_outputs(report, 'mse')}"
    )
    text += _predicted_samples_text(report)
    text += _mode_accuracy_text(report, percent(_percent(report.modes.accuracy), 1))
    scored = report.modes.samples
    if report.modes.accuracy is not None and scored is not None and scored < report.samples:
        text += f" (over the {plural(scored, 'sample')} with a true mode)"
    smoothing = report.smoothing
    if smoothing is not None and smoothing.filtered.mode_accuracy is not None:
        text += f" (filtered {percent(_percent(smoothing.filtered.mode_accuracy), 1)})"
    detection = report.modes.detection
    if detection is not None:
        switches = plural(len(detection.events), "true switch")
        text += f", {switches}: {detection.detected:,} detected, {detection.missed:,} missed"
        if detection.undetermined:  # the true mode's gaps: neither detected nor missed
            text += f", {detection.undetermined:,} undetermined"
    fallbacks = None if smoothing is None else smoothing.fallbacks
    if fallbacks is not None and fallbacks.samples:  # part of the "smoothed" estimate is not
        text += f"; {fallbacks.summary()}"
    return text


def _predicted_samples_text(report: Report) -> str:
    """`` (over 297 of 300 predicted samples)`` where the metrics are over part of the log.

    A VAF over 73 of 399 predictions read like the whole log's (a gap, a late start).  The
    count is over the outputs the means are over: an output scored on no sample (its metrics
    n/a, which ``_part_of_the_outputs`` says) made the line read "MSE 5.816 (over 0 of 199
    predicted samples)" for an MSE over 199 samples of the other output; and where the outputs
    are scored on different counts (one of them not predicted while its component was
    ``unknown``), the line gives the range, not the smallest as if it held for all.
    """
    counts = [o.samples for o in report.outputs.values() if o.samples]  # 0: n/a, named
    predicted = report.samples - 1  # row 0 is the prior
    if not counts or min(counts) >= predicted:
        return ""
    low, high = min(counts), max(counts)
    if low == high:
        return f" (over {low:,} of {predicted:,} predicted samples)"
    return f" (over {low:,} to {high:,} of {predicted:,} predicted samples, by output)"


_NAMED_OUTPUTS = 3
"""Outputs named where a mean leaves some out; past that, how many more."""


def _part_of_the_outputs(report: Report, metric: str) -> str:
    """`` (mean of 2 of 3 outputs; y1's n/a)`` where the mean ``metric`` leaves outputs out.

    The mean over the outputs is over those where the metric is defined
    (:func:`~hybridlog.report.metrics.mean_where_defined`): report.md's table shows the
    ``n/a`` beside it, comparison.md and a gate's message name what it leaves out, but the
    line read ``fit 99.37 %`` for a log whose y1 was a dead sensor (constant: its fit is
    undefined) and the other two outputs fitted.
    """
    if getattr(report, metric) is None:  # no mean at all: n/a says it
        return ""
    missing = [y for y, o in report.outputs.items() if getattr(o, metric) is None]
    if not missing:
        return ""
    named = ", ".join(path_text(y) for y in missing[:_NAMED_OUTPUTS])
    if len(missing) > _NAMED_OUTPUTS:
        named += f" and {len(missing) - _NAMED_OUTPUTS:,} more"
    whose = f"{named}'s" if len(missing) == 1 else f"those of {named}"
    kept = len(report.outputs) - len(missing)
    return f" (mean of {kept:,} of {len(report.outputs):,} outputs; {whose} n/a)"


def _mode_accuracy_text(report: Report, shown: str) -> str:
    """``, mode accuracy 99.0 %``; of a ``[components]`` model, which accuracy it is.

    There it is the share of samples with every component's mode right, and ``n/a`` where the
    log has the true mode of only some components, each of which report.md scores: ``mode
    accuracy n/a`` read as a log without any true mode.
    """
    modes = report.modes
    if not (modes.components or modes.components_without_truth):
        return f", mode accuracy {shown}"
    if modes.accuracy is None and modes.components:
        scored = ", ".join(modes.components)
        return (
            f", mode accuracy (every component right) n/a: the log has the true mode of only "
            f"some components ({scored}: each scored in report.md)"
        )
    return f", mode accuracy (every component right) {shown}"


def _percent(fraction: float | None) -> float | None:
    return None if fraction is None else 100.0 * fraction


def have_warnings(warned: int, total: int, kind: str) -> str:
    """``3 of 1,000 analysed logs have warnings``, ``1 of 2 estimators has warnings``.

    Out of the reports written (``kind``: what they are of), as summary.md counts them.
    """
    from hybridlog.report.markdown import plural

    return f"{warned:,} of {plural(total, kind)} {'has' if warned == 1 else 'have'} warnings"


def echo_unused_samples(report: Report) -> None:
    """A line on stderr per note of ``report`` saying samples of the log are not used.

    A log sampled at twice the model's rate loses every other sample, and ``--split-gaps``
    analyses the longest piece alone: report.md said so in a NOTE, the terminal nothing,
    under a summary line that read as the whole log's.
    """
    from hybridlog.report.reading_notes import unanalysed_span_notes, unused_sample_notes

    reading = report.reading
    for note in [*unused_sample_notes(reading), *unanalysed_span_notes(reading)]:
        click.echo(one_line(f"hybridlog: note: {note.removeprefix('NOTE: ')}"), err=True)


def gate_exit(failures: Sequence[str]) -> None:
    """A line on stderr per missed CI gate, then exit code 1 if there was one."""
    for failure in failures:
        click.echo(one_line(f"hybridlog: gate failed: {failure}"), err=True)
    if failures:
        sys.exit(1)
