"""The ``hybridlog`` command line: a thin click layer over the jobs (:mod:`hybridlog.jobs`).

Every command calls one library function.  hybridlog's own errors become one line on stderr
and exit code 2 (``--debug`` shows the traceback); a missed CI gate is exit code 1.

Start-up is lazy: this module imports click and hybridlog's light modules only (the errors,
the estimator registry, the names of the built-in models), and each command imports what it
needs when it runs, so ``hybridlog --help``, ``hybridlog <command> --help`` and ``hybridlog
models`` load no numpy, polars, numba, sympy, scipy or matplotlib (``tests/cli/test_startup.py``).
"""

from __future__ import annotations

import atexit
import contextlib
import dataclasses
import gc
import importlib
import json
import os
import signal
import sys
import time
import traceback
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, NoReturn, TypeVar

import click

from hybridlog import __version__
from hybridlog.allocators import return_freed_memory
from hybridlog.background import ESTIMATES, PLOTS, start_worker
from hybridlog.environment import check_environment, check_umask, check_working_folder
from hybridlog.errors import HybridlogError, as_text, excerpt
from hybridlog.estimators import ESTIMATORS
from hybridlog.estimators.filter_options import MODE_SEQUENCES
from hybridlog.estimators.options import OptionSource, describe_options, parse_options, shown
from hybridlog.fitted_lines import fitted
from hybridlog.io.formats import format_list
from hybridlog.launch import lost_output, single_threaded_blas, tolerate_closed_output
from hybridlog.limits import limit_reached
from hybridlog.model.builtins import builtin_names, builtin_reference, builtin_text
from hybridlog.numbers import parse_float, parse_int

if TYPE_CHECKING:
    from hybridlog.cluster.progress import WorkReporter
    from hybridlog.io import ReadOptions
    from hybridlog.report.document import Report

F = TypeVar("F", bound=Callable[..., Any])


MAX_MESSAGE = 400
"""Longest error or warning line the CLI prints (longer ones are cut in the middle)."""


def _examples(*lines: str) -> str:
    """An epilog of example command lines (they run as written from the repository root)."""
    return "\b\nExamples:\n" + "\n".join(f"  {line}" for line in lines)


class _Context:
    def __init__(self, debug: bool = False, quiet: bool = False) -> None:
        self.debug = debug
        self.quiet = quiet


def _set_flag(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    if value:
        setattr(ctx.ensure_object(_Context), str(param.name), True)


def _global_flags(function: F) -> F:
    """``--debug`` and ``-q/--quiet``, accepted before and after the subcommand."""
    function = click.option(
        "--quiet",
        "-q",
        is_flag=True,
        expose_value=False,
        callback=_set_flag,
        help="Print only errors.",
    )(function)
    return click.option(
        "--debug",
        is_flag=True,
        expose_value=False,
        callback=_set_flag,
        help="Show tracebacks of errors.",
    )(function)


def _estimators_epilog(*examples: str) -> str:
    """The registered estimators with their summaries, then ``examples``.

    Read from the registry alone (the one list), which imports no estimator module.
    """
    width = max(len(name) for name in ESTIMATORS)
    rows = [f"  {e.name:<{width}}  {e.summary}" for e in ESTIMATORS.values()]
    listing = "\b\nEstimators (options: --set NAME=VALUE, see docs/estimators.md):\n"
    return listing + "\n".join(rows) + "\n\n" + _examples(*examples)


class _PathName(click.Path):
    """A file or folder name; an empty one is refused (pathlib reads ``""`` as ``.``).

    ``--out ""`` was the working folder (``--out . contains the log``), ``analyze ""`` the
    log ``.``, ``cluster --out ""`` an unexpected error.

    A leading ``~`` or ``~user`` is the home folder, as the shell makes it of ``--out ~/r``
    but not of ``--out=~/r`` nor of a quoted ``"~/r"``: those wrote a folder named ``~`` in
    the working folder (which a later ``rm -r ~`` would take for the home).  A ``~user``
    the system does not know is refused; ``./~`` names a file called ``~``.
    """

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, str) and not value:
            self.fail("an empty name", param, ctx)
        if isinstance(value, str) and value.startswith("~"):
            home = _expand_tilde(value)
            if home.startswith("~"):
                user = value.split("/", 1)[0]
                why = (
                    "the previous working folder, and OLDPWD is not set"
                    if user == "~-"
                    else f"no home folder for {excerpt(user)} (no such user)"
                )
                self.fail(
                    f"{excerpt(value)}: {why}; write ./{value} for a name that starts with ~",
                    param,
                    ctx,
                )
            value = home
        return super().convert(value, param, ctx)


def _expand_tilde(value: str) -> str:
    """``value`` with its leading ``~`` expanded as bash expands it, else as given.

    ``~`` and ``~user`` are the home folder, ``~+`` the working folder, ``~-`` the previous
    one (``$OLDPWD``).
    """
    first, slash, rest = value.partition("/")
    folder = {"~+": _working_folder(), "~-": os.environ.get("OLDPWD")}
    if first in folder:
        return value if not folder[first] else f"{folder[first]}{slash}{rest}"
    return os.path.expanduser(value)


def _working_folder() -> str:
    """The working folder as the shell names it, ``$PWD``, when that is still this folder.

    bash's ``~+`` is ``$PWD``, which keeps the symbolic links it was reached through;
    ``os.getcwd()`` resolves them (``~+`` in a folder reached through ``/data -> /mnt/d``
    was ``/mnt/d``).  A ``$PWD`` that is not absolute or names another folder (a program
    that changed folder without setting it) is not taken.
    """
    shown = os.environ.get("PWD", "")
    try:
        if os.path.isabs(shown) and os.path.samefile(shown, os.curdir):
            return shown
    except OSError:
        pass
    return os.getcwd()


_PATH = _PathName(path_type=Path)
"""The type of every file or folder argument and option but a file to write."""

_FILE_OUT = _PathName(path_type=str)
"""The type of an option naming a file to write: the text as given, whose ``/`` at the end
(``--out dir.json/``, meaning a folder) a ``Path`` would drop; the job refuses it
(:func:`hybridlog.outputs.check_file_name`)."""


# Options shared by several commands: each is defined here once.

_model_option = click.option(
    "--model",
    "model_ref",
    required=True,
    type=_PathName(path_type=str),
    metavar="MODEL",
    help="Built-in model name (see `hybridlog models`) or a model file (.toml).",
)

_estimator_option = click.option(
    "--estimator",
    default=None,
    metavar="NAME",
    help="Estimator (listed below) [default: the model's default_estimator].",
)

_map_option = click.option(
    "--map",
    "maps",
    multiple=True,
    metavar="SYMBOL=PATH",
    help="Map a model input, output or truth symbol (truth.mode, truth.x1) "
    "to a log field. Repeatable.",
)

_msg_dir_option = click.option(
    "--msg-dir",
    "msg_dirs",
    multiple=True,
    type=_PATH,
    metavar="DIR",
    help="Folder of .msg files (pkg/msg/Name.msg) for message types the log does "
    "not define. Repeatable.",
)


def _force_option(replaces: str) -> Callable[[F], F]:
    """``--force``: what it replaces differs by command (and never includes an input)."""
    return click.option("--force", is_flag=True, help=f"Replace {replaces}.")


def _set_option(what: str) -> Callable[[F], F]:
    """``--set NAME=VALUE``: what it may set differs by command."""
    return click.option(
        "--set", "sets", multiple=True, metavar="NAME=VALUE", help=f"{what} Repeatable."
    )


_SMOOTHING = ", ".join(e.name for e in ESTIMATORS.values() if e.capabilities.supports_smoothing)
"""The estimators that declare a fixed-interval smoother (``--smooth``), from the registry."""

_SEQUENCES = ", ".join(
    e.name
    for e in ESTIMATORS.values()
    if any(i.name == "mode_sequence" for i in e.describe_options())
)
"""The estimators with a ``mode_sequence`` option (``--mode-sequence``), from the registry."""


def _read_options(function: F) -> F:
    """How a log is read (:class:`~hybridlog.io.ReadOptions`): every command that reads one.

    analyze, compare, batch and cluster; :func:`_read_options_given` builds the options from
    the values.  What reading did is recorded under ``reading`` in the command's JSON output
    (``report.json``, ``centers.json``).
    """
    decorators = [
        _map_option,
        click.option(
            "--resample",
            type=click.Choice(["nearest", "linear"]),
            default="nearest",
            show_default=True,
            help="How outputs are put on the model's grid: nearest sample within "
            "half a step, or linear interpolation.",
        ),
        click.option(
            "--max-gap",
            type=_Number(),
            default=None,
            metavar="SECONDS",
            help="Longest tolerated gap in the outputs [default: 5*dt].",
        ),
        click.option(
            "--split-gaps",
            is_flag=True,
            help="Cut the log at output gaps longer than --max-gap and use the longest "
            "piece (the pieces, the first 1000 of them and how many, are listed under "
            "reading in report.json or centers.json) "
            "instead of refusing the log.",
        ),
        click.option(
            "--time",
            "time_source",
            type=click.Choice(["log", "header"]),
            default="log",
            show_default=True,
            help="Sample times of bag and MCAP messages: the recorder's log time, or each "
            "message's header.stamp.",
        ),
        click.option(
            "--sort",
            is_flag=True,
            help="Put samples whose times go backwards in order, and keep the last of "
            "samples with equal times (per column: a table's rows of one time are "
            "combined), instead of refusing the log.",
        ),
        click.option(
            "--drop-nonfinite",
            is_flag=True,
            help="Drop NaN, infinite and out-of-range samples (counted under reading in "
            "report.json or centers.json) instead of refusing the log. Values only: a "
            "time that is NaN or infinite is refused still. With --sort, dropped before "
            "the last sample of a time is kept.",
        ),
        click.option(
            "--recover",
            is_flag=True,
            help="Read an unfinished or damaged MCAP file sequentially up to its first bad "
            "record, and use that (recorded under reading in report.json or centers.json). "
            "Refused for a log of another format; batch applies it to its MCAP files.",
        ),
        _msg_dir_option,
    ]
    for decorator in reversed(decorators):
        function = decorator(function)
    return function


def _analysis_options(function: F) -> F:
    """Options shared by analyze, compare and batch: the read options, estimation, gates."""
    decorators = [
        _set_option("Override a model parameter or an estimator option."),
        click.option(
            "--fail-under",
            multiple=True,
            metavar="METRIC=VALUE",
            help="CI gate: exit 1 when METRIC (vaf, fit, mse, mode_accuracy, "
            "missed_switches, fit.y1, state_rmse.x1, ...) is below VALUE. Repeatable. With "
            "--smooth or --mode-sequence the mode and state metrics are the offline "
            "estimates' (the filter's own are not gated), vaf, fit and mse the filter's "
            "one-step-ahead prediction.",
        ),
        click.option(
            "--fail-over",
            multiple=True,
            metavar="METRIC=VALUE",
            help="CI gate: exit 1 when METRIC (mse, state_rmse.x1, missed_switches, ...) is "
            "above VALUE. Repeatable. With --smooth, smoothing_fallback_weight (0 to 1) and "
            "smoothing_fallback_samples gate where the smoother kept the filter's estimate "
            "(refused without a smoother).",
        ),
        click.option(
            "--smooth",
            is_flag=True,
            help="After the filter, run its fixed-interval smoother over the whole log "
            f"(estimators with one: {_SMOOTHING or 'none yet'}; the option smooth = true). "
            "Modes, states and tables then hold the smoothed estimates; report.json's "
            "smoothing key has the filter's metrics beside them (batch's summaries too: "
            "filtered_* columns, the gain over the logs). imm's is Kim's; --set smoother=ec "
            "takes expectation correction (Barber 2006). In compare, every "
            "estimator must have a smoother (--set smooth=true smooths those that do).",
        ),
        click.option(
            "--mode-sequence",
            type=click.Choice(MODE_SEQUENCES),
            default=None,
            help="How the mode timeline is read off: the most probable mode per sample "
            "(argmax), the most likely sequence over the filter's per-mode likelihoods "
            "(viterbi), or the most likely of the best mode histories, each with its own "
            "EKF (kbest; --set beam=N keeps N, default 20) [default: the estimator's option "
            f"mode_sequence, argmax]. Estimators with it: {_SEQUENCES} (unknown-mode: argmax "
            "or kbest, the history of its best trajectory at the end of the log).",
        ),
        click.option(
            "--table-format",
            type=click.Choice(["csv", "parquet"]),
            default="csv",
            show_default=True,
            help="Format of timeline and estimates tables.",
        ),
        _read_options,
        _force_option(
            "an output directory hybridlog wrote before (never a folder holding other "
            "files, never an input)"
        ),
    ]
    for decorator in reversed(decorators):
        function = decorator(function)
    return function


_METAVARS = {"str": "TEXT", "int": "INTEGER", "float": "FLOAT", "bool": "BOOLEAN"}
"""click's names of plain option types; choices and optional types show as ``[a|b]``."""


@dataclass(frozen=True)
class _DataclassOptions:
    """Command-line options generated from an options dataclass: its one definition.

    Each named field becomes ``--field-name VALUE`` whose help, default and type come from
    the field (:func:`~hybridlog.estimators.options.describe_options`); the values given are
    read and checked by :func:`~hybridlog.estimators.options.parse_options`, exactly like
    ``--set`` values, and fields not given keep the dataclass's defaults.  A
    ``Literal`` field may instead be a switch between two of its choices
    (``--exact/--approximate``).

    Attributes
    ----------
    load:
        Returns the dataclass (called when the command is first used, so that its module is
        not imported by ``hybridlog --help`` or other commands).
    names:
        The fields offered, in the order shown.
    owner:
        Whose options they are, for messages (``chiu option 'radius': ...``).
    switches:
        Field → (choice of ``--on``, choice of ``--off``), the flags named after the choices.
    table:
        The model-file table (``estimators.chiu``) whose values replace the dataclass's
        defaults, as the help says; empty: none does.
    """

    load: Callable[[], type[Any]]
    names: tuple[str, ...]
    owner: str
    switches: Mapping[str, tuple[str, str]]
    table: str = ""

    def params(self) -> list[click.Parameter]:
        """The click options, one per field."""
        infos = {info.name: info for info in describe_options(self.load())}
        params: list[click.Parameter] = []
        for name in self.names:
            info = infos[name]
            default = f"default: {shown(info.default)}"
            if self.table:  # the help cannot know the model: say where a value comes from
                default = (
                    f"default: the model file's {self.table}.{name}, else {shown(info.default)}"
                )
            if name in self.switches:
                on, off = self.switches[name]
                params.append(
                    click.Option(
                        [f"--{on}/--{off}", name], default=None, help=f"{info.help} [{default}]"
                    )
                )
                continue
            limits = f"; {info.constraint}" if info.constraint else ""
            params.append(
                click.Option(
                    [f"--{name.replace('_', '-')}", name],
                    default=None,
                    metavar=_METAVARS.get(info.type, f"[{info.type}]"),
                    help=f"{info.help} [{default}{limits}]",
                )
            )
        return params

    def parse(self, given: Mapping[str, Any]) -> Any:
        """The dataclass from the values given on the command line (``None``: not given)."""
        values: dict[str, Any] = {}
        sources: dict[str, OptionSource] = {}
        for name, value in given.items():
            if value is None:
                continue
            if name in self.switches:
                values[name] = self.switches[name][0 if value else 1]
                continue
            values[name] = value
            sources[name] = OptionSource(f"--{name.replace('_', '-')} {excerpt(value)[1:-1]}")
        return parse_options(self.load(), values, estimator=self.owner, sources=sources)


def _comma_list(value: str) -> tuple[str, ...]:
    """A comma-separated option's names (:func:`hybridlog.numbers.comma_items`).

    An empty item is a typo (a name left out, a stray comma), never a name: dropping it
    silently ran less than the user asked for.  A wholly empty value gives no items (the
    command says what it needs).  A name given twice is refused here too, as a usage error
    with the command's help named like the others (the library refuses it for Python).
    """
    from hybridlog.numbers import comma_items

    try:
        names = comma_items(value, "names")
    except ValueError as err:
        raise click.BadParameter(str(err)) from None
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise click.BadParameter(f"{', '.join(map(excerpt, twice))} named twice")
    return names


class _Command(click.Command):
    """A command whose options that take one value are given at most once.

    click keeps the last of ``--out a --out b`` (or ``--model A --model B``, ``--exact
    --approximate``) without a word: the run then wrote elsewhere, or read the log for
    another model, than one of the two said.  Repeatable options (``--set``, ``--map``, …)
    and plain switches given twice (``--force --force``: the same either way) are taken.
    """

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and not ctx.resilient_parsing:
            _, _, order = self.make_parser(ctx).parse_args(args=list(args))
            for param in order:
                times = sum(1 for seen in order if seen is param)
                if (
                    times > 1
                    and isinstance(param, click.Option)
                    and not (param.multiple or param.count)
                    and not (param.is_flag and not param.secondary_opts)
                ):
                    raise click.BadParameter(
                        f"given {'twice' if times == 2 else f'{times} times'}; give it once",
                        ctx=ctx,
                        param=param,
                        param_hint="/".join([*param.opts, *param.secondary_opts]),
                    )
        return super().parse_args(ctx, args)


class _Group(click.Group):
    """The ``hybridlog`` group: its commands are :class:`_Command` s."""

    command_class = _Command


class _GeneratedOptionsCommand(_Command):
    """A command with options generated by a :class:`_DataclassOptions` on first use.

    The options are made when the command's parameters are first needed (to parse its
    arguments or show its help), after the parameter named ``after``.
    """

    def __init__(self, *args: Any, generated: _DataclassOptions, after: str, **kwargs: Any) -> None:
        self._generated: _DataclassOptions | None = generated
        self._after = after
        super().__init__(*args, **kwargs)

    @property
    def params(self) -> list[click.Parameter]:
        if self._generated is not None:
            generated, self._generated = self._generated, None
            at = [p.name for p in self._params].index(self._after) + 1
            self._params[at:at] = generated.params()
        return self._params

    @params.setter
    def params(self, value: list[click.Parameter]) -> None:
        self._params = value


def _chiu_options() -> type[Any]:
    """The clustering options of paper 001's classifier (defaults: MATLAB ``subclust``)."""
    from hybridlog.estimators.observer_options import ChiuOptions

    return ChiuOptions


_CLUSTERING = _DataclassOptions(
    load=_chiu_options,
    names=("radius", "squash", "accept", "reject", "method", "output_lags", "input_lags"),
    owner="chiu",
    switches={"method": ("exact", "approximate")},
    table="estimators.chiu",
)
"""``hybridlog cluster``'s clustering options, from the ``chiu`` estimator's options."""


# The commands' help texts: strings, not their functions' docstrings, which ``python -OO``
# (PYTHONOPTIMIZE=2) drops: --help then described no command but inspect.
_HELP_HYBRIDLOG = """Mode and state estimation for hybrid (switched) systems from recorded logs.

Every command has --help with examples, which run as written from the repository root.
Exit codes: 0 success, 1 a CI gate failed (or a batch's log or a compared estimator
failed on its log), 2 bad usage or bad input (one line on stderr naming the file, option
or line).
"""

_HELP_ANALYZE = """Run one estimator over one log and write report, tables and plots."""

_HELP_BATCH = """Analyse many logs; a failing log never stops the others.

LOGS are log files, ROS 2 bags or folders of logs: a folder without metadata.yaml is
searched, with its subfolders, for log files (by suffix) and bags, skipping names that
start with '.' and links to folders (a note names them).  A log is skipped when its
report records the same log content, model, options and hybridlog version (--force
redoes all).  Exit status 1 when a log could not be analysed or missed a gate, 2 for
bad options, model or output folder.
"""

_HELP_CLUSTER = """Fit Chiu subtractive clusters on regression vectors offline (paper 001).

Clusters φ(k) = [y(k), y(k-1), u(k-1)] (or other lags), labels each cluster as a model
mode from the data and the model alone, and writes the centres and classifier to a JSON
file, a plot, and a table.  The log is read as analyze reads it (the same options).
"""

_HELP_COMPARE = """Run several estimators on one log and write a side-by-side table."""

_HELP_MODELS = """List the built-in models, print the model file of one, or check a model file.

Given a file (as --model takes it: a file of that path wins over a built-in of that
name), checks it as analyze would, every key and each [estimators.<name>] table of
the estimators that can run it, and says what it holds; exit 2 with one line naming
the key where it is not valid.
"""

_HELP_SIMULATE = """Simulate a model along a mode schedule and write a log with ground truth.

A components model plays its [simulation] scenario instead (per-component schedules,
unmodelled behaviour, controller; --set moves its parameters); its log also holds the
commands and the true mode of each component (mode.<component>).

In bags and MCAP files every input and output is a std_msgs/Float64 topic /<name>, the
true mode a std_msgs/String topic /truth/mode (/truth/mode/<component>) and every true
state /truth/<state>, as ROS names (θ is /truth/theta). ROS 2 bags: metadata version 8,
which ros2 bag reads from Humble on.
"""


@click.group(
    cls=_Group,
    help=_HELP_HYBRIDLOG,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
    epilog=_examples(
        "hybridlog models",
        "hybridlog analyze sample_logs/three_tank_hstf.csv --model three_tank_hstf "
        "--estimator imm --out first_report",
    ),
)
@click.version_option(__version__, prog_name="hybridlog")
@_global_flags
@click.pass_context
def cli(ctx: click.Context) -> None:
    """The command group; its help is :data:`_HELP_HYBRIDLOG`."""
    ctx.ensure_object(_Context)
    # before any command imports numba or polars, here or in its workers
    check_environment()
    check_working_folder()
    check_umask()


def _say(ctx: click.Context, text: str) -> None:
    settings = ctx.find_object(_Context)
    if settings is None or not settings.quiet:
        click.echo(_for_terminal(text))


def _path_text(path: object) -> str:
    r"""A path on one line: a line break or tab in it escaped too (``\n``), as errors show it.

    The lines naming what a command wrote (``report: ...``) are one a path, for scripts
    that read them; :func:`_for_terminal` keeps a text's line breaks.
    """
    return "".join(c if c.isprintable() else excerpt(c)[1:-1] for c in as_text(path))


def _for_terminal(text: str) -> str:
    r"""Lines for stdout: names as the system gave them, but nothing a terminal acts on.

    A log named with bytes that are not UTF-8 or with control characters (an escape
    sequence) is shown ``\xNN`` (:func:`~hybridlog.errors.as_text`, :func:`excerpt`'s
    escapes); line breaks and tabs stay.
    """
    return "\n".join(
        "".join(c if c.isprintable() or c == "\t" else excerpt(c)[1:-1] for c in as_text(line))
        for line in text.split("\n")
    )


@cli.command(
    help="Describe a log: columns or topics, types, counts, NaN and infinite values, time "
    "span, mean rates, median steps and gaps.\n\n"
    f"Reads {format_list(titles=True)}.",
    epilog=_examples(
        "hybridlog inspect sample_logs/three_tank_hstf.csv",
        "hybridlog inspect sample_logs/three_tank_hstf.mcap --json",
        "hybridlog inspect sample_logs/three_tank_hstf_ros2",
    ),
)
@_global_flags
@click.argument("log", type=_PATH)
@click.option("--json", "as_json", is_flag=True, help="Print machine-readable JSON.")
@_msg_dir_option
def inspect(log: Path, as_json: bool, msg_dirs: tuple[Path, ...]) -> None:
    """Describe a log (the help text lists the formats from the table of formats)."""
    from hybridlog.io import ReadOptions
    from hybridlog.io.inspect import format_inspection, inspect_log

    info = inspect_log(log, ReadOptions(msg_dirs=tuple(str(d) for d in msg_dirs)))
    click.echo(
        json.dumps(info, indent=2, allow_nan=False)  # NaN is no JSON: never printed
        if as_json
        else _for_terminal(format_inspection(info))
    )


@cli.command(
    epilog=_examples("hybridlog models", "hybridlog models three_tank_hstf"), help=_HELP_MODELS
)
@_global_flags
@click.argument("name", required=False, type=_PathName(path_type=str), metavar="[NAME|FILE]")
def models(name: str | None) -> None:
    """The ``models`` command; its help is :data:`_HELP_MODELS`."""
    if name is not None:
        if not Path(name).is_file() and name in builtin_names():  # no numpy to print one
            click.echo(builtin_text(name), nl=False)
            return
        from hybridlog.jobs.model_description import check_and_describe
        from hybridlog.model.cache import model_file

        path = model_file(name)  # names a folder, a missing file or no built-in: refused
        assert path is not None  # a built-in was printed above
        click.echo(_for_terminal(check_and_describe(path)))
        return
    for builtin in builtin_names():
        click.echo(f"{builtin:20s} {builtin_reference(builtin)}")


class _Strict(click.ParamType[Any]):
    """A click type whose text is read by a strict parser of :mod:`hybridlog.numbers` first.

    click's ``INT`` and ``FLOAT`` read with Python's ``int()`` and ``float()``, which take
    underscores, any Unicode digits, and ``inf``/``nan``; the subclass' click base then does
    the rest (a range check, the ``--help`` text).
    """

    parse: Callable[[str], object]

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, str):
            try:
                value = type(self).parse(value)
            except ValueError as err:
                self.fail(f"{err}, got {excerpt(value)}", param, ctx)
        return super().convert(value, param, ctx)


class _WholeNumber(_Strict, click.IntRange):
    """A whole-number option read by :func:`~hybridlog.numbers.parse_int` (``1_0`` refused)."""

    parse = staticmethod(parse_int)


class _Jobs(_WholeNumber):
    """``--jobs``: a whole number of at least 1, or ``"auto"``, the cores this process may use.

    ``auto`` is passed on as such (:func:`~hybridlog.jobs.batch.run_batch` counts the
    cores), so that a note or an error says ``--jobs auto``, not the count the user did
    not write.
    """

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, str) and value.strip().lower() == "auto":
            return "auto"
        try:
            return super().convert(value, param, ctx)
        except click.BadParameter as err:
            if "whole number" not in err.message:
                raise
            self.fail(err.message.replace("a whole number", "a whole number or auto"), param, ctx)

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        return "N|auto"


class _Number(_Strict, click.types.FloatParamType):
    """A number option read by :func:`~hybridlog.numbers.parse_float` (finite, ASCII only)."""

    parse = staticmethod(parse_float)


class _LogFormats(click.Choice[str]):
    """``--format`` or ``--encoding``: choices read from the log writers when first needed.

    ``name`` is the tuple of :mod:`hybridlog.io.bag_writers` that lists them (the one
    list); the module is imported to parse or show ``simulate``'s options, not by other
    commands.
    """

    def __init__(self, name: str) -> None:
        self._name = name
        super().__init__(())

    @property
    def choices(self) -> tuple[str, ...]:
        from hybridlog.io import bag_writers

        return tuple(getattr(bag_writers, self._name))

    @choices.setter
    def choices(self, value: Sequence[str]) -> None:
        """Ignored: click's constructor sets the choices, which are read instead."""


@cli.command(
    epilog=_examples(
        "hybridlog simulate three_tank_hstf --out sim/tank.csv --seed 1",
        "hybridlog simulate three_tank_hstf --out sim/tank.parquet --schedule 1:50,3:50 "
        "--steps 400",
        "hybridlog simulate three_tank_hstf --out sim/tank_json.mcap --encoding json",
        "hybridlog simulate three_tank_hstf --out sim/tank_bag --format ros2-sqlite3",
        "hybridlog simulate bioplex_pgc --out sim/bioplex.csv --seed 3 --set light_fault=950",
    ),
    help=_HELP_SIMULATE,
)
@_global_flags
@click.argument("model_ref", type=_PathName(path_type=str), metavar="MODEL")
@click.option(
    "--out",
    "out",
    required=True,
    type=_FILE_OUT,
    help="Log to write: .csv, .parquet, .mcap, .bag, or a ROS 2 bag folder with --format.",
)
@click.option(
    "--format",
    "log_format",
    type=_LogFormats("LOG_FORMATS"),
    default=None,
    help="Log format [default: from the suffix of --out].",
)
@click.option(
    "--encoding",
    type=_LogFormats("MCAP_ENCODINGS"),
    default=None,
    help="Message encoding of an MCAP file: ROS 2 CDR, JSON or ROS 1 [default: cdr].",
)
@click.option(
    "--schedule",
    default=None,
    metavar="MODE:STEPS,...",
    help="Steps spent in each mode, repeated to --steps [default: the model's].",
)
@click.option(
    "--steps",
    type=_WholeNumber(min=1),
    default=None,
    help="Number of steps [default: the schedule's total].",
)
@click.option(
    "--seed",
    type=_WholeNumber(min=0),
    default=0,
    show_default=True,
    help="Noise seed (>= 0): the same seed, schedule and --steps give the same log.",
)
@_set_option(
    "A parameter of the model ([parameters]: the plant simulated with another value), or a "
    "scenario parameter of a components model (a fault time, a drift rate)."
)
@click.option(
    "--noise/--no-noise",
    default=True,
    show_default=True,
    help="Draw the model's process and measurement noise.",
)
@click.option(
    "--disturbance",
    default=None,
    metavar="A,OMEGA",
    help="Continuous time: add paper 003's eq. (49), A·(|x1|+...+|xn|)·sin(OMEGA·t), to dx.",
)
@_force_option("a log file or ROS 2 bag folder hybridlog wrote (never a file of yours)")
@click.pass_context
def simulate(
    ctx: click.Context,
    model_ref: str,
    out: str,
    log_format: str | None,
    encoding: str | None,
    schedule: str | None,
    steps: int | None,
    seed: int,
    sets: tuple[str, ...],
    noise: bool,
    disturbance: str | None,
    force: bool,
) -> None:
    """The ``simulate`` command; its help is :data:`_HELP_SIMULATE`."""
    from hybridlog.cluster.progress import reporting
    from hybridlog.jobs.simulate import simulate_log
    from hybridlog.report.markdown import plural

    with reporting(_work_reporter(ctx)):  # a long bag or MCAP file says how long it takes
        outcome = simulate_log(
            model_ref,
            out,
            log_format=log_format,
            encoding=encoding,
            schedule=schedule,
            steps=steps,
            seed=seed,
            noise=noise,
            disturbance=disturbance,
            force=force,
            settings=sets,
        )
    _say(ctx, f"wrote {_path_text(out)} ({plural(outcome.samples, 'sample')})")
    settings = ctx.find_object(_Context)
    if not (settings is not None and settings.quiet):
        for note in outcome.notes:
            click.echo(_one_line(f"hybridlog: note: {note}"), err=True)


@cli.command(
    "cluster",
    cls=_GeneratedOptionsCommand,
    generated=_CLUSTERING,
    after="model_ref",
    epilog=_examples(
        "hybridlog cluster sample_logs/double_cart_case1.csv --model double_cart_case1",
        "hybridlog cluster sample_logs/double_cart_case2.csv --model double_cart_case2 "
        "--radius 0.4 --compare-kmeans --out dc2_centers.json",
        "hybridlog analyze sample_logs/double_cart_case2.csv --model double_cart_case2 "
        "--estimator chiu --set centers=dc2_centers.json --out dc2_chiu",
    ),
    help=_HELP_CLUSTER,
)
@_global_flags
@click.argument("log", type=_PATH)
@_model_option
@click.option(
    "--out",
    "out",
    type=_FILE_OUT,
    default="centers.json",
    show_default=True,
    help="Centres and classifier to write (read by analyze --set centers=FILE).",
)
@click.option(
    "--plot",
    type=_FILE_OUT,
    default=None,
    help="Picture of the clusters [default: --out with .png].",
)
@click.option("--compare-kmeans", is_flag=True, help="Also fit k-means and compare.")
@_read_options
@_force_option("centres and plot files hybridlog wrote (never a file of yours)")
@click.pass_context
def cluster_command(
    ctx: click.Context,
    /,
    log: Path,
    model_ref: str,
    out: str,
    plot: str | None,
    compare_kmeans: bool,
    force: bool,
    **options: Any,
) -> None:
    """The ``cluster`` command; its help is :data:`_HELP_CLUSTER`."""
    from hybridlog.cluster.progress import reporting
    from hybridlog.jobs.cluster import discover_modes

    read = _read_options_given(options)  # what is left: the clustering options
    with reporting(_work_reporter(ctx)):
        outcome = discover_modes(
            log,
            model_ref,
            out=out,
            chiu=_CLUSTERING.parse(options),
            given=[name for name, value in options.items() if value is not None],
            compare_kmeans=compare_kmeans,
            plot=plot,
            read=read,
            force=force,
        )
    _say(ctx, outcome.table)
    for note in outcome.notes:
        _say(ctx, f"- {note}")
    _say(ctx, f"centres: {_path_text(outcome.centers_path)}, plot: {_path_text(outcome.plot_path)}")
    settings = ctx.find_object(_Context)
    if not (settings is not None and settings.quiet):  # as analyze says them of the log
        for alert in outcome.alerts:
            click.echo(_one_line(f"hybridlog: {alert}"), err=True)


@cli.command(
    "analyze",
    epilog=_estimators_epilog(
        "hybridlog analyze sample_logs/three_tank_hstf.csv --model three_tank_hstf "
        "--estimator imm --out imm_report",
        "hybridlog analyze sample_logs/three_tank_hstf.mcap --model three_tank_hstf "
        "--estimator imm --set transition_stay=0.9 --out tank_gated "
        "--fail-under mode_accuracy=0.9 --fail-under fit=60",
        "hybridlog analyze sample_logs/three_tank_hstf.csv --model three_tank_hstf "
        "--estimator imm --smooth --mode-sequence viterbi --out imm_smoothed",
    ),
    help=_HELP_ANALYZE,
)
@_global_flags
@click.argument("log", type=_PATH)
@_model_option
@_estimator_option
@click.option(
    "--out",
    "out_dir",
    type=_PATH,
    default=None,
    help="Output directory [default: <log name>_<estimator> here].",
)
@_analysis_options
@click.pass_context
def analyze_command(
    ctx: click.Context,
    /,
    log: Path,
    model_ref: str,
    estimator: str | None,
    out_dir: Path | None,
    **options: Any,
) -> None:
    """The ``analyze`` command; its help is :data:`_HELP_ANALYZE`."""
    _one_bounded_job()  # before the job's imports: polars' allocator reads its options
    from hybridlog.cluster.progress import reporting
    from hybridlog.jobs.analysis import analyze

    read, common = _split_options(options)
    with reporting(_work_reporter(ctx)):  # chiu's clustering of a long log says how long
        outcome = analyze(log, model_ref, out_dir=out_dir, estimator=estimator, read=read, **common)
    report = outcome.report
    _say(ctx, _summary_line(report))
    _say(ctx, f"report: {_path_text(outcome.out_dir / 'report.md')}")
    settings = ctx.find_object(_Context)
    if not (settings is not None and settings.quiet):  # every kind, as batch and compare count
        from hybridlog.report.markdown import WARNING_PREFIX
        from hybridlog.report.summary import warning_notes

        for warning in warning_notes(report):
            text = warning.removeprefix(WARNING_PREFIX)
            click.echo(_one_line(f"hybridlog: warning: {text}"), err=True)
        _echo_unused_samples(report)
    _gate_exit(outcome.gate_failures)


def _echo_unused_samples(report: Report) -> None:
    """A line on stderr per note of ``report`` saying samples of the log are not used.

    A log sampled at twice the model's rate loses every other sample, and ``--split-gaps``
    analyses the longest piece alone: report.md said so in a NOTE, the terminal nothing,
    under a summary line that read as the whole log's.
    """
    from hybridlog.report.build import unanalysed_span_notes, unused_sample_notes

    reading = report.reading
    for note in [*unused_sample_notes(reading), *unanalysed_span_notes(reading)]:
        click.echo(_one_line(f"hybridlog: note: {note.removeprefix('NOTE: ')}"), err=True)


@cli.command(
    "compare",
    epilog=_estimators_epilog(
        "hybridlog compare sample_logs/three_tank_hstf.csv --model three_tank_hstf "
        "--estimators hstf,imm --out hstf_vs_imm",
        "hybridlog compare sample_logs/double_cart_case1.csv --model double_cart_case1 "
        "--estimators chiu,kmeans --out dc1_compare",
    ),
    help=_HELP_COMPARE,
)
@_global_flags
@click.argument("log", type=_PATH)
@_model_option
@click.option(
    "--estimators",
    required=True,
    metavar="A,B,...",
    callback=lambda ctx, param, value: _comma_list(value),
    help="Comma-separated estimator names (listed below).",
)
@click.option(
    "--out",
    "out_dir",
    required=True,
    type=_PATH,
    help="Output directory: one report per estimator and comparison.md/.csv.",
)
@_analysis_options
@click.pass_context
def compare_command(
    ctx: click.Context,
    /,
    log: Path,
    model_ref: str,
    estimators: tuple[str, ...],
    out_dir: Path,
    **options: Any,
) -> None:
    """The ``compare`` command; its help is :data:`_HELP_COMPARE`."""
    _one_bounded_job()  # before the job's imports: polars' allocator reads its options
    from hybridlog.cluster.progress import reporting
    from hybridlog.jobs.analysis import compare

    read, common = _split_options(options)
    names = list(estimators)
    with reporting(_work_reporter(ctx)):  # chiu's clustering of a long log says how long
        outcome = compare(log, model_ref, names, out_dir=out_dir, read=read, **common)
    _say(ctx, outcome.table)
    if outcome.reports:
        reports = (_path_text(out_dir / name / "report.md") for name in outcome.reports)
        _say(ctx, f"reports: {', '.join(reports)}")
    _say(ctx, f"comparison: {_path_text(out_dir / 'comparison.md')}")
    settings = ctx.find_object(_Context)
    quiet = settings is not None and settings.quiet
    if outcome.reports and not quiet:  # one log: every report read it alike
        _echo_unused_samples(next(iter(outcome.reports.values())))
    for reach in [] if quiet else outcome.reach:  # a tuned estimator beside untuned ones
        click.echo(_one_line(f"hybridlog: note: {reach}"), err=True)
    if outcome.warned and not quiet:
        have = _have_warnings(len(outcome.warned), len(outcome.reports), "estimator")
        click.echo(_one_line(f"hybridlog: {have}; see {out_dir / 'comparison.md'}"), err=True)
    if outcome.unlike and not quiet:  # a VAF over fewer samples is no better VAF
        unlike = "; ".join(outcome.unlike)
        click.echo(
            _one_line(f"hybridlog: not like for like: {unlike}; see {out_dir / 'comparison.md'}"),
            err=True,
        )
    for name, reason in outcome.failures.items():  # a result, as a batch's failed log: exit 1
        click.echo(_one_line(f"hybridlog: estimator failed: {name}: {reason}"), err=True)
    _gate_exit(outcome.gate_failures)
    if outcome.failures:
        sys.exit(1)


@cli.command(
    "batch",
    epilog=_estimators_epilog(
        "hybridlog batch sample_logs/three_tank_hstf.csv sample_logs/three_tank_hstf.mcap "
        "--model three_tank_hstf --estimator imm --out tank_formats",
        "hybridlog simulate three_tank_hstf --out nightly_runs/seed1.csv --seed 1",
        "hybridlog simulate three_tank_hstf --out nightly_runs/seed2.csv --seed 2 "
        "--schedule 3:60,1:60,2:60",
        "hybridlog batch nightly_runs/*.csv --model three_tank_hstf --estimator imm --out nightly "
        "--jobs 2 --fail-under fit=60 --plots failed --junit nightly/junit.xml",
        "hybridlog batch nightly_runs --model three_tank_hstf --estimator imm --out nightly_all "
        "--jobs 2",
    ),
    help=_HELP_BATCH,
)
@_global_flags
@click.argument("logs", nargs=-1, required=True, type=_PATH)
@_model_option
@_estimator_option
@click.option(
    "--out",
    "out_dir",
    required=True,
    type=_PATH,
    help="Output directory: one report folder per log (its path from the logs' common "
    "folder, or from the folder of logs given, e.g. d2/run.csv/) and summary.md/.csv/.png.",
)
@click.option(
    "--jobs",
    type=_Jobs(min=1),
    default=1,
    show_default=True,
    help="Logs analysed in parallel (local processes; not with --scheduler); auto: one per "
    "core this process may use.",
)
@click.option(
    "--scheduler",
    default=None,
    metavar="ADDRESS",
    help="Run on the Dask cluster of this scheduler (e.g. tcp://host:8786; needs "
    "hybridlog[dask] and the paths shared with the workers) instead of local processes. "
    "Without workers for 60 s (none joined, or all left mid-batch): exit 2.",
)
@click.option(
    "--plots",
    type=click.Choice(["none", "failed", "all"]),
    default="none",
    show_default=True,
    help="Per-log plots: none, only logs that miss a gate, or all.",
)
@click.option(
    "--junit",
    default=None,
    type=_FILE_OUT,
    metavar="FILE",
    help="Write JUnit XML: a test case per log per gate, an error per log not analysed.",
)
@_analysis_options
@click.pass_context
def batch_command(
    ctx: click.Context,
    /,
    logs: Sequence[Path],
    model_ref: str,
    estimator: str | None,
    out_dir: Path,
    jobs: int | Literal["auto"],
    scheduler: str | None,
    plots: str,
    junit: str | None,
    **options: Any,
) -> None:
    """The ``batch`` command; its help is :data:`_HELP_BATCH`."""
    from hybridlog.jobs.batch_logs import batch_logs

    found = batch_logs(logs)  # folders of logs searched once, before the job's imports
    total = len(found.paths)
    if jobs == "auto":
        from hybridlog.environment import usable_cores

        workers = usable_cores()
    else:
        workers = jobs
    if workers > 1 and scheduler is None and total > 1:
        # run_batch's workers fork from this forkserver: started before the batch job's
        # imports, it warms up while this process imports polars and numpy
        from hybridlog.jobs.workers import start_forkserver

        start_forkserver()
    from hybridlog.cluster.progress import reporting
    from hybridlog.jobs.batch import run_batch

    read, common = _split_options(options)
    clock = _BatchClock()
    with _batch_progress(ctx, total, clock) as advance, reporting(_batch_reporter(ctx, clock)):
        outcome = run_batch(
            found,
            model_ref,
            out_dir=out_dir,
            estimator=estimator,
            jobs=jobs,
            scheduler=scheduler,
            plots=plots,
            junit=junit,
            read=read,
            progress=advance,
            **common,
        )
    _say(ctx, outcome.table)
    _say(ctx, f"summary: {_path_text(out_dir / 'summary.md')}")
    waited = outcome.waited_for_memory
    settings = ctx.find_object(_Context)
    if not (settings is not None and settings.quiet):
        for note in outcome.notes:
            click.echo(_one_line(f"hybridlog: note: {note}"), err=True)
    if waited and not (settings is not None and settings.quiet):
        seconds = sum(log.memory_wait_s for log in waited)
        click.echo(
            f"hybridlog: note: {len(waited)} of {len(outcome.logs)} logs waited {seconds:.0f} s "
            f"in all for memory held by the other workers' logs: "
            f"{'the Dask workers' if scheduler is not None else f'--jobs {jobs}'} ran fewer "
            "logs at once where all would not fit",
            err=True,
        )
    warned = outcome.warned
    if warned and not (settings is not None and settings.quiet):  # one line, not one a log
        analysed = sum(1 for log in outcome.logs if log.report is not None)
        have = _have_warnings(len(warned), analysed, "analysed log")
        click.echo(_one_line(f"hybridlog: {have}; see {out_dir / 'summary.md'}"), err=True)
    if outcome.failed:
        failed = f"{outcome.failed} of {len(outcome.logs)} logs failed"
        click.echo(_one_line(f"hybridlog: {failed} (see {out_dir / 'summary.md'})"), err=True)
    _gate_exit(outcome.gate_failures)
    if outcome.failed:
        sys.exit(1)


def _have_warnings(warned: int, total: int, kind: str) -> str:
    """``3 of 1,000 analysed logs have warnings``, ``1 of 2 estimators has warnings``.

    Out of the reports written (``kind``: what they are of), as summary.md counts them.
    """
    from hybridlog.report.markdown import plural

    return f"{warned:,} of {plural(total, kind)} {'has' if warned == 1 else 'have'} warnings"


@contextlib.contextmanager
def _batch_progress(
    ctx: click.Context, total: int, clock: _BatchClock
) -> Iterator[Callable[[Any], None] | None]:
    """A progress bar of a batch on stderr: done / failed / skipped, rate and time left.

    Both from ``clock``'s working time, without the waits for a model's first compile: click's
    own ETA, from the bar's start, counted those 10-20 s into every log (54 s left for three
    logs that then took a second); with workers compiling side by side, the time after the
    first of them finishes a log is work, at that worker's rate.  The time left assumes the
    logs left are analysed, not skipped, at the rate of those analysed so far; there is none
    before the first is.
    """
    from hybridlog.cluster.progress import duration_text

    counts = {"done": 0, "failed": 0, "skipped": 0}

    def show(_: object) -> str:
        finished = sum(counts.values())
        analysed = counts["done"] + counts["failed"]
        working = max(clock.working(), 1e-9)
        text = (
            f"done {counts['done']} · failed {counts['failed']} · skipped {counts['skipped']}"
            f" · {finished / working * 60:,.0f} logs/min"
        )
        if analysed and finished < total:
            left = max((total - finished) * working / analysed, 1.0)  # not "0 s left"
            text += f" · {duration_text(left)} left"
        return text

    with _progress(ctx, total, "logs", show) as bar:
        if bar is None:
            yield None
            return

        def advance(outcome: Any) -> None:
            clock.work()
            counts[outcome.status] = counts.get(outcome.status, 0) + 1
            bar(outcome)

        yield advance


@dataclass
class _BatchClock:
    """A batch's working time: since it started, less the time its work waited for compiling.

    A wait is one its reporter holds (:func:`_clocked_wait`) while a model's first run
    compiles, once for workers compiling side by side.  It counts as waiting until it ends or
    a log finishes during it (from then on a worker is analysing logs, which is work).
    """

    started: float = dataclasses.field(default_factory=time.monotonic)
    waited: float = 0.0
    waiting_since: float | None = None

    def working(self) -> float:
        """Seconds since the start, less those waited (so far, for a wait going on)."""
        now = time.monotonic()
        waiting = 0.0 if self.waiting_since is None else now - self.waiting_since
        return now - self.started - self.waited - waiting

    def wait(self) -> None:
        """A wait for compiling begins."""
        self.waiting_since = time.monotonic()

    def work(self) -> None:
        """A wait ends, or a log finished: the time waited so far is counted out."""
        if self.waiting_since is not None:
            self.waited += time.monotonic() - self.waiting_since
            self.waiting_since = None


@contextlib.contextmanager
def _clocked_wait(clock: _BatchClock, shown: bool, what: str, why: str) -> Iterator[None]:
    """:func:`_work_wait` over the bar, its time counted out of ``clock``'s working time."""
    clock.wait()
    try:
        with _work_wait(shown, what, why, over_bar=True):
            yield
    finally:
        clock.work()


def _bars_shown(quiet: bool) -> bool:
    """Whether progress bars are drawn: on a terminal that can draw them, without ``--quiet``.

    Not where stderr is no terminal (a file, a pipe, a CI log) nor on a terminal that says it
    is ``TERM=dumb`` (Emacs' shell, an editor's output pane): click's bar hides the cursor
    with an escape sequence (``ESC[?25l``) and redraws the line with carriage returns, which
    such a terminal prints as they are, a line of ``^[[?25l`` fragments per update.
    """
    return not quiet and sys.stderr.isatty() and os.environ.get("TERM") != "dumb"


@contextlib.contextmanager
def _progress(
    ctx: click.Context,
    total: int,
    label: str,
    show: Callable[[Any], str] | None = None,
) -> Iterator[Callable[[object], None] | None]:
    """A progress bar on stderr, only on a terminal and without ``--quiet``.

    Without click's ETA: ``show`` says the time left where it can be told.
    """
    settings = ctx.find_object(_Context)
    if not _bars_shown(settings is not None and settings.quiet):
        yield None
        return
    bar: Any
    with click.progressbar(
        length=total,
        label=label,
        file=fitted(sys.stderr),
        width=0,  # the bar takes what the line leaves of the terminal (fitted_lines.py)
        show_eta=False,
        show_pos=True,
        item_show_func=None if show is None else lambda item: show(item),
    ) as bar:
        yield lambda item: bar.update(1, item)


def _work_note(quiet: bool, text: str) -> None:
    """A note on stderr that long work is coming and how long it will take (not ``--quiet``).

    Prefixed as every other note (``hybridlog: note: ``): the exact potentials' "about 58
    min" stood bare among them.
    """
    if not quiet:
        click.echo(_for_terminal(f"hybridlog: note: {text}"), err=True)


@contextlib.contextmanager
def _work_progress(quiet: bool, total: int, label: str) -> Iterator[Callable[[int], None]]:
    """A progress bar on stderr of ``total`` units of work, advanced by the units done.

    Only on a terminal and without ``--quiet``.
    """
    if not _bars_shown(quiet):
        yield lambda done: None
        return
    bar: Any
    lines = fitted(sys.stderr)
    with click.progressbar(length=total, label=label, file=lines, show_eta=True, width=0) as bar:
        yield bar.update


WAIT_SHOWN_S = 2.0
"""Work of unforeseeable length (:func:`_work_wait`) is announced once it has taken this long:
a model's warm run loads its cached machine code in about half a second."""


@contextlib.contextmanager
def _work_wait(shown: bool, what: str, why: str, *, over_bar: bool = False) -> Iterator[None]:
    """Say ``what`` and ``why`` once the work inside has taken :data:`WAIT_SHOWN_S`, then how long.

    Only where ``shown`` (:func:`_bars_shown`: a terminal, no ``--quiet``), as the bars: the
    lines tell someone watching why nothing happens for a while (a model's first run
    compiling its machine code); a CI log has the compile time in report.md's Runtime.
    ``over_bar``: a progress bar may be drawn on the current line, which each line clears
    first.
    """
    if not shown:
        yield
        return
    import threading

    from hybridlog.cluster.progress import duration_text

    start = time.perf_counter()
    said = threading.Event()
    # the cursor to the line's start, the line erased (kept: shown only on a terminal)
    clear = "\r\x1b[K" if over_bar else ""

    def say() -> None:
        said.set()
        click.echo(clear + _for_terminal(f"{what} ({why})..."), err=True, color=over_bar)

    timer = threading.Timer(WAIT_SHOWN_S, say)
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:  # a failed work's error is the command's to say, no "done" before it
        timer.cancel()
        timer.join()
    if said.is_set():
        took = duration_text(time.perf_counter() - start)
        click.echo(clear + _for_terminal(f"{what}: done in {took}"), err=True, color=over_bar)


def _work_reporter(ctx: click.Context) -> WorkReporter:
    """How long work reports itself on stderr (:mod:`hybridlog.cluster.progress`).

    The exact clustering potentials: a note with the expected time first, then a bar.  A
    model's first run compiling its machine code: :func:`_work_wait`.  Made of module-level
    functions, so that it is sent pickled to the estimators' worker of ``analyze`` and
    ``compare``, where ``chiu`` clusters and the filters compile (it writes on the same
    stderr).
    """
    from functools import partial

    from hybridlog.cluster.progress import WorkReporter

    quiet = (settings := ctx.find_object(_Context)) is not None and settings.quiet
    return WorkReporter(
        note=partial(_work_note, quiet),
        bar=partial(_work_progress, quiet),
        wait=partial(_work_wait, _bars_shown(quiet)),
    )


def _batch_reporter(ctx: click.Context, clock: _BatchClock) -> WorkReporter:
    """A batch's reporter: a model's first compiling said as :func:`_work_wait`, over the bar.

    The lines clear the bar's line first (its next update draws it again below them); the
    time they wait is left out of ``clock``'s working time, the bar's rate and time left.
    Long clustering inside a log says nothing (the logs' bar is the batch's progress).
    """
    from functools import partial

    from hybridlog.cluster.progress import WorkReporter

    quiet = (settings := ctx.find_object(_Context)) is not None and settings.quiet
    return WorkReporter(wait=partial(_clocked_wait, clock, _bars_shown(quiet)))


def _read_options_given(options: dict[str, Any]) -> ReadOptions:
    """The :func:`_read_options` values, taken out of ``options``, as a ``ReadOptions``."""
    from hybridlog.io import ReadOptions

    return ReadOptions(
        maps=tuple(options.pop("maps")),
        resample=options.pop("resample"),
        max_gap=options.pop("max_gap"),
        split_gaps=options.pop("split_gaps"),
        time=options.pop("time_source"),
        sort=options.pop("sort"),
        drop_nonfinite=options.pop("drop_nonfinite"),
        recover=options.pop("recover"),
        msg_dirs=tuple(str(d) for d in options.pop("msg_dirs")),
    )


def _split_options(options: dict[str, Any]) -> tuple[ReadOptions, dict[str, Any]]:
    """The :func:`_analysis_options` values: the read options and the job's keywords."""
    read = _read_options_given(options)
    return read, {
        "sets": tuple(options.pop("sets")),
        "fail_under": tuple(options.pop("fail_under")),
        "fail_over": tuple(options.pop("fail_over")),
        "table_format": options.pop("table_format"),
        "force": options.pop("force"),
        "smooth": options.pop("smooth"),
        "mode_sequence": options.pop("mode_sequence"),
    }


def _summary_line(report: Report) -> str:
    from hybridlog.report.markdown import duration, format_number, format_percent, plural

    def percent(value: float | None, decimals: int) -> str:
        return "n/a" if value is None else f"{format_percent(value, decimals)} %"

    text = (
        f"{report.estimator} on {_path_text(report.log)}: {plural(report.samples, 'sample')} "
        f"in {duration(report.runtime_s)}, VAF {percent(report.vaf, 2)}, "
        f"fit {percent(report.fit, 2)}, MSE {format_number(report.mse, '.4g')}"
    )
    scored_outputs = [o.samples for o in report.outputs.values() if o.samples is not None]
    if scored_outputs and min(scored_outputs) < report.samples - 1:  # row 0 is the prior
        # a VAF over 73 of 399 predictions read like the whole log's (a gap, a late start)
        text += f" (over {min(scored_outputs):,} of {report.samples - 1:,} predicted samples)"
    text += _mode_accuracy_text(report, percent(_percent(report.modes.accuracy), 1))
    scored = report.modes.samples
    if report.modes.accuracy is not None and scored is not None and scored < report.samples:
        text += f" (over the {plural(scored, 'sample')} with a true mode)"
    smoothing = report.smoothing
    if smoothing is not None and smoothing.filtered.mode_accuracy is not None:
        text += f" (filtered {percent(_percent(smoothing.filtered.mode_accuracy), 1)})"
    detection = report.modes.detection
    if detection is not None:
        switches = plural(detection.detected + detection.missed, "true switch")
        text += f", {switches}: {detection.detected:,} detected, {detection.missed:,} missed"
    fallbacks = None if smoothing is None else smoothing.fallbacks
    if fallbacks is not None and fallbacks.samples:  # part of the "smoothed" estimate is not
        text += f"; {fallbacks.summary()}"
    return text


def _mode_accuracy_text(report: Report, shown: str) -> str:
    """``, mode accuracy 99.0 %``; of a ``[components]`` model, which accuracy it is.

    There it is the share of samples with every component's mode right, and ``n/a`` where the
    log has the true mode of only some components, each of which report.md scores: ``mode
    accuracy n/a`` read as a log without any true mode.
    """
    modes = report.modes
    if not (modes.components or modes.components_without_truth):
        return f", mode accuracy {shown}"
    if modes.accuracy is None and modes.components:
        scored = ", ".join(modes.components)
        return (
            f", mode accuracy (every component right) n/a: the log has the true mode of only "
            f"some components ({scored}: each scored in report.md)"
        )
    return f", mode accuracy (every component right) {shown}"


def _percent(fraction: float | None) -> float | None:
    return None if fraction is None else 100.0 * fraction


def _gate_exit(failures: Sequence[str]) -> None:
    for failure in failures:
        click.echo(_one_line(f"hybridlog: gate failed: {failure}"), err=True)
    if failures:
        sys.exit(1)


def _one_line(text: str) -> str:
    """The final guard on everything printed to stderr: one printable, bounded line."""
    return excerpt(" ".join(str(text).split()), MAX_MESSAGE)[1:-1]


def _usage_message(err: click.UsageError, args: Sequence[str] = ()) -> str:
    """A click usage error as one line: ``hybridlog analyze: --max-gap: 'abc' is not ...``."""
    command = err.ctx.command_path if err.ctx is not None else "hybridlog"
    if isinstance(err, click.BadParameter) and not isinstance(err, click.MissingParameter):
        param = err.param
        if err.param_hint is not None:
            hint = str(err.param_hint)
        elif isinstance(param, click.Option):
            hint = "/".join(param.opts)
        elif param is not None:
            hint = param.human_readable_name
        else:
            hint = "value"
        prefix, message = f"{hint}: ", err.message
    else:
        prefix, message = "", err.format_message()
    message = message.strip().rstrip(".")
    message = message[:1].lower() + message[1:]  # the hint as it is: LOG, not lOG
    return f"{command}: {prefix}{message}{_dash_file(err, args)} (see {command} --help)"


def _dash_file(err: click.UsageError, args: Sequence[str]) -> str:
    """For an unknown option that is a file's name (``-run.csv``): how to give that file.

    ``hybridlog inspect -run.csv`` said only ``no such option '-r'``: the user meant the log.
    """
    if not isinstance(err, click.NoSuchOption):
        return ""
    words = args[: list(args).index("--")] if "--" in args else args
    for word in words:
        if word.startswith(err.option_name) and word != "-" and os.path.lexists(word):
            name = as_text(word)
            return f"; {name!r} is a file: give it after -- or as ./{name}"
    return ""


def _where(err: BaseException) -> str:
    """``module.py:line`` of the innermost hybridlog frame of a traceback, or ``""``."""
    package = str(Path(__file__).parent)
    frames = [f for f in traceback.extract_tb(err.__traceback__) if f.filename.startswith(package)]
    if not frames:
        return ""
    frame = frames[-1]
    return f" in {Path(frame.filename).name}:{frame.lineno}"


@contextlib.contextmanager
def _warnings_handled() -> Iterator[list[warnings.WarningMessage]]:
    """Numerical warnings become errors; other warnings are collected for one-line notes.

    A RuntimeWarning (numpy's overflow, invalid value, division by zero) means a number
    hybridlog computed cannot be vouched for: the command stops with an error rather than
    report it.  Anything else a library warns about is printed after the command as one
    line, never as Python's raw two-line warning text.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        warnings.simplefilter("error", RuntimeWarning)
        yield caught


SHARED_IMPORTS = ("numpy", "hybridlog.model.cache", "hybridlog.estimators.result")
"""What the command and both its workers import, imported before the workers are forked:
modules that start no thread (not polars, whose threads a fork would not carry; numpy's
OpenBLAS has one thread in the console script) and load no large library (not numba nor
matplotlib, which only the workers load)."""

ESTIMATES_WARM_UP = "hybridlog.jit:set_up"
"""What the estimators' worker does first: numba's set-up (:func:`hybridlog.jit.set_up`).
The plots' worker waits for its first drawing's preparation (matplotlib's import, sent when
the report begins, :func:`hybridlog.report.write_report`): on two cores, importing it at
once slowed numba's set-up and the reading it runs beside (first chunk 2.0 against 1.8 s),
where during the estimates it takes the time the filter leaves."""

_PROCESS = {"one_command": False}
"""Whether this process runs one command and ends (the console script, ``python -m``)."""


def _one_bounded_job() -> None:
    """Skip the cyclic garbage collector for a job whose work is bounded (one log).

    Only when the process runs this one command and ends (:func:`main` without ``argv``):
    the collector's full passes over every object the libraries created took about 0.5 s
    of a 10^6-row ``analyze`` and free next to nothing; the process returns its memory at
    exit.  ``batch`` keeps the collector: its parent runs as long as the logs last.  Polars'
    allocator is set to return what the job frees
    (:func:`hybridlog.allocators.return_freed_memory`: a lower peak resident set), which
    must happen before the job imports polars; and two worker processes are forked now,
    while this one is small and has one thread (:func:`hybridlog.background.start_worker`):
    one sets up numba at once and then runs the estimators (their chunks sent back as they
    are made), the other imports matplotlib and draws the plots.  Other cores,
    with nothing of this process's interpreter, and neither numba's compiler nor matplotlib
    ever loaded here.
    """
    if _PROCESS["one_command"]:
        gc.disable()
        return_freed_memory()
        for module in SHARED_IMPORTS:  # imported once, before the forks, for all three
            importlib.import_module(module)
        start_worker(ESTIMATES, ESTIMATES_WARM_UP)
        start_worker(PLOTS)


def _failure(err: Exception) -> str:
    """The one line for a failure past click's own exceptions.

    What the user caused, numerical trouble, an allocation the memory could not hold (past
    the checks made up front, :mod:`hybridlog.memory`), or anything unexpected.
    """
    if isinstance(err, HybridlogError):
        return f"hybridlog: error: {err}"
    if isinstance(err, RuntimeWarning):
        return (
            f"hybridlog: error: numerical trouble{_where(err)}: {err}; hybridlog reports no "
            "number it cannot vouch for (--debug shows where)"
        )
    if isinstance(err, MemoryError):
        return (
            f"hybridlog: error: out of memory{_where(err)}: {str(err) or 'an allocation failed'}; "
            "the process may be limited below the machine's free memory (ulimit -v, "
            "a container); analyse a shorter log or free memory"
        )
    if isinstance(err, OSError) and (limit := limit_reached(err)) is not None:
        return f"hybridlog: error: {limit.what}{_where(err)} ({limit.detail}); {limit.advice}"
    return (
        f"hybridlog: error: unexpected {type(err).__name__}{_where(err)}: {err} "
        "(a bug, or an input hybridlog does not check yet; --debug shows the traceback)"
    )


class _Terminated(SystemExit):
    """``SIGTERM`` (a CI job's timeout, ``kill``) or ``SIGHUP`` (a closed terminal)."""


_ENDING: list[int] = []
"""The signal the console script's command is ending on, once one came."""


def _end_on_signal(signum: int, frame: object) -> None:
    """End on the first ``SIGINT``, ``SIGTERM`` or ``SIGHUP``; let the clean-up finish after it.

    ``SIGINT`` raises ``KeyboardInterrupt`` (click's abort, exit 130); ``SIGTERM`` and
    ``SIGHUP`` raise :class:`_Terminated`, whose default action would end the process at
    once, leaving the temporary output folder a command was writing beside its target:
    raised here, the exception runs every ``with`` block's clean-up first.  Exit code 128 +
    the signal's number (143, 129), as a shell reports it.

    Every later signal is dropped: the command is already ending.  Raised again, it cut
    the clean-up short, inside the removal of the temporary folder or the wait for the plots
    still drawn into it, and left the folder (Ctrl-C twice, or a CI runner's ``SIGTERM``
    followed by another).  The clean-up is bounded (a worker that does not end is killed,
    :meth:`hybridlog.background.Worker.close`); ``SIGKILL`` still ends the process at once.
    """
    if _ENDING:
        return
    _ENDING.append(signum)
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise _Terminated(128 + signum)


def _handle_ending_signals() -> None:
    """Install :func:`_end_on_signal` for ``SIGTERM``, ``SIGHUP`` and a ``SIGINT`` not ignored.

    A ``SIGINT`` the caller ignores (``nohup``, a script's background job) stays ignored, as
    does one whose action was set outside Python (:func:`signal.getsignal` gives None).
    """
    for ending in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(ending, _end_on_signal)
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _end_on_signal)


def main(argv: Sequence[str] | None = None) -> None:
    """Console entry point: run the CLI; every failure becomes one line and an exit code.

    Exit codes: 0 success, 1 a CI gate failed (or a batch's log or a compared estimator
    failed on its log), 2 bad usage or bad input (hybridlog's
    errors, click's usage errors, numerical trouble, anything unexpected), 130 interrupted.
    ``--debug`` (anywhere on the line) re-raises instead, with the traceback.
    """
    _PROCESS["one_command"] = argv is None
    if argv is None:
        single_threaded_blas()
        tolerate_closed_output()
        _handle_ending_signals()
    args = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in args[: args.index("--")] if "--" in args else "--debug" in args
    code = 0
    caught: list[warnings.WarningMessage] = []
    try:
        with _warnings_handled() as caught:
            result = cli.main(args=args, prog_name="hybridlog", standalone_mode=False)
            code = result if isinstance(result, int) else 0
    except click.exceptions.NoArgsIsHelpError as err:
        click.echo(err.format_message())
    except click.exceptions.Abort:
        click.echo("hybridlog: aborted", err=True)
        code = 130
    except click.UsageError as err:
        click.echo(_one_line(_usage_message(err, args)), err=True)
        code = 2
    except click.ClickException as err:
        click.echo(_one_line(f"hybridlog: error: {err.format_message()}"), err=True)
        code = 2 if err.exit_code in (1, 2) else err.exit_code
    except _Terminated as err:
        click.echo("hybridlog: terminated", err=True)
        code = int(err.code or 0)
    except SystemExit as err:  # sys.exit inside a command (a missed gate, failed logs)
        if not isinstance(err.code, int):
            raise
        code = err.code
    except KeyboardInterrupt:
        raise
    except Exception as err:  # the last guard: never a traceback without --debug
        if debug:
            raise
        click.echo(_one_line(_failure(err)), err=True)
        code = 2
    finally:
        for warning in caught:
            category = warning.category.__name__
            click.echo(_one_line(f"hybridlog: note: {category}: {warning.message}"), err=True)
    if _PROCESS["one_command"]:
        code = _said_lost_output(code)
        if sys.getprofile() is None and sys.gettrace() is None:
            _end_process(code)
    if code:
        sys.exit(code)


def _said_lost_output(code: int) -> int:
    """The exit code, 2 in place of 0 where stdout could not be written (:func:`lost_output`).

    ``hybridlog inspect LOG > file`` on a full disk lost what it printed: one line says so
    on stderr.  A reader that left (``| head -1``) is no failure.
    """
    lost = lost_output()
    if lost is None:
        return code
    click.echo(_one_line(f"hybridlog: error: cannot write to standard output ({lost})"), err=True)
    return code or 2


def _end_process(code: int) -> NoReturn:
    """End the console script's process: atexit handlers, stdout and stderr, then ``_exit``.

    Everything the command wrote is closed and every thread and child it started has been
    waited for, so what is left dies with the process.  The interpreter's teardown would
    clear every module and free the objects of numpy, polars, numba, sympy and matplotlib one
    by one: 0.06-0.09 s of a 10^6-row ``analyze`` (six runs each, interleaved: median wall
    1.80 → 1.73 s), and before the collector was frozen at exit 0.6 s.  What libraries ask
    to be done at exit (``atexit``) still runs, and both streams are flushed; a stream that
    cannot be flushed (a closed pipe) does not change the exit code.  :func:`main` does not
    call it under a profiler, tracer or debugger (``python -m cProfile -m hybridlog``,
    coverage, pdb): they write their results after ``main`` returns.
    """
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):  # None: closed when the process started (>&-)
        with contextlib.suppress(OSError, ValueError):
            if stream is not None:
                stream.flush()
    os._exit(code)
