"""Arguments a careless or hostile user gives: one line naming what is wrong, exit 2.

Checked for every command at once, from click's own description of the commands: the
parsing refuses before any work, so these cost no start-up of a job.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import click
import pytest

from hybridlog.cli import cli
from hybridlog.cli_types import PathName, _expand_tilde
from tests.support.paths import SAMPLE_LOGS

Main = Callable[[list[str]], tuple[int, str]]


def _options(command: click.Command) -> list[click.Option]:
    ctx = click.Context(command)
    return [p for p in command.get_params(ctx) if isinstance(p, click.Option)]


def _once_only(option: click.Option) -> bool:
    """An option whose second occurrence would replace the first."""
    plain_switch = option.is_flag and not option.secondary_opts
    return not (option.multiple or option.count or plain_switch or option.is_eager)


def test_an_option_of_one_value_given_twice_is_refused_in_every_command(
    hybridlog_main: Main, tmp_path: Path
) -> None:
    # click kept the last of --out a --out b, --model A --model B, --exact --approximate
    checked = 0
    for name, command in cli.commands.items():
        for option in filter(_once_only, _options(command)):
            first = option.opts[0]
            second = option.secondary_opts[0] if option.secondary_opts else first
            if option.is_flag:
                given = [first, second]
            else:
                value = "1" if not isinstance(option.type, click.Choice) else option.type.choices[0]
                given = [first, str(value), second, str(value)]
            code, err = hybridlog_main([name, str(tmp_path / "log.csv"), *given])
            hint = "/".join([*option.opts, *option.secondary_opts])
            assert code == 2, (name, given, err)
            assert err == (
                f"hybridlog {name}: {hint}: given twice; give it once "
                f"(see hybridlog {name} --help)\n"
            ), (name, given)
            checked += 1
    assert checked > 40
    # repeatable options and plain switches repeated are taken
    code, err = hybridlog_main(["models", "--quiet", "--quiet"])
    assert code == 0 and err == ""


def test_an_option_without_its_value_names_the_command_in_every_command(
    hybridlog_main: Main,
) -> None:
    # `analyze LOG --model` said "hybridlog: option '--model' requires an argument (see
    # hybridlog --help)": click's parser raised it without the command
    for name, command in cli.commands.items():
        for option in _options(command):
            if option.is_eager:
                continue
            first = option.opts[0]
            given, why = (
                (f"{first}=1", "does not take a value")
                if option.is_flag
                else (first, "requires an argument")
            )
            code, err = hybridlog_main([name, "log.csv", given])
            assert (code, err) == (
                2,
                f"hybridlog {name}: option {first!r} {why} (see hybridlog {name} --help)\n",
            ), (name, given)


def test_an_option_name_taken_as_a_value_is_refused_in_every_command(
    hybridlog_main: Main, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # click took the next word whatever it was: `batch LOG --out --force` wrote a folder
    # named --force and lost the --force asked for
    monkeypatch.chdir(tmp_path)
    checked = 0
    for name, command in cli.commands.items():
        for option in _options(command):
            if option.is_flag or option.is_eager:
                continue
            for given in ("--force" if name != "inspect" else "--json", "-q", "--debug=1"):
                code, err = hybridlog_main([name, "log.csv", option.opts[0], given])
                hint = "/".join([*option.opts, *option.secondary_opts])
                file = (
                    f" (a file of that name: ./{given})"
                    if isinstance(option.type, click.Path)
                    else ""
                )
                assert (code, err) == (
                    2,
                    f"hybridlog {name}: {hint}: got {given!r}, which is an option of this "
                    f"command: give {option.opts[0]} its value before it{file} "
                    f"(see hybridlog {name} --help)\n",
                ), (name, option.opts, given)
                checked += 1
    assert checked > 100
    assert list(tmp_path.iterdir()) == []
    # a file of such a name is given as ./NAME; a value that only starts with - is taken
    code, err = hybridlog_main(["analyze", "log.csv", "--model", "m", "--out", "-qh"])
    assert (code, err) == (
        2,
        "hybridlog analyze: --out: got '-qh', which starts with an option of this command: "
        "give --out its value before it (a file of that name: ./-qh) "
        "(see hybridlog analyze --help)\n",
    )
    code, err = hybridlog_main(["inspect", "./--json"])
    assert (code, err) == (2, "hybridlog: error: --json: no such file\n")
    code, err = hybridlog_main(["analyze", "log.csv", "--model", "m", "--max-gap", "-1"])
    assert code == 2 and "--max-gap: expected a number from 0 to 1e+09, got -1" in err


@pytest.mark.parametrize(
    ("args", "hint"),
    [
        (["analyze", "", "--model", "three_tank_hstf"], "LOG"),
        (["analyze", "log.csv", "--model", "three_tank_hstf", "--out", ""], "--out"),
        (["analyze", "log.csv", "--model", ""], "--model"),
        (["batch", "log.csv", "", "--model", "m", "--out", "o"], "LOGS"),
        (["cluster", "log.csv", "--model", "m", "--out", ""], "--out"),
        (["cluster", "log.csv", "--model", "m", "--plot", ""], "--plot"),
        (["compare", "log.csv", "--model", "m", "--estimators", "imm", "--out", ""], "--out"),
        (["inspect", ""], "LOG"),
        (["simulate", "", "--out", "x.csv"], "MODEL"),
        (["analyze", "log.csv", "--model", "m", "--msg-dir", ""], "--msg-dir"),
    ],
)
def test_an_empty_name_is_refused_not_read_as_the_working_folder(
    hybridlog_main: Main, args: list[str], hint: str
) -> None:
    # pathlib reads "" as ".": --out "" was the working folder, analyze "" the log "."
    code, err = hybridlog_main(args)
    command = f"hybridlog {args[0]}"
    assert (code, err) == (2, f"{command}: {hint}: an empty name (see {command} --help)\n")


@pytest.mark.parametrize("command", ["inspect", "analyze", "cluster", "compare", "batch"])
def test_a_log_named_like_an_option_is_named_in_the_error(
    hybridlog_main: Main, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, command: str
) -> None:
    # `hybridlog inspect -run.csv` said only "no such option '-r'"
    monkeypatch.chdir(tmp_path)
    (tmp_path / "-run.csv").write_text("t,y\n0,1\n")
    code, err = hybridlog_main([command, "-run.csv", "--model", "m"])
    assert code == 2
    assert err == (
        f"hybridlog {command}: no such option '-r'; '-run.csv' is a file: give it after -- "
        f"or as ./-run.csv (see hybridlog {command} --help)\n"
    )


def test_an_unknown_option_that_is_no_file_is_only_named(hybridlog_main: Main) -> None:
    code, err = hybridlog_main(["inspect", "-run.csv"])
    assert (code, err) == (
        2,
        "hybridlog inspect: no such option '-r' (see hybridlog inspect --help)\n",
    )


def test_a_tilde_the_shell_left_is_the_home_folder(
    hybridlog_main: Main, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--out=~/run.csv`` (or a quoted ``"~/run.csv"``), which the shell does not expand,
    wrote a folder named ``~`` in the working folder; it is the home folder, as
    ``--out ~/run.csv`` is.  A ``~user`` the system does not know is refused."""
    home, work = tmp_path / "home", tmp_path / "work"
    home.mkdir()
    work.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.chdir(work)
    code, _ = hybridlog_main(
        ["simulate", "three_tank_hstf", "--out=~/run.csv", "-q", "--steps", "5"]
    )
    assert code == 0
    assert (home / "run.csv").is_file() and list(work.iterdir()) == []
    code, err = hybridlog_main(["inspect", "~/run.csv"])
    assert (code, err) == (0, "")
    code, err = hybridlog_main(["simulate", "three_tank_hstf", "--out=~no_such_user_x/r.csv"])
    assert (code, err) == (
        2,
        "hybridlog simulate: --out: '~no_such_user_x/r.csv': no home folder for "
        "'~no_such_user_x' (no such user); write ./~no_such_user_x/r.csv for a name that "
        "starts with ~ (see hybridlog simulate --help)\n",
    )
    assert list(work.iterdir()) == []
    # bash's ~+ (the working folder) and ~- (the previous one) were "no such user"
    monkeypatch.setenv("OLDPWD", str(home))
    code, _ = hybridlog_main(
        ["simulate", "three_tank_hstf", "--out=~+/here.csv", "-q", "--steps", "5"]
    )
    assert code == 0 and (work / "here.csv").is_file()
    code, _ = hybridlog_main(["inspect", "~-/run.csv"])
    assert code == 0
    monkeypatch.delenv("OLDPWD")
    code, err = hybridlog_main(["inspect", "~-/run.csv"])
    assert (code, err) == (
        2,
        "hybridlog inspect: LOG: '~-/run.csv': the previous working folder, and OLDPWD is not "
        "set; write ./~-/run.csv for a name that starts with ~ (see hybridlog inspect --help)\n",
    )


def test_the_working_folder_of_tilde_plus_is_the_shells(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """bash's ``~+`` is ``$PWD``, with the symbolic link it was reached through; it was the
    resolved folder.  A ``$PWD`` naming another folder is not taken."""
    real = tmp_path / "real"
    real.mkdir()
    link = tmp_path / "link"
    link.symlink_to(real)
    monkeypatch.chdir(link)
    monkeypatch.setenv("PWD", str(link))
    assert _expand_tilde("~+/r") == f"{link}/r"
    for stale in (str(tmp_path), "link", ""):
        monkeypatch.setenv("PWD", stale)
        assert _expand_tilde("~+/r") == f"{os.path.realpath(real)}/r"


def test_a_removed_working_folder_is_said_in_words(
    hybridlog_main: Main, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``cd x; rm -r ../x; hybridlog analyze /abs/log.csv ... --out r`` failed with an
    "unexpected FileNotFoundError in outputs.py": a relative path has nowhere to be."""
    gone = tmp_path / "gone"
    gone.mkdir()
    monkeypatch.chdir(gone)
    gone.rmdir()
    code, err = hybridlog_main(["simulate", "three_tank_hstf", "--out", "r.csv", "--steps", "5"])
    assert (code, err) == (
        2,
        "hybridlog: error: the working folder no longer exists (removed while the shell was "
        "in it); change to an existing folder and run again\n",
    )


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (
            ["batch", "log.csv", "--model", "m", "--out", "o", "--plots", "\udcff"],
            "hybridlog batch: --plots: '\\xff' is not one of 'none', 'failed', 'all' "
            "(see hybridlog batch --help)\n",
        ),
        (
            ["analyze", "log.csv", "--model", "three_tank_hstf", "--fail-under", "vaf=\udcff"],
            "hybridlog: error: --fail-under 'vaf=\\xff': bound '\\xff': expected a finite number\n",
        ),
    ],
)
def test_a_byte_that_is_not_utf8_is_shown_as_typed_in_every_message(
    hybridlog_main: Main, args: list[str], said: str
) -> None:
    # messages that quoted a value with repr read '\udcff' for the byte 0xff typed
    assert hybridlog_main(args) == (2, said)


@pytest.mark.parametrize(
    "args",
    [
        ["models", "a" * 300],
        ["simulate", "a" * 300, "--out", "x.csv"],
        ["inspect", "log.csv", "--msg-dir", "a" * 300],
        [
            "analyze",
            str(SAMPLE_LOGS / "double_cart_case1.csv"),
            "--model",
            "double_cart_case1",
            "--estimator",
            "chiu",
            "--set",
            f"centers={'a' * 300}.json",
        ],
    ],
)
def test_a_name_too_long_for_the_file_system_is_named_not_called_a_bug(
    hybridlog_main: Main, args: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # pathlib's is_file() raises ENAMETOOLONG: "unexpected OSError in cache.py:172 (a bug ...)"
    monkeypatch.chdir(tmp_path)
    (tmp_path / "log.csv").write_text("t,u,y\n0,1,2\n")
    code, err = hybridlog_main(args)
    assert code == 2
    assert err.startswith("hybridlog: error: 'aaaa") and err.endswith(
        "': the name is too long for the file system (File name too long); give a shorter one\n"
    ), err


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (
            ["inspect", "log.csv", "--model", "m"],
            "hybridlog inspect: no such option '--model' (an option of analyze, batch, "
            "cluster and compare) (see hybridlog inspect --help)\n",
        ),
        (
            ["--json", "inspect", "log.csv"],
            "hybridlog: no such option '--json' (an option of inspect; give it after the "
            "command) (see hybridlog --help)\n",
        ),
        (
            ["compare", "log.csv", "--estimator", "imm"],
            "hybridlog compare: no such option '--estimator' (an option of analyze and "
            "batch); did you mean '--estimators'? (see hybridlog compare --help)\n",
        ),
    ],
)
def test_an_option_of_another_command_names_the_commands_that_have_it(
    hybridlog_main: Main, args: list[str], said: str
) -> None:
    # inspect --model said "Did you mean '--help'?", hybridlog --json "Did you mean '--version'?"
    assert hybridlog_main(args) == (2, said)


_WRITTEN = {"--out", "--plot", "--junit"}


def test_every_name_hybridlog_writes_is_read_as_one() -> None:
    # the type that refuses a blank at the end of a name to be made (PathName(written=True))
    checked = [
        (name, option.opts[0], isinstance(option.type, PathName) and option.type.written)
        for name, command in cli.commands.items()
        for option in _options(command)
        if _WRITTEN & set(option.opts)
    ]
    assert len(checked) == 7
    assert all(written for _, _, written in checked), checked


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["analyze", "log.csv", "--model", "m", "--out", " "], "--out: a name of blanks only, ' '"),
        (["inspect", "  "], "LOG: a name of blanks only, '  '"),
        (
            ["compare", "log.csv", "--model", "m", "--estimators", "imm", "--out", "  r1"],
            "--out: '  r1' starts or ends with a blank",
        ),
        (
            ["batch", "log.csv", "--model", "m", "--out", "b", "--junit", "b/ j.xml"],
            "its part ' j.xml'",
        ),
        (["simulate", "three_tank_hstf", "--out", "new/run.csv "], "its part 'run.csv '"),
        (["cluster", "log.csv", "--model", "m", "--plot", "c.png "], "'c.png ' starts or ends"),
    ],
)
def test_a_name_to_write_with_a_blank_at_an_end_is_refused(
    hybridlog_main: Main,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    args: list[str],
    said: str,
) -> None:
    # --out " " wrote a folder that ls shows as nothing, --out "  r1" one that reads as r1;
    # the message keeps the user's blanks (all white space was squeezed to one space)
    monkeypatch.chdir(tmp_path)
    code, err = hybridlog_main(args)
    command = f"hybridlog {args[0]}"
    assert code == 2 and err.startswith(f"{command}: ") and said in err, err
    assert err.endswith(f"(see {command} --help)\n") and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_a_folder_there_already_is_taken_as_named(tmp_path: Path) -> None:
    (tmp_path / "runs ").mkdir()
    written = PathName(path_type=str, written=True)
    assert written.convert(f"{tmp_path}/runs /r", None, None) == f"{tmp_path}/runs /r"
    with pytest.raises(click.BadParameter, match="its part 'r '"):
        written.convert(f"{tmp_path}/runs /r ", None, None)
    # a name read, not written, may be as the user's file is named
    assert PathName(path_type=str).convert(" r", None, None) == " r"
