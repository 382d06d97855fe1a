"""Message definitions stored with Windows line ends (``\\r\\n``) are read.

A ``.msg`` file saved on Windows (or checked out there with ``core.autocrlf``) ends its lines
with ``\\r\\n``, and ROS's recorders store the text as they read it: in a ROS 1 bag's
connection header, an MCAP schema.  rosbags parses none of it ("Could not parse"), so the
topic was refused, although ROS reads such files (and ``--msg-dir`` files were read in text
mode, their line ends translated).  The MD5 sum the bag stores is of the definition as ROS
parses it, so it still matches.
"""

from __future__ import annotations

import hashlib
import struct
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as BagWriter
from rosbags.typesys import Stores, get_typestore

from hybridlog.io import ReadOptions, SignalSpec, load_signals
from tests.support.logfiles import write_levels_mcap

DEFINITION = (
    "# A tank's level\r\nfloat64 cm\r\nstring NAME=tank\r\ntp/Inner inner\r\n"
    + "=" * 80
    + "\r\nMSG: tp/Inner\r\nfloat64 v\r\n"
)
INNER_MD5 = hashlib.md5(b"float64 v").hexdigest()
MD5 = hashlib.md5(f"string NAME=tank\nfloat64 cm\n{INNER_MD5} inner".encode()).hexdigest()
STEPS = 10


def _bag(path: Path) -> Path:
    store = get_typestore(Stores.ROS1_NOETIC)
    with BagWriter(path) as writer:
        inputs = writer.add_connection("/u", "std_msgs/msg/Float64", typestore=store)
        levels = writer.add_connection("/y", "tp/msg/Level", msgdef=DEFINITION, md5sum=MD5)
        for k in range(STEPS):
            writer.write(inputs, 10**9 + k * 10**8, struct.pack("<d", k))
            writer.write(levels, 10**9 + k * 10**8, struct.pack("<dd", k + 0.5, -k))
    return path


def _mcap(path: Path) -> Path:
    return write_levels_mcap(path, "tp/msg/Level", DEFINITION.encode(), STEPS)


@pytest.mark.parametrize("log", ["crlf.bag", "crlf.mcap"])
def test_a_definition_with_windows_line_ends_is_read(log: str, tmp_path: Path) -> None:
    path = (_bag if log.endswith(".bag") else _mcap)(tmp_path / log)
    spec = SignalSpec(inputs=("u",), outputs=("y", "v"), mode_ids=("1",), dt=0.1)
    maps = ("u=/u.data", "y=/y.cm", "v=/y.inner.v")
    outputs = load_signals(path, spec, ReadOptions(maps=maps)).outputs
    np.testing.assert_array_equal(outputs[:, 0], np.arange(STEPS) + 0.5)
    np.testing.assert_array_equal(outputs[:, 1], -np.arange(STEPS))
