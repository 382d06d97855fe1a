"""``hybridlog cluster``'s table: centres that differ print differently."""

import polars as pl

from hybridlog.jobs.cluster import discover_modes
from tests.support.paths import SAMPLE_LOGS


def test_centres_far_from_zero_print_apart_in_the_table(tmp_path):
    """A log's outputs offset by 1e12 printed three centres ``1e+12, 1e+12, …``: alike in
    every output though different; now with the digits that tell each column's apart."""
    frame = pl.read_csv(SAMPLE_LOGS / "double_cart_case1.csv").head(300)
    log = tmp_path / "far.csv"
    frame.with_columns(pl.col("y") + 1e12).write_csv(log)
    outcome = discover_modes(log, "double_cart_case1", out=tmp_path / "c.json")
    rows = [line for line in outcome.table.splitlines() if line.startswith("| chiu |")]
    outputs = [row.split(" | ")[-1].rsplit(", ", 1)[0] for row in rows]
    assert len(rows) > 1 and len(set(outputs)) == len(rows), rows
    assert "1e+12" not in outcome.table
