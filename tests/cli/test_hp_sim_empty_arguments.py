"""Every command's positional argument names a file (or a built-in): ``""`` is refused.

The hand-made list of ``test_cli_hostile_arguments`` missed ``models FILE`` when it came:
``hybridlog models ""`` said ``.: not a model file`` (pathlib reads ``""`` as the working
folder).  Walked from click's own description of the commands, a new command is covered.
"""

from __future__ import annotations

from collections.abc import Callable

import click

from hybridlog.cli import cli

Main = Callable[[list[str]], tuple[int, str]]


def test_every_positional_argument_refuses_an_empty_name(hybridlog_main: Main) -> None:
    checked = []
    for name, command in cli.commands.items():
        ctx = click.Context(command)
        arguments = [p for p in command.get_params(ctx) if isinstance(p, click.Argument)]
        for argument in arguments[:1]:  # "" is the first one given
            code, err = hybridlog_main([name, ""])
            hint = argument.human_readable_name
            assert (code, err) == (
                2,
                f"hybridlog {name}: {hint}: an empty name (see hybridlog {name} --help)\n",
            ), name
            checked.append(name)
    assert {"analyze", "batch", "inspect", "models", "simulate"} <= set(checked)
