"""``inspect`` decodes large messages in parts of bounded bytes, not of 512 messages.

Reading header stamps made ``inspect`` decode every camera image: held 512 at a time, a
3.5 GB bag of 6 MiB images peaked at 6.3 GB (19.5 s); parts of at most
:data:`~hybridlog.io.value_counter.DECODED_BYTES_AT_ONCE` bring it back to 121 MB (4.7 s).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from hybridlog.io import value_counter
from hybridlog.io.inspect import inspect_log

IMAGE_BYTES = 2 * 1024 * 1024


def camera_bag(path: Path, count: int) -> Path:
    store = get_typestore(Stores.ROS2_HUMBLE)
    image = store.types["sensor_msgs/msg/Image"]
    header = store.types["std_msgs/msg/Header"]
    stamp = store.types["builtin_interfaces/msg/Time"]
    pixels = np.zeros(IMAGE_BYTES, dtype=np.uint8)
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        connection = writer.add_connection("/camera", image.__msgtype__, typestore=store)
        for k in range(count):
            t = 1_000_000_000 + k * 50_000_000
            message = image(
                header=header(stamp=stamp(sec=t // 10**9, nanosec=t % 10**9), frame_id="cam"),
                height=1024,
                width=2048,
                encoding="mono8",
                is_bigendian=0,
                step=2048,
                data=pixels,
            )
            writer.write(connection, t, store.serialize_cdr(message, image.__msgtype__))
    return path


def test_large_messages_are_decoded_in_parts_of_bounded_bytes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    parts: list[int] = []
    decode_each = value_counter.decode_each

    def counted(decode: Any, datas: list[bytes]) -> list[object]:
        parts.append(sum(len(data) for data in datas))
        return decode_each(decode, datas)

    monkeypatch.setattr(value_counter, "decode_each", counted)
    info = inspect_log(camera_bag(tmp_path / "cam", 24))
    (topic,) = info["topics"]
    assert topic["header_stamp"]["count"] == 24  # every stamp read
    assert sum(parts) > 24 * IMAGE_BYTES
    assert max(parts) < value_counter.DECODED_BYTES_AT_ONCE + 2 * IMAGE_BYTES, parts
