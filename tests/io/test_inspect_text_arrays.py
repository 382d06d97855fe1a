"""Arrays of text are fields as text is: ``inspect`` lists them, ``--map`` reads them.

An element of a ROS ``string[]``, or of a JSON array of strings or booleans, reads as a mode
label (or a 0/1 number) with an index, as a single ``string`` or boolean does; but ``inspect``
listed only arrays of numbers among "the message paths for --map", and the close names a
mistyped path was offered left them out too.
"""

from __future__ import annotations

import json
from pathlib import Path

from hybridlog.io import ReadOptions, inspect_log, open_log
from tests.support.logfiles import NS

STEPS = 5


def test_arrays_of_text_are_listed_as_the_label_fields_they_are(tmp_path: Path) -> None:
    """A ``string[]`` (ROS) or an array of strings or booleans (JSON) reads as labels with an
    index, as a ``string`` does, but inspect listed the one and not the other."""
    from mcap.writer import Writer
    from rosbags.rosbag2 import Writer as BagWriter
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.LATEST)  # a store of its own: the shared one stays as it is
    store.register(get_types_from_msg("string mode\nstring[] modes\nfloat64 x\n", "p/msg/Modes"))
    bag = tmp_path / "bag"
    with BagWriter(bag, version=8) as writer:
        connection = writer.add_connection("/m", "p/msg/Modes", typestore=store)
        for k in range(STEPS):
            message = store.types["p/msg/Modes"](mode=f"m{k}", modes=[f"m{k}", "off"], x=1.0)
            writer.write(connection, k * NS, bytes(store.serialize_cdr(message, "p/msg/Modes")))
    assert inspect_log(bag)["topics"][0]["fields"] == ["/m.mode", "/m.modes[]", "/m.x"]
    with open_log(bag, ReadOptions()) as source:
        assert "/m.modes[]" in source.fields()
        labels = source.read([], ["/m.modes[0]"]).labels["/m.modes[0]"]
    assert labels.categories == tuple(f"m{k}" for k in range(STEPS))

    log = tmp_path / "json.mcap"
    schema = {
        "type": "object",
        "properties": {"tags": {"type": "array", "items": {"type": "string"}}},
    }
    with log.open("wb") as stream:
        mcap = Writer(stream)
        mcap.start(profile="", library="test")
        listed = mcap.register_schema("Listed", "jsonschema", json.dumps(schema).encode())
        found = mcap.register_schema("Found", "jsonschema", b"{}")
        channels = [mcap.register_channel(t, "json", s) for t, s in (("/a", listed), ("/b", found))]
        for k in range(STEPS):
            document = {"tags": [f"m{k}"], "on": [k % 2 == 0], "xs": [float(k)]}
            for channel in channels:
                mcap.add_message(channel, k * NS, json.dumps(document).encode(), k * NS)
        mcap.finish()
    topics = {t["name"]: t for t in inspect_log(log)["topics"]}
    # the schema's fields first, then those its messages hold beyond them (a JSON schema's
    # ``properties`` do not close an object unless ``additionalProperties`` is false)
    assert topics["/a"]["fields"] == ["/a.tags[]", "/a.on[]", "/a.xs[]"]
    assert topics["/b"]["fields"] == ["/b.tags[]", "/b.on[]", "/b.xs[]"]
    assert [v["name"] for v in topics["/b"]["values"]] == ["/b.xs[]"]  # numbers alone
    with open_log(log, ReadOptions()) as source:
        reading = source.read(["/b.on[0]"], ["/a.tags[0]"])
    assert reading.labels["/a.tags[0]"].categories == tuple(f"m{k}" for k in range(STEPS))
    assert reading.numeric["/b.on[0]"].values.tolist() == [1.0, 0.0, 1.0, 0.0, 1.0]
