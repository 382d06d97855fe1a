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


def test_a_signed_zero_or_nans_give_no_column_17_digits():
    """A column holding ``0.0`` and ``-0.0`` (one value, printed ``0`` and ``-0``), or two
    ``nan`` (a set of floats counts each apart), never matched its count of distinct values
    and printed every centre of it to 17 digits (``0.33333333333333331``)."""
    import numpy as np

    from hybridlog.jobs.cluster import _centre_texts

    third = 1 / 3
    assert _centre_texts(np.array([[0.0], [-0.0], [third]])) == [["0"], ["-0"], ["0.3333"]]
    assert _centre_texts(np.array([[np.nan], [np.nan], [third]])) == [["nan"], ["nan"], ["0.3333"]]
    # values told apart still are, to the last bit, beside a signed zero
    one_ulp = np.nextafter(1.0, 2.0)
    assert _centre_texts(np.array([[1.0], [one_ulp], [-0.0], [0.0]])) == [
        ["1"],
        ["1.0000000000000002"],
        ["-0"],
        ["0"],
    ]
