"""Which ``[parameters]`` a command reads: a ``--set`` of one it never reads changes nothing.

The loader refuses ``--set`` of a parameter no string of the model names
(``_refuse_unused_overrides``).  A parameter can be named and still be read by nothing a
command runs: ``analyze`` reads no ``[simulation]`` table (``q0`` of the valve three-tank sets
the inflow ``simulate`` plays only), and ``simulate`` reads no equation of a mode its scenario
never plays (``c_out`` of the BIO-Plex chamber enters only its ``leak`` mode; a schedule
decides which modes are played, the same for every ``--seed``, where guards would not: a model
switched by guards reads every mode).  Both ran with
the ``--set`` value recorded and the output the same as without it.  Like an estimator option
the others make inert (``beam`` without ``kbest``), such a ``--set`` is refused in one line.

Names are read from the model file's text as the loader reads them: the identifiers (NFKC) of
every string outside the prose keys, here outside the tables the command does not read too.
"""

from __future__ import annotations

import re
import unicodedata
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from hybridlog.errors import OptionError, excerpt
from hybridlog.model.toml_text import read_toml

if TYPE_CHECKING:
    from hybridlog.model.hybrid_model import HybridModel

__all__ = ["refuse_unread_by_analysis", "refuse_unread_by_simulation"]

_PROSE_KEYS = frozenset({"name", "description", "reference"})
"""Top-level keys whose strings are prose, not expressions (as the loader's)."""

_IDENTIFIER = re.compile(r"[^\W\d]\w*")

Path = tuple[str, ...]


def _strings(value: Any, path: Path, skip: Callable[[Path], bool]) -> Iterator[str]:
    """Every string in a parsed TOML value, outside the tables ``skip`` names."""
    if skip(path):
        return
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for key, item in value.items():
            if not (path == () and key in _PROSE_KEYS):
                yield from _strings(item, (*path, str(key)), skip)
    elif isinstance(value, list):
        for item in value:
            yield from _strings(item, path, skip)


def _named(model: HybridModel, skip: Callable[[Path], bool]) -> set[str]:
    """The identifiers named by the model file's strings outside the tables ``skip`` names."""
    data = read_toml(model.source)
    named: set[str] = set()
    for text in _strings(data, (), skip):
        named.update(_IDENTIFIER.findall(unicodedata.normalize("NFKC", text)))
    return named


def _given(name: str, texts: Mapping[str, str]) -> str:
    return f"--set {excerpt(name)[1:-1]}={excerpt(texts[name])[1:-1]}"


def refuse_unread_by_analysis(model: HybridModel, texts: Mapping[str, str]) -> None:
    """Refuse ``--set`` of a parameter only ``[simulation]`` names (analyze, compare, batch).

    ``texts``: the ``--set`` values of model parameters, as typed.

    Raises
    ------
    OptionError
        ``--set q0=5: parameters.q0 of <model> is named only under [simulation] ...``.
    """
    if not texts:
        return
    named = _named(model, lambda path: path[:1] == ("simulation",))
    for name in texts:
        if name not in named:
            raise OptionError(
                f"{_given(name, texts)}: parameters.{name} of {model.origin or model.name} is "
                "named only under [simulation], the scenario `hybridlog simulate` plays, "
                "which no estimator reads: it would change nothing here"
            )


def refuse_unread_by_simulation(
    model: HybridModel,
    texts: Mapping[str, str],
    played: Mapping[str, Collection[str]],
    unreached: Mapping[str, Mapping[str, int]] | None = None,
) -> None:
    """Refuse ``--set`` of a parameter named only by modes the simulated run never played.

    ``played``: component name → the ids of its modes the run played (``""`` for the modes
    of a model without components, ``modes.<id>``); a mode's table is left out of the names
    when it was not played.
    ``unreached``: as ``played``, the modes of the schedule (``--schedule``, ``[simulation]
    schedule`` or ``simulation.modes``) the run ended before → the step the schedule starts
    each, which the error then asks ``--steps`` to reach.  Checked after the run, before
    anything is written.

    A model whose guards switch its modes reads every mode, guards and all: which modes a
    run enters depends on the states its noise draws, so the same command was refused with
    one ``--seed`` and ran with another (and the error asked for a ``--schedule``, which such
    a model refuses).  Only a schedule decides, whatever the seed, which modes a run plays.

    Raises
    ------
    OptionError
        ``--set c_out=1e300: parameters.c_out of <model> is named only by modes this run
        never plays (components.pgc.modes.leak) ...``.
    """
    if not texts or model.state_driven:
        return

    def table_unplayed(path: Path) -> bool:
        if path[:1] == ("components",) and len(path) == 4 and path[2] == "modes":
            return path[3] not in played.get(path[1], ())
        if path[:1] == ("modes",) and len(path) == 2 and "" in played:
            return path[1] not in played[""]
        return False

    named = _named(model, table_unplayed)
    for name in texts:
        if name in named:
            continue
        tables = [
            path
            for path in _mode_tables(model)
            if table_unplayed(path) and _names(model, path, name)
        ]
        raise OptionError(
            f"{_given(name, texts)}: parameters.{name} of {model.origin or model.name} is "
            f"named only by modes this run never plays ({', '.join(map('.'.join, tables))}): "
            f"the log would be the same without it; {_remedy(model, tables, unreached or {})}"
        )


def _remedy(
    model: HybridModel, tables: Sequence[Path], unreached: Mapping[str, Mapping[str, int]]
) -> str:
    """How to play the modes of ``tables``: ``--steps`` when the run ended before them."""
    starts = [
        (unreached[component][mode], ".".join(path))
        for path in tables
        for component, mode in [(path[1], path[3]) if len(path) == 4 else ("", path[1])]
        if mode in unreached.get(component, {})
    ]
    if starts:
        step, table = min(starts)
        return (
            f"the run ends before its schedule plays {table} at step {step}: give --steps "
            f"{step} or more, or drop the --set"
        )
    how = "simulation.modes of the model file" if model.has_components else "--schedule"
    return f"play them ({how}) or drop the --set"


def _mode_tables(model: HybridModel) -> Iterator[Path]:
    """The key paths of every mode's table: ``components.<c>.modes.<m>``, ``modes.<id>``."""
    data = read_toml(model.source)
    for component, table in (data.get("components") or {}).items():
        for mode in (table.get("modes") or {}) if isinstance(table, dict) else {}:
            yield ("components", str(component), "modes", str(mode))
    for mode in data.get("modes") or {}:
        yield ("modes", str(mode))


def _names(model: HybridModel, table: Path, name: str) -> bool:
    """Whether the table at ``table`` names ``name``."""
    return name in _named(model, lambda path: path[: len(table)] != table[: len(path)])
