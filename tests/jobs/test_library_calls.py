"""``analyze`` called again and again in one process, as a notebook calls it (README's "From
Python"): it prints nothing, leaves the caller's process as it found it, and an interrupted
call leaves no output and the process usable."""

import json
import os
import re
import signal
import subprocess
import sys
import threading
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.jobs import analysis
from hybridlog.polars_import import SET_ON_IMPORT
from tests.support.paths import ROOT

LOG = ROOT / "sample_logs" / "three_tank_hstf.csv"


def _process_state() -> dict[str, Any]:
    return {
        "environment": {k: v for k, v in os.environ.items() if k not in SET_ON_IMPORT},
        "folder": os.getcwd(),
        "numpy errors": np.geterr(),
        "warnings": list(warnings.filters),
        "handlers": [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)],
        "recursion limit": sys.getrecursionlimit(),
        "threads": sorted(t.name for t in threading.enumerate()),
    }


def _descriptors() -> list[str]:
    """What the process's open file descriptors point to, but font files: matplotlib keeps
    each font open per drawing thread (a cache keyed by the thread's id, bounded at 64), and
    the drawing runs in a new thread each call, so their count varies with the ids the
    system reuses (it failed about one run in two on a busy machine)."""
    targets = []
    for fd in os.listdir("/proc/self/fd"):
        try:
            targets.append(os.readlink(f"/proc/self/fd/{fd}"))
        except OSError:  # the listing's own descriptor, closed by now
            continue
    fonts = (".ttf", ".otf", ".ttc", ".afm", ".pfb")
    # a pipe's or socket's number changes when one is closed and another opened
    return sorted(re.sub(r"\[\d+\]$", "", t) for t in targets if not t.endswith(fonts))


def _analyze(out: Path) -> analysis.Outcome:
    return analysis.analyze(LOG, "three_tank_hstf", estimator="imm", out_dir=out, smooth=True)


def test_calls_leave_the_process_as_they_found_it(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    first = _analyze(tmp_path / "first").report
    _analyze(tmp_path / "second")
    before = _process_state()
    descriptors = _descriptors()
    again = [_analyze(tmp_path / f"again{i}").report for i in range(1)]
    assert _process_state() == before
    assert _descriptors() == descriptors
    assert capfd.readouterr() == ("", "")
    assert {(r.mse, r.modes.accuracy) for r in again} == {(first.mse, first.modes.accuracy)}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["again0", "first", "second"]


def test_an_interrupted_call_leaves_no_output_and_the_next_call_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    original = analysis.estimates

    def interrupted(*args: Any, **kwargs: Any) -> Iterator[Any]:
        chunks = original(*args, **kwargs)
        yield next(chunks)  # the report has begun: its temporary folder exists
        raise KeyboardInterrupt

    monkeypatch.setattr(analysis, "estimates", interrupted)
    with pytest.raises(KeyboardInterrupt):
        _analyze(tmp_path / "interrupted")
    assert list(tmp_path.iterdir()) == []
    monkeypatch.undo()
    assert _analyze(tmp_path / "next").report.modes.accuracy is not None


_FIRST_IMPORT = """
import json, os, sys
before = dict(os.environ)
import hybridlog.polars_import
changed = sorted(k for k in {*before, *os.environ} if before.get(k) != os.environ.get(k))
print(json.dumps([changed, list(hybridlog.polars_import.SET_ON_IMPORT)]))
"""


def test_the_environment_a_first_call_changes_is_what_the_readme_names() -> None:
    """polars' first import sets ``_RJEM_MALLOC_CONF`` too (polars' own ``__init__``): the README
    named only ``POLARS_IGNORE_TIMEZONE_PARSE_ERROR``, and the check above, warm, missed it."""
    environment = {k: v for k, v in os.environ.items() if k not in SET_ON_IMPORT}
    printed = subprocess.run(
        [sys.executable, "-c", _FIRST_IMPORT],
        env=environment,
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    changed, named = json.loads(printed)
    assert changed == sorted(named)
    section = (ROOT / "README.md").read_text(encoding="utf-8").split("## From Python")[1]
    said = set(re.findall(r"`([A-Z_][A-Z0-9_]+)`", section.split("\n## ")[0]))
    assert set(changed) <= said


def test_the_callers_matplotlib_settings_change_no_plot(tmp_path: Path) -> None:
    """A notebook's ``rcParams`` (a dpi, a font size) drew the report's PNGs: outputs.png was
    1000x716 pixels, not the command's 1000x702.  They are kept, and draw nothing."""
    import matplotlib

    plain = _analyze(tmp_path / "plain").out_dir / "plots"
    with matplotlib.rc_context({"figure.dpi": 50, "font.size": 17, "lines.linewidth": 4}):
        styled = _analyze(tmp_path / "styled").out_dir / "plots"
        assert (matplotlib.rcParams["figure.dpi"], matplotlib.rcParams["font.size"]) == (50, 17)
    names = sorted(p.name for p in plain.iterdir())
    assert names == sorted(p.name for p in styled.iterdir())
    assert [(plain / n).read_bytes() == (styled / n).read_bytes() for n in names] == [True] * 3
