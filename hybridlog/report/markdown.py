"""``report.md``: a report for people (and CI job summaries), and the wording it shares.

:func:`render_markdown` writes a :class:`~hybridlog.report.document.Report` as Markdown with
the definitions of its metrics; :func:`plural`, :func:`duration` and :func:`rate` word
counts, times and speeds the same way here and in the command line's messages.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, Protocol

from hybridlog.report.document import command_line_values
from hybridlog.report.gates import met_value
from hybridlog.times import format_time

if TYPE_CHECKING:
    from hybridlog.report.document import Report
    from hybridlog.report.report_parts import ModeReport, Smoothing

__all__ = [
    "DEFINITIONS",
    "FIXED_LIMIT",
    "MAX_LISTED_SWITCHES",
    "WARNING_PREFIX",
    "code_span",
    "duration",
    "escape_markdown",
    "format_number",
    "format_percent",
    "plural",
    "rate",
    "render_markdown",
]

MAX_LISTED_SWITCHES = 50
"""``report.md`` lists at most this many true switches (``report.json`` has all of them)."""


WARNING_PREFIX = "WARNING: "
"""How a note that warns starts (report.json's ``notes``): report.md lists such notes under
"Warnings", first after the run's facts, and the summaries count them."""


FIXED_LIMIT = 1e12
"""Beyond this magnitude a number is written in scientific notation whatever its column's
format: a fit of -1e201 (a diverged prediction) was a cell of 200 digits."""


def format_number(value: Any, spec: str = ".6g") -> str:
    """``value`` by ``spec``; in scientific notation beyond :data:`FIXED_LIMIT`, None as n/a."""
    if value is None:
        return "n/a"
    if isinstance(value, float):
        return format(value, ".6g" if abs(value) >= FIXED_LIMIT else spec)
    return str(value)


def format_percent(value: float | None, decimals: int) -> str:
    """A percentage (VAF, fit, mode accuracy) that reads as 100 only when it is 100.

    To ``decimals`` decimals, more where it would read 100 and is not.  A VAF of 99.99568 %
    read ``100.00 %`` on the terminal, a mode accuracy of 2,999,999 of 3,000,000 samples
    ``100.0000%`` in report.md: a perfect score the run did not have.  Such a value gets the
    decimals that take it off 100 (17 significant digits tell any two floats apart).
    """
    if value is None or not math.isfinite(value) or abs(value) >= FIXED_LIMIT:
        return format_number(value, f".{decimals}f")
    for digits in range(decimals, 18):
        text = f"{value:.{digits}f}"
        if value == 100.0 or float(text) != 100.0:
            return text
    return repr(value)


_MARKUP = re.compile(r"[\\`*\[\]<>&|~$]|(?<![0-9A-Za-z])_|_(?![0-9A-Za-z])")
"""What CommonMark and GitHub's Markdown read as markup inside a line: backslashes, code
spans, emphasis, links, HTML and autolinks, entities, table cells, strikethrough and math.
An underscore inside a word (``three_tank.csv``) is no emphasis and stays as it is."""


_CONTROL = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f]")
"""Control characters but tab and line breaks: a terminal runs ``\\x1b[31m`` as a command."""


_BLOCK_START = re.compile(r"\A(?P<lead>\d{1,9}(?=[.)](?:[ \t]|\Z))|(?=[#+=-]))")
"""What opens a block where the text starts a line (a note, or a failed log, in a list item):
a heading (``# x``), a list (``- x``, ``+ x``, ``1. x``, ``1) x``), a rule (``---``) or a
setext underline; its punctuation gets a backslash (the rest of the line is :data:`_MARKUP`'s:
``*``, ``_``, ``>``, backticks and ``~`` are escaped wherever they are)."""


def _controls_escaped(text: str) -> str:
    return _CONTROL.sub(lambda found: found.group().encode("unicode_escape").decode(), text)


def escape_markdown(text: str, *, line_start: bool = True) -> str:
    r"""``text`` (a log path, a name from a model, an error message) shown as itself in Markdown.

    Each markup character gets a backslash (CommonMark shows any backslash-escaped ASCII
    punctuation as the character), line breaks are written ``\n``/``\r`` and other control
    characters ``\xNN`` (summary.md's table is printed on the terminal too), so that
    ``<b>*x*</b> | y.csv`` stays one table cell of plain text in report.md, summary.md and a
    CI job summary, and ``# 1. run.csv`` the text of a list item, not a heading
    (:data:`_BLOCK_START`).  ``line_start=False`` for text that cannot start a block (a
    table cell): a cell ``-1.2, 0.5`` stays as it is, on the terminal too.
    """
    escaped = _MARKUP.sub(lambda found: "\\" + found.group(0), text)
    if line_start:
        escaped = _BLOCK_START.sub(r"\g<lead>\\", escaped, count=1)
    return _controls_escaped(escaped.replace("\r", "\\r").replace("\n", "\\n"))


def code_span(text: str) -> str:
    r"""``text`` as a Markdown code span: fenced by one backtick more than its longest run.

    CommonMark shows a code span's content as it is; the space padding keeps a backtick at
    either end off the fence, and line breaks are written ``\n`` as in :func:`escape_markdown`.
    """
    text = _controls_escaped(text.replace("\r", "\\r").replace("\n", "\\n"))
    fence = "`" * (max((len(run) for run in re.findall("`+", text)), default=0) + 1)
    pad = " " if text.startswith("`") or text.endswith("`") else ""
    return f"{fence}{pad}{text}{pad}{fence}"


NO_TRUE_MODE_REASON = "the log has no ground-truth mode"
NO_TRUE_STATE_REASON = "the log has no ground truth for state"
"""The start of ``null_reasons["state_rmse.x"]`` for a state the log has no truth of."""
"""``null_reasons.mode_accuracy`` of a log without a true mode."""


def _modes_given(report: Report) -> str:
    """Why the report's modes are given, not estimated (read from the log), else ``""``.

    The report builder leaves every mode metric out for them and says why in
    ``null_reasons`` (:attr:`hybridlog.estimators.result.EstimationResult.modes_given`).
    """
    modes = report.modes
    if modes.accuracy is not None or modes.components or modes.samples == 0:
        return ""
    why = report.null_reasons.get("mode_accuracy", "")
    return "" if why == NO_TRUE_MODE_REASON else why


def plural(count: int, noun: str, plural_form: str | None = None) -> str:
    """``"1 switch"``, ``"2 switches"``: a count with its noun in agreement.

    Parameters
    ----------
    count:
        How many.
    noun:
        The singular noun (or noun phrase ending in the noun).
    plural_form:
        The plural when it is not ``noun + "s"`` (``"es"`` after s, x, ch, sh).

    Returns
    -------
    str
        E.g. ``"1 estimated mode switch"``, ``"0 estimated mode switches"``.

    """
    if count == 1:
        return f"{count} {noun}"
    if plural_form is None:
        plural_form = noun + ("es" if noun.endswith(("s", "x", "ch", "sh")) else "s")
    return f"{count:,} {plural_form}"


def duration(seconds: float | None) -> str:
    """A duration for people, with three significant digits and a unit that fits.

    ``0.00031`` → ``"0.31 ms"``, ``2.5e-6`` → ``"2.5 µs"``, ``12.345`` → ``"12.3 s"``,
    ``None`` → ``"n/a"``.
    """
    if seconds is None or not math.isfinite(seconds):
        return "n/a"
    magnitude = abs(seconds)
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("µs", 1e-6)):
        if magnitude >= scale:
            return f"{seconds / scale:.3g} {unit}"
    return f"{seconds * 1e9:.3g} ns" if magnitude > 0 else "0 s"


def rate(per_second: float | None, noun: str) -> str:
    """``1234567.8`` → ``"1,234,568 samples/s"`` (``"n/a"`` when unknown)."""
    if per_second is None or not math.isfinite(per_second):
        return "n/a"
    return f"{per_second:,.0f} {noun}/s" if per_second >= 100 else f"{per_second:.3g} {noun}/s"


DEFINITIONS = (
    "MSE = mean((y − ŷ)²) and VAF = max(1 − var(y − ŷ)/var(ŷ), 0)·100 % (paper 001) use the "
    "one-step-ahead prediction ŷ(k), made before y(k) is used; the first sample (the prior) "
    "has none.",
    "Fit = (1 − ‖y − ŷ‖/‖y − mean(y)‖)·100 % (MATLAB `compare`'s NRMSE): 100 is perfect, "
    "0 no better than the mean of y, negative worse. Unlike VAF, its denominator does not "
    "depend on the prediction, so a worse predictor cannot score higher.",
    "A metric is n/a (null) when undefined, with the reason given: VAF when var(ŷ) = 0, fit "
    "when y is constant; so is one float64 cannot hold (the MSE of errors of 1e200 or "
    "1e-300). The top rows are the means over the outputs where it is defined; a gate on the "
    "mean fails while any output's is n/a.",
    "Mode accuracy: the fraction of the samples with a true mode (all of them, or those from "
    "the first of a true mode that starts late and outside a sampled true mode's gaps, the "
    "samples without one within dt/2) whose estimated mode is the true one.",
    "Detection delay: from a true switch to the first estimated change *into* the new mode at "
    "or after it, before the next true switch. An estimate that was already in that mode "
    "before the switch has not detected it: a miss, as is a switch never followed by such a "
    "change. The mean and max are over the detected switches.",
)


def _given_line(report: Report) -> list[str]:
    """``- given: `--set A=150`, ...``: the values the command line gave, when any."""
    given = command_line_values(report)
    return [f"- given: {', '.join(code_span(g) for g in given)}"] if given else []


def render_markdown(report: Report) -> str:
    """Render a report for people (``report.md``, CI job summaries).

    Parameters
    ----------
    report:
        A report from :func:`hybridlog.report.build.build_report` (or read back).

    Returns
    -------
    str
        Markdown: title, run facts, per-output MSE/VAF/fit table (with why a metric is
        n/a), mode summary (with accuracy, confusion matrix and every true switch with its
        detection or why it was missed, when the true mode is known), state RMSE table,
        runtime, the estimator's notes and the definitions of the metrics.

    """
    lines: list[str] = [
        f"# hybridlog report: {escape_markdown(report.log)}",
        "",
        f"- model: {code_span(report.model)}, estimator: `{report.estimator}`",
        *_given_line(report),
        f"- samples: {report.samples:,}, dt = {format_number(report.dt)} s, "
        f"t = {format_time(report.t_start)} … {format_time(report.t_end)} s",
        *_fields_line(report.reading),
        f"- hybridlog {report.hybridlog_version}",
        *_warnings_lines(report.notes),
        *_gates_lines(report, report.extra.get("gates")),
        "",
        "## Outputs",
        "",
        *_offline_caveat(report, "outputs"),
        "| output | MSE | VAF (%) | fit (%) |",
        "|---|---:|---:|---:|",
    ]
    for y, m in report.outputs.items():
        lines.append(
            f"| {escape_markdown(y)} | {format_number(m.mse)} | {format_percent(m.vaf, 4)} "
            f"| {format_percent(m.fit, 4)} |"
        )
    lines.append(
        f"| **mean** | **{format_number(report.mse)}** | **{format_percent(report.vaf, 4)}** "
        f"| **{format_percent(report.fit, 4)}** |"
    )
    undefined = [
        f"- {name} is n/a: {escape_markdown(why)}"
        for name, why in report.null_reasons.items()
        if name.partition(".")[0] in ("mse", "vaf", "fit")
    ]
    expected = report.samples - 1  # every sample after the prior
    undefined += [
        f"- {escape_markdown(y)}: metrics over {m.samples:,} of {expected:,} samples; the others "
        "have no finite measurement or no prediction (NaN)"
        for y, m in report.outputs.items()
        if m.samples is not None and m.samples < expected
    ]
    if undefined:
        lines += ["", *undefined]

    modes = report.modes
    lines += ["", "## Modes", "", *_offline_caveat(report, "modes")]
    given = _modes_given(report)
    switches = plural(len(modes.switches), "mode switch" if given else "estimated mode switch")
    signal = given and len(modes.labels) > 1  # a one-mode model's sigma needs no signal
    lines += [f"{switches}{' in the switching signal' if signal else ''}.", ""]
    lines += ["| mode | dwell (s) |", "|---|---:|"]
    lines += [
        f"| {escape_markdown(m)} | {format_number(modes.dwell_s.get(m))} |" for m in modes.labels
    ]
    lines.append("")
    if modes.components:
        lines += _component_lines(modes, report.samples)
    elif modes.accuracy is None and modes.samples == 0:
        lines.append(_NOT_COVERED[0].upper() + _NOT_COVERED[1:] + ".")
    elif given:
        lines.append(given[0].upper() + given[1:] + ".")
    elif modes.accuracy is None:
        lines.append("No ground-truth mode in the log: accuracy and delays are not known.")
    else:
        lines += _truth_lines(modes, modes.accuracy, report.samples)

    if report.states:
        lines += ["", "## States", "", *_offline_caveat(report, "states")]
        lines += ["| state | RMSE |", "|---|---:|"]
        lines += [
            f"| {escape_markdown(x)} | {format_number(s.rmse)} |" for x, s in report.states.items()
        ]
        lines += _state_caveats(report)
    if report.smoothing is not None:
        lines += ["", *_smoothing_lines(report.smoothing)]

    lines += [
        "",
        "## Runtime",
        "",
        f"- estimation: {duration(report.runtime_s)} ({rate(report.samples_per_s, 'samples')})",
    ]
    if report.compile_s is not None:
        lines.append(f"- compilation: {duration(report.compile_s)}")
    notes = [note for note in report.notes if not note.startswith(WARNING_PREFIX)]
    if notes:
        lines += ["", "## Notes", ""]
        lines += [f"- {escape_markdown(note)}" for note in notes]
    lines += ["", "## How the metrics are defined", ""]
    lines += [f"- {text}" for text in DEFINITIONS]
    if _undetermined_anywhere(report):
        lines.append(f"- {UNDETERMINED_DEFINITION}")
    return "\n".join(lines) + "\n"


UNDETERMINED_DEFINITION = (
    "Undetermined: a true switch not detected before the true mode's record stops (a sample "
    "without a true mode, in a gap of it) is neither detected nor missed: the log cannot say "
    "whether the estimate changed into the new mode after that, before the truth left it. "
    "Such switches are counted apart, not among the missed ones (nor in a gate on "
    "missed_switches); a detection before the record stops counts, with its delay."
)
"""report.md's definition of an undetermined switch, given where a report has one."""


def _undetermined_anywhere(report: Report) -> bool:
    """Whether some true switch of ``report`` (or of a side or component) is undetermined."""
    modes = [report.modes, *report.modes.components.values()]
    if any(m.detection is not None and m.detection.undetermined for m in modes):
        return True
    smoothing = report.smoothing
    if smoothing is None:
        return False
    sides = (smoothing.filtered, smoothing.smoothed)
    return any(
        side.undetermined or any(c.undetermined for c in side.components.values()) for side in sides
    )


def _warnings_lines(notes: tuple[str, ...]) -> list[str]:
    """The "Warnings" section: the notes that warn, first after the run's facts.

    At the end of the notes, after the runtime, a reader of the tables above took their
    numbers at face value: a scaled sensor's innovations, a true mode with a gap, an output
    bridged across gaps.  Each warning is written whole, ``WARNING:`` included, as the notes
    of report.json hold it; the other notes stay under "Notes".
    """
    warnings = [note for note in notes if note.startswith(WARNING_PREFIX)]
    if not warnings:
        return []
    return ["", "## Warnings", "", *(f"- {escape_markdown(note)}" for note in warnings)]


def _gates_lines(report: Report, records: Any) -> list[str]:
    """The "Gates" section: each CI gate ``analyze`` checked, met or missed and why.

    From report.json's ``gates`` (:func:`~hybridlog.report.gates.gate_records`), after the
    warnings: a report kept by CI says which bound it missed, not only the exit code.  A met
    gate's value is said as a missed one's would be (:func:`~hybridlog.report.gates.met_value`).
    """
    if not isinstance(records, list) or not records:
        return []
    lines = ["", "## Gates", ""]
    for record in records:
        if not isinstance(record, Mapping):
            continue
        gate = code_span(str(record.get("gate")))
        failure = record.get("failure")
        if failure is not None:
            lines.append(f"- {gate}: **missed**: {escape_markdown(str(failure))}")
        else:
            value, bound = record.get("value"), record.get("bound")
            metric = str(record.get("metric"))
            shown = (
                met_value(report, metric, float(value), float(bound))
                if isinstance(value, (int, float)) and isinstance(bound, (int, float))
                else f"{metric} = n/a"
            )
            lines.append(f"- {gate}: met ({escape_markdown(shown)})")
    return lines


def _fields_line(reading: Mapping[str, Any] | None) -> list[str]:
    """The log field read for each symbol (``reading.fields``), as one list item.

    ``u ← `u`, y1 ← `level` (--map)``: where a field came from is said unless it is the
    default name; nothing for a report without the record (older, or built without a log).
    """
    fields = (reading or {}).get("fields")
    if not isinstance(fields, Mapping) or not fields:
        return []
    parts = []
    for symbol, chosen in fields.items():
        if not isinstance(chosen, Mapping) or not isinstance(chosen.get("field"), str):
            continue
        origin = chosen.get("from")
        where = (
            "" if origin == "default" else f" ({escape_markdown(str(origin), line_start=False)})"
        )
        symbol_text = escape_markdown(str(symbol), line_start=False)
        parts.append(f"{symbol_text} ← {code_span(chosen['field'])}{where}")
    if not parts:
        return []
    return [f"- log fields: {', '.join(parts)} (unmarked: the default name)"]


def _state_caveats(report: Report) -> list[str]:
    """Why a state's RMSE is n/a, and over how many samples one of a partial truth is."""
    caveats = [
        f"- {escape_markdown(name)} is n/a: {escape_markdown(why)}"
        for name, why in report.null_reasons.items()
        if name.partition(".")[0] == "state_rmse"
        # no line per state of a log without any true state: "n/a" says it; a state with a
        # truth but no estimate there (held, not estimated) has one all the same
        and (
            any(s.samples for s in report.states.values())
            or not why.startswith(NO_TRUE_STATE_REASON)
        )
    ]
    # the warnings say which estimates were not finite or not estimated, where there are any
    warned = any(note.startswith(WARNING_PREFIX) for note in report.notes)
    see = ": see the warnings" if warned else ""
    caveats += [
        f"- {escape_markdown(x)}: RMSE over {s.samples:,} of {report.samples:,} samples; the "
        f"others have no true value, or no estimate of it (not finite, or not estimated{see})"
        for x, s in report.states.items()
        if s.samples and s.samples < report.samples
    ]
    return ["", *caveats] if caveats else []


def _change(before: float | int | None, after: float | int | None, spec: str) -> str:
    if before is None or after is None:
        return "n/a"
    return format(after - before, "+" + spec)


class _Switches(Protocol):
    """A side's switch counts: :class:`SmoothingMetrics` or :class:`ComponentSide`."""

    @property
    def detected(self) -> int | None: ...
    @property
    def missed(self) -> int | None: ...
    @property
    def undetermined(self) -> int: ...


def _delays_apart(filtered: _Switches | None, offline: _Switches | None) -> str | None:
    """Why two sides' detection delays are not compared, or ``None`` where they are.

    A delay is a mean (or largest) over the switches a side detected: where a side missed
    some, or the true mode's gaps left some undetermined, the two means may be over other
    switches, and their difference is no gain or loss of either side (the smoother that
    misses two switches the filter caught, 0.43 s → 0 s, read as 0.43 s faster).  The
    counts alone cannot tell which switches each side detected, so only where both detected
    every one are the delays compared.
    """
    if filtered is None or offline is None:
        return None
    if filtered.detected != offline.detected:
        return "n/a (other switches)"
    if filtered.missed or offline.missed or filtered.undetermined or offline.undetermined:
        return "n/a (switches missed)"
    return None


def _offline_caveat(report: Report, section: str) -> list[str]:
    """For a report of offline estimates, which estimates a section's numbers are of.

    The "Smoothing" section, at the end, said it; a reader of the tables above it took the
    output metrics for the smoothed estimates' and the modes and states for the filter's.
    """
    smoothing = report.smoothing
    if smoothing is None:
        return []
    if section == "outputs":
        return [
            "The causal filter's one-step-ahead prediction ŷ(k|k−1), with or without an "
            "offline pass: it is the basis of MSE, VAF and fit (see Smoothing).",
            "",
        ]
    if section == "states" and smoothing.keeps_filter_states:
        return ["The causal filter's own: the Viterbi path changes only the modes.", ""]
    how = ", ".join(f"`{n}`" for n in (smoothing.method, smoothing.mode_sequence) if n)
    return [
        f"Of the offline estimates ({how}); the causal filter's own {section} are compared "
        "with them under Smoothing.",
        "",
    ]


def _fallback_lines(smoothing: Smoothing) -> list[str]:
    """The "Smoothing" section's line on the samples the smoother left to the forward pass.

    ``smoothing.fallbacks``; no line where it never did.  Where the guard refused steps the
    line points to the docs' account of why it does by construction on models with fewer
    outputs than states.
    """
    fallbacks = smoothing.fallbacks
    if fallbacks is None or fallbacks.samples == 0:
        return []
    why = (
        ', and "Why the guard fires on models with more states than outputs" there'
        if fallbacks.by_cause.get("guard")
        else ""
    )
    return [
        f"- Fallbacks: {fallbacks.summary()}. On those samples the smoothed estimate is, in "
        f'part or whole, the forward pass\'s (docs/smoothing.md, "The algorithms"{why}).'
    ]


def _smoothing_lines(smoothing: Smoothing) -> list[str]:
    """The "Smoothing" section: what ran after the filter and the metrics before and after."""
    if smoothing.method:
        method = f"`{smoothing.method}`"
    elif smoothing.keeps_filter_states:
        method = "none (the filter's estimates)"
    else:  # kbest: the states of the filters along its path, run forward only
        method = "none (the states: the path's own filters, forward only)"
    f, s = smoothing.filtered, smoothing.smoothed
    explained = f.outputs is not None and s.outputs is not None
    lines = [
        "## Smoothing",
        "",
        f"- smoother: {method}; mode sequence: `{smoothing.mode_sequence}`",
        f"- {smoothing.description}",
        *_fallback_lines(smoothing),
        "- The modes, states and tables of this report hold these estimates (the causal "
        "filter's own are in the `_filtered` columns). The output MSE, VAF and fit above stay "
        "the filter's one-step-ahead prediction ŷ(k|k−1): an offline pass uses y(k) and the "
        "samples after it, so it predicts nothing."
        + (
            " The output fit below is of ŷ(k) = h(x̂(k), u(k)) in the estimated mode: how well "
            "each side's estimates explain the measurements."
            if explained
            else ""
        ),
        "",
        f"| metric | filtered | {'smoothed' if smoothing.method else smoothing.mode_sequence} "
        "| change |",
        "|---|---:|---:|---:|",
    ]

    def percent(value: float | None) -> float | None:
        return None if value is None else 100.0 * value

    rows: list[tuple[str, float | int | None, float | int | None, str]] = [
        ("mode accuracy (%)", percent(f.mode_accuracy), percent(s.mode_accuracy), ".4g"),
        ("true switches missed", f.missed, s.missed, "d"),
        *(
            [("true switches undetermined", f.undetermined, s.undetermined, "d")]
            if f.undetermined or s.undetermined
            else []
        ),
        ("detection delay, mean (s)", f.detection_delay_s, s.detection_delay_s, ".6g"),
        ("detection delay, max (s)", f.detection_max_s, s.detection_max_s, ".6g"),
        ("estimated mode switches", f.estimated_switches, s.estimated_switches, "d"),
    ]
    rows += [
        (f"RMSE {x}", f.states[x].rmse, state.rmse, ".6g")
        for x, state in s.states.items()
        if x in f.states
    ]
    for c, side in s.components.items():
        own = f.components.get(c)
        rows += [
            (
                f"component {c}: mode accuracy (%)",
                percent(None if own is None else own.mode_accuracy),
                percent(side.mode_accuracy),
                ".4g",
            ),
            (
                f"component {c}: detection delay, mean (s)",
                None if own is None else own.detection_delay_s,
                side.detection_delay_s,
                ".6g",
            ),
        ]
        for count in ("missed", "undetermined"):  # rows of switches only where there are some
            offline, filtered = getattr(side, count), getattr(own, count, None)
            if offline or filtered:
                rows.append((f"component {c}: true switches {count}", filtered, offline, "d"))
    if explained and f.outputs is not None and s.outputs is not None:
        rows += [
            (f"fit of h(x̂) {y} (%)", f.outputs[y].fit, out.fit, ".4g")
            for y, out in s.outputs.items()
            if y in f.outputs
        ]
    apart = {
        f"RMSE {x}": counts for x in s.states if (counts := smoothing.samples_apart(x)) is not None
    }
    sides: list[tuple[str, _Switches | None, _Switches]] = [("", f, s)]
    sides += [(f"component {c}: ", f.components.get(c), side) for c, side in s.components.items()]
    delays_apart = {
        name: why
        for prefix, before_side, after_side in sides
        if (why := _delays_apart(before_side, after_side)) is not None
        for name in (f"{prefix}detection delay, mean (s)", f"{prefix}detection delay, max (s)")
    }
    for name, before, after, spec in rows:
        if spec == ".4g":  # a percentage
            shown = [format_percent(None if v is None else float(v), 4) for v in (before, after)]
        else:
            shown = [format_number(v, spec) for v in (before, after)]
        change = _change(before, after, spec)
        if name in apart:  # over other samples: neither side's gain
            shown = [
                f"{cell} over {n:,} samples" for cell, n in zip(shown, apart[name], strict=True)
            ]
            change = "n/a (other samples)"
        if name in delays_apart and change != "n/a":  # over other switches: neither's gain
            change = delays_apart[name]
        lines.append(f"| {escape_markdown(name)} | {shown[0]} | {shown[1]} | {change} |")
    if any(
        delays_apart.get(name) and before is not None and after is not None
        for name, before, after, _ in rows
    ):
        lines += [
            "",
            "A detection delay is over the switches its side detected: where a side missed "
            "some (or the true mode's gaps left some undetermined) the two may be over other "
            "switches, so their change is not given (see true switches missed).",
        ]
    if apart:
        lines += [
            "",
            "An RMSE with its samples beside it is over other samples on each side (where that "
            "side estimated the state: see the warnings), so the two are not compared.",
        ]
    if f.mode_accuracy is None and (f.components or s.components):
        lines += [
            "",
            "The log has the true mode of only some components: mode accuracy, missed "
            "switches and delays are per component (the component rows), none jointly.",
        ]
    elif f.mode_accuracy is None:
        lines += ["", "No ground-truth mode in the log: mode accuracy and delays are not known."]
    elif f.detected is None:
        lines += [
            "",
            "Mode accuracy: the samples with every component's mode right; the log's true "
            "modes are per component, so switches are not scored jointly.",
        ]
    return lines


def _component_lines(modes: ModeReport, samples: int) -> list[str]:
    """A ``[components]`` model's modes against the log's per-component truth."""
    joint = (
        f"- every component right: {_accuracy(modes.accuracy)} of the samples"
        + (
            f" ({modes.samples:,} of {samples:,}: those where every component has a true mode)"
            if modes.samples is not None and modes.samples < samples
            else ""
        )
        if modes.accuracy is not None
        else "- the log has the true mode of only some components"
        + (
            f" (not of {', '.join(escape_markdown(c) for c in modes.components_without_truth)})"
            if modes.components_without_truth
            else ""
        )
        + ": no joint accuracy"
    )
    lines = [joint, ""]
    for name, component in modes.components.items():
        lines += [f"### Component {escape_markdown(name)}", ""]
        # said for every component: one whose true mode never switches may still be
        # estimated to (false alarms, which no detection count shows)
        lines.append(f"- {plural(len(component.switches), 'estimated mode switch')}")
        if component.accuracy is None:  # listed with its truth, which covers no sample
            lines.append(f"- {_NOT_COVERED}")
        else:
            lines += _truth_lines(component, component.accuracy, samples)
        lines.append("")
    for name in modes.components_without_truth:
        lines += [f"### Component {escape_markdown(name)}", "", f"- {_NO_TRUTH}", ""]
    return lines[:-1]


_NO_TRUTH = "the log has no true mode of this component: it is not scored"


_NOT_COVERED = (
    "the true mode has no sample on the analysed span (it starts after the last sample, or "
    "has none in it): accuracy and delays are not known"
)


def _accuracy(fraction: float | None) -> str:
    """A mode accuracy (a fraction) as a percentage: ``99.6678%``, never 100 % when it is not."""
    return "n/a" if fraction is None else f"{format_percent(100.0 * fraction, 4)}%"


def _scored_samples(modes: ModeReport, samples: int) -> str:
    """`` over 371 of 401 samples (...)`` when the true mode covers only some samples."""
    if modes.samples is None or modes.samples >= samples:
        return ""
    return f" over {modes.samples:,} of {samples:,} samples (those with a true mode)"


def _truth_lines(modes: ModeReport, accuracy: float, samples: int) -> list[str]:
    """Accuracy (over how many of the ``samples``), detection of every switch, confusion."""
    det = modes.detection
    events = det.events if det is not None else ()
    detected, missed = (det.detected, det.missed) if det is not None else (0, 0)
    undetermined = det.undetermined if det is not None else 0
    delay = modes.detection_delay_s
    lines = [
        f"- mode accuracy: {_accuracy(accuracy)}" + _scored_samples(modes, samples),
        f"- {plural(len(events), 'true mode switch')}: {detected:,} detected, {missed:,} missed"
        + (
            f", {undetermined:,} undetermined (the true mode's record stops before they could "
            "be told detected or missed)"
            if undetermined
            else ""
        )
        + (
            f"; detection delay mean {format_number(delay)} s, "
            f"max {format_number(det.max_s if det is not None else None)} s"
            if delay is not None
            else ""
        ),
    ]
    if events:
        lines += ["", "| true switch at (s) | from → to | detected at (s) | delay (s) |"]
        lines.append("|---:|---|---|---:|")
        for e in events[:MAX_LISTED_SWITCHES]:
            found = e.detected_t
            if found is not None:
                when = format_time(found)
            elif e.undetermined_reason is not None:
                when = f"undetermined: {e.undetermined_reason}"
            else:
                when = f"missed: {e.miss_reason}"
            lines.append(
                f"| {format_time(e.t)} "
                f"| {escape_markdown(e.from_mode)} → {escape_markdown(e.to_mode)} "
                f"| {escape_markdown(when)} | {format_number(e.delay_s)} |"
            )
        if len(events) > MAX_LISTED_SWITCHES:
            lines.append(f"\n… and {len(events) - MAX_LISTED_SWITCHES:,} more in report.json.")
    confusion = modes.confusion or {}
    lines += [
        "",
        "Confusion (rows: true mode, columns: estimated mode, sample counts):",
        "",
        "| true \\ estimated | " + " | ".join(escape_markdown(m) for m in modes.labels) + " |",
        "|---|" + "---:|" * len(modes.labels),
    ]
    for t_id in modes.labels:
        row = confusion.get(t_id, {})
        lines.append(
            f"| {escape_markdown(t_id)} | "
            + " | ".join(f"{row.get(e, 0):,}" for e in modes.labels)
            + " |"
        )
    return lines
