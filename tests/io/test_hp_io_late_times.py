"""MCAP log times past 2262 (2^63 ns, beyond int64): refused by reading, said by ``inspect``.

MCAP log times are unsigned 64-bit; int64 nanoseconds end in 2262.  Reading refuses such a
file naming the topic and the time.  ``inspect`` described the messages before the first
such time and said "20 messages" of a file of 40, its problem naming the time but not that
counting stopped there.  Written with the ``mcap`` writer.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcap.writer import Writer as McapWriter

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)
LATEST = 2**63 - 1


def _log(path: Path, start: int) -> Path:
    """JSON topics ``/u`` and ``/y``, 20 messages each, 0.1 s apart from ``start`` ns."""
    with path.open("wb") as stream:
        writer = McapWriter(stream)
        writer.start()
        schema = writer.register_schema("X", "jsonschema", b"{}")
        channels = [writer.register_channel(t, "json", schema) for t in ("/u", "/y")]
        for k in range(20):
            t = start + k * 100_000_000
            for channel in channels:
                writer.add_message(channel, t, json.dumps({"x": k}).encode(), t)
        writer.finish()
    return path


@pytest.mark.parametrize("start", [LATEST - 999_999_999, 2**64 - 3_000_000_000])
def test_a_log_time_past_2262_is_refused_naming_the_topic(start: int, tmp_path: Path) -> None:
    log = _log(tmp_path / "late.mcap", start)
    first_late = next(t for k in range(20) if (t := start + k * 100_000_000) > LATEST)
    with pytest.raises(LogError) as error:
        load_signals(log, SPEC, ReadOptions(maps=("u=/u.x", "y=/y.x")))
    assert str(error.value) == (
        f"{log}: topic '/u': a message's log time, {first_late} ns, is after the year 2262 "
        "(2^63 ns), which no clock records: a damaged or mis-stamped log"
    )


def test_inspect_says_its_counts_stop_at_a_log_time_past_2262(tmp_path: Path) -> None:
    log = _log(tmp_path / "late.mcap", LATEST - 999_999_999)  # 10 of each topic before 2^63
    described = inspect_log(log)
    assert described["messages"] == 20
    (problem,) = described["problems"]
    assert problem.endswith(
        "reading stopped there, after 20 messages: the counts and times above are of those"
    )
