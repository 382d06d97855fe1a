"""polars leaves ``SIGINT`` to Python in hybridlog's processes (``hybridlog/polars_import.py``).

Each case runs in a fresh interpreter (polars installs its handler once, when imported): a
table is sunk by polars' streaming engine from a Python source that sends the process
``SIGINT`` while the sink runs.  With polars' own handler in place, an ignored ``SIGINT``
aborted the sink after two of its forty batches, and a Ctrl-C raised ``KeyboardInterrupt``
twice (pola-rs/polars#23988).
"""

from __future__ import annotations

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
