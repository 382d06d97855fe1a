"""``cluster --compare-kmeans`` where k-means cannot run: said in one line, chiu's result written.

On a log whose regression vectors φ(k) are all one point chiu finds its one centre, but
k-means wants as many distinct points as clusters: its error stopped the whole command, and
the centres file chiu had fitted was never written.
"""

import csv
import json
from pathlib import Path

from hybridlog.jobs.cluster import discover_modes
from tests.support.paths import SAMPLE_LOGS


def _still_log(path: Path) -> Path:
    """The double cart's log with its input and output held at 1 (true modes kept)."""
    with (SAMPLE_LOGS / "double_cart_case1.csv").open(encoding="utf-8", newline="") as file:
        rows = list(csv.DictReader(file))
    with path.open("w", encoding="utf-8", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows({**row, "u": "1.0", "y": "1.0"} for row in rows[:200])
    return path


def test_kmeans_that_cannot_run_leaves_chius_result_written(tmp_path: Path) -> None:
    log = _still_log(tmp_path / "still.csv")
    out = tmp_path / "c.json"
    outcome = discover_modes(log, "double_cart_case1", out=out, compare_kmeans=True)
    assert outcome.kmeans is None and len(outcome.chiu.centers) == 1
    said = [note for note in outcome.notes if note.startswith("kmeans")]
    assert said == [
        "kmeans: not compared, k-means could not run: clusters: the data have fewer than "
        "2 distinct points (1 among 199)"
    ]
    content = json.loads(out.read_text(encoding="utf-8"))
    assert "kmeans" not in content and len(content["chiu"]["centers"]) == 1
    assert outcome.plot_path is not None and outcome.plot_path.stat().st_size > 0
