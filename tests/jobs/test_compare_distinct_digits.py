"""compare's table: different values of a column never read alike, however close."""

from __future__ import annotations

import math

from hybridlog.report.summary_tables import markdown_table


def test_values_that_differ_past_eight_digits_still_read_apart() -> None:
    """Two estimators' VAFs of 99.9999999912 and 99.9999999934 (a log with little noise)
    both read ``100.000000`` in comparison.md: the digits grew by at most 4, then the column
    showed two different values alike, and neither as it was."""
    vaf = [99.9999999912, 99.9999999934]
    mse = [1.0000000001e-3, 1.0000000002e-3]
    table = markdown_table(
        ("vaf", "mse"), [list(row) for row in zip(vaf, mse, strict=True)], distinct=True
    )
    assert table.splitlines()[2:] == [
        "| 99.999999991 | 0.0010000000001 |",
        "| 99.999999993 | 0.0010000000002 |",
    ]
    # neighbouring float64 values, in either notation, beside a zero and a distant value
    for x in (0.945054945054945, 1.0e-9, 123456.75, -3.5e-200):
        column = [x, math.nextafter(x, math.inf), 0.0, x * 1e7]
        cells = markdown_table(("y",), [[v] for v in column], distinct=True).splitlines()[2:]
        assert len(set(cells)) == len(column), cells
    # the digits grow only as far as needed
    assert markdown_table(("y",), [[0.5], [0.25]], distinct=True).splitlines()[2:] == [
        "| 0.5000 |",
        "| 0.2500 |",
    ]
