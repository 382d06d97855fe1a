"""analyze's line says which mode accuracy a ``[components]`` model's is.

For a model of concurrent components the accuracy is the share of samples with every
component's mode right, and it is ``null`` where the log has the true mode of only some
components: the line said ``mode accuracy n/a`` as for a log without any true mode, while
report.md scored each component that has one.
"""

from dataclasses import replace

from hybridlog.cli_lines import summary_line
from hybridlog.report.document import read_report
from hybridlog.report.report_parts import ModeReport
from tests.report.test_summary_plot import REPORT


def _with_components(accuracy: float | None, without: tuple[str, ...]) -> str:
    report = read_report(REPORT)
    component = ModeReport(labels=("ok", "leak"), switches=(), dwell_s={"ok": 1.0, "leak": 0.0})
    scored = replace(component, accuracy=0.5, samples=report.samples)
    modes = replace(
        report.modes,
        accuracy=accuracy,
        confusion=None,
        detection=None,
        components={"valve": scored},
        components_without_truth=without,
    )
    return summary_line(replace(report, modes=modes))


def test_the_line_names_the_joint_accuracy_and_a_partial_truth() -> None:
    assert ", mode accuracy (every component right) 75.0 %" in _with_components(0.75, ())
    partial = _with_components(None, ("pump",))
    assert partial.endswith(
        ", mode accuracy (every component right) n/a: the log has the true mode of only some "
        "components (valve: each scored in report.md)"
    )
