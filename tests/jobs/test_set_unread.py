"""``--set`` of a model parameter the command never reads is refused, naming why.

``simulate bioplex_pgc --set c_out=1e300`` wrote an ordinary log (``c_out`` enters only the
chamber's ``leak`` mode, which the scenario never plays), and ``analyze --set q0=5`` on the
valve three-tank ran (``q0`` is the inflow of ``[simulation]`` only): each recorded the value
and changed nothing, where an estimator option made inert by the others is refused.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import OptionError
from hybridlog.jobs.model_description import check_and_describe
from hybridlog.jobs.overrides import parse_sets
from hybridlog.jobs.simulate import simulate_log
from hybridlog.model.builtins import builtin_names, builtin_text
from hybridlog.model.loader import parse_model
from hybridlog.model.reads import refuse_unread_by_simulation
from tests.support.cli import run_main


@pytest.mark.parametrize("setting", ["c_out=1e300", "k_leak=0.1"])
def test_a_parameter_only_unplayed_component_modes_name_is_refused(tmp_path: Path, setting):
    out = tmp_path / "x.csv"
    with pytest.raises(OptionError) as caught:
        simulate_log("bioplex_pgc", out, steps=20, seed=1, sets=[setting])
    name = setting.split("=")[0]
    assert str(caught.value) == (
        f"--set {setting}: parameters.{name} of bioplex_pgc is named only by modes this run "
        "never plays (components.pgc.modes.leak): the log would be the same without it; play "
        "them (simulation.modes of the model file) or drop the --set"
    )
    assert not out.exists() and not list(tmp_path.iterdir())
    # q_max, named by the regulators' stuck_open modes (not played either), is also the
    # drift's bound in simulation.unmodelled: read once the drift starts within the run
    simulate_log("bioplex_pgc", out, steps=20, seed=1, sets=["q_max=0.6", "drift_start=5"])
    assert out.exists()


def test_a_parameter_only_unstarted_unmodelled_behaviours_name_is_refused(tmp_path: Path):
    # `--steps 20 --set q_max=0.6` wrote a log the same as without it: the drift that q_max
    # bounds starts at step 700, and no played mode names q_max
    out = tmp_path / "x.csv"
    with pytest.raises(OptionError) as caught:
        simulate_log("bioplex_pgc", out, steps=20, seed=1, sets=["q_max=0.6"])
    assert str(caught.value) == (
        "--set q_max=0.6: parameters.q_max of bioplex_pgc is named only by modes this run "
        "never plays (components.fr1.modes.stuck_open, components.fr2.modes.stuck_open) and "
        "by unmodelled behaviours it never starts (simulation.unmodelled[0]): the log would "
        "be the same without it; the run ends before simulation.unmodelled[0] starts at "
        "step 700: give --steps 700 or more, or drop the --set"
    )
    assert not list(tmp_path.iterdir())


def test_a_parameter_only_unscheduled_modes_name_is_refused(tmp_path: Path):
    out = tmp_path / "x.csv"
    with pytest.raises(
        OptionError,
        match=r"^--set s2=1: parameters\.s2 of three_tank_hstf is "
        r"named only by modes this run never plays \(modes\.2, modes\.3\): .* "
        r"play them \(--schedule\) or drop the --set$",
    ):
        simulate_log("three_tank_hstf", out, schedule="1:20", seed=1, sets=["s2=1"])
    assert not out.exists()
    simulate_log("three_tank_hstf", out, schedule="1:20,3:2", seed=1, sets=["s2=1"])
    assert out.exists()


def test_a_guard_switched_models_unplayed_mode_is_read():
    text = builtin_text("double_cart_case1")
    text = text.replace('guard = "x3 > 0"', 'guard = "x3 > lim"').replace(
        "[modes.1]", "[parameters]\nlim = 0.0\n\n[modes.1]", 1
    )
    model = parse_model(text, origin="cart.toml")
    # only mode 1 played: lim is its twin's guard, which decided that; and the equations of
    # a guard-switched mode are read too, as another seed may enter it
    refuse_unread_by_simulation(model, {"lim": "1"}, {"": {"1"}})


def test_a_parameter_only_the_simulation_names_is_refused_by_analyze():
    with pytest.raises(OptionError) as caught:
        parse_sets(["q0=5"], "three_tank_valves")
    assert str(caught.value) == (
        "--set q0=5: parameters.q0 of three_tank_valves is named only under [simulation], "
        "the scenario `hybridlog simulate` plays, which no estimator reads: it would change "
        "nothing here"
    )
    model, overrides = parse_sets(["C1=5e-5"], "three_tank_valves")
    assert model.parameters["C1"] == 5e-5 and overrides.parameters == {"C1": 5e-5}


_GUARDED = """
dt = 1.0
states = ["x"]
outputs = ["y"]

[parameters]
a = 0.5
lim = 1.5
g = 2.0

[modes.low]
guard = "x <= lim"
f = ["a*x"]
h = ["x"]

[modes.high]
guard = "x > lim"
f = ["0.0*x"]
h = ["g*x"]

[noise]
process = 1.0
measurement = 0.01

[initial]
state = [0.0]
covariance = 1.0
"""


def test_a_guard_switched_modes_parameter_is_read_whatever_the_seed(tmp_path: Path):
    # the noise of some seeds takes x past lim, of others not: `--set g=3` (the sensor gain
    # of the high mode) was refused for those, with "play them (--schedule)", which this
    # model refuses; the same command now writes a log for every seed
    model = tmp_path / "guarded.toml"
    model.write_text(_GUARDED)
    entered = set()
    for seed in range(6):
        out = tmp_path / f"seed{seed}.csv"
        simulate_log(model, out, steps=5, seed=seed, sets=["g=3"])
        entered.add("high" in out.read_text())
    assert entered == {True, False}  # the seeds differ in whether the mode is entered


def test_a_run_steps_end_before_the_schedule_plays_the_mode_names_the_steps(tmp_path: Path):
    # "play them (--schedule)" where the model's schedule plays modes 2 and 3 after step 100
    out = tmp_path / "x.csv"
    with pytest.raises(OptionError) as caught:
        simulate_log("three_tank_hstf", out, steps=100, seed=1, sets=["s2=0.4"])
    assert str(caught.value) == (
        "--set s2=0.4: parameters.s2 of three_tank_hstf is named only by modes this run "
        "never plays (modes.2, modes.3): the log would be the same without it; the run ends "
        "before its schedule plays modes.2 at step 101: give --steps 101 or more, or drop "
        "the --set"
    )
    assert not list(tmp_path.iterdir())
    simulate_log("three_tank_hstf", out, steps=101, seed=1, sets=["s2=0.4"])
    assert out.exists()


def test_a_components_run_steps_end_before_a_scheduled_mode_names_the_steps(tmp_path: Path):
    text = builtin_text("bioplex_pgc").replace('pgc = "growth"', 'pgc = "growth, leak@30"')
    model = tmp_path / "pgc.toml"
    model.write_text(text)
    out = tmp_path / "x.csv"
    with pytest.raises(OptionError, match=r"plays components\.pgc\.modes\.leak at step 30: "):
        simulate_log(model, out, steps=29, seed=1, sets=["c_out=500"])
    assert not out.exists()
    simulate_log(model, out, steps=30, seed=1, sets=["c_out=500"])
    assert out.exists()


_CLUTCH = """
time = "continuous"
dt = 0.1
integration = {method = "rk4", step = 0.01}
states = ["x"]
outputs = ["y"]

[parameters]
a = 0.5
r = 0.3
s = 2.0
both = 1.0

[modes.slow]
dx = ["-a*x"]
h = ["x"]

[modes.fast]
dx = ["-2*a*both*x"]
h = ["x"]

[jumps."slow->fast"]
x = "r*both*x"

[jumps."*->slow"]
x = "s*x"

[noise]
measurement = 0.01

[initial]
state = [1.0]

[simulation]
schedule = "slow:10,fast:10"
"""


def test_a_parameter_only_jump_maps_of_unmade_switches_name_is_refused(tmp_path: Path):
    # `--set s=3` (the map of every switch into slow) wrote the same log as without it: the
    # run starts in slow and switches only slow -> fast
    model = tmp_path / "clutch.toml"
    model.write_text(_CLUTCH)
    out = tmp_path / "x.csv"
    with pytest.raises(OptionError) as caught:
        simulate_log(model, out, seed=1, sets=["s=3"])
    assert str(caught.value) == (
        f"--set s=3: parameters.s of {model} is named only by jump maps of switches this run "
        'never makes (jumps."*->slow"): the log would be the same without it; the run ends '
        'before its schedule switches from fast to slow (jumps."*->slow") at step 21: give '
        "--steps 21 or more, or drop the --set"
    )
    with pytest.raises(OptionError, match=r"jumps\.\"slow->fast\"\): .* make those switches "):
        simulate_log(model, out, schedule="slow:10", seed=1, sets=["r=0.1"])
    # a map the run's own switch pair overrides is not read either: fast -> slow here takes
    # its own map, never "*->slow"
    text = _CLUTCH + '\n[jumps."fast->slow"]\nx = "x"\n'
    model.write_text(text)
    with pytest.raises(OptionError, match=r"never makes \(jumps\.\"\*->slow\"\): "):
        simulate_log(model, out, steps=25, seed=1, sets=["s=3"])
    assert not list(tmp_path.glob("*.csv"))


def test_a_parameter_a_made_switch_or_a_played_mode_reads_is_accepted(tmp_path: Path):
    model = tmp_path / "clutch.toml"
    model.write_text(_CLUTCH)
    logs = {}
    for name, steps, settings in (("base", 25, []), ("s", 25, ["s=3"]), ("r", 20, ["r=0.1"])):
        out = tmp_path / f"{name}.csv"
        simulate_log(model, out, steps=steps, seed=1, sets=settings)
        logs[name] = out.read_text()
    assert logs["s"] != logs["base"]  # the schedule repeats: fast -> slow at step 21
    # `both` is read by fast's dx where the slow -> fast jump is never made
    simulate_log(model, tmp_path / "b.csv", schedule="fast:5", seed=1, sets=["both=2"])
    # and refused where neither is read, naming both parts
    with pytest.raises(OptionError, match=r"only by modes .* \(modes\.fast\) and by jump maps"):
        simulate_log(model, tmp_path / "c.csv", steps=5, seed=1, sets=["both=2"])


_ESTIMATED = """
dt = 1.0
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[parameters]
a = 0.5
kbest = 3.0
data = 1.0

[modes.1]
f = ["a*x + u"]
h = ["data*x"]

[modes.2]
f = ["0.9*x + u"]
h = ["x"]

[signals]
y = "/sensor/level.data"

[noise]
measurement = 1.0

[initial]
state = [0.0]

[simulation]
schedule = "1:5,2:5"

[simulation.inputs]
u = "sin(t)"

[estimators.imm]
mode_sequence = "kbest"
"""


def test_a_parameter_only_keys_without_expressions_name_is_refused_by_every_command(
    tmp_path: Path,
):
    # `--set kbest=1` beside `mode_sequence = "kbest"` was taken by simulate and analyze,
    # which read no option value as an expression
    model = tmp_path / "m.toml"
    model.write_text(_ESTIMATED)
    out = tmp_path / "x.csv"
    why = (
        f"--set kbest=1: parameters.kbest of {model} is named only in keys no command reads "
        "as expressions (estimators.imm.mode_sequence): "
    )
    with pytest.raises(OptionError) as caught:
        simulate_log(model, out, seed=1, sets=["kbest=1"])
    assert str(caught.value) == why + "the log would be the same without it; drop the --set"
    with pytest.raises(OptionError) as caught:
        parse_sets(["kbest=1"], str(model))
    assert str(caught.value) == why + "it would change nothing here"
    # `data` is also a path's field under [signals], and a gain of modes.1: read
    simulate_log(model, out, seed=1, sets=["data=2"])
    assert parse_sets(["data=2"], str(model))[0].parameters["data"] == 2.0
    # ... unless only modes.2 is played: named by an unplayed mode and a log path
    with pytest.raises(OptionError, match=r"expressions \(signals\.y\) and by modes this run "):
        simulate_log(model, out, schedule="2:5", seed=1, sets=["data=2"], force=True)


def test_simulate_refuses_an_unmade_switchs_parameter_on_the_command_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
):
    model = tmp_path / "clutch.toml"
    model.write_text(_CLUTCH)
    out = tmp_path / "x.csv"
    args = ["simulate", str(model), "--out", str(out), "--schedule", "fast:4", "--set", "r=2"]
    code, output = run_main(args, capsys)
    assert code == 2 and output.count("\n") == 1 and not out.exists()
    assert output.startswith(f"hybridlog: error: --set r=2: parameters.r of {model} is named ")


def test_models_file_notes_each_parameter_no_expression_reads(tmp_path: Path) -> None:
    """A parameter named nowhere, or only where no expression is read, passed ``models FILE``
    without a word: a leftover of an edit, or a name the equations spell otherwise."""
    text = builtin_text("ice_clutch").replace(
        "[parameters]", "[parameters]\nkk2 = 3.0\nleft_over = 1.0", 1
    )
    text = text.replace("[noise]", '[signals]\ny = "/kk2.data"\n\n[noise]', 1)
    path = tmp_path / "clutch.toml"
    path.write_text(text, encoding="utf-8")
    notes = [line for line in check_and_describe(path).splitlines() if "parameters." in line]
    assert notes == [
        "NOTE: parameters.kk2 is read by no expression of the model (named only in signals.y, "
        "read as no expression): a leftover, or a name the equations spell otherwise?",
        "NOTE: parameters.left_over is read by no expression of the model: a leftover, or a "
        "name the equations spell otherwise?",
    ]
    for name in builtin_names():
        builtin = tmp_path / f"{name}.toml"
        builtin.write_text(builtin_text(name), encoding="utf-8")
        assert "NOTE: parameters." not in check_and_describe(builtin), name
