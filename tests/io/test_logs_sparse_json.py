"""JSON topics whose messages carry only the fields their logger had at that moment.

A logger of sparse signals writes ``{"u": 1}`` then ``{"y": 10}`` on one topic: each field is
a signal with its own times, read from the messages that carry it (SPEC §5 aligns signals
of any rates).  Logs written with mcap's own ``Writer``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, format_inspection, inspect_log, load_signals

S = 10**9
N = 20
DT = 0.1


def write(
    path: Path,
    messages: list[tuple[int, dict[str, Any]]],
    schema: dict[str, Any] | None = None,
) -> Path:
    """``(log time ns, document)`` on topic ``/io`` (JSON, with ``schema`` if given)."""
    from mcap.writer import Writer

    with path.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile="", library="tests")
        sid = 0
        if schema is not None:
            sid = writer.register_schema("io", "jsonschema", json.dumps(schema).encode())
        channel = writer.register_channel("/io", "json", sid)
        for t, document in messages:
            writer.add_message(channel, t, json.dumps(document).encode(), t)
        writer.finish()
    return path


def interleaved(offset_ns: int = S // 20) -> list[tuple[int, dict[str, Any]]]:
    """``{"u": k}`` at k*dt and ``{"y": 10 k}`` ``offset_ns`` later."""
    out: list[tuple[int, dict[str, Any]]] = []
    for k in range(N):
        t = k * S // 10
        out.append((t, {"u": float(k)}))
        out.append((t + offset_ns, {"y": 10.0 * k}))
    return out


def load(log: Path, *maps: str, **options: Any) -> Any:
    spec = SignalSpec(inputs=("u",), outputs=("y",), states=("x",), mode_ids=("a", "b"), dt=DT)
    return load_signals(log, spec, ReadOptions(maps=maps, **options))


def test_fields_of_a_sparse_topic_are_read_from_the_messages_carrying_them(
    tmp_path: Path,
) -> None:
    log = write(tmp_path / "sparse.mcap", interleaved())
    signals = load(log, "u=/io.u", "y=/io.y")
    # the grid starts at the first output (0.05 s); u(k) is held from 0.0 + k*dt
    np.testing.assert_allclose(signals.time, 0.05 + DT * np.arange(N))
    np.testing.assert_array_equal(signals.outputs[:, 0], 10.0 * np.arange(N))
    np.testing.assert_array_equal(signals.inputs[:, 0], np.arange(N, dtype=float))


def test_fields_logged_at_one_time_in_separate_messages_are_not_repeats(
    tmp_path: Path,
) -> None:
    log = write(tmp_path / "same_time.mcap", interleaved(offset_ns=0))
    signals = load(log, "u=/io.u", "y=/io.y")
    np.testing.assert_array_equal(signals.outputs[:, 0], 10.0 * np.arange(N))
    np.testing.assert_array_equal(signals.inputs[:, 0], np.arange(N, dtype=float))


def test_nested_and_label_fields_may_be_sparse(tmp_path: Path) -> None:
    messages: list[tuple[int, dict[str, Any]]] = []
    for k in range(N):
        t = k * S // 10
        messages.append((t, {"cmd": {"u": float(k)}, "mode": "a" if k < N // 2 else "b"}))
        messages.append((t + S // 20, {"meas": {"y": 10.0 * k}}))
    log = write(tmp_path / "nested.mcap", messages)
    signals = load(log, "u=/io.cmd.u", "y=/io.meas.y", "truth.mode=/io.mode")
    np.testing.assert_array_equal(signals.outputs[:, 0], 10.0 * np.arange(N))
    assert signals.truth_modes is not None
    np.testing.assert_array_equal(signals.truth_modes, [0] * (N // 2) + [1] * (N // 2))


def test_a_field_no_message_carries_is_refused_listing_those_found(tmp_path: Path) -> None:
    log = write(tmp_path / "sparse.mcap", interleaved())
    with pytest.raises(
        LogError,
        match=r"output 'y' \(field '/io\.yy', from --map y=/io\.yy\): none of the 40 messages "
        r"of topic '/io' .*has field 'yy'; closest: 'y'",
    ):
        load(log, "u=/io.u", "y=/io.yy")


def test_a_key_the_schema_requires_is_refused_where_a_message_lacks_it(
    tmp_path: Path,
) -> None:
    schema = {
        "type": "object",
        "properties": {"u": {"type": "number"}, "y": {"type": "number"}},
        "required": ["u", "y"],
    }
    messages = [(k * S // 10, {"u": float(k), "y": 10.0 * k}) for k in range(N)]
    messages[7] = (messages[7][0], {"u": 7.0})
    log = write(tmp_path / "required.mcap", messages, schema)
    with pytest.raises(
        LogError,
        match=r"\(field '/io\.y', from --map y=/io\.y\): the message has no field 'y', which "
        r"the topic's JSON schema lists as "
        r"required in the message logged at t=0\.7 s",
    ):
        load(log, "u=/io.u", "y=/io.y")
    schema["required"] = ["u"]
    log = write(tmp_path / "optional.mcap", messages, schema)
    signals = load(log, "u=/io.u", "y=/io.y", max_gap=0.25)
    assert 10.0 * 7 not in signals.outputs[:, 0]


def test_repeated_times_among_a_sparse_field_s_messages_are_its_own(tmp_path: Path) -> None:
    messages = interleaved()
    messages.insert(5, (messages[4][0], {"u": 99.0}))  # u twice at t = 0.2 s
    log = write(tmp_path / "twice.mcap", messages)
    with pytest.raises(
        LogError,
        match=r"'/io\.u': 1 message\(s\) \(among the messages that carry it\) have the same "
        r"log time as the one before \(first at t=0\.2 s\); --sort",
    ):
        load(log, "u=/io.u", "y=/io.y")
    notes: dict[str, Any] = {}
    signals = load_signals(
        log,
        SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=DT),
        ReadOptions(maps=("u=/io.u", "y=/io.y"), sort=True),
        notes=notes,
    )
    assert signals.inputs[2, 0] == 99.0
    assert notes["duplicates_dropped"] == {"/io.u": 1}


def test_a_null_value_is_still_refused(tmp_path: Path) -> None:
    messages = interleaved()
    messages[6] = (messages[6][0], {"u": None})
    log = write(tmp_path / "null.mcap", messages)
    with pytest.raises(
        LogError, match=r"\(field '/io\.u', from --map u=/io\.u\): the value is null, not"
    ):
        load(log, "u=/io.u", "y=/io.y")


def test_a_null_is_a_non_finite_sample_that_drop_nonfinite_drops(tmp_path: Path) -> None:
    """JSON has no NaN or inf: JavaScript's ``JSON.stringify`` writes them as ``null``.  A null
    among numbers was refused even with --drop-nonfinite (which drops a NaN there), and
    inspect counted it neither as a value nor as non-finite (no problem at all); it is now a
    non-finite sample: refused naming the remedy, dropped and counted with the NaNs."""
    messages = interleaved()
    messages[6] = (messages[6][0], {"u": None})  # u at t = 0.3 s
    messages[8] = (messages[8][0], {"u": float("nan")})  # u at t = 0.4 s, written NaN
    messages[7] = (messages[7][0], {"y": 30.0, "v": [None, 1.0]})  # an element of an array
    log = write(tmp_path / "null.mcap", messages)
    with pytest.raises(LogError, match=r"null, not a number \(.*--drop-nonfinite drops it"):
        load(log, "u=/io.u", "y=/io.y")
    notes: dict[str, Any] = {}
    signals = load_signals(
        log,
        SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=DT),
        ReadOptions(maps=("u=/io.u", "y=/io.y"), drop_nonfinite=True, max_gap=0.5),
        notes=notes,
    )
    assert notes["nonfinite_dropped"]["/io.u"] == 2
    assert 3.0 not in signals.inputs[:, 0] and 4.0 not in signals.inputs[:, 0]
    values = {v["name"]: v for v in inspect_log(log)["topics"][0]["values"]}
    assert values["/io.u"] == {"name": "/io.u", "count": 20, "nonfinite": 2}
    assert values["/io.v[]"] == {"name": "/io.v[]", "count": 2, "nonfinite": 1}


def test_a_field_of_text_and_nulls_is_a_label_not_a_field_of_numbers(tmp_path: Path) -> None:
    messages = interleaved()
    messages[0] = (messages[0][0], {"u": 0.0, "mode": "a"})
    messages[2] = (messages[2][0], {"u": 1.0, "mode": None})
    log = write(tmp_path / "labels.mcap", messages)
    report = inspect_log(log)
    assert "/io.mode" not in {v["name"] for v in report["topics"][0]["values"]}
    assert not report["problems"]


def test_inspect_names_the_fields_only_some_messages_carry(tmp_path: Path) -> None:
    log = write(tmp_path / "sparse.mcap", interleaved())
    text = format_inspection(inspect_log(log))
    assert "fields with a number in only some JSON messages" in text
    assert "/io.u: 20 of 40 messages" in text and "/io.y: 20 of 40 messages" in text


def test_inspect_names_a_field_of_numbers_and_text_as_analyze_refuses_it(tmp_path: Path) -> None:
    """``{"u": "s"}`` in one message of a field of numbers: inspect listed the field as one a
    message leaves out ('20 of 21 messages', read from those that carry it) and had no problem,
    while analyze refused it at that message; a field of text alone (a label) is none."""
    messages = interleaved()
    messages[6] = (messages[6][0], {"u": "s", "mode": "a"})
    messages[8] = (messages[8][0], {"u": [1.0, "x"], "mode": "b"})
    log = write(tmp_path / "mixed.mcap", messages)
    with pytest.raises(LogError) as refused:
        load(log, "u=/io.u", "y=/io.y")
    words = "'/io.u': the value is a string, not a number in the message logged at t=0.3 s"
    assert words.replace("'/io.u'", "input 'u' (field '/io.u', from --map u=/io.u)") in str(
        refused.value
    )
    refuses = "analyze refuses it as an input, output or true state"
    assert inspect_log(log)["problems"] == [
        f"{words} (18 of its values are numbers: {refuses})",
        "'/io.u[]': the value is a string, not a number in the message logged at t=0.4 s "
        f"(1 of its values is a number: {refuses})",
    ]


def test_inspect_names_a_field_of_numbers_and_booleans_as_analyze_refuses_it(
    tmp_path: Path,
) -> None:
    """``{"u": true}`` in one message of a field of numbers: inspect said the field was one
    some messages leave out (19 of 20) and had no problem, while analyze refused it there; a
    field of booleans alone (read as 0 and 1) and an array's booleans are no problem."""
    messages = interleaved()
    messages[6] = (messages[6][0], {"u": True, "on": False, "bits": [1, True]})
    messages[8] = (messages[8][0], {"u": 4.0, "on": True, "bits": [0, False]})
    log = write(tmp_path / "booleans.mcap", messages)
    with pytest.raises(LogError, match=r"/io\.u\): the value is a boolean where the messages"):
        load(log, "u=/io.u", "y=/io.y")
    assert inspect_log(log)["problems"] == [
        "'/io.u': the value is a boolean among numbers in the message logged at t=0.3 s "
        "(19 of its values are numbers: analyze refuses it as an input, output or true state)"
    ]


def test_a_sparse_label_field_lists_only_the_labels_its_messages_hold(tmp_path: Path) -> None:
    from hybridlog.io.formats import open_log

    messages: list[tuple[int, dict[str, Any]]] = []
    for k in range(N):
        t = k * S // 10
        messages += [(t, {"mode": "b" if k % 3 else "a"}), (t + S // 20, {"y": 1.0})]
    with open_log(write(tmp_path / "labels.mcap", messages)) as source:
        series = source.read([], ["/io.mode"]).labels["/io.mode"]
    assert series.categories == ("a", "b")
    np.testing.assert_array_equal(series.codes, [0 if k % 3 == 0 else 1 for k in range(N)])
    np.testing.assert_array_equal(series.time_ns, np.arange(N) * S // 10)


def write_raw(path: Path, documents: list[str]) -> Path:
    """Messages as written text (``1e400`` is no Python float ``json.dumps`` could write)."""
    from mcap.writer import Writer

    with path.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile="", library="tests")
        channel = writer.register_channel("/io", "json", 0)
        for k, text in enumerate(documents):
            writer.add_message(channel, k * S // 10, text.encode(), k * S // 10)
        writer.finish()
    return path


@pytest.mark.parametrize(
    ("written", "field", "number"),
    [
        ('{"u": 1, "y": 1e400}', "y", "1e400"),
        ('{"u": 1, "y": -2.5E+309}', "y", "-2.5E+309"),
        ('{"u": 1e999, "y": 1}', "u", "1e999"),
        ('{"u": 1, "y": 1, "v": [1, 1e400]}', "y", None),  # not mapped: read as usual
        ('{"u": 1, "y": 1, "p": {"q": [0, 1e400]}}', "p.q[1]", "1e400"),
    ],
)
def test_a_json_number_beyond_float_range_is_named_as_written(
    tmp_path: Path, written: str, field: str, number: str | None
) -> None:
    # 1e400 decodes to inf and was reported as "inf", which the message does not say.
    documents = ['{"u": 1, "y": 1, "p": {"q": [0, 1]}}'] * N
    documents[7] = written
    log = write_raw(tmp_path / "log.mcap", documents)
    maps = ("u=/io/u", "y=/io/y") if field in "uy" else ("u=/io/u", f"y=/io/{field}")
    if number is None:
        assert load(log, *maps).n_samples == N
        return
    with pytest.raises(LogError) as info:
        load(log, *maps)
    message = str(info.value)
    assert message.startswith(f"{log}: topic '/io'")
    assert f"field '/io/{field}'" in message
    assert f"{number} in the message logged at t=0.7 s (message 8 of the topic)" in message
    assert message.endswith("is beyond the range of a float64 (about 1.8e308)")
    # --drop-nonfinite drops it, as it does an infinite number
    notes: dict[str, Any] = {}
    signals = load_signals(
        log,
        SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=DT),
        ReadOptions(maps=maps, drop_nonfinite=True),
        notes=notes,
    )
    assert signals.n_samples == N
    assert notes["nonfinite_dropped"] == {f"/io/{field}": 1}


def test_a_json_infinity_token_is_still_reported_as_infinite(tmp_path: Path) -> None:
    documents = ['{"u": 1, "y": 1}'] * N
    documents[3] = '{"u": 1, "y": Infinity}'
    log = write_raw(tmp_path / "log.mcap", documents)
    with pytest.raises(LogError, match=r"inf for output 'y' at t=0\.3 s"):
        load(log, "u=/io/u", "y=/io/y")


@pytest.mark.parametrize("written", ['{"u": 1, "y": -1%s}', '{"u": 1, "y": [1%s]}'])
def test_a_json_integer_beyond_float_range_is_one_with_1e400(tmp_path: Path, written: str) -> None:
    # JSON integers have no bound. One of 401 digits was refused as 'an integer beyond the
    # range of a float64' even with --drop-nonfinite (which drops 1e400), and inspect
    # counted it as finite (it counted 1e400, and a CSV cell of those digits, as not).
    documents = ['{"u": 1, "y": %s}' % ("[1]" if "[" in written else "1")] * N
    documents[7] = written % ("0" * 400)
    log = write_raw(tmp_path / "log.mcap", documents)
    field = "/io/y[0]" if "[" in written else "/io/y"
    with pytest.raises(LogError) as info:
        load(log, "u=/io/u", f"y={field}")
    message = str(info.value)
    assert f"field {field!r}: " in message and "\n" not in message
    assert "in the message logged at t=0.7 s (message 8 of the topic)" in message
    assert message.endswith("is beyond the range of a float64 (about 1.8e308)")
    notes: dict[str, Any] = {}
    signals = load_signals(
        log,
        SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=DT),
        ReadOptions(maps=("u=/io/u", f"y={field}"), drop_nonfinite=True),
        notes=notes,
    )
    assert signals.n_samples == N and np.isfinite(signals.outputs).all()
    assert notes["nonfinite_dropped"] == {field: 1}
    (topic,) = inspect_log(log)["topics"]
    counted = {v["name"]: v["nonfinite"] for v in topic["values"]}
    assert counted[field.replace("[0]", "[]").replace("/io/", "/io.")] == 1
