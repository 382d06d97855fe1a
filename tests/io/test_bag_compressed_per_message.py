"""A ROS 2 bag compressed per message (rosbags' writer, zstd), whole and as a bare file.

Through its folder the bag reads as written.  Its storage file alone holds each message as
a zstd frame; decoding one as CDR failed with rosbags' "Invalid or unsupported CDR
encapsulation.", which names no cause: the error now says the bytes are compressed and
that the folder reads them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals
from hybridlog.io.message_paths import UndecodableError, decode_each

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)
MAPS = ("u=/u.data", "y=/y.data")
N = 20


def _bag(folder: Path, storage: StoragePlugin) -> Path:
    store = get_typestore(Stores.ROS2_HUMBLE)
    number = store.types["std_msgs/msg/Float64"]
    writer = Writer(folder, version=8, storage_plugin=storage)
    writer.set_compression(CompressionMode.MESSAGE, CompressionFormat.ZSTD)
    with writer:
        topics = [
            writer.add_connection(t, "std_msgs/msg/Float64", typestore=store) for t in ("/u", "/y")
        ]
        for k in range(N):
            for topic, value in zip(topics, (float(k), -1.5 * k), strict=True):
                data = store.serialize_cdr(number(data=value), "std_msgs/msg/Float64")
                writer.write(topic, 1_000_000_000 + k * 100_000_000, data)
    return folder


@pytest.mark.parametrize(
    "storage", [StoragePlugin.SQLITE3, StoragePlugin.MCAP], ids=["db3", "mcap"]
)
def test_the_storage_file_alone_is_named_compressed(storage: StoragePlugin, tmp_path: Path) -> None:
    folder = _bag(tmp_path / "bag", storage)
    signals = load_signals(folder, SPEC, ReadOptions(maps=MAPS))
    np.testing.assert_array_equal(signals.outputs[:, 0], -1.5 * np.arange(N))
    (file,) = (f for f in folder.iterdir() if f.name != "metadata.yaml")
    with pytest.raises(LogError) as error:
        load_signals(file, SPEC, ReadOptions(maps=MAPS))
    message = str(error.value)
    assert "topic '/u'" in message and "t=1 s cannot be decoded" in message
    assert "its bytes are zstd-compressed" in message and "read through its folder" in message
    assert "CDR encapsulation" not in message and "\n" not in message
    problems = inspect_log(file)["problems"]
    assert len(problems) == 2 and all("zstd-compressed" in p for p in problems)


def test_an_lz4_frame_is_named_and_other_bad_bytes_keep_the_decoder_s_words() -> None:
    def refuse(data: bytes) -> object:
        raise ValueError("Invalid or unsupported CDR encapsulation.")

    with pytest.raises(UndecodableError, match="its bytes are LZ4-compressed") as error:
        decode_each(refuse, [b"\x04\x22\x4d\x18\x64\x40"])
    assert error.value.row == 0
    with pytest.raises(UndecodableError, match=r"^Invalid or unsupported CDR encapsulation\.$"):
        decode_each(refuse, [b"\x00\x01\x00\x00"])
