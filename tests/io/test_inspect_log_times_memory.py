"""``inspect`` keeps every message's log time in 8 bytes, not in a Python integer.

The log times of every topic are held until the end of the pass (for the steps and gaps):
as a list of Python integers they took about 40 bytes a message, 160 MB more for a bag of
4.4·10^6 messages (an hour of ``tf``, diagnostics and cameras beside a model's topics).
Measured here with ``tracemalloc`` over a source that yields only times.
"""

from __future__ import annotations

import tracemalloc
from collections.abc import Iterator

from hybridlog.io.message_topics import Topic
from hybridlog.io.messages import MessageSource

TOPICS = 10


class TimesOnly(MessageSource):
    """``count`` messages, empty, on :data:`TOPICS` topics without a definition."""

    def __init__(self, count: int) -> None:
        super().__init__("times.mcap", None, "mcap")
        self.count = count
        self._topics = {
            f"/t{i}": Topic(f"/t{i}", "", "cdr", problem="no schema") for i in range(TOPICS)
        }

    def _iter_raw(self, topics: set[str]) -> Iterator[tuple[str, int, bytes]]:
        for k in range(self.count):
            yield f"/t{k % TOPICS}", 1_000_000 * k, b""

    def close(self) -> None:
        """Nothing to release."""


def test_log_times_take_about_8_bytes_a_message() -> None:
    TimesOnly(100).describe()  # imports done before the measurement
    count = 200_000
    source = TimesOnly(count)
    tracemalloc.start()
    try:
        described = source.describe()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert described["messages"] == count
    # 8 bytes each, and the steps of one topic at a time while it is described
    assert peak / count < 16
