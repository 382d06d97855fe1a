"""A log batch cannot read fails with the reason ``analyze`` gives for that very log.

batch hashes a log before reading it, and the hash's error came first: a missing log was
``log gone.csv: cannot read it: No such file or directory`` in summary.csv where
``analyze`` says ``gone.csv: no such file``, and a link to nothing lost what ``analyze``
says of it (``a symbolic link to 'nowhere.csv', which does not exist``).  The log is now
checked as its reader checks it before it is hashed.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.jobs.analysis import analyze
from hybridlog.jobs.batch import run_batch


def test_an_unreadable_log_fails_in_batch_as_in_analyze(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    (logs / "link.csv").symlink_to("nowhere.csv")
    (logs / "empty.csv").touch()
    unreadable = [logs / "gone.csv", logs / "link.csv", logs / "empty.csv"]
    outcome = run_batch(unreadable, "three_tank_hstf", out_dir=tmp_path / "out", estimator="imm")
    errors = {log.log: log.error for log in outcome.logs if log.status == "failed"}
    for log in unreadable:
        with pytest.raises(LogError) as analyzed:
            analyze(log, "three_tank_hstf", out_dir=tmp_path / "a", estimator="imm")
        assert errors[str(log)] == str(analyzed.value)
