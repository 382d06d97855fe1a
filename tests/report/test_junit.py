"""The JUnit XML of a batch stays well-formed XML whatever the logs are named."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from hybridlog.errors import OutputError
from hybridlog.outputs import temporary_name
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


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full")
def test_a_junit_file_the_disk_cannot_take_is_named_not_its_temporary(tmp_path: Path) -> None:
    """The batch writes the file staged under a hidden temporary name; a full disk was
    reported as '--junit /ci/.junit.hybridlog-tmp-0a7c-26412-9f8e09f6.xml: cannot write it',
    a file the user never named and that is gone by the time the error is read."""
    target = tmp_path / "junit.xml"
    staged = temporary_name(target, keep_suffix=True)
    staged.symlink_to("/dev/full")  # writes to it fail with ENOSPC, as on a full disk
    expected = rf"^--junit {re.escape(str(target))}: cannot write it: No space left on device$"
    with pytest.raises(OutputError, match=expected):
        write_junit(staged, "hybridlog batch: m · imm", [])
