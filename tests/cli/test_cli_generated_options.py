"""Options generated from an options dataclass: a bad value is a usage error like any other.

``hybridlog cluster LOG --model M --radius abc`` said ``hybridlog: error: --radius abc: chiu
option 'radius': expected a finite number, got 'abc'``, checked inside the command, where
every other option's bad value is ``hybridlog <command>: --option: <why> (see hybridlog
<command> --help)``.  Each kind of option a dataclass declares is read by its click type.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import click
import pytest

from hybridlog.cli_process import run
from hybridlog.cli_types import DataclassOptions, GeneratedOptionsCommand, Group
from hybridlog.estimators.options import option


def _even(value: int) -> None:
    if value % 2:
        raise ValueError(f"{value} is odd")


@dataclass(frozen=True)
class _Kinds:
    count: int = option(4, "a whole number", range=(2, 10), check=_even)
    ratio: float = option(0.5, "a number", range=(0.0, 1.0), above=True)
    flag: bool = option(True, "a boolean")
    kind: Literal["a", "b"] = option("a", "a choice")
    limit: int | None = option(None, "a whole number or none")
    name: str = option("x", "text")


_GENERATED = DataclassOptions(
    load=lambda: _Kinds,
    names=("count", "ratio", "flag", "kind", "limit", "name"),
    owner="kinds",
    switches={},
)


@click.group(cls=Group)
def _group() -> None:
    """A group of the one command below."""


@_group.command("try", cls=GeneratedOptionsCommand, generated=_GENERATED, after="log")
@click.argument("log")
def _try(log: str, **options: Any) -> None:
    click.echo(repr(_GENERATED.parse(options)))


def _run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    try:
        run(_group, ["try", "log.csv", *args])
    except SystemExit as exit_:
        code = int(exit_.code or 0)
    else:
        code = 0
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.mark.parametrize(
    ("args", "why"),
    [
        (["--count", "abc"], "--count: expected a whole number, got 'abc'"),
        (["--count", "2.5"], "--count: expected a whole number, got '2.5'"),
        (["--count", "1_0"], "--count: expected a whole number, got '1_0'"),
        (["--count", "12"], "--count: 12 is outside [2, 10]"),
        (["--count", "3"], "--count: 3 is odd"),  # the field's own check
        (["--ratio", "0"], "--ratio: 0 is outside (0, 1]"),
        (["--ratio", "inf"], "--ratio: expected a finite number, got 'inf'"),
        (["--ratio", '"0.3"'], "--ratio: expected a finite number, got the string '0.3': write"),
        (["--flag", "yes"], "--flag: expected true or false, got 'yes'"),
        (["--kind", "c"], "--kind: 'c' is not one of a, b"),
        (["--limit", "few"], "--limit: expected a whole number, got 'few'"),
    ],
)
def test_a_bad_value_of_each_kind_is_a_usage_error(capsys, args, why):
    code, out, err = _run(capsys, *args)
    assert code == 2 and out == ""
    assert err.startswith(f"hybridlog try: {why}") and err.endswith(
        " (see hybridlog try --help)\n"
    ), err


def test_the_values_are_read_as_set_reads_them(capsys):
    args = ["--count", " 6 ", "--ratio", "1", "--flag", "false", "--kind", "b", "--limit", "none"]
    code, out, err = _run(capsys, *args, "--name", "'y z'")
    assert (code, err) == (0, "")
    assert out.strip() == repr(_Kinds(count=6, ratio=1.0, flag=False, kind="b", name="y z"))
    code, out, _ = _run(capsys)
    assert code == 0 and out.strip() == repr(_Kinds())
