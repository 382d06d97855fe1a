"""Which ``[parameters]`` a command reads: a ``--set`` of one it never reads changes nothing.

The loader refuses ``--set`` of a parameter no string of the model names
(``_refuse_unused_overrides``).  A parameter can be named and still be read by nothing a
command runs: ``analyze`` reads no ``[simulation]`` table (``q0`` of the valve three-tank sets
the inflow ``simulate`` plays only), ``simulate`` reads no equation of a mode its scenario
never plays (``c_out`` of the BIO-Plex chamber enters only its ``leak`` mode) and no jump map
of a switch its schedule never makes (``[jumps."0->1"]`` of a run in mode ``0`` throughout),
and no command reads a name in a key that holds no expression as an expression (a mode id,
a log path under ``[signals]``, an option value under ``[estimators.<name>]``: a parameter
``kbest`` beside ``mode_sequence = "kbest"``).  Each ran with the ``--set`` value recorded and
the output the same as without it.  Like an estimator option the others make inert (``beam``
without ``kbest``), such a ``--set`` is refused in one line, naming the keys that name it and
why each is not read.

A schedule decides, the same for every ``--seed``, which modes a run plays and which switches
it makes, where guards would not: a model switched by guards reads every mode and every jump
map, so that the seed never decides a refusal.

Names are read from the model file's text as the loader reads them: the identifiers (NFKC) of
every string outside the prose keys, sorted by the key that holds each (:func:`_leaves`).
"""

from __future__ import annotations

import json
import re
import unicodedata
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from hybridlog.errors import OptionError, excerpt
from hybridlog.model.toml_text import key_path, read_toml

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["refuse_unread_by_analysis", "refuse_unread_by_simulation", "unread_parameters"]

PROSE_KEYS = frozenset({"name", "description", "reference"})
"""Top-level keys whose strings are prose, not expressions: no name in them is read as a symbol
(the loader's :func:`~hybridlog.model.loader._refuse_unused_overrides` reads past them too)."""

_IDENTIFIER = re.compile(r"[^\W\d]\w*")


def identifiers(text: str) -> frozenset[str]:
    """The names a string of a model file could read, as the loader reads them (NFKC)."""
    return frozenset(_IDENTIFIER.findall(unicodedata.normalize("NFKC", text)))


Path = tuple[str, ...]

_NO_EXPRESSION_TABLES = frozenset(
    {
        "time",
        "dt",
        "integration",  # method, step
        "states",
        "inputs",
        "outputs",
        "booleans",
        "variables",
        "commands",  # symbol names
        "default_estimator",
        "estimators",  # option values: numbers, choices, paths, eigenvalue lists
        "signals",
        "truth",  # log paths
        "initial",  # numbers and mode ids
        "transitions",  # probabilities
        "noise",  # variances
    }
)
"""Top-level keys whose strings no command reads as an expression (the loader's readers)."""

_NO_EXPRESSION_COMPONENT_KEYS = frozenset({"initial", "transitions", "unknown", "description"})
"""Keys of ``[components.<c>]`` that hold mode ids, command values, probabilities and prose."""

_NO_EXPRESSION_SIMULATION_KEYS = frozenset(
    {"state", "state_min", "steps", "schedule", "parameters", "modes", "commands"}
)
"""Keys of ``[simulation]`` that hold numbers, mode ids and scenario steps only (steps name
``[simulation.parameters]``, never ``[parameters]``: the two share no name)."""

_NO_EXPRESSION_UNMODELLED_KEYS = frozenset({"component", "description", "start", "end"})


def _holds_no_expression(path: Path) -> Path | None:
    """``path`` when no command reads the string at this key as an expression, else ``None``."""
    head = path[:1]
    if head and head[0] in _NO_EXPRESSION_TABLES:
        return path
    if head == ("components",) and len(path) >= 3:
        if path[2] in _NO_EXPRESSION_COMPONENT_KEYS:
            return path
        if path[2] == "modes" and path[4:] == ("description",):  # a mode's prose
            return path
    if head == ("simulation",) and len(path) >= 2:
        if path[1] in _NO_EXPRESSION_SIMULATION_KEYS:
            return path
        if path[1] == "unmodelled" and path[3:4] and path[3] in _NO_EXPRESSION_UNMODELLED_KEYS:
            return path
        if path[1:3] == ("controller", "states"):
            return path
    return None


def _leaves(value: Any, path: Path = ()) -> Iterator[tuple[Path, str]]:
    """Every string in a parsed TOML value with its key path.

    The strings of an array share its path (``modes.1.f``); the tables of an array of
    tables are told apart by their index, ``[i]`` (``simulation.unmodelled``, ``[i]``).
    """
    if isinstance(value, str):
        yield path, value
    elif isinstance(value, dict):
        for key, item in value.items():
            if not (path == () and key in PROSE_KEYS):
                yield from _leaves(item, (*path, str(key)))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            yield from _leaves(item, (*path, f"[{i}]") if isinstance(item, dict) else path)


def _named_by(model: HybridModel) -> list[tuple[Path, frozenset[str]]]:
    """Each string's key path and the identifiers it names (as the parser reads names)."""
    return [(path, identifiers(text)) for path, text in _leaves(read_toml(model.source))]


@dataclass(frozen=True)
class _Unread:
    """A part of the model file a command does not read.

    ``table``: the table of a string's key path that lies in this part (shown in the error),
    or ``None`` when the key is elsewhere; ``why``: how the error says it, ``{tables}``
    standing for the tables found; ``show``: how it names a table.
    """

    table: Callable[[Path], Path | None]
    why: str
    show: Callable[[Path], str]


def _dotted(path: Path) -> str:
    """A key path as the loader's errors write it (``estimators.imm.mode_sequence``)."""
    shown = ""
    for key in path:
        indexed = key.startswith("[") and key.endswith("]") and key[1:-1].isdigit()
        shown = f"{shown}{key}" if indexed else key_path(shown, key)
    return shown


_NO_EXPRESSION = _Unread(
    _holds_no_expression,
    "in keys no command reads as expressions ({tables})",
    _dotted,
)


def _given(name: str, texts: Mapping[str, str]) -> str:
    return f"--set {excerpt(name)[1:-1]}={excerpt(texts[name])[1:-1]}"


def _unread_only(
    model: HybridModel, texts: Mapping[str, str], parts: Sequence[_Unread]
) -> Iterator[tuple[str, list[tuple[_Unread, list[Path]]]]]:
    """Each ``--set`` parameter named only in ``parts``, with the tables of each part naming it.

    The first part whose ``table`` takes a key decides it; a key no part takes is read.
    """
    if not texts:
        return
    leaves = _named_by(model)
    for name in texts:
        found: dict[int, list[Path]] = {}
        for path, names in leaves:
            if name not in names:
                continue
            taken = next(
                ((i, t) for i, part in enumerate(parts) if (t := part.table(path)) is not None),
                None,
            )
            if taken is None:
                break  # a key the command reads
            found.setdefault(taken[0], [])
            if taken[1] not in found[taken[0]]:
                found[taken[0]].append(taken[1])
        else:
            if found:  # (named nowhere: the loader refused it)
                yield name, [(parts[i], tables) for i, tables in sorted(found.items())]


def _why(where: list[tuple[_Unread, list[Path]]]) -> str:
    return " and ".join(
        part.why.format(tables=", ".join(map(part.show, tables))) for part, tables in where
    )


_SIMULATION = _Unread(
    lambda path: path[:1] if path[:1] == ("simulation",) else None,
    "under [simulation], the scenario `hybridlog simulate` plays, which no estimator reads",
    lambda path: "simulation",
)


def refuse_unread_by_analysis(model: HybridModel, texts: Mapping[str, str]) -> None:
    """Refuse ``--set`` of a parameter no estimator reads (analyze, compare, batch).

    ``texts``: the ``--set`` values of model parameters, as typed.  Unread: ``[simulation]``
    and every key that holds no expression (:func:`_holds_no_expression`).

    Raises
    ------
    OptionError
        ``--set q0=5: parameters.q0 of <model> is named only under [simulation] ...``.
    """
    for name, where in _unread_only(model, texts, (_NO_EXPRESSION, _SIMULATION)):
        raise OptionError(
            f"{_given(name, texts)}: parameters.{name} of {model.origin or model.name} is "
            f"named only {_why(where)}: it would change nothing here"
        )


def unread_parameters(model: HybridModel) -> list[str]:
    """A ``NOTE:`` line per ``[parameters]`` entry no expression of the model reads.

    Named in no string outside the prose keys, or only in keys that hold no expression
    (:func:`_holds_no_expression`): a value the file gives that no command uses, a leftover
    of an edit or the intended spelling of a name the equations write otherwise (a name they
    use that is no parameter is refused), said by ``hybridlog models FILE`` (a ``--set`` of
    it is refused).
    """
    leaves = _named_by(model)
    lines = []
    for name in model.parameters:
        tables = [p for p, names in leaves if name in names]
        if any(_holds_no_expression(p) is None for p in tables):
            continue
        where = sorted({_dotted(p) for p in tables})
        named = f"named only in {', '.join(where)}, read as no expression" if where else ""
        lines.append(
            f"NOTE: parameters.{name} is read by no expression of the model"
            f"{f' ({named})' if named else ''}: a leftover, or a name the equations spell "
            "otherwise?"
        )
    return lines


def refuse_unread_by_simulation(
    model: HybridModel,
    texts: Mapping[str, str],
    played: Mapping[str, Collection[str]],
    unreached: Mapping[str, Mapping[str, int]] | None = None,
    switches: Collection[tuple[str, str]] | None = None,
    unmade: Mapping[tuple[str, str], int] | None = None,
    unstarted: Mapping[int, int] | None = None,
) -> None:
    """Refuse ``--set`` of a parameter named only by what the simulated run never read.

    ``played``: component name → the ids of its modes the run played (``""`` for the modes
    of a model without components, ``modes.<id>``); a mode's table is left out of the names
    when it was not played.
    ``unreached``: as ``played``, the modes of the schedule (``--schedule``, ``[simulation]
    schedule`` or ``simulation.modes``) the run ended before → the step the schedule starts
    each, which the error then asks ``--steps`` to reach.
    ``switches``: the switches ``(from id, to id)`` the run made; a jump map
    (``[jumps."a->b"]``, ``"*->b"``) that none of them applied is left out of the names
    (``None``: every jump map is read).  ``unmade``: the switches of the schedule the run
    ended before → the step the schedule makes each.
    ``unstarted``: the unmodelled behaviours of a components model's scenario the run ended
    before (their index in ``simulation.unmodelled``) → the step the scenario starts each;
    their equations are left out of the names.
    Keys that hold no expression are never read (:func:`_holds_no_expression`).  Checked
    after the run, before anything is written.

    A model whose guards switch its modes reads every mode and jump map, guards and all:
    which modes a run enters depends on the states its noise draws, so the same command was
    refused with one ``--seed`` and ran with another (and the error asked for a
    ``--schedule``, which such a model refuses).  Only a schedule decides, whatever the seed,
    which modes a run plays and which switches it makes.

    Raises
    ------
    OptionError
        ``--set c_out=1e300: parameters.c_out of <model> is named only by modes this run
        never plays (components.pgc.modes.leak) ...``.
    """
    parts = [_NO_EXPRESSION]
    if not model.state_driven:

        def mode_unplayed(path: Path) -> Path | None:
            if path[:1] == ("components",) and len(path) >= 4 and path[2] == "modes":
                return path[:4] if path[3] not in played.get(path[1], ()) else None
            if path[:1] == ("modes",) and len(path) >= 2 and "" in played:
                return path[:2] if path[1] not in played[""] else None
            return None

        parts.append(_Unread(mode_unplayed, "by modes this run never plays ({tables})", ".".join))
        if switches is not None:
            applied = {_applied(model, switch) for switch in switches}

            def jump_unmade(path: Path) -> Path | None:
                if path[:1] == ("jumps",) and len(path) >= 2 and _ends(path[1]) not in applied:
                    return path[:2]
                return None

            parts.append(
                _Unread(
                    jump_unmade,
                    "by jump maps of switches this run never makes ({tables})",
                    lambda path: f"jumps.{_shown(path[1])}",
                )
            )
    if unstarted:

        def behaviour_unstarted(path: Path) -> Path | None:
            if path[:2] == ("simulation", "unmodelled") and len(path) >= 3:
                return path[:3] if path[2] in {f"[{i}]" for i in unstarted} else None
            return None

        parts.append(
            _Unread(
                behaviour_unstarted,
                "by unmodelled behaviours it never starts ({tables})",
                _dotted,
            )
        )
    for name, where in _unread_only(model, texts, parts):
        raise OptionError(
            f"{_given(name, texts)}: parameters.{name} of {model.origin or model.name} is "
            f"named only {_why(where)}: the log would be the same without it; "
            f"{_remedy(model, where, unreached or {}, unmade or {}, unstarted or {})}"
        )


def _ends(raw: str) -> tuple[str, str]:
    """A jump map's key ``"a -> b"`` → ``("a", "b")`` (``"*"`` for any source), as the loader."""
    source, _, target = (part.strip() for part in raw.partition("->"))
    return source, target


def _shown(raw: str) -> str:
    """A jump map's key as the loader's errors show it (``"0->1"``)."""
    return json.dumps(raw) if len(raw) <= 130 and raw.isprintable() else excerpt(raw, 40)


def _applied(model: HybridModel, switch: tuple[str, str]) -> tuple[str, str] | None:
    """The ends of the jump map a switch applies (``None``: none, the state is kept)."""
    jump = model.jump_between(*(model.mode_ids.index(mode) for mode in switch))
    return None if jump is None else (jump.source or "*", jump.target)


def _remedy(
    model: HybridModel,
    where: list[tuple[_Unread, list[Path]]],
    unreached: Mapping[str, Mapping[str, int]],
    unmade: Mapping[tuple[str, str], int],
    unstarted: Mapping[int, int],
) -> str:
    """How to make the run read the tables of ``where``: ``--steps`` when it ended before them."""
    starts: list[tuple[int, str]] = []
    verbs: list[str] = []
    for part, tables in where:
        if part is _NO_EXPRESSION:
            continue
        for path in tables:
            if path[0] == "simulation":  # an unmodelled behaviour: only --steps cut it off
                start = unstarted[int(path[2][1:-1])]
                starts.append((start, f"{part.show(path)} starts"))
            elif path[0] == "jumps":
                verbs.append("make those switches")
                ends = _ends(path[1])
                starts += [
                    (step, f"its schedule switches from {a} to {b} ({part.show(path)})")
                    for (a, b), step in unmade.items()
                    if _applied(model, (a, b)) == ends
                ]
            else:
                verbs.append("play them")
                component, mode = (path[1], path[3]) if len(path) == 4 else ("", path[1])
                if mode in unreached.get(component, {}):
                    starts.append(
                        (unreached[component][mode], f"its schedule plays {part.show(path)}")
                    )
    if starts:
        step, what = min(starts)
        return (
            f"the run ends before {what} at step {step}: give --steps "
            f"{step} or more, or drop the --set"
        )
    if not verbs:
        return "drop the --set"
    how = "simulation.modes of the model file" if model.has_components else "--schedule"
    return f"{' or '.join(dict.fromkeys(verbs))} ({how}) or drop the --set"
