"""A column read as the true mode by its name says so when it holds no mode of the model.

A log's ``mode`` column is the true mode by default (SPEC §5); one that means something else
(a controller's ``AUTO``/``MANUAL``) was refused as "not a mode of the model" with no word
on why it was read at all, nor how to have it read otherwise.
"""

from __future__ import annotations

from pathlib import Path

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
