"""A model file as text: numbers no double holds, TOML errors, encodings, hand-edited values.

Each error is one line that starts with the file and names the key (or, for text that is not
TOML, the line); a number the loader cannot hold as written is refused, never read as another.
"""

from __future__ import annotations

import re

import pytest

from hybridlog.errors import ModelError
from hybridlog.model.builtins import builtin_text
from hybridlog.model.loader import load_model, parse_model
from tests.support.model_text import edited as _replace
from tests.support.model_text import refused as _refused
from tests.support.models import LINEAR_TWO_MODE, PENDULUM_ONE_MODE

PRIOR = "mode_probabilities = [0.6, 0.4]"
MEASUREMENT = "measurement = [[0.05, 0.01], [0.01, 0.08]]"
BIG = "1" + "0" * 400
"""A TOML integer beyond the largest double (float() of it raised OverflowError)."""


@pytest.mark.parametrize(
    ("old", "new", "key"),
    [
        ("dt = 0.1", "dt = 1e-400", "dt"),
        (MEASUREMENT, "measurement = 1e-400", r"noise\.measurement"),
        ("process = [0.01, 0.02]", "process = [0.01, 1e-310]", r"noise\.process\[1\]"),
        ("state = [0.0, 0.0]", "state = [0.0, -1e-400]", r"simulation\.state\[1\]"),
        ("matrix = [[0.97, 0.03], [0.05, 0.95]]", "stay = 1e-400", r"transitions\.stay"),
        ("[noise]", "[estimators.imm]\nrho = 1e-400\n\n[noise]", r"estimators\.imm\.rho"),
    ],
)
def test_a_number_below_the_smallest_double_is_refused_naming_its_key(old, new, key):
    # tomllib reads 1e-400 as 0.0: a measurement noise of 1e-400 was a noiseless sensor, a
    # transition probability 0, a dt "must be positive, got 0.0" (of a positive number).
    message = _refused(_replace(LINEAR_TWO_MODE, old, new), key + r": '-?1e-[34]\d0' is smaller")
    assert "write 0 or a larger number" in message


@pytest.mark.parametrize(
    ("old", "new", "key", "what"),
    [
        ("dt = 0.1", f"dt = {BIG}", "dt", "a whole number of 401 digits"),
        ("state = [0.5, -0.2]", f"state = [0.5, -{BIG}]", r"initial\.state\[1\]", "a whole"),
        ("dt = 0.1", "dt = 1e400", "dt", "'1e400'"),
        (
            "process = [0.01, 0.02]",
            "process = [[1e309, 0], [0, 1]]",
            r"noise\.process\[0\]\[0\]",
            "'1e309'",
        ),
    ],
)
def test_a_number_beyond_the_largest_double_is_refused_naming_its_key(old, new, key, what):
    # A 400-digit integer crashed the loader with OverflowError (a traceback, exit 1).
    message = _refused(_replace(LINEAR_TWO_MODE, old, new), key + ": " + what)
    assert "is beyond the largest double" in message


@pytest.mark.parametrize(
    ("old", "new", "what"),
    [
        # tomllib's int() refuses a decimal literal of more than 4,300 digits (ValueError
        # "Exceeds the limit ... for integer string conversion"), before any key is known
        ("dt = 0.1", "dt = 1" + "0" * 5000, "line 3: a whole number of 5,001 digits"),
        ("state = [0.5, -0.2]", "state = [0.5, -1" + "_0" * 4400 + "]", "line 25: a whole"),
        # a hex literal int() reads, but whose decimal digits str() refuses to write
        ("dt = 0.1", "dt = 0x" + "f" * 4000, "dt: a whole number of more than 4,300 digits"),
    ],
)
def test_an_integer_of_more_digits_than_python_converts_is_refused_naming_its_line(old, new, what):
    # Before: "unexpected ValueError in toml_text.py" (a bug, exit 2) for both
    message = _refused(_replace(LINEAR_TWO_MODE, old, new), re.escape(what))
    assert "is beyond the largest double" in message and len(message) < 300


@pytest.mark.parametrize(
    ("expression", "written"), [("1e-400*u", "'1e-400'"), (f"{BIG}*u", "a whole number")]
)
def test_an_expression_number_no_double_holds_is_refused(expression, written):
    # "x1 + 1e-400*u" was "x1": Python's parser reads the literal as 0.0.
    text = _replace(PLANT, '"0.9*x + u"', f'"0.9*x + {expression}"')
    _refused(text, r"modes\.a\.f\[0\]: " + written)


@pytest.mark.parametrize("literal", ["9" * 5000, "1" + "0" * 4300])
def test_an_expression_integer_of_more_digits_than_python_reads_is_refused_as_any_big_one(
    literal,
):
    # Python's parser refused it with "Exceeds the limit (4300 digits) ... use
    # sys.set_int_max_str_digits() to increase the limit": advice for a program, not a file
    text = _replace(PLANT, '"0.9*x + u"', f'"0.9*x + {literal}*u"')
    digits = f"{len(literal):,}"
    message = _refused(text, rf"modes\.a\.f\[0\]: a whole number of {digits} digits is beyond")
    assert "sys." not in message and len(message) < 300


PLANT = """\
dt = 1.0
states = ["x"]
inputs = ["u"]
outputs = ["y"]

[modes.a]
f = ["0.9*x + u"]
h = ["x"]

[modes.b]
f = ["0.5*x"]
h = ["x"]

[initial]
state = [0.0]
"""


@pytest.mark.parametrize("value", ["0.0", "-0.0", "0e-400", "2.3e-308", "1.7e308", "1e-300"])
def test_numbers_a_double_holds_are_read(value):
    model = parse_model(_replace(PLANT, "state = [0.0]", f"state = [{value}]"))
    assert model.initial_state[0] == float(value)


@pytest.mark.parametrize(
    ("text", "line", "shown"),
    [
        # tomllib: "Cannot overwrite a value (at end of document)", without the key or line
        (PLANT + "[noise]\nmeasurement = 1\nmeasurement = 2\n\n", 18, "'measurement = 2'"),
        (_replace(PLANT, "dt = 1.0", "dt = 1.0\ndt = 2.0"), 2, "'dt = 2.0'"),
        (PLANT.replace("\n", "\r\n") + "[modes.a]\r\nh = ['x']\r\n", 16, "'[modes.a]'"),
        ("\ufeffdt = 1\ndt = 1\n", 2, "'dt = 1'"),
    ],
)
def test_a_key_or_table_given_twice_names_the_line_and_its_text(text, line, shown):
    message = _refused(text, rf"line {line}: invalid TOML: ")
    assert ("given twice" in message or "declared twice" in message) and shown in message


def test_an_empty_file_says_so():
    # was "m.toml: dt: required key is missing"
    _refused("\n# nothing yet\n", r"no keys \(an empty model file\?\)")


def test_a_file_that_is_not_utf8_names_the_line_of_the_bad_byte(tmp_path):
    path = tmp_path / "plant.toml"
    path.write_bytes(PLANT.encode() + b"# caf\xe9\n")  # a Latin-1 comment on line 16
    with pytest.raises(ModelError, match=r"plant\.toml: line 16: not UTF-8 \(byte 0xe9\)"):
        load_model(path)
    path.write_bytes(b"\xff\xfe" + PLANT.encode("utf-16-le"))  # Notepad's "Unicode"
    with pytest.raises(ModelError, match=r"plant\.toml: not UTF-8: the file is UTF-16"):
        load_model(path)


@pytest.mark.parametrize(
    ("value", "pattern"),
    [
        # was "wrong shape; expected 2x2 instead of 2x2"
        ("[[1, 0], [0]]", r"noise\.measurement\[1\]: wrong length of a row of the 2x2 matrix; "),
        ("[[1, 0.5], [0, 1]]", r"noise\.measurement: .*symmetric; \[0\]\[1\] is 0\.5 but \[1\]"),
        (
            "[[1, 2], [2, 1]]",
            r"noise\.measurement: .*semi-definite \(its smallest eigenvalue is -1\)",
        ),
    ],
)
def test_a_bad_covariance_names_what_is_wrong(value, pattern):
    _refused(_replace(LINEAR_TWO_MODE, MEASUREMENT, f"measurement = {value}"), pattern)


@pytest.mark.parametrize(
    ("old", "new", "pattern"),
    [
        # was "unknown mode 'True'" and "unknown mode '['slow']'"
        (PRIOR, "mode = true", r"initial\.mode: expected a mode id .*, got true$"),
        (PRIOR, 'mode = ["slow"]', r"initial\.mode: expected a mode id"),
        # was "probabilities must be non-negative and sum to 1", for either
        (
            PRIOR,
            "mode_probabilities = [1.5, -0.5]",
            r"initial\.mode_probabilities: probabilities must be non-negative; "
            r"mode 'fast' has -0\.5",
        ),
        (
            PRIOR,
            "mode_probabilities = [0.3, 0.3]",
            r"initial\.mode_probabilities: probabilities must sum to 1; they sum to 0\.6 "
            r"\(modes in order: slow, fast\)",
        ),
    ],
)
def test_initial_modes_name_what_is_wrong(old, new, pattern):
    _refused(_replace(LINEAR_TWO_MODE, old, new), pattern)


@pytest.mark.parametrize(
    ("old", "new", "pattern"),
    [
        # were "the constant 'True' is not allowed in a model expression", quoting a spelling
        # the file never had
        (
            'a = "sin(0.7*t) + 0.5*cos(0.13*t)"',
            "a = true",
            r"simulation\.inputs\.a: expected an expression string, got bool$",
        ),
        ("state = [0.0, 0.0]", "state = [0.0, false]", r"simulation\.state\[1\]: .*got false$"),
        ("dt = 0.1", "dt = 0.1\ntime = true", r"time: expected .*, got true$"),
    ],
)
def test_a_toml_boolean_is_named_as_the_file_spells_it(old, new, pattern):
    _refused(_replace(LINEAR_TWO_MODE, old, new), pattern)


def test_a_toml_boolean_in_a_mode_function_is_no_expression():
    text = _replace(PENDULUM_ONE_MODE, 'h = ["sin(theta)",', "h = [true,")
    _refused(text, r"modes\.only\.h\[0\]: expected an expression string, got bool$")


def test_a_number_written_as_an_expression_is_that_number():
    text = _replace(LINEAR_TWO_MODE, 'a = "sin(0.7*t) + 0.5*cos(0.13*t)"', "a = 0.25")
    assert float(parse_model(text).simulation_inputs["a"]) == 0.25


def test_an_edited_builtin_names_the_reference_a_renamed_mode_left():
    text = builtin_text("ice_clutch").replace("[modes.0]", "[modes.off]")
    _refused(text.replace('mode = "0"', 'mode = "off"'), r'jumps\."0->1": unknown mode \'0\'')


@pytest.mark.parametrize(
    ("old", "new", "key"),
    [
        ('light_cmd = "1"', 'light_cmd = "1e-400"', r"simulation\.commands\.light_cmd"),
        ("when = {light_cmd = 0}", "when = {light_cmd = 1e-400}", r"components\.ls\.transitions"),
        ("unknown = 0.001", "unknown = 1e-400", r"components\.fr1\.unknown"),
    ],
)
def test_a_components_value_no_double_holds_is_refused(old, new, key):
    # each was read as 0: a scenario's command value, a rule's condition, a fault rate
    _refused(_replace(builtin_text("bioplex_pgc"), old, new), key + r".*: '1e-400' is smaller")


def test_a_schedule_naming_a_mode_the_file_lacks_is_refused_when_loaded():
    # A copy of three_tank_hstf with mode 3 renamed or removed loaded, and analyze ran on it;
    # only simulate named the stale schedule.
    tank = builtin_text("three_tank_hstf")
    renamed = _replace(tank, "[modes.3]", "[modes.three]")
    removed = re.sub(r"\[modes\.3\].*?\nh = [^\n]*\n", "", tank, flags=re.DOTALL)
    assert "[modes.3]" not in removed and "[modes.2]" in removed
    for text in (renamed, removed):
        _refused(text, r"simulation\.schedule: unknown mode '3'")


@pytest.mark.parametrize(
    ("value", "pattern"),
    [
        ("x = " + "[" * 5000 + "]" * 5000, r"invalid TOML: arrays or tables nested too deeply"),
        ("x = " + "{a = " * 5000 + "1" + "}" * 5000, r"invalid TOML: arrays or tables nested"),
        (".".join(["parameters"] + ["a"] * 5000) + " = 1", r"parameters(\.a){32}: nested more"),
    ],
)
def test_a_value_nested_thousands_deep_is_refused_in_one_line(value, pattern):
    # was "unexpected RecursionError" (tomllib on the arrays; the loader on the dotted key)
    _refused(value + "\n" + PLANT, pattern)


@pytest.mark.parametrize(
    ("blank", "shown", "named"),
    [
        ("\u00a0", r"'\xa0dt = 0.1'", "U+00A0 (no-break space)"),
        ("\u2003", r"'\u2003dt = 0.1'", "U+2003 (em space)"),
        ("\r", r"'\rdt = 0.1'", "U+000D (carriage return)"),
    ],
)
def test_a_blank_toml_does_not_read_is_shown_and_named_in_the_invalid_line(blank, shown, named):
    # str.strip() took it away from the quoted line: "Invalid statement: 'dt = 0.1'", a line
    # that looks valid (a no-break space pasted from a web page), or no line at all
    message = _refused(_replace(LINEAR_TWO_MODE, "dt = 0.1", blank + "dt = 0.1"), r"line \d+: ")
    assert message.endswith(shown) and named in message
    # a line of it alone was quoted as nothing: "line 3: invalid TOML: Invalid statement"
    alone = _refused(_replace(LINEAR_TWO_MODE, "dt = 0.1", f"dt = 0.1\n{blank} "), r"line \d+: ")
    assert named in alone


def test_crlf_line_ends_are_not_named_in_an_invalid_line():
    text = _replace(LINEAR_TWO_MODE, "dt = 0.1", "dt =").replace("\n", "\r\n")
    message = _refused(text, r"line \d+: invalid TOML: Invalid value: 'dt ='$")
    assert "U+000D" not in message
