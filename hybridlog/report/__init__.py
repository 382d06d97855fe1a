"""Reports of estimation runs: metrics, report.json/report.md, tables, plots and CI gates.

The entry point is :func:`write_report`, which returns the typed :class:`Report` (its
:meth:`~Report.to_json` is ``report.json``; :func:`read_report` reads one back).  The pieces
live in :mod:`.metrics`, :mod:`.build`, :mod:`.document`, :mod:`.markdown`, :mod:`.tables`,
:mod:`.plots` and :mod:`.gates`; output folders are written with
:func:`hybridlog.outputs.atomic_output_dir`.
"""

from hybridlog.outputs import atomic_output_dir
from hybridlog.report.build import build_report
from hybridlog.report.document import Report, read_report
from hybridlog.report.gates import Gate, evaluate_gates, parse_gates, validate_gates
from hybridlog.report.markdown import render_markdown
from hybridlog.report.writer import write_report

__all__ = [
    "Gate",
    "Report",
    "atomic_output_dir",
    "build_report",
    "evaluate_gates",
    "parse_gates",
    "read_report",
    "render_markdown",
    "validate_gates",
    "write_report",
]
