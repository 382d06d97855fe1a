"""Help texts: every example runs as written, lists and options come from one definition."""

from __future__ import annotations

import ast
import dataclasses
import glob
import shlex
import shutil
from collections import Counter
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from hybridlog.cli import _CLUSTERING, cli, main
from hybridlog.estimators import ESTIMATORS
from hybridlog.estimators.options import describe_options, shown
from hybridlog.io import ReadOptions
from tests.support.paths import ROOT


def help_examples() -> list[tuple[str, str]]:
    """``(command, example line)`` for the top-level help and every command, in order."""
    found: list[tuple[str, str]] = []
    for name in ["", *cli.commands]:
        args = [name, "--help"] if name else ["--help"]
        text = CliRunner().invoke(cli, args, prog_name="hybridlog", terminal_width=1000).output
        _, marker, examples = text.partition("Examples:\n")
        assert marker, f"'hybridlog {name} --help' has no examples"
        for line in examples.splitlines():
            if not line.strip():
                break
            assert line.strip().startswith("hybridlog "), line
            found.append((name or "hybridlog", line.strip()))
    return found


def run(line: str) -> None:
    """Run one example in-process like a shell would: split words, expand globs."""
    words = shlex.split(line)[1:]
    args = [match for word in words for match in (sorted(glob.glob(word)) or [word])]
    try:
        main(args)
    except SystemExit as exit_:
        assert exit_.code in (0, None), f"{line}: exit {exit_.code}"


def test_every_help_example_runs_as_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    examples = help_examples()
    assert {command for command, _ in examples} == {"hybridlog", *cli.commands}
    shutil.copytree(ROOT / "sample_logs", tmp_path / "sample_logs")
    monkeypatch.chdir(tmp_path)
    # In order, in one folder: chained examples (cluster, then analyze with its centres)
    # find what the earlier ones wrote, and an output two examples share would fail.
    for _, line in examples:
        run(line)
        err = capsys.readouterr().err
        assert "hybridlog: " not in err and "Traceback" not in err, f"{line}\n{err}"
    assert len(examples) >= 20


def help_text(*args: str) -> str:
    result = CliRunner().invoke(cli, [*args, "--help"], terminal_width=1000)
    assert result.exit_code == 0, result.output
    return result.output


@pytest.mark.parametrize("command", ["analyze", "compare", "batch"])
def test_help_lists_every_estimator_with_its_summary_from_the_registry(command):
    lines = help_text(command).splitlines()
    for estimator in ESTIMATORS.values():
        assert any(line.split() == [estimator.name, *estimator.summary.split()] for line in lines)


def test_cluster_options_are_generated_from_the_chiu_options():
    # One definition (issue 8: the defaults were repeated in the CLI): each clustering option
    # of `hybridlog cluster` shows the default and help of the chiu estimator's options, and
    # what is not given is the dataclass's default.
    options_type = ESTIMATORS["chiu"].options_type
    infos = {info.name: info for info in describe_options(options_type)}
    params = {p.name: p for p in cli.commands["cluster"].params}
    for name in _CLUSTERING.names:
        option = params[name]
        assert isinstance(option, click.Option) and option.default is None, name
        assert option.help is not None and infos[name].help in option.help, name
        # the default shown is the model file's [estimators.chiu] value where it sets one
        # (the help said 0.5 beside a model file whose radius = 0.3 cluster fitted)
        default = f"default: the model file's estimators.chiu.{name}, else "
        assert f"{default}{shown(infos[name].default)}" in option.help, name
    assert params["method"].opts == ["--exact"] and params["method"].secondary_opts == [
        "--approximate"
    ]
    assert _CLUSTERING.parse({name: None for name in _CLUSTERING.names}) == options_type()
    given = {"radius": "0.4", "input_lags": "1,2"}
    read = {
        name: params[name].type.convert(text, params[name], None) for name, text in given.items()
    }
    chosen = _CLUSTERING.parse({**read, "method": False})
    assert chosen == options_type(radius=0.4, method="approximate", input_lags="1,2")
    with pytest.raises(click.BadParameter, match=r"^0\.5 is outside \(1, 100\]$"):
        params["squash"].type.convert("0.5", params["squash"], None)


def test_every_option_is_declared_once():
    # `--map` and `--msg-dir` were declared twice (issue 8).  Each flag has one click.option
    # call in the CLI's modules (cli.py, the shared options of cli_options.py, ...); --out
    # alone is declared per command: each writes something different.
    modules = sorted((ROOT / "hybridlog").glob("cli*.py"))
    assert {"cli.py", "cli_options.py"} <= {module.name for module in modules}
    trees = [ast.parse(module.read_text(encoding="utf-8")) for module in modules]
    declared = Counter(
        flag
        for tree in trees
        for node in ast.walk(tree)
        if isinstance(node, ast.Call)
        and ast.unparse(node.func) in ("click.option", "click.Option")
        and node.args
        and isinstance(node.args[0], ast.Constant)
        and isinstance(node.args[0].value, str)
        for flag in node.args[0].value.split("/")
        if flag.startswith("-")
    )
    assert {"--map", "--msg-dir", "--model", "--estimator", "--force"} <= set(declared)
    assert {flag: n for flag, n in declared.items() if n > 1} == {"--out": 5}


def test_every_command_that_reads_a_log_for_a_model_takes_every_read_option():
    # cluster read with --map alone, yet its errors told it to use --drop-nonfinite: the read
    # options are declared once and taken by every command whose reading can suggest them.
    flags = {
        "maps": "--map",
        "resample": "--resample",
        "max_gap": "--max-gap",
        "split_gaps": "--split-gaps",
        "time": "--time",
        "sort": "--sort",
        "drop_nonfinite": "--drop-nonfinite",
        "recover": "--recover",
        "msg_dirs": "--msg-dir",
    }
    assert set(flags) == {field.name for field in dataclasses.fields(ReadOptions)}
    for name in ("analyze", "compare", "batch", "cluster"):
        offered = {flag for p in cli.commands[name].params for flag in getattr(p, "opts", [])}
        assert set(flags.values()) <= offered, name


def test_help_texts_survive_python_s_optimisation_of_docstrings():
    # python -OO (PYTHONOPTIMIZE=2, set in some images) drops docstrings: click took six
    # commands' and the group's descriptions from them, and --help described inspect alone
    import json
    import subprocess
    import sys

    code = (
        "import json; from hybridlog.cli import cli; "
        "print(json.dumps({'': cli.help, **{n: c.help for n, c in cli.commands.items()}}))"
    )
    done = subprocess.run(
        [sys.executable, "-OO", "-c", code], check=True, capture_output=True, text=True, cwd=ROOT
    )
    optimised = json.loads(done.stdout)
    assert optimised == {"": cli.help, **{n: c.help for n, c in cli.commands.items()}}
    assert all(text and len(text) > 40 for text in optimised.values()), optimised
