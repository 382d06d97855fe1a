"""``inspect`` lists an MCAP file's attachments and metadata records.

Neither is a message and no estimator reads them, but a log that carries a calibration file or
a robot's serial number should say so.  The records are walked for in a finished file's data
section (the summary's indexes of them are optional), collected as they go by in a file read
sequentially, and a record the walk cannot pass is a problem, not an error.  The conformance
suite's files and every ``mcap`` writer variant are checked in ``test_logs_conformance.py``.
"""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner
from mcap.writer import Writer

from hybridlog.cli import cli
from hybridlog.io import inspect_log

NS = 1_000_000_000
ENTRIES = {"serial": "A-17", "notes": "n" * 100, **{f"k{i}": str(i) for i in range(6)}}


def _write(path: Path) -> Path:
    """A JSON topic ``/y`` of 10 messages, an attachment at 5 s and two metadata records."""
    with path.open("wb") as handle:
        writer = Writer(handle, chunk_size=200)
        writer.start(profile="", library="tests")
        schema = writer.register_schema(
            "Y", "jsonschema", b'{"type": "object", "properties": {"y": {"type": "number"}}}'
        )
        channel = writer.register_channel("/y", "json", schema)
        for k in range(10):
            if k == 5:
                writer.add_attachment(k * NS, k * NS, "calib.yaml", "text/yaml", b"gain: 2\n" * 4)
                writer.add_metadata("robot", ENTRIES)
                writer.add_metadata("empty", {})
            writer.add_message(channel, k * NS, json.dumps({"y": k}).encode(), k * NS)
        writer.finish()
    return path


def test_inspect_prints_the_attachments_and_metadata_records(tmp_path: Path) -> None:
    log = _write(tmp_path / "run.mcap")
    result = CliRunner().invoke(cli, ["inspect", str(log)])
    assert result.exit_code == 0, result.output
    text = result.output
    assert "attachments (files the log carries; analyze reads only its messages):" in text
    assert "  calib.yaml: text/yaml, 32 bytes, log time 5 s" in text
    robot = next(line for line in text.splitlines() if line.startswith("  robot: "))
    # the first six entries, a long value cut, the rest counted
    assert robot.startswith("  robot: serial = 'A-17', notes = 'nnn")
    assert "…" in robot and robot.endswith("k3 = '3', ... 2 more (see --json)")
    assert "  empty: no entries" in text
    info = json.loads(CliRunner().invoke(cli, ["inspect", str(log), "--json"]).output)
    assert info["attachments"] == [
        {"name": "calib.yaml", "media_type": "text/yaml", "bytes": 32, "log_time": 5.0}
    ]
    assert info["metadata_records"] == [
        {"name": "robot", "entries": ENTRIES},
        {"name": "empty", "entries": {}},
    ]


def test_an_unfinished_file_lists_the_records_read_before_its_end(tmp_path: Path) -> None:
    log = _write(tmp_path / "cut.mcap")
    log.write_bytes(log.read_bytes()[:-10])  # no closing magic: read sequentially
    info = inspect_log(log)
    assert info["reading"]["recovered"]
    assert [a["name"] for a in info["attachments"]] == ["calib.yaml"]
    assert [m["name"] for m in info["metadata_records"]] == ["robot", "empty"]


def test_a_record_the_walk_cannot_pass_is_a_problem_and_the_messages_are_read(
    tmp_path: Path,
) -> None:
    log = _write(tmp_path / "run.mcap")
    data = bytearray(log.read_bytes())
    at = data.index(b"calib.yaml") - 4  # the attachment's name: its length prefix
    data[at : at + 4] = (10**9).to_bytes(4, "little")
    log.write_bytes(bytes(data))
    info = inspect_log(log)
    assert [(t["name"], t["count"]) for t in info["topics"]] == [("/y", 10)]
    assert info["attachments"] == []
    [problem] = info["problems"]
    record = at - 8 - 8 - 9  # back over the two times, then the opcode and the length
    assert problem.startswith(f"the record at byte {record} cannot be read (")
    assert problem.endswith("attachments and metadata records after it are not listed")


def test_logs_of_other_formats_have_no_such_keys(tmp_path: Path) -> None:
    log = tmp_path / "run.csv"
    log.write_text("t,y\n0,1\n1,2\n")
    assert "attachments" not in inspect_log(log)
