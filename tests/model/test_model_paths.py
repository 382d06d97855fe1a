"""A model file's ``[signals]`` and ``[truth]``: every key is one the log mapping reads."""

import numpy as np
import pytest

from hybridlog.errors import ModelError
from hybridlog.io import SignalSpec, load_signals, write_table
from hybridlog.model.loader import parse_model
from hybridlog.simulate import simulate
from tests.support.models import LINEAR_TWO_MODE

# LINEAR_TWO_MODE: states p, v; input a; outputs y1, y2; modes slow, fast.


def _with(table: str) -> str:
    return LINEAR_TWO_MODE + "\n" + table + "\n"


@pytest.mark.parametrize(
    ("table", "message"),
    [
        (
            '[signals]\np = "/state.p"',
            r"signals\.p: a state; true states map under \[truth\] \(truth\.p = \.\.\.\)$",
        ),
        ('[signals]\nmode = "/m"', r"signals\.mode: the true mode maps under \[truth\]$"),
        (
            '[truth]\na = "/cmd.data"',
            r"truth\.a: an input; inputs and outputs map under \[signals\]$",
        ),
        (
            '[truth]\ny2 = "/y.data"',
            r"truth\.y2: an output; inputs and outputs map under \[signals\]$",
        ),
        (
            '[truth]\nq = "/truth/q.data"',
            r"truth\.q: not a true mode or state of the model \(allowed: mode, p, v\)$",
        ),
        (
            '[truth]\nmode.slow = "/m"',
            r"truth\.'mode\.slow': not a true mode or state of the model",
        ),
        (
            '[signals]\nY1 = "level"',
            r"signals\.Y1: not an input or output of the model \(allowed: a, y1, y2\)$",
        ),
        ('[signals]\ny1 = ""', r"signals\.y1: an empty path names no field of a log$"),
        ('[truth]\np = ""', r"truth\.p: an empty path names no field of a log$"),
        ("[signals]\ny1 = 3", r"signals\.y1: expected a string, got int$"),
        ("[truth]\nmode = true", r"truth\.mode: expected a string, got bool$"),
    ],
)
def test_a_key_the_log_mapping_would_skip_is_refused_naming_where_it_belongs(table, message):
    with pytest.raises(ModelError, match=r"^plant\.toml: " + message):
        parse_model(_with(table), origin="plant.toml")


def test_every_key_the_loader_accepts_is_read_from_the_log(tmp_path):
    # Each accepted key names a column no default would find: the log is read only if
    # every one of them is used, and the values are those of the renamed columns.
    model = parse_model(
        _with(
            '[signals]\na = "force N"\ny1 = "pos"\ny2 = "vel"\n'
            '[truth]\nmode = "phase"\np = "pos_true"\nv = "vel_true"'
        )
    )
    columns = simulate(model, steps=40, seed=1).columns(model)
    renamed = {"a": "force N", "y1": "pos", "y2": "vel", "mode": "phase", "p": "pos_true"}
    renamed["v"] = "vel_true"
    log = tmp_path / "run.csv"
    write_table(log, {renamed.get(name, name): values for name, values in columns.items()})
    signals = load_signals(log, SignalSpec.of(model))
    assert np.array_equal(signals.inputs[:, 0], columns["a"])
    assert np.array_equal(signals.outputs, np.column_stack([columns["y1"], columns["y2"]]))
    assert np.array_equal(signals.truth_states, np.column_stack([columns["p"], columns["v"]]))
    assert signals.truth_modes is not None
    assert [model.mode_ids[m] for m in signals.truth_modes] == list(columns["mode"])
