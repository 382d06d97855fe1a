"""The process running a command line: failures as one line and an exit code, signals, the end.

:func:`run` runs the click group: hybridlog's errors, click's usage errors, numerical
trouble and anything unexpected become one line on stderr and exit code 2 (``--debug``:
the traceback).  Run as the console script (no ``argv``), it also handles ``SIGTERM`` and
``SIGHUP`` as an exception (:func:`_end_on_signal`), sets what only a whole process may set
for a job bounded by one log (:func:`one_bounded_job`) and ends the process itself
(:func:`_end_process`).
"""

from __future__ import annotations

import atexit
import contextlib
import difflib
import errno
import gc
import importlib
import os
import signal
import sys
import traceback
import warnings
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import NoReturn

import click

from hybridlog.allocators import return_freed_memory
from hybridlog.background import ESTIMATES, PLOTS, start_worker
from hybridlog.cli_lines import one_line
from hybridlog.errors import HybridlogError, as_text, excerpt
from hybridlog.launch import lost_output, single_threaded_blas, tolerate_closed_output
from hybridlog.limits import limit_reached


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
    error = KeyboardInterrupt() if signum == signal.SIGINT else _Terminated(128 + signum)
    _RAISED[:] = [error]
    raise error


_RAISED: list[BaseException] = []
"""The exception :func:`_end_on_signal` raised, to tell it where Python drops it."""


def _raise_dropped_signal(
    previous: Callable[[sys.UnraisableHookArgs], object],
) -> Callable[[sys.UnraisableHookArgs], None]:
    """A ``sys.unraisablehook`` that sends the ending signal again when its exception is dropped.

    Python drops an exception raised inside a finaliser (``__del__``) or a callback it
    calls from C, printing "Exception ignored in" and a traceback.  Ctrl-C while numba
    compiled in a batch's own process (``--jobs 1``) came inside llvmlite's ``__del__``: the
    command went on to its end and exit 0, every later signal dropped as the command was
    taken to be ending.  The signal is sent again, from a thread, to be raised once the
    finaliser returned (again, should it come inside another).  Other exceptions go to
    ``previous``.
    """

    def hook(unraisable: sys.UnraisableHookArgs) -> None:
        if not (_RAISED and unraisable.exc_value is _RAISED[0]):
            previous(unraisable)
            return
        import threading  # here: a dropped signal only
        import time

        signum = _ENDING[0]

        def send_again() -> None:
            # later, and only then taken as not ending: raised at once, it came inside this
            # hook (starting a thread waits for it), which drops it too
            time.sleep(_SEND_AGAIN_S)
            _RAISED.clear()
            _ENDING.clear()
            os.kill(os.getpid(), signum)

        threading.Thread(target=send_again, daemon=True).start()

    return hook


_SEND_AGAIN_S = 0.05
"""How long after a dropped signal's exception it is sent again (:func:`_raise_dropped_signal`)."""


def _handle_ending_signals() -> None:
    """Install :func:`_end_on_signal` for ``SIGTERM``, ``SIGHUP`` and a ``SIGINT`` not ignored.

    A ``SIGINT`` the caller ignores (``nohup``, a script's background job) stays ignored, as
    does one whose action was set outside Python (:func:`signal.getsignal` gives None).
    """
    for ending in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(ending, _end_on_signal)
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _end_on_signal)
    sys.unraisablehook = _raise_dropped_signal(sys.unraisablehook)


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


def one_bounded_job() -> None:
    """Skip the cyclic garbage collector for a job whose work is bounded (one log).

    Only when the process runs this one command and ends (:func:`run` without ``argv``):
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


def run(group: click.Group, argv: Sequence[str] | None = None) -> None:
    """Run ``group`` on ``argv``; every failure becomes one line and an exit code.

    :func:`hybridlog.cli.main`, the console entry point, runs the ``hybridlog`` group.  Without
    ``argv`` (the console script, ``python -m hybridlog``) the command line is ``sys.argv``
    and this process runs the one command and ends.

    Exit codes: 0 success, 1 a CI gate failed (or a batch's log or a compared estimator
    failed on its log), 2 bad usage or bad input (hybridlog's
    errors, click's usage errors, numerical trouble, anything unexpected), 130 interrupted.
    ``--debug`` (anywhere on the line) prints the traceback before the line, the exit code
    unchanged; called in-process (``argv`` given) it re-raises instead.
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
            result = group.main(args=args, prog_name="hybridlog", standalone_mode=False)
            code = result if isinstance(result, int) else 0
    except click.exceptions.NoArgsIsHelpError as err:
        click.echo(err.format_message())
    except click.exceptions.Abort:
        click.echo("hybridlog: aborted", err=True)
        code = 130
    except click.UsageError as err:
        click.echo(one_line(_usage_message(err, args)), err=True)
        code = 2
    except click.ClickException as err:
        click.echo(one_line(f"hybridlog: error: {err.format_message()}"), err=True)
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
            if not _PROCESS["one_command"]:
                raise  # called in-process (a test, a debugger's session): the exception
            # The process: the traceback, then the one line and the exit code it always has
            # (re-raised, Python's 1 would read as a failed CI gate).
            traceback.print_exception(err, file=sys.stderr)
        click.echo(one_line(_failure(err)), err=True)
        code = 2
    finally:
        for warning in caught:
            category = warning.category.__name__
            click.echo(one_line(f"hybridlog: note: {category}: {warning.message}"), err=True)
    if _PROCESS["one_command"]:
        code = _said_lost_output(code)
        if sys.getprofile() is None and sys.gettrace() is None:
            _end_process(code)
    if code:
        sys.exit(code)


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
    elif isinstance(err, click.NoSuchOption) and (owners := _owners(err)):
        close = [
            known
            for known in err.possibilities or ()
            if difflib.SequenceMatcher(None, err.option_name, known).ratio() >= _CLOSE
        ]
        mean = f"; did you mean {close[0]!r}?" if close else ""
        prefix, message = "", f"no such option {err.option_name!r} ({owners}){mean}"
    else:
        prefix, message = "", err.format_message()
    message = message.strip().rstrip(".")
    message = message[:1].lower() + message[1:]  # the hint as it is: LOG, not lOG
    return f"{command}: {prefix}{message}{_dash_file(err, args)} (see {command} --help)"


_CLOSE = 0.8
"""How like the unknown option one of the command's must be to be suggested beside the other
commands that have it (``--estimators`` for ``--estimator``, not ``--help`` for ``--model``)."""


def _owners(err: click.NoSuchOption) -> str:
    """The other commands that have the unknown option, in words, or ``""``.

    ``hybridlog inspect LOG --model M`` said ``Did you mean '--help'?``, and ``hybridlog
    --json inspect LOG`` ``Did you mean '--version'?``: click suggests the option most like it
    among those of the command it was given to, however unlike.
    """
    if err.ctx is None:
        return ""
    root = err.ctx.find_root()
    group = root.command
    if not isinstance(group, click.Group):
        return ""
    owners = [
        name
        for name, command in sorted(group.commands.items())
        if command is not err.ctx.command
        and any(
            err.option_name in (*param.opts, *param.secondary_opts)
            for param in command.get_params(root)
            if isinstance(param, click.Option)
        )
    ]
    if not owners:
        return ""
    listed = owners[0] if len(owners) == 1 else f"{', '.join(owners[:-1])} and {owners[-1]}"
    where = "; give it after the command" if err.ctx.command is group else ""
    return f"an option of {listed}{where}"


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
            "a container); free memory, or give less work (a shorter log; simulate: fewer "
            "--steps)"
        )
    if isinstance(err, OSError) and (limit := limit_reached(err)) is not None:
        return f"hybridlog: error: {limit.what}{_where(err)} ({limit.detail}); {limit.advice}"
    if isinstance(err, OSError) and err.errno == errno.ENAMETOOLONG and err.filename:
        # a name given (--model, --junit, --msg-dir, a centres file) that the system refuses
        # to look up: pathlib's is_file() and exists() raise it, where they answer False
        # for a missing file; it was "unexpected OSError ... (a bug ...)"
        name = excerpt(os.fsdecode(err.filename))
        return (
            f"hybridlog: error: {name}: the name is too long for the file system "
            f"({err.strerror}); give a shorter one"
        )
    return (
        f"hybridlog: error: unexpected {type(err).__name__}{_where(err)}: {err} "
        "(a bug, or an input hybridlog does not check yet; --debug shows the traceback)"
    )


def _where(err: BaseException) -> str:
    """``module.py:line`` of the innermost hybridlog frame of a traceback, or ``""``."""
    package = str(Path(__file__).parent)
    frames = [f for f in traceback.extract_tb(err.__traceback__) if f.filename.startswith(package)]
    if not frames:
        return ""
    frame = frames[-1]
    return f" in {Path(frame.filename).name}:{frame.lineno}"


def _said_lost_output(code: int) -> int:
    """The exit code, 2 in place of 0 where stdout could not be written (:func:`lost_output`).

    ``hybridlog inspect LOG > file`` on a full disk lost what it printed: one line says so
    on stderr.  A reader that left (``| head -1``) is no failure.
    """
    lost = lost_output()
    if lost is None:
        return code
    click.echo(one_line(f"hybridlog: error: cannot write to standard output ({lost})"), err=True)
    return code or 2


def _end_process(code: int) -> NoReturn:
    """End the console script's process: atexit handlers, stdout and stderr, then ``_exit``.

    Everything the command wrote is closed and every thread and child it started has been
    waited for, so what is left dies with the process.  The interpreter's teardown would
    clear every module and free the objects of numpy, polars, numba, sympy and matplotlib one
    by one: 0.06-0.09 s of a 10^6-row ``analyze`` (six runs each, interleaved: median wall
    1.80 → 1.73 s), and before the collector was frozen at exit 0.6 s.  What libraries ask
    to be done at exit (``atexit``) still runs, and both streams are flushed; a stream that
    cannot be flushed (a closed pipe) does not change the exit code.  :func:`run` does not
    call it under a profiler, tracer or debugger (``python -m cProfile -m hybridlog``,
    coverage, pdb): they write their results after ``main`` returns.
    """
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):  # None: closed when the process started (>&-)
        with contextlib.suppress(OSError, ValueError):
            if stream is not None:
                stream.flush()
    os._exit(code)
