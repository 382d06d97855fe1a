"""QoS profiles rosbags cannot parse, and which topic holds them.

rosbags parses every topic's ``offered_qos_profiles`` as it opens a ROS 2 bag (a folder's
``metadata.yaml``, the ``topics`` table of each ``.db3`` file) or a ``ros2`` MCAP file (its
channels' metadata), with :func:`rosbags.rosbag2.metadata.parse_qos`, and raises on
anything but a YAML list of complete profiles -- in its own words ("string indices must be
integers"), naming no topic.  Other writers, and edited bags, store other things: a YAML
scalar, a list of text, a profile without ``deadline``.  hybridlog never uses QoS, but only
rosbags reads ROS 2 bags; so the profiles are judged here by rosbags' own parser and what a
topic holds instead is said: for a bag once rosbags has failed to open it
(``BagSource._open_problem``: a bag it opens costs nothing), for an MCAP file before rosbags
is chosen to read it (:func:`~hybridlog.io.mcap_reader.rosbags_summary_problem`: the
``mcap`` reader, which never reads QoS, reads it instead).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from hybridlog.errors import excerpt
from hybridlog.io.definitions import first_line

EXPECTED = "a YAML list of complete profiles"
"""What rosbags reads a topic's ``offered_qos_profiles`` as."""


def qos_problem(
    profiles: Iterable[tuple[str, Any]], *, noun: str = "topic", place: str = ""
) -> str | None:
    """The first topic whose QoS profiles rosbags cannot parse, and why; ``None`` if none.

    Parameters
    ----------
    profiles:
        ``(topic, offered_qos_profiles as stored)``: YAML text (a ``.db3`` column, MCAP
        channel metadata, a version-8 ``metadata.yaml``) or what a version-9
        ``metadata.yaml`` holds there, already parsed.
    noun:
        What a topic is called where it is stored (``"channel"`` in an MCAP file).
    place:
        Where the profiles are stored, as said after the topic (``" in metadata.yaml"``).
    """
    from rosbags.rosbag2.metadata import parse_qos

    for topic, stored in profiles:
        try:
            parse_qos(stored)
        except Exception as err:  # rosbags raises what its YAML and dict lookups raise
            return (
                f"the QoS profiles of {noun} {excerpt(topic)}{place} hold "
                f"{_held(stored, err)}, not {EXPECTED}"
            )
    return None


def bag_qos_problem(path: Path) -> str | None:
    """Why rosbags cannot parse a QoS profile of a ROS 2 bag, or ``None``.

    ``path`` is a bag folder, whose ``metadata.yaml`` and ``.db3`` files are looked at (its
    MCAP storage files are checked as MCAP files are,
    :func:`~hybridlog.io.mcap_reader.rosbags_summary_problem`), or a bare ``.db3`` file.
    What cannot be read here is left for rosbags to say.
    """
    if not path.is_dir():
        return qos_problem(_db3_profiles(path), place=" in its topics table")
    if not (path / "metadata.yaml").is_file():
        return None  # rosbags says a bag folder needs one
    problem = qos_problem(_metadata_profiles(path / "metadata.yaml"), place=" in metadata.yaml")
    if problem is not None:
        return problem
    for file in sorted(path.glob("*.db3")):
        problem = qos_problem(_db3_profiles(file), place=f" in the topics table of {file.name}")
        if problem is not None:
            return problem
    return None


def _db3_profiles(path: Path) -> list[tuple[str, Any]]:
    """``(topic, offered_qos_profiles)`` of an sqlite3 bag (none before the column existed)."""
    import sqlite3  # only when a bag is opened

    try:
        # immutable, as rosbags opens it: no lock and no journal files beside the bag
        connection = sqlite3.connect(f"{path.absolute().as_uri()}?immutable=1", uri=True)
        try:
            columns = {row[1] for row in connection.execute("PRAGMA table_info(topics)")}
            if "offered_qos_profiles" not in columns:
                return []
            query = "SELECT name, offered_qos_profiles FROM topics ORDER BY id"
            return [(str(name), qos) for name, qos in connection.execute(query)]
        finally:
            connection.close()
    except sqlite3.Error:  # not a database rosbags can read either: it says why
        return []


def _metadata_profiles(path: Path) -> list[tuple[str, Any]]:
    """``(topic, offered_qos_profiles)`` of a ``metadata.yaml``, read as rosbags reads it."""
    from ruamel.yaml import YAML
    from ruamel.yaml.error import YAMLError

    try:
        document = YAML(typ="safe").load(path.read_text(encoding="utf-8"))
        listed = document["rosbag2_bagfile_information"]["topics_with_message_count"]
        return [
            (
                str(entry["topic_metadata"]["name"]),
                entry["topic_metadata"].get("offered_qos_profiles"),
            )
            for entry in listed
        ]
    except (OSError, ValueError, YAMLError, LookupError, TypeError, AttributeError):
        return []  # a metadata.yaml rosbags cannot read either: it says why


def _held(stored: Any, err: BaseException) -> str:
    """What ``stored`` holds where rosbags expects a YAML list of complete profiles."""
    from ruamel.yaml import YAML

    value = stored
    if isinstance(stored, str):
        try:
            value = YAML(typ="safe").load(stored)
        except Exception as yaml_err:  # what rosbags' parse_qos raised on loading it
            reason = getattr(yaml_err, "problem", None) or first_line(yaml_err)
            return f"text that is not YAML ({excerpt(reason)[1:-1]}: {excerpt(stored)})"
    if not isinstance(value, list):
        return _kind_of(value)
    for number, item in enumerate(value, 1):
        if not isinstance(item, dict):
            return f"a list whose item {number} is {_kind_of(item)}"
    if isinstance(err, KeyError):
        return f"a profile without {excerpt(err.args[0])}"
    return f"a profile rosbags cannot read ({excerpt(first_line(err))[1:-1]})"


def _kind_of(value: Any) -> str:
    if value is None:
        return "nothing (a YAML null)"
    if isinstance(value, str):
        return f"the text {excerpt(value)}"
    if isinstance(value, dict):
        keys = ", ".join(str(key) for key in value)
        return f"a mapping ({excerpt(keys)[1:-1]})" if keys else "an empty mapping"
    if isinstance(value, list):
        return "a list"
    return f"the value {excerpt(repr(value))[1:-1]}"
