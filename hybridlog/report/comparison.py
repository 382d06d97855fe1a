"""What ``compare``'s numbers are over, and why a cell is ``n/a``: comparison.md's sections.

``compare`` puts each estimator's numbers from its own report.json side by side, but they
need not be over the same samples: vaf, fit and mse leave out the rows where an estimator
made no one-step-ahead prediction (``unknown-mode`` makes none of an output no filter
cluster determines), and a mean over the outputs leaves out an output whose value is
``null``.  A VAF of 92 over 170 samples beside one of 91 over 179 read as the better
estimator.  Now:

- :func:`sample_counts`: per estimator the samples each number is over, from its report
  (``outputs.<y>.samples``, ``modes.samples``, ``states.<x>.samples``), a table column
  each (``output_samples.y1``, ``mode_samples``, ``state_samples.x1``);
  :func:`unequal_columns` picks those whose counts differ between the estimators, which
  the table then shows;
- :func:`samples_section` says over how many samples each kind of number is, for every
  estimator alike or, where they differ, per estimator, and which means leave out an output;
- :func:`unavailable_section` gives each ``n/a`` cell's reason, as the estimator's
  report.md does (``null_reasons``);
- :func:`reach_section` lists each ``--set`` that reached only some of the estimators (an
  option the others lack, or do not read there): a tuned estimator beside untuned ones.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from hybridlog.report.gates import null_reason, outputs_left_out
from hybridlog.report.markdown import escape_markdown

if TYPE_CHECKING:
    from hybridlog.report.document import Report

__all__ = [
    "MODE_SAMPLES",
    "OUTPUT_METRICS",
    "reach_section",
    "sample_counts",
    "samples_section",
    "unavailable_section",
    "unequal_columns",
]

OUTPUT_METRICS = ("vaf", "fit", "mse")
"""The table's numbers over the outputs' one-step-ahead predictions (a mean over outputs)."""

MODE_SAMPLES = "mode_samples"
"""The column of the samples the mode metrics are over (``modes.samples``)."""

_OUTPUT_PREFIX = "output_samples."
_STATE_PREFIX = "state_samples."


def sample_counts(report: Report, states: Sequence[str] = ()) -> dict[str, int | None]:
    """The samples each kind of number of ``report`` is over, by column name.

    ``output_samples.<y>`` per output (the rows with a measurement and a prediction),
    ``mode_samples`` (the samples with a true mode), and ``state_samples.<x>`` for each of
    ``states`` (the states whose RMSE the table shows).  ``None``: not recorded (a report
    of an older version).
    """
    counts: dict[str, int | None] = {
        _OUTPUT_PREFIX + y: output.samples for y, output in report.outputs.items()
    }
    counts[MODE_SAMPLES] = report.modes.samples
    for x in states:
        state = report.states.get(x)
        counts[_STATE_PREFIX + x] = None if state is None else state.samples
    return counts


def unequal_columns(reports: Mapping[str, Report], states: Sequence[str] = ()) -> tuple[str, ...]:
    """The columns of :func:`sample_counts` whose counts differ between ``reports``.

    A count not recorded (``None``) is not compared.  Empty for fewer than two reports.
    """
    counts = [sample_counts(report, states) for report in reports.values()]
    if len(counts) < 2:
        return ()
    columns = list(dict.fromkeys(c for count in counts for c in count))
    return tuple(
        column
        for column in columns
        if len({count.get(column) for count in counts} - {None}) > 1
        or (any(column not in count for count in counts))
    )


def _over(counts: Mapping[str, int | None], prefix: str, noun: str = "output") -> str:
    """``300 samples of y1, 298 of y2`` or ``300 samples of each output (y1, y2)``."""
    named = [(c.removeprefix(prefix), n) for c, n in counts.items() if c.startswith(prefix)]
    if not named:
        return f"no {noun}"
    values = {n for _, n in named}
    if len(named) > 1 and len(values) == 1:
        (n,) = values
        names = ", ".join(escape_markdown(y, line_start=False) for y, _ in named)
        return f"{_count(n)} samples of each {noun} ({names})"
    # "301 samples of x1 and none of x2" (a gated state the log has no truth of): the
    # second read "and no of x2"
    parts = [f"{n:,}" if n else "none" for _, n in named]
    parts[0] = f"{_count(named[0][1])} samples"
    return _and(
        [
            f"{p} of {escape_markdown(y, line_start=False)}"
            for p, (y, _) in zip(parts, named, strict=True)
        ]
    )


def _count(n: int | None) -> str:
    return "no" if not n else f"{n:,}"  # None: nothing to score (no true mode)


def _and(parts: Sequence[str]) -> str:
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


def _left_out(report: Report, metric: str) -> frozenset[str]:
    """The outputs whose ``metric`` (``vaf``, ``fit``, ``mse``) ``report`` holds as ``null``."""
    return frozenset(y for y, o in report.outputs.items() if getattr(o, metric) is None)


def _describe(own: Mapping[str, int | None]) -> str:
    """The samples of one kind of number: ``300 samples of y1 and 298 of y2``, ``301 samples``."""
    if any(c.startswith(_OUTPUT_PREFIX) for c in own):
        return _over(own, _OUTPUT_PREFIX)
    if len(own) > 1:  # the states' RMSEs
        return _over(own, _STATE_PREFIX, "state")
    return f"{_count(next(iter(own.values())))} samples"


def samples_section(
    reports: Mapping[str, Report], states: Sequence[str] = (), given: Sequence[str] = ()
) -> tuple[list[str], list[str]]:
    """comparison.md's "What the numbers are over" lines, and what is not like for like.

    ``given``: the estimators that read the modes from the log's switching signal
    (``switching-observer``): their reports score no mode metric, which would compare the
    log's true mode with itself (``EstimationResult.modes_given``), and are said so here.
    Returns the Markdown lines (empty without reports) and, for the terminal, what is not
    like for like between the estimators, a phrase each (``vaf, fit and mse are not over
    the same samples for every estimator``; ``vaf is a mean over other outputs for some
    estimators``: one's mean leaves out an output another's has).  A mean that leaves out
    an output is said for each estimator, even when every one leaves out the same.
    """
    if not reports:
        return [], []
    counts = {name: sample_counts(report, states) for name, report in reports.items()}
    unequal = set(unequal_columns(reports, states))
    columns = list(dict.fromkeys(c for count in counts.values() for c in count))
    kinds = [
        ("vaf, fit and mse", [c for c in columns if c.startswith(_OUTPUT_PREFIX)]),
        ("the mode metrics", [MODE_SAMPLES]),
    ]
    if states:  # one line for all the states, as for the outputs
        kind = f"the RMSE of {states[0]}" if len(states) == 1 else "the states' RMSEs"
        kinds.append((kind, [_STATE_PREFIX + x for x in states]))
    lines = ["", "## What the numbers are over", ""]
    unlike: list[str] = []
    for kind, chosen in kinds:
        if not chosen:  # a model without outputs has no vaf to speak of
            continue
        shown = escape_markdown(kind, line_start=False)
        mine = {name: {c: count.get(c) for c in chosen} for name, count in counts.items()}
        differ = sorted(c for c in chosen if c in unequal)
        if not any(n for own in mine.values() for n in own.values()):
            lines.append(f"- {shown}: not scored, no sample to score")
            continue
        if not differ:
            every = "every estimator" if len(reports) > 1 else f"`{next(iter(reports))}`"
            lines.append(f"- {shown}: {every} over {_describe(next(iter(mine.values())))}")
            continue
        unlike.append(f"{kind} are not over the same samples for every estimator")
        per = [f"`{name}` over {_describe(own)}" for name, own in mine.items()]
        lines.append(
            f"- {shown}: **not over the same samples**, so not like for like "
            f"({', '.join(f'`{c}`' for c in differ)} in the table): " + "; ".join(per)
        )
    for metric in OUTPUT_METRICS:
        left_out = {name: _left_out(report, metric) for name, report in reports.items()}
        if len(set(left_out.values())) > 1:  # means over different outputs
            unlike.append(f"{metric} is a mean over other outputs for some estimators")
        for name, report in reports.items():
            partial = outputs_left_out(report, metric)
            if partial is None:
                continue
            # every output's value null: there is no mean, not one leaving some out
            whole = len(left_out[name]) == len(report.outputs)
            said = "has no value, as no output has one:" if whole else "is a mean that leaves out"
            lines.append(
                f"- {metric} of `{name}` {said} " + escape_markdown(partial, line_start=False)
            )
    offline = [name for name, report in reports.items() if report.smoothing is not None]
    if offline and len(offline) < len(reports):
        # the states' RMSEs too, unless the offline pass kept the filter's states (the
        # Viterbi path alone changes the modes only)
        states_too = bool(states) and any(
            (smoothing := reports[name].smoothing) is not None and not smoothing.keeps_filter_states
            for name in offline
        )
        which = "the mode metrics and the states' RMSEs" if states_too else "the mode metrics"
        own = "`filtered_mode_accuracy`" + (" and `filtered_state_rmse.<x>`" if states_too else "")
        unlike.append(f"{which} of {', '.join(offline)} are of offline estimates")
        lines.append(
            f"- {which} of "
            + ", ".join(f"`{name}`" for name in offline)
            + " are of offline estimates (the `smoothing` column), the others' of their own "
            f"estimates: {own} compare every estimator's own"
        )
    for name in given:
        if name not in reports:
            continue
        lines.append(
            f"- `{name}` has no mode metrics: it reads its modes from the log's switching "
            "signal, the log's true mode, so they would score that signal against itself"
        )
    lines += [
        "",
        "vaf, fit and mse use the rows with a measurement and a one-step-ahead prediction "
        "(the first sample, the prior, has none); the mode metrics the samples with a true "
        "mode; a state's RMSE the samples with its true state and an estimate.",
    ]
    return lines, unlike


def unavailable_section(
    columns: Sequence[str],
    rows: Sequence[Sequence[object]],
    reports: Mapping[str, Report],
    metrics: Sequence[str],
) -> list[str]:
    """comparison.md's "Not available" lines: why each ``n/a`` metric cell is one.

    ``columns`` and ``rows`` are the table's (the estimator first in each row); ``metrics``
    the columns that hold a report metric by its gate name (``vaf``, ``state_rmse.x1``).
    A failed estimator's row is left out (its ``error`` cell says why), as are the
    ``filtered_<metric>`` cells (``filtered_mode_accuracy``, ``filtered_state_rmse.<x>``) of
    an estimator not smoothed: each is its ``<metric>``, whose reason is given.  A smoothed
    estimator's says "the filter's own:" and the metric's reason.
    ``smoothing_fallback_weight`` is ``n/a`` where no smoother ran (an estimator without one,
    ``--mode-sequence viterbi`` alone).
    """
    lines: list[str] = []
    for row in rows:
        name = str(row[0])
        report = reports.get(name)
        if report is None:
            continue
        for column, value in zip(columns, row, strict=True):
            if value is not None:
                continue
            if column in metrics:
                why = null_reason(report, column)
            elif column.startswith("filtered_") and report.smoothing is not None:
                own = column.removeprefix("filtered_")
                why = "the filter's own: " + null_reason(report, own)
            elif column == "smoothing_fallback_weight":
                why = "no smoother ran on its estimates, so none fell back to the filter's"
            else:
                continue
            lines.append(f"- `{name}` {column}: {escape_markdown(why, line_start=False)}")
    return ["", "## Not available", "", *lines] if lines else []


def reach_section(reach: Sequence[str]) -> list[str]:
    """comparison.md's "Given to some estimators only" lines: one per phrase of ``reach``.

    ``reach``: each ``--set`` of an estimator option that did not reach every estimator
    compared, what it reached and why not the others
    (``set_reach`` of the ``compare`` job); empty: no section.
    """
    if not reach:
        return []
    lines = [f"- {escape_markdown(phrase, line_start=False)}" for phrase in reach]
    return ["", "## Given to some estimators only", "", *lines]
