"""Times written for people: fixed point, to the digits the float holds (hybridlog/times.py)."""

from __future__ import annotations

import re

import pytest

from hybridlog.times import format_duration, format_time, round_duration
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


@pytest.mark.parametrize(
    ("seconds", "times", "text", "rounded"),
    [
        (0.509999762, (1700000000.49, 1700000001.0), "0.51", 0.51),  # two Unix-time floats
        (0.509999762, (0.49, 1.0), "0.509999762", 0.509999762),  # small times: the nanosecond
        (123456.75, (1700000000.25,), "123456.75", 123456.75),  # :g wrote 123457
        (1.5e-05, (), "0.000015", 1.5e-05),  # :g wrote 1.5e-05
        (2.5e-10, (), "0", 0.0),  # below the nanosecond
        (None, (), "n/a", None),
    ],
)
def test_a_duration_is_written_to_the_digits_its_times_hold(
    seconds: float | None, times: tuple[float, ...], text: str, rounded: float | None
) -> None:
    assert format_duration(seconds, *times) == text
    if seconds is not None:
        assert round_duration(seconds, *times) == rounded


# '{hold['seconds']:g}', '{bound["left_out"]}', '{_num(gap['duration'])}': a duration a
# reading or inspect records (io/alignment_notes.py, io/log_pieces.py, io/true_modes.py,
# io/summary.py), written by hand
_KEYS = r"['\"](?:seconds|left_out|duration|sample_time|min_step|max_step)['\"]\]"
_DURATION_BY_HAND = re.compile(
    r"\{[^{}()]*\[" + _KEYS + r"(?:![rsa])?(?::[^}]*)?\}"
    r"|\{(?!format_duration\(|_duration\()[\w.]+\(\w+\[" + _KEYS + r"[^{}]*\}"
)


def test_no_message_writes_a_recorded_duration_by_hand() -> None:
    """Every duration of a reading (``held.*.seconds``, ``span.*.left_out``, segments) or of
    inspect (spans, steps, gaps) goes through :func:`format_duration`: ``:g`` wrote a hold of
    123456.75 s as 123457 s, and inspect's .6g a gap of 123456.25 s as 123456 s."""
    assert _DURATION_BY_HAND.search("({hold['seconds']:g} s")
    assert _DURATION_BY_HAND.search('{bound["left_out"]} s')
    assert _DURATION_BY_HAND.search("({_num(gap['duration'])} s)")
    assert not _DURATION_BY_HAND.search("{format_duration(b['left_out'], b['at'])} s")
    found = [
        f"{path.relative_to(PACKAGE.parent)}:{number}: {line.strip()}"
        for path in sorted(PACKAGE.rglob("*.py"))
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if _DURATION_BY_HAND.search(line)
    ]
    assert found == []
