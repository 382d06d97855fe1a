"""``inspect --json`` is strict JSON with the keys README documents, for every kind of log.

README lists the keys; this holds them to it, for the sample logs of every format and for
logs with nothing to describe (a topic without messages, a table without rows, a time column
that cannot be read), where a key left out or a NaN written would break a script reading it.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from hybridlog.cli import main
from hybridlog.io import inspect_log
from tests.support.paths import SAMPLE_LOGS

STEPS = ("rate_hz", "sample_time", "min_step", "max_step", "regular", "repeated")
GAPS = ("gap_count", "gaps")
TABLE = ("path", "format", "rows", "columns", "time", *STEPS, *GAPS, "problems")
COLUMN = ("name", "dtype", "count", "nonfinite", "min", "max", *STEPS, *GAPS)
MESSAGES = ("path", "format", "messages", "topics", "time", "problems", "reading")
TOPIC = (
    *("name", "type", "encoding", "count", "indexed_count", "start", "end", "duration"),
    *STEPS,
    *GAPS,
    *("nonfinite", "values", "undecodable", "header_stamp", "fields", "arrays"),
)
SAMPLES = sorted(p.name for p in SAMPLE_LOGS.iterdir() if p.suffix != ".md")


def odd_logs(root: Path) -> list[Path]:
    """A topic without messages, a table without rows, one with an unreadable time column."""
    from mcap.writer import Writer

    mcap = root / "empty_topic.mcap"
    with mcap.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="test")
        schema = writer.register_schema("S", "jsonschema", b"{}")
        writer.register_channel("/never", "json", schema)
        channel = writer.register_channel("/once", "json", schema)
        writer.add_message(channel, 5, b'{"v": NaN}', 5)
        writer.finish()
    (root / "header.csv").write_text("t,x\n")
    (root / "nan_time.csv").write_text("t,x\nnan,1\n1,inf\n")
    return [mcap, root / "header.csv", root / "nan_time.csv"]


def check(info: dict[str, Any]) -> None:
    text = json.dumps(info, allow_nan=False)
    assert json.loads(text) == info
    if "topics" in info:
        profile = ["profile"] if "profile" in info else []
        # an MCAP file, read by either reader (a ros2-profile one by rosbags'), lists what it
        # carries beside its messages; a bag has no such records
        side = ["attachments", "metadata_records"] if "profile" in info else []
        assert list(info) == [*MESSAGES[:2], *profile, *MESSAGES[2:], *side]
        assert all(tuple(t) == TOPIC for t in info["topics"])
        spans = [("start", "end", "duration")]
    else:
        assert tuple(info) == TABLE
        assert all(tuple(c) == COLUMN for c in info["columns"])
        spans = [("column", "start", "end", "duration")]
    assert info["time"] is None or tuple(info["time"]) in spans


@pytest.mark.parametrize("name", SAMPLES)
def test_sample_logs_have_the_documented_keys(name: str) -> None:
    check(inspect_log(SAMPLE_LOGS / name))


def test_logs_with_nothing_to_describe_have_them_too(tmp_path: Path) -> None:
    for log in odd_logs(tmp_path):
        check(inspect_log(log))


def test_the_cli_prints_strict_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = odd_logs(tmp_path)[0]
    main(["inspect", str(log), "--json"])  # returns: inspect describes
    printed = capsys.readouterr().out

    def refuse(token: str) -> None:
        raise AssertionError(f"{token} is not JSON")

    info = json.loads(printed, parse_constant=refuse)
    assert info["topics"][1]["values"] == [{"name": "/once.v", "count": 1, "nonfinite": 1}]
    assert info["topics"][0]["count"] == 0 and info["topics"][0]["start"] is None
