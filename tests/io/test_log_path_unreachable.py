"""A log path that cannot be reached is one line naming why, for inspect and analyze alike.

``log_format`` asked ``Path.exists``, which says ``False`` of a symbolic link leading back to
itself (reported as "no such file", beside a link the user can list) and raises
``PermissionError`` for a log inside a folder one may not enter (reported as "unexpected
PermissionError ... (a bug)"); a bag folder one may not list raised it too.  One ``stat`` of
the path now says which: the system's reason, or a link to a target that does not exist.
"""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path
from typing import Any

import pytest

from tests.support.cli import run_main
from tests.support.paths import SAMPLE_LOGS


def refused(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    code, out = run_main(args, capsys)
    lines = out.strip().splitlines()
    assert code == 2, out
    assert len(lines) == 1 and "Traceback" not in out and "a bug" not in out, out
    return lines[0]


@pytest.mark.parametrize("command", ["inspect", "analyze"])
def test_a_symbolic_link_loop_is_not_said_missing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    (tmp_path / "a.csv").symlink_to(tmp_path / "b.csv")
    (tmp_path / "b.csv").symlink_to(tmp_path / "a.csv")
    model = ["--model", "three_tank_hstf", "--out", str(tmp_path / "out")]
    line = refused(
        [command, str(tmp_path / "a.csv"), *(model if command == "analyze" else [])], capsys
    )
    assert line == (
        f"hybridlog: error: {tmp_path / 'a.csv'}: cannot be read ({os.strerror(errno.ELOOP)})"
    )
    assert not (tmp_path / "out").exists()


def test_a_link_to_nothing_names_its_target(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "log.csv").symlink_to(tmp_path / "gone.csv")
    assert refused(["inspect", str(tmp_path / "log.csv")], capsys) == (
        f"hybridlog: error: {tmp_path / 'log.csv'}: a symbolic link to "
        f"'{tmp_path / 'gone.csv'}', which does not exist"
    )


def _denied(where: Path, method: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """``Path.<method>`` of ``where`` fails as for a user the folder's mode shuts out (the
    suite may run as root, whom ``chmod`` does not stop)."""
    real = getattr(Path, method)

    def guarded(self: Path, *args: Any, **kwargs: Any) -> Any:
        if self == where:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(self))
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Path, method, guarded)


def test_a_log_in_a_folder_one_may_not_enter_is_said_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    log = tmp_path / "log.csv"
    shutil.copy(SAMPLE_LOGS / "three_tank_hstf.csv", log)
    _denied(log, "stat", monkeypatch)
    assert refused(["inspect", str(log)], capsys) == (
        f"hybridlog: error: {log}: cannot be read ({os.strerror(errno.EACCES)})"
    )


def test_a_bag_folder_one_may_not_list_is_said_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    bag = tmp_path / "bag"
    shutil.copytree(SAMPLE_LOGS / "three_tank_hstf_ros2", bag)
    (bag / "metadata.yaml").unlink()  # found by listing the folder
    _denied(bag, "iterdir", monkeypatch)
    assert refused(["inspect", str(bag)], capsys) == (
        f"hybridlog: error: {bag}: cannot be read ({os.strerror(errno.EACCES)})"
    )
