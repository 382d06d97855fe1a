"""``simulate`` writes only values a log hybridlog reads may hold: finite, below 2^480.

Found in the pass: a run growing to 1e300 was written without a word, and ``analyze`` then
refused the log it had just written ("1.01e+145 for output 'y' ... is out of range").
simulate checked its values for NaN and infinity only, while the readers refuse a magnitude
of 2^480 (:data:`hybridlog.signals.MAX_MAGNITUDE`) and up: every value simulate writes is
now held to the readers' bound, states, outputs, inputs and a components model's values
alike, and a run beyond it is refused as diverged, naming the column and time.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hybridlog.errors import ModelError
from hybridlog.io.load import ReadOptions, SignalSpec, load_signals
from hybridlog.model.builtins import builtin_text
from hybridlog.model.loader import load_model, parse_model
from hybridlog.simulate import simulate
from hybridlog.simulate_components import simulate_components
from tests.support.cli import run_main

GROWING = """
name = "growing"
time = "discrete"
dt = 1.0
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[modes.a]
f = ["10*x + u"]
h = ["x"]

[noise]
process = 0.0
measurement = 0.0

[initial]
state = [1.0]
covariance = 1.0

[simulation]
schedule = "a:10"

[simulation.inputs]
u = "U"
"""


def _model(tmp_path: Path, u: str = "0") -> Path:
    path = tmp_path / "growing.toml"
    path.write_text(GROWING.replace('"U"', f'"{u}"'), encoding="utf-8")
    return path


@pytest.mark.parametrize("name", ["run.csv", "run.parquet", "run.mcap"])
def test_a_run_up_to_the_bound_is_written_and_read_back_identical(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = _model(tmp_path)
    log = tmp_path / name
    code, output = run_main(["simulate", str(model), "--out", str(log), "--steps", "144"], capsys)
    assert code == 0, output
    read = load_signals(log, SignalSpec.of(load_model(model)), ReadOptions())
    expected = simulate(load_model(model), steps=144)
    assert read.outputs[-1, 0] == expected.outputs[-1, 0] > 1e143
    np.testing.assert_array_equal(read.outputs, expected.outputs)
    np.testing.assert_array_equal(read.truth_states, expected.states)


def test_a_run_beyond_the_bound_is_refused_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = _model(tmp_path)
    log = tmp_path / "run.csv"
    code, output = run_main(["simulate", str(model), "--out", str(log), "--steps", "300"], capsys)
    assert code == 2, output
    assert output == (
        f"hybridlog: error: {model}: the simulation diverged: x = 1e+145 at t = 145 s is out "
        "of range (|value| >= 2^480 = 3.12e+144, more than a log hybridlog reads may hold); "
        "nothing was written\n"
    )
    assert not log.exists()


def test_an_input_beyond_the_bound_names_its_key(tmp_path: Path) -> None:
    with pytest.raises(ModelError) as error:
        simulate(load_model(_model(tmp_path, "1e200*k")), steps=3)
    assert str(error.value) == (
        f"{tmp_path / 'growing.toml'}: simulation.inputs.u: 1e+200 at t = 1 s (k = 1); the "
        "input must be a finite number below 2^480 = 3.12e+144 in magnitude at every step"
    )


@pytest.mark.parametrize(
    ("old", "new", "key", "where"),
    [
        ("[simulation]", "[simulation]\nstate = [1e200]", "simulation.state[0]", ""),
        (
            "state = [1.0]",
            "state = [-1e150]",
            "initial.state[0]",
            " (the file gives no simulation.state)",
        ),
    ],
)
def test_a_start_beyond_the_bound_names_its_key(
    old: str, new: str, key: str, where: str, tmp_path: Path
) -> None:
    # was "the simulation diverged: x = 1e+200 at t = 0 s", naming no key
    path = _model(tmp_path)
    path.write_text(path.read_text(encoding="utf-8").replace(old, new), encoding="utf-8")
    start = new.rsplit("[", 1)[1].rstrip("]")
    with pytest.raises(ModelError) as error:
        simulate(load_model(path), steps=3)
    assert str(error.value) == (
        f"{path}: {key}: the run would start with x = {float(start):g}{where}, more than a log "
        "hybridlog reads may hold (|value| >= 2^480 = 3.12e+144); start it within that"
    )


def test_a_components_start_beyond_the_bound_names_its_key() -> None:
    text = builtin_text("bioplex_pgc")
    start = "state = [0.49, 0.49, 1200.0]"
    assert text.count(start) == 2  # [initial] and [simulation]
    at = text.index("[simulation]")
    edited = text[:at] + text[at:].replace(start, "state = [0.49, 0.49, 1e300]", 1)
    with pytest.raises(ModelError, match=r"^b\.toml: simulation\.state\[2\]: the run would start "):
        simulate_components(parse_model(edited, origin="b.toml"), steps=3)


def test_a_components_run_beyond_the_bound_names_the_value(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "bioplex.csv"
    settings = ["--set", "u_max=1e200", "--set", "u_nominal=1e160"]
    code, output = run_main(
        ["simulate", "bioplex_pgc", "--out", str(log), "--steps", "5", *settings], capsys
    )
    assert code == 2, output
    assert "bioplex_pgc: the simulation diverged: uc1 = 1e+160 at t = 0 s is out of range" in output
    assert not log.exists()


GUARDED = """
name = "guarded"
time = "discrete"
dt = 1.0
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[modes.low]
guard = "x <= 5"
f = ["F"]
h = ["x"]

[modes.high]
guard = "x > 5"
f = ["F"]
h = ["x"]

[noise]
process = 0.0
measurement = 0.0

[initial]
state = [1.0]
covariance = 1.0

[simulation.inputs]
u = "0"
"""


@pytest.mark.parametrize(
    ("f", "high", "message"),
    [
        # a NaN state holds no guard: it was reported as "no mode's guard holds (x = [nan])",
        # then as "the simulation diverged: x = nan at t = 1 s", naming no key
        (
            "sqrt(x - 2)",
            "x > 5",
            r"modes\.low\.f\[0\]: 'sqrt\(x - 2\)' is nan at x = 1, u = 0, the step from t = 0 s "
            r"to 1 s \(the state left the domain of f there\)",
        ),
        ("x*1e100", "x > 5", r"the simulation diverged: x = 1e\+200 at t = 2 s is out of range"),
        # the state was a Python list of 17 digits, the inputs the guards read unnamed:
        # "(x = [10.999999999999998])"
        (
            "x + 10",
            "x > 20",
            r"no mode's guard \(modes.<id>.guard\) holds at t = 1 s \(x = 11, u = 0\)$",
        ),
    ],
)
def test_a_state_driven_run_that_diverges_says_so(
    f: str, high: str, message: str, tmp_path: Path
) -> None:
    path = tmp_path / "guarded.toml"
    path.write_text(GUARDED.replace('"F"', f'"{f}"').replace('"x > 5"', f'"{high}"'))
    with pytest.raises(ModelError, match=rf"^{path}: {message}"):
        simulate(load_model(path), steps=10)
