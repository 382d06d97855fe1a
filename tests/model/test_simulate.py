"""``simulate`` refuses bad input up front, naming the option or the model file and key."""

from pathlib import Path

import numpy as np
import pytest

from hybridlog.cli import main
from hybridlog.errors import ModelError, OptionError
from hybridlog.estimators.hstf import HstfOptions, run_hstf
from hybridlog.estimators.imm import ImmOptions, run_imm
from hybridlog.model.loader import load_model, parse_model
from hybridlog.signals import AlignedSignals
from hybridlog.simulate import simulate
from hybridlog.simulation_limits import memory_needed
from tests.support.models import PENDULUM_ONE_MODE
from tests.support.paths import ROOT

TANK = (ROOT / "hybridlog/model/builtin/three_tank_hstf.toml").read_text()


def _model_file(tmp_path, text, old=None, new=None):
    if old is not None:
        assert old in text
        text = text.replace(old, new, 1)
    path = tmp_path / "plant.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("seed", [-1, 1.5, True, "3"])
def test_a_bad_seed_is_an_option_error(seed):
    with pytest.raises(OptionError, match=r"^--seed: must be a non-negative integer$"):
        simulate(load_model("three_tank_hstf"), steps=3, seed=seed)


@pytest.mark.parametrize("steps", [0, -1, 2.5, True, "5", np.float64(3.0)])
def test_bad_steps_are_an_option_error(steps, tmp_path):
    # steps=2.5 failed as numpy's TypeError inside the run, steps=True ran one step, as
    # `seed` is checked; a components model's run alike
    from hybridlog.simulate_components import simulate_components

    with pytest.raises(OptionError, match=r"^--steps: must be a positive integer$"):
        simulate(load_model("three_tank_hstf"), steps=steps)
    with pytest.raises(OptionError, match=r"^--steps: must be a positive integer$"):
        simulate_components(load_model("bioplex_pgc"), steps=steps)
    assert simulate(load_model("three_tank_hstf"), steps=np.int64(3)).time.shape == (4,)


def test_more_steps_than_memory_are_refused_up_front_with_the_size(tmp_path):
    model = load_model("three_tank_hstf")
    # 15 values a row (t, mode, u, 3 outputs, 3 states, 6 noise draws), 8 messages
    assert memory_needed(model, 1000, "bag") == 1000 * (15 * 8 * 3 + 8 * 128)
    # 10^9 steps of 1 s: a time a log holds (< 9.2e9 s), about 1 TB
    with pytest.raises(OptionError, match=r"^--steps: 1,000,000,000 steps would need about"):
        simulate(model, steps=10**9)
    with pytest.raises(OptionError, match=r"^--schedule: .* GB of memory and .* is available"):
        simulate(model, schedule=f"1:{10**9}")
    path = _model_file(tmp_path, TANK, 'schedule = "', f'schedule = "2:{10**9},')
    with pytest.raises(ModelError, match=rf"^{path}: simulation\.schedule: .* steps would need"):
        simulate(load_model(path))


def test_only_a_writer_that_holds_its_messages_counts_them_in_the_memory_check(monkeypatch):
    # A CSV run of 2·10^7 three-tank steps (5 GB at its peak) was refused as needing 27.7 GB:
    # each of its 8 columns was counted 128 bytes a row, the index entry a ROS 1 bag's writer
    # keeps per message, which neither a table nor an MCAP file or ROS 2 bag holds.
    model = load_model("three_tank_hstf")
    values = 15 * 8 * 3
    assert memory_needed(model, 1000) == 1000 * values  # no log written
    for log_format in ("csv", "parquet", "mcap", "ros2-sqlite3", "ros2-mcap"):
        assert memory_needed(model, 1000, log_format) == 1000 * values
    monkeypatch.setattr("hybridlog.memory.available_memory", lambda: 1000 * values * 2)
    assert simulate(model, steps=999, log_format="csv").time.shape == (1000,)
    with pytest.raises(OptionError, match=r"^--steps: 999 steps would need about"):
        simulate(model, steps=999, log_format="bag")


def test_a_run_ending_later_than_a_log_holds_is_refused_up_front(tmp_path, monkeypatch):
    # 10^4 steps of 10^6 s end at 10^10 s, beyond the int64 nanoseconds of every log: the
    # MCAP and bag writers failed after simulating ("unexpected error ... argument out of
    # range") and the CSV was written, for hybridlog to refuse reading it.
    def never(*args, **kwargs):
        raise AssertionError("simulated a run no log holds")

    monkeypatch.setattr("hybridlog.simulation_kernels.simulate_steps", never)
    path = _model_file(tmp_path, TANK, "dt = 1.0", "dt = 1e6")
    model = load_model(path)
    with pytest.raises(OptionError) as error:
        simulate(model, steps=10_000)
    assert str(error.value) == (
        "--steps: 10,000 steps of 1e+06 s end at t = 10000000000 s, later than the log holds "
        "(times before 9200000000 s); simulate fewer steps"
    )
    with pytest.raises(OptionError, match=r"^--schedule: 10,000 steps of 1e\+06 s end at"):
        simulate(model, schedule="1:10000")
    path = _model_file(tmp_path, TANK, "dt = 1.0", "dt = 1e6")
    path.write_text(path.read_text().replace('schedule = "1:100,', 'schedule = "1:9800,'))
    with pytest.raises(ModelError, match=rf"^{path}: simulation\.schedule: 10,000 steps of"):
        simulate(load_model(path))


def test_a_run_past_a_float_is_refused_as_ending_too_late(tmp_path):
    # --steps of 400 digits: `steps * dt` converted the steps to a float, an unexpected
    # OverflowError; a model's schedule of such a count and a components model's too
    from hybridlog.jobs.simulate import simulate_log

    steps = 10**400 - 1
    with pytest.raises(OptionError) as error:
        simulate(load_model("three_tank_hstf"), steps=steps)
    assert str(error.value) == (
        "--steps: 1.000e+400 steps of 1 s end later than the log holds "
        "(times before 9200000000 s); simulate fewer steps"
    )
    with pytest.raises(OptionError, match=r"^--schedule: 1\.000e\+400 steps of 1 s end later"):
        simulate(load_model("three_tank_hstf"), schedule=f"1:{steps}")
    with pytest.raises(OptionError, match=r"^--steps: 1\.000e\+400 steps of 60 s end later"):
        simulate_log("bioplex_pgc", tmp_path / "run.csv", steps=steps)
    assert list(tmp_path.iterdir()) == []


def test_a_run_ending_later_than_a_ros1_bag_holds_is_refused_before_simulating(
    tmp_path, monkeypatch
):
    # A ROS 1 bag's seconds are 32-bit: 5000 steps of 10^6 s (5e9 s) fit an MCAP file, not
    # a bag, and the bag was refused only once simulated.
    from hybridlog.jobs.simulate import simulate_log

    def never(*args, **kwargs):
        raise AssertionError("simulated a run the bag cannot hold")

    path = _model_file(tmp_path, TANK, "dt = 1.0", "dt = 1e6")
    monkeypatch.setattr("hybridlog.simulation_kernels.simulate_steps", never)
    with pytest.raises(OptionError, match=r"\(times before 4294967296 s\); simulate fewer"):
        simulate_log(path, tmp_path / "run.bag", steps=5000)
    # the bound was written 4.295e+09, rounded up past the end it refused
    path = _model_file(tmp_path, TANK, "dt = 1.0", "dt = 1e4")
    with pytest.raises(OptionError) as error:
        simulate_log(path, tmp_path / "run.bag", steps=429_497)
    assert str(error.value) == (
        "--steps: 429,497 steps of 10000 s end at t = 4294970000 s, later than the log holds "
        "(times before 4294967296 s); simulate fewer steps"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plant.toml"]


def test_a_bad_schedule_names_the_model_file_and_key_or_the_option(tmp_path):
    path = _model_file(tmp_path, TANK, 'schedule = "', 'schedule = "7:10,')
    # refused when the file is loaded, whichever command reads it (was: by simulate alone)
    with pytest.raises(ModelError, match=rf"^{path}: simulation\.schedule: unknown mode '7'"):
        load_model(path)
    model = load_model(_model_file(tmp_path, TANK))
    with pytest.raises(OptionError, match=r"^--schedule: 'ten' in '1:ten' is not a whole number$"):
        simulate(model, schedule="1:ten")
    assert simulate(model, schedule="2:4").modes.tolist() == [1] * 5
    # spaces around the colon as around the commas (the mode '1 ' was unknown)
    assert simulate(model, schedule=" 1 : 2 , 2 :1 ").modes.tolist() == [0, 0, 0, 1]
    # given empty (a script's unset variable), never taken for the model's own schedule
    with pytest.raises(OptionError, match=r"^--schedule: '' is not MODE:STEPS$"):
        simulate(model, schedule="")
    # two colons: was "unknown mode '1:10'", though a mode id never holds ':'
    with pytest.raises(OptionError, match=r"^--schedule: '1:10:2' is not MODE:STEPS \(one"):
        simulate(model, schedule="1:10:2")


@pytest.mark.parametrize(
    ("old", "new", "said"),
    [
        (
            "measurement = 0.5 ",
            "measurement = 1e308 ",
            r"y1 = -?[0-9.]+e\+15[34] at t = 0 s is out of range .*\): noise\.measurement's "
            r"variance 1e\+308 \(a standard deviation of 1e\+154\) reaches it alone; ",
        ),
        (
            "process = 0.5 ",
            "process = 1e308 ",
            r"x1 = -?[0-9.]+e\+15[34] at t = 1 s is out of range .*\): noise\.process's "
            r"variance 1e\+308 \(a standard deviation of 1e\+154\) reaches it alone; ",
        ),
    ],
)
def test_values_the_noise_alone_reaches_name_the_noise_not_a_divergence(tmp_path, old, new, said):
    """``[noise] measurement = 1e308`` was "the simulation diverged: y1 = -1.75e+154", as if
    the equations had run away, naming no key (found by hostile59)."""
    path = _model_file(tmp_path, TANK, old, new)
    with pytest.raises(ModelError, match=rf"^{path}: the simulation's noise: {said}"):
        simulate(load_model(path), steps=5, seed=0)
    # noise off, the same model runs; a divergence of the equations is still one (below)
    assert simulate(load_model(path), steps=5, seed=0, noise=False).states.shape == (6, 3)


def test_divergence_and_missing_inputs_name_the_model_file(tmp_path):
    exploding = PENDULUM_ONE_MODE.replace('f = ["theta + 0.05*omega"', 'f = ["1e300*theta"')
    path = _model_file(tmp_path, exploding)
    diverged = rf"^{path}: the simulation diverged: theta = 1e\+300 at t = 0\.05 s is out of range"
    with pytest.raises(ModelError, match=diverged):
        simulate(load_model(path), steps=20)
    silent = PENDULUM_ONE_MODE.replace('torque = "0.3*sin(0.5*t)"', "")
    path = _model_file(tmp_path, silent)
    with pytest.raises(ModelError) as missing:
        simulate(load_model(path), steps=20)
    # it said what was missing, not what to write (the model_files.md example of a
    # continuous-time model had no [simulation.inputs] and stopped there)
    assert str(missing.value) == (
        f"{path}: simulation.inputs.torque: no input signal to simulate with; write "
        'torque = "..." (an expression of t and k) under [simulation.inputs]'
    )


@pytest.mark.parametrize(
    ("expression", "value", "time"),
    [
        ("sqrt(t - 0.5)", "nan", "0"),
        ("1/(t - 0.1)", "inf", "0.1"),
        ("log(k)", "-inf", "0"),
        ("1/(k - 1)", "inf", "0.05"),
    ],
)
def test_an_input_expression_outside_its_domain_names_its_key_and_time(
    tmp_path, expression, value, time
):
    """`sqrt(t - 5)` gave "numerical trouble in simulate.py:160: invalid value in sqrt"."""
    path = _model_file(tmp_path, PENDULUM_ONE_MODE.replace('"0.3*sin(0.5*t)"', f'"{expression}"'))
    with pytest.raises(
        ModelError, match=rf"^{path}: simulation\.inputs\.torque: {value} at t = {time} s \(k = "
    ):
        simulate(load_model(path), steps=20)


def test_a_singular_measurement_noise_names_the_file_mode_and_estimator(tmp_path):
    text = PENDULUM_ONE_MODE.replace("measurement = [0.01, 0.02]", "measurement = [0.0, 0.02]")
    model = load_model(_model_file(tmp_path, text))
    signals = AlignedSignals(
        source="sim",
        time=np.arange(4.0),
        input_names=model.inputs,
        output_names=model.outputs,
        inputs=np.zeros((4, 1)),
        outputs=np.zeros((4, 2)),
    )
    for run, options, name in ((run_hstf, HstfOptions(), "hstf"), (run_imm, ImmOptions(), "imm")):
        with pytest.raises(
            ModelError,
            match=rf"^{tmp_path}/plant\.toml: noise\.measurement: the measurement noise covariance "
            rf"of mode 'only' is singular; the {name} filter needs",
        ):
            run(model, signals, options)


@pytest.mark.parametrize(
    ("args", "fragment"),
    [
        (["--seed", "-1"], "--seed: expected a whole number of at least 0, got -1"),
        (["--steps", "10**9"], "GB"),
    ],
)
def test_the_command_refuses_in_one_line_before_writing(tmp_path, capsys, args, fragment):
    # Issue 7: a ValueError traceback, and an OOM kill at 23.7 GB, before.
    out = tmp_path / "s.csv"
    args = [str(10**9) if a == "10**9" else a for a in args]
    with pytest.raises(SystemExit) as exit_:
        main(["simulate", "three_tank_hstf", "--out", str(out), *args])
    assert exit_.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0] and "Traceback" not in lines[0], lines
    assert not out.exists()


def test_a_folder_named_like_a_built_in_is_not_taken_for_the_model(tmp_path, monkeypatch):
    # Outputs kept in a folder named after the model: "three_tank_hstf: no such model file"
    # for the built-in, and a log written into the folder "touched the model file".
    from hybridlog.jobs.analysis import analyze
    from hybridlog.jobs.simulate import simulate_log

    monkeypatch.chdir(tmp_path)
    Path("three_tank_hstf").mkdir()
    assert load_model("three_tank_hstf").origin == "three_tank_hstf"
    simulate_log("three_tank_hstf", "three_tank_hstf/run.csv", steps=20)
    analyze("three_tank_hstf/run.csv", "three_tank_hstf", out_dir="three_tank_hstf/report")
    assert (tmp_path / "three_tank_hstf/report/report.json").is_file()
    with pytest.raises(ModelError, match=r"^plant\.toml: no such model file$"):
        load_model("plant.toml")  # a file's name is still a file's, found or not


@pytest.mark.parametrize(
    ("old", "new", "group"),
    [
        ('states = ["x1", "x2", "x3"]', 'states = ["x1", "x2", "mode"]', "states"),
        ('outputs = ["y1", "y2", "y3"]', 'outputs = ["y1", "y2", "mode"]', "outputs"),
        ('inputs = ["u"]', 'inputs = ["mode"]', "inputs"),
    ],
)
def test_no_signal_can_take_the_true_mode_s_column(tmp_path, old, new, group):
    # simulate's CSV held the state's values under 'mode' and no true mode (or the mode ids
    # over the output's values): one column written over the other, without a word.
    path = _model_file(tmp_path, TANK, old, new)
    with pytest.raises(ModelError) as error:
        load_model(path)
    assert str(error.value).startswith(f"{path}: {group}: 'mode' ")
    assert str(error.value).endswith("and cannot be a symbol name")


RULED_OUT = """
name = "ruled_out"
time = "discrete"
dt = 0.1
states = ["x1"]
inputs = ["u"]
outputs = ["y"]
[modes.a]
f = ["0.9*x1 + u"]
h = ["x1"]
[modes.b]
f = ["0.5*x1 + u"]
h = ["x1"]
[modes.c]
f = ["0.2*x1 + u"]
h = ["2*x1"]
[noise]
process = 0.01
measurement = 0.01
[initial]
state = [0.0]
mode = "a"
[transitions]
matrix = [[0.98, 0.02, 0.0], [0.0, 0.98, 0.02], [0.02, 0.0, 0.98]]
[simulation]
inputs = { u = "sin(t)" }
schedule = "a:10,b:10,c:10"
"""


def test_a_schedule_through_a_switch_the_markov_matrix_rules_out_is_noted():
    # Before: the log was written without a word, and imm's Viterbi path could not follow it.
    model = parse_model(RULED_OUT, origin="ruled_out.toml")
    assert simulate(model, jit=False).notes == ()  # a -> b -> c -> ... as the matrix allows
    log = simulate(model, schedule="a:10,c:10,b:10", steps=60, jit=False)
    assert log.notes == (
        "--schedule: switches from mode 'a' to 'c' at t = 1.1 s (row 11) and 1 more time, "
        "which [transitions] gives probability 0: the model rules "
        "it out, so imm weighs it as impossible and its Viterbi and k-best mode sequences "
        "cannot take it",
        "--schedule: switches from mode 'c' to 'b' at t = 2.1 s (row 21) and 1 more time, "
        "which [transitions] gives probability 0: the model rules "
        "it out, so imm weighs it as impossible and its Viterbi and k-best mode sequences "
        "cannot take it",
        "--schedule: switches from mode 'b' to 'a' at t = 3.1 s (row 31), which [transitions] "
        "gives probability 0: the model rules it out, so imm "
        "weighs it as impossible and its Viterbi and k-best mode sequences cannot take it",
    )
    # a first mode [initial] rules out costs one sample, and the paper's scenario does it
    assert simulate(model, schedule="b:5", jit=False).notes == ()
    assert simulate(load_model("three_tank_hstf"), steps=3, jit=False).notes == ()


def test_the_command_prints_the_note_on_stderr_and_writes_the_log(tmp_path, capsys):
    model = _model_file(tmp_path, RULED_OUT)
    out = tmp_path / "s.csv"
    main(["simulate", str(model), "--out", str(out), "--schedule", "a:3,c:3"])  # exit 0
    assert out.exists()
    captured = capsys.readouterr()
    assert captured.err.startswith("hybridlog: note: --schedule: switches from mode 'a' to 'c'")
    assert len(captured.err.splitlines()) == 1 and "wrote" in captured.out
    main(["simulate", str(model), "--out", str(out), "--schedule", "a:3,c:3", "-q", "--force"])
    assert capsys.readouterr().err == ""


def test_steps_within_a_huge_schedule_build_only_the_rows_run():
    # --steps 5 of "1:10^12,2:5" allocated the whole schedule (8 TB) and ran out of memory
    model = load_model("three_tank_hstf")
    log = simulate(model, schedule=f"1:{10**12},2:5", steps=5, noise=False)
    assert log.modes.tolist() == [0] * 6
    # a schedule shorter than --steps repeats, cut where the steps end
    assert simulate(model, schedule="1:2,3:3", steps=12).modes.tolist() == [
        0, 0, 0, 2, 2, 2, 0, 0, 2, 2, 2, 0, 0,
    ]  # fmt: skip
    assert simulate(model, schedule="1:2,3:3", steps=3).modes.tolist() == [0, 0, 0, 2]


GUARDED = """
name = "guarded"
dt = 0.1
states = ["x"]
outputs = ["y"]

[modes.down]
f = ["x - 0.3"]
h = ["x"]
guard = "x > 0"

[modes.up]
f = ["x + 0.2"]
h = ["x"]
guard = "x < 1"

[noise]
process = 0.0
measurement = 0.01

[initial]
state = [0.5]
mode = "down"
"""


def test_where_guards_overlap_the_first_listed_mode_holds():
    # in 0 < x < 1 both guards hold: the first listed mode is taken, as model_files says
    model = parse_model(GUARDED, origin="guarded.toml")
    log = simulate(model, steps=4, noise=False, jit=False)
    # x = 0.5, 0.2 (both hold: down), -0.1 (up alone), 0.1 (both: down), -0.2
    assert [model.mode_ids[q] for q in log.modes] == ["down", "down", "up", "down", "up"]
    up_first = GUARDED[GUARDED.index("[modes.up]") : GUARDED.index("[noise]")]
    text = GUARDED.replace(up_first, "").replace("[modes.down]", up_first + "[modes.down]")
    model = parse_model(text, origin="guarded.toml")
    log = simulate(model, steps=4, noise=False, jit=False)
    # x = 0.5, 0.7, 0.9 (both hold: up), 1.1 (down alone), 0.8
    assert [model.mode_ids[q] for q in log.modes] == ["up", "up", "up", "down", "up"]


@pytest.mark.parametrize(
    ("guard", "verdict"),
    [("x > x", "never holds"), ("x**2 >= 0", "always holds"), ("sqrt(2) > 1", "always holds")],
)
def test_a_guard_sympy_decides_says_which_way(guard, verdict):
    # 'x > x' (never) and 'x**2 >= 0' (always) were both "does not depend on the states"
    text = GUARDED.replace('guard = "x > 0"', f'guard = "{guard}"')
    message = rf"^guarded\.toml: modes\.down\.guard: '.*' {verdict}, whatever the states and"
    with pytest.raises(ModelError, match=message):
        parse_model(text, origin="guarded.toml")


@pytest.mark.parametrize(
    ("guard", "said"),
    [
        ("x*1e308*10 > 1", r"'x\*1e308\*10 > 1' is not finite in double precision"),
        ("x/0 > 1", r"'x/0 > 1' is not finite \(a division by zero\?\)"),
    ],
)
def test_a_guard_refused_as_not_finite_is_quoted_as_written(guard, said):
    """The guard is parsed as ``Piecewise(1, guard, 0)``, and the refusal quoted that
    wrapper, which the user never wrote (found by review58)."""
    text = GUARDED.replace('guard = "x > 0"', f'guard = "{guard}"')
    with pytest.raises(ModelError, match=rf"^guarded\.toml: modes\.down\.guard: {said}") as err:
        parse_model(text, origin="guarded.toml")
    assert "Piecewise" not in str(err.value)


def test_a_guard_outside_its_domain_does_not_hold_and_is_named_where_none_does():
    # sqrt(x) > 0 at x = -0.1 compares a NaN: it does not hold (in the reals sqrt(-0.1) is
    # not above 0), and the next guard (x < 1) takes the sample, as before
    text = GUARDED.replace('guard = "x > 0"', 'guard = "sqrt(x) > 0"')
    log = simulate(parse_model(text, origin="guarded.toml"), steps=4, noise=False)
    assert log.modes.tolist() == [0, 0, 1, 0, 1]  # x = 0.5, 0.2 (down), -0.1 (up), 0.1, -0.2
    # where no other guard holds, the error names the guard left undefined, not only that
    # no guard held
    text = text.replace('guard = "x < 1"', 'guard = "x > 0.3"')
    message = (
        r"^guarded\.toml: modes\.down\.guard: 'sqrt\(x\) > 0' is undefined \(a side is nan\) "
        r"at x = -0\.1, t = 0\.2 s \(the state left the domain of the guard there\), and no "
        r"other mode's guard holds"
    )
    with pytest.raises(ModelError, match=message):
        simulate(parse_model(text, origin="guarded.toml"), steps=4, noise=False)


def test_a_guard_an_input_takes_out_of_its_domain_names_the_input():
    # 'the state left the domain of the guard' was said of a guard that reads only an input
    text = (
        GUARDED.replace('outputs = ["y"]', 'inputs = ["u"]\noutputs = ["y"]')
        .replace('guard = "x > 0"', 'guard = "sqrt(u) >= 0"')
        .replace('guard = "x < 1"', 'guard = "x > 100"')
    )
    text += '\n[simulation.inputs]\nu = "1 - t"\n'
    message = (
        r"^guarded\.toml: modes\.down\.guard: 'sqrt\(u\) >= 0' is undefined \(a side is "
        r"nan\) at x = .*, u = -0\.1.*\(the input left the domain of the guard there\)"
    )
    with pytest.raises(ModelError, match=message):
        simulate(parse_model(text, origin="guarded.toml"), steps=20, noise=False)


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            "state = [15.0, 10.0, 10.0]",
            "state = [15.0, -2.5, 10.0]",
            r"simulation\.state_min\[1\]: the run starts with x2 = -2\.5 \(simulation\.state\)",
        ),
        (
            "state_min = [0.0, 0.0, 0.0]",
            "state_min = [0.0, 0.0, 12.0]",
            r"simulation\.state_min\[2\]: the run starts with x3 = 10 \(simulation\.state\), "
            r"below its bound 12",
        ),
        (  # without simulation.state the run starts at initial.state
            "state = [15.0, 10.0, 10.0]\n",
            "",
            r"simulation\.state_min\[0\]: the run starts with x1 = 20 \(initial\.state; the file "
            r"gives no simulation\.state\), below its bound 25",
        ),
    ],
)
def test_a_run_starting_below_its_state_min_is_refused_as_the_file_loads(old, new, message):
    # row 0 held the level state_min calls impossible, and row 1 the bound: a jump the
    # plant cannot make; `hybridlog models FILE` called the file valid
    text = TANK.replace(old, new, 1)
    if not new:
        text = text.replace("state_min = [0.0, 0.0, 0.0]", "state_min = [25.0, 0.0, 0.0]", 1)
    assert text != TANK
    with pytest.raises(ModelError, match=rf"^tank\.toml: {message}"):
        parse_model(text, origin="tank.toml")


def test_a_first_run_compiles_the_model_inside_the_reporters_wait(monkeypatch):
    # a linear model of 30 states and 40 modes compiled for minutes before its first log,
    # and simulate said nothing meanwhile; analyze's filters say so on a terminal
    import contextlib

    from hybridlog.cluster.progress import WorkReporter, reporting
    from hybridlog.model import compiled

    calls: list[str] = []
    waits: list[str] = []
    function = compiled._function

    def counted(model, name, jit):
        calls.append(f"{name} in wait" if waits and waits[-1] == "open" else name)
        return function(model, name, jit)

    @contextlib.contextmanager
    def wait(what, why):
        waits.append("open")
        yield
        waits[-1] = what

    monkeypatch.setattr(compiled, "_function", counted)
    model = parse_model(PENDULUM_ONE_MODE)
    with reporting(WorkReporter(wait=wait)):
        simulate(model, steps=5)
    assert waits == ["simulate: compiling machine code for model 'pendulum'"]
    inside = {call.split()[0] for call in calls if call.endswith(" in wait")}
    assert inside == {"f", "h"} == {call.split()[0] for call in calls}


@pytest.mark.parametrize(
    ("model", "schedule"),
    [
        ("three_tank_hstf", "1:7,3:5,2:9"),  # scheduled
        ("double_cart_case1", None),  # guarded: the mode of each row from its state
        ("ice_clutch", "0:6,1:5,0:4"),  # continuous, jump maps at the switches
    ],
)
def test_a_run_in_chunks_is_the_run_in_one_call(tmp_path, monkeypatch, model, schedule):
    # the compiled loops run a few thousand steps a call (a long run says how long it takes,
    # and a signal ends it); each chunk starts from the row before it, to the same values
    import hybridlog.simulate as simulate_module
    from hybridlog.simulation_inputs import Disturbance

    disturbance = None
    if model == "ice_clutch":  # its 10 integration steps a row each draw process noise
        text = (ROOT / "hybridlog/model/builtin/ice_clutch.toml").read_text()
        old = "measurement = 1e-4 "
        loaded = load_model(_model_file(tmp_path, text, old, "process = 1e-4\n" + old))
        disturbance = Disturbance(0.01, 3.0)  # a function of the time of each step
    else:
        loaded = load_model(model)
    runs = []
    for work in (10**9, 1, 30):  # one call; a row a call; chunks of 30 steps (3 rows of ice_clutch)
        monkeypatch.setattr(simulate_module, "CHUNK_WORK", work)
        runs.append(simulate(loaded, schedule=schedule, steps=40, seed=5, disturbance=disturbance))
    for run in runs[1:]:
        for name in ("time", "inputs", "outputs", "modes", "states"):
            assert np.array_equal(getattr(run, name), getattr(runs[0], name)), name


@pytest.mark.parametrize(
    ("builtin", "old", "new"),
    [
        ("three_tank_hstf", "A = 154.0", "A = 154.000271828"),
        ("double_cart_case1", "[0.7627, 0.4596,", "[0.762700271828, 0.4596,"),
    ],
)
def test_simulate_compiles_no_jacobian(tmp_path, builtin, old, new):
    """``simulate`` compiled the Jacobians F and H, which it never calls: on a model's first
    run about half of its compile time (a scheduled and a state-driven model)."""
    from hybridlog.model import compiled

    text = (ROOT / f"hybridlog/model/builtin/{builtin}.toml").read_text()
    model = load_model(_model_file(tmp_path, text, old, new))
    simulate(model, steps=20)
    key = compiled.model_key(model)
    names = {name for memo, name, jit in compiled._COMPILED if memo == key and jit}
    assert names == ({"f", "h", "guard"} if model.state_driven else {"f", "h"})


def test_a_guard_at_its_pole_stops_the_run_rather_than_hold_by_the_sign_of_a_zero():
    # '1/x > 0' at x = 0 compared inf > 0: the guard held (by the sign of the zero: at -0.0
    # it would not), and the run went on in 'down' at a point where it is undefined
    text = GUARDED.replace('guard = "x > 0"', 'guard = "1/x > 0"').replace(
        "state = [0.5]", "state = [0.0]"
    )
    message = (
        r"^guarded\.toml: modes\.down\.guard: '1/x > 0' has an infinite side at x = 0, "
        r"t = 0 s \(a pole, .*\): whether it holds cannot be told; nothing was written$"
    )
    with pytest.raises(ModelError, match=message):
        simulate(parse_model(text, origin="guarded.toml"), steps=4, noise=False)
