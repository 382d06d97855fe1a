"""``--recover`` is read by bare MCAP files only: given for another format, it is not ignored.

It was silently ignored for a CSV, Parquet or bag log: the user who asked for a damaged log
to be recovered got a report as if the log were whole, with nothing to say the option did
nothing.  ``analyze`` (and ``compare``, ``cluster``: every command opening the log) now refuse
it in one line naming the option, the log and its format; a batch over logs of mixed formats
applies it to its MCAP files and says so in a note, and refuses it when no log is one.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from hybridlog.errors import OptionError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.jobs.batch import run_batch
from tests.support.cli import run_main

SAMPLES = Path(__file__).resolve().parents[2] / "sample_logs"
SPEC = SignalSpec(inputs=("q",), outputs=("y1",), mode_ids=("1",), dt=0.1)
TAIL = "--recover reads only an unfinished or damaged MCAP file (sequentially, up to its first bad"


@pytest.mark.parametrize(
    ("name", "what", "hint"),
    [
        ("three_tank_hstf.csv", "a CSV file", "leave it out"),
        ("three_tank_hstf.parquet", "a Parquet file", "leave it out"),
        ("three_tank_hstf.bag", "a ROS 1 bag", "leave it out"),
        (
            "three_tank_hstf_ros2mcap",
            "a ROS 2 bag",
            "for an unfinished .mcap storage file of the bag, give that file itself",
        ),
    ],
)
def test_recover_for_a_log_of_another_format_is_refused_naming_it(
    name: str, what: str, hint: str
) -> None:
    log = SAMPLES / name
    with pytest.raises(OptionError) as raised:
        load_signals(log, SPEC, ReadOptions(recover=True))
    assert str(raised.value) == f"--recover: {log} is {what}; {TAIL} record): {hint}"


def test_analyze_refuses_it_in_one_line_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "report"
    log = SAMPLES / "three_tank_hstf.csv"
    args = ["analyze", str(log), "--model", "three_tank_hstf", "--out", str(out), "--recover"]
    code, printed = run_main(args, capsys)
    assert code == 2 and not out.exists()
    (line,) = printed.strip().splitlines()
    assert line.startswith(f"hybridlog: error: --recover: {log} is a CSV file; ")


def test_a_batch_over_mixed_formats_recovers_its_mcap_files_and_says_so(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("three_tank_hstf.csv", "three_tank_hstf.mcap", "three_tank_hstf.parquet"):
        shutil.copyfile(SAMPLES / name, logs / name)
    outcome = run_batch(
        [logs], "three_tank_hstf", out_dir=tmp_path / "out", read=ReadOptions(recover=True)
    )
    assert [log.status for log in outcome.logs] == ["done", "done", "done"]
    assert outcome.notes == [
        "--recover: applied to the MCAP file of the batch; the other 2 logs (1 csv, "
        "1 parquet) are not MCAP files and are read as they are"
    ]
    (mcap,) = [log for log in outcome.logs if log.log.endswith(".mcap")]
    assert mcap.report is not None and mcap.report.reading["recovered"] is True


def test_a_batch_without_an_mcap_file_refuses_it(tmp_path: Path) -> None:
    csv = tmp_path / "a.csv"
    shutil.copyfile(SAMPLES / "three_tank_hstf.csv", csv)
    with pytest.raises(
        OptionError, match=r"^--recover: no log of the batch is an MCAP file \(1 csv\); "
    ):
        run_batch(
            [csv], "three_tank_hstf", out_dir=tmp_path / "out", read=ReadOptions(recover=True)
        )
    assert not (tmp_path / "out").exists()
    from hybridlog.jobs.batch_logs import recover_note  # the batch's note: none for MCAP alone

    assert recover_note([str(SAMPLES / "three_tank_hstf.mcap")]) is None
