"""A CI gate given twice is refused before any log is read.

``batch --fail-under vaf=50 --fail-under vaf=50`` wrote each log's JUnit case twice (the same
classname and name, which CI systems take for one test) and each failure twice on the
terminal and in summary.md; ``vaf=50`` beside ``vaf=50.0`` the same under two names.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from hybridlog.errors import OptionError
from hybridlog.jobs.batch import run_batch
from hybridlog.report import parse_gates
from tests.jobs.test_batch_resume import write_logs


@pytest.mark.parametrize(
    ("under", "over", "message"),
    [
        (["vaf=50", "vaf=50"], [], "--fail-under 'vaf=50': given twice; give it once"),
        (["vaf=50", " vaf = 5e1"], [], "--fail-under ' vaf = 5e1': the same gate as 'vaf=50'"),
        ([], ["mse=2", "mse=2.0"], "--fail-over 'mse=2.0': the same gate as 'mse=2'"),
    ],
)
def test_a_gate_given_twice_is_refused(under: list[str], over: list[str], message: str) -> None:
    with pytest.raises(OptionError) as raised:
        parse_gates(under, over)
    assert str(raised.value).startswith(message)


def test_bounds_of_one_metric_that_differ_are_kept() -> None:
    gates = parse_gates(["vaf=50", "vaf=60", "fit=50"], ["vaf=90"])
    assert [(g.kind, g.metric, g.bound) for g in gates] == [
        ("under", "vaf", 50.0),
        ("under", "vaf", 60.0),
        ("under", "fit", 50.0),
        ("over", "vaf", 90.0),
    ]


def test_a_batch_with_a_gate_given_twice_writes_nothing(tmp_path: Path) -> None:
    logs = write_logs(tmp_path / "logs", ["a.csv"], steps=10)
    with pytest.raises(OptionError, match="given twice"):
        run_batch(
            logs,
            "three_tank_hstf",
            out_dir=tmp_path / "out",
            fail_under=["vaf=50", "vaf=50"],
            junit=tmp_path / "junit.xml",
        )
    assert not (tmp_path / "out").exists() and not (tmp_path / "junit.xml").exists()


def test_a_gate_is_named_without_the_blanks_it_was_given_with() -> None:
    """``--fail-under ' fit = 60 '`` was the JUnit case, summary column and report.md gate
    ``--fail-under  fit = 60 ``: another test case than ``fit=60`` for CI's history."""
    (gate,) = parse_gates([" fit = 60 "])
    assert gate.spec == "fit=60" and gate.bound == 60.0


def test_a_bound_of_minus_zero_is_zero() -> None:
    """``--fail-over mse=-0`` read "is over the bound -0" and recorded -0.0 in report.json."""
    (gate,) = parse_gates([], ["mse=-0"])
    assert math.copysign(1.0, gate.bound) == 1.0 and f"{gate.bound:g}" == "0"


@pytest.mark.parametrize(
    ("given", "named"),
    [("fit=-0", "fit=0"), ("fit=-0.0", "fit=0.0"), ("fit=+0", "fit=0"), ("vaf=+60", "vaf=60")],
)
def test_a_gate_is_named_without_a_sign_that_is_not_its_bounds(given: str, named: str) -> None:
    """``--fail-under fit=-0`` was the JUnit case, summary column and report.md gate
    ``fit=-0``: another test case than ``fit=0`` for the same bound; ``-1`` keeps its sign."""
    gate, negative = parse_gates([given, "fit=-1"])
    assert gate.spec == named and negative.spec == "fit=-1"
