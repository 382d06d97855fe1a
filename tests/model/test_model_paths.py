"""How a model file names log fields: ``[signals]``, ``[truth]`` and the symbols they map."""

import numpy as np
import pytest

from hybridlog.cli import main
from hybridlog.errors import ModelError
from hybridlog.io import SignalSpec, load_signals, write_table
from hybridlog.io.mapping import DEFAULT_MODE_FIELD
from hybridlog.io.table_times import TIME_COLUMNS
from hybridlog.model.expressions import symbol_name_problem
from hybridlog.model.loader import parse_model
from hybridlog.model.log_fields import _LOG_FIELD_NAMES, _report_columns
from hybridlog.simulate import simulate
from tests.support.models import LINEAR_TWO_MODE

# LINEAR_TWO_MODE: states p, v; input a; outputs y1, y2; modes slow, fast.


def _with(model: str, table: str) -> str:
    return model + "\n" + table + "\n"


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
        parse_model(_with(LINEAR_TWO_MODE, table), origin="plant.toml")


def test_the_allowed_keys_of_a_large_model_stay_a_short_line():
    outputs = [f"y{i}" for i in range(300)]
    text = (
        LINEAR_TWO_MODE.replace('outputs = ["y1", "y2"]', f"outputs = {outputs}".replace("'", '"'))
        .replace("C = [[1.0, 0.0], [0.0, 1.0]]", f"C = {[[1.0, 0.0]] * 300}")
        .replace("C = [[1.0, 0.0], [0.5, 2.0]]", f"C = {[[1.0, 0.0]] * 300}")
        .replace("measurement = [[0.05, 0.01], [0.01, 0.08]]", "measurement = 0.05")
    )
    with pytest.raises(ModelError) as caught:
        parse_model(_with(text, '[signals]\nz = "/z.data"'), origin="plant.toml")
    line = str(caught.value)
    assert line.startswith("plant.toml: signals.z: not an input or output of the model")
    assert line.endswith("y10 and 289 more)") and len(line) < 200, line


def test_every_key_the_loader_accepts_is_read_from_the_log(tmp_path):
    # Each accepted key names a column no default would find: the log is read only if
    # every one of them is used, and the values are those of the renamed columns.
    model = parse_model(
        _with(
            LINEAR_TWO_MODE,
            '[signals]\na = "force N"\ny1 = "pos"\ny2 = "vel"\n'
            '[truth]\nmode = "phase"\np = "pos_true"\nv = "vel_true"',
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


@pytest.mark.parametrize(
    ("old", "new", "group", "name"),
    [
        ('states = ["p", "v"]', 'states = ["p", "mode"]', "states", "mode"),
        ('inputs = ["a"]', 'inputs = ["mode"]', "inputs", "mode"),
        ('outputs = ["y1", "y2"]', 'outputs = ["y1", "time"]', "outputs", "time"),
        ('states = ["p", "v"]', 'states = ["time", "v"]', "states", "time"),
    ],
)
def test_a_symbol_named_like_a_field_a_log_gives_another_meaning_is_refused(old, new, group, name):
    # A state 'mode' was read from the true mode's column, and the true mode from the
    # state's numbers: the log was refused ("truth.mode '0.0' is not a mode"), and simulate
    # wrote one 'mode' column for both.
    text = LINEAR_TWO_MODE.replace(old, new, 1)
    with pytest.raises(
        ModelError, match=rf"^plant\.toml: {group}: '{name}' is .* log .*cannot be a symbol name$"
    ):
        parse_model(text, origin="plant.toml")


def test_the_refused_field_names_are_the_logs_own():
    # the loader cannot import io (peers): its list must follow io's names
    assert set(TIME_COLUMNS) - {"t"} | {DEFAULT_MODE_FIELD} == set(_LOG_FIELD_NAMES)
    assert symbol_name_problem("t") is not None  # t is refused by the grammar already


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            'outputs = ["y1", "y2"]',
            'outputs = ["y1", "p_var"]',
            r"outputs: estimates column 'p_var' would hold both the variance of state 'p' and "
            r"the measurement of output 'p_var'; rename one of them$",
        ),
        (
            'outputs = ["y1", "y2"]',
            'outputs = ["y1", "v_true"]',
            r"outputs: estimates column 'v_true' would hold both the true value of state 'v'",
        ),
        (
            'outputs = ["y1", "y2"]',
            'outputs = ["y1", "p_hat_filtered"]',
            r"outputs: estimates column 'p_hat_filtered' would hold both the filtered estimate",
        ),
        (
            'outputs = ["y1", "y2"]',
            'outputs = ["y1", "y1_hat"]',
            r"outputs: estimates column 'y1_hat' would hold both the prediction of output 'y1' "
            r"and the measurement of output 'y1_hat'",
        ),
        (
            "[modes.fast]",
            "[modes.slow_filtered]",
            r"modes\.slow: timeline column 'p_slow_filtered' would hold both the probability of "
            r"mode 'slow_filtered' and the filtered probability of mode 'slow'",
        ),
    ],
)
def test_names_whose_report_columns_coincide_are_refused(old, new, message):
    # The later column silently replaced the first: estimates.csv's p_var held the output,
    # and the variance of p was nowhere.
    with pytest.raises(ModelError, match=r"^plant\.toml: " + message):
        parse_model(LINEAR_TWO_MODE.replace(old, new, 1), origin="plant.toml")


def test_names_whose_columns_live_in_different_tables_are_kept():
    # p_slow is an estimates column (an output) and a timeline column (a mode probability)
    model = parse_model(
        LINEAR_TWO_MODE.replace('outputs = ["y1", "y2"]', 'outputs = ["y1", "p_slow"]')
    )
    assert model.outputs == ("y1", "p_slow")


def test_the_checked_columns_are_those_a_smoothed_run_writes(tmp_path):
    model_path = tmp_path / "plant.toml"
    model_path.write_text(LINEAR_TWO_MODE)
    model = parse_model(LINEAR_TWO_MODE)
    log = tmp_path / "run.csv"
    main(["simulate", str(model_path), "--out", str(log), "--steps", "60", "-q"])
    out = tmp_path / "report"
    analyze = ["analyze", str(log), "--model", str(model_path), "--estimator", "imm"]
    main([*analyze, "--smooth", "--out", str(out), "-q"])
    expected: dict[str, set[str]] = {"timeline": set(), "estimates": set()}
    for table, column, _, _ in _report_columns(model.states, model.outputs, model.mode_ids):
        expected[table].add(column)
    for table, fixed in (
        ("timeline", {"t", "mode", "mode_filtered", "truth_mode"}),
        ("estimates", {"t"}),
    ):
        header = (out / f"{table}.csv").read_text().splitlines()[0].split(",")
        assert set(header) == expected[table] | fixed


@pytest.mark.parametrize(
    ("given", "meant"),
    [
        ("three_tank", "three_tank_hstf"),
        ("Three_Tank_HSTF", "three_tank_hstf"),
        (" ice_clutch", "ice_clutch"),
        ("doublecart_case1", "double_cart_case1"),
    ],
)
def test_a_model_name_close_to_a_built_in_is_suggested(tmp_path, monkeypatch, given, meant):
    # --model three_tank listed the built-ins without a word; --estimator Imm suggests imm
    from hybridlog.model.cache import model_file

    monkeypatch.chdir(tmp_path)
    with pytest.raises(ModelError, match=rf"\(built-ins: [^)]*\); did you mean '{meant}'\?$"):
        model_file(given)
    with pytest.raises(ModelError, match=r"\(built-ins: [^)]*\)$"):
        model_file("xyz")


def test_a_model_link_to_nothing_or_a_loop_is_said_so(tmp_path):
    # --model LINK said "LINK: neither a model file nor a built-in model (built-ins: ...)"
    from hybridlog.model.cache import model_file

    (tmp_path / "dangling.toml").symlink_to("gone.toml")
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    with pytest.raises(ModelError, match=r"dangling.toml: a symbolic link to 'gone.toml', which"):
        model_file(tmp_path / "dangling.toml")
    with pytest.raises(ModelError, match=r"/a: cannot be read \(Too many levels of symbolic"):
        model_file(tmp_path / "a")


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".mcap", ".bag", ".db3", ".MCAP"])
def test_a_log_given_as_the_model_is_said_to_be_a_log(tmp_path, suffix):
    # analyze --model run.mcap MODEL said "line 1: not UTF-8 (byte 0x89); save the file as UTF-8"
    from hybridlog.model.cache import model_file

    log = tmp_path / f"run{suffix}"
    log.write_bytes(b"\x89MCAP0\r\n")
    with pytest.raises(ModelError, match=rf"run\{suffix}: a log \(\{suffix}\), not a model file"):
        model_file(log)
