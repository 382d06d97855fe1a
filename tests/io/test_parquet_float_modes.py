"""A Parquet float column of true modes reads each whole number as an integer id.

A float column holding modes 1, 2 and 2.5 read ``1.0`` as the label ``'1.0'`` (whole numbers
lost their ``.0`` only when every value was whole) and was refused: "truth.mode '1.0' is
not a mode of the model", though the same numbers in an MCAP file's ``Float64`` topic read
as ``1``, ``2``, ``2.5`` and docs/model_files.md says a log holding the mode as a number
reads ``1.0`` as ``1``.  Each whole number now loses its ``.0``, as in a message log.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2", "2.5"), dt=0.1)


def log(tmp_path: Path, modes: list[float]) -> Path:
    path = tmp_path / "log.parquet"
    t = [0.1 * k for k in range(len(modes))]
    pl.DataFrame({"t": t, "u": t, "y": t, "mode": modes}).write_parquet(path)
    return path


def test_whole_floats_beside_a_fraction_are_integer_ids(tmp_path: Path) -> None:
    signals = load_signals(log(tmp_path, [1.0, 2.0, 2.5, 1.0]), SPEC)
    assert signals.truth_modes is not None
    np.testing.assert_array_equal(signals.truth_modes, [0, 1, 2, 0])


def test_a_float_that_names_no_mode_is_still_refused(tmp_path: Path) -> None:
    with pytest.raises(LogError, match=r"row 3, column 'mode': truth.mode '1.5' at t=0.2 s"):
        load_signals(log(tmp_path, [1.0, 2.0, 1.5]), SPEC, ReadOptions())
