"""A Parquet decimal column of true modes reads a whole ``1.0`` as mode ``1``.

A decimal column holds numbers, as a float column does, whose ``1.0`` is mode ``1`` (README,
"Table time columns"); the decimal's text ``'1.0'`` was compared with the model's ids and
the log refused: "truth.mode '1.0' at t=0 s is not a mode of the model".
"""

from __future__ import annotations

from decimal import Decimal
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import SignalSpec, load_signals
from hybridlog.io.table_labels import label_codes

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=1.0)


def _log(path: Path, modes: list[str], dtype: pl.Decimal) -> Path:
    n = len(modes)
    values = np.arange(n, dtype=float)
    mode = pl.Series("mode", [Decimal(m) for m in modes], dtype=dtype)
    pl.DataFrame({"t": values, "u": values, "y": values, "mode": mode}).write_parquet(path)
    return path


def test_whole_decimal_modes_are_the_models_ids(tmp_path: Path) -> None:
    log = _log(tmp_path / "modes.parquet", ["1.0", "1.0", "2.0", "2.0", "1.0"], pl.Decimal(5, 1))
    aligned = load_signals(log, SPEC)
    assert aligned.truth_modes is not None
    assert aligned.truth_modes.tolist() == [0, 0, 1, 1, 0]


def test_a_decimal_that_is_not_whole_is_no_mode(tmp_path: Path) -> None:
    log = _log(tmp_path / "modes.parquet", ["1.00", "1.50", "2.00"], pl.Decimal(5, 2))
    with pytest.raises(LogError, match=r"row 2, column 'mode': truth.mode '1.50' at t=1 s"):
        load_signals(log, SPEC)


def test_a_decimal_keeps_every_digit() -> None:
    big = pl.Series(
        [Decimal("12345678901234567890.000"), Decimal("-3.00")], dtype=pl.Decimal(30, 3)
    )
    assert label_codes(big)[1] == ("12345678901234567890", "-3")
