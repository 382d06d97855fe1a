"""A model's ``[signals]``/``[truth]`` field the log has but cannot use is not replaced.

A model naming ``y = "name"`` (a Parquet text column) or ``y = "t"`` (the time column) was
read from the column ``y`` instead, without a word: the report described a signal the model
did not name.  ``[truth] x1 = "xs"`` (text) likewise scored the states against the column
``x1``.  Now an input or output is refused naming the field and the cause, and a truth
symbol has no truth (recorded under ``truth_unusable``); a path the log lacks still falls
back to the default field, as documented.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals


def log(tmp_path: Path) -> Path:
    path = tmp_path / "log.parquet"
    pl.DataFrame(
        {
            "t": [0.0, 0.1, 0.2],
            "u": [1.0, 2.0, 3.0],
            "y": [5.0, 6.0, 7.0],
            "name": ["a", "b", "c"],
            "level": [9.0, 8.0, 7.0],
            "x1": [1.0, 1.0, 1.0],
            "xs": ["a", "b", "c"],
        }
    ).write_parquet(path)
    return path


def spec(**tables: Any) -> SignalSpec:
    return SignalSpec(
        inputs=("u",), outputs=("y",), mode_ids=("1",), dt=0.1, states=("x1",), **tables
    )


@pytest.mark.parametrize(
    ("path", "cause"),
    [
        ("name", "column 'name' has type String, expected a number"),
        ("t", "'t' is the table's time column"),
    ],
)
def test_an_unusable_signals_field_is_refused(tmp_path: Path, path: str, cause: str) -> None:
    with pytest.raises(LogError) as info:
        load_signals(log(tmp_path), spec(signals={"y": path}))
    assert str(info.value).startswith(
        f"{tmp_path / 'log.parquet'}: output 'y' (column {path!r}, from the model's [signals]; "
        f"use --map y=... for another): {cause}"
    )


def test_signals_fields_the_log_has_or_lacks_are_read_as_documented(tmp_path: Path) -> None:
    read = load_signals(log(tmp_path), spec(signals={"y": "level"}))
    np.testing.assert_array_equal(read.outputs[:, 0], [9.0, 8.0, 7.0])
    fallback = load_signals(log(tmp_path), spec(signals={"y": "no_level"}))
    np.testing.assert_array_equal(fallback.outputs[:, 0], [5.0, 6.0, 7.0])


def test_an_unusable_truth_field_is_no_truth(tmp_path: Path) -> None:
    notes: dict[str, Any] = {}
    read = load_signals(log(tmp_path), spec(truth={"x1": "xs"}), ReadOptions(), notes=notes)
    assert read.truth_states is None
    assert notes["truth_unusable"] == [
        "truth.x1 (column 'xs', the model's [truth]: column 'xs' has type String, "
        "expected a number)"
    ]
