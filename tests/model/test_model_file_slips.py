"""Slips a control engineer makes writing a model file, each refused naming what was meant.

An expression written as in MATLAB or sympy (``x^2``, ``Piecewise((x, x > 0), ...)``,
``(x > 0)*x``), a comment inside the quotes, a Markov matrix with a negative entry or a row
a little short of 1, a top-level key written below a table header: each was read as
something else or refused in words that pointed elsewhere.
"""

from __future__ import annotations

import re

import pytest
import sympy

from hybridlog.cli import main
from hybridlog.errors import ModelError
from hybridlog.model.expressions import parse_expression
from hybridlog.model.loader import parse_model
from hybridlog.simulate import simulate
from tests.support.model_text import edited as _replace
from tests.support.model_text import refused as _refused
from tests.support.models import LINEAR_TWO_MODE

X = {"x": sympy.Symbol("x", real=True), "u": sympy.Symbol("u", real=True)}
MATRIX = "matrix = [[0.97, 0.03], [0.05, 0.95]]"


@pytest.mark.parametrize(
    ("text", "said"),
    [
        # was "operator BitXor is not allowed in a model expression"
        ("x^2", r"'\^' is not a power .*write '\*\*'"),
        # was 0.9*x: Python's parser dropped the rest of the text as a comment
        ("0.9*x # + u", r"'0\.9\*x # \+ u' holds '#', which would silently drop the rest"),
        ("0.9*x + u  # leak", r".* holds '#'"),
        # was "Piecewise takes at least 3 arguments (2 given)"
        ("Piecewise((x, x > 0), (0, True))", r"Piecewise takes flat arguments"),
        # was sympy's "Relational cannot be used in Mul"
        ("(x > 0)*x", r"the comparison 'x > 0' is a condition, not a number"),
        ("sqrt(x > 0)", r"the comparison 'x > 0' is a condition"),
        ("-(x > 0)", r"the comparison 'x > 0' is a condition"),
        ("Piecewise(x, x > 0, x > 1)", r"the comparison 'x > 1' is a condition"),
        ("(x > 0) < 1", r"the comparison 'x > 0' is a condition"),
        # were "a IfExp expression", "a BoolOp expression", "comparison Eq", "operator Mod"
        ("x if x > 0 else 0", r"'a if condition else b' .*; write Piecewise\(a, condition, b\)"),
        ("Piecewise(x, x > 0 and u > 0, 0)", r"'and' .*; write Piecewise\(Piecewise\(a, x > 0"),
        ("Piecewise(x, x > 0 or u > 0, 0)", r"'or' .*; write Piecewise\(a, x > 0, a, u > 0, b\)"),
        ("Piecewise(x, not x > 0, 0)", r"'not' .*; write the opposite comparison"),
        ("Piecewise(x, x == 0, 0)", r"'==' is not a comparison of model .*; write <, <=, > or >="),
        ("x % 2", r"'%' \(remainder\) is not in the grammar of model expressions"),
        ("x // 2", r"'//' \(floor division\) is not in the grammar"),
        # was only Python's "unexpected indent": a TOML multi-line string keeps its breaks
        ("0.9*x\n + u", r"cannot parse .*: unexpected indent; a line break ends an expression"),
        ("0.9*x +\n u", r"cannot parse .*: invalid syntax; .*wrap it in \( \)"),
    ],
)
def test_an_expression_written_as_elsewhere_says_what_to_write(text, said):
    with pytest.raises(ModelError, match=r"^modes\.a\.f\[0\]: " + said):
        parse_expression(text, X, key="modes.a.f[0]")


@pytest.mark.parametrize("text", ["(0.9*x\n + u", "(0.9*x\n + * u)", "0.9*x +\n * u"])
def test_a_line_break_that_is_no_cause_gets_no_hint(text):
    """The hint came with every text holding a line break: '(0.9*x\\n + u' ("'(' was never
    closed") was told to wrap in ( ) what is wrapped; now only a text that parses with its
    line breaks as spaces gets it."""
    with pytest.raises(ModelError, match=r"^k: cannot parse ") as raised:
        parse_expression(text, X, key="k")
    assert "line break" not in str(raised.value)


def test_a_guard_broken_over_lines_gets_the_hint():
    """A guard is parsed apart from the other expressions, and said only "unexpected
    indent" for 'x\\n > 0' in a TOML multi-line string."""
    from hybridlog.model.mode_equations import mode_guard

    with pytest.raises(ModelError, match=r"^k: cannot parse 'x\\n > 0': unexpected indent; a "):
        mode_guard("x\n > 0", "k", X, {"x", "u"})


def test_a_line_break_inside_parentheses_still_parses():
    written = parse_expression("(0.9*x\n + u)", X, key="k")
    assert written == parse_expression("0.9*x + u", X, key="k")


def test_piecewise_and_comparisons_still_parse_where_they_belong():
    expr = parse_expression("Piecewise(x, x > 0, u, u > 1, 0) + Piecewise(1, x < u, 2)", X, key="k")
    assert float(expr.subs({X["x"]: 2.0, X["u"]: 3.0})) == 3.0
    both_sides = parse_expression("Piecewise(1, x + u <= 2*u, 0)", X, key="k")
    assert float(both_sides.subs({X["x"]: 2.0, X["u"]: 3.0})) == 1.0


@pytest.mark.parametrize(
    ("matrix", "said"),
    [
        # row 1 sums to 1: the row furthest from summing to 1 (row 0) was named
        (
            "matrix = [[0.97, 0.03], [1.05, -0.05]]",
            r"transitions\.matrix\[1\]\[1\]: a probability must be non-negative, got -0\.05 "
            r"\(from mode 'fast' to 'fast'\)",
        ),
        (
            "matrix = [[0.97, 0.13], [0.05, 0.95]]",
            r"transitions\.matrix\[0\]: each row must sum to 1; the row of mode 'slow' sums "
            r"to 1\.1$",
        ),
        # allclose's relative tolerance let 0.99999 through
        (
            "matrix = [[0.97, 0.03], [0.05, 0.94999]]",
            r"transitions\.matrix\[1\]: .* the row of mode 'fast' sums to 0\.99999$",
        ),
    ],
)
def test_a_markov_row_names_its_negative_entry_or_its_sum(matrix, said):
    _refused(_replace(LINEAR_TWO_MODE, MATRIX, matrix), said)


def test_a_markov_row_of_rounded_thirds_summing_to_one_is_read():
    text = LINEAR_TWO_MODE.replace(
        "[modes.fast]",
        "[modes.third]\nA = [[1.0, 0.1], [0.0, 0.9]]\n"
        "B = [[0.0], [0.1]]\nC = [[1.0, 0.0], [0.0, 1.0]]\n\n"
        "[modes.fast]",
    )
    text = _replace(text, "mode_probabilities = [0.6, 0.4]", 'mode = "slow"')
    rows = "[[0.333333, 0.333333, 0.333334], [0.1, 0.8, 0.1], [0.0, 0.05, 0.95]]"
    model = parse_model(_replace(text, MATRIX, f"matrix = {rows}"))
    assert model.transitions[0, 2] == 0.333334


def test_a_markov_matrix_keyed_by_mode_id_is_read_as_the_initial_probabilities_are():
    # was "transitions.matrix: expected a 2x2 matrix", though initial.mode_probabilities
    # takes a table keyed by mode id; a keyed row leaves the modes it does not name at 0
    keyed = "matrix = {fast = {slow = 0.05, fast = 0.95}, slow = [0.97, 0.03]}"
    model = parse_model(_replace(LINEAR_TWO_MODE, MATRIX, keyed))
    assert model.transitions.tolist() == [[0.97, 0.03], [0.05, 0.95]]
    sparse = "matrix = [{slow = 1.0}, {fast = 1}]"
    assert parse_model(_replace(LINEAR_TWO_MODE, MATRIX, sparse)).transitions.tolist() == [
        [1.0, 0.0],
        [0.0, 1.0],
    ]
    for matrix, said in [
        ("matrix = {slow = [0.97, 0.03]}", r"transitions\.matrix\.fast: the row of mode 'fast' "),
        (
            "matrix = {slow = [1, 0], fast = [0, 1], medium = [0, 1]}",
            r"transitions\.matrix\.medium: unknown ",
        ),
        (
            "matrix = {slow = {slow = 1, quick = 0}, fast = [0, 1]}",
            r"transitions\.matrix\.slow\.quick: unknown mode",
        ),
        (
            "matrix = {slow = {slow = 1.1, fast = -0.1}, fast = [0, 1]}",
            r"transitions\.matrix\.slow\.fast: a ",
        ),
        (
            "matrix = {slow = {slow = 0.9}, fast = [0, 1]}",
            r"transitions\.matrix\.slow: each row must sum",
        ),
        ("matrix = [[0.97, 0.03], [1]]", r"transitions\.matrix\[1\]: expected a row of 2 "),
        ("matrix = [[0.97, 0.03]]", r"transitions\.matrix: expected a 2x2 matrix"),
    ]:
        _refused(_replace(LINEAR_TWO_MODE, MATRIX, matrix), said)


def test_vectors_and_diagonals_keyed_by_state_or_output_name_are_read_in_the_models_order():
    # were refused ("expected a list of 2 numbers"), though the Markov matrix and the
    # initial mode probabilities take a table keyed by mode id
    text = _replace(LINEAR_TWO_MODE, "state = [0.5, -0.2]", "state = {v = -0.2, p = 0.5}")
    text = _replace(text, "process = [0.01, 0.02]", "process = {v = 0.02, p = 0.01}")
    text = _replace(
        text,
        "measurement = [[0.05, 0.01], [0.01, 0.08]]",
        "measurement = {y2 = 0.08, y1 = 0.05}",
    )
    text = _replace(text, "state = [0.0, 0.0]", "state = {p = 0.0, v = 1.5}")
    text = _replace(text, "process_noise = [[0.02", "process_noise = {p = 0.02, v = 0.03}\n#[[0.02")
    model = parse_model(text)
    plain = parse_model(LINEAR_TWO_MODE)
    assert model.initial_state.tolist() == plain.initial_state.tolist() == [0.5, -0.2]
    assert model.modes[0].process_noise.tolist() == [[0.01, 0.0], [0.0, 0.02]]
    assert model.modes[1].process_noise.tolist() == [[0.02, 0.0], [0.0, 0.03]]
    assert model.modes[0].measurement_noise.tolist() == [[0.05, 0.0], [0.0, 0.08]]
    assert model.simulation_state is not None and model.simulation_state.tolist() == [0.0, 1.5]
    for given, said in [
        ("state = {p = 0.5}", r"initial\.state: no value for state 'v'; a table keyed by state "),
        ("state = {p = 0.5, v = 0, w = 1}", r"initial\.state\.w: unknown state \(states: p, v\)"),
        ("state = {p = 0.5, v = 'a'}", r"initial\.state\.v: "),
    ]:
        _refused(_replace(LINEAR_TWO_MODE, "state = [0.5, -0.2]", given), said)
    _refused(
        _replace(LINEAR_TWO_MODE, "process = [0.01, 0.02]", "process = {p = 0.1, y1 = 1}"),
        r"noise\.process\.y1: unknown state \(states: p, v\)",
    )
    _refused(
        _replace(
            LINEAR_TWO_MODE,
            "measurement = [[0.05, 0.01], [0.01, 0.08]]",
            "measurement = {y1 = 0.1, p = 1}",
        ),
        r"noise\.measurement\.p: unknown output \(outputs: y1, y2\)",
    )


def test_a_full_covariance_keyed_by_name_is_read_in_the_models_order():
    # a diagonal could be keyed by state or output name, a full matrix not: "expected a
    # list of 2 numbers" of a table of rows
    keyed = "measurement = {y2 = {y2 = 0.08, y1 = 0.01}, y1 = [0.05, 0.01]}"
    text = _replace(LINEAR_TWO_MODE, "measurement = [[0.05, 0.01], [0.01, 0.08]]", keyed)
    model, plain = parse_model(text), parse_model(LINEAR_TWO_MODE)
    assert model.modes[0].measurement_noise.tolist() == [[0.05, 0.01], [0.01, 0.08]]
    assert model.modes[0].measurement_noise.tolist() == plain.modes[0].measurement_noise.tolist()
    for given, said in [
        (
            "{y1 = [0.05, 0.01], y2 = {y2 = 0.08}}",
            r"noise\.measurement\.y2: no value for output 'y1'",
        ),
        ("{y1 = [0.05, 0.01], y2 = 0.08}", r"noise\.measurement\.y2: expected a list of 2 numbers"),
        ("{y1 = [0.05, 0.01]}", r"noise\.measurement: no value for output 'y2'"),
        (  # named as written (was "[0][1] is 0.02 but [1][0] is 0.01", places never written)
            "{y1 = [0.05, 0.02], y2 = [0.01, 0.08]}",
            r"noise\.measurement: covariance must be symmetric; y1\.y2 is 0\.02 but y2\.y1 is",
        ),
        ("{y1 = {y1 = 1, p = 0}, y2 = [0, 1]}", r"noise\.measurement\.y1\.p: unknown output"),
    ]:
        _refused(
            _replace(
                LINEAR_TWO_MODE,
                "measurement = [[0.05, 0.01], [0.01, 0.08]]",
                f"measurement = {given}",
            ),
            said,
        )


def test_the_sample_time_below_a_table_header_is_named_where_it_is():
    # was "dt: required key is missing", of a file that has it
    text = _replace(LINEAR_TWO_MODE, "dt = 0.1\n", "")
    text = _replace(text, "[initial]\n", "[initial]\ndt = 0.1\n")
    message = _refused(text, r"initial\.dt: 'dt' is a top-level key, but written below ")
    assert "the [initial] header, it belongs to that table" in message


@pytest.mark.parametrize(
    ("table", "key", "value"),
    [
        ("[noise]", "time", '"discrete"'),
        ("[transitions]", "default_estimator", '"imm"'),
        ("[modes.fast]", "inputs", '["a"]'),
        ("[simulation]", "dt", "0.1"),
    ],
)
def test_every_fixed_table_names_a_top_level_key_written_in_it(table, key, value):
    # `time = "continuous"` below [noise] gave a discrete-time model and a misleading
    # "dx needs time = 'continuous'"; `default_estimator` below [transitions] an unknown key
    text = LINEAR_TWO_MODE.replace(f"{key} = ", "# ", 1)
    text = _replace(text, f"{table}\n", f"{table}\n{key} = {value}\n")
    where = table.strip("[]")
    _refused(text, rf"{where}\.{key}: '{key}' is a top-level key, but written below")


@pytest.mark.parametrize(
    "table",
    ["[estimators.imm]\nbeam = 5\n", '[signals]\na = "/a.data"\n', '[truth]\np = "/p.data"\n'],
)
def test_a_top_level_key_appended_below_the_last_table_is_named_where_it_is(table):
    # a file ending with [estimators.imm] took the default_estimator appended to it for an
    # option: "imm has no option 'default_estimator'"; below [signals], "not an input or output"
    text = LINEAR_TWO_MODE.replace('default_estimator = "imm"\n', "", 1)
    text += f'\n{table}default_estimator = "imm"\n'
    where = re.escape(table.split("]")[0][1:])
    _refused(text, rf"{where}\.default_estimator: 'default_estimator' is a top-level key, but")


def test_no_estimator_option_is_named_like_a_top_level_key():
    # the loader (which cannot import the estimators) refuses every top-level key written in
    # an [estimators.<name>] table as misplaced: right only while no option is so named
    from hybridlog.estimators import ESTIMATORS
    from hybridlog.model.file_keys import TOP_KEYS

    options = {i.name for e in ESTIMATORS.values() for i in e.describe_options()}
    assert options and not options & TOP_KEYS


def test_a_required_key_found_in_a_parameter_table_is_named():
    text = _replace(LINEAR_TWO_MODE, "dt = 0.1\n", "")
    text = _replace(text, "[noise]\n", "[parameters]\ng = 9.81\ndt = 0.1\n\n[noise]\n")
    _refused(text, r"dt: required key is missing \(the file has parameters\.dt: a key written")


def test_a_sub_table_of_a_mode_is_no_misplaced_key():
    text = _replace(LINEAR_TWO_MODE, "[noise]\n", "[modes.fast.noise]\nprocess = 0.1\n\n[noise]\n")
    _refused(text, r"modes\.fast\.noise: unknown key \(allowed: .*process_noise")


@pytest.mark.parametrize(
    ("old", "new", "said"),
    [
        ('a = "sin(0.7*t) + 0.5*cos(0.13*t)"', 'a = "t^2"', r"simulation\.inputs\.a: '\^'"),
        (MATRIX, "matrix = [[0.97, 0.03], [1.05, -0.05]]", r"transitions\.matrix\[1\]\[1\]: "),
        ("dt = 0.1\n", "", r"initial\.dt: 'dt' is a top-level key"),
    ],
)
def test_cli_names_each_slip_in_one_line_and_writes_nothing(tmp_path, capsys, old, new, said):
    text = _replace(LINEAR_TWO_MODE, old, new)
    if "dt" in said:  # the sample time written below [initial]
        text = _replace(text, "[initial]\n", "[initial]\ndt = 0.1\n")
    path = tmp_path / "plant.toml"
    path.write_text(text)
    out = tmp_path / "sim.csv"
    with pytest.raises(SystemExit) as exit_:
        main(["simulate", str(path), "--out", str(out), "--steps", "3"])
    assert exit_.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"hybridlog: error: {path}: "), lines
    assert re.search(said, lines[0]), lines
    assert not out.exists()


BOOLEAN_TANK = """\
time = "continuous"
dt = 0.1
integration = {method = "rk4", step = 0.1}
booleans = ["U"]
states = ["h"]
inputs = ["q"]
outputs = ["y"]

[dynamics]
dx = ["q - 0.5*sqrt(abs(h))*U"]
h = ["h"]

[noise]
measurement = 0.01

[initial]
state = [1.0]
"""


@pytest.mark.parametrize(
    ("dx", "said"),
    [
        # ∂/∂U of the Piecewise is 0: the split G + D·δ lost the valve, the modes had it
        ('"q - Piecewise(0.5*sqrt(abs(h)), U > 0.5, 0)"', r"a boolean appears inside Piecewise"),
        ('"q - 0.5*sqrt(abs(h))*U**2"', r"U\*\*2 is a power of booleans"),
        ('"q - 0.5*sqrt(abs(h)*U)"', r"a boolean appears inside sqrt"),
    ],
)
def test_a_boolean_used_other_than_as_a_factor_is_refused(dx, said):
    text = _replace(BOOLEAN_TANK, '"q - 0.5*sqrt(abs(h))*U"', dx)
    _refused(text, r"dynamics\.dx\[0\]: not affine in the booleans \(" + said)


def test_a_boolean_affine_model_still_loads():
    model = parse_model(BOOLEAN_TANK)
    assert model.mode_ids == ("0", "1")


def test_cli_refuses_a_boolean_inside_a_piecewise(tmp_path, capsys):
    path = tmp_path / "tank.toml"
    dx = '"q - Piecewise(0.5*sqrt(abs(h)), U > 0.5, 0)"'
    path.write_text(_replace(BOOLEAN_TANK, '"q - 0.5*sqrt(abs(h))*U"', dx))
    out = tmp_path / "sim.csv"
    with pytest.raises(SystemExit) as exit_:
        main(["simulate", str(path), "--out", str(out), "--steps", "3"])
    assert exit_.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and f"{path}: dynamics.dx[0]: not affine" in lines[0], lines
    assert not out.exists()


ROOT = """\
dt = 0.1
states = ["x"]
outputs = ["y"]

[modes.a]
f = ["F"]
h = ["H"]

[modes.b]
A = [[0.5]]
C = [[1.0]]

[noise]
process = 0.0
measurement = 0.0

[initial]
state = [1.0]
covariance = 1.0
"""


@pytest.mark.parametrize(
    ("f", "h", "said"),
    [
        # each was "the simulation diverged: x = nan at t = 0.2 s", naming no key
        ("x**(1/3) - 2", "x", r"modes\.a\.f\[0\]: 'x\*\*\(1/3\) - 2' is nan at x = -1, the step "),
        ("log(x) + 0.5", "x", r"modes\.a\.f\[0\]: 'log\(x\) \+ 0\.5' is nan at x = -0\.193147"),
        (
            "x - 0.5",
            "sqrt(x)",
            r"modes\.a\.h\[0\]: 'sqrt\(x\)' is nan at x = -0\.5, at t = 0\.3 s ",
        ),
    ],
)
def test_a_discrete_expression_leaving_its_domain_is_named(f, h, said):
    text = ROOT.replace('"F"', f'"{f}"').replace('"H"', f'"{h}"')
    with pytest.raises(ModelError, match=r"^m\.toml: " + said) as caught:
        simulate(parse_model(text, origin="m.toml"), steps=5)
    assert "the simulation diverged; nothing was written" in str(caught.value)


def test_a_discrete_expression_of_a_scheduled_mode_is_named_in_that_mode():
    # x(k) = f_q(k)(x(k-1)): the step into row 3 is mode a's, from b's x = 0.25 at row 2
    text = ROOT.replace('"F"', '"log(x - 1)"').replace('"H"', '"x"')
    said = (
        r"^m\.toml: modes\.a\.f\[0\]: 'log\(x - 1\)' is nan at x = 0\.25, the step from t = 0\.2 s"
    )
    with pytest.raises(ModelError, match=said):
        simulate(parse_model(text, origin="m.toml"), steps=6, schedule="b:2,a:1")


def test_cli_names_a_discrete_expression_leaving_its_domain(tmp_path, capsys):
    path = tmp_path / "plant.toml"
    path.write_text(ROOT.replace('"F"', '"log(x) + 0.5"').replace('"H"', '"x"'))
    out = tmp_path / "sim.parquet"
    with pytest.raises(SystemExit) as exit_:
        main(["simulate", str(path), "--out", str(out), "--steps", "5"])
    assert exit_.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and f"{path}: modes.a.f[0]: 'log(x) + 0.5' is nan" in lines[0], lines
    assert not out.exists()
