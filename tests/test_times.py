"""Times written for people: fixed point, to the digits the float holds (hybridlog/times.py)."""

from __future__ import annotations

import re

import pytest

from hybridlog.times import format_time
from tests.test_layers import PACKAGE


@pytest.mark.parametrize(
    ("seconds", "text"),
    [
        (1700000101.01, "1700000101.01"),  # :g wrote 1.7e+09
        (1700000000.0, "1700000000"),
        (0.1999999999999993, "0.2"),
        (2.5e-10, "0"),  # below the nanosecond
        (-3.25, "-3.25"),
        (None, "n/a"),
        (float("inf"), "inf"),
    ],
)
def test_a_time_is_written_to_the_digits_it_holds(seconds: float | None, text: str) -> None:
    assert format_time(seconds) == text


# 't = {x:g} s', 't={x:.6g} s', 'at t = {x}': a Unix time written 1.7e+09, or unrounded
_TIME_BY_HAND = re.compile(r"(?<![\w.])t ?= ?\{(?!format_time\(|_seconds\()[^}]*\}")


def test_no_message_writes_a_time_by_hand() -> None:
    """Every ``t = …`` in the package's text goes through :func:`format_time` (or, for integer
    nanoseconds, ``io``'s exact ``format_ns``): an error "diverged at t = 1.7e+09 s" named
    no sample of a log stamped in Unix time."""
    found = [
        f"{path.relative_to(PACKAGE.parent)}:{number}: {line.strip()}"
        for path in sorted(PACKAGE.rglob("*.py"))
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if _TIME_BY_HAND.search(line) and "format_ns(" not in line
    ]
    assert found == []
