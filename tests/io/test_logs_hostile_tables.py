"""Tables as other tools write them, with types and text a reader must not guess at.

Every input is read correctly or refused with one line naming the file, the column and the
row (or line).  Parquet files are written by polars (as pyarrow and pandas write them), CSV
files as text, never by hybridlog's own writers.
"""

from __future__ import annotations

import datetime as dt
import re
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals
from hybridlog.io.tables import TableSource

N = 30
T = np.round(np.arange(N) * 0.1, 10)
U = np.sin(T)
Y = np.cos(T)
SPEC = SignalSpec(inputs=("u",), outputs=("y",), states=("x",), mode_ids=("1", "2"), dt=0.1)


def parquet(tmp_path: Path, name: str = "log.parquet", **columns: Any) -> Path:
    path = tmp_path / name
    pl.DataFrame({"t": T, "u": U, "y": Y, **columns}).write_parquet(path)
    return path


def load(path: Path, *maps: str, **options: Any) -> Any:
    return load_signals(path, SPEC, ReadOptions(maps=maps, **options))


# ------------------------------------------------------------------ Parquet time columns


START = dt.datetime(2024, 1, 1)


@pytest.mark.parametrize(
    "column",
    [
        pl.Series([START + dt.timedelta(seconds=0.1 * k) for k in range(N)]).dt.cast_time_unit(
            "ms"
        ),
        pl.Series(
            [START.replace(tzinfo=dt.UTC) + dt.timedelta(seconds=0.1 * k) for k in range(N)]
        ).dt.convert_time_zone("Europe/Berlin"),
        pl.Series([dt.timedelta(seconds=0.1 * k) for k in range(N)]),
    ],
    ids=["datetime-ms", "datetime-tz", "duration"],
)
def test_datetime_and_duration_time_columns_are_read(column: pl.Series, tmp_path: Path) -> None:
    signals = load(parquet(tmp_path, t=column))
    np.testing.assert_array_equal(signals.outputs[:, 0], Y)
    offset = 0.0 if column.dtype == pl.Duration else START.replace(tzinfo=dt.UTC).timestamp()
    np.testing.assert_allclose(signals.time - offset, T, atol=1e-6)  # float64 at 1.7e9 s


@pytest.mark.parametrize(
    ("column", "what"),
    [
        (
            pl.Series(
                [dt.datetime(2300, 1, 1) + dt.timedelta(seconds=0.1 * k) for k in range(N)]
            ).dt.cast_time_unit("us"),
            r"the date '2300-01-01 00:00:00'",
        ),
        (
            pl.Series([dt.timedelta(days=200 * 365 * (k - 15)) for k in range(N)]),
            r"the duration '-1095000 days, 0:00:00'",
        ),
    ],
    ids=["datetime-2300", "duration-3000-years"],
)
def test_a_time_beyond_the_nanosecond_grid_is_refused_naming_the_row(
    column: pl.Series, what: str, tmp_path: Path
) -> None:
    """A date after 2262 became NaN in the conversion: "numerical trouble" and no file."""
    log = parquet(tmp_path, t=column)
    with pytest.raises(LogError, match=rf"^{re.escape(str(log))}, row 1, column 't': {what} is "):
        load(log)
    assert "row 1, column 't'" in inspect_log(log)["problems"][0]


@pytest.mark.parametrize(
    ("start", "step", "words"),
    [
        (1.7e9, 0.1, r"values near t=1700000000 s are 128 s apart, so every row holds that one"),
        (1000.0, 0.01, r"are 6\.1e-05 s apart, too coarse for its steps of 0\.01 s on average"),
    ],
)
def test_a_float32_time_column_too_coarse_for_its_steps_is_refused(
    start: float, step: float, words: str, tmp_path: Path
) -> None:
    """Unix time in float32 collapsed into "time repeats"; at 1000 s it rounded silently."""
    column = pl.Series(start + np.arange(N) * step, dtype=pl.Float32)
    log = parquet(tmp_path, t=column)
    with pytest.raises(LogError, match=r", row \d+, column 't': the time column is float32, "):
        load(log)
    with pytest.raises(LogError, match=words):
        load(log)


def test_a_float32_time_column_fine_enough_is_read(tmp_path: Path) -> None:
    signals = load(parquet(tmp_path, t=pl.Series(T, dtype=pl.Float32)))
    np.testing.assert_array_equal(signals.outputs[:, 0], Y)
    np.testing.assert_allclose(signals.time, T, atol=1e-7)


# ------------------------------------------------------------------ mode columns


@pytest.mark.parametrize(
    ("bad", "shown"),
    [(float("nan"), "NaN"), (float("inf"), "inf"), (1e20, r"1e\+20")],
)
def test_a_float_mode_column_s_odd_cell_is_refused_not_taken_for_empty(
    bad: float, shown: str, tmp_path: Path
) -> None:
    """NaN, inf or 1e20 among whole mode ids became an empty cell, and truth was bridged."""
    modes = [1.0, 2.0] * (N // 2)
    modes[7] = bad
    log = parquet(tmp_path, mode=modes)
    with pytest.raises(
        LogError, match=rf", row 8, column 'mode': truth\.mode '{shown}' at t=0\.7 s is not a mode"
    ):
        load(log)


def test_empty_cells_of_a_float_mode_column_are_no_samples(tmp_path: Path) -> None:
    modes: list[float | None] = [1.0, 2.0] * (N // 2)
    modes[7] = None
    signals = load(parquet(tmp_path, mode=modes))
    assert signals.truth_modes is not None
    assert signals.truth_modes[6] == 0 and signals.truth_modes[8] == 0


# ------------------------------------------------------------------ CSV time columns


def csv_log(tmp_path: Path, times: list[str], name: str = "log.csv") -> Path:
    path = tmp_path / name
    lines = [
        "t,u,y",
        *(f"{t},{float(u)!r},{float(y)!r}" for t, u, y in zip(times, U, Y, strict=True)),
    ]
    path.write_text("\n".join(lines) + "\n")
    return path


UTC_START = START.replace(tzinfo=dt.UTC).timestamp()


@pytest.mark.parametrize(
    ("written", "offset_s"),
    [
        (lambda k: (START + dt.timedelta(seconds=0.1 * k)).isoformat(), 0.0),
        (lambda k: str(START + dt.timedelta(seconds=0.1 * k)), 0.0),  # pandas: a space
        (lambda k: (START + dt.timedelta(seconds=0.1 * k)).isoformat() + "Z", 0.0),
        (lambda k: (START + dt.timedelta(seconds=0.1 * k)).isoformat() + "+01:00", -3600.0),
    ],
    ids=["T", "space", "Z", "offset"],
)
def test_an_iso_8601_time_column_is_read_as_dates_and_times(
    written: Any, offset_s: float, tmp_path: Path
) -> None:
    """It was refused: "'2024-01-01T00:00:00' is not a number"."""
    log = csv_log(tmp_path, [written(k) for k in range(N)])
    signals = load(log)
    np.testing.assert_array_equal(signals.outputs[:, 0], Y)
    np.testing.assert_allclose(signals.time - (UTC_START + offset_s), T, atol=1e-6)
    assert inspect_log(log)["time"]["start"] == pytest.approx(UTC_START + offset_s)


def test_nanoseconds_of_an_iso_time_are_kept(tmp_path: Path) -> None:
    times = [f"2024-01-01T00:00:{k // 10:02d}.{(k % 10) * 100_000_000 + k:09d}" for k in range(N)]
    series = TableSource(csv_log(tmp_path, times)).read(["y"]).numeric["y"]
    expected = int(UTC_START) * 10**9 + np.arange(N) * 100_000_000 + np.arange(N)
    np.testing.assert_array_equal(series.time_ns, expected)


@pytest.mark.parametrize(
    ("bad", "words"),
    [
        (
            "2024-01-01 00:00:00.7",
            r"'2024-01-01 00:00:00\.7' is not a date and time written like "
            r"'2024-01-01T00:00:00' on line 2 \(ISO 8601\)",
        ),
        ("01/01/2024 00:00:00", r"'01/01/2024 00:00:00' is not a date and time written like"),
        ("2300-01-01T00:00:00", r"the date '2300-01-01 00:00:00' is beyond what the nanosecond"),
    ],
)
def test_an_iso_time_column_with_an_odd_cell_is_refused_naming_the_line(
    bad: str, words: str, tmp_path: Path
) -> None:
    times = [(START + dt.timedelta(seconds=0.1 * k)).isoformat() for k in range(N)]
    times[7] = bad
    log = csv_log(tmp_path, times)
    with pytest.raises(LogError, match=rf"^{re.escape(str(log))}, line 9, column 't': {words}"):
        load(log)


# ------------------------------------------------------------------ CSV text


def csv_text(tmp_path: Path, header: str, row: Any, *, newline: str = "\n") -> Path:
    """A CSV file of ``header`` and ``row(k, u, y)`` for every k (``row`` gives a line)."""
    path = tmp_path / "log.csv"
    lines = [header, *(row(k, float(U[k]), float(Y[k])) for k in range(N))]
    path.write_bytes((newline.join(lines) + newline).encode())
    return path


def plain(k: int, u: float, y: float) -> str:
    return f"{float(T[k])!r},{u!r},{y!r}"


@pytest.mark.parametrize(
    ("header", "row", "newline"),
    [
        ("t,u,y", lambda k, u, y: f'"{float(T[k])!r}","{u!r}","{y!r}"', "\n"),
        ('"t","u","y"', plain, "\n"),
        ("t,u,y", plain, "\r\n"),
        ("\ufefft,u,y", plain, "\n"),
        ("t,u,y", lambda k, u, y: f" {float(T[k])!r} , +{u!r}\t,{y!r}", "\n"),
        ("t,u,y,note", lambda k, u, y: f'{plain(k, u, y)},"said ""hi"", twice"', "\n"),
    ],
    ids=["quoted-numbers", "quoted-header", "crlf", "bom", "blanks-and-plus", "quoted-text"],
)
def test_csv_text_as_other_tools_write_it_is_read(
    header: str, row: Any, newline: str, tmp_path: Path
) -> None:
    signals = load(csv_text(tmp_path, header, row, newline=newline))
    np.testing.assert_array_equal(signals.inputs[:, 0], U)
    np.testing.assert_array_equal(signals.outputs[:, 0], Y)


def odd_at_7(cell: str, column: int = 1) -> Any:
    """Rows whose ``column`` (0: t, 1: u, 2: y) is ``cell`` at k = 7."""

    def row(k: int, u: float, y: float) -> str:
        cells = [repr(float(T[k])), repr(u), repr(y)]
        if k == 7:
            cells[column] = cell
        return ",".join(cells)

    return row


@pytest.mark.parametrize(
    ("header", "row", "words"),
    [
        ("t,u,y", odd_at_7('"1,234.5"'), r", line 9, column 'u': '1,234\.5' is not a number"),
        ("t,u,y", odd_at_7("NaN"), r", line 9, column 'u': nan for input 'u' at t=0\.7 s"),
        ("t,u,y", odd_at_7("nan", 2), r", line 9, column 'y': nan for output 'y' at t=0\.7 s"),
        ("t,u,y", odd_at_7("-inf"), r", line 9, column 'u': -inf for input 'u' at t=0\.7 s"),
        ("t,u,y", odd_at_7("NA"), r", line 9, column 'u': 'NA' is not a number"),
        ("t,u,y", odd_at_7("1_000"), r", line 9, column 'u': '1_000' is not a number"),
        ("t,u,y", odd_at_7('"0.5"x'), r", line 9: a quote where a field cannot hold one"),
        ("t,u,y", odd_at_7('a"b'), r", line 9: a quote inside a field that is not quoted"),
        (
            "t;u;y",
            lambda k, u, y: f"{float(T[k])!r};{u!r};{y!r}",
            r", line 1: .* separated by semicolons",
        ),
        (
            "t,u,y,",
            lambda k, u, y: plain(k, u, y) + ",",
            r", line 1: column 4 of the header has no name \(",
        ),
        (
            ",t,u,y",
            lambda k, u, y: f"{k}," + plain(k, u, y),
            r", line 1: column 1 .* no name \(pandas' to_csv writes",
        ),
        ("t,u,y,u", lambda k, u, y: plain(k, u, y) + ",0", r", line 1: duplicate column name 'u'"),
        (
            't,u,"y\nz"',
            plain,
            r", line 1: the header's column 3 opens a quote that runs on to line 2; ",
        ),
    ],
    ids=[
        "thousands",
        "NaN",
        "nan",
        "-inf",
        "NA",
        "underscore",
        "text-after-quote",
        "quote-inside",
        "semicolons",
        "trailing-separator",
        "pandas-index",
        "duplicate",
        "header-quote-open",
    ],
)
def test_csv_text_hybridlog_cannot_vouch_for_is_refused_naming_the_line(
    header: str, row: Any, words: str, tmp_path: Path
) -> None:
    log = csv_text(tmp_path, header, row)
    with pytest.raises(LogError, match=rf"^{re.escape(str(log))}{words}"):
        load(log)


# ------------------------------------------------------------------ Parquet value types


@pytest.mark.parametrize(
    ("column", "expected"),
    [
        (pl.Series([f"{v:.6f}" for v in U]).str.to_decimal(scale=6), np.round(U, 6)),
        (pl.Series(U, dtype=pl.Float16), U.astype(np.float16).astype(np.float64)),
        (
            pl.Series([2**63 + 2048 * k for k in range(N)], dtype=pl.UInt64),
            [float(2**63 + 2048 * k) for k in range(N)],
        ),
        (pl.Series([1, -1] * (N // 2), dtype=pl.Int8), np.array([1.0, -1.0] * (N // 2))),
        (pl.Series([True, False] * (N // 2)), np.array([1.0, 0.0] * (N // 2))),
    ],
    ids=["decimal", "float16", "uint64-held-beyond-2^53", "int8", "boolean"],
)
def test_numeric_parquet_types_are_read_as_their_nearest_float64(
    column: pl.Series, expected: Any, tmp_path: Path
) -> None:
    """A uint64 beyond 2^53 that a float64 holds is read (one it cannot hold is refused,
    test_integers_beyond_float64.py)."""
    signals = load(parquet(tmp_path, u=column))
    np.testing.assert_array_equal(signals.inputs[:, 0], np.asarray(expected, dtype=np.float64))


@pytest.mark.parametrize(
    ("column", "type_name"),
    [
        (pl.Series([f"{v:.3f}" for v in U]).cast(pl.Categorical), "Categorical"),
        (pl.Series([f"{v}" for v in U]), "String"),
        (pl.Series([dt.timedelta(seconds=float(v)) for v in U]), r"Duration\(time_unit='us'\)"),
        (pl.Series([b"1"] * N), "Binary"),
        (pl.Series([None] * N, dtype=pl.Null), "Null"),
    ],
    ids=["categorical", "large-string-numbers", "duration", "binary", "all-null"],
)
def test_parquet_columns_of_other_types_are_refused_naming_the_column(
    column: pl.Series, type_name: str, tmp_path: Path
) -> None:
    log = parquet(tmp_path, u=column)
    with pytest.raises(
        LogError,
        match=rf"^{re.escape(str(log))}: input 'u' \(column 'u', the default; use --map u=\.\.\. "
        rf"for another\): column 'u' has type {type_name}, expected a number$",
    ):
        load(log)


@pytest.mark.parametrize(
    ("column", "type_name"),
    [
        (pl.Series([True, False] * (N // 2)), "Boolean"),
        (pl.Series([dt.date(2024, 1, 1) + dt.timedelta(days=k) for k in range(N)]), "Date"),
        (pl.Series([dt.time(0, 0, k) for k in range(N)]), "Time"),
    ],
    ids=["boolean", "date", "time-of-day"],  # text: see test_a_parquet_text_time_column_...
)
def test_a_time_column_of_another_type_is_refused(
    column: pl.Series, type_name: str, tmp_path: Path
) -> None:
    log = parquet(tmp_path, t=column)
    expected = (
        f"column 't' has type {type_name}, expected seconds as numbers, a Datetime or "
        "Duration, or ISO 8601 dates and times as text"
    )
    with pytest.raises(LogError) as refused:
        load(log)
    assert str(refused.value) == f"{log}: {expected}"
    # inspect said "line 2, column 't': '2024-01-01' is not a number" (a CSV's line, in a
    # Parquet file), and that a Boolean time "goes backwards"
    assert inspect_log(log)["problems"] == [expected]


@pytest.mark.parametrize("cell", ["1e400", "-" + "9" * 400, '"1e999"'])
def test_a_csv_number_beyond_a_float64_is_refused_as_such_not_as_inf(
    cell: str, tmp_path: Path
) -> None:
    """It was refused as "inf for input 'u'", which the cell does not say."""
    log = csv_text(tmp_path, "t,u,y", odd_at_7(cell))
    shown = re.escape(cell.strip('"')[:25])
    with pytest.raises(
        LogError, match=rf", line 9, column 'u': '{shown}.*' is beyond the range of a float64"
    ):
        load(log)
    notes: dict[str, Any] = {}
    load_signals(log, SPEC, ReadOptions(drop_nonfinite=True), notes=notes)
    assert notes["nonfinite_dropped"] == {"u": 1}  # out of range whatever it is taken for


def test_an_infinity_written_as_one_is_still_dropped_on_request(tmp_path: Path) -> None:
    log = csv_text(tmp_path, "t,u,y", odd_at_7("-Infinity"))
    notes: dict[str, Any] = {}
    load_signals(log, SPEC, ReadOptions(drop_nonfinite=True), notes=notes)
    assert notes["nonfinite_dropped"] == {"u": 1}


def iso_parquet(tmp_path: Path, times: list[str | None], writer: str) -> Path:
    """A Parquet log whose time column is text, or dictionary-encoded text (pyarrow's
    ``dictionary_encode``, a pandas ``category``); polars writes both (pyarrow, not installed
    here, writes the same Parquet types)."""
    path = tmp_path / f"log_{writer}.parquet"
    t = pl.Series("t", times, dtype=pl.String)
    if writer == "dictionary":
        t = t.cast(pl.Categorical)
    frame = pl.DataFrame([t, pl.Series("u", U), pl.Series("y", Y)])
    frame.write_parquet(path)
    return path


WRITERS = ["string", "dictionary"]


@pytest.mark.parametrize("writer", WRITERS)
@pytest.mark.parametrize(
    ("written", "offset_s"),
    [
        (lambda k: (START + dt.timedelta(seconds=0.1 * k)).isoformat(), 0.0),
        (lambda k: str(START + dt.timedelta(seconds=0.1 * k)), 0.0),
        (lambda k: (START + dt.timedelta(seconds=0.1 * k)).isoformat() + "+01:00", -3600.0),
    ],
    ids=["T", "space", "offset"],
)
def test_a_parquet_string_time_column_is_read_as_iso_8601(
    written: Any, offset_s: float, writer: str, tmp_path: Path
) -> None:
    """It was refused: "column 't' has type String, expected a number"."""
    log = iso_parquet(tmp_path, [written(k) for k in range(N)], writer)
    signals = load(log)
    np.testing.assert_array_equal(signals.outputs[:, 0], Y)
    np.testing.assert_allclose(signals.time - (UTC_START + offset_s), T, atol=1e-6)
    assert inspect_log(log)["time"]["start"] == pytest.approx(UTC_START + offset_s)


def test_a_parquet_iso_time_keeps_its_nanoseconds(tmp_path: Path) -> None:
    times = [f"2024-01-01T00:00:{k // 10:02d}.{(k % 10) * 100_000_000 + k:09d}" for k in range(N)]
    series = TableSource(iso_parquet(tmp_path, times, "string")).read(["y"]).numeric["y"]
    expected = int(UTC_START) * 10**9 + np.arange(N) * 100_000_000 + np.arange(N)
    np.testing.assert_array_equal(series.time_ns, expected)


@pytest.mark.parametrize("writer", WRITERS)
@pytest.mark.parametrize(
    ("bad", "words"),
    [
        ("2024-01-01 00:00:00.7", r"row 8, column 't': '2024-01-01 00:00:00\.7' is not a date"),
        ("2300-01-01T00:00:00", r"row 8, column 't': the date '2300-01-01 00:00:00' is beyond"),
        (None, r"row 8, column 't': empty time cell"),
    ],
)
def test_a_parquet_iso_time_column_with_an_odd_value_is_refused_naming_the_row(
    bad: str | None, words: str, writer: str, tmp_path: Path
) -> None:
    times: list[str | None] = [
        (START + dt.timedelta(seconds=0.1 * k)).isoformat() for k in range(N)
    ]
    times[7] = bad
    log = iso_parquet(tmp_path, times, writer)
    with pytest.raises(LogError, match=rf"^{re.escape(str(log))}, {words}"):
        load(log)


@pytest.mark.parametrize("first", ["0.0", "soon"])
def test_a_parquet_text_time_column_not_of_dates_is_refused(first: str, tmp_path: Path) -> None:
    times = [first, *(str(k / 10) for k in range(1, N))]
    log = iso_parquet(tmp_path, times, "string")
    with pytest.raises(
        LogError,
        match=rf"column 't' has type String, expected seconds as numbers or ISO 8601.*'{first}'",
    ):
        load(log)
