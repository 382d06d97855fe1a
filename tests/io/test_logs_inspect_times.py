"""``inspect`` writes a log's times to the digits they hold, as it writes its spans.

Times were written to the microsecond: an MCAP file whose messages were logged 4 ns apart
read ``time: 1 s to 1 s (0.000000004 s)``, and a topic of a ROS 2 bag logged 500 ns after
another started at ``5`` beside its span's ``0.0000005``.  Times are now written to the digits
their float holds (the nanosecond for times of seconds, the microsecond near the Unix epoch).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hybridlog.io import format_inspection, inspect_log


def write_mcap(path: Path, start_ns: int, step_ns: int) -> Path:
    from mcap.writer import Writer

    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="test")
        channel = writer.register_channel("/y", "json", 0)
        for k in range(3):
            t = start_ns + k * step_ns
            writer.add_message(channel, t, json.dumps({"v": k}).encode(), t)
        writer.finish()
    return path


@pytest.mark.parametrize(
    ("start_ns", "step_ns", "line"),
    [
        (10**9, 2, "time: 1 s to 1.000000004 s (0.000000004 s)"),
        (5 * 10**9 + 500, 10**7, "time: 5.0000005 s to 5.0200005 s (0.02 s)"),
        (1_700_000_000 * 10**9, 10**6, "time: 1700000000 s to 1700000000.002 s (0.002 s)"),
    ],
)
def test_times_are_written_to_the_digits_they_hold(
    start_ns: int, step_ns: int, line: str, tmp_path: Path
) -> None:
    log = write_mcap(tmp_path / "log.mcap", start_ns, step_ns)
    text = format_inspection(inspect_log(log))
    assert line in text.splitlines()
