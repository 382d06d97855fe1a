"""What ``analyze`` sends its estimators' worker makes the worker import none of the job.

A function goes to a worker pickled by module and name, and the worker imports its module to
run it: the warm-up sent as :func:`hybridlog.jobs.analysis`'s own made the worker import the
whole job (the readers, the report's modules: 0.04 s more of a core, while the command reads
its log on the other).  The requests are recorded here as the worker would read them, then read
in a fresh interpreter that has imported what the console script's worker has when forked.
"""

from __future__ import annotations

import io
import json
import subprocess
import sys
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import pytest

from hybridlog import background
from hybridlog.cli_process import SHARED_IMPORTS
from hybridlog.jobs.analysis import analyze
from tests.support.paths import TANK_CSV

NOT_IN_THE_WORKER = (
    "hybridlog.jobs.analysis",
    "hybridlog.jobs.compare",
    "hybridlog.jobs.estimation",
    "hybridlog.jobs.gate_checks",
    "hybridlog.jobs.overrides",
    "hybridlog.io.load",
    "hybridlog.report.document",
    "hybridlog.report.report_parts",
    "hybridlog.report.report_reader",
)
"""Modules of the job the estimators' worker never runs."""

READER = """
import importlib, json, sys
import hybridlog.cli
for module in json.loads(sys.argv[2]):
    importlib.import_module(module)
from hybridlog.background import _read_message
with open(sys.argv[1], "rb") as requests:
    while _read_message(requests)[0]:
        pass
print(json.dumps(sorted(m for m in json.loads(sys.argv[3]) if m in sys.modules)))
"""


class _Recording:
    """An estimators' worker that records each request as sent, then runs it here."""

    alive = True

    def __init__(self) -> None:
        self.sent = io.BytesIO()

    def _record(self, kind: str, function: Callable[..., Any], args: tuple[Any, ...]) -> None:
        background._write_message(self.sent, (kind, function, args))

    def submit(self, function: Callable[..., Any], *args: Any) -> None:
        self._record("call", function, args)
        function(*args)

    def stream(self, function: Callable[..., Iterable[Any]], *args: Any) -> Iterator[Any]:
        self._record("stream", function, args)
        return iter(function(*args))

    def release(self) -> None:
        pass


def test_the_estimators_worker_imports_none_of_the_job(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    recording = _Recording()
    monkeypatch.setitem(background._WORKERS, background.ESTIMATES, recording)  # type: ignore[arg-type]
    analyze(TANK_CSV, "three_tank_hstf", estimator="imm", out_dir=tmp_path / "out")
    requests = tmp_path / "requests.bin"
    requests.write_bytes(recording.sent.getvalue())
    assert recording.sent.getvalue(), "nothing was sent to the worker"
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            READER,
            str(requests),
            json.dumps(SHARED_IMPORTS),
            json.dumps(NOT_IN_THE_WORKER),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout) == []
