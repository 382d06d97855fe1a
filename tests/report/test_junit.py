"""The JUnit XML of a batch stays well-formed XML whatever the logs are named."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from hybridlog.report.junit import write_junit
from hybridlog.report.summary import BatchRow


def test_names_and_errors_xml_cannot_hold_are_written_out(tmp_path: Path) -> None:
    """A log named with control characters (an escape sequence, a NUL) made the whole file
    unreadable to a CI system: 'not well-formed (invalid token)'."""
    name = "runs/ctl\x01\x1b[31m\x00 & <x>\ufffe.csv"
    rows = [
        BatchRow(
            log=name, folder="x", status="failed", report=None, error=f"{name}: not a log\x07"
        ),
        BatchRow(log="a\nb.csv", folder="y", status="failed", report=None, error="bad"),
    ]
    path = tmp_path / "junit.xml"
    write_junit(path, "hybridlog batch: m\x1b · imm", rows)
    root = ET.parse(path).getroot()  # raised ParseError
    cases = list(root.iter("testcase"))
    shown = "runs/ctl\\x01\\x1b[31m\\x00 & <x>\\ufffe.csv"
    assert [case.get("classname") for case in cases] == [shown, "a\nb.csv"]
    error = cases[0].find("error")
    assert error is not None
    assert error.get("message") == error.text == f"{shown}: not a log\\x07"
    suite = root.find("testsuite")
    assert suite is not None
    assert suite.get("name") == "hybridlog batch: m\\x1b · imm"
