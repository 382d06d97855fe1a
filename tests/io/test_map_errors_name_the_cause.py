"""A field the log has but that cannot be used is refused naming why, not as a missing one.

The message of a symbol whose field was unusable was built as "no field 'P' for output 'y1'
(from --map y1=P); <reason>" whatever the reason: ``--map y1=/a.b.v`` on topics ``/a``
(field ``b.v``) and ``/a.b`` (field ``v``) read "no field '/a.b.v' ...; '/a.b.v' names 2
fields"; ``--time header`` on topics without ``header.stamp`` read "no field for input 'u'
(looked for '/u.data' ...); topic '/u' has no header.stamp"; a Parquet text column mapped
to an input did not name the input at all.  Now the symbol and field come first, as a
place, then the cause: "output 'y1' (field '/a.b.v', from --map y1=/a.b.v): '/a.b.v' names
2 fields ..."; "no field" is said only of a field the log lacks.
"""

from __future__ import annotations

import re
from pathlib import Path

import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.io.mapping import resolve_signal_map
from tests.io.test_logs_nested_topics import dotted_mcap

SAMPLE_MCAP = Path(__file__).parents[2] / "sample_logs" / "three_tank_hstf.mcap"
SPEC = SignalSpec(inputs=("u",), outputs=("y1",), mode_ids=("1", "2"), dt=0.1)


def refusal(log: Path, spec: SignalSpec = SPEC, **options: object) -> str:
    with pytest.raises(LogError) as info:
        load_signals(log, spec, ReadOptions(**options))  # type: ignore[arg-type]
    return str(info.value)


def test_a_path_naming_two_fields_is_not_called_missing(tmp_path: Path) -> None:
    log = dotted_mcap(tmp_path / "dotted.mcap")
    message = refusal(log, maps=('u="/a".b.v', "y1=/a.b.v"))
    assert message.startswith(
        f"{log}: output 'y1' (field '/a.b.v', from --map y1=/a.b.v): '/a.b.v' names 2 fields: "
    )
    assert "no field" not in message


def test_time_header_without_a_stamp_names_the_missing_header_first(tmp_path: Path) -> None:
    log = dotted_mcap(tmp_path / "dotted.mcap")
    message = refusal(log, maps=('u="/a".b.v', 'y1="/a.b".v'), time="header")
    # its JSON schema leaves the object open (no additionalProperties: false), so the
    # messages, not the schema, say that the header is missing
    assert message.startswith(
        f"{log}: input 'u' (field '\"/a\".b.v', from --map u=\"/a\".b.v): topic '/a' (Outer): "
        "header.stamp: the message has no field 'header'"
    )
    # by default: the topic /u is there, only its messages lack the header
    spec = SignalSpec(inputs=("u",), outputs=("y1", "y2", "y3"), mode_ids=("1",), dt=1.0)
    message = refusal(SAMPLE_MCAP, spec, time="header")
    assert message.startswith(
        f"{SAMPLE_MCAP}: input 'u' (field '/u.data', the default; use --map u=... for "
        "another): topic '/u' (std_msgs/msg/Float64) has no header.stamp"
    )
    assert "no field" not in message


def test_a_parquet_text_column_mapped_to_an_input_names_the_input(tmp_path: Path) -> None:
    log = tmp_path / "log.parquet"
    frame = {"t": [0.0, 0.1, 0.2], "u": [1.0, 2.0, 3.0], "y1": [1.0, 2.0, 3.0], "s": "abc"}
    pl.DataFrame(frame).write_parquet(log)
    message = refusal(log, maps=("u=s",))
    assert message == (
        f"{log}: input 'u' (column 's', from --map u=s): column 's' has type String, "
        "expected a number"
    )


@pytest.mark.parametrize("suffix", ["csv", "parquet"])
def test_a_missing_mapped_column_is_still_called_missing(tmp_path: Path, suffix: str) -> None:
    log = tmp_path / f"log.{suffix}"
    frame = pl.DataFrame({"t": [0.0, 0.1], "u": [1.0, 2.0], "y1": [1.0, 2.0], "level": 3.0})
    frame.write_csv(log) if suffix == "csv" else frame.write_parquet(log)
    message = refusal(log, maps=("y1=levle",))
    assert message == (
        f"{log}: output 'y1' (column 'levle', from --map y1=levle): no column 'levle'; "
        "closest: 'level'"
    )


def test_without_a_log_source_a_missing_mapped_name_is_called_missing() -> None:
    with pytest.raises(
        LogError,
        match=re.escape("log.csv: input 'u' (column 'v', from --map u=v): no column 'v'; "),
    ):
        resolve_signal_map(
            ("u", "y"), source="log.csv", inputs=("u",), outputs=("y",), states=(), maps={"u": "v"}
        )


@pytest.mark.parametrize("suffix", ["csv", "parquet"])
def test_a_missing_default_column_is_still_called_missing(tmp_path: Path, suffix: str) -> None:
    log = tmp_path / f"log.{suffix}"
    frame = pl.DataFrame({"t": [0.0, 0.1], "u": [1.0, 2.0], "y2": [1.0, 2.0]})
    frame.write_csv(log) if suffix == "csv" else frame.write_parquet(log)
    assert refusal(log) == (
        f"{log}: no column for output 'y1' (looked for 'y1'; use --map y1=...); closest: 'y2'"
    )


def test_a_signals_path_missing_from_its_topic_is_named_as_the_model_s(tmp_path: Path) -> None:
    log = dotted_mcap(tmp_path / "dotted.mcap")
    spec = SignalSpec(
        inputs=("u",),
        outputs=("y1",),
        mode_ids=("1",),
        dt=0.1,
        signals={"u": '"/a.b".w', "y1": '"/a.b".v'},
    )
    message = refusal(log, spec)
    assert message.startswith(
        f"{log}: input 'u' (field '\"/a.b\".w', from the model's [signals]; use --map u=... "
        "for another): "
    )
    # the schema leaves its object open: the messages say that none has the field
    assert message.endswith(
        "none of the 20 messages of topic '/a.b' (Inner) has field 'w'; fields found: 'v'"
    )
