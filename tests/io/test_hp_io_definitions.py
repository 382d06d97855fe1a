"""A message definition that uses a type defined nowhere, or contains itself, is refused.

rosbags registers a definition whose field's type it does not know, and a type that holds
itself (even through an array).  The first made ``inspect`` list the topic with no fields,
no problem and "0 non-finite values", and ``--map`` into the field ended in a ``KeyError``
traceback; the second made every message "cannot be decoded (maximum recursion depth
exceeded)".  Now the topic's problem names the field and the type.  Files are written by
the ``mcap`` writer and rosbags' ROS 1 bag writer.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from rosbags.rosbag1 import Writer as Ros1Writer

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals
from tests.support.logfiles import val_mcap

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)
MISSING = "field inner has type 'my_pkg/msg/Inner', which has no definition"


def _ros1_bag(path: Path) -> Path:
    with Ros1Writer(path) as writer:
        connections = [
            writer.add_connection(t, "my_pkg/msg/Val", msgdef="my_pkg/Inner inner", md5sum="0" * 32)
            for t in ("/u", "/y")
        ]
        for k in range(10):
            for connection in connections:
                writer.write(connection, k * 100_000_000, bytes(8))
    return path


def _problems(log: Path, *msg_dirs: Path) -> list[str]:
    problems: list[str] = inspect_log(log, ReadOptions(msg_dirs=tuple(map(str, msg_dirs))))[
        "problems"
    ]
    return problems


@pytest.mark.parametrize("kind", ["mcap", "ros1 bag"])
def test_a_field_of_an_undefined_type_is_named(kind: str, tmp_path: Path) -> None:
    if kind == "mcap":
        log = val_mcap(tmp_path / "val.mcap", "my_pkg/Inner inner")
    else:
        log = _ros1_bag(tmp_path / "val.bag")
    problems = _problems(log)
    assert len(problems) == 2
    assert all(MISSING in p and "my_pkg/msg/Inner.msg" in p for p in problems)
    with pytest.raises(LogError, match=MISSING):
        load_signals(log, SPEC, ReadOptions(maps=("u=/u.inner.data", "y=/y.inner.data")))


def test_a_msg_dir_type_using_an_undefined_type_is_named(tmp_path: Path) -> None:
    log = val_mcap(tmp_path / "val.mcap", "")  # no stored text: --msg-dir defines it
    (tmp_path / "defs" / "my_pkg" / "msg").mkdir(parents=True)
    (tmp_path / "defs" / "my_pkg" / "msg" / "Val.msg").write_text("Inner inner\n")
    problems = _problems(log, tmp_path / "defs")
    assert problems and all(MISSING in p for p in problems)


NODE = "my_pkg/Node[] kids\n" + "=" * 80 + "\nMSG: my_pkg/Node\nmy_pkg/Node[] kids\n"


@pytest.mark.parametrize(
    ("definition", "field"), [("my_pkg/Val v\nfloat64 data", "v"), (NODE, "kids.kids")]
)
def test_a_type_that_contains_itself_is_named(definition: str, field: str, tmp_path: Path) -> None:
    # Val holds Val; Val holds Node[], and Node holds Node[] (a tree: rosbags cannot either)
    problems = _problems(val_mcap(tmp_path / "val.mcap", definition))
    assert len(problems) == 2
    assert all(f"contains itself (field {field})" in p for p in problems)
