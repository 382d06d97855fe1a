"""An empty item in a comma-separated option is a one-line error naming the option.

``compare --estimators imm,,hstf`` (or ``imm,``) ran imm and hstf without a word: the stray
comma, often a name left out, was dropped.  Every option whose metavar is a comma list is
checked here, so that a new one is parsed the same way.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import click
import pytest

from hybridlog.cli import cli

Main = Callable[[list[str]], tuple[int, str]]


def _comma_options() -> list[tuple[str, click.Option]]:
    found = []
    for name, command in cli.commands.items():
        for param in command.get_params(click.Context(command)):
            if isinstance(param, click.Option) and "," in (param.metavar or ""):
                found.append((name, param))
    return found


def test_the_comma_list_options_are_found() -> None:
    assert ("compare", "--estimators") in {(n, o.opts[0]) for n, o in _comma_options()}


VALID_ITEM = {"--estimators": "imm", "--schedule": "1:10", "--disturbance": "0.5"}
"""One good item of each comma-list option (a new option must be added here)."""


def _base(command: str, tmp_path: Path) -> list[str]:
    if command == "simulate":
        return [command, "three_tank_hstf", "--out", str(tmp_path / "out.csv")]
    log, out = str(tmp_path / "log.csv"), str(tmp_path / "out")
    return [command, log, "--model", "three_tank_hstf", "--out", out]


@pytest.mark.parametrize("shape", ["{0},,{0}", "{0},", ",{0}", " , "])
def test_an_empty_item_in_a_comma_list_is_refused_naming_the_option(
    hybridlog_main: Main, tmp_path: Path, shape: str
) -> None:
    for command, option in _comma_options():
        value = shape.format(VALID_ITEM[option.opts[0]])
        code, err = hybridlog_main([*_base(command, tmp_path), option.opts[0], value])
        assert code == 2, (command, value, err)
        assert f" {option.opts[0]}: " in err and err.count("\n") == 1, err
        assert not any(tmp_path.iterdir())  # nothing written


def test_compare_says_which_item_is_empty(hybridlog_main: Main, tmp_path: Path) -> None:
    code, err = hybridlog_main([*_base("compare", tmp_path), "--estimators", "imm,,hstf"])
    assert (code, err) == (
        2,
        "hybridlog compare: --estimators: item 2 of 'imm,,hstf' is empty; separate the names "
        "with single commas (see hybridlog compare --help)\n",
    )


def test_compare_says_which_name_is_given_twice(hybridlog_main: Main, tmp_path: Path) -> None:
    """A name given twice was refused in another form than every other usage error
    (``hybridlog: error: --estimators: 'imm' named twice``, without the command's help)."""
    code, err = hybridlog_main([*_base("compare", tmp_path), "--estimators", "imm,hstf, imm"])
    assert (code, err) == (
        2,
        "hybridlog compare: --estimators: 'imm' named twice (see hybridlog compare --help)\n",
    )


def test_spaces_around_names_are_still_fine(hybridlog_main: Main, tmp_path: Path) -> None:
    # parsed, then refused for the missing log (not for the list)
    code, err = hybridlog_main(
        [
            "compare",
            str(tmp_path / "missing.csv"),
            "--model",
            "three_tank_hstf",
            "--estimators",
            " imm , hstf ",
            "--out",
            str(tmp_path / "out"),
        ]
    )
    assert code == 2 and "missing.csv" in err and "--estimators" not in err
