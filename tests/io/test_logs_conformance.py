"""Valid MCAP files of every shape are read alike.

The MCAP specification makes most records optional -- chunks, message and chunk indexes,
statistics, summary offsets, and repeating channels and schemas in the summary.  A reader
that seeks with the summary alone misses channels that are only in the data section and
reports their messages as missing (or the file as damaged).  Two corpora check that:

- ``tests/data/mcap-conformance/``: the 416 input files of the MCAP project's conformance
  suite with the topics and counts a streaming read finds in each (see its README), copied
  from ``../shared/testdata`` because CI runs on a fresh clone that has no such folder;
- every combination of the ``mcap`` writer's options, for the ``ros2``, ``ros1`` and empty
  profiles, whose values are known (``logfiles.write_mcap_variant``).
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner
from mcap.writer import CompressionType, IndexType

from hybridlog.cli import cli
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals
from tests.support.logfiles import (
    VARIANT_ATTACHMENT,
    VARIANT_METADATA,
    VARIANT_TOPICS,
    variant_values,
    write_mcap_variant,
)

CONFORMANCE = Path(__file__).parents[1] / "data" / "mcap-conformance"

# Problems that mean "read as damaged"; undecodable encodings are listed, not damaged.
DAMAGE_WORDS = ("damaged", "CRC", "index lists", "unfinished")


def test_every_conformance_input_lists_the_expected_topics_and_counts() -> None:
    expected: dict[str, dict[str, int]] = json.loads(
        (CONFORMANCE / "expected_counts.json").read_text()
    )
    assert len(expected) == 416
    wrong: dict[str, Any] = {}
    carrying = 0
    for name, counts in expected.items():
        info = inspect_log(CONFORMANCE / name)
        # attachments and metadata records, as the mcap library's streaming read finds them
        side = _side_records_streamed(CONFORMANCE / name)
        listed_side = (
            [(a["name"], a["media_type"], a["bytes"], a["log_time"]) for a in info["attachments"]],
            [(m["name"], m["entries"]) for m in info["metadata_records"]],
        )
        carrying += bool(side[0] or side[1])
        if listed_side != side:
            wrong[name] = ("attachments and metadata", listed_side, side)
            continue
        found = {t["name"]: t["count"] for t in info["topics"]}
        damage = [p for p in info["problems"] if any(w in p for w in DAMAGE_WORDS)]
        listed = [
            t["name"]
            for t in info["topics"]
            if t["indexed_count"] is not None and t["indexed_count"] != t["count"]
        ]
        if found != counts or damage or listed or info["messages"] != sum(counts.values()):
            wrong[name] = (found, counts, damage, listed)
    example = next(iter(wrong.items()), None)
    assert not wrong, f"{len(wrong)} of {len(expected)} read wrongly, e.g. {example}"
    assert carrying == 28  # OneAttachment's 14 variants and OneMetadata's 14


def _side_records_streamed(path: Path) -> tuple[list[Any], list[Any]]:
    """The Attachment and Metadata records of ``path``, streamed by the mcap library."""
    from mcap.records import Attachment, Metadata
    from mcap.stream_reader import StreamReader

    attachments: list[Any] = []
    metadata: list[Any] = []
    with path.open("rb") as handle:
        for record in StreamReader(handle).records:
            if isinstance(record, Attachment):
                attachments.append(
                    (record.name, record.media_type, len(record.data), record.log_time / 1e9)
                )
            elif isinstance(record, Metadata):
                metadata.append((record.name, dict(record.metadata)))
    return attachments, metadata


def test_undecodable_conformance_channels_are_listed_with_their_counts() -> None:
    schemaless = CONFORMANCE / "OneSchemalessMessage" / "OneSchemalessMessage-ch-chx-mx-st-sum.mcap"
    info = inspect_log(schemaless)
    assert [(t["name"], t["count"], t["type"]) for t in info["topics"]] == [("example", 1, "")]
    assert info["problems"] == [
        "topic 'example' (no type): message encoding 'text' is not supported "
        "(supported: cdr, ros1, json)"
    ]


WRITER_VARIANTS = list(
    itertools.product(
        [True, False],  # use_chunking
        [IndexType.ALL, IndexType.CHUNK, IndexType.MESSAGE, IndexType.NONE],
        [True, False],  # repeat_channels
        [True, False],  # repeat_schemas
        [True, False],  # use_statistics
    )
)
COMPRESSIONS = [CompressionType.ZSTD, CompressionType.LZ4, CompressionType.NONE]


@pytest.mark.parametrize("profile", ["ros2", "ros1", ""])
def test_every_writer_variant_gives_the_same_counts_and_values(
    profile: str, tmp_path: Path
) -> None:
    steps = 40  # the attachment and metadata half way, at 20 s
    expected = variant_values(np.arange(steps))
    wrong: list[str] = []
    for number, (chunking, indexes, channels, schemas, statistics) in enumerate(WRITER_VARIANTS):
        options = {
            "use_chunking": chunking,
            "index_types": indexes,
            "repeat_channels": channels,
            "repeat_schemas": schemas,
            "use_statistics": statistics,
            "use_summary_offsets": number % 2 == 0,
            "compression": COMPRESSIONS[number % 3],
        }
        log = write_mcap_variant(tmp_path / f"v{number}.mcap", profile, steps, **options)
        info = inspect_log(log)
        counts = {t["name"]: t["count"] for t in info["topics"]}
        signals = load_signals(
            log,
            SignalSpec(inputs=("u",), outputs=("y",), mode_ids=("a",), dt=1.0),
            ReadOptions(maps=("u=/u.data", "y=/y.data")),
        )
        name, media_type, data = VARIANT_ATTACHMENT
        same = (
            counts == dict.fromkeys(VARIANT_TOPICS, steps)
            and info["problems"] == []
            and info["attachments"]
            == [{"name": name, "media_type": media_type, "bytes": len(data), "log_time": 20.0}]
            and info["metadata_records"]
            == [{"name": VARIANT_METADATA[0], "entries": VARIANT_METADATA[1]}]
            and np.array_equal(signals.time, np.arange(steps, dtype=float))
            and np.array_equal(signals.inputs[:, 0], expected["/u"])
            and np.array_equal(signals.outputs[:, 0], expected["/y"])
        )
        if not same:
            wrong.append(f"{options}: {counts} {info['problems']}")
    assert not wrong, "\n".join(wrong)


def test_inspect_counts_a_ros1_mcap_without_repeated_channels(tmp_path: Path) -> None:
    log = write_mcap_variant(
        tmp_path / "ros1.mcap", "ros1", 25, repeat_channels=False, repeat_schemas=False
    )
    result = CliRunner().invoke(cli, ["inspect", str(log), "--json"])
    assert result.exit_code == 0, result.output
    info = json.loads(result.output)
    assert [(t["name"], t["count"], t["indexed_count"]) for t in info["topics"]] == [
        ("/u", 25, 25),
        ("/y", 25, 25),
    ]
    assert info["problems"] == []
    assert info["topics"][0]["fields"] == ["/u.data"]
