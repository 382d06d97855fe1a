"""Real log files for the tests: simulated runs, logs written by other tools, damaged files.

Everything here writes actual files with the libraries robots and loggers use (rosbags' bag
writers, the ``mcap`` writer, ``mcap-ros1-support``/``mcap-ros2-support``), so the readers are
tested on the bytes those tools produce, not on hybridlog's own writer alone.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
from mcap.records import ChunkIndex, Footer, Statistics, SummaryOffset
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer
from rosbags.typesys import Stores, get_typestore

from hybridlog.model.loader import load_model
from hybridlog.simulate import simulate

MAGIC = b"\x89MCAP0\r\n"
NS = 1_000_000_000


@cache
def ros2_store() -> Any:
    return get_typestore(Stores.LATEST)


@cache
def ros1_store() -> Any:
    return get_typestore(Stores.ROS1_NOETIC)


def msgdef(msgtype: str, ros_version: int = 2) -> str:
    store = ros1_store() if ros_version == 1 else ros2_store()
    return str(store.generate_msgdef(msgtype, ros_version=ros_version)[0])


def float64_cdr(value: float) -> bytes:
    return bytes(
        ros2_store().serialize_cdr(
            ros2_store().types["std_msgs/msg/Float64"](data=value), "std_msgs/msg/Float64"
        )
    )


def val_mcap(path: Path, definition: str) -> Path:
    """Topics ``/u`` and ``/y`` of ``my_pkg/msg/Val`` (10 messages each), defined by ``definition``.

    The stored text alone defines the type (``""``: none stored, ``--msg-dir`` must); each
    message's bytes are one float64's CDR.
    """
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2")
        schema = writer.register_schema("my_pkg/msg/Val", "ros2msg", definition.encode())
        channels = [writer.register_channel(t, "cdr", schema) for t in ("/u", "/y")]
        for k in range(10):
            for channel in channels:
                writer.add_message(channel, k * 100_000_000, float64_cdr(k), k * 100_000_000)
        writer.finish()
    return path


def cdr(message: Any, msgtype: str) -> bytes:
    return bytes(ros2_store().serialize_cdr(message, msgtype))


def stamped_point(store: Any, t_ns: int, x: float, frame: str = "map") -> Any:
    """A ``geometry_msgs/PointStamped`` with ``header.stamp = t_ns`` and ``point.x = x``."""
    types = store.types
    header_fields = {
        "stamp": types["builtin_interfaces/msg/Time"](sec=t_ns // NS, nanosec=t_ns % NS),
        "frame_id": frame,
    }
    if "seq" in [name for name, _ in store.fielddefs["std_msgs/msg/Header"][1]]:
        header_fields["seq"] = 0
    header = types["std_msgs/msg/Header"](**header_fields)
    point = types["geometry_msgs/msg/Point"](x=x, y=-x, z=0.5)
    return types["geometry_msgs/msg/PointStamped"](header=header, point=point)


# --------------------------------------------------------------------- simulated runs


@dataclass(frozen=True)
class Run:
    """A simulated run of a built-in model: its columns as ``simulate`` writes them."""

    model: Any
    columns: dict[str, Any]

    @property
    def time_ns(self) -> np.ndarray:
        return np.rint(self.columns["t"] * 1e9).astype(np.int64)


@cache
def tank_run(steps: int = 90, seed: int = 7) -> Run:
    model = load_model("three_tank_hstf")
    log = simulate(model, schedule="1:30,2:30,3:30", steps=steps, seed=seed)
    return Run(model, log.columns(model))


# --------------------------------------------------------------------- MCAP by hand


@dataclass(frozen=True)
class Channel:
    topic: str
    encoding: str = "cdr"
    schema_name: str = "std_msgs/msg/Float64"
    schema_encoding: str = "ros2msg"
    schema_text: str | None = None  # default: the standard definition of schema_name

    def schema_bytes(self) -> bytes:
        if self.schema_text is not None:
            return self.schema_text.encode()
        if self.schema_encoding == "ros2msg":
            return msgdef(self.schema_name).encode()
        return b""


def write_mcap(
    path: Path,
    channels: Sequence[Channel | None],
    messages: Iterable[tuple[int, int, bytes]],
    *,
    profile: str = "ros2",
    chunk_size: int = 1024 * 1024,
    compression: CompressionType = CompressionType.NONE,
    finish: bool = True,
    data_crc: bool = False,
) -> Path:
    """Write an MCAP with the ``mcap`` library's writer.

    ``channels[i]`` describes channel ``i``; ``None`` gives a schemaless CDR channel.
    ``messages`` are ``(channel index, log time ns, data)``.  Without ``finish`` the file ends
    like one whose recorder was killed: the last chunk flushed, no summary, no footer.
    """
    handle = path.open("wb")
    writer = Writer(
        handle, chunk_size=chunk_size, compression=compression, enable_data_crcs=data_crc
    )
    writer.start(profile=profile, library="tests")
    ids: list[int] = []
    schemas: dict[tuple[str, str], int] = {}
    for channel in channels:
        if channel is None:
            ids.append(writer.register_channel("/schemaless", "cdr", 0))
            continue
        key = (channel.schema_name, channel.schema_encoding)
        if channel.schema_encoding == "none":
            schema_id = 0
        elif key not in schemas:
            schemas[key] = writer.register_schema(
                channel.schema_name,
                channel.schema_encoding if channel.schema_encoding != "empty" else "",
                channel.schema_bytes(),
            )
            schema_id = schemas[key]
        else:
            schema_id = schemas[key]
        ids.append(writer.register_channel(channel.topic, channel.encoding, schema_id))
    for index, (channel_index, log_time, data) in enumerate(messages):
        writer.add_message(ids[channel_index], log_time, data, log_time, index)
    if finish:
        writer.finish()
    else:
        writer.flush()
    handle.close()
    return path


def float_messages(
    times_ns: Sequence[int], values: Sequence[float], channel: int = 0
) -> list[tuple[int, int, bytes]]:
    return [(channel, int(t), float64_cdr(float(v))) for t, v in zip(times_ns, values, strict=True)]


def drop_chunk_index(source: Path, target: Path, which: int = 0) -> Path:
    """Copy an MCAP, leaving out one chunk index from its summary (a damaged index).

    The data section is copied byte for byte; the summary is rewritten without the chunk
    index and without summary offsets, and the footer's summary CRC is left out (zero).
    """
    data = source.read_bytes()
    footer_at = len(data) - 8 - 29
    summary_start = struct.unpack_from("<Q", data, footer_at + 9)[0]
    out = bytearray(data[:summary_start])
    chunk_indexes = 0
    with source.open("rb") as handle:
        handle.seek(summary_start)
        reader = StreamReader(handle, skip_magic=True)
        for record in reader.records:
            if isinstance(record, Footer):
                break
            if isinstance(record, SummaryOffset):
                continue
            if isinstance(record, ChunkIndex):
                chunk_indexes += 1
                if chunk_indexes - 1 == which:
                    continue
            out += _record_bytes(record)
    assert chunk_indexes > which, "the file has too few chunks"
    out += _record_bytes(Footer(summary_start=summary_start, summary_offset_start=0, summary_crc=0))
    out += MAGIC
    target.write_bytes(bytes(out))
    return target


def _record_bytes(record: Any) -> bytes:
    from mcap.data_stream import RecordBuilder

    builder = RecordBuilder()
    record.write(builder)
    return bytes(builder.end())


def statistics_of(path: Path) -> Statistics | None:
    from mcap.reader import make_reader

    with path.open("rb") as handle:
        summary = make_reader(handle).get_summary()
    return None if summary is None else summary.statistics


def flip_byte(path: Path, offset: int) -> None:
    data = bytearray(path.read_bytes())
    data[offset] ^= 0xFF
    path.write_bytes(bytes(data))


def find(path: Path, needle: bytes, start: int = 0) -> int:
    index = path.read_bytes().find(needle, start)
    assert index >= 0, needle
    return index


def write_levels_mcap(path: Path, msgtype: str, definition: bytes, steps: int) -> Path:
    """A ROS 2 MCAP file of ``/u`` (``Float64``, ``k``) and ``/y`` (``msgtype``: two float64s,
    ``k + 0.5`` and ``-k``), a sample every 0.1 s from 1 s; ``definition`` stored as written."""
    header = b"\x00\x01\x00\x00"  # CDR, little-endian
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        level = writer.register_schema(msgtype, "ros2msg", definition)
        number = writer.register_schema("std_msgs/msg/Float64", "ros2msg", b"float64 data")
        inputs = writer.register_channel("/u", "cdr", number)
        levels = writer.register_channel("/y", "cdr", level)
        for k in range(steps):
            t = NS + k * NS // 10
            writer.add_message(inputs, t, header + struct.pack("<d", k), t)
            writer.add_message(levels, t, header + struct.pack("<dd", k + 0.5, -k), t)
        writer.finish()
    return path


def write_msg_dir(root: Path, package: str, name: str, text: str) -> Path:
    folder = root / package / "msg"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.msg").write_text(text)
    return root


def json_bytes(value: Any) -> bytes:
    return json.dumps(value).encode()


# --------------------------------------------------------------------- a recorded scene
#
# The tank run as a robot would record it: the pump command (the input) only every 5 s,
# the three levels on two topics logged 4 ms after the step (a PointStamped with y1, y2 and a
# Float64 with y3 at four times the rate, whose extra samples hold wrong values the nearest
# rule must not pick), the true mode as an Int32 and the true states as a Float64MultiArray,
# plus unrelated chatter and IMU topics.

OUTPUT_DELAY_NS = 4_000_000
MAPS = [
    "--map", "u=/pump/cmd.data",
    "--map", "y1=/levels.point.x",
    "--map", "y2=/levels/point/y",
    "--map", "y3=/level3.data",
    "--map", "truth.mode=/sim/mode.data",
    "--map", "truth.x1=/sim/state.data[0]",
    "--map", "truth.x2=/sim/state.data[1]",
    "--map", "truth.x3=/sim/state.data[-1]",
]  # fmt: skip


@dataclass(frozen=True)
class Record:
    """One message of the scene, independent of the format."""

    topic: str
    kind: str  # float, point, int, array, string, imu
    log_ns: int
    value: Any
    stamp_ns: int


TYPES = {
    "float": "std_msgs/msg/Float64",
    "point": "geometry_msgs/msg/PointStamped",
    "int": "std_msgs/msg/Int32",
    "array": "std_msgs/msg/Float64MultiArray",
    "string": "std_msgs/msg/String",
    "imu": "sensor_msgs/msg/Imu",
}


def scene(run: Run, *, extras: bool = True) -> list[Record]:
    columns = run.columns
    t = run.time_ns
    out: list[Record] = []
    for k, t_k in enumerate(t.tolist()):
        late = t_k + OUTPUT_DELAY_NS
        if k % 5 == 0:
            out.append(Record("/pump/cmd", "float", t_k, float(columns["u"][k]), t_k))
        out.append(Record("/sim/mode", "int", t_k, int(columns["mode"][k]), t_k))
        state = [float(columns[x][k]) for x in ("x1", "x2", "x3")]
        out.append(Record("/sim/state", "array", t_k, state, t_k))
        point = (float(columns["y1"][k]), float(columns["y2"][k]))
        out.append(Record("/levels", "point", late, point, late))
        for j in range(4):
            value = float(columns["y3"][k]) + (0.0 if j == 0 else 1000.0)
            stamp = late + j * 250_000_000
            out.append(Record("/level3", "float", stamp, value, stamp))
        if extras:
            out.append(Record("/chatter", "string", t_k + 1_000_000, f"step {k}", t_k))
            for j in range(5):
                out.append(Record("/imu", "imu", t_k + j * 200_000_000, float(j), t_k))
    out.sort(key=lambda r: r.log_ns)
    return out


def header_scene_records() -> list[Record]:
    """The scene without extras, every message logged 9 ms after its header stamp."""
    return [
        Record(r.topic, r.kind, r.log_ns + 9_000_000, r.value, r.log_ns)
        for r in scene(tank_run(), extras=False)
    ]


def ros_message(store: Any, record: Record) -> Any:
    types = store.types
    kind, value = record.kind, record.value
    if kind == "float":
        return types["std_msgs/msg/Float64"](data=value)
    if kind == "int":
        return types["std_msgs/msg/Int32"](data=value)
    if kind == "string":
        return types["std_msgs/msg/String"](data=value)
    if kind == "point":
        message = stamped_point(store, record.stamp_ns, value[0])
        message.point.y = value[1]
        return message
    if kind == "array":
        layout = types["std_msgs/msg/MultiArrayLayout"](
            dim=[types["std_msgs/msg/MultiArrayDimension"](label="x", size=3, stride=3)],
            data_offset=0,
        )
        return types["std_msgs/msg/Float64MultiArray"](
            layout=layout, data=np.array(value, dtype=np.float64)
        )
    header = stamped_point(store, record.stamp_ns, 0.0).header
    quaternion = types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
    vector = types["geometry_msgs/msg/Vector3"]
    return types["sensor_msgs/msg/Imu"](
        header=header,
        orientation=quaternion,
        orientation_covariance=np.zeros(9),
        angular_velocity=vector(x=value, y=0.0, z=0.0),
        angular_velocity_covariance=np.zeros(9),
        linear_acceleration=vector(x=0.0, y=0.0, z=9.81),
        linear_acceleration_covariance=np.zeros(9),
    )


def json_message(record: Record) -> dict[str, Any]:
    stamp = {"sec": record.stamp_ns // NS, "nanosec": record.stamp_ns % NS}
    header = {"stamp": stamp, "frame_id": "map"}
    if record.kind == "point":
        x, y = record.value
        return {"header": header, "point": {"x": x, "y": y, "z": 0.5}}
    if record.kind == "array":
        return {"header": header, "layout": {"dim": [], "data_offset": 0}, "data": record.value}
    if record.kind == "imu":
        return {"header": header, "angular_velocity": {"x": record.value}}
    return {"header": header, "data": record.value}


def write_ros2_bag(path: Path, records: Sequence[Record], storage: str) -> Path:
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Ros2Writer

    store = ros2_store()
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Ros2Writer(path, version=9, storage_plugin=plugin) as writer:
        connections: dict[str, Any] = {}
        for record in records:
            if record.topic not in connections:
                connections[record.topic] = writer.add_connection(
                    record.topic, TYPES[record.kind], typestore=store
                )
            data = store.serialize_cdr(ros_message(store, record), TYPES[record.kind])
            writer.write(connections[record.topic], record.log_ns, data)
    return path


def write_uy_bag(folder: Path, *, per_file: bool = False) -> Path:
    """A ROS 2 ``.db3`` bag of two Float64 topics ``/u`` and ``/y``, 20 messages each at 10 Hz.

    ``per_file``: compressed per file (zstd), as ``ros2 bag record --compression-mode file``.
    """
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin
    from rosbags.rosbag2 import Writer as Ros2Writer

    store = ros2_store()
    number = store.types["std_msgs/msg/Float64"]
    writer = Ros2Writer(folder, version=8, storage_plugin=StoragePlugin.SQLITE3)
    if per_file:
        writer.set_compression(CompressionMode.FILE, CompressionFormat.ZSTD)
    with writer:
        topics = [
            writer.add_connection(t, "std_msgs/msg/Float64", typestore=store) for t in ("/u", "/y")
        ]
        for k in range(20):
            for topic in topics:
                data = store.serialize_cdr(number(data=float(k)), "std_msgs/msg/Float64")
                writer.write(topic, 10**9 + k * 10**8, data)
    return folder


def write_ros1_bag(path: Path, records: Sequence[Record]) -> Path:
    from rosbags.rosbag1 import Writer as Ros1Writer

    store = ros1_store()
    with Ros1Writer(path) as writer:
        connections: dict[str, Any] = {}
        for record in records:
            if record.topic not in connections:
                connections[record.topic] = writer.add_connection(
                    record.topic, TYPES[record.kind], typestore=store
                )
            data = store.serialize_ros1(ros_message(store, record), TYPES[record.kind])
            writer.write(connections[record.topic], record.log_ns, data)
    return path


def write_mcap_ros2(path: Path, records: Sequence[Record]) -> Path:
    """With ``mcap-ros2-support``'s writer (messages given as dicts)."""
    from mcap_ros2.writer import Writer as McapRos2Writer

    store = ros2_store()
    with path.open("wb") as handle:
        writer = McapRos2Writer(handle)
        schemas: dict[str, Any] = {}
        for record in records:
            msgtype = TYPES[record.kind]
            if msgtype not in schemas:
                schemas[msgtype] = writer.register_msgdef(msgtype, msgdef(msgtype))
            message = store.deserialize_cdr(
                store.serialize_cdr(ros_message(store, record), msgtype), msgtype
            )
            writer.write_message(
                record.topic, schemas[msgtype], _as_dict(message), log_time=record.log_ns
            )
        writer.finish()
    return path


def _as_dict(message: Any) -> Any:
    if hasattr(message, "__msgtype__") or hasattr(message, "__dataclass_fields__"):
        fields = getattr(message, "__dataclass_fields__", {})
        return {name: _as_dict(getattr(message, name)) for name in fields if name != "__msgtype__"}
    if isinstance(message, np.ndarray):
        return message.tolist()
    if isinstance(message, list):
        return [_as_dict(item) for item in message]
    return message


def write_mcap_ros1(path: Path, records: Sequence[Record]) -> Path:
    """With ``mcap-ros1-support``'s writer (genpy message classes)."""
    from mcap_ros1._vendor.genpy import Time
    from mcap_ros1._vendor.genpy.dynamic import generate_dynamic
    from mcap_ros1.writer import Writer as McapRos1Writer

    classes: dict[str, Any] = {}

    def cls(msgtype: str) -> Any:
        ros1_name = msgtype.replace("/msg/", "/")
        if ros1_name not in classes:
            classes.update(generate_dynamic(ros1_name, msgdef(msgtype, 1)))
        return classes[ros1_name]

    def make(record: Record) -> Any:
        message_class = cls(TYPES[record.kind])
        value = record.value
        if record.kind in ("float", "int", "string", "array"):
            return message_class(data=value)
        stamp = Time(record.stamp_ns // NS, record.stamp_ns % NS)
        header = classes["std_msgs/Header"](seq=0, stamp=stamp, frame_id="map")
        if record.kind == "point":
            point = classes["geometry_msgs/Point"](x=value[0], y=value[1], z=0.5)
            return message_class(header=header, point=point)
        message = message_class(header=header)
        message.angular_velocity.x = value
        return message

    with path.open("wb") as handle:
        writer = McapRos1Writer(handle)
        for record in records:
            writer.write_message(record.topic, make(record), log_time=record.log_ns)
        writer.finish()
    return path


def write_mcap_json(path: Path, records: Sequence[Record], *, profile: str = "") -> Path:
    channels: list[Channel | None] = []
    index: dict[str, int] = {}
    messages = []
    for record in records:
        if record.topic not in index:
            index[record.topic] = len(channels)
            schema = {"type": "object"}
            channels.append(
                Channel(record.topic, "json", TYPES[record.kind], "jsonschema", json.dumps(schema))
            )
        messages.append((index[record.topic], record.log_ns, json_bytes(json_message(record))))
    return write_mcap(path, channels, messages, profile=profile, compression=CompressionType.ZSTD)


def write_mcap_cdr(path: Path, records: Sequence[Record], *, profile: str = "") -> Path:
    store = ros2_store()
    channels: list[Channel | None] = []
    index: dict[str, int] = {}
    messages = []
    for record in records:
        msgtype = TYPES[record.kind]
        if record.topic not in index:
            index[record.topic] = len(channels)
            channels.append(Channel(record.topic, "cdr", msgtype, "ros2msg"))
        messages.append(
            (index[record.topic], record.log_ns, cdr(ros_message(store, record), msgtype))
        )
    return write_mcap(path, channels, messages, profile=profile, compression=CompressionType.LZ4)


# --------------------------------------------------------------------- MCAP writer variants
#
# The MCAP specification makes most records optional: chunks, message and chunk indexes,
# statistics, summary offsets, and repeating channels and schemas in the summary.  The
# ``mcap`` writer can leave each out; a reader must read every combination the same way.

VARIANT_TOPICS = ("/u", "/y")


def variant_values(k: np.ndarray) -> dict[str, np.ndarray]:
    """The values of ``/u`` and ``/y`` at step ``k`` (distinct, so a mix-up shows)."""
    return {"/u": 0.5 * k, "/y": 100.0 + k * k / 7.0}


def write_mcap_variant(path: Path, profile: str, steps: int = 40, **writer_options: Any) -> Path:
    """``/u`` and ``/y`` (``Float64``, one per second) with the given ``Writer`` options.

    ``profile`` ``"ros2"`` (or ``""``) writes CDR with ``ros2msg`` schemas, ``"ros1"`` ROS 1
    serialisation with ``ros1msg`` schemas, as the ``ros2``/``ros1`` profiles require.  Half
    way through, the file gets :data:`VARIANT_ATTACHMENT` and :data:`VARIANT_METADATA`
    (indexed in the summary or not, as ``index_types`` says).
    """
    ros1 = profile == "ros1"
    values = variant_values(np.arange(steps))
    with path.open("wb") as handle:
        writer = Writer(handle, chunk_size=300, **writer_options)
        writer.start(profile=profile, library="tests")
        if ros1:
            schema = writer.register_schema("std_msgs/Float64", "ros1msg", b"float64 data\n")
        else:
            schema = writer.register_schema(
                "std_msgs/msg/Float64", "ros2msg", msgdef("std_msgs/msg/Float64").encode()
            )
        channels = {
            topic: writer.register_channel(topic, "ros1" if ros1 else "cdr", schema)
            for topic in VARIANT_TOPICS
        }
        for k in range(steps):
            if k == steps // 2:
                name, media_type, data = VARIANT_ATTACHMENT
                writer.add_attachment(k * NS, k * NS, name, media_type, data)
                writer.add_metadata(*VARIANT_METADATA)
            for topic in VARIANT_TOPICS:
                value = float(values[topic][k])
                data = struct.pack("<d", value) if ros1 else float64_cdr(value)
                writer.add_message(channels[topic], k * NS, data, k * NS, k)
        writer.finish()
    return path


VARIANT_ATTACHMENT = ("calibration.yaml", "text/yaml", b"gain: 2.5\n" * 50)
VARIANT_METADATA = ("robot", {"serial": "A-17", "firmware": "2.4.1"})


# --------------------------------------------------------------------- definitions that lie
#
# Logs whose stored definitions do not let rosbags decode a topic, beside good topics:
# rosbag2's talker.db3 stores the placeholder ``uint8 level`` for rcl_interfaces/msg/Log,
# and ROS 2 Jazzy records service events with the ``.srv`` text (``---``) as definition.

LOG_TYPE = "rcl_interfaces/msg/Log"
PLACEHOLDER = "uint8 level\n"
EVENT_TYPE = "example_interfaces/srv/AddTwoInts_Event"
EVENT_DEFINITION = (
    "=" * 80 + "\nSRV: example_interfaces/srv/AddTwoInts\nint64 a\nint64 b\n---\nint64 sum\n"
)


def log_cdr(k: int) -> bytes:
    """A ``rosout`` message at level 20 (INFO) whose stamp's first byte is 251 + k."""
    store = ros2_store()
    types = store.types
    message = types[LOG_TYPE](
        stamp=types["builtin_interfaces/msg/Time"](sec=1_700_000_251 + k, nanosec=0),
        level=20,
        name="talker",
        msg=f"Publishing: 'Hello World: {k}'",
        file="talker.cpp",
        function="on_timer",
        line=42,
    )
    return cdr(message, LOG_TYPE)


@cache
def event_store() -> Any:
    """ROS 2 types plus ``AddTwoInts`` and its service event, to serialise real events.

    Written as field definitions: rosbags' ``.msg`` parser renames ``srv`` types.
    """
    from rosbags.typesys.base import Nodetype

    store = get_typestore(Stores.LATEST)
    request, response = (f"example_interfaces/srv/AddTwoInts_{p}" for p in ("Request", "Response"))
    int64 = (Nodetype.BASE, ("int64", 0))
    store.register(
        {
            request: ([], [("a", int64), ("b", int64)]),
            response: ([], [("sum", int64)]),
            EVENT_TYPE: (
                [],
                [
                    ("info", (Nodetype.NAME, "service_msgs/msg/ServiceEventInfo")),
                    ("request", (Nodetype.SEQUENCE, ((Nodetype.NAME, request), 1))),
                    ("response", (Nodetype.SEQUENCE, ((Nodetype.NAME, response), 1))),
                ],
            ),
        }
    )
    return store


def event_cdr(k: int) -> bytes:
    """A service event: the request ``k + 1`` sent."""
    store = event_store()
    types = store.types
    info = types["service_msgs/msg/ServiceEventInfo"](
        event_type=0,
        stamp=types["builtin_interfaces/msg/Time"](sec=k, nanosec=0),
        client_gid=np.zeros(16, dtype=np.uint8),
        sequence_number=k,
    )
    request = types["example_interfaces/srv/AddTwoInts_Request"](a=k, b=1)
    return bytes(
        store.serialize_cdr(
            types[EVENT_TYPE](info=info, request=[request], response=[]), EVENT_TYPE
        )
    )


@dataclass(frozen=True)
class Stream:
    """One topic of a hand-made log: its type, stored definition and messages."""

    topic: str
    msgtype: str
    definition: str
    messages: tuple[tuple[int, bytes], ...]


def good_streams(steps: int = 30) -> list[Stream]:
    """``/u`` and ``/y`` as ``Float64``, one per second, ``u = k``, ``y = 2k``."""
    definition = msgdef("std_msgs/msg/Float64")
    return [
        Stream(
            topic,
            "std_msgs/msg/Float64",
            definition,
            tuple((k * NS, float64_cdr(float(k * scale))) for k in range(steps)),
        )
        for topic, scale in (("/u", 1), ("/y", 2))
    ]


def rosout_stream(definition: str, steps: int = 30) -> Stream:
    return Stream(
        "/rosout", LOG_TYPE, definition, tuple((k * NS, log_cdr(k)) for k in range(steps))
    )


def event_stream(steps: int = 30) -> Stream:
    return Stream(
        "/add_two_ints/_service_event",
        EVENT_TYPE,
        EVENT_DEFINITION,
        tuple((k * NS + 1000, event_cdr(k)) for k in range(steps)),
    )


def write_streams_mcap(
    path: Path, streams: Sequence[Stream], *, newest_first: bool = False, **writer_options: Any
) -> Path:
    """A ``ros2``-profile MCAP with the ``mcap`` writer, each stream with its own schema.

    Messages are written in log-time order, or with ``newest_first`` in the reverse order
    (which the MCAP specification allows).
    """
    with path.open("wb") as handle:
        writer = Writer(handle, **writer_options)
        writer.start(profile="ros2", library="tests")
        ids = []
        for stream in streams:
            schema = writer.register_schema(stream.msgtype, "ros2msg", stream.definition.encode())
            ids.append(writer.register_channel(stream.topic, "cdr", schema))
        messages = sorted(
            ((t, i, data) for i, stream in enumerate(streams) for t, data in stream.messages),
            reverse=newest_first,
        )
        for t, i, data in messages:
            writer.add_message(ids[i], t, data, t)
        writer.finish()
    return path


def write_streams_bag(
    path: Path, streams: Sequence[Stream], storage: str = "sqlite3", qos: Sequence[Any] = ()
) -> Path:
    """A ROS 2 bag with rosbags' writer, each stream with its stored definition."""
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Ros2Writer

    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Ros2Writer(path, version=9, storage_plugin=plugin) as writer:
        connections = []
        for stream in streams:
            if stream.msgtype in ros2_store().fielddefs:
                digest = ros2_store().hash_rihs01(stream.msgtype)
            else:
                digest = event_store().hash_rihs01(stream.msgtype)
            connections.append(
                writer.add_connection(
                    stream.topic,
                    stream.msgtype,
                    msgdef=stream.definition,
                    rihs01=digest,
                    offered_qos_profiles=list(qos),
                )
            )
        messages = sorted(
            (t, i, data) for i, stream in enumerate(streams) for t, data in stream.messages
        )
        for t, i, data in messages:
            writer.write(connections[i], t, data)
    return path


def forget_type_hashes(db3: Path) -> None:
    """Clear the type hashes of an sqlite3 bag, as bags recorded before ROS 2 Iron have none."""
    import sqlite3

    with sqlite3.connect(db3) as connection:
        connection.execute("update topics set type_description_hash = ''")
        connection.execute("update message_definitions set type_description_hash = ''")
    connection.close()


def reliable_qos(depth: int = 10) -> Any:
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    never = QosTime(sec=9223372036, nsec=854775807)
    return Qos(
        history=QosHistory.KEEP_LAST,
        depth=depth,
        reliability=QosReliability.RELIABLE,
        durability=QosDurability.VOLATILE,
        deadline=never,
        lifespan=never,
        liveliness=QosLiveliness.AUTOMATIC,
        liveliness_lease_duration=never,
        avoid_ros_namespace_conventions=False,
    )


SCENE_WRITERS: dict[str, tuple[str, Callable[[Path, list[Record]], Path]]] = {
    "rosbags ROS 2 sqlite3": ("bag_sqlite", lambda p, r: write_ros2_bag(p, r, "sqlite3")),
    "rosbags ROS 2 mcap": ("bag_mcap", lambda p, r: write_ros2_bag(p, r, "mcap")),
    "rosbags ROS 1": ("run.bag", write_ros1_bag),
    "mcap-ros2-support": ("ros2.mcap", write_mcap_ros2),
    "mcap-ros1-support": ("ros1.mcap", write_mcap_ros1),
    "mcap JSON": ("json.mcap", write_mcap_json),
    "mcap CDR, no profile": ("cdr.mcap", write_mcap_cdr),
}
"""Each other tool's writer of a recorded scene (its name, file name and writer): every
message-log reader and decoder hybridlog has."""


STAMPED_DEFINITION = """std_msgs/Header header
float64 x
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""
"""A message with a ``header.stamp`` and a ``float64 x``, as one ROS 2 text definition
(the form an MCAP schema of encoding ``ros2msg`` holds)."""
