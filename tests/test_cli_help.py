"""Every example in every ``--help`` runs as written, from a copy of the repository root."""

from __future__ import annotations

import glob
import shlex
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from hybridlog.cli import cli, main

ROOT = Path(__file__).resolve().parent.parent


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
