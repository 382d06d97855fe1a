"""A batch with ``--smooth`` (issue 12): the flag is a setting that a resumed batch compares."""

from __future__ import annotations

import json
from pathlib import Path

from hybridlog.jobs.batch import run_batch
from tests.jobs.test_batch_resume import TANK, statuses, write_logs


def test_changing_smooth_redoes_the_logs_and_the_same_flag_skips_them(tmp_path: Path) -> None:
    logs = write_logs(tmp_path / "logs", ["s1.csv", "s2.csv"])
    out = tmp_path / "out"

    def again(**options: object) -> dict[str, str]:
        return statuses(run_batch(logs, TANK, out_dir=out, estimator="imm", **options))

    assert set(again().values()) == {"done"}
    assert set(again(smooth=True).values()) == {"done"}
    report = json.loads((out / "s1.csv" / "report.json").read_text())
    assert report["smoothing"]["method"] and report["options"]["smooth"] is True
    assert report["batch"]["settings"]["options"]["smooth"] is True
    assert set(again(smooth=True).values()) == {"skipped"}
    summary = (out / "summary.md").read_text().splitlines()[0]
    assert summary == f"# Batch: {TANK} · imm · {report['smoothing']['method']}, argmax"
    # --set smooth=true is the same run as --smooth
    assert set(again(sets=["smooth=true"]).values()) == {"skipped"}
    assert set(again(smooth=True, mode_sequence="viterbi").values()) == {"done"}
    assert set(again(smooth=True, mode_sequence="viterbi").values()) == {"skipped"}
    assert set(again().values()) == {"done"}
    assert "smoothing" not in json.loads((out / "s1.csv" / "report.json").read_text())
    assert (out / "summary.md").read_text().startswith(f"# Batch: {TANK} · imm\n")
