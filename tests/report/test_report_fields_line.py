"""report.md says which log field fed each symbol (reading.fields) and which truth is a
measured field (reading.truth_shared); a report read back with a record it does not know
the shape of still renders."""

from __future__ import annotations

from typing import Any

import pytest

from hybridlog.report import build_report, render_markdown
from tests.report.test_report_files import DT, make_run


def _markdown(reading: dict[str, Any], marker: str = "log fields") -> list[str]:
    result, signals = make_run(n=40, seed=1, truth=False)
    report = build_report(result, signals, log="r.csv", model_name="m", dt=DT, reading=reading)
    return [line for line in render_markdown(report).splitlines() if marker in line]


def test_the_fields_line_marks_all_but_the_default() -> None:
    fields = {
        "u": {"field": "u", "from": "default"},
        "y1": {"field": "lvl", "from": "--map"},
        "truth.mode": {"field": "/ph.data", "from": "[truth]"},
    }
    assert _markdown({"fields": fields}) == [
        "- log fields: u ← `u`, y1 ← `lvl` (--map), truth.mode ← `/ph.data` (\\[truth\\]) "
        "(unmarked: the default name)"
    ]


@pytest.mark.parametrize("fields", [None, "u", {}, {"u": 3}, {"u": {"from": "--map"}}])
def test_a_record_of_another_shape_gives_no_line(fields: object) -> None:
    assert _markdown({"fields": fields}) == []


def test_truth_read_from_a_measured_field_is_noted() -> None:
    reading = {"truth_shared": ["truth.x1 (column 'y1', also output 'y1')"]}
    assert _markdown(reading, "ground truth") == [
        "- NOTE: ground truth read from the field of an input or output (the measurement "
        "itself, not independent of it): truth.x1 (column 'y1', also output 'y1')"
    ]
