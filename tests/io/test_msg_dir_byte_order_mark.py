"""A ``--msg-dir`` file that starts with a UTF-8 byte-order mark is read.

Windows Notepad saves UTF-8 text with a byte-order mark (``EF BB BF``).  The ``.msg`` file a
user writes for a log without definitions was then refused, "not a readable message
definition (Could not parse: ...)", naming nothing of the cause: the mark was read as text
of the first line.  It is skipped, as in a CSV log.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hybridlog.io import ReadOptions, SignalSpec, load_signals
from tests.support.logfiles import write_levels_mcap

STEPS = 10


def test_a_msg_file_with_a_byte_order_mark_defines_its_type(tmp_path: Path) -> None:
    log = tmp_path / "levels.mcap"
    write_levels_mcap(log, "tank_msgs/msg/Level", b"", STEPS)  # no definition stored
    folder = tmp_path / "msgs" / "tank_msgs" / "msg"
    folder.mkdir(parents=True)
    (folder / "Level.msg").write_bytes(b"\xef\xbb\xbf# a level\r\nfloat64 cm\r\nfloat64 low\r\n")
    spec = SignalSpec(inputs=("u",), outputs=("y", "z"), mode_ids=("1",), dt=0.1)
    options = ReadOptions(
        maps=("u=/u.data", "y=/y.cm", "z=/y.low"), msg_dirs=(str(tmp_path / "msgs"),)
    )
    outputs = load_signals(log, spec, options).outputs
    np.testing.assert_array_equal(outputs[:, 0], np.arange(STEPS) + 0.5)
    np.testing.assert_array_equal(outputs[:, 1], -np.arange(STEPS))
