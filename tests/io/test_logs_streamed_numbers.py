"""Numbers of messages rosbags decodes are read as each message is decoded, none kept.

``PointStamped`` topics read 0.66-0.84x as fast as rosbags' own loop: the decoded messages
were kept 512 at a time, and their objects made Python's cyclic garbage collector run as
often again, its full collections walking them (``hybridlog/io/topic_reader.py``,
``TopicReader._add_numbers_streamed``).  The numbers must be those the careful reading gives.
"""

from __future__ import annotations

import weakref
from pathlib import Path

import numpy as np
import pytest
from rosbags.typesys.store import Typestore

from hybridlog.io import ReadOptions, SignalSpec, load_signals
from tests.support.logfiles import Channel, cdr, ros2_store, stamped_point, write_mcap

N = 700
"""Messages: more than a part the careful reading keeps decoded at once (`DECODED_AT_ONCE`)."""
POINT = "geometry_msgs/msg/PointStamped"
SPEC = SignalSpec(inputs=("u",), outputs=("y1", "y2"), mode_ids=("a",), dt=0.01)
MAPS = ("u=/p.point.x", "y1=/p.point.y", "y2=/p.point.z")


def _points(path: Path) -> Path:
    store = ros2_store()
    messages = [
        (0, k * 10_000_000, cdr(stamped_point(store, k * 10_000_000, 0.25 * k), POINT))
        for k in range(N)
    ]
    return write_mcap(path, [Channel("/p", schema_name=POINT)], messages)


def test_no_decoded_message_outlives_its_numbers(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    decoded: list[weakref.ref[object]] = []
    alive: list[int] = []
    original = Typestore.deserialize_cdr

    def counted(self: Typestore, rawdata: bytes, typename: str) -> object:
        alive.append(sum(ref() is not None for ref in decoded))
        message = original(self, rawdata, typename)
        decoded.append(weakref.ref(message))
        return message

    monkeypatch.setattr(Typestore, "deserialize_cdr", counted)
    signals = load_signals(_points(tmp_path / "p.mcap"), SPEC, ReadOptions(maps=MAPS))
    assert len(alive) == N  # each message decoded once, for its three numbers
    assert max(alive) == 0
    x = 0.25 * np.arange(N)
    np.testing.assert_array_equal(signals.inputs[:, 0], x)
    np.testing.assert_array_equal(signals.outputs, np.column_stack([-x, np.full(N, 0.5)]))
