"""write_table: formats, exact float round trip, no overwrite, no half-written files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pytest

from hybridlog.errors import OptionError, OutputError
from hybridlog.io import write_table
from hybridlog.io.writers import Column


def test_csv_floats_round_trip_exactly(tmp_path: Path) -> None:
    rng = np.random.default_rng(11)
    x = rng.normal(size=20_000) * 10.0 ** rng.integers(-308, 308, size=20_000)
    x[:6] = [0.1, 1 / 3, 5e-324, -0.0, np.finfo(float).max, 0.30000000000000004]
    path = write_table(tmp_path / "x.csv", {"x": x})
    back = pl.read_csv(path, schema_overrides={"x": pl.Float64}).get_column("x").to_numpy()
    assert back.tobytes() == x.tobytes()
    assert "0.30000000000000004" in path.read_text()


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_round_trip_every_format(tmp_path: Path, suffix: str) -> None:
    columns: dict[str, Column] = {
        "t": np.array([0.0, 0.5]),
        "k": np.array([1, 2]),
        "mode": ["1", "valve_open"],
    }
    path = write_table(tmp_path / f"log{suffix}", columns)
    frame = pl.read_csv(path, infer_schema=False) if suffix == ".csv" else pl.read_parquet(path)
    assert frame.columns == ["t", "k", "mode"]
    assert frame.get_column("mode").to_list() == ["1", "valve_open"]
    assert [float(v) for v in frame.get_column("t").to_list()] == [0.0, 0.5]


def test_refuses_to_overwrite_unless_forced(tmp_path: Path) -> None:
    path = tmp_path / "log.csv"
    path.write_text("precious\n")
    # not hybridlog's: said so without --force too, which would not replace it either
    with pytest.raises(OutputError, match=r"log.csv: exists and hybridlog did not write it"):
        write_table(path, {"x": np.zeros(2)})
    assert path.read_text() == "precious\n"
    with pytest.raises(OutputError, match=r"log.csv: exists and hybridlog did not write it"):
        write_table(path, {"x": np.zeros(2)}, force=True)  # --force: only what it wrote
    assert path.read_text() == "precious\n"
    path.unlink()
    write_table(path, {"x": np.zeros(2)})
    write_table(path, {"y": np.zeros(2)}, force=True)
    assert path.read_text().startswith("y\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == [".log.csv.hybridlog", "log.csv"]


def test_failed_write_leaves_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(self: pl.DataFrame, file: object, **_: object) -> None:
        Path(str(file)).write_text("half a ta")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(pl.DataFrame, "write_csv", broken)
    with pytest.raises(OutputError, match="No space left"):
        write_table(tmp_path / "sub" / "log.csv", {"x": np.zeros(2)})
    assert list(tmp_path.iterdir()) == []  # not even the folder made for it


def test_creates_parent_directories(tmp_path: Path) -> None:
    path = write_table(tmp_path / "a" / "b" / "log.parquet", {"x": np.arange(3.0)})
    assert pl.read_parquet(path).get_column("x").to_list() == [0.0, 1.0, 2.0]


def test_bad_arguments(tmp_path: Path) -> None:
    with pytest.raises(OptionError, match=r"unsupported table format '.xlsx'.*\.csv, \.parquet"):
        write_table(tmp_path / "log.xlsx", {"x": np.zeros(2)})
    with pytest.raises(ValueError, match="expected 2"):
        write_table(tmp_path / "log.csv", {"x": np.zeros(2), "y": np.zeros(3)})
    with pytest.raises(ValueError, match="1-D"):
        write_table(tmp_path / "log.csv", {"x": np.zeros((2, 2))})
    assert list(tmp_path.iterdir()) == []
