"""A gate on a mean over the outputs fails while one output's value is null.

``--fail-under vaf=90`` passed on a run whose second sensor was stuck (constant, so its
VAF and fit are undefined): the top-level ``vaf`` is the mean over the outputs where it is
defined, so it scored the run on the first output alone.  Per-output gates are unchanged.
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from hybridlog.report import build_report, render_markdown
from hybridlog.report.gates import evaluate_gates, parse_gates
from hybridlog.report.junit import write_junit
from hybridlog.report.summary_rows import BatchRow

from .test_report_files import DT, make_run


def _stuck_sensor():  # type: ignore[no-untyped-def]
    result, signals = make_run(120, seed=6)
    outputs = signals.outputs.copy()
    predictions = result.output_predictions.copy()
    outputs[:, 1] = 4.0  # y2 stuck: fit undefined
    predictions[1:, 1] = 4.0  # and predicted as stuck: VAF undefined
    return build_report(
        dataclasses.replace(result, output_predictions=predictions),
        dataclasses.replace(signals, outputs=outputs),
        log="run.csv",
        model_name="m",
        dt=DT,
    )


@pytest.mark.parametrize("name", ["vaf", "fit"])
def test_a_gate_on_the_mean_fails_while_an_output_is_undefined(name: str) -> None:
    report = _stuck_sensor()
    mean = getattr(report, name)
    assert mean is not None and mean == getattr(report.outputs["y1"], name)
    assert getattr(report.outputs["y2"], name) is None
    (failure,) = evaluate_gates(report, parse_gates([f"{name}=0"]))
    assert failure.startswith(f"{name} = ") and "is a mean that leaves out 1 of 2 outputs: " in (
        failure
    )
    assert f"{name}.y2 ({report.null_reasons[f'{name}.y2']})" in failure
    assert failure.endswith("so the --fail-under bound 0 cannot be met")
    # the per-output gates read each output as before
    assert evaluate_gates(report, parse_gates([f"{name}.y1=0"])) == []
    (own,) = evaluate_gates(report, parse_gates([f"{name}.y2=0"]))
    assert own.startswith(f"{name}.y2 is not available")
    # a gate on the mean MSE reads every output: it is defined for both
    assert report.outputs["y2"].mse is not None
    assert evaluate_gates(report, parse_gates([], ["mse=1e9"])) == []
    assert "a gate on the mean fails while any output's is n/a" in render_markdown(report)


def test_batch_summary_and_junit_read_the_same_failure(tmp_path: Path) -> None:
    report = _stuck_sensor()
    gates = parse_gates(["vaf=0"])
    row = BatchRow(
        log="run.csv",
        folder="run",
        status="done",
        report=report,
        error=None,
        gates=tuple(
            (f"{g.option} {g.spec}", next(iter(evaluate_gates(report, [g])), None)) for g in gates
        ),
    )
    assert not row.passed and row.missed[0].startswith("vaf = ")
    path = tmp_path / "junit.xml"
    write_junit(path, "hybridlog batch: m · imm", [row])
    failures = list(ET.parse(path).getroot().iter("failure"))
    assert len(failures) == 1 and "leaves out 1 of 2 outputs" in (failures[0].get("message") or "")
    assert np.isfinite(report.vaf or np.nan)  # the mean itself is still reported


def test_a_mean_undefined_for_every_output_names_every_output() -> None:
    """``fit`` of a log whose every sensor is stuck named y1 alone: "undefined for every
    output (y1: ...)" read as if y2 had a fit."""
    result, signals = make_run(120, seed=6)
    outputs = signals.outputs.copy()
    outputs[:, :] = 4.0  # every sensor stuck: fit undefined for each
    report = build_report(
        result, dataclasses.replace(signals, outputs=outputs), log="run.csv", model_name="m", dt=DT
    )
    assert report.fit is None and list(report.outputs) == ["y1", "y2"]
    why = report.null_reasons["fit.y1"]
    assert why == report.null_reasons["fit.y2"]
    assert report.null_reasons["fit"] == f"undefined for every output (y1, y2: {why})"
