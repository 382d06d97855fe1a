"""The ``hybridlog`` command line: a thin click layer over the jobs (:mod:`hybridlog.jobs`).

Every command parses its options, calls one library function, prints what it did and exits.
hybridlog's own errors become one line on stderr and exit code 2 (``--debug`` shows the
traceback); a missed CI gate is exit code 1 (:func:`main`, :mod:`hybridlog.cli_process`).
The pieces the commands are built of live beside it: the parameter types and command classes
(:mod:`hybridlog.cli_types`), the options several commands share
(:mod:`hybridlog.cli_options`), the progress bars and work reporters
(:mod:`hybridlog.cli_progress`) and the lines the commands print (:mod:`hybridlog.cli_lines`).

Start-up is lazy: this module imports click and hybridlog's light modules only (the errors,
the estimator registry, the names of the built-in models), and each command imports what it
needs when it runs, so ``hybridlog --help``, ``hybridlog <command> --help`` and ``hybridlog
models`` load no numpy, polars, numba, sympy, scipy or matplotlib (``tests/cli/test_startup.py``).
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

import click

from hybridlog import __version__
from hybridlog.cli_lines import (
    echo_unused_samples,
    for_terminal,
    gate_exit,
    have_warnings,
    one_line,
    path_text,
    say,
    summary_line,
)
from hybridlog.cli_options import (
    analysis_options,
    estimator_option,
    force_option,
    global_flags,
    is_quiet,
    model_option,
    msg_dir_option,
    read_options,
    read_options_given,
    set_option,
    split_options,
)
from hybridlog.cli_process import one_bounded_job, run
from hybridlog.cli_progress import BatchClock, batch_progress, batch_reporter, work_reporter
from hybridlog.cli_types import (
    FILE_OUT,
    FOLDER_OUT,
    PATH,
    DataclassOptions,
    GeneratedOptionsCommand,
    Group,
    Jobs,
    LogFormats,
    PathName,
    WholeNumber,
    comma_list,
)
from hybridlog.environment import check_environment, check_umask, check_working_folder
from hybridlog.estimators import ESTIMATORS
from hybridlog.io.formats import format_list
from hybridlog.model.builtins import builtin_names, builtin_reference, builtin_text


def _examples(*lines: str) -> str:
    """An epilog of example command lines (they run as written from the repository root)."""
    return "\b\nExamples:\n" + "\n".join(f"  {line}" for line in lines)


def _estimators_epilog(*examples: str) -> str:
    """The registered estimators with their summaries, then ``examples``.

    Read from the registry alone (the one list), which imports no estimator module.
    """
    width = max(len(name) for name in ESTIMATORS)
    rows = [f"  {e.name:<{width}}  {e.summary}" for e in ESTIMATORS.values()]
    listing = "\b\nEstimators (options: --set NAME=VALUE, see docs/estimators.md):\n"
    return listing + "\n".join(rows) + "\n\n" + _examples(*examples)


def _chiu_options() -> type[Any]:
    """The clustering options of paper 001's classifier (defaults: MATLAB ``subclust``)."""
    from hybridlog.estimators.observer_options import ChiuOptions

    return ChiuOptions


_CLUSTERING = DataclassOptions(
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
    cls=Group,
    help=_HELP_HYBRIDLOG,
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
    epilog=_examples(
        "hybridlog models",
        "hybridlog analyze sample_logs/three_tank_hstf.csv --model three_tank_hstf "
        "--estimator imm --out first_report",
    ),
)
@click.version_option(__version__, prog_name="hybridlog")
@global_flags
def cli() -> None:
    """The command group; its help is :data:`_HELP_HYBRIDLOG`."""
    # before any command imports numba or polars, here or in its workers
    check_environment()
    check_working_folder()
    check_umask()


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
@global_flags
@click.argument("log", type=PATH)
@click.option("--json", "as_json", is_flag=True, help="Print machine-readable JSON.")
@msg_dir_option
def inspect(log: Path, as_json: bool, msg_dirs: tuple[Path, ...]) -> None:
    """Describe a log (the help text lists the formats from the table of formats)."""
    from hybridlog.io import ReadOptions
    from hybridlog.io.inspect import format_inspection, inspect_log

    info = inspect_log(log, ReadOptions(msg_dirs=tuple(str(d) for d in msg_dirs)))
    click.echo(
        json.dumps(info, indent=2, allow_nan=False)  # NaN is no JSON: never printed
        if as_json
        else for_terminal(format_inspection(info))
    )


@cli.command(
    epilog=_examples("hybridlog models", "hybridlog models three_tank_hstf"), help=_HELP_MODELS
)
@global_flags
@click.argument("name", required=False, type=PathName(path_type=str), metavar="[NAME|FILE]")
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
        click.echo(for_terminal(check_and_describe(path)))
        return
    for builtin in builtin_names():
        click.echo(f"{builtin:20s} {builtin_reference(builtin)}")


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
@global_flags
@click.argument("model_ref", type=PathName(path_type=str), metavar="MODEL")
@click.option(
    "--out",
    "out",
    required=True,
    type=FILE_OUT,
    help="Log to write: .csv, .parquet, .mcap, .bag, or a ROS 2 bag folder with --format.",
)
@click.option(
    "--format",
    "log_format",
    type=LogFormats("LOG_FORMATS"),
    default=None,
    help="Log format [default: from the suffix of --out].",
)
@click.option(
    "--encoding",
    type=LogFormats("MCAP_ENCODINGS"),
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
    type=WholeNumber(min=1),
    default=None,
    help="Number of steps [default: the schedule's total].",
)
@click.option(
    "--seed",
    type=WholeNumber(min=0),
    default=0,
    show_default=True,
    help="Noise seed: the same seed, schedule and --steps give the same log.",
)
@set_option(
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
@force_option("a log file or ROS 2 bag folder hybridlog wrote (never a file of yours)")
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

    with reporting(work_reporter(ctx)):  # a long bag or MCAP file says how long it takes
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
            sets=sets,
        )
    say(ctx, f"wrote {path_text(out)} ({plural(outcome.samples, 'sample')})")
    if not is_quiet(ctx):
        for note in outcome.notes:
            click.echo(one_line(f"hybridlog: note: {note}"), err=True)


@cli.command(
    "cluster",
    cls=GeneratedOptionsCommand,
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
@global_flags
@click.argument("log", type=PATH)
@model_option
@click.option(
    "--out",
    "out",
    type=FILE_OUT,
    default="centers.json",
    show_default=True,
    help="Centres and classifier to write (read by analyze --set centers=FILE).",
)
@click.option(
    "--plot",
    type=FILE_OUT,
    default=None,
    help="Picture of the clusters [default: --out with .png].",
)
@click.option("--compare-kmeans", is_flag=True, help="Also fit k-means and compare.")
@read_options
@force_option("centres and plot files hybridlog wrote (never a file of yours)")
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

    read = read_options_given(options)  # what is left: the clustering options
    with reporting(work_reporter(ctx)):
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
    say(ctx, outcome.table)
    for note in outcome.notes:
        say(ctx, f"- {note}")
    say(ctx, f"centres: {path_text(outcome.centers_path)}, plot: {path_text(outcome.plot_path)}")
    if not is_quiet(ctx):  # as analyze says them of the log
        for alert in outcome.alerts:
            click.echo(one_line(f"hybridlog: {alert}"), err=True)


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
@global_flags
@click.argument("log", type=PATH)
@model_option
@estimator_option
@click.option(
    "--out",
    "out_dir",
    type=FOLDER_OUT,
    default=None,
    help="Output directory [default: <log name>_<estimator> here].",
)
@analysis_options
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
    one_bounded_job()  # before the job's imports: polars' allocator reads its options
    from hybridlog.cluster.progress import reporting
    from hybridlog.jobs.analysis import analyze

    read, common = split_options(options)
    with reporting(work_reporter(ctx)):  # chiu's clustering of a long log says how long
        outcome = analyze(log, model_ref, out_dir=out_dir, estimator=estimator, read=read, **common)
    report = outcome.report
    say(ctx, summary_line(report))
    say(ctx, f"report: {path_text(outcome.out_dir / 'report.md')}")
    if not is_quiet(ctx):  # every kind, as batch and compare count
        from hybridlog.report.markdown import WARNING_PREFIX
        from hybridlog.report.summary_notes import warning_notes

        for warning in warning_notes(report):
            text = warning.removeprefix(WARNING_PREFIX)
            click.echo(one_line(f"hybridlog: warning: {text}"), err=True)
        echo_unused_samples(report)
    gate_exit(outcome.gate_failures)


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
@global_flags
@click.argument("log", type=PATH)
@model_option
@click.option(
    "--estimators",
    required=True,
    metavar="A,B,...",
    callback=lambda ctx, param, value: comma_list(value),
    help="Comma-separated estimator names (listed below).",
)
@click.option(
    "--out",
    "out_dir",
    required=True,
    type=FOLDER_OUT,
    help="Output directory: one report per estimator and comparison.md/.csv.",
)
@analysis_options
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
    one_bounded_job()  # before the job's imports: polars' allocator reads its options
    from hybridlog.cluster.progress import reporting
    from hybridlog.jobs.compare import compare

    read, common = split_options(options)
    names = list(estimators)
    with reporting(work_reporter(ctx)):  # chiu's clustering of a long log says how long
        outcome = compare(log, model_ref, names, out_dir=out_dir, read=read, **common)
    say(ctx, outcome.table)
    if outcome.reports:
        reports = (path_text(out_dir / name / "report.md") for name in outcome.reports)
        say(ctx, f"reports: {', '.join(reports)}")
    say(ctx, f"comparison: {path_text(out_dir / 'comparison.md')}")
    quiet = is_quiet(ctx)
    if outcome.reports and not quiet:  # one log: every report read it alike
        echo_unused_samples(next(iter(outcome.reports.values())))
    for reach in [] if quiet else outcome.reach:  # a tuned estimator beside untuned ones
        click.echo(one_line(f"hybridlog: note: {reach}"), err=True)
    if outcome.warned and not quiet:
        have = have_warnings(len(outcome.warned), len(outcome.reports), "estimator")
        click.echo(one_line(f"hybridlog: {have}; see {out_dir / 'comparison.md'}"), err=True)
    if outcome.unlike and not quiet:  # a VAF over fewer samples is no better VAF
        unlike = "; ".join(outcome.unlike)
        click.echo(
            one_line(f"hybridlog: not like for like: {unlike}; see {out_dir / 'comparison.md'}"),
            err=True,
        )
    for name, reason in outcome.failures.items():  # a result, as a batch's failed log: exit 1
        click.echo(one_line(f"hybridlog: estimator failed: {name}: {reason}"), err=True)
    gate_exit(outcome.gate_failures)
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
@global_flags
@click.argument("logs", nargs=-1, required=True, type=PATH)
@model_option
@estimator_option
@click.option(
    "--out",
    "out_dir",
    required=True,
    type=FOLDER_OUT,
    help="Output directory: one report folder per log (its path from the logs' common "
    "folder, or from the folder of logs given, e.g. d2/run.csv/) and summary.md/.csv/.png.",
)
@click.option(
    "--jobs",
    type=Jobs(min=1),
    default=None,
    help="Logs analysed in parallel (local processes; not with --scheduler, not even 1); "
    "auto: one per core this process may use.  [default: 1]",
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
    type=FILE_OUT,
    metavar="FILE",
    help="Write JUnit XML: a test case per log per gate, an error per log not analysed.",
)
@analysis_options
@click.pass_context
def batch_command(
    ctx: click.Context,
    /,
    logs: Sequence[Path],
    model_ref: str,
    estimator: str | None,
    out_dir: Path,
    jobs: int | Literal["auto"] | None,
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
        workers = 1 if jobs is None else jobs
    if workers > 1 and scheduler is None and total > 1:
        # run_batch's workers fork from this forkserver: started before the batch job's
        # imports, it warms up while this process imports polars and numpy
        from hybridlog.jobs.workers import start_forkserver

        start_forkserver()
    from hybridlog.cluster.progress import reporting
    from hybridlog.jobs.batch import run_batch

    read, common = split_options(options)
    clock = BatchClock()
    with batch_progress(ctx, total, clock) as advance, reporting(batch_reporter(ctx, clock)):
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
    say(ctx, outcome.table)
    say(ctx, f"summary: {path_text(out_dir / 'summary.md')}")
    waited = outcome.waited_for_memory
    quiet = is_quiet(ctx)
    if not quiet:
        for note in outcome.notes:
            click.echo(one_line(f"hybridlog: note: {note}"), err=True)
    if waited and not quiet:
        seconds = sum(log.memory_wait_s for log in waited)
        click.echo(
            f"hybridlog: note: {len(waited):,} of {len(outcome.logs):,} logs waited "
            f"{seconds:.0f} s in all for memory held by the other workers' logs: "
            f"{'the Dask workers' if scheduler is not None else f'--jobs {jobs}'} ran fewer "
            "logs at once where all would not fit",
            err=True,
        )
    warned = outcome.warned
    if warned and not quiet:  # one line, not one a log
        analysed = sum(1 for log in outcome.logs if log.report is not None)
        have = have_warnings(len(warned), analysed, "analysed log")
        click.echo(one_line(f"hybridlog: {have}; see {out_dir / 'summary.md'}"), err=True)
    if outcome.failed:
        failed = f"{outcome.failed:,} of {len(outcome.logs):,} logs failed"
        click.echo(one_line(f"hybridlog: {failed} (see {out_dir / 'summary.md'})"), err=True)
    gate_exit(outcome.gate_failures)
    if outcome.failed:
        sys.exit(1)


def main(argv: Sequence[str] | None = None) -> None:
    """Console entry point: run the CLI; every failure becomes one line and an exit code.

    Exit codes: 0 success, 1 a CI gate failed (or a batch's log or a compared estimator
    failed on its log), 2 bad usage or bad input, 130 interrupted; without ``argv`` (the
    console script, ``python -m hybridlog``) the process ends with the command
    (:func:`hybridlog.cli_process.run`).
    """
    run(cli, argv)
