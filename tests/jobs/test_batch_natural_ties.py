"""The natural order of a batch's logs is one order, whatever the names and their order given.

``r1``, ``r01`` and ``r001`` are of equal value: they kept the order they were given in, so
the rows of summary.md, summary.csv and the JUnit file hung on the order of the arguments.
And ``str.isdigit`` took a superscript ``²`` for a digit, which ``int`` refuses: a log named
``run1²2.csv`` ended the batch as an unexpected ValueError before any log was read.
"""

from __future__ import annotations

import itertools
from pathlib import Path

from hybridlog.jobs.batch_logs import batch_logs, natural_key


def test_names_of_equal_value_are_ordered_by_their_text_whatever_the_order_given() -> None:
    names = ["r1", "r001", "r01", "r2", "r1a"]
    orders = {tuple(sorted(given, key=natural_key)) for given in itertools.permutations(names)}
    assert orders == {("r001", "r01", "r1", "r1a", "r2")}


def test_a_digit_that_is_no_decimal_digit_is_text(tmp_path: Path) -> None:
    for name in ("run1²2.csv", "run1①2.csv", "run3.csv", "run12.csv"):
        (tmp_path / name).write_text("t,u\n0,1\n", encoding="utf-8")

    found = [Path(p).name for p in batch_logs([tmp_path]).paths]

    assert found == ["run1²2.csv", "run1①2.csv", "run3.csv", "run12.csv"]


def test_logs_given_in_any_order_are_listed_alike(tmp_path: Path) -> None:
    logs = [tmp_path / f"{name}.csv" for name in ("r1", "r01", "r001")]
    for log in logs:
        log.write_text("t,u\n0,1\n", encoding="utf-8")

    listed = {tuple(batch_logs(list(given)).paths) for given in itertools.permutations(logs)}

    assert listed == {tuple(str(tmp_path / f"{n}.csv") for n in ("r001", "r01", "r1"))}
