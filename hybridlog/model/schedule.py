"""A mode schedule as written, ``"1:100,2:50"``: ``simulate --schedule``, ``[simulation] schedule``.

In the model layer, so the loader checks a model file's schedule against its modes when the
file is read, as :mod:`hybridlog.simulate` parses it when it runs.
"""

from __future__ import annotations

from hybridlog.errors import HybridlogError, ModelError, OptionError
from hybridlog.numbers import parse_int

__all__ = ["parse_schedule"]


def parse_schedule(
    text: str, mode_ids: tuple[str, ...], *, where: str = "--schedule"
) -> list[tuple[int, int]]:
    """``"1:100,2:50"`` → ``[(index of mode '1', 100), (index of mode '2', 50)]``.

    ``where`` names the schedule's origin in errors: ``--schedule`` (an
    :class:`OptionError`) or ``<model file>: simulation.schedule`` (a :class:`ModelError`).
    """
    error: type[HybridlogError] = OptionError if where.startswith("--") else ModelError
    schedule: list[tuple[int, int]] = []
    for part in text.split(","):
        part = part.strip()
        mode, sep, count = part.rpartition(":")
        mode = mode.strip()  # "1 : 100, 2 : 50" as written in a model file
        if not sep or not mode:
            raise error(f"{where}: '{part}' is not MODE:STEPS")
        if ":" in mode:  # '1:10:2' read as mode '1:10' (a mode id never holds ':')
            raise error(f"{where}: '{part}' is not MODE:STEPS (one ':' per item)")
        if mode not in mode_ids:
            raise error(f"{where}: unknown mode '{mode}' (modes: {', '.join(mode_ids)})")
        try:
            steps = parse_int(count)
        except ValueError:
            raise error(f"{where}: '{count}' in '{part}' is not a whole number") from None
        if steps <= 0:
            raise error(f"{where}: the step count in '{part}' must be positive")
        schedule.append((mode_ids.index(mode), steps))
    return schedule
