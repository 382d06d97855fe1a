"""A run's result taken in chunks is reported as the whole result."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hybridlog.report.build import ReportBuilder, build_report
from tests.report.test_report_files import DT, make_run


def test_chunks_whose_options_hold_arrays_are_one_run() -> None:
    """chiu's options hold its centres as arrays: a log longer than one chunk (65,536 rows)
    failed with "unexpected ValueError in build.py" (an array's == has no truth value)."""
    result, signals = make_run(n=90)
    options = {"centers": np.arange(6.0).reshape(3, 2), "lags": (1, [2, 3]), "radius": 0.3}
    result = dataclasses.replace(result, options=options)
    builder = ReportBuilder(signals, log="run.csv", dt=DT)
    for start in range(0, 90, 40):
        chunk = result.rows(start, min(start + 40, 90))
        builder.add(
            dataclasses.replace(chunk, options={**options, "centers": options["centers"].copy()})
        )
    chunked = builder.report(model_name="tanks")
    whole = build_report(result, signals, log="run.csv", model_name="tanks", dt=DT)
    assert chunked.mse == whole.mse and chunked.modes.accuracy == whole.modes.accuracy


def test_a_chunk_of_other_options_is_refused() -> None:
    result, signals = make_run(n=60)
    result = dataclasses.replace(result, options={"centers": np.zeros((2, 2))})
    builder = ReportBuilder(signals, log="run.csv", dt=DT)
    builder.add(result.rows(0, 30))
    other = dataclasses.replace(result.rows(30, 60), options={"centers": np.ones((2, 2))})
    with pytest.raises(ValueError, match="a chunk of another run"):
        builder.add(other)


def test_the_terminal_summary_writes_a_huge_fit_in_scientific_notation() -> None:
    """A diverged but finite prediction gave a fit of about -1e301, printed with ``.2f``
    on the terminal as a number of 300 digits (report.md already wrote it as 1e+301)."""
    from hybridlog.cli_lines import summary_line

    result, signals = make_run(n=30)
    huge = dataclasses.replace(result, output_predictions=result.output_predictions * 1e300)
    report = build_report(huge, signals, log="run.csv", model_name="tanks", dt=DT)
    assert report.fit is not None and abs(report.fit) > 1e12
    line = summary_line(report)
    assert "e+" in line and len(line) < 300, line
