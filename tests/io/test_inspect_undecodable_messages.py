"""``inspect`` of a topic with a message that cannot be decoded describes the others.

A JSON-encoded MCAP topic with one message cut short listed no field at all (its fields come
from its messages, and the count stopped at the first it could not decode), nor any value.
It now lists the fields and counts the values of the messages it decodes, and says how many
it could not and the earliest one's log time: in ``problems`` and in the topic's
``undecodable`` (``count``, ``first``).  A topic none of whose messages decode (a wrong
definition) is described as before: no values, and why.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hybridlog.io import format_inspection, inspect_log
from tests.support.logfiles import Channel, float64_cdr, write_mcap

JSON = Channel("/s", encoding="json", schema_name="S", schema_encoding="jsonschema")
CUT = b'{"a": 1,'
WHY = "Expecting property name enclosed in double quotes: line 1 column 9 (char 8)"


def _json_log(path: Path, bad: set[int], n: int = 5) -> Path:
    messages = [
        (0, k * 10**8, CUT if k in bad else b'{"a": %d, "b": {"c": 2.5}}' % k) for k in range(n)
    ]
    return write_mcap(path, [JSON], messages, profile="")


def test_the_fields_of_the_messages_decoded_are_listed_and_the_others_counted(
    tmp_path: Path,
) -> None:
    info = inspect_log(_json_log(tmp_path / "one.mcap", {2}))
    (topic,) = info["topics"]
    assert topic["fields"] == ["/s.a", "/s.b.c"]
    assert topic["values"] == [
        {"name": "/s.a", "count": 4, "nonfinite": 0},
        {"name": "/s.b.c", "count": 4, "nonfinite": 0},
    ]
    assert topic["undecodable"] == {"count": 1, "first": 0.2}
    said = (
        f"topic '/s' (S): 1 of its 5 messages cannot be decoded, logged at t=0.2 s ({WHY}): "
        "analyze refuses the topic where a field of it is mapped; the fields and values here "
        "are the other 4's"
    )
    assert info["problems"] == [said]
    text = format_inspection(info)
    assert "  /s.a\n  /s.b.c\n" in text and f"problems:\n  {said}" in text
    # a field every decoded message holds is not one "in only some JSON messages"
    assert "only some JSON messages" not in text


def test_several_are_counted_and_the_earliest_named(tmp_path: Path) -> None:
    info = inspect_log(_json_log(tmp_path / "two.mcap", {1, 3}))
    (topic,) = info["topics"]
    assert topic["undecodable"] == {"count": 2, "first": 0.1}
    assert topic["fields"] == ["/s.a", "/s.b.c"] and topic["values"][0]["count"] == 3
    assert (
        "2 of its 5 messages cannot be decoded, the first logged at t=0.1 s"
        in (info["problems"][0])
    )


def test_a_topic_none_of_whose_messages_decode_is_described_as_before(tmp_path: Path) -> None:
    info = inspect_log(_json_log(tmp_path / "none.mcap", set(range(5))))
    (topic,) = info["topics"]
    assert topic["values"] is None and topic["undecodable"] is None and topic["fields"] == []
    assert info["problems"] == [
        f"topic '/s' (S): the message logged at t=0 s cannot be decoded ({WHY}); its values "
        "are not counted"
    ]


def test_a_first_part_none_of_whose_messages_decode_is_not_taken_for_the_topic(
    tmp_path: Path,
) -> None:
    """The first DECODED_AT_ONCE messages cut short (a logger's start), the rest whole: the
    topic was described as one none of whose messages decode, no field listed."""
    from hybridlog.io.topic_reader import DECODED_AT_ONCE

    n = DECODED_AT_ONCE + 3
    info = inspect_log(_json_log(tmp_path / "start.mcap", set(range(DECODED_AT_ONCE)), n))
    (topic,) = info["topics"]
    assert topic["fields"] == ["/s.a", "/s.b.c"] and topic["values"][0]["count"] == 3
    assert topic["undecodable"] == {"count": DECODED_AT_ONCE, "first": 0.0}
    assert info["problems"][0].startswith(
        f"topic '/s' (S): {DECODED_AT_ONCE} of its {n} messages cannot be decoded, the first "
        "logged at t=0 s"
    )


@pytest.mark.parametrize("bad", [0, 3])
def test_a_cdr_message_cut_short_is_left_out_too(tmp_path: Path, bad: int) -> None:
    """The same for ROS 2 messages: a truncated one no longer hides the others' values."""
    data = [float64_cdr(float(k)) for k in range(6)]
    data[bad] = data[bad][:6]
    messages = [(0, k * 10**8, d) for k, d in enumerate(data)]
    log = write_mcap(tmp_path / "cdr.mcap", [Channel("/y")], messages)
    (topic,) = inspect_log(log)["topics"]
    assert topic["values"] == [{"name": "/y.data", "count": 5, "nonfinite": 0}]
    assert topic["undecodable"] == {"count": 1, "first": bad / 10}
