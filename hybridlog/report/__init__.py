"""Reports of estimation runs: metrics, report.json/report.md, tables, plots and CI gates.

The entry point is :func:`write_report`; the pieces live in :mod:`.metrics`,
:mod:`.document`, :mod:`.tables`, :mod:`.plots` and :mod:`.gates`; output folders are
written with :func:`hybridlog.outputs.atomic_output_dir`.
"""

from hybridlog.outputs import atomic_output_dir
from hybridlog.report.document import build_report, render_markdown, report_json
from hybridlog.report.gates import Gate, evaluate_gates, parse_gates, validate_gates
from hybridlog.report.writer import write_report

__all__ = [
    "Gate",
    "atomic_output_dir",
    "build_report",
    "evaluate_gates",
    "parse_gates",
    "render_markdown",
    "report_json",
    "validate_gates",
    "write_report",
]
