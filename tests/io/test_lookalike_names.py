"""A name that differs from the closest one only in characters that print alike says so.

``--map u=/u.dаta`` (a Cyrillic ``а``) was refused with "the message has no field 'dаta';
closest: 'data'", and a CSV header ``t,u,у1`` (a Cyrillic ``у``) with "no column for output
'y1' ...; closest: 'у1'": two names that print the same, one said to be missing.  The
non-ASCII characters that tell the two apart are now named with their code points.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.errors import LogError, OptionError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.io.mapping import parse_maps
from hybridlog.io.source import closest_names

SPEC = SignalSpec(inputs=("u",), outputs=("y1",), mode_ids=("1",), dt=0.1)
SAMPLE_MCAP = Path(__file__).parents[2] / "sample_logs" / "three_tank_hstf.mcap"


def test_a_lookalike_in_the_wanted_name_is_named() -> None:
    assert closest_names(["dаta"], ["data", "stamp"]) == (
        "closest: 'data' ('dаta' has U+0430 CYRILLIC SMALL LETTER A)"
    )


def test_a_lookalike_in_the_log_s_name_is_named(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    log.write_text("t,u,у1\n0,1,2\n0.1,2,3\n0.2,3,4\n")
    with pytest.raises(LogError) as info:
        load_signals(log, SPEC)
    assert str(info.value).endswith("closest: 'у1' ('у1' has U+0443 CYRILLIC SMALL LETTER U)")


def test_a_mapped_message_path_with_a_lookalike_names_it() -> None:
    spec = SignalSpec(inputs=("u",), outputs=("y1", "y2", "y3"), mode_ids=("1",), dt=1.0)
    with pytest.raises(LogError) as info:
        load_signals(SAMPLE_MCAP, spec, ReadOptions(maps=("u=/u.dаta",)))
    assert "no field 'dаta'; closest: 'data' ('dаta' has U+0430 CYRILLIC SMALL LETTER A)" in str(
        info.value
    )


def test_names_alike_but_in_ascii_get_no_note() -> None:
    assert closest_names(["levle"], ["level"]) == "closest: 'level'"
    # a non-ASCII character both names share tells them not apart
    assert closest_names(["θ2"], ["θ1"]) == "closest: 'θ1'"


def test_a_mapped_symbol_with_a_lookalike_names_it() -> None:
    with pytest.raises(OptionError) as info:
        parse_maps(["у1=y2"], inputs=("u",), outputs=("y1", "y2"), states=())
    assert str(info.value) == (
        "--map 'у1=y2': unknown symbol 'у1'; 'у1' has U+0443 CYRILLIC SMALL LETTER U; "
        "valid symbols: u, y1, y2, truth.mode"
    )
