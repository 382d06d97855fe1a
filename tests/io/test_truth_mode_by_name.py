"""A column read as the true mode by its name says so when it holds no mode of the model.

A log's ``mode`` column is the true mode by default (SPEC §5); one that means something else
(a controller's ``AUTO``/``MANUAL``) was refused as "not a mode of the model" with no word
on why it was read at all, nor how to have it read otherwise.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1", "2"), dt=1.0)
REMEDY = "rename it in the log, or name the true modes' field with --map truth.mode=FIELD"


def _log(path: Path) -> Path:
    rows = [f"{k},0,{k},{'AUTO' if k % 2 else 'MANUAL'},1" for k in range(4)]
    path.write_text("t,u,y,mode,q\n" + "\n".join(rows) + "\n")
    return path


def test_a_column_read_by_its_name_names_the_remedy(tmp_path: Path) -> None:
    log = _log(tmp_path / "run.csv")
    with pytest.raises(LogError, match=r"read as truth\.mode by its name") as refused:
        load_signals(log, SPEC)
    assert str(refused.value).endswith(REMEDY)
    assert "\n" not in str(refused.value)
    # the user's own --map gets the refusal alone: they named that field as the true mode
    with pytest.raises(LogError) as mapped:
        load_signals(log, SPEC, ReadOptions(maps=("truth.mode=mode",)))
    assert str(mapped.value).endswith("(mode ids: 1, 2; compared as text)")
    # another field named as the true mode: the column 'mode' is not read as it
    aligned = load_signals(log, SPEC, ReadOptions(maps=("truth.mode=q",)))
    assert aligned.truth_modes is not None and aligned.truth_modes.tolist() == [0, 0, 0, 0]


def test_a_list_column_by_a_truth_name_is_noted_not_taken_for_no_column(tmp_path: Path) -> None:
    """A Parquet list column ``mode`` (or ``x``) is fields ``mode[0]``, ...: no field ``mode``.

    Read as absent, the report said "No ground-truth mode in the log" of a log that has one,
    in a form that cannot be read as it is; it now says why it was not used.
    """
    log = tmp_path / "run.parquet"
    pl.DataFrame(
        {
            "t": [0.0, 1.0, 2.0],
            "u": [0.0, 0.0, 0.0],
            "y": [1.0, 2.0, 3.0],
            "mode": [[1], [2], [1]],
            "x": [[1.0], [2.0], [3.0]],
        }
    ).write_parquet(log)
    spec = SignalSpec(inputs=("u",), outputs=("y",), states=("x",), mode_ids=("1", "2"), dt=1.0)
    notes: dict[str, Any] = {}
    aligned = load_signals(log, spec, notes=notes)
    assert aligned.truth_modes is None and aligned.truth_states is None
    assert notes["truth_unusable"] == [
        "truth.mode (column 'mode': 'mode' is a list of int64; add an index, e.g. mode[0])",
        "truth.x (column 'x': 'x' is a list of float64; add an index, e.g. x[0])",
    ]
    # an element named with --map is read
    mapped = load_signals(log, spec, ReadOptions(maps=("truth.mode=mode[0]",)))
    assert mapped.truth_modes is not None and mapped.truth_modes.tolist() == [0, 1, 0]
