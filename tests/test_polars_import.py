"""polars as hybridlog imports it (``hybridlog/polars_import.py``): ``SIGINT`` left to Python,
and given only paths whose text is the system's name.

Each ``SIGINT`` case runs in a fresh interpreter (polars installs its handler once, when
imported): a table is sunk by polars' streaming engine from a Python source that sends the process
``SIGINT`` while the sink runs.  With polars' own handler in place, an ignored ``SIGINT``
aborted the sink after two of its forty batches, and a Ctrl-C raised ``KeyboardInterrupt``
twice (pola-rs/polars#23988).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

SINK = """
import os, signal, sys, time
signal.signal(signal.SIGINT, {action})
from hybridlog.polars_import import pl, register_io_source

def frames(with_columns, predicate, n_rows, batch_size):
    for k in range({batches}):
        if k == 2:
            os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.005)
        yield pl.DataFrame({{"a": list(range(k * 1000, (k + 1) * 1000))}})

interrupts = 0
try:
    try:
        register_io_source(frames, schema=pl.Schema({{"a": pl.Int64}})).sink_csv(sys.argv[1])
    except KeyboardInterrupt:
        interrupts += 1
    for _ in range(100_000):  # where Python's own handler raises, if it has not yet
        pass
except KeyboardInterrupt:
    interrupts += 1
print(interrupts)
"""

BATCHES = 40


@pytest.mark.parametrize(
    ("action", "interrupts"),
    [("signal.SIG_IGN", 0), ("signal.default_int_handler", 1)],
    ids=["ignored", "default"],
)
def test_sigint_during_a_polars_sink_is_python_s_to_handle(
    tmp_path: Path, action: str, interrupts: int
) -> None:
    """An ignored SIGINT stays ignored; a Ctrl-C is one KeyboardInterrupt; the table is whole."""
    out = tmp_path / "table.csv"
    done = subprocess.run(
        [sys.executable, "-c", SINK.format(action=action, batches=BATCHES), str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""  # no panic of polars' threads
    assert int(done.stdout) == interrupts
    assert len(out.read_text().splitlines()) == 1 + 1000 * BATCHES


def test_the_main_thread_takes_sigint_back_after_a_thread_imported_polars() -> None:
    """polars first imported in a thread: take_back_sigint in the main thread restores Python's."""
    script = """
import ctypes, signal, threading
libc = ctypes.CDLL(None)
class Action(ctypes.Structure):
    _fields_ = [("handler", ctypes.c_void_p), ("mask", ctypes.c_ulong * 16),
                ("flags", ctypes.c_int), ("restorer", ctypes.c_void_p)]
def handler():
    action = Action()
    libc.sigaction(signal.SIGINT, None, ctypes.byref(action))
    return action.handler
python_s = handler()
thread = threading.Thread(target=lambda: __import__("hybridlog.polars_import"))
thread.start()
thread.join()
after_import = handler()
from hybridlog.polars_import import take_back_sigint
take_back_sigint()
print(after_import != python_s, handler() == python_s)
"""
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["True", "True"]


@pytest.mark.parametrize(
    ("name", "text"),
    [
        (b"r\xc3\xa9.parquet", "r\udcc3\udca9.parquet"),  # ré.parquet where names are ASCII
        (b"r\xff.parquet", "r\udcff.parquet"),  # a name that is not UTF-8
        (b"r\xc3\xa9.parquet", "ré.parquet"),  # UTF-8 mode: polars takes the path itself
    ],
    ids=["ascii-locale", "not-utf8", "utf8"],
)
def test_polars_reads_and_writes_the_file_the_path_names(
    tmp_path: Path, name: bytes, text: str
) -> None:
    """Under ``LC_ALL=C`` without UTF-8 mode Python reads ``ré.parquet`` as
    ``r\\udcc3\\udca9.parquet``, whose bytes are UTF-8: polars was given that text and failed
    with 'Object does not have a .write() method' (analyze, simulate, a Parquet log)."""
    from hybridlog.polars_import import pl, polars_file

    path = tmp_path / text
    assert os.fsencode(path) == os.fsencode(tmp_path) + b"/" + name  # the name the system has
    frame = pl.DataFrame({"a": [1.5, 2.5]})
    with polars_file(path, "wb") as target:
        frame.write_parquet(target)
    with polars_file(path, "rb") as source:
        assert pl.read_parquet(source).equals(frame)
    assert os.listdir(os.fsencode(tmp_path)) == [name]


def test_a_non_ascii_path_under_the_c_locale(tmp_path: Path) -> None:
    """The command, where Python reads names as ASCII (a cron job, a minimal container)."""
    folder = tmp_path / "é 日本 🚀"
    out = "é 日本 🚀/sim.parquet"
    folder.mkdir()
    environment = {**os.environ, "LC_ALL": "C", "PYTHONUTF8": "0", "PYTHONCOERCECLOCALE": "0"}
    environment["PYTHONPATH"] = str(ROOT)
    run = subprocess.run(
        [sys.executable, "-m", "hybridlog", "simulate", "three_tank_hstf", "--out", out],
        cwd=tmp_path,
        env=environment,
        capture_output=True,
        timeout=60,
    )
    assert (run.returncode, run.stderr) == (0, b"")
    assert run.stdout == f"wrote {out} (301 samples)\n".encode()
    assert (folder / "sim.parquet").stat().st_size > 0
