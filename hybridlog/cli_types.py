"""The click building blocks of the command line: parameter types and command classes.

Parameter types read a value strictly (:class:`PathName`: no empty name, a leading ``~``
as the shell makes it; :class:`WholeNumber`, :class:`Number`: :mod:`hybridlog.numbers`'s
parsers, a range said in words; :class:`Jobs`, :class:`LogFormats`, :func:`comma_list`).
:class:`_Command` refuses an option that takes one value given twice;
:class:`DataclassOptions` makes a command's options from an options dataclass, on first use
(:class:`GeneratedOptionsCommand`), each read by its field's type (:class:`_FieldValue`).

Light, as :mod:`hybridlog.cli`: click and hybridlog's light modules only.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click

from hybridlog.errors import excerpt
from hybridlog.estimators.options import describe_options, read_text, shown
from hybridlog.numbers import parse_float, parse_int


class PathName(click.Path):
    """A file or folder name; an empty one is refused (pathlib reads ``""`` as ``.``).

    ``--out ""`` was the working folder (``--out . contains the log``), ``analyze ""`` the
    log ``.``, ``cluster --out ""`` an unexpected error.

    A leading ``~`` or ``~user`` is the home folder, as the shell makes it of ``--out ~/r``
    but not of ``--out=~/r`` nor of a quoted ``"~/r"``: those wrote a folder named ``~`` in
    the working folder (which a later ``rm -r ~`` would take for the home).  A ``~user``
    the system does not know is refused; ``./~`` names a file called ``~``.

    A name of blanks only is refused too; and, for a name hybridlog writes (``written``),
    a part of it still to be made that starts or ends with a blank: ``--out " "`` wrote a
    folder that ``ls`` shows as nothing, ``--out "  r1"`` one that reads as ``r1``.  Folders
    that exist already are taken as they are named.
    """

    def __init__(self, *, written: bool = False, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.written = written

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        """The name as a path, ``~`` expanded; a usage error for an empty name or unknown user."""
        if isinstance(value, str) and not value:
            self.fail("an empty name", param, ctx)
        if isinstance(value, str) and value.isspace():
            self.fail(f"a name of blanks only, {excerpt(value)}", param, ctx)
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
        if self.written and isinstance(value, str):
            blank = _blank_at_an_end(value)
            if blank is not None:
                part = "" if blank == value.rstrip("/") else f": its part {excerpt(blank)}"
                self.fail(
                    f"{excerpt(value)}{part} starts or ends with a blank; write it without "
                    "(a file or folder named so is easily taken for another)",
                    param,
                    ctx,
                )
        return super().convert(value, param, ctx)


def _blank_at_an_end(name: str) -> str | None:
    """The first part of ``name`` still to be made that starts or ends with a blank, or None.

    Parts from the first that does not exist on: a folder already there is taken as named.
    """
    parts = name.split("/")
    for k, part in enumerate(parts):
        if not part or part in (".", ".."):
            continue
        if os.path.lexists("/".join(parts[: k + 1])):
            continue
        for later in parts[k:]:
            if later != later.strip():
                return later
        return None
    return None


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


PATH = PathName(path_type=Path)
"""The type of every file or folder argument and option but one hybridlog writes."""


FOLDER_OUT = PathName(path_type=Path, written=True)
"""The type of an option naming a folder to write (``--out`` of analyze, compare, batch)."""


FILE_OUT = PathName(path_type=str, written=True)
"""The type of an option naming a file to write: the text as given, whose ``/`` at the end
(``--out dir.json/``, meaning a folder) a ``Path`` would drop; the job refuses it
(:func:`hybridlog.outputs.check_file_name`)."""


class _Strict(click.ParamType[Any]):
    """A click number type whose text is read by a strict parser of :mod:`hybridlog.numbers`.

    click's ``INT`` and ``FLOAT`` read with Python's ``int()`` and ``float()``, which take
    underscores, any Unicode digits, and ``inf``/``nan``; the subclass' click base then does
    the rest.  A value out of the range (``min``, ``max``) is refused in the words of the
    other refusals, ``expected a whole number of at least 1, got 0``, which ``--help`` uses
    too (``[at least 1]``): click's were ``0 is not in the range x>=1``.
    """

    parse: Callable[[str], object]
    noun: str
    # the range, set by the subclass' click base (click.IntRange, click.FloatRange)
    min: Any
    max: Any
    min_open: bool
    max_open: bool

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        """The number read strictly and in range; a usage error saying what is expected."""
        if isinstance(value, str):
            try:
                value = type(self).parse(value)
            except ValueError as err:
                reason = str(err)
                if reason.startswith("expected "):
                    reason = f"expected {self._expected(reason.removeprefix('expected '))}"
                self.fail(f"{reason}, got {excerpt(value)}", param, ctx)
        low = self.min is not None and (value <= self.min if self.min_open else value < self.min)
        high = self.max is not None and (value >= self.max if self.max_open else value > self.max)
        if low or high:
            within = self._describe_range()  # a number of at least 1, a number from 0 to 9
            within = f"of {within}" if within.startswith("at ") else within
            expected = self._expected(f"{self.noun} {within}")
            self.fail(f"expected {expected}, got {shown(value)}", param, ctx)
        return super().convert(value, param, ctx)

    def _expected(self, what: str) -> str:
        """What the option takes, as an error says it after ``expected``."""
        return what

    def _describe_range(self) -> str:
        """The range in words: ``at least 1``, ``from 0 to 1e+09``, ``above 0``."""
        if self.min is not None and self.max is not None and not (self.min_open or self.max_open):
            return f"from {shown(self.min)} to {shown(self.max)}"
        words = []
        if self.min is not None:
            words.append(f"{'above' if self.min_open else 'at least'} {shown(self.min)}")
        if self.max is not None:
            words.append(f"{'below' if self.max_open else 'at most'} {shown(self.max)}")
        return " and ".join(words)


class WholeNumber(_Strict, click.IntRange):
    """A whole-number option read by :func:`~hybridlog.numbers.parse_int` (``1_0`` refused)."""

    parse = staticmethod(parse_int)
    noun = "a whole number"


class Jobs(WholeNumber):
    """``--jobs``: a whole number of at least 1, or ``"auto"``, the cores this process may use.

    ``auto`` is passed on as such (:func:`~hybridlog.jobs.batch.run_batch` counts the
    cores), so that a note or an error says ``--jobs auto``, not the count the user did
    not write.
    """

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        """``"auto"`` (any case) as it is, else the whole number; a usage error otherwise."""
        if isinstance(value, str) and value.strip().lower() == "auto":
            return "auto"
        return super().convert(value, param, ctx)

    def _expected(self, what: str) -> str:
        return f"{what} or auto"

    def get_metavar(self, param: click.Parameter, ctx: click.Context) -> str:
        """``N|auto`` in ``--help``."""
        return "N|auto"


class Number(_Strict, click.FloatRange):
    """A number option read by :func:`~hybridlog.numbers.parse_float` (finite, ASCII only)."""

    parse = staticmethod(parse_float)
    noun = "a number"


class LogFormats(click.Choice[str]):
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
        """The names listed by :mod:`hybridlog.io.bag_writers` (imported now)."""
        from hybridlog.io import bag_writers

        return tuple(getattr(bag_writers, self._name))

    @choices.setter
    def choices(self, value: Sequence[str]) -> None:
        """Ignored: click's constructor sets the choices, which are read instead."""


def comma_list(value: str) -> tuple[str, ...]:
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

    A usage error click's parser raises without the command (``--model`` at the end, its
    value missing) is given it, so that the message names the command and its ``--help``.

    Nor is an option's value one of the command's option names: click took the next word
    whatever it was, so ``--out --force`` (the folder's name forgotten) wrote a folder named
    ``--force`` and lost the ``--force`` asked for, and ``--model -q`` read a model ``-q``.
    A value that starts with a short option (``--out -qh``: ``-q -h`` run together) is so
    too.  A file of such a name is still given as ``./--force``.
    """

    def parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        try:
            return self._parse_args(ctx, args)
        except click.UsageError as err:
            # click's parser raises some without the context (an option's value missing,
            # `--force=1`): they named `hybridlog` and its --help, not the command's
            if err.ctx is None:
                err.ctx = ctx
            raise

    def _parse_args(self, ctx: click.Context, args: list[str]) -> list[str]:
        if args and not ctx.resilient_parsing:
            values, _, order = self.make_parser(ctx).parse_args(args=list(args))
            _refuse_option_names_as_values(self.get_params(ctx), values, ctx)
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


def _refuse_option_names_as_values(
    params: Sequence[click.Parameter], values: Mapping[str, Any], ctx: click.Context
) -> None:
    """A usage error where an option's value is the name of an option of the command."""
    options = [param for param in params if isinstance(param, click.Option)]
    names = {name for option in options for name in (*option.opts, *option.secondary_opts)}
    for param in options:
        if param.is_flag or param.name not in values:
            continue
        given = values[param.name]
        for value in given if isinstance(given, (list, tuple)) else [given]:
            if not isinstance(value, str):
                continue
            exact = value.partition("=")[0] in names
            # -qh: short options run together, as click reads them where an option may stand
            joined = value[1:2] not in ("", "-") and value[:2] in names
            if exact or joined:
                file = (
                    f" (a file of that name: ./{value})"
                    if isinstance(param.type, click.Path)
                    else ""
                )
                raise click.BadParameter(
                    f"got {excerpt(value)}, which {'is' if exact else 'starts with'} an "
                    "option of this command: give "
                    f"{param.opts[0]} its value before it{file}",
                    ctx=ctx,
                    param=param,
                    param_hint="/".join([*param.opts, *param.secondary_opts]),
                )


class Group(click.Group):
    """The ``hybridlog`` group: its commands are :class:`_Command` s."""

    command_class = _Command


_METAVARS = {"str": "TEXT", "int": "INTEGER", "float": "FLOAT", "bool": "BOOLEAN"}
"""click's names of plain option types; choices and optional types show as ``[a|b]``."""


@dataclass(frozen=True)
class DataclassOptions:
    """Command-line options generated from an options dataclass: its one definition.

    Each named field becomes ``--field-name VALUE`` whose help, default and type come from
    the field (:func:`~hybridlog.estimators.options.describe_options`); a value given is read
    and checked as the command line is parsed (:class:`_FieldValue`, exactly like a ``--set``
    value), so that a bad one is a usage error like any other option's, and fields not given
    keep the dataclass's defaults.  Whether the values go together (``conflicts()``: ``reject``
    below ``accept``) is the job's to check, with the values of the model file's table
    (:attr:`table`) the others take.  A ``Literal`` field may instead be a switch between
    two of its choices (``--exact/--approximate``).

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
                    type=_FieldValue(self.load, name),
                    default=None,
                    metavar=_METAVARS.get(info.type, f"[{info.type}]"),
                    help=f"{info.help} [{default}{limits}]",
                )
            )
        return params

    def parse(self, given: Mapping[str, Any]) -> Any:
        """The dataclass from the values given on the command line (``None``: not given).

        Each value was read by its option's type (:class:`_FieldValue`); how they go
        together is not checked here: ``--reject 0.7`` was refused against ``accept``'s
        default 0.5 (``0.7 is not below accept = 0.5 (its default)``) where the model file
        sets ``accept = 0.9``, which is the default the help promises.
        """
        values: dict[str, Any] = {}
        for name, value in given.items():
            if value is None:
                continue
            values[name] = (
                self.switches[name][0 if value else 1] if name in self.switches else value
            )
        return self.load()(**values)


class _FieldValue(click.ParamType[Any]):
    """The value of one option of an options dataclass, read as a ``--set`` value is.

    :func:`~hybridlog.estimators.options.read_text`: the field's type, choices, range and
    check; a bad value is a usage error naming the option (``hybridlog cluster: --radius:
    expected a finite number, got 'abc' (see hybridlog cluster --help)``), where the
    command's own check said ``hybridlog: error: --radius abc: chiu option 'radius': ...``.
    """

    name = "value"

    def __init__(self, load: Callable[[], type[Any]], field: str) -> None:
        self._load = load
        self._field = field

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        """The field's value read from the text; a usage error with the reason otherwise."""
        if not isinstance(value, str):
            return value
        try:
            return read_text(self._load(), self._field, value)
        except ValueError as err:
            self.fail(str(err), param, ctx)


class GeneratedOptionsCommand(_Command):
    """A command with options generated by a :class:`DataclassOptions` on first use.

    The options are made when the command's parameters are first needed (to parse its
    arguments or show its help), after the parameter named ``after``.
    """

    def __init__(self, *args: Any, generated: DataclassOptions, after: str, **kwargs: Any) -> None:
        self._generated: DataclassOptions | None = generated
        self._after = after
        super().__init__(*args, **kwargs)

    @property
    def params(self) -> list[click.Parameter]:
        """The command's parameters, the generated options among them (made on first use)."""
        if self._generated is not None:
            generated, self._generated = self._generated, None
            at = [p.name for p in self._params].index(self._after) + 1
            self._params[at:at] = generated.params()
        return self._params

    @params.setter
    def params(self, value: list[click.Parameter]) -> None:
        self._params = value
