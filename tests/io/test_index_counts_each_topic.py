"""Every topic's count is checked against the file's index, whatever the topics before it said.

``describe`` checked a topic's count only while its list of problems was empty: a problem
of an earlier topic (its own count, a JSON schema passed over, one nested too deep) let the
next topic's messages differ from the index without a word.  The check is skipped only
where the file was not read whole (reading stopped at a damaged record).
"""

from __future__ import annotations

import json
from pathlib import Path

from mcap.writer import Writer

from hybridlog.io import inspect_log


def test_a_count_the_index_contradicts_is_said_of_every_topic(tmp_path: Path) -> None:
    path = tmp_path / "counts.mcap"
    with path.open("wb") as handle:
        writer = Writer(handle)
        writer.start()
        schema = writer.register_schema("v", "jsonschema", b'{"type": "object"}')
        ids = [writer.register_channel(t, "json", schema) for t in ("/a", "/b")]
        for k in range(10):
            for channel in ids:
                data = json.dumps({"v": float(k)}).encode()
                writer.add_message(channel, k * 10**8, data, k * 10**8)
        statistics = writer._Writer__statistics  # type: ignore[attr-defined]
        for channel, extra in zip(ids, (2, 3), strict=True):  # an index that lists more
            statistics.channel_message_counts[channel] += extra
        writer.finish()
    problems = inspect_log(path)["problems"]
    assert "topic '/a': 10 messages found but the index lists 12" in problems
    assert "topic '/b': 10 messages found but the index lists 13" in problems
