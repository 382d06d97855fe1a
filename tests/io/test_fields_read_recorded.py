"""Which log field fed each model symbol, and who chose it, is recorded; one field never
feeds two inputs or outputs, nor is the ground truth of two symbols."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals

N = 12


def _log(tmp_path: Path) -> Path:
    log = tmp_path / "log.csv"
    rows = [f"{k / 10},{k},{2 * k},{3 * k},{4 * k},a,{5 * k},{6 * k}" for k in range(N)]
    log.write_text("t,u,y1,y2,level,phase,x1,h\n" + "\n".join(rows) + "\n")
    return log


SPEC = SignalSpec(
    inputs=("u",),
    outputs=("y1", "y2"),
    mode_ids=("a",),
    dt=0.1,
    states=("x1", "x2"),
    signals={"y2": "level"},
    truth={"mode": "phase"},
)


def test_every_symbol_names_its_field_and_who_chose_it(tmp_path: Path) -> None:
    notes: dict[str, Any] = {}
    load_signals(_log(tmp_path), SPEC, ReadOptions(maps=("truth.x2=h",)), notes=notes)
    assert notes["fields"] == {
        "u": {"field": "u", "from": "default"},
        "y1": {"field": "y1", "from": "default"},
        "y2": {"field": "level", "from": "[signals]"},
        "truth.mode": {"field": "phase", "from": "[truth]"},
        "truth.x1": {"field": "x1", "from": "default"},
        "truth.x2": {"field": "h", "from": "--map"},
    }
    assert list(notes)[:3] == ["format", "time", "fields"]


def test_truth_found_but_without_samples_is_not_listed(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    log.write_text("t,u,y1,y2,x1\n" + "".join(f"{k / 10},{k},{k},{k},\n" for k in range(N)))
    notes: dict[str, Any] = {}
    load_signals(log, SignalSpec(inputs=("u",), outputs=("y1", "y2"), mode_ids=("a",), dt=0.1,
                                 states=("x1",)), notes=notes)  # fmt: skip
    assert "truth.x1" not in notes["fields"]
    assert "truth_shared" not in notes
    assert notes["truth_without_samples"] == ["truth.x1 (column 'x1')"]


@pytest.mark.parametrize(
    ("maps", "message"),
    [
        (
            ("u=y1",),
            "input 'u' (from --map u=y1) and output 'y1' (the default) read the same column 'y1'",
        ),
        (
            ("y1=level",),
            "output 'y1' (from --map y1=level) and output 'y2' (from the model's [signals]) "
            "read the same column 'level'",
        ),
    ],
)
def test_one_field_feeding_two_inputs_or_outputs_is_refused(
    tmp_path: Path, maps: tuple[str, ...], message: str
) -> None:
    log = _log(tmp_path)
    with pytest.raises(LogError) as error:
        load_signals(log, SPEC, ReadOptions(maps=maps))
    assert str(error.value) == (
        f"{log}: {message}: one column feeds one input or output (an input equal to an "
        "output, or one measurement counted twice, is a mapping slip); map one of them to "
        "another column with --map"
    )


def test_ground_truth_may_share_an_outputs_field(tmp_path: Path) -> None:
    # a state measured directly: its truth is the output's column, which the reading says
    notes: dict[str, Any] = {}
    signals = load_signals(_log(tmp_path), SPEC, ReadOptions(maps=("truth.x2=y1",)), notes=notes)
    assert notes["fields"]["truth.x2"] == {"field": "y1", "from": "--map"}
    assert notes["truth_shared"] == ["truth.x2 (column 'y1', also output 'y1')"]
    assert signals.truth_states is not None
    np.testing.assert_array_equal(signals.truth_states[:, 1], signals.outputs[:, 0])


@pytest.mark.parametrize(
    ("spec", "maps", "message"),
    [
        (
            SPEC,
            ("truth.x2=x1",),
            "truth.x1 (the default) and truth.x2 (from --map truth.x2=x1) read the same column "
            "'x1'",
        ),
        (
            replace(SPEC, truth={"mode": "phase", "x1": "h", "x2": "h"}),
            (),
            "truth.x1 (from the model's [truth]) and truth.x2 (from the model's [truth]) read "
            "the same column 'h'",
        ),
        (
            SPEC,
            ("truth.x1=phase",),
            "truth.mode (from the model's [truth]) and truth.x1 (from --map truth.x1=phase) "
            "read the same column 'phase'",
        ),
    ],
)
def test_one_field_as_the_ground_truth_of_two_symbols_is_refused(
    tmp_path: Path, spec: SignalSpec, maps: tuple[str, ...], message: str
) -> None:
    # the estimates of two states were scored against one column, with no word of it
    log = _log(tmp_path)
    with pytest.raises(LogError) as error:
        load_signals(log, spec, ReadOptions(maps=maps))
    assert str(error.value) == (
        f"{log}: {message}: one column is the ground truth of one symbol (two states, or a "
        "state and the true mode, are not one measurement: a slip of --map or [truth]); map "
        "one of them to another column with --map"
    )


def test_two_spellings_of_one_message_field_are_one_field() -> None:
    # '/y1/data' and '/y1.data' (and the path with spaces around it) read one field of a bag
    log = Path(__file__).parents[2] / "sample_logs" / "three_tank_hstf.bag"
    spec = SignalSpec(inputs=("u",), outputs=("y1",), mode_ids=("1",), dt=1.0)
    for mapped in ("/y1/data", " /y1.data"):
        with pytest.raises(LogError) as error:
            load_signals(log, spec, ReadOptions(maps=(f"u={mapped}",)))
        assert str(error.value).startswith(
            f"{log}: input 'u' (from --map u={mapped}) and output 'y1' (the default) read the "
            f"same field ({mapped!r} and '/y1.data' name one field): "
        )
