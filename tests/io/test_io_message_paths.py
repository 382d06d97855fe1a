"""Message paths: parsing, the slash alias, the same path on every decoder.

Paths are read out of messages rosbags wrote and deserialised, on random messages of types
with strings, sequences, nested messages and fixed arrays, in little- and big-endian CDR and
in ROS 1 serialisation; bytes that do not fit their definition are refused.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.records import Schema
from mcap_ros1.decoder import DecoderFactory as Ros1Decoders
from mcap_ros2.decoder import DecoderFactory as Ros2Decoders
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, load_signals
from hybridlog.io.formats import open_log
from hybridlog.io.message_paths import (
    PathError,
    Target,
    UndecodableError,
    accessor,
    as_float_array,
    as_label,
    as_number,
    check_path,
    decode_each,
    evaluate,
    leaf_value,
    split_path,
    stamp_ns,
)
from tests.support.logfiles import (
    Channel,
    header_scene_records,
    msgdef,
    ros1_store,
    ros2_store,
    stamped_point,
    write_mcap,
    write_ros2_bag,
)

TOPICS = ["/truth", "/truth/x1", "/joint_states", "/a.b"]


@pytest.mark.parametrize(
    ("text", "topic", "steps"),
    [
        ("/joint_states.position[2]", "/joint_states", ("position", 2)),
        ("/joint_states/position[-1]", "/joint_states", ("position", -1)),
        ("/truth/x1.data", "/truth/x1", ("data",)),
        ("/truth/x1/data", "/truth/x1", ("data",)),  # longest topic wins over /truth
        ("/truth.mode", "/truth", ("mode",)),
        ("/truth/mode", "/truth", ("mode",)),
        ("/a.b.c", "/a.b", ("c",)),  # a topic with a dot: still the longest prefix
        ("/joint_states.header.stamp.sec", "/joint_states", ("header", "stamp", "sec")),
        ("/joint_states[0]", "/joint_states", (0,)),
    ],
)
def test_paths_split_at_the_longest_topic(text: str, topic: str, steps: tuple[Any, ...]) -> None:
    path = split_path(text, TOPICS)
    assert (path.topic, path.steps) == (topic, steps)


@pytest.mark.parametrize("index", ["[-0]", "[-00]", "[ -0 ]"])
def test_minus_zero_is_refused_as_counting_from_neither_end(index: str) -> None:
    # Python's a[-0] is a[0]: '/joint_states.position[-0]' read the first element, where one
    # counting from the end meant another
    with pytest.raises(PathError, match=r"counts from neither end; write \[0\] .* \[-1\]"):
        split_path(f"/joint_states.position{index}", TOPICS)


def test_a_path_without_a_topic_lists_close_ones() -> None:
    with pytest.raises(PathError, match=r"no topic for '/joint_state\.x'.*'/joint_states'"):
        split_path("/joint_state.x", TOPICS)
    with pytest.raises(PathError, match="cannot read"):
        split_path("/joint_states.position[x]", TOPICS)


def test_a_path_to_a_constant_says_it_is_one() -> None:
    # it read "has no field 'POWER_SUPPLY_STATUS_FULL'; closest: ..." of a name the type has
    defs = ros2_store().fielddefs
    with pytest.raises(
        PathError,
        match=r"^sensor_msgs/msg/BatteryState has no field 'POWER_SUPPLY_STATUS_FULL': it is a "
        r"constant of the type \(uint8 4\), which no message carries$",
    ):
        check_path(defs, "sensor_msgs/msg/BatteryState", ("POWER_SUPPLY_STATUS_FULL",))


def test_definitions_check_paths_and_name_the_fields() -> None:
    defs = ros2_store().fielddefs
    assert check_path(defs, "sensor_msgs/msg/JointState", ("position", -1)).kind == "number"
    assert check_path(defs, "sensor_msgs/msg/JointState", ("position",)).kind == "array"
    assert check_path(defs, "sensor_msgs/msg/JointState", ("header", "frame_id")).kind == "string"
    assert check_path(defs, "sensor_msgs/msg/JointState", ("header",)).kind == "message"
    with pytest.raises(PathError, match="has no field 'postion'; closest: 'position'"):
        check_path(defs, "sensor_msgs/msg/JointState", ("postion", 0))
    with pytest.raises(PathError, match="is an array"):
        check_path(defs, "sensor_msgs/msg/JointState", ("position", "x"))
    # /joint_states/position/1 was told 'index it before .1, e.g. [0].1'
    with pytest.raises(
        PathError, match=r"^\.position is an array; write its index in brackets: \[1\]$"
    ):
        check_path(defs, "sensor_msgs/msg/JointState", split_path("/j/position/1", ["/j"]).steps)
    # a fixed-size array said "(the array has 9)", where one a message sizes names elements
    with pytest.raises(
        PathError,
        match=r"^\.orientation_covariance\[-10\]: index out of range \(the array has 9 elements\)$",
    ):
        check_path(defs, "sensor_msgs/msg/Imu", ("orientation_covariance", -10))


def test_arrays_of_strings_and_of_messages_are_arrays_of_their_element_type(
    tmp_path: Path,
) -> None:
    """``/tf.transforms`` was 'a message (array), not a number; name a field in it', and
    naming a field in it was then refused for want of an index."""
    defs = ros2_store().fielddefs
    assert check_path(defs, "tf2_msgs/msg/TFMessage", ("transforms",)) == Target(
        "array", "geometry_msgs/msg/TransformStamped"
    )
    assert check_path(defs, "sensor_msgs/msg/JointState", ("name",)) == Target("array", "string")
    assert check_path(defs, "sensor_msgs/msg/JointState", ("name", 0)) == Target("string", "string")
    bag = write_ros2_bag(tmp_path / "bag", header_scene_records(), "sqlite3")
    with open_log(bag, ReadOptions()) as source:
        assert source.explain_missing("/sim/state.layout.dim", numeric=True) == (
            "'/sim/state.layout.dim' is an array of std_msgs/msg/MultiArrayDimension; "
            "add an index, e.g. /sim/state.layout.dim[0]"
        )
        assert source.explain_missing("/sim/state.layout.dim[-1].size", numeric=True) is None


def _point_schema(ros1: bool) -> Schema:
    name = "geometry_msgs/PointStamped" if ros1 else "geometry_msgs/msg/PointStamped"
    text = msgdef("geometry_msgs/msg/PointStamped", 1 if ros1 else 2)
    return Schema(id=1, name=name, encoding="ros1msg" if ros1 else "ros2msg", data=text.encode())


def decoded_points() -> dict[str, object]:
    """The same PointStamped decoded by every library hybridlog reads with."""
    t_ns = 12 * 10**9 + 345
    ros2_message = stamped_point(ros2_store(), t_ns, 1.5)
    ros1_message = stamped_point(ros1_store(), t_ns, 1.5)
    ros2_raw = bytes(ros2_store().serialize_cdr(ros2_message, "geometry_msgs/msg/PointStamped"))
    ros1_raw = bytes(ros1_store().serialize_ros1(ros1_message, "geometry_msgs/msg/PointStamped"))
    ros2_decode = Ros2Decoders().decoder_for("cdr", _point_schema(ros1=False))
    ros1_decode = Ros1Decoders().decoder_for("ros1", _point_schema(ros1=True))
    assert ros2_decode is not None and ros1_decode is not None
    return {
        "rosbags ROS 2": ros2_store().deserialize_cdr(ros2_raw, "geometry_msgs/msg/PointStamped"),
        "rosbags ROS 1": ros1_store().deserialize_ros1(ros1_raw, "geometry_msgs/msg/PointStamped"),
        "mcap-ros2-support": ros2_decode(ros2_raw),
        "mcap-ros1-support": ros1_decode(ros1_raw),
        "json": json.loads(
            json.dumps(
                {
                    "header": {"stamp": {"sec": 12, "nanosec": 345}, "frame_id": "map"},
                    "point": {"x": 1.5, "y": -1.5, "z": 0.5},
                }
            )
        ),
    }


@pytest.mark.parametrize("library", list(decoded_points()))
def test_the_same_path_works_on_every_decoder(library: str) -> None:
    message = decoded_points()[library]
    assert as_number(evaluate(message, ("point", "x"))) == 1.5
    assert as_number(evaluate(message, ("point", "y"))) == -1.5
    assert as_label(evaluate(message, ("header", "frame_id"))) == "map"
    assert stamp_ns(evaluate(message, ("header", "stamp"))) == 12 * 10**9 + 345
    with pytest.raises(PathError, match="has no field 'q'"):
        evaluate(message, ("point", "q"))
    with pytest.raises(PathError, match="not a number"):
        as_number(evaluate(message, ("header", "frame_id")))


def decoded_arrays() -> dict[str, object]:
    """One Float64MultiArray and one uint8[] field, decoded by every library."""
    ros2, ros1 = ros2_store(), ros1_store()
    values = [0.5, -1.5, 2.0]
    raw2 = bytes(
        ros2.serialize_cdr(
            ros2.types["std_msgs/msg/Float64MultiArray"](
                layout=ros2.types["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0),
                data=np.array(values),
            ),
            "std_msgs/msg/Float64MultiArray",
        )
    )
    raw1 = bytes(
        ros1.serialize_ros1(
            ros1.types["std_msgs/msg/Float64MultiArray"](
                layout=ros1.types["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0),
                data=np.array(values),
            ),
            "std_msgs/msg/Float64MultiArray",
        )
    )
    name2, name1 = "std_msgs/msg/Float64MultiArray", "std_msgs/Float64MultiArray"
    schema2 = Schema(id=1, name=name2, encoding="ros2msg", data=msgdef(name2).encode())
    schema1 = Schema(id=1, name=name1, encoding="ros1msg", data=msgdef(name2, 1).encode())
    decode2 = Ros2Decoders().decoder_for("cdr", schema2)
    decode1 = Ros1Decoders().decoder_for("ros1", schema1)
    assert decode2 is not None and decode1 is not None
    return {
        "rosbags ROS 2": ros2.deserialize_cdr(raw2, name2),
        "rosbags ROS 1": ros1.deserialize_ros1(raw1, name2),
        "mcap-ros2-support": decode2(raw2),
        "mcap-ros1-support": decode1(raw1),
        "json": {"layout": {"dim": [], "data_offset": 0}, "data": values},
    }


@pytest.mark.parametrize("library", list(decoded_arrays()))
def test_numeric_arrays_are_float_arrays_on_every_decoder(library: str) -> None:
    message = decoded_arrays()[library]
    values = leaf_value(message, ("data",))
    assert isinstance(values, np.ndarray) and values.dtype == np.float64
    np.testing.assert_array_equal(values, [0.5, -1.5, 2.0])
    assert leaf_value(message, ("data", -1)) == 2.0
    assert leaf_value(message, ("layout", "data_offset")) == 0.0
    with pytest.raises(PathError, match="index out of range"):
        leaf_value(message, ("data", 3))


def test_numeric_arrays_become_float_arrays_whatever_the_container() -> None:
    import array

    for container in ([1, 2, 3], (1, 2, 3), array.array("i", [1, 2, 3]), np.arange(1, 4)):
        result = as_float_array(container)
        assert result.dtype == np.float64
        np.testing.assert_array_equal(result, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(as_float_array(b"\x01\x02"), [1.0, 2.0])
    # a uint8[] decoded as bytes is an array element by element too, not only as a whole
    # (its [-1] was 'is not an array' where leaf_value took the whole as [1.0, 2.0])
    assert leaf_value({"data": b"\x01\x02"}, ("data", -1)) == 2.0
    with pytest.raises(PathError, match=r"index out of range \(the array has 2 elements\)$"):
        leaf_value({"data": b"\x01\x02"}, ("data", 2))
    with pytest.raises(PathError, match=r"index out of range \(the array has 1 element\)$"):
        evaluate({"data": [0.5]}, ("data", 1))  # it said "1 elements"
    with pytest.raises(PathError, match="is not an array"):
        leaf_value({"data": "text"}, ("data", 0))
    message = {"position": [0.5, 1.5, 2.5]}
    assert as_number(evaluate(message, ("position", -1))) == 2.5
    with pytest.raises(PathError, match="index out of range"):
        evaluate(message, ("position", 3))
    with pytest.raises(PathError, match="not an array of numbers"):
        as_float_array(["a"])


def test_labels_are_text_and_integral_numbers_lose_their_fraction() -> None:
    assert as_label(" valve_open ") == "valve_open"
    assert as_label(3) == "3"
    assert as_label(3.0) == "3"
    assert as_label(np.int32(2)) == "2"
    assert as_label(2.5) == "2.5"
    assert as_label(True) == "1"


# ------------------------------------------------------------------ deserialised messages

MIXED = """
bool flag
int8 small
string name
uint16 count
float32[3] fixed
int64 big
string[] tags
test_msgs/Inner[] inners
uint8[] blob
float64 last
================================================================================
MSG: test_msgs/Inner
uint8 a
float64 b
string note
"""


def _store(ros1: bool) -> Any:
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.LATEST)
    store.register(get_types_from_msg(MIXED, "test_msgs/msg/Mixed"))
    return store


STORES = {False: _store(False), True: _store(True)}
small_text = st.text(alphabet="abcxyz_é", max_size=6)
inner = st.tuples(st.integers(0, 255), st.floats(-1e6, 1e6), small_text)
mixed = st.fixed_dictionaries(
    {
        "flag": st.booleans(),
        "small": st.integers(-128, 127),
        "name": small_text,
        "count": st.integers(0, 65535),
        "fixed": st.lists(st.floats(-100, 100, width=32), min_size=3, max_size=3),
        "big": st.integers(-(2**40), 2**40),
        "tags": st.lists(small_text, max_size=3),
        "inners": st.lists(inner, max_size=4),
        "blob": st.binary(max_size=5),
        "last": st.floats(-1e9, 1e9),
    }
)
PATHS: list[tuple[Any, ...]] = [
    ("flag",),
    ("small",),
    ("count",),
    ("fixed", 2),
    ("fixed", -3),
    ("big",),
    ("inners", 0, "b"),
    ("inners", -1, "a"),
    ("inners", 1, "b"),
    ("blob", -1),
    ("last",),
]


def _message(store: Any, fields: dict[str, Any]) -> Any:
    types = store.types
    inners = [types["test_msgs/msg/Inner"](a=a, b=b, note=n) for a, b, n in fields["inners"]]
    return types["test_msgs/msg/Mixed"](
        flag=fields["flag"],
        small=fields["small"],
        name=fields["name"],
        count=fields["count"],
        fixed=np.array(fields["fixed"], dtype=np.float32),
        big=fields["big"],
        tags=fields["tags"],
        inners=inners,
        blob=np.frombuffer(fields["blob"], dtype=np.uint8),
        last=fields["last"],
    )


def _reference(messages: list[Any], steps: tuple[Any, ...]) -> tuple[int, list[float]]:
    values = []
    for row, message in enumerate(messages):
        try:
            values.append(as_number(evaluate(message, steps)))
        except PathError:
            return row, values
    return -1, values


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(mixed, st.booleans()), min_size=1, max_size=6), st.booleans())
def test_paths_read_deserialised_messages_of_every_layout(
    rows: list[tuple[dict[str, Any], bool]], ros1: bool
) -> None:
    # Messages written by rosbags (little- and big-endian CDR, ROS 1) and read back through
    # decode_each with rosbags' deserialiser: every path gives the field that was written.
    store = STORES[ros1]
    messages = [_message(store, fields) for fields, _ in rows]
    if ros1:
        raw = [bytes(store.serialize_ros1(m, "test_msgs/msg/Mixed")) for m in messages]
        decode = lambda data: store.deserialize_ros1(data, "test_msgs/msg/Mixed")  # noqa: E731
    else:
        raw = [
            bytes(store.serialize_cdr(m, "test_msgs/msg/Mixed", little_endian=little))
            for m, (_, little) in zip(messages, rows, strict=True)
        ]
        decode = lambda data: store.deserialize_cdr(data, "test_msgs/msg/Mixed")  # noqa: E731
    decoded = decode_each(decode, raw)
    for steps in PATHS:
        bad_row, expected = _reference(messages, steps)
        got = _reference(decoded, steps)
        assert got[0] == bad_row
        np.testing.assert_array_equal(got[1], expected)
        for message in decoded[: bad_row if bad_row >= 0 else None]:
            assert as_number(accessor(steps)(message)) == as_number(evaluate(message, steps))
    assert [as_label(m.name) for m in decoded] == [as_label(m.name) for m in messages]


def test_messages_that_do_not_fit_their_type_are_refused_naming_the_row() -> None:
    store = ros2_store()
    good = bytes(
        store.serialize_cdr(stamped_point(store, 1, 2.0), "geometry_msgs/msg/PointStamped")
    )
    decode = lambda data: store.deserialize_cdr(data, "geometry_msgs/msg/PointStamped")  # noqa: E731
    with pytest.raises(UndecodableError) as info:
        decode_each(decode, [good, good[:-9]])
    assert info.value.row == 1


def test_a_placeholder_definition_is_refused_not_read_into_wrong_numbers() -> None:
    # rosbag2's talker.db3: rcl_interfaces/msg/Log stored as "uint8 level".  Read straight
    # from the bytes, level would be 251, 252, 253 (the first byte of stamp.sec).
    from tests.support.logfiles import LOG_TYPE, PLACEHOLDER, log_cdr

    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(PLACEHOLDER, LOG_TYPE))
    with pytest.raises(UndecodableError) as info:
        decode_each(
            lambda data: store.deserialize_cdr(data, LOG_TYPE), [log_cdr(k) for k in range(3)]
        )
    assert info.value.row == 0


def test_accessor_follows_attributes_and_indices_like_evaluate() -> None:
    store = ros2_store()
    point = stamped_point(store, 3 * 10**9 + 7, 1.5)
    assert accessor(("point", "y"))(point) == -1.5
    assert accessor(("header", "stamp", "sec"))(point) == 3
    array = store.types["std_msgs/msg/Float64MultiArray"](
        layout=store.types["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0),
        data=np.array([1.0, 2.0, 4.0]),
    )
    assert accessor(("data", -1))(array) == evaluate(array, ("data", -1)) == 4.0
    with pytest.raises(IndexError):
        accessor(("data", 3))(array)


def test_a_stamp_beyond_the_nanosecond_grid_is_refused_not_an_overflow(tmp_path: Path) -> None:
    """--time header on a JSON stamp written in nanoseconds (1.7e18 'seconds'), or a nanosec
    of 2^70 s, was 'unexpected OverflowError in messages.py' (the int64 array of times)."""
    with pytest.raises(PathError, match=r"beyond the 9\.2e\+09 s .*: 1\.7e\+18 s \(a stamp in"):
        stamp_ns(1_700_000_000_000_000_000)
    with pytest.raises(PathError, match=r"beyond .*: 1180591620717411303424 s and 0 ns$"):
        stamp_ns({"sec": 2**70, "nanosec": 0})
    assert stamp_ns({"sec": 9_100_000_000, "nanosec": 5}) == 9_100_000_000 * 10**9 + 5
    assert stamp_ns(-1.5) == -1_500_000_000
    log = tmp_path / "stamped.mcap"
    channels = [
        Channel(t, encoding="json", schema_name="x", schema_encoding="jsonschema", schema_text="{}")
        for t in ("/u", "/y")
    ]
    messages = [
        (c, k * 10**8, json.dumps({"header": {"stamp": 1.7e18 + k}, "data": k}).encode())
        for k in range(5)
        for c in (0, 1)
    ]
    write_mcap(log, channels, messages, profile="")
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.1)
    with pytest.raises(LogError, match=r"topic '/u' \(x\): header\.stamp is beyond the 9\.2e\+09"):
        load_signals(log, spec, ReadOptions(time="header"))


def test_a_json_integer_beyond_a_float_is_refused_not_an_overflow(tmp_path: Path) -> None:
    """JSON integers have no bound: 10^400 was 'unexpected OverflowError in
    message_paths.py' (float() of it), alone or in an array.  It is infinite, as 1e400 is,
    and refused as written (or dropped with --drop-nonfinite, test_logs_sparse_json)."""
    assert as_number(10**400) == np.inf and as_number(-(10**400)) == -np.inf
    assert list(leaf_value({"d": [1, -(10**400)]}, ("d",))) == [1.0, -np.inf]
    assert as_number(10**300) == 1e300
    log = tmp_path / "big.mcap"
    channels = [
        Channel(t, encoding="json", schema_name="x", schema_encoding="jsonschema", schema_text="{}")
        for t in ("/u", "/y")
    ]
    texts = ["1" + "0" * 400 if k == 3 else str(k) for k in range(6)]
    messages = [
        (c, k * 10**8, b'{"data": %s}' % t.encode()) for k, t in enumerate(texts) for c in (0, 1)
    ]
    write_mcap(log, channels, messages, profile="")
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.1)
    with pytest.raises(
        LogError, match=r"'/u\.data': 1000.* at t=0\.3 s .* beyond the range of a float64"
    ):
        load_signals(log, spec)


def test_default_truth_without_header_stamp_is_no_truth_with_time_header(tmp_path: Path) -> None:
    """--time header on stamped /u and /y beside a std_msgs/String /truth/mode (no header):
    the unmapped default truth refused the whole run, and the user could not unmap it."""
    stamped = {
        "type": "object",
        "properties": {
            "header": {"type": "object", "properties": {"stamp": {"type": "number"}}},
            "data": {"type": "number"},
        },
    }
    channels = [
        Channel(
            t,
            encoding="json",
            schema_name="Stamped",
            schema_encoding="jsonschema",
            schema_text=json.dumps(stamped),
        )
        for t in ("/u", "/y")
    ]
    channels.append(Channel("/truth/mode", schema_name="std_msgs/msg/String"))
    store = get_typestore(Stores.LATEST)
    mode = bytes(
        store.serialize_cdr(store.types["std_msgs/msg/String"](data="a"), "std_msgs/msg/String")
    )
    messages = [
        (c, k * 10**8, json.dumps({"header": {"stamp": 5.0 + k / 10}, "data": k}).encode())
        for k in range(5)
        for c in (0, 1)
    ]
    messages += [(2, k * 10**8, mode) for k in range(5)]
    log = write_mcap(tmp_path / "stamped.mcap", channels, sorted(messages, key=lambda m: m[1]))
    spec = SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=0.1)
    notes: dict[str, Any] = {}
    signals = load_signals(log, spec, ReadOptions(time="header"), notes=notes)
    assert signals.truth_modes is None
    np.testing.assert_allclose(signals.time, [5.0, 5.1, 5.2, 5.3, 5.4])
    (note,) = notes["truth_unusable"]
    assert note.startswith("truth.mode (field '/truth/mode.data': topic '/truth/mode' (std_msgs")
    assert "has no header.stamp" in note
    # by log time it is truth; mapped with --map it must be usable
    assert load_signals(log, spec, ReadOptions()).truth_modes is not None
    with pytest.raises(
        LogError, match=r"from --map truth.mode=/truth/mode.data\): topic .* no header"
    ):
        load_signals(log, spec, ReadOptions(time="header", maps=("truth.mode=/truth/mode.data",)))


def test_default_truth_a_json_read_cannot_use_is_no_truth(tmp_path: Path) -> None:
    """A JSON truth topic found unusable only in its messages is no truth, as a ROS one is.

    README's own example (a truth topic without ``header.stamp`` under ``--time header``)
    stopped the run on an MCAP file of JSON messages: their schema (``{"type": "object"}``)
    does not say which fields a message has, so only the read found the missing stamp, and
    its error ended the analysis where a ROS topic's definition made the topic no truth.
    Named with ``--map``, it is still an error; so is a bad value (a text among numbers).
    """
    schema = json.dumps({"type": "object"})
    names = ("/u", "/y", "/truth/x", "/truth/mode")
    channels = [
        Channel(
            t, encoding="json", schema_name="S", schema_encoding="jsonschema", schema_text=schema
        )
        for t in names
    ]

    def message(topic: str, k: int, truth_x: object) -> bytes:
        stamp = {"header": {"stamp": 5.0 + k / 10}}
        if topic == "/truth/x":
            return json.dumps({"data": truth_x}).encode()
        if topic == "/truth/mode":
            return json.dumps({"data": "a"}).encode()
        return json.dumps({**stamp, "data": k}).encode()

    spec = SignalSpec(inputs=("u",), outputs=("y",), states=("x",), mode_ids=("a",), dt=0.1)

    def log_with(truth_x: object) -> Path:
        messages = [
            (c, k * 10**8, message(t, k, truth_x)) for k in range(5) for c, t in enumerate(names)
        ]
        return write_mcap(tmp_path / f"json_{truth_x}.mcap", channels, messages)

    log = log_with(1.5)
    notes: dict[str, Any] = {}
    signals = load_signals(log, spec, ReadOptions(time="header"), notes=notes)
    assert signals.truth_states is None and signals.truth_modes is None
    unusable = {n.partition(" (")[0]: n for n in notes["truth_unusable"]}
    assert set(unusable) == {"truth.x", "truth.mode"}
    assert "header.stamp: the message has no field 'header'" in unusable["truth.x"]
    assert "truth.x" not in notes["fields"]
    assert load_signals(log, spec, ReadOptions()).truth_states is not None  # by log time
    mapped = ReadOptions(time="header", maps=("truth.x=/truth/x.data",))
    with pytest.raises(LogError, match=r"from --map truth.x=/truth/x.data\): topic .* header"):
        load_signals(log, spec, mapped)
    # a bad value is no missing stamp: an error, found by default too
    with pytest.raises(LogError, match=r"truth.x \(field '/truth/x.data', the default.*string"):
        load_signals(log_with("high"), spec, ReadOptions())
