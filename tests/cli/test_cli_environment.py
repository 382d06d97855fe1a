"""Environment variables numba and polars read as numbers: a malformed one is one line, exit 2.

``NUMBA_NUM_THREADS=abc`` was reported as "numerical trouble" (numba's RuntimeWarning),
``=0`` as an "unexpected ValueError", and ``POLARS_MAX_THREADS=0`` ended in a polars panic.
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from hybridlog.environment import check_environment, numba_whole_numbers
from hybridlog.errors import OptionError
from tests.support.paths import SAMPLE_LOGS

Main = Callable[[list[str]], tuple[int, str]]
POLARS = "a whole number of threads from 1 to 1024 (polars starts them all at once)"


@pytest.mark.parametrize(
    ("name", "value", "expected"),
    [
        ("NUMBA_NUM_THREADS", "abc", "a whole number of threads, at least 1"),
        ("NUMBA_NUM_THREADS", "0", "a whole number of threads, at least 1"),
        ("NUMBA_OPT", "x", "an optimisation level 0, 1, 2, 3 or max"),
        ("NUMBA_DISABLE_JIT", "yes", "a whole number"),  # any setting numba reads with int
        ("NUMBA_ENABLE_AVX", "1.5", "a whole number"),
        ("POLARS_MAX_THREADS", "0", POLARS),
        ("POLARS_MAX_THREADS", "abc", POLARS),
        ("POLARS_MAX_THREADS", "-1", POLARS),
        ("POLARS_MAX_THREADS", "1025", POLARS),  # polars would start them all: minutes
        ("POLARS_MAX_THREADS", "100000", POLARS),
    ],
)
def test_a_malformed_setting_is_named_with_its_value(name: str, value: str, expected: str) -> None:
    with pytest.raises(OptionError) as err:
        check_environment({"PATH": "/bin", name: value})
    assert str(err.value) == (
        f"environment variable {name}='{value}': expected {expected}; "
        "unset it or give it such a value"
    )


@pytest.mark.parametrize(
    "settings",
    [
        {"NUMBA_NUM_THREADS": "2", "NUMBA_OPT": "max", "POLARS_MAX_THREADS": "+1"},
        {"NUMBA_DISABLE_JIT": " 0 ", "POLARS_MAX_THREADS": " 3 "},
        {"POLARS_MAX_THREADS": "1024"},
        # what no library reads as a number, or takes malformed as unset
        {"NUMBA_CACHE_DIR": "/nowhere", "NUMBA_THREADING_LAYER": "x", "NUMBA_NO_SUCH": "x"},
        {"OMP_NUM_THREADS": "abc", "OPENBLAS_NUM_THREADS": "abc", "TMPDIR": "/nowhere"},
    ],
)
def test_well_formed_and_unchecked_settings_pass(settings: dict[str, str]) -> None:
    check_environment(settings)


def test_numbas_table_is_what_numba_itself_refuses() -> None:
    """Read from numba's source, the table agrees with numba: a value it cannot parse warns."""
    names = numba_whole_numbers()
    assert {"NUMBA_DISABLE_JIT", "NUMBA_ENABLE_AVX", "NUMBA_NUM_THREADS", "NUMBA_DEBUG"} <= names
    assert "NUMBA_CACHE_DIR" not in names and "NUMBA_OPT" not in names
    probe = (
        "import warnings; warnings.simplefilter('error', RuntimeWarning)\n"
        "import numba.core.config\n"
    )
    run = subprocess.run(
        [sys.executable, "-c", probe],
        env={"PATH": "/bin:/usr/bin", "NUMBA_ENABLE_AVX": "x"},
        capture_output=True,
        text=True,
        check=False,
    )
    assert run.returncode != 0 and "NUMBA_ENABLE_AVX" in run.stderr


def test_the_command_refuses_before_any_work(
    hybridlog_main: Main, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("NUMBA_NUM_THREADS", "0")
    out = tmp_path / "out"
    log = str(SAMPLE_LOGS / "three_tank_hstf.csv")
    code, err = hybridlog_main(["analyze", log, "--model", "three_tank_hstf", "--out", str(out)])
    assert code == 2
    assert err == (
        "hybridlog: error: environment variable NUMBA_NUM_THREADS='0': expected a whole "
        "number of threads, at least 1; unset it or give it such a value\n"
    )
    assert not out.exists()
