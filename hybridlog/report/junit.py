"""JUnit XML of a batch, so that CI systems show each log's gates as their own test cases.

One ``testcase`` per log per CI gate (``classname`` the log, ``name`` the gate), failing with
the gate's message when it is missed; one per log that could not be analysed, as an
``error`` carrying the log's one-line error; and, when no gate is given, one ``analysis``
case per analysed log.  The format is the common subset read by GitHub Actions reporters,
GitLab, Jenkins and Azure DevOps (``testsuites`` → ``testsuite`` → ``testcase`` with
``failure``/``error`` children), written with :mod:`xml.etree.ElementTree`.

In a batch with an offline pass (``--smooth``, ``--mode-sequence``) each analysed log's
cases carry its offline and filter's own metrics in ``system-out``, a line each
(``mode_accuracy = 0.995851 (the filter's own: 0.987552)``, then per component and per
state, as summary.csv's columns: :func:`hybridlog.report.summary_offline.offline_columns`), and the
``testsuite`` the batch's gains per metric as ``properties``
(:func:`hybridlog.report.summary_offline.offline_gains`): ``smoothing`` (the pass), then
``<metric>.logs``, ``.filtered_median``, ``.offline_median``, ``.median_change``,
``.better``, ``.equal``, ``.worse``, with their shortest round-trip digits.  Where the
smoother left the forward estimate standing, a last line of ``system-out`` says so (``the
smoother fell back to the forward estimate on 997 of 1,000 samples (guard 997), which carry
99.1 % of the smoothed estimates' weight``).  Not
``properties`` of each ``testcase``: the JUnit schemas CI systems validate against (Jenkins'
``junit-4.xsd``, xunit2) have none there, so pytest refuses its ``record_property`` for
them.

A log whose true mode starts late (its mode accuracy over part of the log,
:func:`hybridlog.report.coverage.mode_coverage`) says so in its cases' ``system-out`` too:
``mode_accuracy is over 201 of 301 samples (the true mode starts at t = 100 s)``; and a log
whose report warns (its notes that start ``WARNING:``,
:func:`hybridlog.report.summary_notes.warning_notes`: the innovations' test of a filter, a true
mode silent longer than ``--max-gap``) has each warning there, a line each, as report.md
has them.
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from hybridlog.errors import OutputError, excerpt
from hybridlog.outputs import (
    PathLike,
    check_file_name,
    check_file_target,
    record_path,
    shown_output,
    wrote_file,
)
from hybridlog.report.coverage import mode_coverage
from hybridlog.report.summary_notes import warning_notes
from hybridlog.report.summary_offline import offline_gains, offline_label
from hybridlog.report.summary_rows import BatchRow

if TYPE_CHECKING:
    from hybridlog.report.document import Report

__all__ = ["ROOT_NAME", "check_junit_target", "is_junit_of_ours", "junit_tree", "write_junit"]

ROOT_NAME = "hybridlog batch"
"""``name`` of the ``testsuites`` element: how a JUnit file of hybridlog's is recognised."""

_SIGNATURE = f'<testsuites name="{ROOT_NAME}'


def is_junit_of_ours(path: Path) -> bool:
    """Whether ``path`` is a JUnit file a batch wrote, unchanged since.

    Its root element's name says so, and the record a batch leaves beside it
    (:func:`~hybridlog.outputs.record_file`) names this very file: one edited since (a note
    added by hand) is the user's.  A file without a record (written before batches recorded
    their JUnit files) is known by its root element alone.
    """
    if os.path.lexists(record_path(path)) and not wrote_file(path):
        return False
    try:
        with path.open("rb") as handle:
            head = handle.read(256).decode("utf-8", "replace")
    except OSError:
        return False
    return _SIGNATURE in head


def check_junit_target(target: PathLike) -> Path:
    """Check that the JUnit file may be written: new, or a JUnit file of a batch.

    A CI job re-runs a batch into the same file, so a JUnit file hybridlog wrote is replaced
    (with or without ``--force``); any other existing file never (SPEC §9: ``--force``
    replaces only what hybridlog wrote).

    Raises
    ------
    OutputError
        When the target is a folder, a device or pipe, a symbolic link, an existing file of
        someone else's, or cannot be created.
    """
    check_file_name(target, "--junit")  # before Path drops the "/" of --junit j.xml/
    path = Path(target)
    if path.is_symlink():
        # a link to a batch's JUnit file read as that file: the batch folder's previous
        # run's file (the link's target) was withdrawn, the link left pointing at nothing,
        # and the batch refused at its end, every summary gone
        raise OutputError(
            f"--junit {excerpt(str(target))[1:-1]}: is a symbolic link (to "
            f"{excerpt(os.readlink(path))}), which hybridlog does not write through; name the "
            "file itself or another path"
        )
    ours = path.is_file() and is_junit_of_ours(path)
    if (path.exists() or path.is_symlink()) and not ours and not path.is_dir():
        raise OutputError(
            f"--junit {excerpt(str(target))[1:-1]}: exists and is not a JUnit file hybridlog "
            "wrote (or it was edited since), so it is not replaced (not even with --force); "
            "name another file"
        )
    try:
        return check_file_target(path, force=ours, ours=is_junit_of_ours)
    except OutputError as err:
        raise OutputError(f"--junit {err}") from None


_NOT_XML = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")
"""Characters XML 1.0 cannot hold, not even as references: the C0 controls but tab and
line breaks, lone surrogates, U+FFFE and U+FFFF."""


def _xml(text: str) -> str:
    r"""``text`` with each character XML cannot hold written ``\xNN`` or ``\uNNNN``.

    A log named with an escape sequence (``\x1b[31m``) or a NUL byte would otherwise make
    the whole file unreadable to a CI system's parser, every other log's result with it.
    """
    return _NOT_XML.sub(lambda found: found.group().encode("unicode_escape").decode(), text)


def _case(suite: ET.Element, classname: str, name: str, seconds: float) -> ET.Element:
    return ET.SubElement(
        suite,
        "testcase",
        {"classname": _xml(classname), "name": _xml(name), "time": f"{seconds:.3f}"},
    )


def _properties(parent: ET.Element, values: Sequence[tuple[str, object]]) -> None:
    """A ``properties`` child of ``parent`` with each value (none: no child)."""
    if values:
        properties = ET.SubElement(parent, "properties")
        for name, value in values:
            ET.SubElement(properties, "property", {"name": _xml(name), "value": _xml(str(value))})


def _offline_text(row: BatchRow, metrics: Sequence[str]) -> str | None:
    """A log's offline and filter's own metrics, a line each; ``None`` without a pass."""
    smoothing = None if row.report is None else row.report.smoothing
    if smoothing is None:
        return None

    def shown(value: float | None) -> str:
        return "n/a" if value is None else f"{value:.6g}"

    lines = [f"offline estimates ({offline_label(smoothing)}) against the filter's own:"]
    for metric, offline, own in row.offline_pairs(metrics):
        apart = row.samples_apart(metric)
        if apart is None:
            lines.append(f"{metric} = {shown(offline)} (the filter's own: {shown(own)})")
        else:  # over other samples: not a gain (summary_offline.offline_samples_apart)
            lines.append(
                f"{metric} = {shown(offline)} over {apart[1]:,} samples (the filter's own: "
                f"{shown(own)} over {apart[0]:,} samples; not compared)"
            )
    if smoothing.fallbacks is not None and smoothing.fallbacks.samples:
        lines.append(smoothing.fallbacks.summary())
    return _xml("\n".join(lines))


def _coverage_text(report: Report) -> str | None:
    """``mode_accuracy is over 201 of 301 samples (...)`` for a true mode that starts late."""
    part = mode_coverage(report)
    return None if part is None else _xml(f"mode_accuracy is over {part}")


def junit_tree(
    suite_name: str, rows: Sequence[BatchRow], offline: Sequence[str] | None = None
) -> ET.ElementTree[ET.Element]:
    """The JUnit document of a batch (see the module docstring).

    ``offline``: the metrics compared when the run has an offline pass
    (:func:`~hybridlog.report.summary_offline.offline_metrics`), ``None`` otherwise (nothing of
    it is written).
    """
    root = ET.Element("testsuites", {"name": ROOT_NAME})
    suite = ET.SubElement(root, "testsuite", {"name": _xml(suite_name)})
    if offline is not None:  # the first child of the suite, as the schemas have it
        passes = sorted(
            {offline_label(r.report.smoothing) for r in rows if r.report and r.report.smoothing}
        )
        _properties(
            suite,
            ([("smoothing", " / ".join(passes))] if passes else [])
            + [
                (f"{g.metric}.{key}", value)
                for g in offline_gains(rows, offline)
                for key, value in (
                    ("logs", g.logs),
                    ("filtered_median", g.filtered),
                    ("offline_median", g.offline),
                    ("median_change", g.change),
                    ("better", g.better),
                    ("equal", g.equal),
                    ("worse", len(g.worse)),
                )
            ],
        )
    tests = failures = errors = 0
    total = 0.0
    for row in rows:
        total += row.seconds
        if row.report is None:
            case = _case(suite, row.log, "analysis", row.seconds)
            message = _xml(row.error or "could not be analysed")
            ET.SubElement(case, "error", {"message": message, "type": "hybridlog"}).text = message
            tests, errors = tests + 1, errors + 1
            continue
        seconds = row.seconds
        said = [
            _offline_text(row, offline) if offline is not None else None,
            _coverage_text(row.report),
            *(_xml(note) for note in warning_notes(row.report)),
        ]
        output = "\n".join(text for text in said if text is not None) or None
        cases = []
        if not row.gates:
            cases.append(_case(suite, row.log, "analysis", seconds))
            tests += 1
        for gate, failure in row.gates:
            case = _case(suite, row.log, gate, seconds / len(row.gates))
            cases.append(case)
            tests += 1
            if failure is not None:
                message = _xml(failure)
                ET.SubElement(case, "failure", {"message": message, "type": "gate"}).text = message
                failures += 1
        for case in cases if output is not None else []:
            # after any failure, in the schemas' order
            ET.SubElement(case, "system-out").text = output
    counts = {"tests": str(tests), "failures": str(failures), "errors": str(errors)}
    for element in (root, suite):
        element.attrib.update({**counts, "time": f"{total:.3f}"})
    suite.set("skipped", "0")
    ET.indent(root)
    return ET.ElementTree(root)


def write_junit(
    path: Path,
    suite_name: str,
    rows: Sequence[BatchRow],
    offline: Sequence[str] | None = None,
) -> None:
    """Write the JUnit XML of a batch to ``path`` (UTF-8, with an XML declaration).

    ``offline`` as for :func:`junit_tree`.  ``path`` may be the staged temporary of the
    ``--junit`` file (:func:`hybridlog.outputs.atomic_files`); an error names that file.
    """
    try:
        junit_tree(suite_name, rows, offline).write(path, encoding="utf-8", xml_declaration=True)
    except OSError as err:
        raise OutputError(f"--junit {shown_output(path)}: cannot write it: {err.strerror}") from err
