"""A gate's message tells the value from its bound, and two bounds from each other.

Both were written to 6 significant digits, so a value just under its bound read
``vaf = 21.7984 is under the bound 21.7984`` (and two conflicting bounds ``at least 21.7984
and at most 21.7984``): a CI log saying a gate failed on equal numbers.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from hybridlog.errors import OptionError
from hybridlog.report.gates import evaluate_gates, parse_gates
from tests.report.test_report_gates import report


def test_a_value_just_under_its_bound_is_written_with_the_digits_that_differ() -> None:
    tight = replace(report(), mse=21.79840161233655)
    (failure,) = evaluate_gates(tight, parse_gates(fail_under=["mse=21.79840161233656"]))
    assert failure == "mse = 21.79840161233655 is under the bound 21.79840161233656"


def test_a_value_far_from_its_bound_keeps_six_digits() -> None:
    (failure,) = evaluate_gates(report(), parse_gates(fail_over=["mse=0.1"]))
    assert failure == "mse = 0.26 is over the bound 0.1"


def test_conflicting_bounds_that_round_alike_are_told_apart() -> None:
    with pytest.raises(OptionError, match=r"at least 21\.798402 and at most 21\.798401,"):
        parse_gates(fail_under=["vaf=21.7984017"], fail_over=["vaf=21.798401"])
