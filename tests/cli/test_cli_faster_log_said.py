"""A log sampled twice as fast as the model's grid says on the terminal that half is unused.

Sampled every dt/2, the tank log's inputs and outputs lost every other sample (each grid
point takes one, SPEC §5) with a NOTE in report.md only: ``analyze`` and ``compare`` printed
nothing about it.  Both now print the note on stderr, one line (not with ``--quiet``).
"""

from pathlib import Path

import polars as pl

from tests.cli.test_cli import run
from tests.support.paths import SAMPLE_LOGS

SAID = (
    "hybridlog: note: input u, output y1, output y2, output y3 each have 121 samples over the "
    "61 sample times analysed (1.98 a sample time): each sample time takes one (the last at or "
    "before it or the nearest, SPEC §5), so at least 60 of each are not used; is the model's "
    "dt the log's?\n"
)


def half_step_log(tmp_path: Path) -> Path:
    """The tank log with a copy of each row half a step later: sampled every dt/2."""
    frame = pl.read_csv(SAMPLE_LOGS / "three_tank_hstf.csv")
    later = frame.with_columns(pl.col("t") + 0.5)
    path = tmp_path / "half.csv"
    pl.concat([frame, later]).sort("t", maintain_order=True).head(121).write_csv(path)
    return path


def test_analyze_and_compare_say_the_samples_a_fast_log_leaves_unused(tmp_path: Path) -> None:
    log = half_step_log(tmp_path)
    args = [str(log), "--model", "three_tank_hstf"]
    analyzed = run(["analyze", *args, "--estimator", "imm", "--out", str(tmp_path / "a")])
    assert analyzed.stderr == SAID
    assert SAID.removeprefix("hybridlog: note: ")[:-1] in (tmp_path / "a" / "report.md").read_text()
    compared = run(["compare", *args, "--estimators", "imm,hstf", "--out", str(tmp_path / "c")])
    assert compared.stderr.count(SAID) == 1
    quiet = run(["-q", "analyze", *args, "--estimator", "imm", "--out", str(tmp_path / "q")])
    assert quiet.stderr == ""
