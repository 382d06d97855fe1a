"""MCAP channels of ``omgidl`` schemas, named by their IDL modules (``foo::Point``), are read.

The MCAP specification names an ``omgidl`` schema's type as IDL does, through its modules
with ``::`` (``spatial::events::Zone``), and DDS recorders write it so.  rosbags names the
struct of ``module foo { struct Point }`` ``foo/Point``, so every such topic was refused,
"its stored definition defines 'foo/Point', not its type 'foo::Point'", and ``inspect``
listed no field of it.  The values are checked against rosbags' own decoding.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer
from rosbags.typesys import Stores, get_types_from_idl, get_typestore

from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals

IDL = """#ifndef SPATIAL_IDL
#define SPATIAL_IDL
module spatial {
  module events {
    struct Zone {
      uint8 kind;
      double level;
      sequence<float> corners;
    };
  };
};
#endif
"""
NAMES = ("spatial::events::Zone", "::spatial::events::Zone")
STEPS = 20


def _write(path: Path, name: str) -> list[tuple[int, bytes]]:
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_idl(IDL.split("#endif")[0].split("#define SPATIAL_IDL\n")[1]))
    zone = store.types["spatial/events/Zone"]
    messages = [
        (
            10**9 + k * 10**8,
            bytes(
                store.serialize_cdr(
                    zone(kind=k % 3, level=k + 0.5, corners=np.array([k, -k], dtype=np.float32)),
                    "spatial/events/Zone",
                )
            ),
        )
        for k in range(STEPS)
    ]
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="test")
        schema = writer.register_schema(name, "omgidl", IDL.encode())
        plain = writer.register_schema("Input", "jsonschema", b"")
        zones = writer.register_channel("/zone", "cdr", schema)
        inputs = writer.register_channel("/u", "json", plain)
        for t, data in messages:
            writer.add_message(zones, t, data, t)
            writer.add_message(inputs, t, b'{"data": 1.0}', t)
        writer.finish()
    return messages


@pytest.mark.parametrize("name", NAMES)
def test_an_omgidl_schema_named_by_its_modules_is_read(name: str, tmp_path: Path) -> None:
    log = tmp_path / "zones.mcap"
    _write(log, name)
    info = inspect_log(log)
    assert not info.get("problems"), info.get("problems")
    spec = SignalSpec(inputs=("u",), outputs=("y", "z", "c"), mode_ids=("1",), dt=0.1)
    signals = load_signals(
        log,
        spec,
        ReadOptions(maps=("u=/u.data", "y=/zone.level", "z=/zone.kind", "c=/zone.corners[1]")),
    )
    np.testing.assert_array_equal(signals.outputs[:, 0], np.arange(STEPS) + 0.5)
    np.testing.assert_array_equal(signals.outputs[:, 1], np.arange(STEPS) % 3)
    np.testing.assert_array_equal(signals.outputs[:, 2], -np.arange(STEPS))
