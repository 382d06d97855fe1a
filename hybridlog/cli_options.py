"""The options several commands share, each defined once, and the values they give.

``--debug`` and ``--quiet`` (:func:`global_flags`; :func:`is_quiet`),
``--model``, ``--estimator``, ``--force``, ``--set``, how a log is read (:func:`read_options`,
its values as a :class:`~hybridlog.io.ReadOptions` by :func:`read_options_given`) and what
an analysis takes (:func:`analysis_options`, :func:`split_options`).

Light, as :mod:`hybridlog.cli`: click and hybridlog's light modules only.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

import click

from hybridlog.cli_types import PATH, Number, PathName
from hybridlog.estimators import ESTIMATORS
from hybridlog.estimators.filter_options import MODE_SEQUENCES
from hybridlog.io.options import LONGEST_GAP_S

if TYPE_CHECKING:
    from hybridlog.io import ReadOptions


F = TypeVar("F", bound=Callable[..., Any])


class _Context:
    """What ``--quiet`` set, kept in the click context's object (:func:`is_quiet` reads it).

    ``--debug`` is not kept here: :func:`hybridlog.cli_process.run` finds it on the command
    line itself, where it must also be found when the line does not parse.
    """

    def __init__(self, quiet: bool = False) -> None:
        self.quiet = quiet


def _set_quiet(ctx: click.Context, param: click.Parameter, value: bool) -> None:
    if value:
        ctx.ensure_object(_Context).quiet = True


def is_quiet(ctx: click.Context) -> bool:
    """Whether ``--quiet`` was given, before the subcommand or after it."""
    settings = ctx.find_object(_Context)
    return settings is not None and settings.quiet


def global_flags(function: F) -> F:
    """``--debug`` and ``-q/--quiet``, accepted before and after the subcommand.

    ``--debug`` is only accepted here: :func:`hybridlog.cli_process.run` reads it from the
    command line.
    """
    function = click.option(
        "--quiet",
        "-q",
        is_flag=True,
        expose_value=False,
        callback=_set_quiet,
        help="Print only errors.",
    )(function)
    return click.option(
        "--debug",
        is_flag=True,
        expose_value=False,
        help="Show tracebacks of errors.",
    )(function)


# Options shared by several commands: each is defined here once.

model_option = click.option(
    "--model",
    "model_ref",
    required=True,
    type=PathName(path_type=str),
    metavar="MODEL",
    help="Built-in model name (see `hybridlog models`) or a model file (.toml).",
)
"""``--model MODEL``: a built-in model or a model file, for every command that reads a log."""


estimator_option = click.option(
    "--estimator",
    default=None,
    metavar="NAME",
    help="Estimator (listed below) [default: the model's default_estimator].",
)
"""``--estimator NAME`` of ``analyze`` and ``batch``: the model's default when not given."""


_map_option = click.option(
    "--map",
    "maps",
    multiple=True,
    metavar="SYMBOL=PATH",
    help="Map a model input, output or truth symbol (truth.mode, truth.x1) "
    "to a log field. Repeatable.",
)


msg_dir_option = click.option(
    "--msg-dir",
    "msg_dirs",
    multiple=True,
    type=PATH,
    metavar="DIR",
    help="Folder of .msg files (pkg/msg/Name.msg) for message types the log does "
    "not define. Repeatable.",
)
"""``--msg-dir DIR``: message definitions for a log that lacks them (``inspect`` too)."""


def force_option(replaces: str) -> Callable[[F], F]:
    """``--force``: what it replaces differs by command (and never includes an input)."""
    return click.option("--force", is_flag=True, help=f"Replace {replaces}.")


def set_option(what: str) -> Callable[[F], F]:
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


def read_options(function: F) -> F:
    """How a log is read (:class:`~hybridlog.io.ReadOptions`): every command that reads one.

    analyze, compare, batch and cluster; :func:`read_options_given` builds the options from
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
            type=Number(min=0, max=LONGEST_GAP_S),  # as ReadOptions checks it, a usage error
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
            "message's header.stamp (batch reads its tables by their time column).",
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
        msg_dir_option,
    ]
    for decorator in reversed(decorators):
        function = decorator(function)
    return function


def analysis_options(function: F) -> F:
    """Options shared by analyze, compare and batch: the read options, estimation, gates."""
    decorators = [
        set_option("Override a model parameter or an estimator option."),
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
        read_options,
        force_option(
            "an output directory hybridlog wrote before (never a folder holding other "
            "files, never an input)"
        ),
    ]
    for decorator in reversed(decorators):
        function = decorator(function)
    return function


def read_options_given(options: dict[str, Any]) -> ReadOptions:
    """The :func:`read_options` values, taken out of ``options``, as a ``ReadOptions``."""
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


def split_options(options: dict[str, Any]) -> tuple[ReadOptions, dict[str, Any]]:
    """The :func:`analysis_options` values: the read options and the job's keywords."""
    read = read_options_given(options)
    return read, {
        "sets": tuple(options.pop("sets")),
        "fail_under": tuple(options.pop("fail_under")),
        "fail_over": tuple(options.pop("fail_over")),
        "table_format": options.pop("table_format"),
        "force": options.pop("force"),
        "smooth": options.pop("smooth"),
        "mode_sequence": options.pop("mode_sequence"),
    }
