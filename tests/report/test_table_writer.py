"""TableWriter: tables appended chunk by chunk, the same files as the whole run's tables."""

from __future__ import annotations

import dataclasses
import os
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from hybridlog.estimators.result import EstimationResult, TimelineColumn
from hybridlog.report import tables
from hybridlog.report.table_format import TABLE_FORMATS, check_table_format
from hybridlog.signals import AlignedSignals
from tests.report.test_report_files import make_run
from tests.report.test_report_smoothing import smoothed_run

Build = Callable[[EstimationResult, AlignedSignals], tables.Table]


def result_rows(result: EstimationResult, start: int, stop: int) -> EstimationResult:
    """Rows ``start:stop`` of a result, copied: a chunk as an estimator would yield it."""

    def rows(array: np.ndarray) -> np.ndarray:
        return np.array(array[start:stop])

    post = result.post_processing
    return dataclasses.replace(
        result,
        time=rows(result.time),
        modes=rows(result.modes),
        mode_probabilities=rows(result.mode_probabilities),
        state_means=rows(result.state_means),
        state_variances=rows(result.state_variances),
        output_predictions=rows(result.output_predictions),
        timeline_columns=tuple(
            dataclasses.replace(column, values=rows(column.values))
            for column in result.timeline_columns
        ),
        post_processing=None
        if post is None
        else dataclasses.replace(post, filtered=result_rows(post.filtered, start, stop)),
    )


def scribble(result: EstimationResult) -> None:
    """Overwrite every array of a chunk, as the estimator's next chunk does."""
    for array in (
        result.time,
        result.mode_probabilities,
        result.state_means,
        result.state_variances,
        result.output_predictions,
    ):
        array.fill(-7.0)
    result.modes.fill(0)
    for column in result.timeline_columns:
        column.values.fill(0)
    if result.post_processing is not None:
        scribble(result.post_processing.filtered)


def chunked(n: int, size: int | list[int]) -> Iterator[tuple[int, int]]:
    """Consecutive ``(start, stop)`` covering ``n`` rows: of ``size`` rows, or these sizes."""
    sizes = iter(size) if isinstance(size, list) else iter(lambda: size, None)
    start = 0
    while start < n:
        stop = min(n, start + next(sizes))
        yield start, stop
        start = stop


def full_run() -> tuple[EstimationResult, AlignedSignals]:
    """A smoothed run with estimator columns, and a truth state missing from its first rows."""
    result, signals = smoothed_run()
    n = result.n_samples
    rng = np.random.default_rng(3)
    result = dataclasses.replace(
        result,
        timeline_columns=(
            TimelineColumn("mode.pump", rng.integers(0, 2, n), labels=("on", "off")),
            TimelineColumn("delta_tilde.d1", rng.normal(size=n)),
        ),
    )
    assert signals.truth_states is not None
    signals.truth_states[:150, 2] = np.nan  # x3's truth begins at row 150; x2 has none
    return result, signals


def run_tables(
    result: EstimationResult, signals: AlignedSignals, start: int, stop: int, truth: tuple[int, ...]
) -> tuple[tables.Table, tables.Table]:
    rows = signals.rows(start, stop)
    return (
        tables.timeline_table(result, rows),
        tables.estimates_table(result, rows, truth_states=truth),
    )


def row_groups(path: Path) -> list[int]:
    """The number of rows of each row group of a Parquet file, from its Thrift footer."""
    data = path.read_bytes()
    assert data[:4] == data[-4:] == b"PAR1"
    size = int.from_bytes(data[-8:-4], "little")
    metadata, _ = _thrift_struct(data[-8 - size : -8], 0)
    return [group[3] for group in metadata[4]]  # FileMetaData.row_groups, RowGroup.num_rows


def _varint(buf: bytes, pos: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        byte = buf[pos]
        pos += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if not byte & 0x80:
            return value, pos


def _thrift_value(buf: bytes, pos: int, kind: int) -> tuple[object, int]:
    """One value of Thrift's compact protocol (what Parquet's footer is written in)."""
    if kind in (1, 2):  # a boolean element of a list (a field's boolean is in its header)
        return buf[pos] == 1, pos + 1
    if kind == 3:
        return buf[pos], pos + 1
    if kind in (4, 5, 6):
        raw, pos = _varint(buf, pos)
        return (raw >> 1) ^ -(raw & 1), pos
    if kind == 7:
        return buf[pos : pos + 8], pos + 8
    if kind == 8:
        length, pos = _varint(buf, pos)
        return buf[pos : pos + length], pos + length
    if kind in (9, 10):
        header = buf[pos]
        pos += 1
        count, element = header >> 4, header & 0x0F
        if count == 15:
            count, pos = _varint(buf, pos)
        items = []
        for _ in range(count):
            item, pos = _thrift_value(buf, pos, element)
            items.append(item)
        return items, pos
    if kind == 11:
        count, pos = _varint(buf, pos)
        if count:
            types = buf[pos]
            pos += 1
            for _ in range(count):
                _, pos = _thrift_value(buf, pos, types >> 4)
                _, pos = _thrift_value(buf, pos, types & 0x0F)
        return None, pos
    assert kind == 12, kind
    return _thrift_struct(buf, pos)


def _thrift_struct(buf: bytes, pos: int) -> tuple[dict[int, object], int]:
    fields: dict[int, object] = {}
    field = 0
    while True:
        header = buf[pos]
        pos += 1
        if header == 0:
            return fields, pos
        delta, kind = header >> 4, header & 0x0F
        if delta:
            field += delta
        else:
            raw, pos = _varint(buf, pos)
            field = (raw >> 1) ^ -(raw & 1)
        if kind in (1, 2):
            fields[field] = kind == 1
        else:
            fields[field], pos = _thrift_value(buf, pos, kind)


def writer_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name.startswith("hybridlog-")]


def test_the_thrift_reader_finds_polars_row_groups(tmp_path: Path) -> None:
    path = tmp_path / "x.parquet"
    pl.DataFrame({"x": np.arange(250.0), "s": ["a"] * 250}).write_parquet(path, row_group_size=100)
    assert row_groups(path) == [100, 100, 50]


@pytest.mark.parametrize("table_format", ["csv", "parquet"])
@pytest.mark.parametrize(
    "sizes",
    [
        128,  # multiples of the batch: the same batches as the whole table's
        50,  # batches cut at every chunk's end
        [7, 100, 1, 64, 200, 28],
        [20, 20, 20],  # fewer rows than a batch, in three chunks: written whole
        400,  # one chunk
    ],
)
def test_chunks_written_alternately_make_the_whole_runs_files(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, table_format: str, sizes: int | list[int]
) -> None:
    """Timeline and estimates writers fed chunk after chunk, each chunk overwritten once added:
    the files are those write_table writes for the whole run."""
    monkeypatch.setattr(tables, "BATCH_ROWS", 64)
    fmt = check_table_format(table_format)
    result, signals = full_run()
    n = 60 if sizes == [20, 20, 20] else result.n_samples
    result, signals = result_rows(result, 0, n), signals.rows(0, n)
    truth = tables.states_with_truth(signals)
    whole = run_tables(result, signals, 0, n, truth)
    want = [
        tables.write_table(table, tmp_path / f"whole_{k}", fmt) for k, table in enumerate(whole)
    ]
    with (
        tables.TableWriter(tmp_path / "timeline", fmt, whole[0].schema) as timeline,
        tables.TableWriter(tmp_path / "estimates", fmt, whole[1].schema) as estimates,
    ):
        for start, stop in chunked(n, sizes):
            chunk = result_rows(result, start, stop)
            timeline_chunk, estimates_chunk = run_tables(chunk, signals, start, stop, truth)
            timeline.add(timeline_chunk)
            estimates.add(estimates_chunk)
            scribble(chunk)
        got = [timeline.close(), estimates.close()]
    assert writer_threads() == []
    for path, expected in zip(got, want, strict=True):
        assert path.suffix == f".{fmt}"
        if fmt == "csv":
            assert path.read_bytes() == expected.read_bytes()
        else:
            frame, whole_frame = pl.read_parquet(path), pl.read_parquet(expected)
            assert frame.schema == whole_frame.schema
            assert frame.equals(whole_frame)
            groups = [64] * (n // 64) + ([n % 64] if n % 64 else [])
            assert row_groups(path) == row_groups(expected) == groups


def test_chunk_tables_concatenated_are_the_whole_runs_tables() -> None:
    result, signals = full_run()
    truth = tables.states_with_truth(signals)
    assert truth == (0, 2)
    whole = run_tables(result, signals, 0, result.n_samples, truth)
    assert whole[1].frame().equals(tables.estimates_table(result, signals).frame())  # the default
    parts = [
        run_tables(result_rows(result, start, stop), signals, start, stop, truth)
        for start, stop in chunked(result.n_samples, [100, 50, 250])
    ]
    for k in range(2):
        assert pl.concat([part[k].frame() for part in parts]).equals(whole[k].frame())
    # Decided per chunk, the first chunk (no truth for x3 yet) would have a column fewer.
    first = tables.estimates_table(result_rows(result, 0, 100), signals.rows(0, 100))
    assert "x3_true" not in first.schema
    assert "x3_true" in parts[0][1].schema


def test_a_batch_owns_its_rows() -> None:
    """Polars takes contiguous float64 arrays as views: a batch must not."""
    result, signals = full_run()
    chunk = result_rows(result, 0, 100)
    frames = [table.batch(0, 100) for table in run_tables(chunk, signals, 0, 100, (0, 2))]
    copies = [frame.clone() for frame in frames]
    assert chunk.time.flags.c_contiguous
    scribble(chunk)
    for frame, copy in zip(frames, copies, strict=True):
        assert frame.equals(copy)


@pytest.mark.parametrize("table_format", ["csv", "parquet"])
def test_a_writer_given_no_rows_writes_the_header(tmp_path: Path, table_format: str) -> None:
    fmt = check_table_format(table_format)
    result, signals = make_run(n=30)
    empty = tables.estimates_table(result_rows(result, 0, 0), signals.rows(0, 0))
    want = tables.write_table(empty, tmp_path / "want", fmt)
    with tables.TableWriter(tmp_path / "none", fmt, empty.schema) as writer:
        pass
    with tables.TableWriter(tmp_path / "empty", fmt, empty.schema) as writer:
        writer.add(empty)
    for path in (tmp_path / f"none.{fmt}", tmp_path / f"empty.{fmt}"):
        if fmt == "csv":
            assert (
                path.read_bytes()
                == want.read_bytes()
                == b",".join(name.encode() for name in empty.schema) + b"\n"
            )
        else:
            frame = pl.read_parquet(path)
            assert frame.height == 0
            assert frame.schema == empty.schema


def test_a_table_of_one_batch_is_written_without_the_sink(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def no_sink(*args: object, **kwargs: object) -> None:
        raise AssertionError("the sink started")

    monkeypatch.setattr(tables, "register_io_source", no_sink)
    result, signals = make_run(n=tables.BATCH_ROWS)
    for fmt in TABLE_FORMATS:
        path = tables.write_table(tables.timeline_table(result, signals), tmp_path / "t", fmt)
        assert path.stat().st_size > 0


@pytest.mark.parametrize("table_format", ["csv", "parquet"])
@pytest.mark.parametrize("rows", [10, 1000])
def test_a_folder_whose_name_is_not_utf8_takes_the_tables(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, table_format: str, rows: int
) -> None:
    """A batch names a log's folder after the log: polars took no path that is not UTF-8
    (a log named with byte 0xff failed with 'Object does not have a .write() method')."""
    monkeypatch.setattr(tables, "BATCH_ROWS", 64)  # 1000 rows: through the streaming sink
    fmt = check_table_format(table_format)
    folder = Path(os.fsdecode(bytes(tmp_path) + b"/run\xff.csv"))
    folder.mkdir()
    result, signals = make_run(n=rows)
    table = tables.timeline_table(result, signals)
    path = tables.write_table(table, folder / "timeline", fmt)
    want = tables.write_table(table, tmp_path / "timeline", fmt)
    if fmt == "csv":
        assert path.read_bytes() == want.read_bytes()
    else:
        with path.open("rb") as handle:
            assert pl.read_parquet(handle).equals(pl.read_parquet(want))
        assert row_groups(path) == row_groups(want)


@pytest.mark.parametrize("table_format", ["csv", "parquet"])
@pytest.mark.parametrize("rows", [10, 1000])
def test_a_missing_folder_is_raised_in_the_caller(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, table_format: str, rows: int
) -> None:
    """Whether the sink's thread failed (1,000 rows) or close writes the rows whole (10)."""
    monkeypatch.setattr(tables, "BATCH_ROWS", 64)
    fmt = check_table_format(table_format)
    result, signals = make_run(n=rows)
    table = tables.estimates_table(result, signals)
    stem = tmp_path / "missing" / "estimates"
    with (
        pytest.raises(FileNotFoundError, match="No such file or directory") as raised,
        tables.TableWriter(stem, fmt, table.schema) as writer,
    ):
        for start, stop in chunked(rows, 100):
            chunk = result_rows(result, start, stop)
            writer.add(tables.estimates_table(chunk, signals.rows(start, stop)))
        writer.close()
    assert "missing" in str(raised.value)
    assert writer_threads() == []


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full")
@pytest.mark.parametrize(("table_format", "error"), [("csv", OSError), ("parquet", Exception)])
def test_a_full_disk_is_raised_in_the_caller(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, table_format: str, error: type[Exception]
) -> None:
    """Writes to /dev/full fail with ENOSPC, as on a full disk (polars' Parquet writer wraps
    the OSError in its ComputeError)."""
    monkeypatch.setattr(tables, "BATCH_ROWS", 64)
    fmt = check_table_format(table_format)
    result, signals = make_run(n=4000)
    (tmp_path / f"estimates.{fmt}").symlink_to("/dev/full")
    table = tables.estimates_table(result, signals)
    with (
        pytest.raises(error, match=r"No space left on device \(os error 28\)"),
        tables.TableWriter(tmp_path / "estimates", fmt, table.schema) as writer,
    ):
        writer.add(table)
        writer.close()
    assert writer_threads() == []


def failing_take(
    monkeypatch: pytest.MonkeyPatch, failure: BaseException, after: threading.Event
) -> None:
    """Make the sink's source raise ``failure`` at its first take, once ``after`` is set."""

    def take(self: object) -> pl.DataFrame | None:
        after.wait(timeout=10)
        time.sleep(0.2)  # the caller waits for room by now
        raise failure

    monkeypatch.setattr(tables._Batches, "take", take)


def test_add_waiting_for_room_gets_the_error_of_a_dead_sink(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The sink dies while add waits on a full queue: add raises, no deadlock."""
    monkeypatch.setattr(tables, "BATCH_ROWS", 16)
    failure = OSError(28, "No space left on device")
    result, signals = make_run(n=400)
    table = tables.timeline_table(result, signals)
    built = threading.Event()
    column = table.columns["t"]

    def counted(lo: int, hi: int) -> pl.Series:
        if lo == 16 * tables.QUEUED_BATCHES:  # the queue is full: add is about to wait
            built.set()
        return column(lo, hi)

    table.columns["t"] = counted
    failing_take(monkeypatch, failure, built)
    outcome: list[BaseException] = []

    def feed() -> None:
        try:
            with tables.TableWriter(tmp_path / "timeline", "csv", table.schema) as writer:
                writer.add(table)
        except OSError as err:
            outcome.append(err)

    feeder = threading.Thread(target=feed, daemon=True)
    feeder.start()
    feeder.join(timeout=30)
    assert not feeder.is_alive()
    assert outcome == [failure]  # the very exception the sink died of
    assert writer_threads() == []


def test_at_most_a_few_batches_are_in_flight(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """While the sink takes nothing, add builds the queue's batches and one more, then waits."""
    monkeypatch.setattr(tables, "BATCH_ROWS", 16)
    result, signals = make_run(n=400)
    table = tables.estimates_table(result, signals)
    built: list[int] = []
    column = table.columns["t"]

    def counted(lo: int, hi: int) -> pl.Series:
        built.append(lo)
        return column(lo, hi)

    table.columns["t"] = counted
    go = threading.Event()
    original = tables._Batches.take

    def gated(self: tables._Batches) -> pl.DataFrame | None:
        go.wait(timeout=30)
        return original(self)

    monkeypatch.setattr(tables._Batches, "take", gated)
    with tables.TableWriter(tmp_path / "estimates", "parquet", table.schema) as writer:
        feeder = threading.Thread(target=writer.add, args=(table,), daemon=True)
        feeder.start()
        feeder.join(timeout=1.0)
        assert feeder.is_alive()  # waiting for room
        # Two batches held before the sink started (more than BATCH_ROWS rows), queued then.
        assert len(built) == tables.QUEUED_BATCHES + 1
        go.set()
        feeder.join(timeout=30)
        assert not feeder.is_alive()
        path = writer.close()
    assert len(built) == 25
    assert pl.read_parquet(path).equals(table.frame())


def test_leaving_with_an_exception_ends_the_thread_at_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(tables, "BATCH_ROWS", 16)
    result, signals = make_run(n=400)
    table = tables.estimates_table(result, signals)
    start = time.perf_counter()
    with (
        pytest.raises(KeyError, match="the estimator failed"),
        tables.TableWriter(tmp_path / "estimates", "parquet", table.schema) as writer,
    ):
        writer.add(table)
        assert writer_threads() != []  # the sink runs, waiting for more
        raise KeyError("the estimator failed")
    assert time.perf_counter() - start < 5.0
    assert writer_threads() == []
    with pytest.raises(ValueError, match="closed"):
        writer.add(table)


def test_misuse_is_refused(tmp_path: Path) -> None:
    result, signals = make_run(n=30)
    timeline = tables.timeline_table(result, signals)
    estimates = tables.estimates_table(result, signals)
    with tables.TableWriter(tmp_path / "timeline", "csv", timeline.schema) as writer:
        with pytest.raises(ValueError, match="a table with columns"):
            writer.add(estimates)
        writer.add(timeline)
        writer.close()
        with pytest.raises(ValueError, match="closed"):
            writer.close()
    assert pl.read_csv(tmp_path / "timeline.csv").height == 30


def test_truth_states_must_be_states_with_truth() -> None:
    result, signals = make_run(n=30)
    with pytest.raises(ValueError, match=r"truth_states \[3\]"):
        tables.estimates_table(result, signals, truth_states=[3])
    _, no_truth = make_run(n=30, truth=False)
    assert tables.states_with_truth(no_truth) == ()
    with pytest.raises(ValueError, match="no ground-truth states"):
        tables.estimates_table(result, no_truth, truth_states=[0])
    chosen = tables.estimates_table(result, signals, truth_states=[1, 0])
    assert [c for c in chosen.schema if c.endswith("_true")] == ["x1_true", "x2_true"]


def test_rows_of_signals_are_views() -> None:
    _, signals = make_run(n=30)
    rows = signals.rows(10, 25)
    assert rows.n_samples == 15
    assert rows.source == signals.source
    assert rows.state_names == signals.state_names
    assert signals.truth_modes is not None and signals.truth_states is not None
    assert rows.truth_modes is not None and rows.truth_states is not None
    for part, whole in [
        (rows.time, signals.time),
        (rows.inputs, signals.inputs),
        (rows.outputs, signals.outputs),
        (rows.truth_modes, signals.truth_modes),
        (rows.truth_states, signals.truth_states),
    ]:
        assert np.shares_memory(part, whole)
        assert np.array_equal(part, whole[10:25], equal_nan=True)
    assert signals.rows(30, 30).n_samples == 0
    _, no_truth = make_run(n=30, truth=False)
    assert no_truth.rows(0, 5).truth_states is None
    for start, stop in [(-1, 5), (5, 4), (0, 31)]:
        with pytest.raises(ValueError, match=f"rows {start}:{stop} of 30"):
            signals.rows(start, stop)
