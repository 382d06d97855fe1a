"""One ``header.stamp`` of 0 among set stamps is refused under ``--time header``.

A publisher that left one header unset wrote 0 among stamps of 10 s.  With ``--sort`` that
message was moved to the start of the log as a sample at t=0 s and, with a ``--max-gap``
long enough, the log read from 0 s without a word.  A zero first (simulated time starting
at 0) is a stamp.  Written with ``mcap-ros2-support``'s writer.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap_ros2.writer import Writer as Ros2McapWriter

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from tests.support.logfiles import STAMPED_DEFINITION

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)
MAPS = ("u=/u.x", "y=/y.x")
N = 20


def _log(path: Path, zero_at: int, start: int = 1) -> Path:
    """Stamps 0.1 s apart from ``start`` s; message ``zero_at``'s stamp left at 0."""
    with path.open("wb") as stream:
        writer = Ros2McapWriter(stream)
        schema = writer.register_msgdef("my_pkg/msg/Stamped", STAMPED_DEFINITION)
        for k in range(N):
            stamp = (
                {"sec": 0, "nanosec": 0}
                if k == zero_at
                else {"sec": start + k // 10, "nanosec": k % 10 * 100_000_000}
            )
            for topic in ("/u", "/y"):
                message = {"header": {"stamp": stamp}, "x": float(k)}
                writer.write_message(topic, schema, message, log_time=(100 + k) * 100_000_000)
        writer.finish()
    return path


@pytest.mark.parametrize("sort", [False, True])
def test_a_zero_stamp_after_set_stamps_is_refused_naming_the_message(
    sort: bool, tmp_path: Path
) -> None:
    log = _log(tmp_path / "stamped.mcap", zero_at=3)
    options = ReadOptions(maps=MAPS, time="header", sort=sort, max_gap=20.0)
    with pytest.raises(LogError) as error:
        load_signals(log, SPEC, options)
    assert str(error.value) == (
        f"{log}: topic '/u': header.stamp is 0 in message 4 of 20 (logged at t=10.3 s), after "
        "a stamp of t=1.2 s: the publisher did not set it; use --time log"
    )


def test_a_zero_stamp_first_is_a_time(tmp_path: Path) -> None:
    log = _log(tmp_path / "stamped.mcap", zero_at=0, start=0)  # simulated time from 0
    signals = load_signals(log, SPEC, ReadOptions(maps=MAPS, time="header"))
    assert signals.n_samples == N and signals.time[0] == 0.0
