"""An input recorded once (a latched set-point) is held over the whole log, said so.

A ROS 1 latched topic, or a set-point published once before recording started, has one
message in the bag.  The hold carries it over the log (SPEC §5), and the reading notes say
how often a held input was sampled: the median of its steps, of which one message has none.
``numpy.median`` of no step warned "Mean of empty slice" and gave NaN, which ``analyze``
refused as numerical trouble (exit 2, no report).  Now a series of one sample has no
``every`` nor ``steps`` (``None``), and the report says the input is held at its last
value, as one published only when it changes is.  Written with rosbags' ROS 1 bag writer
and the ``mcap`` writer.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Ros1Writer

from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.report.reading_notes import log_reading_notes
from tests.support.logfiles import Channel, float_messages, ros1_store, write_mcap

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=0.1)
START = 1_700_000_000 * 10**9
N = 30
OUTPUT_TIMES = [START + k * 10**8 for k in range(N)]
SET_POINT_AT = START - 5 * 10**9  # latched: recorded once, 5 s before the outputs


def _bag(path: Path) -> Path:
    store, msgtype = ros1_store(), "std_msgs/msg/Float64"
    with Ros1Writer(path) as writer:
        u = writer.add_connection("/u", msgtype, typestore=store, latching=1)
        y = writer.add_connection("/y", msgtype, typestore=store)
        cls = store.types[msgtype]
        writer.write(u, SET_POINT_AT, store.serialize_ros1(cls(data=30.0), msgtype))
        for k, t in enumerate(OUTPUT_TIMES):
            writer.write(y, t, store.serialize_ros1(cls(data=float(k)), msgtype))
    return path


def _mcap(path: Path) -> Path:
    messages = float_messages([SET_POINT_AT], [30.0], 0)
    messages += float_messages(OUTPUT_TIMES, range(N), 1)
    return write_mcap(path, [Channel("/u"), Channel("/y")], messages)


@pytest.mark.parametrize(("name", "write"), [("latched.bag", _bag), ("latched.mcap", _mcap)])
def test_an_input_recorded_once_is_held_and_said_to_be(
    name: str, write: Any, tmp_path: Path
) -> None:
    log = write(tmp_path / name)
    notes: dict[str, Any] = {}
    signals = load_signals(log, SPEC, ReadOptions(maps=("u=/u.data", "y=/y.data")), notes=notes)
    assert signals.n_samples == N
    assert np.array_equal(signals.inputs[:, 0], np.full(N, 30.0))
    assert np.array_equal(signals.outputs[:, 0], np.arange(N, dtype=float))
    held = notes["held"]["u"]
    assert (held["every"], held["steps"], held["regular"]) == (None, None, False)
    json.dumps(notes, allow_nan=False)
    said = [n for n in log_reading_notes(notes) if "input u" in n]
    assert said == [
        "WARNING: input u has no sample from t = 1699999995 to 1700000002.9 s (7.9 s, longer "
        "than max_gap): held at its last value, as an input published only when it changes is "
        "(zero-order hold)"
    ]
