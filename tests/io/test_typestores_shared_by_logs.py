"""The logs of a batch share the type stores of the definitions they store alike.

Each log's every definition was parsed and its rosbags type store built anew (rosbags
generates a class per type): some 1-2 ms a definition, a tenth of a small log's reading.
The stores are kept by the definition's text (and the type, ROS 1 or 2, the ``--msg-dir``
types), so a log that defines the same type name otherwise gets a store of its own.
"""

from __future__ import annotations

from collections import OrderedDict
from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, definitions, load_signals
from tests.support.logfiles import val_mcap

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=0.1)


def _read(path: Path, field: str) -> int:
    maps = (f"u=/u.{field}", f"y=/y.{field}")
    return len(load_signals(path, SPEC, ReadOptions(maps=maps)).time)


@pytest.fixture
def built(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The definitions whose stores are built, from an empty cache."""
    monkeypatch.setattr(definitions, "_stores", OrderedDict())
    calls: list[str] = []
    build = definitions._build_typestore

    def counted(msgtype: str, encoding: str, text: str, **kwargs: object) -> object:
        calls.append(text)
        return build(msgtype, encoding, text, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(definitions, "_build_typestore", counted)
    return calls


def test_the_second_log_of_a_definition_builds_no_store(tmp_path: Path, built: list[str]) -> None:
    first = val_mcap(tmp_path / "a.mcap", "float64 a")
    second = val_mcap(tmp_path / "b.mcap", "float64 a")
    assert _read(first, "a") == _read(second, "a") == 10
    assert built == ["float64 a"]


def test_another_definition_of_the_same_type_name_gets_its_own_store(
    tmp_path: Path, built: list[str]
) -> None:
    assert _read(val_mcap(tmp_path / "a.mcap", "float64 a"), "a") == 10
    other = val_mcap(tmp_path / "b.mcap", "float64 b")
    assert _read(other, "b") == 10
    with pytest.raises(LogError, match="has no field 'a'; fields: 'b'"):
        _read(other, "a")
    assert built == ["float64 a", "float64 b"]


def test_the_stores_kept_are_bounded(built: list[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(definitions, "STORE_CACHE_SIZE", 2)
    texts = ["float64 a", "float64 b", "float64 c", "float64 a"]
    stores = [
        definitions.typestore_for("my_pkg/msg/Val", "msg", t, ros1=False, extra={}) for t in texts
    ]
    assert len(definitions._stores) == 2 and built == texts  # "a" was dropped for "c"
    assert stores[0] is not stores[3]
    assert definitions.typestore_for("my_pkg/msg/Val", "msg", "float64 c", ros1=False, extra={})
    assert built == texts
