"""Damaged logs of every format: a :class:`LogError` or a result, never another exception.

Each sample log (every format hybridlog reads, every bag storage, bare storage files) is
copied and damaged the way files get damaged -- cut off at several points, 64 bytes flipped
or zeroed at several offsets -- and then inspected and loaded at library level, as
``analyze``, ``compare``, ``batch`` and ``inspect`` do (MCAP files and bag folders also with
``--recover``).  Each call must either return or raise :class:`~hybridlog.errors.LogError`
(which the CLI prints as one line with exit code 2); any other exception is what a user
would see as a traceback.  The damaged file must not be changed by reading it.
"""

from __future__ import annotations

import hashlib
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hybridlog.errors import LogError
from hybridlog.io import ReadOptions, SignalSpec, inspect_log, load_signals
from hybridlog.model.loader import load_model
from tests.support.paths import SAMPLE_LOGS

SAMPLES = SAMPLE_LOGS

# name -> (sample to copy, file inside it to damage or "" for the sample itself)
LOGS: dict[str, tuple[str, str]] = {
    "csv": ("three_tank_hstf.csv", ""),
    "parquet": ("three_tank_hstf.parquet", ""),
    "mcap cdr": ("three_tank_hstf.mcap", ""),
    "mcap json": ("three_tank_hstf_json.mcap", ""),
    "mcap ros1": ("three_tank_hstf_ros1.mcap", ""),
    "ros1 bag": ("three_tank_hstf.bag", ""),
    "ros2 sqlite3 folder": ("three_tank_hstf_ros2", "three_tank_hstf_ros2.db3"),
    "ros2 mcap folder": ("three_tank_hstf_ros2mcap", "three_tank_hstf_ros2mcap.mcap"),
    "ros2 folder metadata": ("three_tank_hstf_ros2", "metadata.yaml"),
    "bare db3": ("three_tank_hstf_ros2/three_tank_hstf_ros2.db3", ""),
    "bare mcap (rosbags' writer)": ("three_tank_hstf_ros2mcap/three_tank_hstf_ros2mcap.mcap", ""),
}

CUTS = (0.02, 0.1, 0.5, 0.9, -1)  # fractions of the file kept; -1: all but the last byte
OFFSETS = (0.05, 0.25, 0.5, 0.75, 0.95)  # where 64 bytes are flipped or zeroed
WIDTH = 64


def truncate(fraction: float) -> Callable[[bytes], bytes]:
    return lambda data: data[:-1] if fraction < 0 else data[: int(len(data) * fraction)]


def overwrite(fraction: float, how: str) -> Callable[[bytes], bytes]:
    def damage(data: bytes) -> bytes:
        at = min(int(len(data) * fraction), max(len(data) - WIDTH, 0))
        chunk = data[at : at + WIDTH]
        new = bytes(b ^ 0xFF for b in chunk) if how == "flip" else bytes(len(chunk))
        return data[:at] + new + data[at + len(chunk) :]

    return damage


DAMAGES: dict[str, Callable[[bytes], bytes]] = {
    **{f"cut at {c:g}": truncate(c) for c in CUTS},
    **{f"flip 64 B at {f:g}": overwrite(f, "flip") for f in OFFSETS},
    **{f"zero 64 B at {f:g}": overwrite(f, "zero") for f in OFFSETS},
}


def damaged_copy(name: str, folder: Path, damage: Callable[[bytes], bytes]) -> tuple[Path, Path]:
    """The damaged log and the file in it that was damaged."""
    sample, inner = LOGS[name]
    source = SAMPLES / sample
    folder.mkdir(parents=True, exist_ok=True)
    log = folder / source.name
    if source.is_dir():
        shutil.copytree(source, log)
    else:
        shutil.copyfile(source, log)
    target = log / inner if inner else log
    target.write_bytes(damage(target.read_bytes()))
    return log, target


def read_every_way(log: Path) -> list[str]:
    """Inspect and load ``log``; what escaped as something other than a LogError."""
    model = load_model("three_tank_hstf")
    escaped: list[str] = []
    recover = [False, True] if log.suffix == ".mcap" else [False]  # bare MCAP only reads it
    calls: list[Callable[[], object]] = [lambda: inspect_log(log)]
    for flag in recover:
        calls.append(
            lambda flag=flag: load_signals(  # type: ignore[misc]
                log, SignalSpec.of(model), ReadOptions(recover=flag)
            )
        )
    for call in calls:
        try:
            call()
        except LogError as err:
            assert "\n" not in str(err), str(err)
        except Exception as err:
            escaped.append(f"{type(err).__name__}: {str(err)[:200]}")
    return escaped


def check(name: str, folder: Path, damage: Callable[[bytes], bytes]) -> list[str]:
    log, target = damaged_copy(name, folder, damage)
    before = hashlib.sha256(target.read_bytes()).hexdigest()
    escaped = read_every_way(log)
    assert hashlib.sha256(target.read_bytes()).hexdigest() == before, "the log was changed"
    return escaped


@pytest.mark.parametrize("name", list(LOGS))
def test_damaged_logs_raise_log_errors_only(name: str, tmp_path: Path) -> None:
    failures = {}
    for number, (label, damage) in enumerate(DAMAGES.items()):
        escaped = check(name, tmp_path / str(number), damage)
        if escaped:
            failures[label] = escaped
    assert not failures, failures


@pytest.mark.parametrize("name", list(LOGS))
@settings(
    max_examples=8,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(
    offset=st.floats(0.0, 1.0),
    width=st.integers(1, 256),
    how=st.sampled_from(["flip", "zero", "cut"]),
)
def test_damage_anywhere_raises_log_errors_only(
    name: str, offset: float, width: int, how: str, tmp_path_factory: pytest.TempPathFactory
) -> None:
    def damage(data: bytes) -> bytes:
        at = int(offset * (len(data) - 1))
        if how == "cut":
            return data[:at]
        chunk = data[at : at + width]
        new = bytes(b ^ 0xFF for b in chunk) if how == "flip" else bytes(len(chunk))
        return data[:at] + new + data[at + len(chunk) :]

    assert check(name, tmp_path_factory.mktemp("damage"), damage) == []


@pytest.mark.parametrize("name", ["bare db3", "ros2 sqlite3 folder"])
def test_an_sqlite_bag_cut_by_one_byte_is_refused(name: str, tmp_path: Path) -> None:
    # SQLite reads the missing end of its last page as zeros: without the page count check
    # the last /u message's float64 lost its exponent byte and 20.0 was read as 1e-322.
    log, target = damaged_copy(name, tmp_path, truncate(-1))
    with pytest.raises(LogError) as error:
        inspect_log(log)
    assert str(error.value).startswith(
        f"{target}: damaged SQLite database: 135167 bytes where its header records 33 pages"
    )
