"""Reports of estimation runs: metrics, report.json/report.md, tables, plots and CI gates.

The entry point is :func:`write_report`; the pieces live in :mod:`.metrics`,
:mod:`.document`, :mod:`.tables`, :mod:`.plots` and :mod:`.gates`; output folders are
written with :func:`hybridlog.outputs.atomic_output_dir`.  The names below are imported on
first use (:mod:`hybridlog.lazy`), so importing the package loads no numpy or matplotlib.
"""

from typing import TYPE_CHECKING

from hybridlog.lazy import lazy_exports

if TYPE_CHECKING:
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

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "hybridlog.outputs": ["atomic_output_dir"],
        ".document": ["build_report", "render_markdown", "report_json"],
        ".gates": ["Gate", "evaluate_gates", "parse_gates", "validate_gates"],
        ".writer": ["write_report"],
    },
)
