"""Reports of estimation runs: metrics, report.json/report.md, tables, plots and CI gates.

The entry point is :func:`write_report`, which returns the typed :class:`Report` (its
:meth:`~Report.to_json` is ``report.json``; :func:`read_report` reads one back).  The pieces
live in :mod:`.metrics`, :mod:`.build`, :mod:`.document`, :mod:`.markdown`, :mod:`.tables`,
:mod:`.plots`, :mod:`.gates` and :mod:`.summary`, each with the modules named in
docs/architecture.md (the outputs a smoothed run's estimates explain are
:mod:`hybridlog.estimators.explained`'s); output folders are written with
:func:`hybridlog.outputs.atomic_output_dir`.  The names below are imported on first use
(:mod:`hybridlog.lazy`), so importing the package loads no numpy or matplotlib.
"""

from typing import TYPE_CHECKING

from hybridlog.lazy import lazy_exports

if TYPE_CHECKING:
    from hybridlog.outputs import atomic_output_dir
    from hybridlog.report.build import build_report
    from hybridlog.report.document import Report, read_report
    from hybridlog.report.gates import (
        Gate,
        evaluate_gates,
        parse_gates,
        recorded_failures,
        validate_gates,
    )
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
    "recorded_failures",
    "render_markdown",
    "validate_gates",
    "write_report",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "hybridlog.outputs": ["atomic_output_dir"],
        ".build": ["build_report"],
        ".document": ["Report", "read_report"],
        ".gates": ["Gate", "evaluate_gates", "parse_gates", "recorded_failures", "validate_gates"],
        ".markdown": ["render_markdown"],
        ".writer": ["write_report"],
    },
)
