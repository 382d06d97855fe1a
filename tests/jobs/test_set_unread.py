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
from hybridlog.jobs.analysis import parse_sets
from hybridlog.jobs.simulate import simulate_log
from hybridlog.model.builtins import builtin_text
from hybridlog.model.loader import parse_model
from hybridlog.model.reads import refuse_unread_by_simulation


@pytest.mark.parametrize("setting", ["c_out=1e300", "k_leak=0.1"])
def test_a_parameter_only_unplayed_component_modes_name_is_refused(tmp_path: Path, setting):
    out = tmp_path / "x.csv"
    with pytest.raises(OptionError) as caught:
        simulate_log("bioplex_pgc", out, steps=20, seed=1, settings=[setting])
    name = setting.split("=")[0]
    assert str(caught.value) == (
        f"--set {setting}: parameters.{name} of bioplex_pgc is named only by modes this run "
        "never plays (components.pgc.modes.leak): the log would be the same without it; play "
        "them (simulation.modes of the model file) or drop the --set"
    )
    assert not out.exists() and not list(tmp_path.iterdir())
    # a parameter of a played mode (a regulator's stuck_open is not played either, but
    # q_max is also the drift's bound in simulation.unmodelled) still runs
    simulate_log("bioplex_pgc", out, steps=20, seed=1, settings=["q_max=0.6"])
    assert out.exists()


def test_a_parameter_only_unscheduled_modes_name_is_refused(tmp_path: Path):
    out = tmp_path / "x.csv"
    with pytest.raises(
        OptionError,
        match=r"^--set s2=1: parameters\.s2 of three_tank_hstf is "
        r"named only by modes this run never plays \(modes\.2, modes\.3\): .* "
        r"play them \(--schedule\) or drop the --set$",
    ):
        simulate_log("three_tank_hstf", out, schedule="1:20", seed=1, settings=["s2=1"])
    assert not out.exists()
    simulate_log("three_tank_hstf", out, schedule="1:20,3:2", seed=1, settings=["s2=1"])
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
        simulate_log(model, out, steps=5, seed=seed, settings=["g=3"])
        entered.add("high" in out.read_text())
    assert entered == {True, False}  # the seeds differ in whether the mode is entered


def test_a_run_steps_end_before_the_schedule_plays_the_mode_names_the_steps(tmp_path: Path):
    # "play them (--schedule)" where the model's schedule plays modes 2 and 3 after step 100
    out = tmp_path / "x.csv"
    with pytest.raises(OptionError) as caught:
        simulate_log("three_tank_hstf", out, steps=100, seed=1, settings=["s2=0.4"])
    assert str(caught.value) == (
        "--set s2=0.4: parameters.s2 of three_tank_hstf is named only by modes this run "
        "never plays (modes.2, modes.3): the log would be the same without it; the run ends "
        "before its schedule plays modes.2 at step 101: give --steps 101 or more, or drop "
        "the --set"
    )
    assert not list(tmp_path.iterdir())
    simulate_log("three_tank_hstf", out, steps=101, seed=1, settings=["s2=0.4"])
    assert out.exists()


def test_a_components_run_steps_end_before_a_scheduled_mode_names_the_steps(tmp_path: Path):
    text = builtin_text("bioplex_pgc").replace('pgc = "growth"', 'pgc = "growth, leak@30"')
    model = tmp_path / "pgc.toml"
    model.write_text(text)
    out = tmp_path / "x.csv"
    with pytest.raises(OptionError, match=r"plays components\.pgc\.modes\.leak at step 30: "):
        simulate_log(model, out, steps=29, seed=1, settings=["c_out=500"])
    assert not out.exists()
    simulate_log(model, out, steps=30, seed=1, settings=["c_out=500"])
    assert out.exists()
