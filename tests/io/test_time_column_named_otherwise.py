"""A table whose time column has another name says how to use it.

A CSV with a ``timestamp`` (or ``Time``) column was refused with "no time column (expected
't' or 'time' in seconds); closest: 'timestamp'" and nothing on what to do: ``--map`` takes
model symbols only and ``--time`` chooses log or header times.  The refusal now says to
rename the column.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import LogError
from hybridlog.io import SignalSpec, load_signals

SPEC = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("1",), dt=0.1)


@pytest.mark.parametrize("name", ["timestamp", "Time"])
def test_another_time_column_name_is_refused_with_the_remedy(tmp_path: Path, name: str) -> None:
    log = tmp_path / "log.csv"
    log.write_text(f"{name},u,y\n0,1,2\n0.1,2,3\n0.2,3,4\n")
    with pytest.raises(LogError) as info:
        load_signals(log, SPEC)
    case = " (names are case-sensitive: 'Time' is not 'time')" if name == "Time" else ""
    assert str(info.value) == (
        f"{log}: no time column (expected 't' or 'time' in seconds); closest: {name!r}{case}; "
        "rename the time column to 't' (no option names another)"
    )
