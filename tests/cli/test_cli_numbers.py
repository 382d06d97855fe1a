"""Numbers typed on the command line are read strictly (``hybridlog/numbers.py``).

Python's ``int()``/``float()`` took ``1_0`` as 10, ``٣`` (an Arabic-Indic digit) as 3 and
``infinity`` as a number: ``--steps 1_0``, ``--radius 1_0`` or ``--set theta=1_0`` ran a
different analysis than the one typed, without a word.
"""

import pytest

from hybridlog.cli_types import Number, WholeNumber
from hybridlog.numbers import parse_float, parse_int
from tests.cli.test_cli import run
from tests.support.paths import SAMPLE_LOGS, TANK_CSV

LENIENT = ["1_0", "٣", "１", "0x3", "1,5", "", " ", "+", "--1", "1 0", "3\u00a0", "\u20033"]
"""Texts Python reads (or half reads) as numbers and hybridlog must not."""


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("42", 42),
        ("-3", -3),
        ("+7", 7),
        (" 2 ", 2),
        ("\t5\n", 5),
        ("007", 7),
        ("1" * 30, int("1" * 30)),
    ],
)
def test_whole_numbers_are_ascii_digits_with_a_sign(text, value):
    assert parse_int(text) == value


@pytest.mark.parametrize("text", [*LENIENT, "5.0", "1e3", "inf", "nan", "9" * 5000])
def test_anything_else_is_not_a_whole_number(text):
    with pytest.raises(ValueError, match=r"^expected a whole number"):
        parse_int(text)


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("0.5", 0.5),
        (".5", 0.5),
        ("5.", 5.0),
        ("-2.5E+4", -25000.0),
        ("1e-3", 0.001),
        (" 3 ", 3.0),
        ("+0", 0.0),
    ],
)
def test_numbers_have_a_decimal_point_and_exponent(text, value):
    assert parse_float(text) == value


@pytest.mark.parametrize(
    "text", [*LENIENT, ".", "e3", "1e", "1.5.2", "inf", "-Infinity", "nan", "1e999", "0x1p3"]
)
def test_anything_else_is_not_a_finite_number(text):
    with pytest.raises(ValueError, match=r"^expected a finite number$"):
        parse_float(text)


@pytest.mark.parametrize("text", ["1e-400", "-1e-400", "1e-310", "0.000000001e-300"])
def test_a_number_a_double_does_not_hold_in_full_is_refused(text):
    """``--set A=1e-400`` was read as 0 (then blamed on an expression dividing by zero)."""
    with pytest.raises(ValueError, match=r"^expected a number a double holds in full"):
        parse_float(text)


@pytest.mark.parametrize("text", ["0", "-0.0", "0e-400", "2.2250738585072014e-308"])
def test_zero_and_the_smallest_normal_double_are_numbers(text):
    assert parse_float(text) == float(text)


def _refused(args, *fragments):
    """Exit 2, one line naming the option and the value, nothing written."""
    result = run(args, expect=2)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


@pytest.mark.parametrize("steps", ["1_0", "٣", "0x3", "3.0"])
def test_simulate_steps_is_read_strictly(tmp_path, steps):
    out = tmp_path / "sim.csv"
    _refused(
        ["simulate", "three_tank_hstf", "--out", str(out), "--steps", steps],
        "--steps",
        "expected a whole number",
        repr(steps),
    )
    assert not out.exists()


def test_simulate_steps_may_be_surrounded_by_ascii_spaces(tmp_path):
    out = tmp_path / "sim.csv"
    result = run(["simulate", "three_tank_hstf", "--out", str(out), "--steps", " 4 "])
    assert "(5 samples)" in result.stderr + result.output


@pytest.mark.parametrize(
    ("option", "value"),
    [("--seed", "1_0"), ("--seed", "٣")],
)
def test_simulate_seed_is_read_strictly(tmp_path, option, value):
    _refused(
        ["simulate", "three_tank_hstf", "--out", str(tmp_path / "s.csv"), option, value],
        option,
        repr(value),
    )


@pytest.mark.parametrize("value", ["1_0", "inf", "nan", "1e999", "٣"])
def test_max_gap_is_read_strictly(tmp_path, value):
    out = tmp_path / "r"
    args = ["analyze", str(TANK_CSV), "--model", "three_tank_hstf", "--out", str(out)]
    _refused([*args, "--max-gap", value], "--max-gap", "expected a finite number", repr(value))
    assert not out.exists()


def test_batch_jobs_is_read_strictly(tmp_path):
    out = tmp_path / "b"
    args = ["batch", str(TANK_CSV), "--model", "three_tank_hstf", "--out", str(out)]
    _refused([*args, "--jobs", "٢"], "--jobs", "expected a whole number", "'٢'")
    assert not out.exists()


@pytest.mark.parametrize(("option", "value"), [("--radius", "1_0"), ("--radius", "infinity")])
def test_cluster_options_are_read_strictly(tmp_path, option, value):
    out = tmp_path / "c.json"
    log = SAMPLE_LOGS / "double_cart_case1.csv"
    _refused(
        ["cluster", str(log), "--model", "double_cart_case1", "--out", str(out), option, value],
        f"hybridlog cluster: {option}: expected a finite number, got '{value}'",
    )
    assert not out.exists()


@pytest.mark.parametrize(
    ("estimator", "setting", "fragments"),
    [
        ("hstf", "theta=1_0", ("hstf option 'theta'", "expected a finite number, got '1_0'")),
        (
            "imm",
            "transition_stay=٠.٩٩",
            ("imm option 'transition_stay'", "expected a finite number, got '٠.٩٩'"),
        ),
        ("hstf", "A=1_54", ("--set A=1_54: expected a finite number, got '1_54'",)),
        ("hstf", "A=inf", ("--set A=inf: expected a finite number, got 'inf'",)),
        ("hstf", "A=1e-400", ("--set A=1e-400: expected a number a double holds in full",)),
    ],
)
def test_set_values_are_read_strictly(tmp_path, estimator, setting, fragments):
    out = tmp_path / "r"
    args = ["analyze", str(TANK_CSV), "--model", "three_tank_hstf", "--out", str(out)]
    _refused([*args, "--estimator", estimator, "--set", setting], *fragments)
    assert not out.exists()


@pytest.mark.parametrize(
    ("option", "spec"), [("--fail-under", "vaf=9_0"), ("--fail-over", "mse=infinity")]
)
def test_gate_bounds_are_read_strictly(tmp_path, option, spec):
    out = tmp_path / "r"
    args = ["analyze", str(TANK_CSV), "--model", "three_tank_hstf", "--out", str(out)]
    _refused([*args, option, spec], option, repr(spec), "expected a finite number")
    assert not out.exists()


@pytest.mark.parametrize(
    ("args", "fragments"),
    [
        (["--schedule", "1:1_0"], ("--schedule: '1_0' in '1:1_0' is not a whole number",)),
        (["--schedule", "1:٣"], ("--schedule: '٣' in '1:٣' is not a whole number",)),
    ],
)
def test_simulate_schedule_steps_are_read_strictly(tmp_path, args, fragments):
    out = tmp_path / "s.csv"
    _refused(["simulate", "three_tank_hstf", "--out", str(out), *args], *fragments)
    assert not out.exists()


@pytest.mark.parametrize("value", ["2e-4,6_28", "inf,1", "2e-4,٦"])
def test_simulate_disturbance_is_read_strictly(tmp_path, value):
    out = tmp_path / "s.csv"
    _refused(
        ["simulate", "three_tank_valves", "--out", str(out), "--disturbance", value],
        "--disturbance: expected A,OMEGA (two finite numbers)",
        repr(value),
    )
    assert not out.exists()


def test_simulate_scenario_parameters_are_read_strictly(tmp_path):
    out = tmp_path / "s.csv"
    _refused(
        ["simulate", "bioplex_pgc", "--out", str(out), "--set", "light_fault=9_50"],
        "--set light_fault=9_50: expected a finite number, got '9_50'",
    )
    assert not out.exists()


def test_cluster_lags_are_read_strictly(tmp_path):
    out = tmp_path / "c.json"
    log = SAMPLE_LOGS / "double_cart_case1.csv"
    args = ["cluster", str(log), "--model", "double_cart_case1", "--out", str(out)]
    _refused(
        [*args, "--input-lags", "0,1_0"],
        "hybridlog cluster: --input-lags: '1_0' is not a whole number",
    )
    assert not out.exists()


def test_switching_observer_eigenvalues_are_read_strictly(tmp_path):
    out = tmp_path / "r"
    log = SAMPLE_LOGS / "ice_clutch.csv"
    args = ["analyze", str(log), "--model", "ice_clutch", "--out", str(out)]
    _refused(
        [*args, "--estimator", "switching-observer", "--set", "eigenvalues=-5,-1_0"],
        "switching-observer option 'eigenvalues'",
        "expected negative numbers separated by commas, got '-5,-1_0'",
    )
    assert not out.exists()


def test_batch_jobs_auto_is_one_per_usable_core(monkeypatch):
    """``--jobs auto``: as many workers as cores this process may use (was refused).

    The CLI passes ``"auto"`` on, which run_batch counts (so that its notes and errors say
    ``--jobs auto``, not the count).
    """
    import click

    import hybridlog.environment as environment
    import hybridlog.jobs.batch as batch
    from hybridlog.cli_types import Jobs

    jobs = Jobs(min=1)
    assert jobs.convert("auto", None, None) == "auto" == jobs.convert(" AUTO ", None, None)
    assert jobs.convert("2", None, None) == 2
    with pytest.raises(click.BadParameter, match="a whole number or auto, got 'many'"):
        jobs.convert("many", None, None)
    with pytest.raises(
        click.BadParameter, match=r"^expected a whole number of at least 1 or auto, got 0$"
    ):
        jobs.convert("0", None, None)  # was click's "0 is not in the range x>=1"
    assert batch.usable_cores is environment.usable_cores
    assert environment.usable_cores() >= 1


@pytest.mark.parametrize(
    ("kind", "inside", "outside", "why"),
    [
        (WholeNumber(min=1), "1", "0", "a whole number of at least 1, got 0"),
        (WholeNumber(max=5), "5", "6", "a whole number of at most 5, got 6"),
        (WholeNumber(min=0, max=5), "0", "-1", "a whole number from 0 to 5, got -1"),
        (Number(min=0, max=1e9), "1e9", "2e9", "a number from 0 to 1e+09, got 2e+09"),
        (Number(min=0, min_open=True), "1e-9", "0", "a number above 0, got 0"),
        (Number(max=1, max_open=True), "0.5", "1", "a number below 1, got 1"),
    ],
)
def test_a_number_out_of_range_is_refused_in_hybridlogs_words(kind, inside, outside, why):
    # click said "0 is not in the range x>=1", unlike "expected a whole number, got 'x'";
    # --help says the range in the same words ("[at least 1]", not "[x>=1]")
    import click

    assert kind.convert(inside, None, None) == float(inside)
    with pytest.raises(click.BadParameter) as refused:
        kind.convert(outside, None, None)
    assert refused.value.message == f"expected {why}"
    assert kind._describe_range() in why
