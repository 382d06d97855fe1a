"""The JUnit XML of a batch stays well-formed XML whatever the logs are named."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from hybridlog.errors import OutputError
from hybridlog.outputs import temporary_name
from hybridlog.report.junit import write_junit
from hybridlog.report.summary_rows import BatchRow


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


def test_a_cases_time_is_its_logs_wall_time(tmp_path: Path) -> None:
    """JUnit's ``time`` was the report's ``runtime_s``, the estimator's alone (0.000 for every
    case of the README's batch: 300 samples in under a millisecond), and 0 for a log that
    failed; it is the log's wall time in the run, shared among its gates' cases."""
    import xml.etree.ElementTree as ET

    from hybridlog.jobs.batch import run_batch
    from tests.jobs.test_batch_resume import write_logs

    logs = write_logs(tmp_path / "logs", ["s1.csv"], steps=20)
    (tmp_path / "logs" / "bad.csv").write_text("t,u\n0,1\n")
    junit = tmp_path / "junit.xml"
    outcome = run_batch(
        [*logs, tmp_path / "logs" / "bad.csv"],
        "three_tank_hstf",
        out_dir=tmp_path / "out",
        estimator="imm",
        junit=junit,
        fail_under=["vaf=0", "fit=-1000"],
    )
    seconds = {Path(o.log).name: o.seconds for o in outcome.logs}
    assert seconds["s1.csv"] > 0.001 and seconds["bad.csv"] > 0.0
    root = ET.parse(junit).getroot()
    times = [(c.get("classname"), c.get("name"), c.get("time")) for c in root.iter("testcase")]
    good, bad = str(logs[0]), str(tmp_path / "logs" / "bad.csv")
    assert sorted(times) == sorted(
        [
            (bad, "analysis", f"{seconds['bad.csv']:.3f}"),
            (good, "--fail-under vaf=0", f"{seconds['s1.csv'] / 2:.3f}"),
            (good, "--fail-under fit=-1000", f"{seconds['s1.csv'] / 2:.3f}"),
        ]
    )
    suite = root.find("testsuite")
    assert suite is not None and suite.get("time") == f"{sum(seconds.values()):.3f}"
