"""Every estimator's options under the one rule: what a hostile pass over all of them found.

``--set rho=1e-400`` said "expected a finite number" where the model file's ``rho = 1e-400``
said why (a double does not hold it); a table was checked value by value, so a combination
(``candidates`` below the default beam, ``accept`` below the default ``reject``) or a value
the model cannot take (two eigenvalues for three states, an unknown mode id) passed when
another estimator ran, and was refused, naming neither the file nor the key, only as its own
estimator ran; chiu's ``squash = 1`` and ``reject = 0`` were within their documented ranges
and refused by the clustering alone; a ``centers`` path naming a folder was refused only by
the job reading it, without ``--set centers=``.
"""

from pathlib import Path

import pytest

from hybridlog.errors import ModelError, OptionError
from hybridlog.estimators.filter_options import HstfOptions
from hybridlog.estimators.hybrid_observer_options import SwitchingObserverOptions
from hybridlog.estimators.observer_options import ChiuOptions
from hybridlog.estimators.options import OptionSource, describe_options, parse_options
from hybridlog.estimators.registry import ESTIMATORS, resolve_estimator
from hybridlog.model.builtins import builtin_text
from hybridlog.model.loader import parse_model
from tests.support.cli import run_main

TANK = builtin_text("three_tank_hstf")
CART = builtin_text("double_cart_case1")


def _set(cls, name, text, estimator="e"):
    """``--set name=text`` parsed as an option of ``cls``."""
    source = OptionSource.command_line("--set", name, text)
    return parse_options(cls, {name: text}, estimator=estimator, sources={name: source})


def _table(text, table, lines):
    """The model ``text`` with ``[estimators.<table>]`` holding ``lines``, checked."""
    model = parse_model(f"{text}\n[estimators.{table}]\n{lines}\n", origin="m.toml")
    return resolve_estimator(model, None)


@pytest.mark.parametrize("text", ["1e-400", "-1e-310"])
def test_a_number_a_double_cannot_hold_is_said_so_on_the_command_line(text):
    with pytest.raises(OptionError) as err:
        _set(HstfOptions, "rho", text, "hstf")
    assert str(err.value).startswith(
        f"--set rho={text}: hstf option 'rho': expected a number a double holds in full"
    )


@pytest.mark.parametrize(
    ("text", "table", "lines", "named"),
    [
        # a combination, with the default of the option the table leaves out
        (TANK, "unknown-mode", "candidates = 5", "estimators.unknown-mode.candidates: "),
        (CART, "chiu", "accept = 0.1", "estimators.chiu.accept: chiu option 'reject': 0.15 is "),
        # a value the model cannot take
        (TANK, "switching-observer", 'eigenvalues = "-1,-2"', "the model has 3 states, so give"),
        (CART, "kmeans", 'cluster_modes = "2,7"', "option 'cluster_modes': unknown mode '7'"),
        (CART, "chiu", 'cluster_modes = "1,,2"', "option 'cluster_modes': item 2 of '1,,2' is"),
        # the low bound itself is outside the range (documented as "(1, 100]", "(0, 1]")
        (
            CART,
            "chiu",
            "squash = 1",
            "estimators.chiu.squash: chiu option 'squash': 1 is outside (1, 100]",
        ),
        (
            CART,
            "chiu",
            "reject = 0",
            "estimators.chiu.reject: chiu option 'reject': 0 is outside (0, 1)",
        ),
    ],
)
def test_a_table_is_checked_as_a_whole_whichever_estimator_runs(text, table, lines, named):
    # the model's default estimator is hstf (the tank) or chiu (the cart), not the table's
    with pytest.raises(ModelError) as err:
        _table(text, table, lines)
    message = str(err.value)
    assert message.startswith("m.toml: estimators.") and named in message, message


def test_the_same_table_whole_and_right_passes():
    assert _table(TANK, "switching-observer", 'eigenvalues = "-1,-2,-3"').name == "hstf"
    assert _table(TANK, "unknown-mode", "candidates = 20").name == "hstf"
    assert _table(CART, "chiu", 'accept = 0.6\nreject = 0.5\ncluster_modes = "2,1"').name == "chiu"


def test_chiu_bounds_are_refused_when_parsed():
    with pytest.raises(OptionError, match=r"^--set squash=1: e option 'squash': 1 is outside \(1,"):
        _set(ChiuOptions, "squash", "1")
    with pytest.raises(OptionError, match=r"^--set reject=0: e option 'reject': 0 is outside \(0,"):
        _set(ChiuOptions, "reject", "0")
    with pytest.raises(OptionError, match=r"^--set reject=0.6: e option 'reject': 0.6 is not "):
        _set(ChiuOptions, "reject", "0.6")  # the default accept is 0.5
    assert _set(ChiuOptions, "squash", "1.01").squash == 1.01


def test_switching_observer_eigenvalues_say_which_number_a_double_cannot_hold():
    with pytest.raises(OptionError, match=r"\(-1e-400: expected a number a double holds"):
        _set(SwitchingObserverOptions, "eigenvalues", "-1,-1e-400")
    assert SwitchingObserverOptions("-1,-3").eigenvalue_list(2) == (-1.0, -3.0)


def test_a_centres_path_naming_a_folder_is_refused_from_either_source(tmp_path, monkeypatch):
    (tmp_path / "sub").mkdir()
    monkeypatch.chdir(tmp_path)
    with pytest.raises(OptionError, match=r"^--set centers=sub: e option 'centers': 'sub' is a "):
        _set(ChiuOptions, "centers", "sub")
    origin = str(tmp_path / "m.toml")
    source = OptionSource.model_file(origin, "chiu", "centers")
    with pytest.raises(ModelError, match=r"estimators\.chiu\.centers: chiu option 'centers': '"):
        parse_options(ChiuOptions, {"centers": "."}, estimator="chiu", sources={"centers": source})
    # a file that is not there yet is the reader's question (hybridlog cluster may write it)
    options = _set(ChiuOptions, "centers", "sub/later.json")
    assert options.centers == "sub/later.json"


def test_analyze_refuses_another_estimators_inconsistent_table(tmp_path: Path, capsys):
    model = tmp_path / "dc.toml"
    model.write_text(f"{CART}\n[estimators.chiu]\naccept = 0.1\n")
    out = tmp_path / "r"
    args = ["analyze", "no_such_log.csv", "--model", str(model), "--estimator", "kmeans"]
    code, stderr = run_main([*args, "--out", str(out)], capsys)
    assert code == 2 and not out.exists()
    assert stderr == (
        f"hybridlog: error: {model}: estimators.chiu.accept: chiu option 'reject': 0.15 is not "
        f"below accept = 0.1 ({model}: estimators.chiu.accept): need 0 < reject < accept <= 1\n"
    )


def test_a_set_value_the_model_cannot_take_names_the_set_option():
    """``--set eigenvalues=-1,-2`` on a three-state model was refused as the estimator ran,
    naming neither ``--set`` nor the option; the model file's value is checked by its table."""
    from hybridlog.estimators.registry import prepare

    model = parse_model(builtin_text("ice_clutch"))
    with pytest.raises(
        OptionError,
        match=r"^--set eigenvalues=-1,-2: switching-observer option 'eigenvalues': the model has "
        r"3 states",
    ):
        prepare(model, "switching-observer", {"eigenvalues": "-1,-2"}, overrides_by="--set")
    prepare(model, "switching-observer", {"eigenvalues": "-1,-2,-3"}, overrides_by="--set")


@pytest.mark.parametrize(
    ("cls", "name", "text", "said"),
    [
        # just outside: six digits made it the bound, "1 is outside [1e-12, 1]"
        (HstfOptions, "rho", "1.0000001", "1.0000001 is outside [1e-12, 1]"),
        (HstfOptions, "theta", "0.49999999", "0.49999999 is outside [0.5, 1]"),
        # a bound six digits round: the range read [1, 4.5036e+15], which refused 4.5036e15
        (
            SwitchingObserverOptions,
            "condition_limit",
            "4.5036e15",
            "4.5036e+15 is outside [1, 4503599627370496]",
        ),
    ],
)
def test_a_refused_value_and_its_range_are_shown_with_the_digits_that_tell_them_apart(
    cls, name, text, said
):
    with pytest.raises(OptionError) as err:
        _set(cls, name, text)
    assert str(err.value) == f"--set {name}={text}: e option '{name}': {said}"


def test_the_largest_value_the_documented_range_shows_is_taken():
    (info,) = [i for i in describe_options(SwitchingObserverOptions) if i.name == "condition_limit"]
    high = info.constraint.split(", ")[1].rstrip("]")
    assert _set(SwitchingObserverOptions, "condition_limit", high).condition_limit == float(high)


PARTNERS = {("unknown-mode", "candidates"): {"beam": "1"}}
"""A bound that passes only with another option given (candidates >= beam)."""


def _bounds():
    for name, estimator in ESTIMATORS.items():
        for info in describe_options(estimator.options_type):
            if info.constraint:
                yield name, estimator.options_type, info


@pytest.mark.parametrize(
    ("estimator", "cls", "info"),
    [pytest.param(*bound, id=f"{bound[0]}.{bound[2].name}") for bound in _bounds()],
)
def test_a_bound_the_range_shows_as_included_is_taken_and_an_excluded_one_refused(
    estimator, cls, info
):
    # sliding-mode's threshold showed [0, 1] and chiu's reject (0, 1] while threshold = 0 or 1
    # and reject = 1 (never below accept <= 1) were always refused: the range shown is the
    # one that passes, an end shown with a round bracket the one refused as outside it.
    interval = info.constraint.removeprefix("in ")
    low, high = interval[1:-1].split(", ")
    partners = PARTNERS.get((estimator, info.name), {})
    for text, included in ((low, interval[0] == "["), (high, interval[-1] == "]")):
        values = {**partners, info.name: text}
        sources = {key: OptionSource.command_line("--set", key, v) for key, v in values.items()}
        if included:
            parse_options(cls, values, estimator=estimator, sources=sources)
        else:
            with pytest.raises(OptionError, match=f"'{info.name}': {text} is outside "):
                parse_options(cls, values, estimator=estimator, sources=sources)
